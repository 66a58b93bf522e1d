/* Private pieces of the tracer shared by its files (src/trace/), and the secondary rays' offset, which the frame
 * (frame/frame.c) uses too. Not installed; not exported. */
#ifndef RTO_TRACE_INTERNAL_H
#define RTO_TRACE_INTERNAL_H

#include "../core/internal.h"

#include <math.h>
#include <string.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* The tracer (trace/traverse.c) and its SIMD lanes (trace/lanes.c). */

/** Instruction-set paths of rto_trace. Every path runs §6 per ray and gives the same hit records and counters. */
typedef enum rto__trace_isa {
    RTO__TRACE_AUTO = 0,   /* the default path, or the one RTO_TRACE_ISA from the environment asks for (see resolve) */
    RTO__TRACE_SCALAR = 1, /* one ray at a time on the accel's own trees: the reference every other path is tested
                              against */
    RTO__TRACE_SSE2 = 2,   /* one ray at a time on the packed copy of the trees, both child boxes in one SSE2 test */
    RTO__TRACE_AVX2 = 3,   /* 8 lanes */
    RTO__TRACE_AVX512 = 4, /* 16 lanes (AVX-512 F, BW, DQ and VL) */
    RTO__TRACE_ISA_COUNT = 5
} rto__trace_isa;

/** "auto", "scalar", "sse2", "avx2", "avx512". */
const char *rto__trace_isa_name(rto__trace_isa isa);
/** Whether this CPU (and build) can run the path; AUTO and SCALAR always can. */
int rto__trace_isa_supported(rto__trace_isa isa);
/** The path AUTO runs here: sse2 (packed.c) where the build has it (x86-64), the fastest on every ray set
 * bench_trace measures on the machines of docs/results/trace.md, else scalar; RTO_TRACE_ISA = scalar, sse2, avx2 or
 * avx512 asks for that path, or the best the CPU has below it. */
rto__trace_isa rto__trace_isa_resolve(void);

/** rto_trace on a chosen path (an unsupported one is refused: RTO_ERR_UNSUPPORTED). */
rto_status rto__trace_with(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                           rto__trace_isa isa, rto_hit_record *hits, rto_trace_counters *counters, rto_msg *msg);

/** A traversal stack entry: a node reference (its meaning depends on the tree) and the entry t of its box. */
typedef struct rto__trace_entry {
    uint32_t ref;
    float t;
} rto__trace_entry;

/** The order in which the packed path (trace/packed.c) walks a worker's rays. Each ray's walk is the same in every
 * order, node for node, and so are the bytes: the order only decides the speed. */
typedef enum rto__trace_order {
    RTO__ORDER_AUTO = 0,    /* as rto__trace_packed_order says */
    RTO__ORDER_ONE = 1,     /* one ray at a time, each to its end */
    RTO__ORDER_IN_TURN = 2, /* RTO__TRACE_PACKED_STREAMS rays in flight, one node of each in turn */
    RTO__ORDER_GROUPS_8 = 3, /* 8 neighbouring rays walking together (AVX2) */
    RTO__ORDER_GROUPS_16 = 4 /* 16 (AVX-512) */
} rto__trace_order;

/** Rays the packed path keeps in flight in turn. */
#define RTO__TRACE_PACKED_STREAMS 8
/** Packed trees of more bytes than this (a core's L2 cache on the machines of docs/results/trace.md, or more) take
 * diverging rays in turn. */
#define RTO__TRACE_PACKED_CACHE ((size_t)2 << 20)

/** rto__trace_with with the packed path's order chosen too (ignored by the other paths). */
rto_status rto__trace_with_order(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                                 rto__trace_isa isa, rto__trace_order order, rto_hit_record *hits,
                                 rto_trace_counters *counters, rto_msg *msg);

/** What every path of one rto_trace call reads. */
typedef struct rto__tracer {
    const rto_accel *accel;
    const rto_scene *scene;
    const rto_accel_tlas *tlas;
    size_t stack_cap;        /* entries per stack: enough for the deepest tree */
    rto__trace_order order;  /* the packed path's */
} rto__tracer;

/** A lane kernel: rays [begin, end) in W lanes, each lane one ray running §6 with its own stacks; a lane that
 * finishes takes the next ray. scratch holds scratch_size(stack_cap) bytes, 64-byte aligned. */
typedef struct rto__trace_lanes {
    size_t (*scratch_size)(size_t stack_cap);
    void (*trace)(const rto__tracer *tr, const rto_wf_ray *rays, size_t begin, size_t end, rto_hit_record *hits,
                  rto_trace_counters *counters, void *scratch);
} rto__trace_lanes;
/** The lane kernel of a path (trace/lanes.c), NULL when the build has none. */
const rto__trace_lanes *rto__trace_lanes_kernel(rto__trace_isa isa);

/** Whether the build has the packed path (trace/packed.c: x86-64). */
int rto__trace_packed_built(void);
/** The packed copy of an accel's trees, made on first use (make) and kept with the accel; NULL when it cannot be made
 * (out of memory, a tree beyond 31-bit references) or the build has no packed path: then the scalar tracer runs.
 * make 0: the copy if it was made, else NULL. */
