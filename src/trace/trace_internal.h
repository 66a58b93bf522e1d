/* Private pieces of the tracer shared by its files (src/trace/), and the secondary rays' offset, which the frame
 * (frame/frame.c) uses too. Not installed; not exported. */
#ifndef RTO_TRACE_INTERNAL_H
#define RTO_TRACE_INTERNAL_H

#include "rtoracle.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

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
