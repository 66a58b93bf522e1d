/* The conformance model of DESIGN.md §9 (see conform.h): §6's arithmetic in binary64 interval arithmetic, each
 * binary32 operation's result widened by its rounding error, division and reciprocal by 2.5 ulp. Interval endpoints
 * computed in binary64 are themselves moved outward by a little more than a binary64 rounding (dn / up), so every
 * enclosure is rigorous; the widening that matters is binary32's, 2^29 times larger. */
#include "conform.h"

#include "internal.h"

#include <math.h>
#include <stdlib.h>

#define U32 0x1p-24            /* binary32 unit roundoff: |fl(x) - x| <= U32 |x| for normal results */
#define ETA32 0x1p-150         /* ... and <= ETA32 for subnormal ones */
#define DIV_REL (2.5 * 0x1p-23) /* 2.5 ulp: ulp(x) <= 2^-23 |x| for a normal x */
#define DIV_ABS (2.5 * 0x1p-149)
#define F32_ROUNDS_TO_INF 0x1.ffffffp127 /* the least magnitude that rounds to infinity */
#define CLAMP ((double)1e-20f) /* §2: |d| below it becomes +-1e-20f before 1 / d */

/* Outward moves covering one binary64 rounding (relative 2^-53, plus the subnormal step). */
static inline double dn(double x) { return isinf(x) ? x : x - (fabs(x) * 0x1p-50 + 0x1p-1070); }
static inline double up(double x) { return isinf(x) ? x : x + (fabs(x) * 0x1p-50 + 0x1p-1070); }

static inline cf_iv point(double x) { return (cf_iv){x, x}; }

static inline int is_point(cf_iv x) { return x.lo == x.hi; }

/* What a binary32 operation whose exact result lies in x may give. A point x (an exact result) gives its correctly
 * rounded value or, where the operation is a product fused into the next addition, x itself: the hull of both, so
 * exact zeros and values binary32 holds stay points. Otherwise x widened by the rounding error of its ends (rounding
 * is monotone), which contains the unrounded values too; infinite past the overflow threshold. */
static inline cf_iv f32(cf_iv x)
{
    if (is_point(x) && isfinite(x.lo)) {
        const double r = (double)(float)x.lo;
        if (isinf(r))
            return x.lo > 0 ? (cf_iv){x.lo, INFINITY} : (cf_iv){-INFINITY, x.lo};
        return r < x.lo ? (cf_iv){r, x.lo} : (cf_iv){x.lo, r};
    }
    const double el = fabs(x.lo) * U32, eh = fabs(x.hi) * U32;
    cf_iv r = {dn(x.lo - (el > ETA32 ? el : ETA32)), up(x.hi + (eh > ETA32 ? eh : ETA32))};
    if (r.hi >= F32_ROUNDS_TO_INF)
        r.hi = INFINITY;
    if (r.lo <= -F32_ROUNDS_TO_INF)
        r.lo = -INFINITY;
    return r;
}

/* Sums and products in binary64: exact points stay points (the error term of the operation is 0: TwoSum, or fma
 * for the product), anything else moves outward. */
static inline cf_iv add(cf_iv a, cf_iv b)
{
    if (is_point(a) && is_point(b)) {
        const double s = a.lo + b.lo, bb = s - a.lo, err = (a.lo - (s - bb)) + (b.lo - bb);
        if (err == 0.0 && isfinite(s))
            return (cf_iv){s, s};
    }
    return (cf_iv){dn(a.lo + b.lo), up(a.hi + b.hi)};
}

static inline cf_iv neg(cf_iv a) { return (cf_iv){-a.hi, -a.lo}; }
static inline cf_iv sub(cf_iv a, cf_iv b) { return add(a, neg(b)); }

/* An endpoint product; 0 * inf (a bound reached only in the limit) counts as 0. */
static inline double prod(double a, double b)
{
    const double p = a * b;
    return isnan(p) ? 0.0 : p;
}

