/* Validation of GPU hit dumps (DESIGN.md §6, §9): ray by ray, a GPU's 96-byte hit record against what the
 * conformance model of §9 allows (conform.h). A record equal to the oracle's passes at once. Otherwise a hit must
 * name a primitive that some conforming implementation hits, with t, u and v inside the intervals the model gives for
 * it, its instance's customIndex, hitGroup and objToWorld exactly, and no primitive that every conforming
 * implementation reaches and hits may lie before it; a miss must be the miss record of its ray, and no primitive may
 * be reached and hit by every conforming implementation. Each accepted difference is named by the freedom that
 * explains it (arithmetic, tie, edge, box, t-range, first-hit). Faults are classified (rto_hit_fault) and the primary
 * one is the highest-priority fault of the first wrong ray, so a report reads "bary at ray 1234" and not "hits
 * differ"; every class seen anywhere is listed too. */
#include "conform.h"
#include "core/tolerance.h"
#include "internal.h"
#include "report_internal.h"
#include "trace_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

const char *rto_hit_fault_name(rto_hit_fault f)
{
    switch (f) {
    case RTO_HIT_OK: return "none";
    case RTO_HIT_SIZE: return "size";
    case RTO_HIT_MISS_FLAG: return "miss-flag";
    case RTO_HIT_INSTANCE: return "instance";
    case RTO_HIT_PRIM: return "prim";
    case RTO_HIT_T: return "t";
    case RTO_HIT_BARY: return "bary";
    case RTO_HIT_CUSTOM_INDEX: return "custom-index";
    case RTO_HIT_HIT_GROUP: return "hit-group";
    case RTO_HIT_TRANSFORM: return "transform";
    }
    return "unknown";
}

#define HIT_FAULT_LAST RTO_HIT_TRANSFORM

/* The check (report->checks) that a fault class fails. */
static const char *check_of(rto_hit_fault f)
{
    switch (f) {
    case RTO_HIT_SIZE: return "size";
    case RTO_HIT_MISS_FLAG: return "miss";
    case RTO_HIT_INSTANCE:
    case RTO_HIT_PRIM: return "primitive";
    case RTO_HIT_T: return "t";
    case RTO_HIT_BARY: return "bary";
    default: return "instance-data";
    }
}

static const char *const check_names[] = {"size", "miss", "primitive", "t", "bary", "instance-data"};

/* ------------------------------------------------------------------------------------------------------------------ */
/* One ray's findings                                                                                                   */

/* A differing field, its fault class, and for the first finding of each class the sentence the summary uses. */
typedef struct finding {
    rto_hit_fault fault;
    char field[RTO_REPORT_NAME_MAX];
    rto_value expected, actual, diff, tolerance;
} finding;

/* Everything wrong with one ray: faults as a bit set over rto_hit_fault, the rows to list (a tie's rows first), and
 * the summary sentence of each fault class (only the first of a class is kept). */
typedef struct ray_result {
    unsigned faults;
    int freedom; /* an accepted difference: the freedom that explains it (freedom, below) */
    uint32_t nrows;
    finding rows[24]; /* at most: t, 2 bary, 2 IDs, 12 matrix values; or 4 ID rows + t of a miss, 2 bary, 12 matrix */
    char text[HIT_FAULT_LAST + 1][200];
    double bound[HIT_FAULT_LAST + 1]; /* the tolerance at the fault's first row; 0 when exact */
} ray_result;

static void add_row(ray_result *rr, rto_hit_fault f, const char *field, rto_value expected, rto_value actual,
                    rto_value diff, rto_value tolerance)
{
    if (rr->nrows >= sizeof rr->rows / sizeof rr->rows[0])
        return;
    finding *x = &rr->rows[rr->nrows++];
    x->fault = f;
    snprintf(x->field, sizeof x->field, "%s", field);
    x->expected = expected;
    x->actual = actual;
    x->diff = diff;
    x->tolerance = tolerance;
}

/* Records fault f of the ray; the first call for a class writes its sentence and bound. */
static void fault(ray_result *rr, rto_hit_fault f, double bound, const char *fmt, ...) RTO_PRINTF(4, 5);
static void fault(ray_result *rr, rto_hit_fault f, double bound, const char *fmt, ...)
{
    if (rr->faults & (1u << f))
        return;
    rr->faults |= 1u << f;
    rr->bound[f] = bound;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(rr->text[f], sizeof rr->text[f], fmt, ap);
    va_end(ap);
}

/* An ID row: indices as decimal with a signed difference, or (where either side is 0xFFFFFFFF, the miss value) as
 * bit patterns with their xor. */
static void id_row(ray_result *rr, rto_hit_fault f, const char *field, uint32_t expected, uint32_t actual)
{
    if (expected == UINT32_MAX || actual == UINT32_MAX)
        add_row(rr, f, field, rto__val_hex32(expected), rto__val_hex32(actual), rto__val_hex32(expected ^ actual),
                rto__val_none());
    else
        add_row(rr, f, field, rto__val_uint(expected), rto__val_uint(actual),
                rto__val_int((int64_t)actual - (int64_t)expected), rto__val_none());
}

static void float_row(ray_result *rr, rto_hit_fault f, const char *field, float expected, float actual,
                      double tolerance, int has_tolerance)
{
    add_row(rr, f, field, rto__val_f32(expected), rto__val_f32(actual), rto__val_f64((double)actual - (double)expected),
            has_tolerance ? rto__val_f64(tolerance) : rto__val_none());
}