const void *rto__trace_packed_trees(const rto_accel *accel, int make);
/** Whether n rays traced on this many threads pay for making the packed copy: n >= threads * the slots it holds
 * (making it costs about what tracing one ray costs per slot, and one thread makes it). */
int rto__trace_packed_worth(const rto_accel *accel, uint64_t n, uint32_t threads);
/** The packed path's order for rays [begin, end), left to choose: where more than a quarter of neighbouring rays (up
 * to 1024 pairs looked at) point more than 60 degrees apart, rays in turn if its trees (tree_bytes) are larger than
 * RTO__TRACE_PACKED_CACHE, else one at a time (nothing to wait for); where they are alike, groups of 16 on a CPU with
 * AVX-512, of 8 on one with AVX2, else one at a time (the branch predictor learns their walk). docs/trace.md,
 * "Paths", gives the figures. */
rto__trace_order rto__trace_packed_order(size_t tree_bytes, const rto_wf_ray *rays, size_t begin, size_t end);
/** The bytes of a packed copy's slots (64 per internal node and per BLAS triangle). */
size_t rto__trace_packed_bytes(const void *trees);
/** The scratch bytes a worker of the packed path needs (its stacks, in any order). */
size_t rto__trace_packed_scratch(size_t stack_cap);
/** Whether this CPU runs the packed path in this order (groups of 8 need AVX2, of 16 AVX-512). */
int rto__trace_packed_order_supported(rto__trace_order order);
/** Rays [begin, end) on the packed trees in tr->order; stacks holds rto__trace_packed_scratch(tr->stack_cap)
 * bytes. */
void rto__trace_packed(const rto__tracer *tr, const void *trees, const rto_wf_ray *rays, size_t begin, size_t end,
                       rto_hit_record *hits, rto_trace_counters *counters, rto__trace_entry *stacks);

/** rto_slab_test's body (§6), inlined into the traversal loops: the same binary32 operations in the same order. */
static inline int rto__slab(const float bmin[3], const float bmax[3], const float origin[3], const float inv_dir[3],
                            float t_min, float best_t, float *t_entry)
{
    float lo[3], hi[3];
#pragma GCC unroll 3
    for (int a = 0; a < 3; a++) {
        const float t0 = (bmin[a] - origin[a]) * inv_dir[a];
        const float t1 = (bmax[a] - origin[a]) * inv_dir[a];
        lo[a] = rto__minf(t0, t1);
        hi[a] = rto__maxf(t0, t1);
    }
    const float t_near = rto__maxf(rto__maxf(rto__maxf(lo[0], lo[1]), lo[2]), t_min);
    const float t_far = rto__minf(rto__minf(rto__minf(hi[0], hi[1]), hi[2]), best_t);
    *t_entry = t_near;
    return t_near <= t_far;
}

/* The intersection pieces of §6 (trace/intersect.c exports them as rto_ray_inv_dir, rto_triangle_intersect and
 * rto_ray_to_object), inlined into the traversal loops. Every product, sum and comparison is one binary32 operation
 * in the contract's order (-ffp-contract=off keeps them apart). */

/* dot(a, b) = (a.x*b.x + a.y*b.y) + a.z*b.z; cross is the textbook formula. */
static inline float rto__dot3(const float a[3], const float b[3])
{
    return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];
}

