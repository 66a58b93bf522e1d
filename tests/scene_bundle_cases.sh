# The scene a trace or frame bundle holds is read by one reader (rto_scene_bundle_read): check-hits and check-frame
# both feed it these cases and must refuse each with the same line. Sourced by cli_check_hits.sh and
# cli_check_frame.sh, which define `edited FILE OP...` (a fresh copy of their bundle of rtstress:2, FILE changed by
# bundle_edit with the manifest's sha256 rewritten) and `refused TEXT` (their command exits 2 with one line holding
# TEXT). Every case runs in the optimised build; under the sanitizers every third (cli_lib.sh's `sampled`).
scene_bundle_case_list=(
    "mesh_0_indices.npy as-u32|mesh_0_indices.npy: holds dtype <u4, shape (36,); expected dtype <u4, shape (12, 3)"
    "mesh_0_positions.npy as-u32|mesh_0_positions.npy: holds dtype <u4, shape (24,); expected dtype <f4, shape (N, 3)"
    "mesh_0_indices.npy set-u32 5 8|mesh_0_indices.npy: triangle 1 names vertex 8; the mesh has 8 vertices"
    "mesh_0_positions.npy set-f32 4 nan|mesh_0_positions.npy: a vertex position is not finite"
    "instances.npy set-u32 24 1|instances.npy: instance 0 names BLAS 1; the bundle has 1 meshes" # blas: word 24 of 32
    "instances.npy set-f32 3 inf|instances.npy: a transform of instance 0 is not finite"
    "instances.npy set-f32 15 nan|instances.npy: a transform of instance 0 is not finite" # worldToObj
    "instances.npy set-u32 25 0x1000000|instances.npy: instance 0 has customIndex 0x1000000 or mask 0x" # 24 bits
    "instances.npy set-u32 26 0x100|instances.npy: instance 0 has customIndex 0x" # mask past its 8 bits
    "instances.npy truncate 7|instances.npy: holds InstanceRecord records, shape (7,); expected InstanceRecord records, shape (8,)"
)
scene_bundle_cases() {
    local step i
    step=$(sampled 3)
    for ((i = 0; i < ${#scene_bundle_case_list[@]}; i += step)); do
        local edit=${scene_bundle_case_list[i]%%|*} text=${scene_bundle_case_list[i]#*|}
        # shellcheck disable=SC2086 # the edit is FILE OP ARGS, split on purpose
        edited $edit
        refused "$text"
    done
}
