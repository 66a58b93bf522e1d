/* The conformance model of DESIGN.md §9: what a conforming GPU may compute when it runs §6. Every binary32 operation
 * of §6 is correctly rounded (round to nearest even), except that any a*b + c may be fused into one rounding, and
 * that division and reciprocal may be off by up to 2.5 ulp (WGSL's rule); nothing else. For one ray and one
 * primitive or box, the functions below enclose every value a conforming implementation may compute in an interval,
 * evaluated in binary64 with outward rounding (each binary32 operation's result widened by its rounding error, which
 * also covers the unrounded value of a fused product), and classify the outcome as certain, possible or impossible.
 *
 * Reaching a primitive: the slab test is monotone in the box's bounds for any one implementation (a correctly rounded
 * subtraction and product are monotone, and (b - o) * inv has no a*b + c to fuse), so a ray that one implementation's
 * slab test sends into a box is sent into every box that contains it: the TLAS and BLAS ancestors of a leaf. A
 * primitive is therefore certainly reached when the world ray certainly enters its instance's box (the TLAS leaf) and
 * the object-space ray certainly enters the triangle's box (the BLAS leaf), both within [tMin, bound]. */
#ifndef RTO_TRACE_CONFORM_H
#define RTO_TRACE_CONFORM_H

#include "rtoracle.h"

#include <stdint.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** A closed interval of reals (binary64 bounds); lo > hi never occurs. */
typedef struct cf_iv {
    double lo, hi;
} cf_iv;

/** An outcome under the model: no conforming implementation gets it, some may, all do. */
typedef enum cf_outcome { CF_NEVER = 0, CF_POSSIBLE = 1, CF_CERTAIN = 2 } cf_outcome;

/** A ray as a conforming implementation may hold it in one space: origin and direction (exact in world space,
 * intervals after an instance's worldToObj) and the reciprocal direction its slab tests use (§2's clamp, then 1 / d). */
typedef struct cf_ray {
    cf_iv o[3], d[3], inv[3];
} cf_ray;

/** Möller–Trumbore of one triangle under the model: det, u, v, u + v and t as intervals. */
typedef struct cf_tri {
    cf_iv det, u, v, uv, t;
} cf_tri;

/** The world-space ray (point intervals) and its reciprocal direction. */
void cf_ray_world(const rto_wf_ray *ray, cf_ray *out);
/** The object-space ray of an instance: o' = W2O (o, 1), d' = W2O (d, 0), rows ((m0 x + m1 y) + m2 z) + m3. */
void cf_ray_object(const rto_mat34 *world_to_obj, const rto_wf_ray *ray, cf_ray *out);
/** The triangle's intervals for a ray in its object space. */
void cf_triangle(const float v0[3], const float v1[3], const float v2[3], const cf_ray *r, cf_tri *out);
/** Whether a conforming implementation accepts the hit (u >= 0, v >= 0, u + v <= 1, tMin <= t < bound, det != 0, and
 * not culled by flags), and whether every one does. */
cf_outcome cf_triangle_hit(const cf_tri *tri, float t_min, float bound, uint32_t flags);
/** The slab test of a box (§6) within [tMin, bound]: whether the ray enters it. */
cf_outcome cf_slab(const rto_aabb *box, const cf_ray *r, float t_min, float bound);
/** Whether x lies in the interval. NaN never does. */
int cf_in(cf_iv iv, double x);

/** A scene as the model reads it: the scene and its instances' world boxes (the TLAS leaves, rto_instance_aabb). */
typedef struct cf_scene {
    const rto_scene *scene;
    rto_aabb *instance_boxes;
} cf_scene;

/** Computes the instance boxes; cf_scene_free releases them. */
rto_status cf_scene_init(cf_scene *cs, const rto_scene *scene, rto_msg *msg);
void cf_scene_free(cf_scene *cs);

/** One primitive of a scene for a ray under the model. */
typedef struct cf_prim {
    int valid;           /* the instance and triangle exist */
    int masked;          /* the instance's mask does not meet the ray's cull mask (never reached) */
    cf_tri tri;          /* the intervals of its Möller–Trumbore */
    cf_outcome hit;      /* hit within [tMin, bound] (bound as passed to cf_prim_eval), culling included */
    cf_outcome reached;  /* both leaf boxes entered within [tMin, bound] */
} cf_prim;

/** Evaluates triangle prim of instance inst for the ray, with bound the largest t a hit may have (exclusive). */
void cf_prim_eval(const cf_scene *cs, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, float bound, cf_prim *out);
/** Whether every conforming implementation must find the primitive at a t below bound, whatever order it traverses
 * in: reached and hit certainly, with bound as the largest t (so a record at bound or beyond cannot be its answer). */
int cf_must_find(const cf_prim *p);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