static inline cf_iv mul(cf_iv a, cf_iv b)
{
    if (is_point(a) && is_point(b)) {
        const double p = prod(a.lo, b.lo);
        if (p == 0.0 || (isfinite(p) && fma(a.lo, b.lo, -p) == 0.0))
            return (cf_iv){p, p};
    }
    const double p[4] = {prod(a.lo, b.lo), prod(a.lo, b.hi), prod(a.hi, b.lo), prod(a.hi, b.hi)};
    double lo = p[0], hi = p[0];
    for (int k = 1; k < 4; k++) {
        lo = p[k] < lo ? p[k] : lo;
        hi = p[k] > hi ? p[k] : hi;
    }
    return (cf_iv){dn(lo), up(hi)};
}

/* binary32 operations of §6 */
static inline cf_iv fadd(cf_iv a, cf_iv b) { return f32(add(a, b)); }
static inline cf_iv fsub(cf_iv a, cf_iv b) { return f32(sub(a, b)); }
static inline cf_iv fmul(cf_iv a, cf_iv b) { return f32(mul(a, b)); }

/* 1 / x within 2.5 ulp; unbounded when x may be 0. */
static cf_iv frecip(cf_iv x)
{
    if (x.lo <= 0.0 && x.hi >= 0.0)
        return (cf_iv){-INFINITY, INFINITY};
    cf_iv r = {dn(1.0 / x.hi), up(1.0 / x.lo)};
    const double el = fabs(r.lo) * DIV_REL, eh = fabs(r.hi) * DIV_REL;
    r.lo = dn(r.lo - (el > DIV_ABS ? el : DIV_ABS));
    r.hi = up(r.hi + (eh > DIV_ABS ? eh : DIV_ABS));
    if (r.hi >= F32_ROUNDS_TO_INF)
        r.hi = INFINITY;
    if (r.lo <= -F32_ROUNDS_TO_INF)
        r.lo = -INFINITY;
    return r;
}

static inline cf_iv imin(cf_iv a, cf_iv b) { return (cf_iv){a.lo < b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi}; }
static inline cf_iv imax(cf_iv a, cf_iv b) { return (cf_iv){a.lo > b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi}; }

/* dot(a, b) = (a.x*b.x + a.y*b.y) + a.z*b.z; cross the textbook formula (§6). */
static cf_iv fdot(const cf_iv a[3], const cf_iv b[3])
{
    return fadd(fadd(fmul(a[0], b[0]), fmul(a[1], b[1])), fmul(a[2], b[2]));
}

static void fcross(const cf_iv a[3], const cf_iv b[3], cf_iv out[3])
{
    out[0] = fsub(fmul(a[1], b[2]), fmul(a[2], b[1]));
    out[1] = fsub(fmul(a[2], b[0]), fmul(a[0], b[2]));
    out[2] = fsub(fmul(a[0], b[1]), fmul(a[1], b[0]));
}

int cf_in(cf_iv iv, double x) { return x >= iv.lo && x <= iv.hi; }

/* §2's clamp, then 1 / d: a direction component that may be on either side of 0 gives the hull of both signs. */
static cf_iv inv_dir(cf_iv d)
{
    cf_iv c;
    if (d.lo >= 0.0)
        c = (cf_iv){d.lo > CLAMP ? d.lo : CLAMP, d.hi > CLAMP ? d.hi : CLAMP};
    else if (d.hi < 0.0)
        c = (cf_iv){d.lo < -CLAMP ? d.lo : -CLAMP, d.hi < -CLAMP ? d.hi : -CLAMP};
    else
        return (cf_iv){dn(-1.0 / CLAMP * (1 + DIV_REL)), up(1.0 / CLAMP * (1 + DIV_REL))};
    return frecip(c);
}