/* The objToWorld element at column c, row r (WGSL's objToWorld[c][r]); the padding [c][3] is never compared. */
static void matrix_field(int c, int r, char field[RTO_REPORT_NAME_MAX])
{
    /* c and r are 0..3: one digit each (the casts tell the compiler so). */
    snprintf(field, RTO_REPORT_NAME_MAX, "objToWorld[%u][%u]", (unsigned)c & 3u, (unsigned)r & 3u);
}

/* A miss must be exactly the miss record of its ray (rto_hit_record_miss): t = tMax, the four IDs 0xFFFFFFFF, bary
 * and the matrix 0 (as numbers: -0 is 0). */
static void compare_miss(size_t i, const rto_wf_ray *ray, const rto_hit_record *g, ray_result *rr)
{
    if (!(g->t == ray->t_max)) {
        float_row(rr, RTO_HIT_T, "t", ray->t_max, g->t, 0, 0);
        fault(rr, RTO_HIT_T, 0, "ray %zu misses, but its miss record's t is %.9g instead of the ray's tMax %.9g", i,
              (double)g->t, (double)ray->t_max);
    }
    const struct {
        rto_hit_fault f;
        const char *field;
        uint32_t v;
    } ids[] = {
        {RTO_HIT_INSTANCE, "instanceId", g->instance_id},
        {RTO_HIT_PRIM, "primId", g->prim_id},
        {RTO_HIT_HIT_GROUP, "hitGroup", g->hit_group},
        {RTO_HIT_CUSTOM_INDEX, "customIndex", g->custom_index},
    };
    for (size_t k = 0; k < sizeof ids / sizeof ids[0]; k++) {
        if (ids[k].v == UINT32_MAX)
            continue;
        id_row(rr, ids[k].f, ids[k].field, UINT32_MAX, ids[k].v);
        fault(rr, ids[k].f, 0, "ray %zu misses, but its miss record's %s is 0x%08" PRIx32 " instead of 0xFFFFFFFF", i,
              ids[k].field, ids[k].v);
    }
    for (int k = 0; k < 2; k++) {
        if (g->bary[k] == 0.0f)
            continue;
        float_row(rr, RTO_HIT_BARY, k ? "bary.v" : "bary.u", 0.0f, g->bary[k], 0, 0);
        fault(rr, RTO_HIT_BARY, 0, "ray %zu misses, but its miss record's bary.%c is %.9g instead of 0", i,
              k ? 'v' : 'u', (double)g->bary[k]);
    }
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++) {
            if (g->obj_to_world[c][r] == 0.0f)
                continue;
            char field[RTO_REPORT_NAME_MAX];
            matrix_field(c, r, field);
            float_row(rr, RTO_HIT_TRANSFORM, field, 0.0f, g->obj_to_world[c][r], 0, 0);
            fault(rr, RTO_HIT_TRANSFORM, 0, "ray %zu misses, but its miss record's %s is %.9g instead of 0", i, field,
                  (double)g->obj_to_world[c][r]);
        }
}

/* What intersecting a record's claimed primitive again gives. */
typedef enum claim_kind {
    CLAIM_HIT = 0,      /* the ray hits it: th holds t, u, v */
    CLAIM_NO_INSTANCE,  /* instanceId out of range */
    CLAIM_NO_PRIM,      /* primId out of range for the instance's mesh */
    CLAIM_MASKED,       /* the instance's mask does not meet the ray's cull mask */
    CLAIM_MISSED        /* the triangle is missed (or culled by the ray's flags) */
} claim_kind;

static claim_kind reintersect(const rto_hits_check_desc *d, const rto_wf_ray *ray, uint32_t inst, uint32_t prim,
                              rto_tri_hit *th)
{
    /* Range first: a dump's IDs are untrusted, and an index past the scene must be a finding, not a read. */
    if (inst >= d->instance_count)
        return CLAIM_NO_INSTANCE;
    const rto_instance *in = &d->instances[inst];
    if (prim >= d->meshes[in->blas].triangle_count)
        return CLAIM_NO_PRIM;
    if (!(in->mask & ray->cull_mask))
        return CLAIM_MASKED;
    return rto_instance_triangle_hit(in, &d->meshes[in->blas], prim, ray, th) ? CLAIM_HIT : CLAIM_MISSED;
}

/* The rows naming where a GPU record's hit departs from the oracle's record e: missFlag, instanceId and primId where
 * they differ, as fault f's rows, or (prefix "accepted.") as an accepted difference's. */
static void departure_rows(ray_result *rr, rto_hit_fault f, const char *prefix, const rto_hit_record *e,
                           const rto_hit_record *g)
{
    char field[RTO_REPORT_NAME_MAX];
    if (e->miss_flag != g->miss_flag) {
        snprintf(field, sizeof field, "%smissFlag", prefix);
        id_row(rr, f, field, e->miss_flag, g->miss_flag);
    }
    if (e->instance_id != g->instance_id) {
        snprintf(field, sizeof field, "%sinstanceId", prefix);
        id_row(rr, f, field, e->instance_id, g->instance_id);
    }
    if (e->prim_id != g->prim_id) {
        snprintf(field, sizeof field, "%sprimId", prefix);
        id_row(rr, f, field, e->prim_id, g->prim_id);
    }
}

