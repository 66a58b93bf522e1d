/* The stage2 scene (seed 002 §2.3): two spheres, a box and the ground slab of the seed's traceScene, intersected with
 * the seed's own intersectSphere / intersectBox, operation by operation in binary32, so the hit a GPU running that
 * WGSL finds is the hit this file finds (DESIGN.md §2: built with -ffp-contract=off, as WGSL without fused
 * multiply-adds).
 *
 * Transliteration rules (docs/frame.md, "The stage2 scene"):
 * - every WGSL expression keeps its evaluation order: `b * b - 4.0 * a * c` is (b*b) - ((4*a)*c), `center -
 *   halfExtents - ray.origin` is ((center - halfExtents) - origin), dot(a, b) is (a.x*b.x + a.y*b.y) + a.z*b.z;
 * - WGSL min / max on vec3 are rto__minf / rto__maxf per component (a < b ? a : b, a > b ? a : b): the same result as
 *   any min / max for numbers, and a fixed choice for NaN, which WGSL leaves to the implementation;
 * - `1.0 / ray.direction` is IEEE division per component: a zero component gives +-inf, as WGSL on real GPUs (the
 *   seed has no clamp; DESIGN.md §2's 1e-20 clamp is the triangle tracer's, not this scene's). A ray whose origin
 *   lies exactly on a slab plane with a zero direction component then computes 0 * inf = NaN for that slab, and the
 *   NaN rules above decide it;
 * - closest.t starts at 999999 (the seed's) and a hit must also have t < the ray's tMax; the ray's tMin is not used:
 *   the seed's 0.001 epsilon is its only lower bound. */
#include "frame_internal.h"
#include "internal.h"

#include <math.h>
#include <string.h>

/* The seed's hardcoded scene, in traceScene's order (the hit record's instanceId). */
typedef struct stage2_prim {
    int is_box;
    float center[3];
    float size[3]; /* sphere: the radius in [0]; box: the half extents */
} stage2_prim;

static const stage2_prim prims[RTO_STAGE2_PRIMITIVES] = {
    {0, {0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}},      /* sphere1 */
    {0, {2.5f, 0.0f, -1.0f}, {1.0f, 0.0f, 0.0f}},     /* sphere2 */
    {1, {-2.5f, 0.0f, 0.0f}, {0.75f, 0.75f, 0.75f}},  /* box1 */
    {1, {0.0f, -1.5f, 0.0f}, {10.0f, 0.5f, 10.0f}},   /* ground */
};

static float dot3(const float a[3], const float b[3]) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

/* WGSL normalize as DESIGN.md §7 defines it: v / length(v), length = sqrt(dot(v, v)). */
static void normalize3(const float v[3], float out[3])
{
    const float len = sqrtf(dot3(v, v));
    for (int a = 0; a < 3; a++)
        out[a] = v[a] / len;
}

/* WGSL sign: 1, 0 or -1 (0 for +-0; NaN gives 0 here, which WGSL does not define). */
static float sign_f(float x) { return x > 0.0f ? 1.0f : (x < 0.0f ? -1.0f : 0.0f); }

/* intersectSphere: 1 and *t_out for a hit. */
static int sphere_hit(const float o[3], const float d[3], const float center[3], float radius, float *t_out)
{
    float oc[3];
    for (int a = 0; a < 3; a++)
        oc[a] = o[a] - center[a];
    const float a = dot3(d, d);
    const float b = 2.0f * dot3(oc, d);
    const float c = dot3(oc, oc) - radius * radius;
    const float discriminant = b * b - 4.0f * a * c;
    if (discriminant < 0.0f)
        return 0;
    const float sqrt_d = sqrtf(discriminant);
    float t = (-b - sqrt_d) / (2.0f * a);
    if (t < 0.001f)
        t = (-b + sqrt_d) / (2.0f * a);
    if (t < 0.001f)
        return 0;
    /* A NaN t (a NaN discriminant) passes both tests as `hit` in the seed too; traceScene's `t < closest.t` then
     * rejects it. */
    *t_out = t;
    return 1;
}

