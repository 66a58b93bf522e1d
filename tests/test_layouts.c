/* GPU layouts and bundle file names: each .npy dtype against its C struct (sizes and offsets from offsetof, field
 * names and types written out here from DESIGN.md §5-§7), dump acceptance, and the literal file names and roles. */
#include "testutil.h"

#include <unistd.h>

typedef struct want_field {
    const char *name;
    rto_dtype type;
    uint32_t count;
    size_t offset; /* offsetof in the C struct */
} want_field;

#define F(st, member, name, type, count) {name, type, count, offsetof(st, member)}

static const want_field tlas_node[] = {
    F(rto_tlas_node, min, "min", RTO_DTYPE_F32, 3), F(rto_tlas_node, item, "item", RTO_DTYPE_U32, 1),
    F(rto_tlas_node, max, "max", RTO_DTYPE_F32, 3), F(rto_tlas_node, pad, "pad", RTO_DTYPE_U32, 1)};
static const want_field blas_node[] = {
    F(rto_bvh_node, lmin, "lmin", RTO_DTYPE_F32, 3),     F(rto_bvh_node, left, "left", RTO_DTYPE_U32, 1),
    F(rto_bvh_node, lmax, "lmax", RTO_DTYPE_F32, 3),     F(rto_bvh_node, right, "right", RTO_DTYPE_U32, 1),
    F(rto_bvh_node, rmin, "rmin", RTO_DTYPE_F32, 3),     F(rto_bvh_node, parent, "parent", RTO_DTYPE_U32, 1),
    F(rto_bvh_node, rmax, "rmax", RTO_DTYPE_F32, 3),     F(rto_bvh_node, pad, "pad", RTO_DTYPE_U32, 1)};
static const want_field aabb[] = {F(rto_aabb, min, "min", RTO_DTYPE_F32, 3), F(rto_aabb, max, "max", RTO_DTYPE_F32, 3)};
static const want_field instance[] = {
    F(rto_instance_record, obj_to_world, "objToWorld", RTO_DTYPE_F32, 12),
    F(rto_instance_record, world_to_obj, "worldToObj", RTO_DTYPE_F32, 12),
    F(rto_instance_record, blas, "blas", RTO_DTYPE_U32, 1),
    F(rto_instance_record, custom_index, "customIndex", RTO_DTYPE_U32, 1),
    F(rto_instance_record, mask, "mask", RTO_DTYPE_U32, 1),
    F(rto_instance_record, sbt_offset, "sbtOffset", RTO_DTYPE_U32, 1),
    F(rto_instance_record, flags, "flags", RTO_DTYPE_U32, 1),
    F(rto_instance_record, pad, "pad", RTO_DTYPE_U32, 3)};
static const want_field hit[] = {
    F(rto_hit_record, t, "t", RTO_DTYPE_F32, 1),
    F(rto_hit_record, instance_id, "instanceId", RTO_DTYPE_U32, 1),
    F(rto_hit_record, prim_id, "primId", RTO_DTYPE_U32, 1),
    F(rto_hit_record, hit_group, "hitGroup", RTO_DTYPE_U32, 1),
    F(rto_hit_record, bary, "bary", RTO_DTYPE_F32, 2),
    F(rto_hit_record, custom_index, "customIndex", RTO_DTYPE_U32, 1),
    F(rto_hit_record, miss_flag, "missFlag", RTO_DTYPE_U32, 1),
    F(rto_hit_record, obj_to_world, "objToWorld", RTO_DTYPE_F32, 16)};