/* The fields a hit takes from its instance, exactly: customIndex, hitGroup (sbtOffset) and objToWorld. */
static void compare_instance_fields(size_t i, const rto_hit_record *ref, const rto_hit_record *g, ray_result *rr)
{
    if (g->custom_index != ref->custom_index) {
        id_row(rr, RTO_HIT_CUSTOM_INDEX, "customIndex", ref->custom_index, g->custom_index);
        fault(rr, RTO_HIT_CUSTOM_INDEX, 0, "ray %zu: customIndex %" PRIu32 ", but instance %" PRIu32 " has %" PRIu32,
              i, g->custom_index, ref->instance_id, ref->custom_index);
    }
    if (g->hit_group != ref->hit_group) {
        id_row(rr, RTO_HIT_HIT_GROUP, "hitGroup", ref->hit_group, g->hit_group);
        fault(rr, RTO_HIT_HIT_GROUP, 0, "ray %zu: hitGroup %" PRIu32 ", but instance %" PRIu32 " has sbtOffset %" PRIu32,
              i, g->hit_group, ref->instance_id, ref->hit_group);
    }
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++) {
            if (g->obj_to_world[c][r] == ref->obj_to_world[c][r])
                continue;
            char field[RTO_REPORT_NAME_MAX];
            matrix_field(c, r, field);
            float_row(rr, RTO_HIT_TRANSFORM, field, ref->obj_to_world[c][r], g->obj_to_world[c][r], 0, 0);
            fault(rr, RTO_HIT_TRANSFORM, 0, "ray %zu: %s = %.9g, but instance %" PRIu32 "'s objToWorld (column-major "
                  "mat4x3) holds %.9g there", i, field, (double)g->obj_to_world[c][r], ref->instance_id,
                  (double)ref->obj_to_world[c][r]);
        }
}

