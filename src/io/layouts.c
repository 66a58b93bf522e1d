/* The GPU structs of DESIGN.md §5-§7 as NumPy structured dtypes, and the file names and roles of a build bundle:
 * named once here, so the bundle writer, check-bvh and a GPU harness's dumps all agree. The C structs themselves
 * are in rtoracle.h, each with a static assertion of its size; test_layouts checks that every dtype's field offsets
 * equal the struct's. */
#include "internal.h"

#include <stdio.h>
#include <string.h>

static void field(rto_npy_desc *d, const char *name, rto_dtype t, uint32_t count)
{
    rto_npy_field *f = &d->fields[d->nfields];
    memset(f, 0, sizeof *f);
    strncpy(f->name, name, sizeof f->name - 1);
    f->type = t;
    f->count = count;
    /* Packed, in declaration order: every field of these structs is 4-byte aligned, so packing is the C layout. */
    f->offset = d->nfields ? d->fields[d->nfields - 1].offset +
                                 (uint32_t)rto_dtype_size(d->fields[d->nfields - 1].type) * d->fields[d->nfields - 1].count
                           : 0;
    d->nfields++;
}

rto_npy_desc rto_layout_desc(rto_layout layout, uint64_t n)
{
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_NONE, 1, n, 0, 0);
    d.dtype = RTO_DTYPE_STRUCT;
    switch (layout) {
    case RTO_LAYOUT_TLAS_NODE:
        field(&d, "min", RTO_DTYPE_F32, 3);
        field(&d, "item", RTO_DTYPE_U32, 1);
        field(&d, "max", RTO_DTYPE_F32, 3);
        field(&d, "pad", RTO_DTYPE_U32, 1);
        break;
    case RTO_LAYOUT_BLAS_NODE:
        field(&d, "lmin", RTO_DTYPE_F32, 3);
        field(&d, "left", RTO_DTYPE_U32, 1);
        field(&d, "lmax", RTO_DTYPE_F32, 3);
        field(&d, "right", RTO_DTYPE_U32, 1);
        field(&d, "rmin", RTO_DTYPE_F32, 3);
        field(&d, "parent", RTO_DTYPE_U32, 1);
        field(&d, "rmax", RTO_DTYPE_F32, 3);
        field(&d, "pad", RTO_DTYPE_U32, 1);
        break;
    case RTO_LAYOUT_AABB:
        field(&d, "min", RTO_DTYPE_F32, 3);
        field(&d, "max", RTO_DTYPE_F32, 3);
        break;
    case RTO_LAYOUT_INSTANCE:
        field(&d, "objToWorld", RTO_DTYPE_F32, 12);
        field(&d, "worldToObj", RTO_DTYPE_F32, 12);
        field(&d, "blas", RTO_DTYPE_U32, 1);
        field(&d, "customIndex", RTO_DTYPE_U32, 1);
        field(&d, "mask", RTO_DTYPE_U32, 1);
        field(&d, "sbtOffset", RTO_DTYPE_U32, 1);
        field(&d, "flags", RTO_DTYPE_U32, 1);
        field(&d, "pad", RTO_DTYPE_U32, 3);
        break;
    case RTO_LAYOUT_HIT_RECORD:
        field(&d, "t", RTO_DTYPE_F32, 1);
        field(&d, "instanceId", RTO_DTYPE_U32, 1);
        field(&d, "primId", RTO_DTYPE_U32, 1);
        field(&d, "hitGroup", RTO_DTYPE_U32, 1);
        field(&d, "bary", RTO_DTYPE_F32, 2);
        field(&d, "customIndex", RTO_DTYPE_U32, 1);
        field(&d, "missFlag", RTO_DTYPE_U32, 1);
        /* mat4x3<f32>: 4 columns of vec3, each padded to 16 bytes; a .npy field holds one flat count, so the
         * columns are 16 floats, column c at 4c (numpy: rec['objToWorld'].reshape(-1, 4, 4)[:, :, :3]). */
        field(&d, "objToWorld", RTO_DTYPE_F32, 16);
        break;
    case RTO_LAYOUT_WF_RAY:
        field(&d, "origin", RTO_DTYPE_F32, 3);
        field(&d, "tMin", RTO_DTYPE_F32, 1);
        field(&d, "dir", RTO_DTYPE_F32, 3);
        field(&d, "tMax", RTO_DTYPE_F32, 1);
        field(&d, "pixel", RTO_DTYPE_U32, 1);
        field(&d, "flags", RTO_DTYPE_U32, 1);
        field(&d, "cullMask", RTO_DTYPE_U32, 1);
        field(&d, "missIndex", RTO_DTYPE_U32, 1);
        field(&d, "sbtOffset", RTO_DTYPE_U32, 1);
        field(&d, "payloadSlot", RTO_DTYPE_U32, 1);
        field(&d, "kind", RTO_DTYPE_U32, 1);
        field(&d, "pad", RTO_DTYPE_U32, 1);
        break;
    case RTO_LAYOUT_TRACE_COUNTERS:
        field(&d, "nodesVisited", RTO_DTYPE_U32, 1);
        field(&d, "boxTests", RTO_DTYPE_U32, 1);
        field(&d, "triangleTests", RTO_DTYPE_U32, 1);
        field(&d, "instanceEntries", RTO_DTYPE_U32, 1);
        break;
    case RTO_LAYOUT_CAMERA:
        /* mat4x4<f32> column-major: element 4c + r is row r of column c. */
        field(&d, "inverseProjection", RTO_DTYPE_F32, 16);
        field(&d, "inverseView", RTO_DTYPE_F32, 16);
        field(&d, "position", RTO_DTYPE_F32, 3);
        field(&d, "pad", RTO_DTYPE_F32, 1);
        break;
    case RTO_LAYOUT_FRAME_COUNTERS:
        field(&d, "emitted", RTO_DTYPE_U32, 1);
        field(&d, "queued", RTO_DTYPE_U32, 1);
        field(&d, "dropped", RTO_DTYPE_U32, 1);
        field(&d, "refused", RTO_DTYPE_U32, 1);
        field(&d, "traced", RTO_DTYPE_U32, 1);
        field(&d, "hits", RTO_DTYPE_U32, 1);
        field(&d, "misses", RTO_DTYPE_U32, 1);
        field(&d, "shaded", RTO_DTYPE_U32, 1);
        field(&d, "accumulates", RTO_DTYPE_U32, 1);
        field(&d, "conflicts", RTO_DTYPE_U32, 1);
        break;
    default: break; /* unknown: a struct without fields, which rto_npy_write refuses */
    }
    return d;
}

