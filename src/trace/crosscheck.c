/* Comparison and classification of the oracle's hit records and another tracer's (Embree's, a GPU's) (crosscheck.h states the rules). All geometry
 * here is binary64, from the scene's binary32 vertices and matrices, so it judges both tracers from outside. */
#include "crosscheck.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

const char *xc_class_name(xc_class c)
{
    static const char *const names[XC_CLASS_COUNT] = {"agree",      "tie",         "coplanar",      "crossing",
                                                      "t-rounding", "robust-only", "surface-start", "grazing",
                                                      "sliver",     "unexplained"};
    return (unsigned)c < XC_CLASS_COUNT ? names[c] : "?";
}

typedef struct dvec {
    double x[3];
} dvec;

static dvec sub(dvec a, dvec b) { return (dvec){{a.x[0] - b.x[0], a.x[1] - b.x[1], a.x[2] - b.x[2]}}; }
static double dot(dvec a, dvec b) { return a.x[0] * b.x[0] + a.x[1] * b.x[1] + a.x[2] * b.x[2]; }
static dvec cross(dvec a, dvec b)
{
    return (dvec){{a.x[1] * b.x[2] - a.x[2] * b.x[1], a.x[2] * b.x[0] - a.x[0] * b.x[2],
                   a.x[0] * b.x[1] - a.x[1] * b.x[0]}};
}
static double len(dvec a) { return sqrt(dot(a, a)); }
static double maxabs(dvec a) { return fmax(fabs(a.x[0]), fmax(fabs(a.x[1]), fabs(a.x[2]))); }

/* M (x, 1) for a point (w = 1) or M (x, 0) for a direction (w = 0), in binary64. */
static dvec xform(const rto_mat34 *m, const float v[3], double w)
{
    dvec r;
    for (int i = 0; i < 3; i++)
        r.x[i] = (double)m->m[i][0] * v[0] + (double)m->m[i][1] * v[1] + (double)m->m[i][2] * v[2] + m->m[i][3] * w;
    return r;
}

static int valid_tri(const rto_scene *sc, uint32_t inst, uint32_t prim)
{
    return inst < sc->instance_count && sc->instances[inst].blas < sc->mesh_count &&
           prim < sc->meshes[sc->instances[inst].blas].triangle_count;
}

static uint32_t tri_index(const rto_scene *sc, uint32_t inst, uint32_t prim, int k)
{
    return sc->meshes[sc->instances[inst].blas].indices[3 * (size_t)prim + (size_t)k];
}

static const float *tri_vertex(const rto_scene *sc, uint32_t inst, uint32_t prim, int k)
{
    const rto_mesh *m = &sc->meshes[sc->instances[inst].blas];
    return m->positions + 3 * (size_t)tri_index(sc, inst, prim, k);
}

static void world_tri(const rto_scene *sc, uint32_t inst, uint32_t prim, dvec v[3])
{
    for (int k = 0; k < 3; k++)
        v[k] = xform(&sc->instances[inst].obj_to_world, tri_vertex(sc, inst, prim, k), 1);
}

/* Signed distance of a point of a triangle's plane to the triangle's boundary: > 0 inside (to the nearest edge
 * line), < 0 outside (minus the largest distance beyond an edge line), from the barycentrics and the heights.
 * Returns 0 and sets *degenerate for a triangle of zero area. */
static double boundary_distance(const dvec v[3], dvec p, int *degenerate)
{
    dvec e1 = sub(v[1], v[0]), e2 = sub(v[2], v[0]), n = cross(e1, e2);
    double nn = dot(n, n);
    *degenerate = !(nn > 0);
    if (*degenerate)
        return 0;
    dvec w = sub(p, v[0]);
    double u = dot(cross(w, e2), n) / nn, vv = dot(cross(e1, w), n) / nn;
    double b[3] = {1 - u - vv, u, vv};
    /* height over the edge opposite vertex i: twice the area over that edge's length */
    double edge[3] = {len(sub(v[2], v[1])), len(e2), len(e1)};
    double in = INFINITY, out = 0;
    for (int i = 0; i < 3; i++) {
        double d = b[i] * sqrt(nn) / edge[i];
        if (d < in)
            in = d;
        if (-d > out)
            out = -d;
    }
    return out > 0 ? -out : in;
}