/* objToWorld equal element by element (the padding [c][3] aside). */
static int same_matrix(const rto_hit_record *a, const rto_hit_record *b)
{
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            if (memcmp(&a->obj_to_world[c][r], &b->obj_to_world[c][r], sizeof(float)))
                return 0;
    return 1;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The model's verdict on one ray                                                                                      */

/* The freedoms of the model (DESIGN.md §9) that explain an accepted record differing from the oracle's. */
typedef enum freedom {
    FR_NONE = 0,  /* the oracle's record, bit for bit */
    FR_ARITH = 1, /* the same primitive, t or barycentrics within the model's bounds: fused multiply-adds, division */
    FR_TIE = 2,   /* another primitive at a t the model cannot tell apart from the oracle's */
    FR_EDGE = 3,  /* whether a triangle is hit is not certain: the ray passes within rounding of an edge or a vertex,
                   * or runs nearly parallel to the plane */
    FR_BOX = 4,   /* the triangle is certainly hit but not certainly reached: a box test at its edge */
    FR_RANGE = 5, /* the hit t lies within rounding of tMin or tMax */
    FR_ANY = 6    /* a TERMINATE_ON_FIRST_HIT ray ending on another hit than the oracle's (only hit / miss is defined) */
} freedom;
#define FREEDOM_COUNT 7

static const char *const freedom_names[FREEDOM_COUNT] = {"none", "arithmetic", "tie", "edge", "box", "t-range",
                                                         "first-hit"};
static const char *const freedom_facts[FREEDOM_COUNT] = {"", "accepted_arithmetic", "ties", "accepted_edge",
                                                         "accepted_box", "accepted_t_range", "accepted_first_hit"};

/* One check: the description, the scene as the model reads it, and the work the search for primitives that every
 * conforming implementation must find has done (triangle tests, bounded by SCAN_BUDGET so that a dump of wrong
 * records on a large scene cannot make the check quadratic; past it, such rays are accepted unverified and the
 * summary says so). */
typedef struct hcheck {
    const rto_hits_check_desc *d;
    int records_only; /* rto__hits_check_records: no triangles to re-intersect */
    rto_scene scene;
    cf_scene cs;
    uint64_t scan_tests;
    size_t unverified;
} hcheck;

#define SCAN_BUDGET (UINT64_C(1) << 27)

/* A search of every primitive for one that every conforming implementation reaches and hits below bound (other than
 * skip_inst, skip_prim). */
static int scan_must_find(hcheck *c, const rto_wf_ray *ray, float bound, uint32_t skip_inst, uint32_t skip_prim,
                          uint32_t *found_inst, uint32_t *found_prim, cf_prim *found)
{
    const rto_hits_check_desc *d = c->d;
    for (uint32_t inst = 0; inst < d->instance_count; inst++) {
        const rto_instance *in = &d->instances[inst];
        const rto_mesh *m = &d->meshes[in->blas];
        if (!(in->mask & ray->cull_mask))
            continue;
        if (c->scan_tests + m->triangle_count > SCAN_BUDGET) {
            c->unverified++;
            return 0;
        }
        c->scan_tests += m->triangle_count;
        float o[3], dir[3];
        rto_ray_to_object(&in->world_to_obj, ray->origin, ray->dir, o, dir);
        for (uint32_t prim = 0; prim < m->triangle_count; prim++) {
            /* every conforming implementation hits such a primitive, the oracle's arithmetic included: a cheap
             * filter before the model's intervals */
            rto_tri_hit th;
            if ((inst == skip_inst && prim == skip_prim) ||
                !rto__mesh_triangle_hit(m, prim, o, dir, ray->t_min, bound, ray->flags, &th))
                continue;
            cf_prim_eval(&c->cs, inst, prim, ray, bound, found);
            if (cf_must_find(found)) {
                *found_inst = inst;
                *found_prim = prim;
                return 1;
            }
        }
    }
    return 0;
}

/* A primitive every conforming implementation must find below bound, other than the claim: the oracle's own hit
 * first (the usual one), then a search. */
static int must_find_other(hcheck *c, const rto_wf_ray *ray, const rto_hit_record *e, float bound, uint32_t claim_inst,
                           uint32_t claim_prim, uint32_t *inst, uint32_t *prim, cf_prim *p)
{
    if (e->miss_flag)
        return 0; /* a conforming oracle found nothing: nothing is certain (§9) */
    if (!(e->t < bound))
        return 0; /* the oracle's hit lies at or beyond the answer, so nothing certain lies before it (§9) */
    if (e->instance_id != claim_inst || e->prim_id != claim_prim) {
        cf_prim_eval(&c->cs, e->instance_id, e->prim_id, ray, bound, p);
        if (cf_must_find(p)) {
            *inst = e->instance_id;
            *prim = e->prim_id;
            return 1;
        }
    }
    return scan_must_find(c, ray, bound, claim_inst, claim_prim, inst, prim, p);
}

/* Which freedom lets a conforming implementation miss primitive p (hit-or-miss not certain, reach not certain, or
 * its t near the ray's range ends). */
static freedom why_missable(const cf_prim *p, const rto_wf_ray *ray, float bound)
{
    if (p->hit != CF_CERTAIN)
        return p->tri.t.lo < (double)ray->t_min || p->tri.t.hi >= (double)bound ? FR_RANGE : FR_EDGE;
    return FR_BOX;
}

static void interval_text(cf_iv iv, char *buf, size_t cap)
{
    snprintf(buf, cap, "[%.9g, %.9g]", iv.lo, iv.hi);
}

/* The distance from x to the interval's far end: what a row shows as the tolerance. */
static double reach(cf_iv iv, double ref)
{
    const double a = fabs(ref - iv.lo), b = fabs(iv.hi - ref);
    return a > b ? a : b;
}

/* A claimed hit's values against the intervals of its primitive (t, u, v), its instance's exact fields, and the
 * ray's range. */
static void compare_claim(size_t i, const rto_wf_ray *ray, const rto_hit_record *g, const cf_prim *p,
                          const rto_hit_record *ref, int first_hit, ray_result *rr)
{
    char iv[96];
    if (!cf_in(p->tri.t, g->t) || !(g->t >= ray->t_min && g->t < ray->t_max)) {
        interval_text(p->tri.t, iv, sizeof iv);
        float_row(rr, RTO_HIT_T, "t", ref->t, g->t, reach(p->tri.t, ref->t), 1);
        fault(rr, RTO_HIT_T, reach(p->tri.t, ref->t),
              "ray %zu: t = %.9g on triangle %" PRIu32 " of instance %" PRIu32 ", where a conforming implementation "
              "computes t in %s within [tMin %.9g, tMax %.9g)", i, (double)g->t, g->prim_id, g->instance_id, iv,
              (double)ray->t_min, (double)ray->t_max);
    }
    if (first_hit)
        return; /* only hit / miss and the claim's t are defined */
    const cf_iv bary[2] = {p->tri.u, p->tri.v};
    for (int k = 0; k < 2; k++) {
        if (cf_in(bary[k], g->bary[k]))
            continue;
        interval_text(bary[k], iv, sizeof iv);
        float_row(rr, RTO_HIT_BARY, k ? "bary.v" : "bary.u", ref->bary[k], g->bary[k], reach(bary[k], ref->bary[k]),
                  1);
        fault(rr, RTO_HIT_BARY, reach(bary[k], ref->bary[k]),
              "ray %zu: bary.%c = %.9g on triangle %" PRIu32 " of instance %" PRIu32 ", where a conforming "
              "implementation computes it in %s", i, k ? 'v' : 'u', (double)g->bary[k], g->prim_id, g->instance_id, iv);
    }
    compare_instance_fields(i, ref, g, rr);
}

/* A GPU record against the expected one, field by field, where the scene's primitives are not triangles
 * (rto__hits_check_records): missFlag, instanceId, primId, customIndex, hitGroup and objToWorld exact, t and the
 * barycentrics within §9's fixed rules (core/tolerance.h). A record of another outcome or primitive is reported by its
 * IDs alone. */
static void compare_records(size_t i, const rto_hit_record *e, const rto_hit_record *g, ray_result *rr)
{
    if (e->miss_flag != g->miss_flag ||
        (!g->miss_flag && (e->instance_id != g->instance_id || e->prim_id != g->prim_id))) {
        const rto_hit_fault f = e->miss_flag != g->miss_flag         ? RTO_HIT_MISS_FLAG
                                : e->instance_id != g->instance_id ? RTO_HIT_INSTANCE
                                                                   : RTO_HIT_PRIM;
        departure_rows(rr, f, "", e, g);
        if (g->miss_flag)
            fault(rr, f, 0, "ray %zu: the GPU reports a miss; the oracle hits primitive %" PRIu32 " of instance "
                  "%" PRIu32 " at t = %.9g", i, e->prim_id, e->instance_id, (double)e->t);
        else if (e->miss_flag)
            fault(rr, f, 0, "ray %zu: the GPU reports a hit on primitive %" PRIu32 " of instance %" PRIu32 " at t = "
                  "%.9g; the oracle's ray misses", i, g->prim_id, g->instance_id, (double)g->t);
        else
            fault(rr, f, 0, "ray %zu: the GPU hits primitive %" PRIu32 " of instance %" PRIu32 " at t = %.9g, the "
                  "oracle primitive %" PRIu32 " of instance %" PRIu32 " at t = %.9g", i, g->prim_id, g->instance_id,
                  (double)g->t, e->prim_id, e->instance_id, (double)e->t);
        return;
    }
    const struct {
        rto_hit_fault f;
        const char *field;
        uint32_t e, a;
    } ids[] = {
        {RTO_HIT_INSTANCE, "instanceId", e->instance_id, g->instance_id}, /* a miss record's: 0xFFFFFFFF */
        {RTO_HIT_PRIM, "primId", e->prim_id, g->prim_id},
        {RTO_HIT_CUSTOM_INDEX, "customIndex", e->custom_index, g->custom_index},
        {RTO_HIT_HIT_GROUP, "hitGroup", e->hit_group, g->hit_group},
    };
    for (size_t k = 0; k < sizeof ids / sizeof ids[0]; k++) {
        if (ids[k].e == ids[k].a)
            continue;
        id_row(rr, ids[k].f, ids[k].field, ids[k].e, ids[k].a);
        fault(rr, ids[k].f, 0, "ray %zu: %s is %" PRIu32 ", the oracle's %" PRIu32, i, ids[k].field, ids[k].a,
              ids[k].e);
    }
    const double tt = rto__tol_t(e->t);
    if (!rto__tol_t_close(e->t, g->t)) {
        float_row(rr, RTO_HIT_T, "t", e->t, g->t, tt, 1);
        fault(rr, RTO_HIT_T, tt, "ray %zu: t = %.9g, the oracle's %.9g (|diff| %.3g > %.3g = 1e-5 max(1, |t|))", i,
              (double)g->t, (double)e->t, fabs((double)g->t - (double)e->t), tt);
    }
    for (int k = 0; k < 2; k++) {
        if (rto__tol_bary_close(e->bary[k], g->bary[k]))
            continue;
        float_row(rr, RTO_HIT_BARY, k ? "bary.v" : "bary.u", e->bary[k], g->bary[k], RTO__TOL_BARY, 1);
        fault(rr, RTO_HIT_BARY, RTO__TOL_BARY, "ray %zu: bary.%c = %.9g, the oracle's %.9g (|diff| %.3g > 1e-4)", i,
              k ? 'v' : 'u', (double)g->bary[k], (double)e->bary[k], fabs((double)g->bary[k] - (double)e->bary[k]));
    }
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++) {
            if (g->obj_to_world[c][r] == e->obj_to_world[c][r])
                continue;
            char field[RTO_REPORT_NAME_MAX];
            matrix_field(c, r, field);
            float_row(rr, RTO_HIT_TRANSFORM, field, e->obj_to_world[c][r], g->obj_to_world[c][r], 0, 0);
            fault(rr, RTO_HIT_TRANSFORM, 0, "ray %zu: %s = %.9g, the oracle's %.9g", i, field,
                  (double)g->obj_to_world[c][r], (double)e->obj_to_world[c][r]);
        }
    if (!rr->faults)
        rr->freedom = FR_ARITH;
}