static const want_field ray[] = {
    F(rto_wf_ray, origin, "origin", RTO_DTYPE_F32, 3),       F(rto_wf_ray, t_min, "tMin", RTO_DTYPE_F32, 1),
    F(rto_wf_ray, dir, "dir", RTO_DTYPE_F32, 3),             F(rto_wf_ray, t_max, "tMax", RTO_DTYPE_F32, 1),
    F(rto_wf_ray, pixel, "pixel", RTO_DTYPE_U32, 1),         F(rto_wf_ray, flags, "flags", RTO_DTYPE_U32, 1),
    F(rto_wf_ray, cull_mask, "cullMask", RTO_DTYPE_U32, 1),  F(rto_wf_ray, miss_index, "missIndex", RTO_DTYPE_U32, 1),
    F(rto_wf_ray, sbt_offset, "sbtOffset", RTO_DTYPE_U32, 1), F(rto_wf_ray, payload_slot, "payloadSlot", RTO_DTYPE_U32, 1),
    F(rto_wf_ray, kind, "kind", RTO_DTYPE_U32, 1),           F(rto_wf_ray, pad, "pad", RTO_DTYPE_U32, 1)};
static const want_field counters[] = {
    F(rto_trace_counters, nodes_visited, "nodesVisited", RTO_DTYPE_U32, 1),
    F(rto_trace_counters, box_tests, "boxTests", RTO_DTYPE_U32, 1),
    F(rto_trace_counters, triangle_tests, "triangleTests", RTO_DTYPE_U32, 1),
    F(rto_trace_counters, instance_entries, "instanceEntries", RTO_DTYPE_U32, 1)};
static const want_field camera[] = {
    F(rto_camera_uniforms, inverse_projection, "inverseProjection", RTO_DTYPE_F32, 16),
    F(rto_camera_uniforms, inverse_view, "inverseView", RTO_DTYPE_F32, 16),
    F(rto_camera_uniforms, position, "position", RTO_DTYPE_F32, 3),
    F(rto_camera_uniforms, pad, "pad", RTO_DTYPE_F32, 1)};

/* DESIGN.md §7: ten u32 counters, packed. */
static const want_field frame_counters[] = {
    {"emitted", RTO_DTYPE_U32, 1, 0},      {"queued", RTO_DTYPE_U32, 1, 4},   {"dropped", RTO_DTYPE_U32, 1, 8},
    {"refused", RTO_DTYPE_U32, 1, 12},     {"traced", RTO_DTYPE_U32, 1, 16},  {"hits", RTO_DTYPE_U32, 1, 20},
    {"misses", RTO_DTYPE_U32, 1, 24},      {"shaded", RTO_DTYPE_U32, 1, 28},  {"accumulates", RTO_DTYPE_U32, 1, 32},
    {"conflicts", RTO_DTYPE_U32, 1, 36},
};

static const struct {
    rto_layout layout;
    const char *name;
    size_t size; /* DESIGN.md */
    size_t c_size;
    const want_field *fields;
    size_t nfields;
} layouts[] = {
    {RTO_LAYOUT_TLAS_NODE, "TlasNode", 32, sizeof(rto_tlas_node), tlas_node, 4},
    {RTO_LAYOUT_BLAS_NODE, "BlasNode", 64, sizeof(rto_bvh_node), blas_node, 8},
    {RTO_LAYOUT_AABB, "Aabb", 24, sizeof(rto_aabb), aabb, 2},
    {RTO_LAYOUT_INSTANCE, "InstanceRecord", 128, sizeof(rto_instance_record), instance, 8},
    {RTO_LAYOUT_HIT_RECORD, "HitRecord", 96, sizeof(rto_hit_record), hit, 8},
    {RTO_LAYOUT_WF_RAY, "WfRay", 64, sizeof(rto_wf_ray), ray, 12},
    {RTO_LAYOUT_TRACE_COUNTERS, "TraceCounters", 16, sizeof(rto_trace_counters), counters, 4},
    {RTO_LAYOUT_CAMERA, "CameraUniforms", 144, sizeof(rto_camera_uniforms), camera, 4},
    {RTO_LAYOUT_FRAME_COUNTERS, "FrameCounters", 40, sizeof(rto_frame_counters), frame_counters, 10},
};
#define NLAYOUTS (sizeof layouts / sizeof layouts[0])