void cf_ray_world(const rto_wf_ray *ray, cf_ray *out)
{
    for (int a = 0; a < 3; a++) {
        out->o[a] = point(ray->origin[a]);
        out->d[a] = point(ray->dir[a]);
        out->inv[a] = inv_dir(out->d[a]);
    }
}

void cf_ray_object(const rto_mat34 *world_to_obj, const rto_wf_ray *ray, cf_ray *out)
{
    const float(*m)[4] = world_to_obj->m;
    for (int r = 0; r < 3; r++) {
        const cf_iv m0 = point(m[r][0]), m1 = point(m[r][1]), m2 = point(m[r][2]);
        const cf_iv x = point(ray->origin[0]), y = point(ray->origin[1]), z = point(ray->origin[2]);
        const cf_iv dx = point(ray->dir[0]), dy = point(ray->dir[1]), dz = point(ray->dir[2]);
        out->o[r] = fadd(fadd(fadd(fmul(m0, x), fmul(m1, y)), fmul(m2, z)), point(m[r][3]));
        out->d[r] = fadd(fadd(fmul(m0, dx), fmul(m1, dy)), fmul(m2, dz));
        out->inv[r] = inv_dir(out->d[r]);
    }
}

void cf_triangle(const float v0[3], const float v1[3], const float v2[3], const cf_ray *r, cf_tri *out)
{
    cf_iv e1[3], e2[3], s[3], p[3], q[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = fsub(point(v1[a]), point(v0[a]));
        e2[a] = fsub(point(v2[a]), point(v0[a]));
        s[a] = fsub(r->o[a], point(v0[a]));
    }
    fcross(r->d, e2, p);
    out->det = fdot(e1, p);
    const cf_iv inv = frecip(out->det);
    fcross(s, e1, q);
    out->u = fmul(fdot(s, p), inv);
    out->v = fmul(fdot(r->d, q), inv);
    out->t = fmul(fdot(e2, q), inv);
    out->uv = fadd(out->u, out->v);
}

static cf_outcome both(int certain, int never) { return never ? CF_NEVER : certain ? CF_CERTAIN : CF_POSSIBLE; }

cf_outcome cf_triangle_hit(const cf_tri *x, float t_min, float bound, uint32_t flags)
{
    const int cull_back = (flags & RTO_RAY_FLAG_CULL_BACK_FACING) != 0;
    const int cull_front = (flags & RTO_RAY_FLAG_CULL_FRONT_FACING) != 0;
    /* det == 0 is a miss; det < 0 is culled by CULL_BACK_FACING, det > 0 by CULL_FRONT_FACING */
    const int det_never = (x->det.lo == 0.0 && x->det.hi == 0.0) || (cull_back && x->det.hi <= 0.0) ||
                          (cull_front && x->det.lo >= 0.0) || (cull_back && cull_front);
    const int det_certain = (x->det.lo > 0.0 && !cull_front) || (x->det.hi < 0.0 && !cull_back);
    const int never = det_never || x->u.hi < 0.0 || x->v.hi < 0.0 || x->uv.lo > 1.0 || x->t.hi < (double)t_min ||
                      x->t.lo >= (double)bound;
    const int certain = det_certain && x->u.lo >= 0.0 && x->v.lo >= 0.0 && x->uv.hi <= 1.0 &&
                        x->t.lo >= (double)t_min && x->t.hi < (double)bound;
    return both(certain, never);
}

/* tNear = max(lo0, lo1, lo2, tMin) <= tFar = min(hi0, hi1, hi2, bound) holds exactly when every term of the max is
 * at most every term of the min. Comparing term by term keeps what interval arithmetic alone would lose: lo_a <= hi_a
 * always (the min and max of one pair, t0 == t1 for a box flat on axis a), whatever the intervals. */
