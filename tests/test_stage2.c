/* The stage2 scene's tracer (rto_stage2_trace) and its normal rule (rto__stage2_normal) against seed 002's formulas
 * evaluated in binary64 here: for every ray, the nearest primitive and its t, and the normal at the binary64 hit
 * point. A ray whose answer depends on binary32 rounding is detected by the binary64 evaluation itself (a tangent
 * sphere ray, a ray grazing a box edge, a t next to the 0.001 epsilon or tMax, two primitives within 1e-4 of each
 * other, a box hit whose rounded position may fall either side of the face rule's 0.001 band) and checked only for
 * what is defined (a finite t and a primitive that does hit). Pinned cases with exact answers worked out by hand
 * cover the rules the random rays rarely reach: tMax, the epsilon, zero direction components, edges of the box. */
#include "testutil.h"

#include "frame/frame_internal.h"

#include <float.h>

/* The scene of seed 002's traceScene, written again here: centre, radius or half extents. */
static const struct {
    int is_box;
    double c[3], h[3];
} scene[4] = {
    {0, {0, 0, 0}, {1, 0, 0}},
    {0, {2.5, 0, -1}, {1, 0, 0}},
    {1, {-2.5, 0, 0}, {0.75, 0.75, 0.75}},
    {1, {0, -1.5, 0}, {10, 0.5, 10}},
};

/* What the binary64 evaluation says of one ray. */
typedef struct ref {
    int prim;      /* -1: miss */
    double t;      /* the hit's t */
    int ambiguous; /* binary32 rounding may decide the primitive or the hit / miss: check only what is defined */
    int box_band;  /* a box hit too near the face rule's band for rounding to decide: normal not checked */
    double n[3];   /* the seed's normal at the binary64 hit point */
} ref;

/* |a - b| <= rel max(1, |a|, |b|) for finite a and b (infinite slab bounds are never near anything). */
static int near_rel(double a, double b, double rel)
{
    return isfinite(a) && isfinite(b) && fabs(a - b) <= rel * fmax(1.0, fmax(fabs(a), fabs(b)));
}

/* intersectSphere in binary64. Returns 1 for a hit at *t. *amb is set when binary32 rounding could change the answer,
 * with *t_amb the t it would be decided at (the tangent point for a near-tangent miss). */
static int sphere64(const double o[3], const double d[3], const double c[3], double r, double *t, int *amb,
                    double *t_amb)
{
    double oc[3] = {o[0] - c[0], o[1] - c[1], o[2] - c[2]};
    const double a = tu_dot3(d, d), b = 2.0 * tu_dot3(oc, d), cc = tu_dot3(oc, oc) - r * r;
    const double disc = b * b - 4.0 * a * cc;
    /* Near a tangent t moves by err(disc) / (4 a sqrt(disc)): a binary32 discriminant (error a few ulp of b^2 +
     * 4|ac|) keeps t within 1e-5 only when disc is above ~1.5e-4 of that scale; twice that margin is taken. */
    if (fabs(disc) < 3e-4 * (b * b + 4.0 * fabs(a * cc))) {
        *amb = 1;
        *t_amb = -b / (2.0 * a);
    }
    if (disc < 0)
        return 0;
    const double s = sqrt(disc);
    const double t1 = (-b - s) / (2.0 * a), t2 = (-b + s) / (2.0 * a);
    if (near_rel(t1, 0.001, 1e-4) || near_rel(t2, 0.001, 1e-4)) {
        *amb = 1;
        *t_amb = fmin(*t_amb, 0.001);
    }
    *t = t1 < 0.001 ? t2 : t1;
    return *t >= 0.001;
}

/* intersectBox in binary64 (C's IEEE division gives the same infinities as the seed's 1 / direction); *amb and *t_amb
 * as sphere64's. */