static void test_dtypes_match_the_structs(void **state)
{
    (void)state;
    assert_int_equal(NLAYOUTS, RTO_LAYOUT_COUNT);
    for (size_t i = 0; i < NLAYOUTS; i++) {
        rto_npy_desc d = rto_layout_desc(layouts[i].layout, 5);
        assert_string_equal(rto_layout_name(layouts[i].layout), layouts[i].name);
        assert_int_equal(rto_layout_size(layouts[i].layout), layouts[i].size);
        assert_int_equal(layouts[i].c_size, layouts[i].size);
        assert_int_equal(rto_npy_itemsize(&d), layouts[i].size);
        assert_int_equal(d.dtype, RTO_DTYPE_STRUCT);
        assert_int_equal(d.ndim, 1);
        assert_int_equal(d.shape[0], 5);
        assert_int_equal(d.nfields, layouts[i].nfields);
        for (size_t f = 0; f < layouts[i].nfields; f++) {
            const want_field *w = &layouts[i].fields[f];
            if (strcmp(d.fields[f].name, w->name) || d.fields[f].type != w->type || d.fields[f].count != w->count ||
                d.fields[f].offset != w->offset)
                fail_msg("%s field %zu: %s type %d count %u offset %u, want %s type %d count %u offset %zu",
                         layouts[i].name, f, d.fields[f].name, (int)d.fields[f].type, d.fields[f].count,
                         d.fields[f].offset, w->name, (int)w->type, w->count, w->offset);
        }
    }
    assert_null(rto_layout_name((rto_layout)RTO_LAYOUT_COUNT));
    assert_int_equal(rto_layout_size((rto_layout)-1), 0);
    /* the descr a numpy reader sees for the two new structs */
    char descr[1024];
    rto_npy_desc d = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, 1);
    assert_int_equal(rto_npy_descr(&d, descr, sizeof descr), RTO_OK);
    assert_string_equal(descr, "[('t', '<f4'), ('instanceId', '<u4'), ('primId', '<u4'), ('hitGroup', '<u4'), "
                               "('bary', '<f4', (2,)), ('customIndex', '<u4'), ('missFlag', '<u4'), "
                               "('objToWorld', '<f4', (16,))]");
    d = rto_layout_desc(RTO_LAYOUT_WF_RAY, 1);
    assert_int_equal(rto_npy_descr(&d, descr, sizeof descr), RTO_OK);
    assert_string_equal(descr, "[('origin', '<f4', (3,)), ('tMin', '<f4'), ('dir', '<f4', (3,)), ('tMax', '<f4'), "
                               "('pixel', '<u4'), ('flags', '<u4'), ('cullMask', '<u4'), ('missIndex', '<u4'), "
                               "('sbtOffset', '<u4'), ('payloadSlot', '<u4'), ('kind', '<u4'), ('pad', '<u4')]");
}