cf_outcome cf_slab(const rto_aabb *box, const cf_ray *r, float t_min, float bound)
{
    const float bmin[3] = {box->min.x, box->min.y, box->min.z}, bmax[3] = {box->max.x, box->max.y, box->max.z};
    cf_iv lo[4], hi[4];
    for (int a = 0; a < 3; a++) {
        const cf_iv t0 = fmul(fsub(point(bmin[a]), r->o[a]), r->inv[a]);
        const cf_iv t1 = fmul(fsub(point(bmax[a]), r->o[a]), r->inv[a]);
        lo[a] = imin(t0, t1);
        hi[a] = imax(t0, t1);
    }
    lo[3] = point(t_min);
    hi[3] = point(bound);
    int certain = 1, never = 0;
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++) {
            if (a == b && a < 3)
                continue; /* lo_a <= hi_a always */
            certain &= lo[a].hi <= hi[b].lo;
            never |= lo[a].lo > hi[b].hi;
        }
    return both(certain, never);
}

rto_status cf_scene_init(cf_scene *cs, const rto_scene *scene, rto_msg *msg)
{
    cs->scene = scene;
    cs->instance_boxes = rto__alloc(scene->instance_count, sizeof *cs->instance_boxes);
    if (!cs->instance_boxes)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u instance boxes", scene->instance_count);
    /* rto_instance_aabb's bytes: its mesh's box through objToWorld, each mesh's box computed once */
    rto_aabb *mesh_boxes = rto__alloc(scene->mesh_count, sizeof *mesh_boxes);
    if (!mesh_boxes) {
        cf_scene_free(cs);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u mesh boxes", scene->mesh_count);
    }
    for (uint32_t m = 0; m < scene->mesh_count; m++)
        mesh_boxes[m] = rto_mesh_aabb(&scene->meshes[m]);
    for (uint32_t i = 0; i < scene->instance_count; i++)
        cs->instance_boxes[i] = scene->instances[i].blas < scene->mesh_count
                                    ? rto_aabb_transform(&scene->instances[i].obj_to_world,
                                                         &mesh_boxes[scene->instances[i].blas])
                                    : rto_instance_aabb(scene, i); /* the empty box */
    free(mesh_boxes);
    return RTO_OK;
}

void cf_scene_free(cf_scene *cs)
{
    free(cs->instance_boxes);
    cs->instance_boxes = NULL;
}

void cf_prim_eval(const cf_scene *cs, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, float bound, cf_prim *out)
{
    const rto_scene *sc = cs->scene;
    *out = (cf_prim){0};
    if (inst >= sc->instance_count || sc->instances[inst].blas >= sc->mesh_count ||
        prim >= sc->meshes[sc->instances[inst].blas].triangle_count)
        return;
    out->valid = 1;
    const rto_instance *in = &sc->instances[inst];
    const rto_mesh *mesh = &sc->meshes[in->blas];
    out->masked = !(in->mask & ray->cull_mask);
    cf_ray ro, rw;
    cf_ray_object(&in->world_to_obj, ray, &ro);
    const uint32_t *ix = &mesh->indices[3 * (size_t)prim];
    const float *p = mesh->positions;
    cf_triangle(&p[3 * (size_t)ix[0]], &p[3 * (size_t)ix[1]], &p[3 * (size_t)ix[2]], &ro, &out->tri);
    if (out->masked)
        return; /* hit and reached stay CF_NEVER */
    out->hit = cf_triangle_hit(&out->tri, ray->t_min, bound, ray->flags);
    cf_ray_world(ray, &rw);
    const rto_aabb tb = rto_mesh_triangle_aabb(mesh, prim);
    const cf_outcome a = cf_slab(&cs->instance_boxes[inst], &rw, ray->t_min, bound);
    const cf_outcome b = cf_slab(&tb, &ro, ray->t_min, bound);
    out->reached = a < b ? a : b;
}

int cf_must_find(const cf_prim *p)
{
    return p->valid && !p->masked && p->hit == CF_CERTAIN && p->reached == CF_CERTAIN;
}
