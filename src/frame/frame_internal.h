/* Private to the frame stage (src/frame/): what frame.c, programs.c, stage2.c and check_frame.c share. */
#ifndef RTO_FRAME_INTERNAL_H
#define RTO_FRAME_INTERNAL_H

#include "../core/internal.h"

#pragma GCC visibility push(hidden)

/* ---- frame.c / programs.c ------------------------------------------------------------------------------------- */

/** The surface at a hit (rto_frame_api.surface) of a mesh scene; env->scene must not be NULL. */
void rto__surface_mesh(const rto_frame_env *env, const rto_wf_ray *ray, const rto_hit_record *hit, rto_surface *out);
/** rto_frame_api.sample_texture for a scene (NULL or a bad index: (1, 1, 1, 1)). */
void rto__texture_sample(const rto_scene *scene, int32_t texture, const float uv[2], float rgba[4]);
/** normalize(v) = v / length(v), length = sqrt((x*x + y*y) + z*z) in binary32 (DESIGN.md §7). */
void rto__normalize3(const float v[3], float out[3]);
/** The 8-bit value of a resolved channel: clamp to [0, 1], round(x * 255) half up; NaN gives 0. */
uint8_t rto__unorm8(float x);

/* ---- stage2.c ------------------------------------------------------------------------------------------------ */

/** The normal seed 002 shades a stage2 hit with (its intersectSphere / intersectBox normal rules). */
void rto__stage2_normal(const rto_wf_ray *ray, const rto_hit_record *hit, float n[3]);

#pragma GCC visibility pop

#endif