static int box64(const double o[3], const double d[3], const double c[3], const double h[3], double *t, int *amb,
                 double *t_amb)
{
    double tn = -INFINITY, tf = INFINITY;
    for (int k = 0; k < 3; k++) {
        const double inv = 1.0 / d[k];
        const double t0 = (c[k] - h[k] - o[k]) * inv, t1 = (c[k] + h[k] - o[k]) * inv;
        tn = fmax(tn, fmin(t0, t1));
        tf = fmin(tf, fmax(t0, t1));
    }
    /* Entering and leaving at nearly the same t: the ray grazes an edge or a corner. */
    if (near_rel(tn, tf, 1e-4) || near_rel(tn, 0.001, 1e-4) || near_rel(tf, 0.001, 1e-4) ||
        (isfinite(tf) && fabs(tf) < 1e-4)) {
        *amb = 1;
        *t_amb = fmax(tn, 0.0);
    }
    if (tn > tf || tf < 0)
        return 0;
    *t = tn < 0.001 ? tf : tn;
    return *t >= 0.001;
}

static double sign64(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

static ref reference(const rto_wf_ray *ray)
{
    const double o[3] = {ray->origin[0], ray->origin[1], ray->origin[2]};
    const double d[3] = {ray->dir[0], ray->dir[1], ray->dir[2]};
    const double tmax = ray->t_max;
    ref r = {-1, 0, 0, 0, {0, 0, 0}};
    double ts[4], t_amb[4];
    int hit[4], amb_k[4];
    for (int k = 0; k < 4; k++) {
        amb_k[k] = 0;
        t_amb[k] = INFINITY;
        hit[k] = scene[k].is_box ? box64(o, d, scene[k].c, scene[k].h, &ts[k], &amb_k[k], &t_amb[k])
                                 : sphere64(o, d, scene[k].c, scene[k].h[0], &ts[k], &amb_k[k], &t_amb[k]);
        if (hit[k] && ts[k] < 999999.0 && ts[k] < tmax && (r.prim < 0 || ts[k] < r.t)) {
            r.prim = k;
            r.t = ts[k];
        }
    }
    /* A primitive's rounding matters only where it could decide the nearest: it is the nearest, or the t at which it
     * is in doubt is not clearly behind the nearest hit. Rounding at a far primitive is harmless. */
    int amb = 0;
    for (int k = 0; k < 4; k++)
        if (amb_k[k] && (r.prim < 0 || k == r.prim || !(t_amb[k] > r.t * (1 + 1e-4))))
            amb = 1;
    /* Two primitives at nearly the same t, or the hit next to tMax / the 999999 start. */
    for (int k = 0; k < 4 && r.prim >= 0; k++)
        if (k != r.prim && hit[k] && near_rel(ts[k], r.t, 1e-4))
            amb = 1;
    if (r.prim >= 0 && (near_rel(r.t, tmax, 1e-4) || near_rel(r.t, 999999.0, 1e-4)))
        amb = 1;
    r.ambiguous = amb;
    if (r.prim < 0)
        return r;
    double p[3];
    for (int k = 0; k < 3; k++)
        p[k] = o[k] + r.t * d[k] - scene[r.prim].c[k];
    double n[3];
    if (!scene[r.prim].is_box) {
        memcpy(n, p, sizeof n);
    } else {
        for (int k = 0; k < 3; k++) {
            const double band = scene[r.prim].h[k] - 0.001;
            /* The rounded position is off by a few 1e-6 of the distance travelled and of |origin|. */
            if (fabs(fabs(p[k]) - band) < 1e-5 * fmax(1.0, fmax(r.t * sqrt(tu_dot3(d, d)), fmax(fabs(o[0]),
                                                                     fmax(fabs(o[1]), fabs(o[2]))))))
                r.box_band = 1;
            n[k] = (fabs(p[k]) > band ? 1.0 : 0.0) * sign64(p[k]);
        }
    }
    const double len = sqrt(tu_dot3(n, n));
    for (int k = 0; k < 3; k++)
        r.n[k] = n[k] / len;
    return r;
}

static rto_wf_ray make_ray(double ox, double oy, double oz, double dx, double dy, double dz, float tmax)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    r.origin[0] = (float)ox;
    r.origin[1] = (float)oy;
    r.origin[2] = (float)oz;
    r.dir[0] = (float)dx;
    r.dir[1] = (float)dy;
    r.dir[2] = (float)dz;
    r.t_min = 0.0f;
    r.t_max = tmax;
    r.cull_mask = 0xFF;
    return r;
}