/* A ray against one triangle of an instance in object space, binary64: the ray through worldToObj, the triangle's
 * normal, |cos a| between ray and normal, the plane crossing p and S, the largest coordinate magnitude among the
 * origin, p and the vertices (at least 1): the scale of the binary32 rounding both tracers make. Returns 0 when the
 * ray is (nearly) parallel to the plane (|cos a| <= min_cos), the triangle degenerate or the direction 0. */
typedef struct objray {
    dvec v[3], o, d, p;
    double t, dlen, cosa, s;
} objray;

static int obj_ray(const rto_scene *sc, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double min_cos,
                   objray *r)
{
    const rto_instance *in = &sc->instances[inst];
    for (int k = 0; k < 3; k++) {
        const float *p = tri_vertex(sc, inst, prim, k);
        r->v[k] = (dvec){{p[0], p[1], p[2]}};
    }
    r->o = xform(&in->world_to_obj, ray->origin, 1);
    r->d = xform(&in->world_to_obj, ray->dir, 0);
    dvec n = cross(sub(r->v[1], r->v[0]), sub(r->v[2], r->v[0]));
    double nl = len(n);
    r->dlen = len(r->d);
    r->cosa = 0;
    r->s = 1;
    if (!(nl > 0) || !(r->dlen > 0))
        return 0;
    double denom = dot(r->d, n);
    r->cosa = fabs(denom) / (nl * r->dlen);
    if (r->cosa <= min_cos)
        return 0;
    const double t = dot(sub(r->v[0], r->o), n) / denom;
    r->t = t;
    r->p = (dvec){{r->o.x[0] + t * r->d.x[0], r->o.x[1] + t * r->d.x[1], r->o.x[2] + t * r->d.x[2]}};
    r->s = fmax(1, fmax(maxabs(r->o), maxabs(r->p)));
    for (int k = 0; k < 3; k++)
        r->s = fmax(r->s, maxabs(r->v[k]));
    return 1;
}

double xc_edge_distance(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, int *parallel)
{
    *parallel = 1;
    if (!valid_tri(scene, inst, prim))
        return INFINITY;
    objray r;
    if (!obj_ray(scene, inst, prim, ray, XC_PARALLEL_COS, &r))
        return 0;
    *parallel = 0;
    int degenerate;
    double bd = fabs(boundary_distance(r.v, r.p, &degenerate));
    /* distance <= XC_EDGE_REL S / |cos a|  <=>  distance |cos a| / S <= XC_EDGE_REL */
    return bd / r.s * r.cosa;
}

int xc_plane_hit(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double *t, double *u,
                 double *v)
{
    objray r;
    if (!valid_tri(scene, inst, prim) || !obj_ray(scene, inst, prim, ray, XC_PARALLEL_COS, &r))
        return 0;
    dvec e1 = sub(r.v[1], r.v[0]), e2 = sub(r.v[2], r.v[0]), n = cross(e1, e2), w = sub(r.p, r.v[0]);
    const double nn = dot(n, n);
    *t = r.t;
    *u = dot(cross(w, e2), n) / nn;
    *v = dot(cross(e1, w), n) / nn;
    return 1;
}

double xc_t_rounding(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double dt)
{
    if (!valid_tri(scene, inst, prim))
        return INFINITY;
    objray r;
    if (!obj_ray(scene, inst, prim, ray, XC_PARALLEL_COS, &r))
        return 0;
    /* the two hit points o + t d lie |dt| |d'| |cos a| apart across the triangle's plane */
    return fabs(dt) * r.dlen * r.cosa / r.s;
}

