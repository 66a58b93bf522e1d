/* Private pieces of the wavefront frame shared by its files (src/frame/). Not installed; not exported. */
#ifndef RTO_FRAME_INTERNAL_H
#define RTO_FRAME_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* ---------------------------------------------------------------------------------------------------------------- */
/* The frame (frame.c) and its programs (programs.c)                                                                */

/** The surface at a hit (rto_frame_api.surface) of a mesh scene; env->scene must not be NULL. */
void rto__surface_mesh(const rto_frame_env *env, const rto_wf_ray *ray, const rto_hit_record *hit, rto_surface *out);
/** rto_frame_api.sample_texture for a scene (NULL or a bad index: (1, 1, 1, 1)). */
void rto__texture_sample(const rto_scene *scene, int32_t texture, const float uv[2], float rgba[4]);
/** normalize(v) = v / length(v), length = sqrt((x*x + y*y) + z*z) in binary32 (DESIGN.md §7). */
void rto__normalize3(const float v[3], float out[3]);
/** Items per chunk of a GENERATE or TRACE + SHADE pass (default 2^18; the tests set others: the output never
 * depends on it). */
extern size_t rto__frame_chunk;
/** The 8-bit value of a resolved channel: clamp to [0, 1], round(x * 255) half up; NaN gives 0. */
uint8_t rto__unorm8(float x);
/** The kept stages as --stages spells them ("rays,hits,accum", "none"): the manifest's frame.stages. */
void rto__frame_keep_text(uint32_t keep, char *text, size_t cap);

/* ---------------------------------------------------------------------------------------------------------------- */
/* The stage2 scene (stage2.c): seed 002's analytic primitives                                                       */

/** Primitives of the stage2 scene, in traceScene's order: a hit record's instanceId and customIndex. */
#define RTO_STAGE2_PRIMITIVES 4u

/**
 * The seed's normal of a stage2 hit (intersectSphere / intersectBox of seed 002 §2.3) in binary32: position =
 * origin + t * dir per component; a sphere gives normalize(position - center); a box gives normalize(f32(|p.c| >
 * d.c - 0.001) * sign(p.c)) per component with p = position - center, d the half extents. normalize(v) is v / length(v)
 * (DESIGN.md §7), so a box hit whose position is further than 0.001 inside every face (possible only when rounding
 * moves the position: an origin or t far out of scale) has the zero vector and gets NaN, as that formula gives on a
 * GPU. sign(0) = 0 (WGSL). A miss record (or an instanceId past the primitives) gives NaN.
 */
void rto__stage2_normal(const rto_wf_ray *ray, const rto_hit_record *hit, float n[3]);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
