# The scene a trace or frame bundle holds is read by one reader (rto_scene_bundle_read): check-hits and check-frame
# both feed it these cases and must refuse each with the same line. Sourced by cli_check_hits.sh and
# cli_check_frame.sh, which define `edited FILE OP...` (a fresh copy of their bundle of rtstress:2, FILE changed by
# bundle_edit with the manifest's sha256 rewritten) and `refused TEXT` (their command exits 2 with one line holding
# TEXT).
scene_bundle_cases() {
    edited mesh_0_indices.npy as-u32
    refused "mesh_0_indices.npy: holds dtype <u4, shape (36,); expected dtype <u4, shape (12, 3)"
    edited mesh_0_positions.npy as-u32
    refused "mesh_0_positions.npy: holds dtype <u4, shape (24,); expected dtype <f4, shape (N, 3)"
    edited mesh_0_indices.npy set-u32 5 8
    refused "mesh_0_indices.npy: triangle 1 names vertex 8; the mesh has 8 vertices"
    edited mesh_0_positions.npy set-f32 4 nan
    refused "mesh_0_positions.npy: a vertex position is not finite"
    edited instances.npy set-u32 24 1 # instance 0's blas (word 24 of its 32)
    refused "instances.npy: instance 0 names BLAS 1; the bundle has 1 meshes"
    edited instances.npy set-f32 3 inf
    refused "instances.npy: a transform of instance 0 is not finite"
    edited instances.npy set-f32 15 nan # worldToObj
    refused "instances.npy: a transform of instance 0 is not finite"
    edited instances.npy set-u32 25 0x1000000 # customIndex past its 24 bits
    refused "instances.npy: instance 0 has customIndex 0x1000000 or mask 0x"
    edited instances.npy set-u32 26 0x100 # mask past its 8 bits
    refused "instances.npy: instance 0 has customIndex 0x"
    edited instances.npy truncate 7
    refused "instances.npy: holds InstanceRecord records, shape (7,); expected InstanceRecord records, shape (8,)"
}