static rto_hit_record trace1(const rto_wf_ray *ray)
{
    rto_hit_record h;
    memset(&h, 0xA5, sizeof h);
    rto_stage2_trace(ray, 1, &h);
    return h;
}

/* Every field of a hit record of primitive k at t (NaN: any t), as the header states: instanceId = customIndex = k,
 * objToWorld the translation to the centre. */
static void assert_hit_record(const rto_hit_record *h, uint32_t k, float t)
{
    assert_int_equal(h->miss_flag, 0);
    assert_int_equal(h->instance_id, k);
    assert_int_equal(h->custom_index, k);
    assert_int_equal(h->prim_id, 0);
    assert_int_equal(h->hit_group, 0);
    assert_true(h->bary[0] == 0.0f && h->bary[1] == 0.0f);
    if (t == t)
        assert_true(h->t == t);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++) {
            const float want = c < 3 ? (r == c ? 1.0f : 0.0f) : (r < 3 ? (float)scene[k].c[r] : 0.0f);
            if (h->obj_to_world[c][r] != want)
                fail_msg("objToWorld[%d][%d] = %g, expected %g", c, r, (double)h->obj_to_world[c][r], (double)want);
        }
}

static void assert_miss_record(const rto_hit_record *h, float tmax)
{
    assert_int_equal(h->miss_flag, 1);
    assert_true(h->t == tmax);
    assert_int_equal(h->instance_id, 0xFFFFFFFFu);
    assert_int_equal(h->prim_id, 0xFFFFFFFFu);
    assert_int_equal(h->hit_group, 0xFFFFFFFFu);
    assert_int_equal(h->custom_index, 0xFFFFFFFFu);
    assert_true(h->bary[0] == 0.0f && h->bary[1] == 0.0f);
    const float *m = &h->obj_to_world[0][0];
    for (int k = 0; k < 16; k++)
        assert_true(m[k] == 0.0f);
}

static void normal_of(const rto_wf_ray *ray, const rto_hit_record *h, float n[3]) { rto__stage2_normal(ray, h, n); }

/* ---------------------------------------------------------------------------------------------------------------- */
/* Pinned cases: answers worked out by hand                                                                          */