/* Whether a hit record is one its triangle can give: the ray meets the triangle's plane at the record's t (within
 * the t tolerance, or the t-rounding bound) and there lies inside the triangle or within the grazing distance of its
 * boundary. A class that explains a disagreement by a record's triangle (tie, coplanar, crossing, grazing) first
 * checks this, so a record naming a wrong triangle is never explained away. A ray within min_cos of parallel to the
 * plane passes when min_cos > 0 (crosscheck's rule: nothing can be decided there); with min_cos 0 only a ray exactly
 * parallel fails, and the plane crossing is judged however ill-conditioned. */
static int plausible(const rto_scene *sc, const rto_wf_ray *ray, const rto_hit_record *h, double min_cos)
{
    if (!valid_tri(sc, h->instance_id, h->prim_id))
        return 0;
    objray r;
    if (!obj_ray(sc, h->instance_id, h->prim_id, ray, min_cos, &r))
        return min_cos > 0;
    const double dt = (double)h->t - r.t;
    if (!(fabs(dt) <= rto__tol_t(r.t) || fabs(dt) * r.dlen * r.cosa / r.s <= XC_EDGE_REL))
        return 0;
    int degenerate;
    return boundary_distance(r.v, r.p, &degenerate) * r.cosa / r.s >= -XC_EDGE_REL;
}

static int grazes(const rto_scene *sc, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double *rel)
{
    int parallel;
    *rel = xc_edge_distance(sc, inst, prim, ray, &parallel);
    if (parallel) {
        *rel = 0;
        return valid_tri(sc, inst, prim);
    }
    return *rel <= XC_EDGE_REL;
}

int xc_grazing_hit(const rto_scene *scene, const rto_wf_ray *ray, const rto_hit_record *h, int strict, double *rel)
{
    *rel = 0;
    return plausible(scene, ray, h, strict ? 0 : XC_PARALLEL_COS) &&
           grazes(scene, h->instance_id, h->prim_id, ray, rel);
}

static int is_hit(const rto_hit_record *h) { return h && h->miss_flag == 0; }
/* A hit that names its triangle (an occluded TERMINATE_ON_FIRST_HIT record from Embree names none). */
static int names_tri(const rto_hit_record *h) { return is_hit(h) && h->prim_id != UINT32_MAX; }

int xc_agree(const rto_wf_ray *ray, const rto_hit_record *a, const rto_hit_record *b, double *rel_dt)
{
    *rel_dt = 0;
    if (!is_hit(a) && !is_hit(b))
        return 1;
    if (is_hit(a) != is_hit(b))
        return 0;
    if (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT)
        return 1;
    if (a->instance_id != b->instance_id || a->prim_id != b->prim_id)
        return 0;
    *rel_dt = fabs((double)a->t - b->t) / rto__tol_t_scale(a->t);
    return rto__tol_t_close(a->t, b->t);
}

/* Same vertex index in the same instance, or world positions equal within XC_SHARED_REL. */
static int share_vertex(const rto_scene *sc, const rto_hit_record *a, const rto_hit_record *b, char *why, size_t cap)
{
    if (a->instance_id == b->instance_id)
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                if (tri_index(sc, a->instance_id, a->prim_id, i) == tri_index(sc, b->instance_id, b->prim_id, j)) {
                    snprintf(why, cap, "triangles %u and %u of instance %u share vertex %u", a->prim_id, b->prim_id,
                             a->instance_id, tri_index(sc, a->instance_id, a->prim_id, i));
                    return 1;
                }
    dvec va[3], vb[3];
    world_tri(sc, a->instance_id, a->prim_id, va);
    world_tri(sc, b->instance_id, b->prim_id, vb);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            int eq = 1;
            for (int k = 0; k < 3 && eq; k++)
                eq = fabs(va[i].x[k] - vb[j].x[k]) <= XC_SHARED_REL * fmax(1, fabs(va[i].x[k]));
            if (eq) {
                snprintf(why, cap, "triangle %u of instance %u and triangle %u of instance %u share a vertex at "
                         "(%.9g, %.9g, %.9g)", a->prim_id, a->instance_id, b->prim_id, b->instance_id, va[i].x[0],
                         va[i].x[1], va[i].x[2]);
                return 1;
            }
        }
    return 0;
}