static void compare_ray(hcheck *c, size_t i, ray_result *rr)
{
    const rto_hits_check_desc *d = c->d;
    memset(rr, 0, sizeof *rr);
    const rto_wf_ray *ray = &d->rays[i];
    const rto_hit_record *e = &d->expected[i], *g = &d->gpu[i];
    if (!memcmp(e, g, offsetof(rto_hit_record, obj_to_world)) && same_matrix(e, g))
        return; /* the oracle's record (objToWorld's padding aside) */
    if (g->miss_flag > 1) {
        id_row(rr, RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, g->miss_flag);
        fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: missFlag is %" PRIu32 ", neither 0 (hit) nor 1 (miss)", i,
              g->miss_flag);
        return;
    }
    if (c->records_only) {
        compare_records(i, e, g, rr);
        return;
    }
    const int first_hit = (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
    uint32_t fi = 0, fp = 0;
    cf_prim other, claim;
    char iv[96];
    if (g->miss_flag) {
        /* a miss: no primitive may be found by every conforming implementation */
        if (must_find_other(c, ray, e, ray->t_max, UINT32_MAX, UINT32_MAX, &fi, &fp, &other)) {
            interval_text(other.tri.t, iv, sizeof iv);
            id_row(rr, RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, g->miss_flag);
            fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: the GPU reports a miss, but every conforming implementation "
                  "reaches and hits triangle %" PRIu32 " of instance %" PRIu32 " (t in %s)", i, fp, fi, iv);
            return;
        }
        compare_miss(i, ray, g, rr);
        if (!e->miss_flag) { /* the oracle's hit is one a conforming implementation may miss */
            cf_prim_eval(&c->cs, e->instance_id, e->prim_id, ray, ray->t_max, &other);
            rr->freedom = why_missable(&other, ray, ray->t_max);
            id_row(rr, RTO_HIT_OK, "accepted.missFlag", e->miss_flag, g->miss_flag);
        }
        return;
    }
    /* a hit: its primitive must be one a conforming implementation may hit, with these values */
    const rto_hit_fault idf = e->miss_flag                       ? RTO_HIT_MISS_FLAG
                              : g->instance_id != e->instance_id ? RTO_HIT_INSTANCE
                                                                 : RTO_HIT_PRIM;
    cf_prim_eval(&c->cs, g->instance_id, g->prim_id, ray, ray->t_max, &claim);
    if (!claim.valid || claim.masked || claim.hit == CF_NEVER) {
        departure_rows(rr, idf, "", e, g);
        char why[200];
        if (!claim.valid && g->instance_id >= d->instance_count)
            snprintf(why, sizeof why, "which does not exist (the scene has %" PRIu32 " instances)", d->instance_count);
        else if (!claim.valid)
            snprintf(why, sizeof why, "which does not exist (mesh %" PRIu32 " of instance %" PRIu32 " has %" PRIu32
                     " triangles)", d->instances[g->instance_id].blas, g->instance_id,
                     d->meshes[d->instances[g->instance_id].blas].triangle_count);
        else if (claim.masked)
            snprintf(why, sizeof why, "whose instance's mask 0x%02" PRIx32 " does not meet the ray's cull mask 0x%02"
                     PRIx32, d->instances[g->instance_id].mask, ray->cull_mask);
        else {
            interval_text(claim.tri.t, iv, sizeof iv);
            snprintf(why, sizeof why, "which no conforming implementation hits (or every one culls) within [tMin, "
                     "tMax) (t in %s)", iv);
        }
        if (e->miss_flag)
            fault(rr, idf, 0, "ray %zu: the GPU reports a hit on triangle %" PRIu32 " of instance %" PRIu32 ", %s; "
                  "the oracle's ray misses", i, g->prim_id, g->instance_id, why);
        else
            fault(rr, idf, 0, "ray %zu: the GPU claims triangle %" PRIu32 " of instance %" PRIu32 ", %s; the oracle "
                  "hits triangle %" PRIu32 " of instance %" PRIu32 " at t = %.9g", i, g->prim_id, g->instance_id, why,
                  e->prim_id, e->instance_id, (double)e->t);
        return;
    }
    if (e->miss_flag && cf_must_find(&claim)) { /* then no conforming implementation misses: nor could the oracle */
        interval_text(claim.tri.t, iv, sizeof iv);
        id_row(rr, RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, g->miss_flag);
        fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: the expected record is a miss (the bundle does not hold the oracle's "
              "records), but every conforming implementation reaches and hits triangle %" PRIu32 " of instance %" PRIu32
              " (t in %s), as the GPU does", i, g->prim_id, g->instance_id, iv);
        return;
    }
    const int same_prim = !e->miss_flag && e->instance_id == g->instance_id && e->prim_id == g->prim_id;
    rto_hit_record ref = *e;
    if (!same_prim) { /* the oracle's arithmetic on the claim (hit or not): the values the rows show */
        rto_tri_hit th = {0, 0, 0, 0};
        rto_instance_triangle_hit(&d->instances[g->instance_id], &d->meshes[d->instances[g->instance_id].blas],
                                  g->prim_id, ray, &th);
        ref = rto_hit_record_make(&d->instances[g->instance_id], g->instance_id, g->prim_id, &th);
    }
    compare_claim(i, ray, g, &claim, &ref, first_hit, rr);
    if (rr->faults & (1u << RTO_HIT_T))
        return; /* a wrong t says nothing about what lies before the answer */
    /* nothing every conforming implementation finds may lie before the answer (a first hit may be any hit) */
    if (!first_hit && must_find_other(c, ray, e, g->t, g->instance_id, g->prim_id, &fi, &fp, &other)) {
        departure_rows(rr, idf, "", e, g);
        interval_text(other.tri.t, iv, sizeof iv);
        fault(rr, idf, 0, "ray %zu: the GPU claims triangle %" PRIu32 " of instance %" PRIu32 " at t = %.9g, but "
              "every conforming implementation reaches and hits triangle %" PRIu32 " of instance %" PRIu32
              " before it (t in %s)", i, g->prim_id, g->instance_id, (double)g->t, fp, fi, iv);
        return;
    }
    if (rr->faults)
        return;
    /* accepted: name the freedom */
    if (same_prim) {
        rr->freedom = FR_ARITH;
    } else if (e->miss_flag) { /* the oracle missed the claim: a conforming implementation may hit it */
        rr->freedom = why_missable(&claim, ray, ray->t_max);
    } else if (first_hit) {
        rr->freedom = FR_ANY;
    } else {
        cf_prim_eval(&c->cs, e->instance_id, e->prim_id, ray, ray->t_max, &other);
        if (other.tri.t.lo <= claim.tri.t.hi && claim.tri.t.lo <= other.tri.t.hi)
            rr->freedom = FR_TIE; /* t the model cannot tell apart */
        else if (g->t < e->t)
            rr->freedom = why_missable(&claim, ray, e->t); /* the oracle did not find the nearer claim */
        else {
            cf_prim_eval(&c->cs, e->instance_id, e->prim_id, ray, g->t, &other);
            rr->freedom = why_missable(&other, ray, g->t); /* the GPU went past the oracle's hit */
        }
    }
    if (!same_prim) {
        departure_rows(rr, RTO_HIT_OK, "accepted.", e, g);
        float_row(rr, RTO_HIT_OK, "accepted.t", e->t, g->t, 0, 0);
    }
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Input                                                                                                                */