const char *rto_layout_name(rto_layout layout)
{
    switch (layout) {
    case RTO_LAYOUT_TLAS_NODE: return "TlasNode";
    case RTO_LAYOUT_BLAS_NODE: return "BlasNode";
    case RTO_LAYOUT_AABB: return "Aabb";
    case RTO_LAYOUT_INSTANCE: return "InstanceRecord";
    case RTO_LAYOUT_HIT_RECORD: return "HitRecord";
    case RTO_LAYOUT_WF_RAY: return "WfRay";
    case RTO_LAYOUT_TRACE_COUNTERS: return "TraceCounters";
    case RTO_LAYOUT_CAMERA: return "CameraUniforms";
    case RTO_LAYOUT_FRAME_COUNTERS: return "FrameCounters";
    }
    return NULL;
}

size_t rto_layout_size(rto_layout layout)
{
    switch (layout) {
    case RTO_LAYOUT_TLAS_NODE: return sizeof(rto_tlas_node);
    case RTO_LAYOUT_BLAS_NODE: return sizeof(rto_bvh_node);
    case RTO_LAYOUT_AABB: return sizeof(rto_aabb);
    case RTO_LAYOUT_INSTANCE: return sizeof(rto_instance_record);
    case RTO_LAYOUT_HIT_RECORD: return sizeof(rto_hit_record);
    case RTO_LAYOUT_WF_RAY: return sizeof(rto_wf_ray);
    case RTO_LAYOUT_TRACE_COUNTERS: return sizeof(rto_trace_counters);
    case RTO_LAYOUT_CAMERA: return sizeof(rto_camera_uniforms);
    case RTO_LAYOUT_FRAME_COUNTERS: return sizeof(rto_frame_counters);
    }
    return 0;
}

/* A GPU dump is accepted as the structured dtype itself (field names may differ: only types, counts and offsets
 * must match), a 2-D uint32/float32 array of (count, words), or a flat uint32/float32 buffer of count * words. */