/* The world triangles of hits a and b, and a's hit point p on the ray; returns their scale max(1, |coordinate|) over
 * both triangles' vertices (p not included). */
static double hit_pair(const rto_scene *sc, const rto_wf_ray *ray, const rto_hit_record *a, const rto_hit_record *b,
                       dvec t[2][3], dvec *p)
{
    world_tri(sc, a->instance_id, a->prim_id, t[0]);
    world_tri(sc, b->instance_id, b->prim_id, t[1]);
    const double th = a->t;
    for (int k = 0; k < 3; k++)
        p->x[k] = ray->origin[k] + th * ray->dir[k];
    double s = 1;
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 3; k++)
            s = fmax(s, maxabs(t[i][k]));
    return s;
}

/* Both triangles in one plane, and the hit point inside (or within the grazing distance of) both. */
static int coplanar(const rto_scene *sc, const rto_wf_ray *ray, const rto_hit_record *a, const rto_hit_record *b,
                    char *why, size_t cap)
{
    dvec t[2][3], p;
    double s = hit_pair(sc, ray, a, b, t, &p);
    for (int i = 0; i < 2; i++) {
        dvec n = cross(sub(t[i][1], t[i][0]), sub(t[i][2], t[i][0]));
        double nl = len(n);
        if (!(nl > 0))
            return 0;
        for (int k = 0; k < 3; k++)
            if (fabs(dot(n, sub(t[1 - i][k], t[i][0]))) / nl > XC_PLANE_REL * s)
                return 0;
    }
    s = fmax(s, maxabs(p));
    for (int i = 0; i < 2; i++) {
        int degenerate;
        if (boundary_distance(t[i], p, &degenerate) < -XC_EDGE_REL * s || degenerate)
            return 0;
    }
    snprintf(why, cap, "triangle %u of instance %u and triangle %u of instance %u lie in one plane and overlap at "
             "the hit", a->prim_id, a->instance_id, b->prim_id, b->instance_id);
    return 1;
}

/* Two triangles that both contain the hit point (within the grazing distance), not in one plane: the ray meets the
 * line where they touch or cross. */
static int crossing(const rto_scene *sc, const rto_wf_ray *ray, const rto_hit_record *a, const rto_hit_record *b,
                    char *why, size_t cap)
{
    dvec t[2][3], p;
    double s = fmax(hit_pair(sc, ray, a, b, t, &p), maxabs(p));
    s = fmax(s, fmax(fabs(ray->origin[0]), fmax(fabs(ray->origin[1]), fabs(ray->origin[2]))));
    for (int i = 0; i < 2; i++) {
        int degenerate;
        dvec n = cross(sub(t[i][1], t[i][0]), sub(t[i][2], t[i][0]));
        double nl = len(n);
        /* on the triangle: near its plane, and inside it or near its boundary */
        if (!(nl > 0) || fabs(dot(n, sub(p, t[i][0]))) / nl > XC_EDGE_REL * s ||
            boundary_distance(t[i], p, &degenerate) < -XC_EDGE_REL * s || degenerate)
            return 0;
    }
    snprintf(why, cap, "the hit point lies on triangle %u of instance %u and on triangle %u of instance %u, which "
             "meet there", a->prim_id, a->instance_id, b->prim_id, b->instance_id);
    return 1;
}

static void set(xc_result *out, xc_class c, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void set(xc_result *out, xc_class c, const char *fmt, ...)
{
    out->cls = c;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out->why, sizeof out->why, fmt, ap);
    va_end(ap);
}

static const char *side_name(const xc_input *in, int oracle)
{
    return oracle ? "the oracle" : in->other ? in->other : "Embree";
}

/* The model's intervals for a record's triangle (bound tMax); 0 without a model or a triangle. */
static int model_of(const xc_input *in, const rto_hit_record *h, cf_prim *p)
{
    if (!in->model || !names_tri(h) || !valid_tri(in->scene, h->instance_id, h->prim_id))
        return 0;
    cf_prim_eval(in->model, h->instance_id, h->prim_id, in->ray, in->ray->t_max, p);
    return p->valid && !p->masked;
}