/* The scene: every instance names a mesh, every mesh's indices name its vertices, so that re-intersecting any
 * in-range primitive reads only what exists. */
static rto_status check_scene(const rto_hits_check_desc *d, rto_msg *msg)
{
    if ((d->instance_count && !d->instances) || (d->mesh_count && !d->meshes))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL instances or meshes");
    for (uint32_t m = 0; m < d->mesh_count; m++) {
        const rto_mesh *mesh = &d->meshes[m];
        if ((mesh->triangle_count && !mesh->indices) || (mesh->vertex_count && !mesh->positions))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %" PRIu32 " has NULL indices or positions", m);
        for (size_t k = 0; k < 3 * (size_t)mesh->triangle_count; k++)
            if (mesh->indices[k] >= mesh->vertex_count)
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "mesh %" PRIu32 ": index %zu is %" PRIu32 " (the mesh has %" PRIu32 " vertices)", m, k,
                                mesh->indices[k], mesh->vertex_count);
    }
    for (uint32_t i = 0; i < d->instance_count; i++)
        if (d->instances[i].blas >= d->mesh_count)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %" PRIu32 " names mesh %" PRIu32 " of %" PRIu32, i,
                            d->instances[i].blas, d->mesh_count);
    return RTO_OK;
}

/* Whether two records hold the same hit, field by field (as numbers: -0 is 0). */
static int same_record(const rto_hit_record *a, const rto_hit_record *b)
{
    if (!(a->t == b->t) || !(a->bary[0] == b->bary[0]) || !(a->bary[1] == b->bary[1]) ||
        a->instance_id != b->instance_id || a->prim_id != b->prim_id || a->hit_group != b->hit_group ||
        a->custom_index != b->custom_index || a->miss_flag != b->miss_flag)
        return 0;
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            if (a->obj_to_world[c][r] != b->obj_to_world[c][r])
                return 0;
    return 1;
}

