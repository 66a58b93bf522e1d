/* Private pieces of the tracer shared by its files (src/trace/), and the secondary rays' offset, which the frame
 * (frame/frame.c) uses too. Not installed; not exported. */
#ifndef RTO_TRACE_INTERNAL_H
#define RTO_TRACE_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* The tracer (trace/traverse.c) and its SIMD lanes (trace/lanes.c). */

/** Instruction-set paths of rto_trace. Every path runs §6 per ray and gives the same hit records and counters. */
typedef enum rto__trace_isa {
    RTO__TRACE_AUTO = 0,   /* scalar, or the lanes RTO_TRACE_ISA from the environment asks for (see resolve) */
    RTO__TRACE_SCALAR = 1, /* one ray at a time: the reference the lanes are tested against */
    RTO__TRACE_AVX2 = 2,   /* 8 lanes */
    RTO__TRACE_AVX512 = 3, /* 16 lanes (AVX-512 F, BW, DQ and VL) */
    RTO__TRACE_ISA_COUNT = 4
} rto__trace_isa;

/** "auto", "scalar", "avx2", "avx512". */
const char *rto__trace_isa_name(rto__trace_isa isa);
/** Whether this CPU (and build) can run the path; AUTO and SCALAR always can. */
int rto__trace_isa_supported(rto__trace_isa isa);
/** The path AUTO runs here: the scalar tracer, the faster on every ray set bench_trace measures on the machines of
 * docs/results/trace.md; with RTO_TRACE_ISA = avx2 or avx512, the widest lanes the CPU has up to that one. */
rto__trace_isa rto__trace_isa_resolve(void);
/** rto_trace on a chosen path (an unsupported one is refused: RTO_ERR_UNSUPPORTED). */
rto_status rto__trace_with(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                           rto__trace_isa isa, rto_hit_record *hits, rto_trace_counters *counters, rto_msg *msg);

/** A traversal stack entry: a node reference (its meaning depends on the tree) and the entry t of its box. */
typedef struct rto__trace_entry {
    uint32_t ref;
    float t;
} rto__trace_entry;

/** What every path of one rto_trace call reads. */
typedef struct rto__tracer {
    const rto_accel *accel;
    const rto_scene *scene;
    const rto_accel_tlas *tlas;
    size_t stack_cap; /* entries per stack: enough for the deepest tree */
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

/** rto_slab_test's body (§6), inlined into the traversal loops: the same binary32 operations in the same order. */
static inline int rto__slab(const float bmin[3], const float bmax[3], const float origin[3], const float inv_dir[3],
                            float t_min, float best_t, float *t_entry)
{
    float lo[3], hi[3];
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

/** Whether the ray flags cull a triangle of this det (> 0 front, < 0 back; decided in object space, §6). */
int rto__triangle_culled(uint32_t flags, float det);
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