/* intersectBox (the slab method): 1 and *t_out for a hit. */
static int box_hit(const float o[3], const float d[3], const float center[3], const float half[3], float *t_out)
{
    float t_min[3], t_max[3];
    for (int a = 0; a < 3; a++) {
        const float inv_dir = 1.0f / d[a];
        const float t0 = ((center[a] - half[a]) - o[a]) * inv_dir;
        const float t1 = ((center[a] + half[a]) - o[a]) * inv_dir;
        t_min[a] = rto__minf(t0, t1);
        t_max[a] = rto__maxf(t0, t1);
    }
    const float t_near = rto__maxf(rto__maxf(t_min[0], t_min[1]), t_min[2]);
    const float t_far = rto__minf(rto__minf(t_max[0], t_max[1]), t_max[2]);
    if (t_near > t_far || t_far < 0.0f)
        return 0;
    float t = t_near;
    if (t < 0.001f)
        t = t_far;
    if (t < 0.001f)
        return 0;
    *t_out = t;
    return 1;
}

static rto_hit_record miss_record(const rto_wf_ray *ray)
{
    rto_hit_record h;
    memset(&h, 0, sizeof h);
    h.t = ray->t_max;
    h.instance_id = h.prim_id = h.hit_group = h.custom_index = 0xFFFFFFFFu;
    h.miss_flag = 1;
    return h;
}

void rto_stage2_trace(const rto_wf_ray *rays, size_t n, rto_hit_record *hits)
{
    for (size_t i = 0; i < n; i++) {
        const rto_wf_ray *ray = &rays[i];
        /* traceScene: closest.t = 999999, then each primitive in order with `hit && t < closest.t`; the ray's tMax
         * bounds the hit as well. */
        float best = 999999.0f;
        uint32_t found = 0xFFFFFFFFu;
        for (uint32_t k = 0; k < RTO_STAGE2_PRIMITIVES; k++) {
            const stage2_prim *p = &prims[k];
            float t = 0.0f;
            const int hit = p->is_box ? box_hit(ray->origin, ray->dir, p->center, p->size, &t)
                                      : sphere_hit(ray->origin, ray->dir, p->center, p->size[0], &t);
            if (hit && t < best && t < ray->t_max) {
                best = t;
                found = k;
            }
        }
        if (found == 0xFFFFFFFFu) {
            hits[i] = miss_record(ray);
            continue;
        }
        rto_hit_record h;
        memset(&h, 0, sizeof h);
        h.t = best;
        h.instance_id = h.custom_index = found;
        h.prim_id = 0;
        h.hit_group = 0;
        /* objToWorld: the translation to the primitive's centre (column-major mat4x3, columns padded to 4). */
        for (int c = 0; c < 3; c++)
            h.obj_to_world[c][c] = 1.0f;
        for (int r = 0; r < 3; r++)
            h.obj_to_world[3][r] = prims[found].center[r];
        hits[i] = h;
    }
}

void rto__stage2_normal(const rto_wf_ray *ray, const rto_hit_record *hit, float n[3])
{
    if (hit->miss_flag || hit->instance_id >= RTO_STAGE2_PRIMITIVES) {
        n[0] = n[1] = n[2] = NAN;
        return;
    }
    const stage2_prim *prim = &prims[hit->instance_id];
    /* result.position = ray.origin + t * ray.direction */
    float pos[3], p[3];
    for (int a = 0; a < 3; a++) {
        pos[a] = ray->origin[a] + hit->t * ray->dir[a];
        p[a] = pos[a] - prim->center[a];
    }
    if (!prim->is_box) {
        normalize3(p, n);
        return;
    }
    /* The seed's face rule: every axis whose |p| is within 0.001 of the face counts, with its sign (an edge or corner
     * hit gives the normalised diagonal, as the seed's shader does). */
    float v[3];
    for (int a = 0; a < 3; a++)
        v[a] = (fabsf(p[a]) > prim->size[a] - 0.001f ? 1.0f : 0.0f) * sign_f(p[a]);
    normalize3(v, n);
}