/* A record written through its .npy dtype and read back lands in the C struct's fields. */
static void test_records_round_trip(void **state)
{
    (void)state;
    rto_hit_record h[2];
    memset(h, 0, sizeof h);
    h[1].t = 2.5f;
    h[1].instance_id = 7;
    h[1].prim_id = 9;
    h[1].hit_group = 3;
    h[1].bary[0] = 0.25f;
    h[1].bary[1] = 0.5f;
    h[1].custom_index = 0xABCDEF;
    h[1].obj_to_world[3][2] = -4.0f; /* translation z: column 3, row 2 */
    char path[] = "/tmp/rto_test_layouts_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    rto_npy_desc d = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, 2);
    assert_int_equal(rto_npy_write(path, &d, h, NULL), RTO_OK);
    rto_npy back = {0};
    assert_int_equal(rto_npy_read(path, &back, NULL), RTO_OK);
    size_t count = 0;
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &back, &count, NULL), RTO_OK);
    assert_int_equal(count, 2);
    assert_int_equal(back.nbytes, sizeof h);
    const float *words = back.data;
    assert_true(words[24 + 0] == 2.5f);              /* record 1 starts at word 24 */
    assert_int_equal(((const uint32_t *)words)[24 + 6], 0xABCDEF);
    assert_true(words[24 + 8 + 3 * 4 + 2] == -4.0f); /* objToWorld at byte 32, column 3 at 48 more */
    assert_memory_equal(back.data, h, sizeof h);
    rto_npy_free(&back);
    unlink(path);

    rto_instance in;
    memset(&in, 0, sizeof in);
    const double m[3][4] = {{1, 0, 0, 5}, {0, 2, 0, 6}, {0, 0, 4, 7}};
    assert_int_equal(rto_instance_set_transform(&in, m, NULL), RTO_OK);
    in.blas = 3;
    in.custom_index = 11;
    in.mask = 0x7F;
    in.sbt_offset = 2;
    in.flags = 1;
    rto_instance_record r = rto_instance_record_make(&in);
    assert_true(r.obj_to_world[1][3] == 6.0f && r.world_to_obj[2][2] == 0.25f && r.world_to_obj[0][3] == -5.0f);
    assert_int_equal(r.blas, 3);
    assert_int_equal(r.custom_index, 11);
    assert_int_equal(r.mask, 0x7F);
    assert_int_equal(r.sbt_offset, 2);
    assert_int_equal(r.flags, 1);
    assert_int_equal(r.pad[0] | r.pad[1] | r.pad[2], 0);
}

/* Dumps accepted as records, (count, words) or flat words; everything else refused with the layout named. */
static void test_accept_dump_shapes(void **state)
{
    (void)state;
    rto_npy npy;
    size_t count = 0;
    rto_msg msg = {{0}};
    memset(&npy, 0, sizeof npy);
    npy.desc = rto_layout_desc(RTO_LAYOUT_TLAS_NODE, 7);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_TLAS_NODE, &npy, &count, &msg), RTO_OK);
    assert_int_equal(count, 7);
    /* a struct of another layout */
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_WF_RAY, &npy, &count, &msg), RTO_ERR_PARSE);
    assert_non_null(strstr(msg.text, "WfRay"));
    /* a field renamed is still the same layout; a field moved is not */
    strcpy(npy.desc.fields[1].name, "instance");
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_TLAS_NODE, &npy, &count, &msg), RTO_OK);
    npy.desc.fields[1].type = RTO_DTYPE_I32;
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_TLAS_NODE, &npy, &count, &msg), RTO_ERR_PARSE);
    npy.desc = rto_npy_desc_array(RTO_DTYPE_U32, 2, 9, 24, 0);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &npy, &count, &msg), RTO_OK);
    assert_int_equal(count, 9);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_WF_RAY, &npy, &count, &msg), RTO_ERR_PARSE);
    npy.desc = rto_npy_desc_array(RTO_DTYPE_F32, 1, 48, 0, 0);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_WF_RAY, &npy, &count, &msg), RTO_OK);
    assert_int_equal(count, 3);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &npy, &count, &msg), RTO_OK);
    assert_int_equal(count, 2);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_INSTANCE, &npy, &count, &msg), RTO_ERR_PARSE);
    assert_non_null(strstr(msg.text, "InstanceRecord"));
    npy.desc = rto_npy_desc_array(RTO_DTYPE_U64, 1, 8, 0, 0);
    assert_int_equal(rto_layout_accept(RTO_LAYOUT_AABB, &npy, &count, &msg), RTO_ERR_PARSE);
    assert_int_equal(rto_layout_accept((rto_layout)99, &npy, &count, &msg), RTO_ERR_INVALID_ARGUMENT);
}