static inline void rto__cross3(const float a[3], const float b[3], float out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline void rto__sub3(const float a[3], const float b[3], float out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline void rto__ray_inv_dir(const float dir[3], float inv_dir[3])
{
    for (int a = 0; a < 3; a++) {
        float d = dir[a];
        /* §2: no slab test may compute 0 * inf. +-0 becomes +1e-20 (the sign of a zero says nothing about which
         * side the ray leaves), any other tiny component keeps its sign. */
        if (fabsf(d) < 1e-20f)
            d = d < 0.0f ? -1e-20f : 1e-20f;
        inv_dir[a] = 1.0f / d;
    }
}

static inline int rto__triangle_intersect(const float v0[3], const float v1[3], const float v2[3],
                                          const float origin[3], const float dir[3], float t_min, float best_t,
                                          rto_tri_hit *hit)
{
    rto_tri_hit h = {0.0f, 0.0f, 0.0f, 0.0f};
    float e1[3], e2[3], p[3], s[3], q[3];
    rto__sub3(v1, v0, e1);
    rto__sub3(v2, v0, e2);
    rto__cross3(dir, e2, p);
    h.det = rto__dot3(e1, p);
    int ok = 0;
    if (h.det != 0.0f) {
        const float inv = 1.0f / h.det;
        rto__sub3(origin, v0, s);
        rto__cross3(s, e1, q);
        h.u = rto__dot3(s, p) * inv;
        h.v = rto__dot3(dir, q) * inv;
        h.t = rto__dot3(e2, q) * inv;
        ok = h.u >= 0.0f && h.v >= 0.0f && h.u + h.v <= 1.0f && t_min <= h.t && h.t < best_t;
    }
    if (hit)
        *hit = h;
    return ok;
}

static inline void rto__ray_to_object(const rto_mat34 *world_to_obj, const float origin[3], const float dir[3],
                                      float obj_origin[3], float obj_dir[3])
{
    const float(*m)[4] = world_to_obj->m;
    for (int r = 0; r < 3; r++) {
        obj_origin[r] = ((m[r][0] * origin[0] + m[r][1] * origin[1]) + m[r][2] * origin[2]) + m[r][3];
        obj_dir[r] = (m[r][0] * dir[0] + m[r][1] * dir[1]) + m[r][2] * dir[2];
    }
}

/** rto_hit_record_make's record, written field by field into *h (every byte: the record has no padding of its own).
 * Inlined into the tracer's loops, which write straight into the caller's array: a record built on the stack and
 * copied out waits on the stores of its fields. */
static inline void rto__hit_record_store(rto_hit_record *h, const rto_instance *instance, uint32_t inst, uint32_t prim,
                                         const rto_tri_hit *hit)
{
    h->t = hit->t;
    h->instance_id = inst;
    h->prim_id = prim;
    h->hit_group = instance->sbt_offset;
    h->bary[0] = hit->u;
    h->bary[1] = hit->v;
    h->custom_index = instance->custom_index;
    h->miss_flag = 0;
    /* WGSL mat4x3<f32>: column c holds row-major element [r][c] for r = 0..2, then one float of padding. */
    for (int c = 0; c < 4; c++) {
        for (int r = 0; r < 3; r++)
            h->obj_to_world[c][r] = instance->obj_to_world.m[r][c];
        h->obj_to_world[c][3] = 0.0f;
    }
}

/** rto_hit_record_miss's record, written field by field into *h. */
static inline void rto__hit_record_store_miss(rto_hit_record *h, float t_max)
{
    h->t = t_max;
    h->instance_id = UINT32_MAX;
    h->prim_id = UINT32_MAX;
    h->hit_group = UINT32_MAX;
    h->bary[0] = 0.0f;
    h->bary[1] = 0.0f;
    h->custom_index = UINT32_MAX;
    h->miss_flag = 1;
    memset(h->obj_to_world, 0, sizeof h->obj_to_world);
}

/** Whether the ray flags cull a triangle of this det (> 0 front, < 0 back; decided in object space, §6). */
int rto__triangle_culled(uint32_t flags, float det);
/** Möller–Trumbore of a triangle with an object-space ray, then culling: 1 for an accepted hit. */
static inline int rto__triangle_hit(const float v0[3], const float v1[3], const float v2[3], const float o[3],
                                    const float d[3], float t_min, float best_t, uint32_t flags, rto_tri_hit *hit)
{
    return rto__triangle_intersect(v0, v1, v2, o, d, t_min, best_t, hit) && !rto__triangle_culled(flags, hit->det);
}
/** Möller–Trumbore of triangle prim of a mesh with an object-space ray, then culling: 1 for an accepted hit. */
int rto__mesh_triangle_hit(const rto_mesh *mesh, uint32_t prim, const float o[3], const float d[3], float t_min,
                           float best_t, uint32_t flags, rto_tri_hit *hit);
/** Refuses rays that cannot be traced: non-finite origin, direction, tMin or tMax, or tMin > tMax. */
rto_status rto__rays_check(const rto_wf_ray *rays, size_t n, rto_msg *msg);
/**
 * rto_hits_check for primitives that are not triangles (check-frame's stage2 scene: seed 002's analytic spheres and
 * boxes), which the conformance model cannot re-intersect: each GPU record against the expected one field by field,
 * missFlag, instanceId, primId, customIndex, hitGroup and objToWorld exactly, t within 1e-5 max(1, |t|) and u, v
 * within 1e-4 (§9's fixed rules). The report is rto_hits_check's (fault classes, checks, facts, rows); instances and
 * meshes are not read and the expected records are taken as they are.
 */
rto_status rto__hits_check_records(const rto_hits_check_desc *desc, rto_report *report, rto_msg *msg);

/** The self-intersection offset of secondary rays (shadow rays, rto_frame_env.ray_offset): 1e-4 max(1, M), M the
 * largest finite magnitude among the bounds' coordinates and the camera position (trace/ray.c). */
float rto__ray_offset(const rto_aabb *bounds, const rto_camera_uniforms *u);

#if defined(__GNUC__)
/* trace/ray.c: a camera's checks and its binary64 view and OpenGL projection matrices (column-major); the general
 * 4x4 inverse by cofactors (0 for a singular or non-finite matrix). */
rto_status rto__camera_matrices(const rto_camera *camera, uint32_t width, uint32_t height, double view[16],
                                double proj[16], rto_msg *msg);
int rto__invert4(const double a[16], double out[16]);

#pragma GCC visibility pop
#endif

#endif