static int overlap(cf_iv a, cf_iv b) { return a.lo <= b.hi && b.lo <= a.hi; }

/* How far x lies from c in units of the interval's spread about c (the larger distance from c to an end); infinite
 * when the interval is a point and x is not c. */
static double spreads(cf_iv iv, double c, double x)
{
    const double s = fmax(c - iv.lo, iv.hi - c);
    return s > 0 ? fabs(x - c) / s : (x == c ? 0 : INFINITY);
}

/* A sliver: the record's t lies within XC_MODEL_K spreads of the model's t interval about the binary64 crossing, and
 * the interval is wider than the fixed t rule (the triangle is ill-conditioned for this ray). */
static int sliver_t(const xc_input *in, const rto_hit_record *h, const cf_prim *p, double *k)
{
    double t, u, v;
    if (!xc_plane_hit(in->scene, h->instance_id, h->prim_id, in->ray, &t, &u, &v))
        return 0;
    *k = spreads(p->tri.t, t, h->t);
    return *k <= XC_MODEL_K && p->tri.t.hi - p->tri.t.lo > 2 * RTO__TOL_T_REL * rto__tol_t_scale(t);
}

/* plausible(), or under the model: a triangle a conforming implementation may hit, at a t within XC_MODEL_K spreads
 * of the model's interval about the binary64 crossing. */
static int plausible_in(const xc_input *in, const rto_hit_record *h, const cf_prim *p)
{
    if (plausible(in->scene, in->ray, h, XC_PARALLEL_COS))
        return 1;
    double t, u, v;
    return p && p->hit != CF_NEVER && xc_plane_hit(in->scene, h->instance_id, h->prim_id, in->ray, &t, &u, &v) &&
           spreads(p->tri.t, t, h->t) <= XC_MODEL_K;
}

/* A sliver: the hit's binary64 crossing lies within XC_MODEL_K spreads of the model's u, v or u + v interval from the
 * edge (0, 0 or 1), so another binary32 evaluation may decide the edge the other way. */
static int sliver_edge(const xc_input *in, const rto_hit_record *h, const cf_prim *p, double *k)
{
    double t, u, v;
    if (!xc_plane_hit(in->scene, h->instance_id, h->prim_id, in->ray, &t, &u, &v))
        return 0;
    const double ku = spreads(p->tri.u, u, 0), kv = spreads(p->tri.v, v, 0), kw = spreads(p->tri.uv, u + v, 1);
    *k = fmin(ku, fmin(kv, kw));
    return *k <= XC_MODEL_K;
}