static void test_bundle_file_names(void **state)
{
    (void)state;
    static const struct {
        rto_bundle_file f;
        uint32_t mesh;
        const char *name, *role;
    } want[] = {
        {RTO_FILE_INSTANCES, 0, "instances.npy", "instances"},
        {RTO_FILE_INSTANCE_AABBS, 4, "instance_aabbs.npy", "instance-aabbs"},
        {RTO_FILE_TLAS_KEYS, 0, "tlas_keys.npy", "tlas-keys"},
        {RTO_FILE_TLAS_SORTED_KEYS, 0, "tlas_sorted_keys.npy", "tlas-sorted-keys"},
        {RTO_FILE_TLAS_NODES, 0, "tlas_nodes.npy", "tlas-nodes"},
        {RTO_FILE_BLAS_SORTED_KEYS, 3, "blas_3_sorted_keys.npy", "blas-sorted-keys"},
        {RTO_FILE_BLAS_ORDER, 0, "blas_0_order.npy", "blas-order"},
        {RTO_FILE_BLAS_NODES, 4294967295u, "blas_4294967295_nodes.npy", "blas-nodes"},
        {RTO_FILE_BLAS_PRIM_AABBS, 12, "blas_12_prim_aabbs.npy", "blas-prim-aabbs"},
        {RTO_FILE_MESH_POSITIONS, 2, "mesh_2_positions.npy", "mesh-positions"},
        {RTO_FILE_MESH_INDICES, 0, "mesh_0_indices.npy", "mesh-indices"},
        {RTO_FILE_RAYS, 7, "rays.npy", "rays"},
        {RTO_FILE_HITS, 0, "hits.npy", "hits"},
        {RTO_FILE_COUNTERS, 0, "counters.npy", "counters"},
        {RTO_FILE_CAMERA, 0, "camera.npy", "camera"},
        {RTO_FILE_BOUNCE_RAYS, 0, "bounce_0_rays.npy", "bounce-rays"},
        {RTO_FILE_BOUNCE_HITS, 1, "bounce_1_hits.npy", "bounce-hits"},
        {RTO_FILE_BOUNCE_TRACE_COUNTERS, 2, "bounce_2_trace_counters.npy", "bounce-trace-counters"},
        {RTO_FILE_BOUNCE_PAYLOADS, 0, "bounce_0_payloads.npy", "bounce-payloads"},
        {RTO_FILE_EMIT_COUNTS, 9, "emit_counts.npy", "emit-counts"},
        {RTO_FILE_INDIRECT_ARGS, 0, "indirect_args.npy", "indirect-args"},
        {RTO_FILE_FRAME_COUNTERS, 0, "frame_counters.npy", "frame-counters"},
        {RTO_FILE_ACCUM, 0, "accum.npy", "accum"},
        {RTO_FILE_ACCUM_EXR, 0, "accum.exr", "accum-exr"},
        {RTO_FILE_IMAGE, 0, "image.png", "image"},
        {RTO_FILE_NOT_COMPARABLE, 0, "not_comparable.npy", "not-comparable"},
        {RTO_FILE_VB_CAMERA, 0, "vb_camera.npy", "vb-camera"},
        {RTO_FILE_VB_VISIBILITY, 0, "vb_visibility.npy", "vb-visibility"},
        {RTO_FILE_VB_BARYCENTRIC, 0, "vb_barycentric.npy", "vb-barycentric"},
        {RTO_FILE_VB_NORMAL, 0, "vb_normal.npy", "vb-normal"},
        {RTO_FILE_VB_DERIVATIVES, 0, "vb_derivatives.npy", "vb-derivatives"},
        {RTO_FILE_VB_DEPTH, 0, "vb_depth.npy", "vb-depth"},
        {RTO_FILE_VB_DEPTH_UNORM24, 0, "vb_depth_unorm24.npy", "vb-depth-unorm24"},
        {RTO_FILE_VB_ADMISSIBLE_OFFSETS, 0, "vb_admissible_offsets.npy", "vb-admissible-offsets"},
        {RTO_FILE_VB_ADMISSIBLE, 0, "vb_admissible.npy", "vb-admissible"},
        {RTO_FILE_VB_EDGE_MASK, 0, "vb_edge_mask.npy", "vb-edge-mask"},
        {RTO_FILE_VB_IMAGE, 0, "vb_image.npy", "vb-image"},
        {RTO_FILE_VB_BASE_COLORS, 0, "vb_base_colors.npy", "vb-base-colors"},
        {RTO_FILE_MESH_UVS, 3, "mesh_3_uvs.npy", "mesh-uvs"},
        {RTO_FILE_VB_MESH_TEXTURES, 0, "vb_mesh_textures.npy", "vb-mesh-textures"},
        {RTO_FILE_VB_TEXTURES, 0, "vb_textures.npy", "vb-textures"},
        {RTO_FILE_VB_TEXTURE, 2, "vb_texture_2.npy", "vb-texture"},
        {RTO_FILE_FLUID_PARAMS, 0, "fluid_params.npy", "fluid-params"},
        {RTO_FILE_FLUID_PARTICLES, 0, "particles.npy", "fluid-particles"},
        {RTO_FILE_FLUID_VOLUME_U32, 0, "volume_u32.npy", "fluid-volume-u32"},
        {RTO_FILE_FLUID_VOLUME_F16, 0, "volume_f16.npy", "fluid-volume-f16"},
        {RTO_FILE_FLUID_OCCUPANCY, 0, "occupancy.npy", "fluid-occupancy"},
        {RTO_FILE_FLUID_OVERFLOW, 0, "overflow.npy", "fluid-overflow"},
        {RTO_FILE_RM_PARAMS, 0, "rm_params.npy", "rm-params"},
        {RTO_FILE_RM_IMAGE, 0, "rm_image.npy", "rm-image"},
        {RTO_FILE_RM_CROSSING, 0, "rm_crossing.npy", "rm-crossing"},
        {RTO_FILE_RM_CROSSING_T, 0, "rm_crossing_t.npy", "rm-crossing-t"},
        {RTO_FILE_RM_NORMAL_CENTRAL, 0, "rm_normal_central.npy", "rm-normal-central"},
        {RTO_FILE_RM_NORMAL_FORWARD, 0, "rm_normal_forward.npy", "rm-normal-forward"},
        {RTO_FILE_RM_STEPS, 0, "rm_steps.npy", "rm-steps"},
        {RTO_FILE_RM_STEPS_SKIP, 0, "rm_steps_skip.npy", "rm-steps-skip"},
        {RTO_FILE_RM_CERTAIN, 0, "rm_certain.npy", "rm-certain"},
        {RTO_FILE_RM_TOLERANCE, 0, "rm_tolerance.npy", "rm-tolerance"},
        {RTO_FILE_RM_IMAGE_WALL, 0, "rm_image_wall.npy", "rm-image-wall"},
        {RTO_FILE_RM_TOLERANCE_WALL, 0, "rm_tolerance_wall.npy", "rm-tolerance-wall"},
    };
    assert_int_equal(sizeof want / sizeof want[0], RTO_BUNDLE_FILE_COUNT);
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        assert_int_equal(rto_bundle_file_name(want[i].f, want[i].mesh, name, sizeof name), RTO_OK);
        assert_string_equal(name, want[i].name);
        assert_string_equal(rto_bundle_file_role(want[i].f), want[i].role);
    }
    /* the name and its NUL must fit: n - 1 bytes of room is too small, n is enough */
    size_t len = strlen("blas_12_prim_aabbs.npy");
    assert_int_equal(rto_bundle_file_name(RTO_FILE_BLAS_PRIM_AABBS, 12, name, len), RTO_ERR_BUFFER_TOO_SMALL);
    assert_int_equal(rto_bundle_file_name(RTO_FILE_BLAS_PRIM_AABBS, 12, name, len + 1), RTO_OK);
    assert_int_equal(rto_bundle_file_name((rto_bundle_file)RTO_BUNDLE_FILE_COUNT, 0, name, sizeof name),
                     RTO_ERR_INVALID_ARGUMENT);
    assert_null(rto_bundle_file_role((rto_bundle_file)RTO_BUNDLE_FILE_COUNT));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dtypes_match_the_structs),
        cmocka_unit_test(test_records_round_trip),
        cmocka_unit_test(test_accept_dump_shapes),
        cmocka_unit_test(test_bundle_file_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