static void test_pinned_spheres(void **state)
{
    (void)state;
    /* From (0, 0, 5) down -z at sphere 1: oc = (0, 0, 5), a = 1, b = -10, c = 24, disc = 100 - 96 = 4, t = (10 - 2) / 2
     * = 4 exactly; position (0, 0, 1), normal (0, 0, 1). */
    rto_wf_ray r = make_ray(0, 0, 5, 0, 0, -1, RTO_RAY_T_MAX);
    rto_hit_record h = trace1(&r);
    assert_hit_record(&h, 0, 4.0f);
    float n[3];
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 0.0f && n[2] == 1.0f);
    /* tMax bounds the hit strictly: tMax 4 misses (t < tMax fails), as does 3.5; the miss record's t is tMax. */
    r.t_max = 4.0f;
    h = trace1(&r);
    assert_miss_record(&h, 4.0f);
    r.t_max = 3.5f;
    h = trace1(&r);
    assert_miss_record(&h, 3.5f);
    r.t_max = nextafterf(4.0f, INFINITY);
    h = trace1(&r);
    assert_hit_record(&h, 0, 4.0f);
    /* Pointing away: both roots behind (t = -6, -4): a miss. */
    r = make_ray(0, 0, 5, 0, 0, 1, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_miss_record(&h, RTO_RAY_T_MAX);
    /* From the centre of sphere 1 along +x: the near root -1 is under 0.001, the far root t = 1 hits from inside
     * (normal (1, 0, 0), outward as the seed computes it). Sphere 2 is tangent to this ray (disc = 25 - 25 = 0, t =
     * 2.5) and farther, so sphere 1 stays. */
    r = make_ray(0, 0, 0, 1, 0, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 0, 1.0f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 1.0f && n[1] == 0.0f && n[2] == 0.0f);
    /* The tangent alone, from x = 1.5 (past sphere 1, both of its roots behind): sphere 2 touches the ray at
     * (2.5, 0, 0), t = 1 (disc exactly 0), and the seed counts a tangent as a hit. */
    r = make_ray(1.5, 0, 0, 1, 0, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 1, 1.0f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 0.0f && n[2] == 1.0f);
    /* The epsilon: a ray starting on sphere 1's surface going out: the near root 0 is under 0.001, the far root too
     * (it is the same point behind): a miss of sphere 1; nothing else lies along +z. */
    r = make_ray(0, 0, 1, 0, 0, 1, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_miss_record(&h, RTO_RAY_T_MAX);
    /* Starting on the surface going in: the near root 0 fails the epsilon, the far one (t = 2, through the centre)
     * is taken. */
    r = make_ray(0, 0, 1, 0, 0, -1, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 0, 2.0f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 0.0f && n[2] == -1.0f);
    /* A direction that is not unit length: t scales with it (the seed never normalises in traceScene). */
    r = make_ray(0, 0, 5, 0, 0, -2, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 0, 2.0f);
}

static void test_pinned_boxes(void **state)
{
    (void)state;
    /* Straight down onto the ground from (0, 5, 5): invDir = (+inf, -1, +inf); the x and z slabs give (-inf, +inf),
     * the y slab (6, 7); t = 6 exactly; p = (0, 0.5, 5): only |p.y| > 0.499, normal (0, 1, 0). */
    rto_wf_ray r = make_ray(0, 5, 5, 0, -1, 0, RTO_RAY_T_MAX);
    rto_hit_record h = trace1(&r);
    assert_hit_record(&h, 3, 6.0f);
    float n[3];
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 1.0f && n[2] == 0.0f);
    /* The same with -0 components: invDir = (-inf, -1, -inf), the slabs swap ends, the same hit. */
    r.dir[0] = -0.0f;
    r.dir[2] = -0.0f;
    h = trace1(&r);
    assert_hit_record(&h, 3, 6.0f);
    /* Down onto box 1's top face (y = 0.75) from (-2.5, 5, 0): t = 4.25 exactly, normal (0, 1, 0). */
    r = make_ray(-2.5, 5, 0, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 2, 4.25f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 1.0f && n[2] == 0.0f);
    /* Within 0.001 of the +x edge of that face (p.x = 0.7495 > 0.75 - 0.001): the seed's rule sets x as well, so the
     * normal is the diagonal (1, 1, 0) / sqrt 2: the thin outline the seed's box shows. */
    r = make_ray(-2.5 + 0.7495, 5, 0, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 2, 4.25f);
    normal_of(&r, &h, n);
    const float s2 = 1.0f / sqrtf(2.0f);
    assert_true(fabsf(n[0] - s2) <= 1e-7f && fabsf(n[1] - s2) <= 1e-7f && n[2] == 0.0f);
    /* Near a corner: all three axes in the band, (1, 1, 1) / sqrt 3 (the box's corner colour). */
    r = make_ray(-2.5 + 0.7495, 5, 0.7495, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    normal_of(&r, &h, n);
    const float s3 = 1.0f / sqrtf(3.0f);
    assert_true(fabsf(n[0] - s3) <= 1e-7f && fabsf(n[1] - s3) <= 1e-7f && fabsf(n[2] - s3) <= 1e-7f);
    /* From inside box 1 (its centre) along +y: tNear = -0.75 < 0.001, so tFar = 0.75 is taken (the inside face). */
    r = make_ray(-2.5, 0, 0, 0, 1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 2, 0.75f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && n[1] == 1.0f && n[2] == 0.0f);
    /* Documented NaN rule: an origin exactly on the ground's x = -10 plane with a zero x direction computes
     * 0 * inf = NaN for that slab; rto__minf / rto__maxf then take the other operand (+inf for +0, -inf for -0), so the
     * ray misses either way (tNear = +inf > tFar, or tFar = -inf < 0). A GPU may answer otherwise (WGSL leaves min /
     * max of NaN to the implementation); such a ray is a tie case for a comparison. */
    r = make_ray(-10, 5, 0, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_miss_record(&h, RTO_RAY_T_MAX);
    r.dir[0] = -0.0f;
    h = trace1(&r);
    assert_miss_record(&h, RTO_RAY_T_MAX);
    /* Slightly inside the plane the ray hits the ground's top at t = 6. */
    r = make_ray(-9.5, 5, 0, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 3, 6.0f);
    /* A zero direction never hits a sphere (a = 0: t = NaN, rejected by t < closest.t), and for the boxes every
     * slab is NaN or infinite: a miss. */
    r = make_ray(0, 0, 5, 0, 0, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_miss_record(&h, RTO_RAY_T_MAX);
}

static void test_pinned_normals(void **state)
{
    (void)state;
    /* A miss, or an instance past the four primitives, has no normal: NaN. */
    rto_wf_ray r = make_ray(0, 0, 5, 0, 0, 1, RTO_RAY_T_MAX);
    rto_hit_record h = trace1(&r);
    float n[3];
    normal_of(&r, &h, n);
    assert_true(isnan(n[0]) && isnan(n[1]) && isnan(n[2]));
    h.miss_flag = 0;
    h.instance_id = 4;
    normal_of(&r, &h, n);
    assert_true(isnan(n[0]));
    /* A box hit whose rounded position lies deeper than the 0.001 band on every axis (here a t moved by hand into
     * the ground's interior) has the zero vector, normalised to NaN (v / length(v), DESIGN.md §7). */
    r = make_ray(0, 5, 5, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    h.t = 6.5f;
    normal_of(&r, &h, n);
    assert_true(isnan(n[0]) && isnan(n[1]) && isnan(n[2]));
    /* The sign of a zero component: f32(false) * sign(p) keeps the sign of p, -0 where p < 0 (WGSL's product). */
    r = make_ray(-5, 5, -5, 0, -1, 0, RTO_RAY_T_MAX);
    h = trace1(&r);
    assert_hit_record(&h, 3, 6.0f);
    normal_of(&r, &h, n);
    assert_true(n[0] == 0.0f && signbit(n[0]) && n[1] == 1.0f && n[2] == 0.0f && signbit(n[2]));
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Random rays against the binary64 evaluation                                                                       */

typedef struct tally {
    size_t rays, hits, ambiguous, band, checked_normals;
    double max_rel_t, max_normal_err;
} tally;

static void check_ray(const rto_wf_ray *ray, const rto_hit_record *h, tally *ty, const char *set, size_t i)
{
    const ref e = reference(ray);
    ty->rays++;
    if (e.ambiguous) {
        /* Only what is defined: a hit names one of the four primitives, at a finite t past the epsilon, before tMax. */
        ty->ambiguous++;
        if (!h->miss_flag) {
            assert_true(h->instance_id < 4);
            assert_true(isfinite(h->t) && h->t >= 0.001f && h->t < ray->t_max);
        }
        return;
    }
    if (e.prim < 0) {
        if (!h->miss_flag)
            fail_msg("%s ray %zu: expected a miss, got primitive %u at t %.9g (o %g %g %g, d %g %g %g)", set, i,
                     h->instance_id, (double)h->t, (double)ray->origin[0], (double)ray->origin[1],
                     (double)ray->origin[2], (double)ray->dir[0], (double)ray->dir[1], (double)ray->dir[2]);
        assert_miss_record(h, ray->t_max);
        return;
    }
    ty->hits++;
    if (h->miss_flag || h->instance_id != (uint32_t)e.prim)
        fail_msg("%s ray %zu: expected primitive %d at t %.9g, got %s %u at t %.9g (o %.9g %.9g %.9g, d %.9g %.9g "
                 "%.9g)", set, i, e.prim, e.t, h->miss_flag ? "a miss" : "primitive", h->instance_id, (double)h->t,
                 (double)ray->origin[0], (double)ray->origin[1], (double)ray->origin[2], (double)ray->dir[0],
                 (double)ray->dir[1], (double)ray->dir[2]);
    assert_hit_record(h, (uint32_t)e.prim, NAN);
    /* DESIGN.md §9's hit tolerance: |dt| <= 1e-5 max(1, |t|). */
    const double rel = fabs((double)h->t - e.t) / fmax(1.0, fabs(e.t));
    if (rel > 1e-5)
        fail_msg("%s ray %zu: t %.9g, binary64 %.12g (relative error %.3g)", set, i, (double)h->t, e.t, rel);
    ty->max_rel_t = fmax(ty->max_rel_t, rel);
    if (e.box_band) {
        ty->band++;
        return;
    }
    float n[3];
    normal_of(ray, h, n);
    /* Sphere normals move with the rounded position (the t error, a few 1e-6 of the distance travelled, and the
     * origin's rounding): 1e-5 of the larger of the distance and |origin|, over the unit radius. Box normals are
     * exactly one of the face rule's unit vectors, rounded once. */
    const double dist = e.t * sqrt((double)ray->dir[0] * ray->dir[0] + (double)ray->dir[1] * ray->dir[1] +
                                   (double)ray->dir[2] * ray->dir[2]);
    const double omag = fmax(fabs((double)ray->origin[0]), fmax(fabs((double)ray->origin[1]),
                                                                fabs((double)ray->origin[2])));
    for (int k = 0; k < 3; k++) {
        const double err = fabs((double)n[k] - e.n[k]);
        ty->max_normal_err = fmax(ty->max_normal_err, err);
        const double tol = scene[e.prim].is_box ? 1e-7 : 1e-5 * fmax(1.0, fmax(dist, omag));
        if (!(err <= tol))
            fail_msg("%s ray %zu (primitive %d, t %.9g): normal %.9g %.9g %.9g, binary64 %.9g %.9g %.9g", set, i,
                     e.prim, e.t, (double)n[0], (double)n[1], (double)n[2], e.n[0], e.n[1], e.n[2]);
    }
    ty->checked_normals++;
}

static void run_set(const char *set, rto_wf_ray *rays, size_t n, tally *ty)
{
    rto_hit_record *hits = malloc(n * sizeof *hits);
    assert_non_null(hits);
    memset(hits, 0xA5, n * sizeof *hits);
    rto_stage2_trace(rays, n, hits);
    for (size_t i = 0; i < n; i++) {
        /* One call per ray and one call for all give the same records (no state between rays). */
        if (i % 97 == 0) {
            const rto_hit_record one = trace1(&rays[i]);
            assert_memory_equal(&one, &hits[i], sizeof one);
        }
        check_ray(&rays[i], &hits[i], ty, set, i);
    }
    free(hits);
}

/* A point uniform in primitive k (a ball or a box), in binary64: rays aimed at it hit the primitive unless another
 * one is in front, and only rays aimed near a silhouette graze it. */
static void point_in(uint64_t *s, int k, double p[3])
{
    if (!scene[k].is_box) {
        double d[3];
        tu_rng_dir(s, d);
        const double r = scene[k].h[0] * cbrt(tu_rng_unit(s));
        for (int a = 0; a < 3; a++)
            p[a] = scene[k].c[a] + r * d[a];
        return;
    }
    for (int a = 0; a < 3; a++)
        p[a] = scene[k].c[a] + scene[k].h[a] * (2.0 * tu_rng_unit(s) - 1.0);
}

static void test_random_rays(void **state)
{
    (void)state;
    const size_t n = 20000;
    rto_wf_ray *rays = malloc(n * sizeof *rays);
    assert_non_null(rays);
    uint64_t seed = 0x57A6E2u;
    tally all = {0};
    /* 1. Free rays: origins uniform in a box around the scene (inside primitives too), directions uniform. */
    for (size_t i = 0; i < n; i++) {
        double o[3], d[3];
        o[0] = -8 + 16 * tu_rng_unit(&seed);
        o[1] = -3 + 9 * tu_rng_unit(&seed);
        o[2] = -8 + 16 * tu_rng_unit(&seed);
        tu_rng_dir(&seed, d);
        rays[i] = make_ray(o[0], o[1], o[2], d[0], d[1], d[2], RTO_RAY_T_MAX);
    }
    run_set("free", rays, n, &all);
    /* 2. Aimed rays: from outside towards a point of a random primitive (a point inside it), some with a tMax
     * before, some after the aimed point, some with non-unit directions. */
    for (size_t i = 0; i < n; i++) {
        double o[3], p[3], d[3];
        tu_rng_dir(&seed, o);
        const double dist = 3 + 12 * tu_rng_unit(&seed);
        for (int a = 0; a < 3; a++)
            o[a] *= dist;
        point_in(&seed, (int)(tu_rng_next(&seed) % 4), p);
        const double scale = (i % 3 == 0) ? 0.25 + 4 * tu_rng_unit(&seed) : 1.0;
        for (int a = 0; a < 3; a++)
            d[a] = p[a] - o[a];
        const double len = sqrt(tu_dot3(d, d));
        for (int a = 0; a < 3; a++)
            d[a] = d[a] / len * scale;
        const float tmax = (i % 5 == 0) ? (float)(len / scale * (0.5 + tu_rng_unit(&seed))) : RTO_RAY_T_MAX;
        rays[i] = make_ray(o[0], o[1], o[2], d[0], d[1], d[2], tmax);
    }
    run_set("aimed", rays, n, &all);
    /* 3. Directions with zero components (+0 and -0): axis-parallel and in coordinate planes, aimed at a primitive
     * from an origin off every slab plane. 1 / 0 = +-inf in the slabs. */
    for (size_t i = 0; i < n; i++) {
        double p[3], d[3] = {0, 0, 0};
        point_in(&seed, (int)(tu_rng_next(&seed) % 4), p);
        const uint64_t pick = tu_rng_next(&seed);
        const int zeros = 1 + (int)(pick % 2); /* one or two zero components */
        const int first = (int)((pick >> 8) % 3);
        for (int a = 0; a < 3; a++)
            d[a] = 2.0 * tu_rng_unit(&seed) - 1.0;
        for (int z = 0; z < zeros; z++)
            d[(first + z) % 3] = ((pick >> (16 + z)) & 1) ? -0.0 : 0.0;
        const double len = sqrt(tu_dot3(d, d));
        if (len == 0) {
            d[first] = 1.0;
        } else {
            for (int a = 0; a < 3; a++)
                d[a] /= len;
        }
        const double back = 2 + 10 * tu_rng_unit(&seed);
        double o[3];
        for (int a = 0; a < 3; a++)
            o[a] = p[a] - back * d[a];
        rays[i] = make_ray(o[0], o[1], o[2], d[0], d[1], d[2], RTO_RAY_T_MAX);
        for (int a = 0; a < 3; a++)
            if (d[a] == 0.0)
                rays[i].dir[a] = signbit(d[a]) ? -0.0f : 0.0f;
    }
    run_set("axis", rays, n, &all);
    free(rays);
    print_message("stage2: %zu rays, %zu hits checked exactly, %zu ambiguous (binary32 rounding decides; checked "
                  "loosely), %zu box hits in the face rule's band, %zu normals checked; max relative t error %.3g, "
                  "max normal error %.3g\n", all.rays, all.hits, all.ambiguous, all.band, all.checked_normals,
                  all.max_rel_t, all.max_normal_err);
    /* The detection must leave almost every ray decided, or the test would check little. */
    assert_true(all.ambiguous * 50 < all.rays);
    assert_true(all.hits * 3 > all.rays);
}

/* n = 0 reads and writes nothing. */
static void test_empty(void **state)
{
    (void)state;
    rto_stage2_trace(NULL, 0, NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pinned_spheres),
        cmocka_unit_test(test_pinned_boxes),
        cmocka_unit_test(test_pinned_normals),
        cmocka_unit_test(test_random_rays),
        cmocka_unit_test(test_empty),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