void xc_classify(const xc_input *in, xc_result *out)
{
    memset(out, 0, sizeof *out);
    const rto_scene *sc = in->scene;
    const rto_wf_ray *ray = in->ray;
    const rto_hit_record *o = in->oracle, *e = in->embree;
    if (xc_agree(ray, o, e, &out->rel_dt)) {
        out->cls = XC_AGREE;
        return;
    }
    /* The triangle Embree hit, where it names one. */
    const rto_hit_record *et = names_tri(e) ? e : (is_hit(e) && names_tri(in->embree_closest) ? in->embree_closest : NULL);
    char why[200] = "";
    cf_prim po, pe;
    const int have_po = model_of(in, o, &po), have_pe = et && model_of(in, et, &pe);

    if (is_hit(o) && is_hit(e) && et &&
        (rto__tol_t_close(o->t, et->t) || (have_po && have_pe && overlap(po.tri.t, pe.tri.t))) &&
        (o->instance_id != et->instance_id || o->prim_id != et->prim_id) &&
        plausible_in(in, o, have_po ? &po : NULL) && plausible_in(in, et, have_pe ? &pe : NULL)) {
        if (share_vertex(sc, o, et, why, sizeof why)) {
            set(out, XC_TIE, "t %.9g / %.9g: %s", o->t, et->t, why);
            return;
        }
        if (coplanar(sc, ray, o, et, why, sizeof why)) {
            set(out, XC_COPLANAR, "t %.9g / %.9g: %s", o->t, et->t, why);
            return;
        }
        if (crossing(sc, ray, o, et, why, sizeof why)) {
            set(out, XC_CROSSING, "t %.9g / %.9g: %s", o->t, et->t, why);
            return;
        }
    }

    /* The same triangle at t beyond the t tolerance: a t §6's arithmetic may give (the model), or within the rounding
     * of the coordinates? */
    if (names_tri(o) && et == e && names_tri(e) && o->instance_id == e->instance_id && o->prim_id == e->prim_id &&
        valid_tri(sc, o->instance_id, o->prim_id)) {
        double dt = (double)e->t - o->t, rel = xc_t_rounding(sc, o->instance_id, o->prim_id, ray, dt);
        if (have_pe && cf_in(pe.tri.t, e->t) && cf_in(pe.tri.t, o->t)) {
            out->edge_rel = rel;
            set(out, XC_T_ROUNDING, "triangle %u of instance %u at t %.9g / %.9g: both within [%.9g, %.9g], the t a "
                "conforming implementation of §6 may compute", o->prim_id, o->instance_id, o->t, e->t, pe.tri.t.lo,
                pe.tri.t.hi);
            return;
        }
        if (rel <= XC_EDGE_REL) {
            out->edge_rel = rel;
            set(out, XC_T_ROUNDING, "triangle %u of instance %u at t %.9g / %.9g: the two hit points lie %.3g "
                "(relative to the coordinates) apart across its plane", o->prim_id, o->instance_id, o->t, e->t, rel);
            return;
        }
        double k, ko;
        if (have_pe && sliver_t(in, e, &pe, &k) && sliver_t(in, o, &pe, &ko)) {
            k = fmax(k, ko);
            out->edge_rel = rel;
            set(out, XC_SLIVER, "triangle %u of instance %u at t %.9g / %.9g: %.2g times the spread of t that §6's "
                "binary32 arithmetic has on this ill-conditioned triangle", o->prim_id, o->instance_id, o->t, e->t, k);
            return;
        }
    }

    /* Embree default missed the oracle's triangle (or found another) where Embree robust finds it. */
    int same_tri = names_tri(o) && names_tri(e) && o->instance_id == e->instance_id && o->prim_id == e->prim_id;
    if (in->robust && is_hit(o) && !same_tri) {
        double rel;
        if (is_hit(in->robust) && xc_agree(ray, o, in->robust, &rel)) {
            set(out, XC_ROBUST_ONLY, "Embree default %s, Embree robust agrees with the oracle (triangle %u of "
                "instance %u, t %.9g)", is_hit(e) ? "hit another triangle" : "missed", o->prim_id, o->instance_id,
                o->t);
            return;
        }
    }

    /* The hit(s) the other side did not find. */
    const rto_hit_record *cand[2] = {NULL, NULL};
    const cf_prim *cand_model[2] = {NULL, NULL};
    int cand_oracle[2] = {0, 0};
    if (is_hit(o) && !is_hit(e)) {
        cand[0] = o;
        cand_oracle[0] = 1;
    } else if (!is_hit(o) && is_hit(e)) {
        cand[0] = et;
    } else if (et) { /* both hit, different triangles or t */
        if (rto__tol_t_close(o->t, et->t) || (have_po && have_pe && overlap(po.tri.t, pe.tri.t))) {
            cand[0] = o;
            cand_oracle[0] = 1;
            cand[1] = et;
        } else if (o->t < et->t) {
            cand[0] = o;
            cand_oracle[0] = 1;
        } else {
            cand[0] = et;
        }
    }
    for (int c = 0; c < 2; c++)
        if (cand[c])
            cand_model[c] = cand[c] == o ? (have_po ? &po : NULL) : (have_pe ? &pe : NULL);
    /* the ray starts on the triangle it hits: the triangle's plane crossing lies within rounding of tMin */
    for (int c = 0; c < 2; c++) {
        const rto_hit_record *h = cand[c];
        double t, u, v;
        if (!h || !xc_plane_hit(sc, h->instance_id, h->prim_id, ray, &t, &u, &v) ||
            !plausible_in(in, h, cand_model[c]))
            continue;
        const double rel = xc_t_rounding(sc, h->instance_id, h->prim_id, ray, t - ray->t_min);
        if (rel <= XC_EDGE_REL || (cand_model[c] && cand_model[c]->tri.t.lo <= (double)ray->t_min)) {
            out->edge_rel = rel;
            set(out, XC_SURFACE_START, "%s's hit (triangle %u of instance %u, t %.9g) lies within rounding of the "
                "ray's start (tMin %.9g): the ray starts on its surface", side_name(in, cand_oracle[c]), h->prim_id,
                h->instance_id, h->t, ray->t_min);
            return;
        }
    }
    for (int c = 0; c < 2; c++) {
        const rto_hit_record *h = cand[c];
        const cf_prim *p = cand_model[c];
        double rel;
        if (h && p && (p->hit == CF_POSSIBLE || (p->hit == CF_CERTAIN && p->reached == CF_POSSIBLE)) &&
            plausible_in(in, h, p)) {
            set(out, XC_GRAZING, "%s's hit (triangle %u of instance %u, t %.9g) is one a conforming implementation of "
                "§6 may %s", side_name(in, cand_oracle[c]), h->prim_id, h->instance_id, h->t,
                p->hit == CF_POSSIBLE ? "hit or miss (an edge within rounding)" : "reach or not (a box at its edge)");
            return;
        }
        if (h && xc_grazing_hit(sc, ray, h, 0, &rel)) {
            out->edge_rel = rel;
            if (rel == 0)
                set(out, XC_GRAZING, "%s's hit (triangle %u of instance %u, t %.9g) is on a ray nearly parallel to "
                    "its plane", side_name(in, cand_oracle[c]), h->prim_id, h->instance_id, h->t);
            else
                set(out, XC_GRAZING, "%s's hit (triangle %u of instance %u, t %.9g) lies %.3g (relative) from an "
                    "edge", side_name(in, cand_oracle[c]), h->prim_id, h->instance_id, h->t, rel);
            return;
        }
    }
    for (int c = 0; c < 2; c++) {
        const rto_hit_record *h = cand[c];
        double k;
        if (h && cand_model[c] && sliver_edge(in, h, cand_model[c], &k) && plausible_in(in, h, cand_model[c])) {
            set(out, XC_SLIVER, "%s's hit (triangle %u of instance %u, t %.9g) lies %.2g times the spread of §6's "
                "binary32 barycentrics from an edge of this ill-conditioned triangle", side_name(in, cand_oracle[c]),
                h->prim_id, h->instance_id, h->t, k);
            return;
        }
    }

    /* Unexplained: say what each side found. */
    char a[96], b[96];
    if (is_hit(o))
        snprintf(a, sizeof a, "triangle %u of instance %u at t %.9g", o->prim_id, o->instance_id, o->t);
    else
        snprintf(a, sizeof a, "a miss");
    if (et)
        snprintf(b, sizeof b, "triangle %u of instance %u at t %.9g", et->prim_id, et->instance_id, et->t);
    else
        snprintf(b, sizeof b, is_hit(e) ? "a hit (occluded) naming no triangle" : "a miss");
    double rel = 0;
    int parallel = 0;
    const rto_hit_record *h = cand[0] ? cand[0] : NULL;
    if (h && valid_tri(sc, h->instance_id, h->prim_id))
        rel = xc_edge_distance(sc, h->instance_id, h->prim_id, ray, &parallel);
    out->edge_rel = rel;
    set(out, XC_UNEXPLAINED, "the oracle found %s, %s %s; nearest edge %.3g (relative)", a, side_name(in, 0), b, rel);
}