/* The rays and the oracle's records: what the GPU's are compared with must itself be right, so an inconsistent
 * expected record (a hand-edited bundle) is refused as input rather than blamed on the GPU. Each expected hit must
 * be the hit record of its primitive, intersected again here; each expected miss the miss record of its ray. */
static rto_status check_expected(const rto_hits_check_desc *d, rto_msg *msg)
{
    rto_status s = rto__rays_check(d->rays, d->ray_count, msg); /* the rays rto_trace would refuse */
    if (s)
        return s;
    for (size_t i = 0; i < d->ray_count; i++) {
        const rto_wf_ray *ray = &d->rays[i];
        const rto_hit_record *e = &d->expected[i];
        if (e->miss_flag > 1)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "expected record %zu: missFlag %" PRIu32
                            " is neither 0 nor 1", i, e->miss_flag);
        if (e->miss_flag) {
            const rto_hit_record m = rto_hit_record_miss(ray->t_max);
            if (!(e->t == m.t) || !same_record(e, &m))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "expected record %zu is a miss but not the miss record of ray %zu (t = tMax, IDs "
                                "0xFFFFFFFF, bary and objToWorld 0)", i, i);
            continue;
        }
        rto_tri_hit th = {0, 0, 0, 0};
        const claim_kind k = reintersect(d, ray, e->instance_id, e->prim_id, &th);
        if (k != CLAIM_HIT)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "expected record %zu names triangle %" PRIu32 " of instance %" PRIu32 ", %s", i,
                            e->prim_id, e->instance_id,
                            k == CLAIM_NO_INSTANCE ? "an instance the scene does not have"
                            : k == CLAIM_NO_PRIM   ? "a triangle its mesh does not have"
                            : k == CLAIM_MASKED    ? "an instance the ray's cull mask excludes"
                                                   : "which the ray does not hit");
        const rto_hit_record own = rto_hit_record_make(&d->instances[e->instance_id], e->instance_id, e->prim_id, &th);
        if (!same_record(e, &own))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "expected record %zu is not the hit record of triangle %" PRIu32 " of instance %" PRIu32
                            " (t, bary, customIndex, hitGroup or objToWorld differ)", i, e->prim_id, e->instance_id);
    }
    return RTO_OK;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The report                                                                                                           */

static void report_rows(rto_report *r, size_t i, const ray_result *rr)
{
    for (uint32_t k = 0; k < rr->nrows; k++) {
        const finding *x = &rr->rows[k];
        rto_report_row *row = rto__report_row_add(r, i, x->field);
        if (!row)
            return;
        row->expected = x->expected;
        row->actual = x->actual;
        row->diff = x->diff;
        row->tolerance = x->tolerance;
    }
}