rto_status rto_layout_accept(rto_layout layout, const rto_npy *npy, size_t *count, rto_msg *msg)
{
    const char *name = rto_layout_name(layout);
    if (!name || !npy || !count)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown layout %d or NULL array", (int)layout);
    const size_t rec = rto_layout_size(layout), words = rec / 4;
    const rto_npy_desc *d = &npy->desc, want = rto_layout_desc(layout, 0);
    if (d->dtype == RTO_DTYPE_STRUCT) {
        int same = d->ndim == 1 && d->nfields == want.nfields;
        for (uint32_t i = 0; same && i < want.nfields; i++)
            same = d->fields[i].type == want.fields[i].type && d->fields[i].count == want.fields[i].count &&
                   d->fields[i].offset == want.fields[i].offset;
        if (!same)
            return rto__fail(msg, RTO_ERR_PARSE, "a structured dump must be 1-D with the %s layout (%zu bytes)", name,
                            rec);
        *count = (size_t)d->shape[0];
        return RTO_OK;
    }
    if (d->dtype != RTO_DTYPE_U32 && d->dtype != RTO_DTYPE_F32)
        return rto__fail(msg, RTO_ERR_PARSE, "expected %s records, a (count, %zu) or a flat uint32/float32 array", name,
                        words);
    if (d->ndim == 2 && d->shape[1] == words) {
        *count = (size_t)d->shape[0];
        return RTO_OK;
    }
    if (d->ndim == 1 && d->shape[0] % words == 0) {
        *count = (size_t)(d->shape[0] / words);
        return RTO_OK;
    }
    return rto__fail(msg, RTO_ERR_PARSE, "a raw %s dump must have shape (count, %zu) or a multiple of %zu words", name,
                    words, words);
}

rto_instance_record rto_instance_record_make(const rto_instance *in)
{
    rto_instance_record r;
    memset(&r, 0, sizeof r);
    memcpy(r.obj_to_world, in->obj_to_world.m, sizeof r.obj_to_world);
    memcpy(r.world_to_obj, in->world_to_obj.m, sizeof r.world_to_obj);
    r.blas = in->blas;
    r.custom_index = in->custom_index;
    r.mask = in->mask;
    r.sbt_offset = in->sbt_offset;
    r.flags = in->flags;
    return r;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Bundle files                                                                                                    */

static const struct {
    const char *pattern; /* printf pattern; per-BLAS (and per-bounce) names take the mesh (bounce) index */
    const char *role;
    int per_blas;
} files[RTO_BUNDLE_FILE_COUNT] = {
    [RTO_FILE_INSTANCES] = {"instances.npy", "instances", 0},
    [RTO_FILE_INSTANCE_AABBS] = {"instance_aabbs.npy", "instance-aabbs", 0},
    [RTO_FILE_TLAS_KEYS] = {"tlas_keys.npy", "tlas-keys", 0},
    [RTO_FILE_TLAS_SORTED_KEYS] = {"tlas_sorted_keys.npy", "tlas-sorted-keys", 0},
    [RTO_FILE_TLAS_NODES] = {"tlas_nodes.npy", "tlas-nodes", 0},
    [RTO_FILE_BLAS_SORTED_KEYS] = {"blas_%u_sorted_keys.npy", "blas-sorted-keys", 1},
    [RTO_FILE_BLAS_ORDER] = {"blas_%u_order.npy", "blas-order", 1},
    [RTO_FILE_BLAS_NODES] = {"blas_%u_nodes.npy", "blas-nodes", 1},
    [RTO_FILE_BLAS_PRIM_AABBS] = {"blas_%u_prim_aabbs.npy", "blas-prim-aabbs", 1},
    [RTO_FILE_MESH_POSITIONS] = {"mesh_%u_positions.npy", "mesh-positions", 1},
    [RTO_FILE_MESH_INDICES] = {"mesh_%u_indices.npy", "mesh-indices", 1},
    [RTO_FILE_RAYS] = {"rays.npy", "rays", 0},
    [RTO_FILE_HITS] = {"hits.npy", "hits", 0},
    [RTO_FILE_COUNTERS] = {"counters.npy", "counters", 0},
    [RTO_FILE_CAMERA] = {"camera.npy", "camera", 0},
    [RTO_FILE_BOUNCE_RAYS] = {"bounce_%u_rays.npy", "bounce-rays", 1},
    [RTO_FILE_BOUNCE_HITS] = {"bounce_%u_hits.npy", "bounce-hits", 1},
    [RTO_FILE_BOUNCE_TRACE_COUNTERS] = {"bounce_%u_trace_counters.npy", "bounce-trace-counters", 1},
    [RTO_FILE_BOUNCE_PAYLOADS] = {"bounce_%u_payloads.npy", "bounce-payloads", 1},
    [RTO_FILE_EMIT_COUNTS] = {"emit_counts.npy", "emit-counts", 0},
    [RTO_FILE_INDIRECT_ARGS] = {"indirect_args.npy", "indirect-args", 0},
    [RTO_FILE_FRAME_COUNTERS] = {"frame_counters.npy", "frame-counters", 0},
    [RTO_FILE_ACCUM] = {"accum.npy", "accum", 0},
    [RTO_FILE_ACCUM_EXR] = {"accum.exr", "accum-exr", 0},
    [RTO_FILE_IMAGE] = {"image.png", "image", 0},
    [RTO_FILE_NOT_COMPARABLE] = {"not_comparable.npy", "not-comparable", 0},
    [RTO_FILE_VB_CAMERA] = {"vb_camera.npy", "vb-camera", 0},
    [RTO_FILE_VB_VISIBILITY] = {"vb_visibility.npy", "vb-visibility", 0},
    [RTO_FILE_VB_BARYCENTRIC] = {"vb_barycentric.npy", "vb-barycentric", 0},
    [RTO_FILE_VB_NORMAL] = {"vb_normal.npy", "vb-normal", 0},
    [RTO_FILE_VB_DERIVATIVES] = {"vb_derivatives.npy", "vb-derivatives", 0},
    [RTO_FILE_VB_DEPTH] = {"vb_depth.npy", "vb-depth", 0},
    [RTO_FILE_VB_DEPTH_UNORM24] = {"vb_depth_unorm24.npy", "vb-depth-unorm24", 0},
    [RTO_FILE_VB_ADMISSIBLE_OFFSETS] = {"vb_admissible_offsets.npy", "vb-admissible-offsets", 0},
    [RTO_FILE_VB_ADMISSIBLE] = {"vb_admissible.npy", "vb-admissible", 0},
    [RTO_FILE_VB_EDGE_MASK] = {"vb_edge_mask.npy", "vb-edge-mask", 0},
    [RTO_FILE_VB_IMAGE] = {"vb_image.npy", "vb-image", 0},
    [RTO_FILE_VB_BASE_COLORS] = {"vb_base_colors.npy", "vb-base-colors", 0},
    [RTO_FILE_MESH_UVS] = {"mesh_%u_uvs.npy", "mesh-uvs", 1},
    [RTO_FILE_VB_MESH_TEXTURES] = {"vb_mesh_textures.npy", "vb-mesh-textures", 0},
    [RTO_FILE_VB_TEXTURES] = {"vb_textures.npy", "vb-textures", 0},
    [RTO_FILE_VB_TEXTURE] = {"vb_texture_%u.npy", "vb-texture", 1},
    [RTO_FILE_FLUID_PARAMS] = {"fluid_params.npy", "fluid-params", 0},
    [RTO_FILE_FLUID_PARTICLES] = {"particles.npy", "fluid-particles", 0},
    [RTO_FILE_FLUID_VOLUME_U32] = {"volume_u32.npy", "fluid-volume-u32", 0},
    [RTO_FILE_FLUID_VOLUME_F16] = {"volume_f16.npy", "fluid-volume-f16", 0},
    [RTO_FILE_FLUID_OCCUPANCY] = {"occupancy.npy", "fluid-occupancy", 0},
    [RTO_FILE_FLUID_OVERFLOW] = {"overflow.npy", "fluid-overflow", 0},
    [RTO_FILE_RM_PARAMS] = {"rm_params.npy", "rm-params", 0},
    [RTO_FILE_RM_IMAGE] = {"rm_image.npy", "rm-image", 0},
    [RTO_FILE_RM_CROSSING] = {"rm_crossing.npy", "rm-crossing", 0},
    [RTO_FILE_RM_CROSSING_T] = {"rm_crossing_t.npy", "rm-crossing-t", 0},
    [RTO_FILE_RM_NORMAL_CENTRAL] = {"rm_normal_central.npy", "rm-normal-central", 0},
    [RTO_FILE_RM_NORMAL_FORWARD] = {"rm_normal_forward.npy", "rm-normal-forward", 0},
    [RTO_FILE_RM_STEPS] = {"rm_steps.npy", "rm-steps", 0},
    [RTO_FILE_RM_STEPS_SKIP] = {"rm_steps_skip.npy", "rm-steps-skip", 0},
    [RTO_FILE_RM_CERTAIN] = {"rm_certain.npy", "rm-certain", 0},
    [RTO_FILE_RM_TOLERANCE] = {"rm_tolerance.npy", "rm-tolerance", 0},
    [RTO_FILE_RM_IMAGE_WALL] = {"rm_image_wall.npy", "rm-image-wall", 0},
    [RTO_FILE_RM_TOLERANCE_WALL] = {"rm_tolerance_wall.npy", "rm-tolerance-wall", 0},
};

static int known_file(rto_bundle_file f) { return (unsigned)f < RTO_BUNDLE_FILE_COUNT; }

rto_status rto_bundle_file_name(rto_bundle_file f, uint32_t mesh, char *name, size_t cap)
{
    if (!known_file(f) || !name)
        return RTO_ERR_INVALID_ARGUMENT;
    int len = files[f].per_blas ? snprintf(name, cap, files[f].pattern, mesh) : snprintf(name, cap, "%s", files[f].pattern);
    return len >= 0 && (size_t)len < cap ? RTO_OK : RTO_ERR_BUFFER_TOO_SMALL;
}

const char *rto_bundle_file_role(rto_bundle_file f) { return known_file(f) ? files[f].role : NULL; }