/* rto_hits_check (records_only 0) and rto__hits_check_records (1). */
static rto_status hits_check(const rto_hits_check_desc *d, int records_only, rto_report *r, rto_msg *msg)
{
    if (!d || !r)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL descriptor or report");
    rto__report_begin(r, "check-hits");
    for (size_t k = 0; k < sizeof check_names / sizeof check_names[0]; k++)
        rto__report_add_check(r, check_names[k]);
    rto__report_table(r, "hit records", "ray");
    if (records_only)
        snprintf(r->tolerance, sizeof r->tolerance,
                 "no triangles to re-intersect: t within 1e-5 max(1, |t|), u, v within 1e-4 of the expected record "
                 "(§9); IDs, customIndex, hitGroup, missFlag, objToWorld exact");
    else
        snprintf(r->tolerance, sizeof r->tolerance,
                 "§9's conformance model (binary32 correctly rounded, a*b+c fused or not, division 2.5 ulp): t, u, v "
                 "in its intervals; IDs, customIndex, hitGroup, missFlag, objToWorld exact");
    if ((d->ray_count && (!d->rays || !d->expected)) || (d->gpu_count && !d->gpu))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL rays, expected records or GPU records");
    rto_status s = RTO_OK;
    if (!records_only && !(s = check_scene(d, msg)))
        s = check_expected(d, msg);
    if (s)
        return s;

    const size_t n = d->ray_count, gn = d->gpu_count, m = n < gn ? n : gn;
    size_t hits = 0, first_hit = 0, wrong = 0;
    for (size_t i = 0; i < n; i++) {
        hits += !d->expected[i].miss_flag;
        first_hit += (d->rays[i].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
    }
    if (records_only)
        snprintf(r->context, sizeof r->context,
                 "%zu rays (the oracle: %zu hits, %zu misses), GPU dump of %zu records; records compared field by "
                 "field (no triangles to re-intersect)", n, hits, n - hits, gn);
    else
        snprintf(r->context, sizeof r->context,
                 "%zu rays (the oracle: %zu hits, %zu misses), GPU dump of %zu records; %" PRIu32 " instance%s, %"
                 PRIu32 " mesh%s", n, hits, n - hits, gn, d->instance_count, d->instance_count == 1 ? "" : "s",
                 d->mesh_count, d->mesh_count == 1 ? "" : "es");
    rto__report_fact(r, "rays", (int64_t)n);
    rto__report_fact(r, "gpu_records", (int64_t)gn);
    rto__report_fact(r, "hits", (int64_t)hits);
    rto__report_fact(r, "misses", (int64_t)(n - hits));
    rto__report_fact(r, "first_hit_rays", (int64_t)first_hit);

    if (gn != n) {
        /* Reported at the first ray without a record (or the first record without a ray); the records both sides
         * have are still compared, so the other fault classes of a short dump are listed too. */
        rto__report_mark(r, "size", RTO_CHECK_FAILED);
        rto__report_claim(r, RTO_HIT_SIZE, rto_hit_fault_name(RTO_HIT_SIZE));
        rto__report_at(r, "ray", (int64_t)m);
        rto__report_summary(r, "size: the GPU dump holds %zu hit records for %zu rays (the first %s: ray %zu)", gn, n,
                           gn < n ? "ray without a record" : "record without a ray", m);
        rto_report_row *row = rto__report_row_add(r, m, "records");
        if (row) {
            row->expected = rto__val_uint(n);
            row->actual = rto__val_uint(gn);
            row->diff = rto__val_int((int64_t)gn - (int64_t)n);
        }
    } else {
        rto__report_mark(r, "size", RTO_CHECK_PASSED);
    }

    hcheck c = {.d = d, .records_only = records_only};
    c.scene.meshes = (rto_mesh *)d->meshes; /* read only: the model takes a const rto_scene */
    c.scene.mesh_count = d->mesh_count;
    c.scene.instances = (rto_instance *)d->instances;
    c.scene.instance_count = d->instance_count;
    if (!records_only && (s = cf_scene_init(&c.cs, &c.scene, msg)))
        return s;
    size_t accepted[FREEDOM_COUNT] = {0}, first_at[FREEDOM_COUNT] = {0};
    ray_result rr;
    for (size_t i = 0; i < m; i++) {
        compare_ray(&c, i, &rr);
        if (!rr.faults) {
            if (rr.freedom && !accepted[rr.freedom]++)
                first_at[rr.freedom] = i;
            /* a passing report lists the rays a freedom other than arithmetic explains */
            if (rr.freedom > FR_ARITH && r->code == RTO_HIT_OK)
                report_rows(r, i, &rr);
            continue;
        }
        wrong++;
        int primary = 0;
        rto_hit_fault first = RTO_HIT_OK;
        for (int f = RTO_HIT_SIZE; f <= HIT_FAULT_LAST; f++) {
            if (!(rr.faults & (1u << f)))
                continue;
            rto__report_mark(r, check_of((rto_hit_fault)f), RTO_CHECK_FAILED);
            if (rto__report_claim(r, f, rto_hit_fault_name((rto_hit_fault)f))) {
                primary = 1;
                first = (rto_hit_fault)f;
            }
        }
        if (primary) {
            rto__report_at(r, "ray", (int64_t)i);
            rto__report_summary(r, "%s: %s", rto_hit_fault_name(first), rr.text[first]);
            r->tolerance_bound = rr.bound[first];
        }
        report_rows(r, i, &rr); /* the primary ray's rows, then those of later wrong rays while there is room */
    }
    cf_scene_free(&c.cs);
    for (size_t k = 0; k < sizeof check_names / sizeof check_names[0]; k++)
        rto__report_mark(r, check_names[k], RTO_CHECK_PASSED); /* FAILED is sticky */
    size_t differ = 0;
    for (int f = FR_ARITH; f < FREEDOM_COUNT; f++) {
        rto__report_fact(r, freedom_facts[f], (int64_t)accepted[f]);
        differ += accepted[f];
    }
    rto__report_fact(r, "accepted_differences", (int64_t)differ);
    rto__report_fact(r, "unverified", (int64_t)c.unverified);
    rto__report_fact(r, "wrong_rays", (int64_t)wrong);
    char freedoms[320] = "";
    size_t len = 0;
    for (int f = FR_ARITH; f < FREEDOM_COUNT && len < sizeof freedoms; f++)
        if (accepted[f])
            len += (size_t)snprintf(freedoms + len, sizeof freedoms - len, "%s%zu %s (the first at ray %zu)",
                                    len ? ", " : "", accepted[f], freedom_names[f], first_at[f]);
    if (r->code != RTO_HIT_OK) {
        if (wrong)
            rto__report_append(r, "; %zu of %zu compared rays wrong", wrong, m);
        if (differ)
            rto__report_append(r, "; accepted as §9's model allows: %s", freedoms);
        if (c.unverified)
            rto__report_append(r, "; %zu ray(s) accepted unverified (the search for certain hits stopped after %" PRIu64
                              " triangle tests)", c.unverified, c.scan_tests);
        return RTO_ERR_MISMATCH;
    }
    rto__report_summary(r, "ok: %zu rays: %zu equal to the oracle's records", n, n - differ);
    if (differ)
        rto__report_append(r, ", the others as §9's model allows: %s", freedoms);
    if (c.unverified)
        rto__report_append(r, "; %zu ray(s) accepted unverified (the search for certain hits stopped after %" PRIu64
                          " triangle tests)", c.unverified, c.scan_tests);
    return RTO_OK;
}

rto_status rto_hits_check(const rto_hits_check_desc *d, rto_report *r, rto_msg *msg)
{
    return hits_check(d, 0, r, msg);
}

rto_status rto__hits_check_records(const rto_hits_check_desc *d, rto_report *r, rto_msg *msg)
{
    return hits_check(d, 1, r, msg);
}
