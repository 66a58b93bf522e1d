/* Validation of GPU hit dumps (DESIGN.md §6, §9): ray by ray, a GPU's 96-byte hit record against the oracle's. IDs,
 * customIndex, hitGroup, missFlag and the 12 values of objToWorld compare exactly; t and the barycentrics within the
 * §9 tolerances. Two primitives at the same distance make the closest hit ambiguous (a ray through a shared edge hits
 * both triangles at one t, and which one a traversal keeps depends on its order), so a record naming another
 * primitive than the oracle's is not wrong by itself: the claimed primitive is intersected again with the same ray,
 * exactly as traversal does, and if it gives the oracle's t within tolerance the record is a tie, accepted, counted
 * and listed, and then held to that primitive's own values. Faults are classified (rto_hit_fault) and the primary
 * one is the highest-priority fault of the first wrong ray, so a report reads "bary at ray 1234" and not "hits
 * differ"; every class seen anywhere is listed too. */
#include "crosscheck.h"
#include "report_internal.h"
#include "trace_internal.h"

#include <inttypes.h>
#include <math.h>
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
#define BARY_TOLERANCE 1e-4

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

/* §9: |dt| <= 1e-5 max(1, |t|), relative to the reference t. In binary64, where the bound and the difference of two
 * binary32 values are exact enough not to move the boundary. */
static double t_tolerance(float t)
{
    const double a = fabs((double)t);
    return 1e-5 * (a > 1.0 ? a : 1.0);
}

/* Whether actual is within the t tolerance of ref; a NaN or infinity never is. */
static int t_close(float actual, float ref) { return fabs((double)actual - (double)ref) <= t_tolerance(ref); }

static int bary_close(float actual, float ref) { return fabs((double)actual - (double)ref) <= BARY_TOLERANCE; }

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
    int tie, grazing;
    uint32_t nrows;
    finding rows[24]; /* at most: 3 tie rows, t, 2 bary, 2 IDs, 12 matrix values; or 4 ID rows + t of a miss */
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
        add_row(rr, f, field, rto_val_hex32(expected), rto_val_hex32(actual), rto_val_hex32(expected ^ actual),
                rto_val_none());
    else
        add_row(rr, f, field, rto_val_uint(expected), rto_val_uint(actual),
                rto_val_int((int64_t)actual - (int64_t)expected), rto_val_none());
}

static void float_row(ray_result *rr, rto_hit_fault f, const char *field, float expected, float actual,
                      double tolerance, int has_tolerance)
{
    add_row(rr, f, field, rto_val_f32(expected), rto_val_f32(actual), rto_val_f64((double)actual - (double)expected),
            has_tolerance ? rto_val_f64(tolerance) : rto_val_none());
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

/* Why a claimed primitive is not the oracle's hit, as the end of a sentence. */
static void claim_why(const rto_hits_check_desc *d, const rto_wf_ray *ray, const rto_hit_record *g, claim_kind k,
                      const rto_tri_hit *th, float ref_t, const char *ref_name, char *buf, size_t cap)
{
    switch (k) {
    case CLAIM_NO_INSTANCE:
        snprintf(buf, cap, "which does not exist (the scene has %" PRIu32 " instances)", d->instance_count);
        return;
    case CLAIM_NO_PRIM:
        snprintf(buf, cap, "which does not exist (mesh %" PRIu32 " of instance %" PRIu32 " has %" PRIu32 " triangles)",
                 d->instances[g->instance_id].blas, g->instance_id,
                 d->meshes[d->instances[g->instance_id].blas].triangle_count);
        return;
    case CLAIM_MASKED:
        snprintf(buf, cap, "whose instance's mask 0x%02" PRIx32 " does not meet the ray's cull mask 0x%02" PRIx32,
                 d->instances[g->instance_id].mask, ray->cull_mask);
        return;
    case CLAIM_MISSED: snprintf(buf, cap, "which the ray misses (or culls)"); return;
    case CLAIM_HIT: break;
    }
    snprintf(buf, cap, "which the ray hits at t = %.9g, not within %.3g of %s t = %.9g", (double)th->t,
             t_tolerance(ref_t), ref_name, (double)ref_t);
}

/* A record naming another primitive than the oracle's that is not a tie: `instance` if the instance differs, else
 * `prim`, with the IDs and the claimed primitive's own t as rows. */
static void wrong_primitive(const rto_hits_check_desc *d, size_t i, const rto_wf_ray *ray, const rto_hit_record *e,
                            const rto_hit_record *g, claim_kind k, const rto_tri_hit *th, ray_result *rr)
{
    const rto_hit_fault f = g->instance_id != e->instance_id ? RTO_HIT_INSTANCE : RTO_HIT_PRIM;
    if (g->instance_id != e->instance_id)
        id_row(rr, f, "instanceId", e->instance_id, g->instance_id);
    if (g->prim_id != e->prim_id)
        id_row(rr, f, "primId", e->prim_id, g->prim_id);
    const double tol = t_tolerance(e->t);
    add_row(rr, f, "claimed.t", rto_val_f32(e->t), k == CLAIM_HIT ? rto_val_f32(th->t) : rto_val_none(),
            k == CLAIM_HIT ? rto_val_f64((double)th->t - (double)e->t) : rto_val_none(), rto_val_f64(tol));
    char why[160];
    claim_why(d, ray, g, k, th, e->t, "the oracle's", why, sizeof why);
    fault(rr, f, tol,
          "ray %zu: the GPU claims triangle %" PRIu32 " of instance %" PRIu32 ", %s; the oracle hits triangle %" PRIu32
          " of instance %" PRIu32 " at t = %.9g (not a tie)",
          i, g->prim_id, g->instance_id, why, e->prim_id, e->instance_id, (double)e->t);
}

/* Compares record g with the reference ref (the oracle's record, or for a tie or grazing the claimed primitive's
 * own, whose). */
static void compare_hit_fields(size_t i, const rto_hit_record *ref, const rto_hit_record *g, const char *whose,
                               ray_result *rr)
{
    if (!t_close(g->t, ref->t)) {
        const double tol = t_tolerance(ref->t);
        float_row(rr, RTO_HIT_T, "t", ref->t, g->t, tol, 1);
        fault(rr, RTO_HIT_T, tol, "ray %zu: t = %.9g, %s t = %.9g (|dt| %.3g > %.3g)", i, (double)g->t, whose,
              (double)ref->t, fabs((double)g->t - (double)ref->t), tol);
    }
    for (int k = 0; k < 2; k++) {
        if (bary_close(g->bary[k], ref->bary[k]))
            continue;
        float_row(rr, RTO_HIT_BARY, k ? "bary.v" : "bary.u", ref->bary[k], g->bary[k], BARY_TOLERANCE, 1);
        fault(rr, RTO_HIT_BARY, BARY_TOLERANCE, "ray %zu: bary = (%.9g, %.9g), %s (%.9g, %.9g) (off by more than 1e-4)",
              i, (double)g->bary[0], (double)g->bary[1], whose, (double)ref->bary[0], (double)ref->bary[1]);
    }
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

/* One check: the description, the scene as crosscheck.h's functions read it, and the work the grazing rule's brute
 * force has done (triangle tests, bounded by GRAZE_BUDGET so that a dump of wrong records on a large scene cannot
 * make the check quadratic: past it, a disagreement is a fault and the summary says the rule stopped). */
typedef struct hcheck {
    const rto_hits_check_desc *d;
    rto_scene scene;
    uint64_t graze_tests;
    int graze_stopped;
} hcheck;

#define GRAZE_BUDGET (UINT64_C(1) << 27)

/* A hit of the ray on triangle prim of instance inst at t, as a record crosscheck.h's functions can judge. */
static rto_hit_record hit_at(uint32_t inst, uint32_t prim, float t)
{
    rto_hit_record h = rto_hit_record_miss(t);
    h.miss_flag = 0;
    h.instance_id = inst;
    h.prim_id = prim;
    return h;
}

/* Whether the oracle's arithmetic hits a triangle, other than the grazing ones and (skip_inst, skip_prim), nearer
 * than limit (beyond the t tolerance): a solid hit that a record ending at limit skipped. Brute force over every
 * triangle, with the ray's mask, culling and t range. */
static int solid_hit_before(hcheck *c, const rto_wf_ray *ray, float limit, uint32_t skip_inst, uint32_t skip_prim)
{
    const rto_hits_check_desc *d = c->d;
    for (uint32_t inst = 0; inst < d->instance_count; inst++) {
        const rto_instance *in = &d->instances[inst];
        const rto_mesh *m = &d->meshes[in->blas];
        if (!(in->mask & ray->cull_mask))
            continue;
        if (c->graze_tests + m->triangle_count > GRAZE_BUDGET) {
            c->graze_stopped = 1;
            return 1;
        }
        c->graze_tests += m->triangle_count;
        for (uint32_t prim = 0; prim < m->triangle_count; prim++) {
            rto_tri_hit th;
            if ((inst == skip_inst && prim == skip_prim) || !rto_instance_triangle_hit(in, m, prim, ray, &th) ||
                !(th.t < limit) || t_close(th.t, limit))
                continue;
            const rto_hit_record h = hit_at(inst, prim, th.t);
            double rel;
            if (!xc_grazing_hit(&c->scene, ray, &h, 0, &rel))
                return 1;
        }
    }
    return 0;
}

/* DESIGN.md §9's grazing rule, for a GPU record that disagrees with the oracle's on whether or which triangle the ray
 * hits and is not a tie. A GPU's division is not correctly rounded (WGSL allows 2.5 ulp) and it may fuse
 * multiply-adds, so on a ray through an edge or a vertex its Möller–Trumbore decides hit or miss differently. The
 * disagreement is explained when every hit one side found and the other did not grazes its triangle (crosscheck.h's
 * grazing class: within 1e-5 of an edge, relative, or the ray within 1e-4 of parallel to the plane): the oracle's
 * hit if the GPU went past it, the GPU's if the oracle's arithmetic misses that triangle (which must exist, meet the
 * ray's cull mask and not be culled); and the oracle's arithmetic hits no other triangle solidly before the GPU's
 * answer. The record is then held to its own triangle's values (or to the miss record). Returns 1 when explained. */
static int grazing(hcheck *c, size_t i, const rto_wf_ray *ray, const rto_hit_record *e, const rto_hit_record *g,
                   int any_hit, ray_result *rr)
{
    const rto_hits_check_desc *d = c->d;
    const int e_hit = !e->miss_flag, g_hit = !g->miss_flag;
    double rel = 0;
    rto_tri_hit th = {0, 0, 0, 0};
    claim_kind k = CLAIM_MISSED;
    if (g_hit) {
        k = reintersect(d, ray, g->instance_id, g->prim_id, &th);
        if (k != CLAIM_HIT && (k != CLAIM_MISSED || rto__triangle_culled(ray->flags, th.det) ||
                               !xc_grazing_hit(&c->scene, ray, g, 1, &rel)))
            return 0;
    }
    /* where the GPU's answer lies: its triangle's own t when the oracle's arithmetic hits it (a wrong t in the
     * record is then a t fault, below) */
    const float end = !g_hit ? ray->t_max : k == CLAIM_HIT ? th.t : g->t;
    /* A claim the oracle's arithmetic hits solidly is explained only as what lies behind a grazed oracle hit: nearer
     * than the oracle's record, or where the oracle misses, it says the expected record is not the closest hit. */
    if (!any_hit && g_hit && k == CLAIM_HIT && !(e_hit && end > e->t && !t_close(end, e->t)))
        return 0;
    /* both hit a TERMINATE_ON_FIRST_HIT ray (any_hit): any hit will do, so only the claim's own triangle is judged */
    if (!any_hit && e_hit && end > e->t && !t_close(end, e->t) && !xc_grazing_hit(&c->scene, ray, e, 0, &rel))
        return 0;
    if (!any_hit && solid_hit_before(c, ray, end, g_hit ? g->instance_id : UINT32_MAX, g->prim_id))
        return 0;
    rr->grazing = 1;
    if (e->instance_id != g->instance_id)
        id_row(rr, RTO_HIT_OK, "grazing.instanceId", e->instance_id, g->instance_id);
    if (e->prim_id != g->prim_id)
        id_row(rr, RTO_HIT_OK, "grazing.primId", e->prim_id, g->prim_id);
    float_row(rr, RTO_HIT_OK, "grazing.t", e->t, g->t, 0, 0);
    if (any_hit)
        return 1; /* its t was judged with the triangle (xc_grazing_hit) */
    if (!g_hit) {
        compare_miss(i, ray, g, rr);
        return 1;
    }
    if (k == CLAIM_MISSED) { /* the point where the ray meets the triangle's plane, in binary64 */
        double t, u, v;
        if (xc_plane_hit(&c->scene, g->instance_id, g->prim_id, ray, &t, &u, &v))
            th = (rto_tri_hit){(float)t, (float)u, (float)v, th.det};
        else
            th = (rto_tri_hit){g->t, g->bary[0], g->bary[1], th.det}; /* parallel: nothing to hold it to */
    }
    const rto_hit_record ref = rto_hit_record_make(&d->instances[g->instance_id], g->instance_id, g->prim_id, &th);
    compare_hit_fields(i, &ref, g, "its triangle's", rr);
    return 1;
}

/* A TERMINATE_ON_FIRST_HIT ray that both sides hit: which hit a traversal finds first depends on its order (§6), so
 * only that the claimed primitive is hit, at the claimed t, is defined. */
static void compare_first_hit(hcheck *c, size_t i, const rto_wf_ray *ray, const rto_hit_record *e,
                              const rto_hit_record *g, ray_result *rr)
{
    const rto_hits_check_desc *d = c->d;
    rto_tri_hit th = {0, 0, 0, 0};
    const claim_kind k = reintersect(d, ray, g->instance_id, g->prim_id, &th);
    if (k != CLAIM_HIT) {
        if (grazing(c, i, ray, e, g, 1, rr))
            return;
        const rto_hit_fault f = g->instance_id != e->instance_id ? RTO_HIT_INSTANCE : RTO_HIT_PRIM;
        if (g->instance_id != e->instance_id)
            id_row(rr, f, "instanceId", e->instance_id, g->instance_id);
        id_row(rr, f, "primId", e->prim_id, g->prim_id);
        char why[160];
        claim_why(d, ray, g, k, &th, g->t, "the record's", why, sizeof why);
        fault(rr, f, 0, "ray %zu (TERMINATE_ON_FIRST_HIT) claims a hit on triangle %" PRIu32 " of instance %" PRIu32
              ", %s", i, g->prim_id, g->instance_id, why);
        return;
    }
    /* The primitive is hit: a wrong distance is a fault of t, not of the primitive. */
    if (!t_close(g->t, th.t)) {
        const double tol = t_tolerance(th.t);
        float_row(rr, RTO_HIT_T, "t", th.t, g->t, tol, 1);
        fault(rr, RTO_HIT_T, tol, "ray %zu (TERMINATE_ON_FIRST_HIT) hits triangle %" PRIu32 " of instance %" PRIu32
              " at t = %.9g; the GPU's record says t = %.9g (|dt| %.3g > %.3g)", i, g->prim_id, g->instance_id,
              (double)th.t, (double)g->t, fabs((double)g->t - (double)th.t), tol);
    }
}

static void compare_ray(hcheck *c, size_t i, ray_result *rr)
{
    const rto_hits_check_desc *d = c->d;
    memset(rr, 0, sizeof *rr);
    const rto_wf_ray *ray = &d->rays[i];
    const rto_hit_record *e = &d->expected[i], *g = &d->gpu[i];
    if (g->miss_flag > 1) {
        id_row(rr, RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, g->miss_flag);
        fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: missFlag is %" PRIu32 ", neither 0 (hit) nor 1 (miss)", i,
              g->miss_flag);
        return;
    }
    if (g->miss_flag != e->miss_flag) {
        if (grazing(c, i, ray, e, g, 0, rr))
            return;
        id_row(rr, RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, g->miss_flag);
        if (e->miss_flag)
            fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: the GPU reports a hit (triangle %" PRIu32 " of instance %" PRIu32
                  ", t = %.9g) where the oracle's ray misses", i, g->prim_id, g->instance_id, (double)g->t);
        else
            fault(rr, RTO_HIT_MISS_FLAG, 0, "ray %zu: the GPU reports a miss where the oracle hits triangle %" PRIu32
                  " of instance %" PRIu32 " at t = %.9g", i, e->prim_id, e->instance_id, (double)e->t);
        return;
    }
    if (e->miss_flag) {
        compare_miss(i, ray, g, rr);
        return;
    }
    if (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) {
        compare_first_hit(c, i, ray, e, g, rr);
        return;
    }
    rto_hit_record ref = *e;
    if (g->instance_id != e->instance_id || g->prim_id != e->prim_id) {
        rto_tri_hit th = {0, 0, 0, 0};
        const claim_kind k = reintersect(d, ray, g->instance_id, g->prim_id, &th);
        if (k != CLAIM_HIT || !t_close(th.t, e->t)) {
            if (!grazing(c, i, ray, e, g, 0, rr))
                wrong_primitive(d, i, ray, e, g, k, &th, rr);
            return; /* the other fields have no reference: the oracle's belong to another primitive */
        }
        /* A tie: listed as rows (kept only while nothing is wrong, or on a wrong ray), and from here on the record
         * is held to the tied primitive's own hit record. */
        rr->tie = 1;
        if (g->instance_id != e->instance_id)
            id_row(rr, RTO_HIT_OK, "tie.instanceId", e->instance_id, g->instance_id);
        if (g->prim_id != e->prim_id)
            id_row(rr, RTO_HIT_OK, "tie.primId", e->prim_id, g->prim_id);
        float_row(rr, RTO_HIT_OK, "tie.t", e->t, th.t, t_tolerance(e->t), 1);
        ref = rto_hit_record_make(&d->instances[g->instance_id], g->instance_id, g->prim_id, &th);
    }
    compare_hit_fields(i, &ref, g, rr->tie ? "the tied primitive's" : "the oracle's", rr);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Input                                                                                                                */

/* The scene: every instance names a mesh, every mesh's indices name its vertices, so that re-intersecting any
 * in-range primitive reads only what exists. */
static rto_status check_scene(const rto_hits_check_desc *d, rto_msg *msg)
{
    if ((d->instance_count && !d->instances) || (d->mesh_count && !d->meshes))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL instances or meshes");
    for (uint32_t m = 0; m < d->mesh_count; m++) {
        const rto_mesh *mesh = &d->meshes[m];
        if ((mesh->triangle_count && !mesh->indices) || (mesh->vertex_count && !mesh->positions))
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %" PRIu32 " has NULL indices or positions", m);
        for (size_t k = 0; k < 3 * (size_t)mesh->triangle_count; k++)
            if (mesh->indices[k] >= mesh->vertex_count)
                return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "mesh %" PRIu32 ": index %zu is %" PRIu32 " (the mesh has %" PRIu32 " vertices)", m, k,
                                mesh->indices[k], mesh->vertex_count);
    }
    for (uint32_t i = 0; i < d->instance_count; i++)
        if (d->instances[i].blas >= d->mesh_count)
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %" PRIu32 " names mesh %" PRIu32 " of %" PRIu32, i,
                            d->instances[i].blas, d->mesh_count);
    return RTO_OK;
}

/* Whether two records hold the same hit, field by field: t and bary within tolerance, the rest exact. */
static int same_record(const rto_hit_record *a, const rto_hit_record *b)
{
    if (!t_close(a->t, b->t) || !bary_close(a->bary[0], b->bary[0]) || !bary_close(a->bary[1], b->bary[1]) ||
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
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "expected record %zu: missFlag %" PRIu32
                            " is neither 0 nor 1", i, e->miss_flag);
        if (e->miss_flag) {
            const rto_hit_record m = rto_hit_record_miss(ray->t_max);
            if (!(e->t == m.t) || !same_record(e, &m))
                return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "expected record %zu is a miss but not the miss record of ray %zu (t = tMax, IDs "
                                "0xFFFFFFFF, bary and objToWorld 0)", i, i);
            continue;
        }
        rto_tri_hit th = {0, 0, 0, 0};
        const claim_kind k = reintersect(d, ray, e->instance_id, e->prim_id, &th);
        if (k != CLAIM_HIT)
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "expected record %zu names triangle %" PRIu32 " of instance %" PRIu32 ", %s", i,
                            e->prim_id, e->instance_id,
                            k == CLAIM_NO_INSTANCE ? "an instance the scene does not have"
                            : k == CLAIM_NO_PRIM   ? "a triangle its mesh does not have"
                            : k == CLAIM_MASKED    ? "an instance the ray's cull mask excludes"
                                                   : "which the ray does not hit");
        const rto_hit_record own = rto_hit_record_make(&d->instances[e->instance_id], e->instance_id, e->prim_id, &th);
        if (!same_record(e, &own))
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
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
        rto_report_row *row = rto_report_row_add(r, i, x->field);
        if (!row)
            return;
        row->expected = x->expected;
        row->actual = x->actual;
        row->diff = x->diff;
        row->tolerance = x->tolerance;
    }
}

rto_status rto_hits_check(const rto_hits_check_desc *d, rto_report *r, rto_msg *msg)
{
    if (!d || !r)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL descriptor or report");
    rto_report_begin(r, "check-hits");
    for (size_t k = 0; k < sizeof check_names / sizeof check_names[0]; k++)
        rto_report_add_check(r, check_names[k]);
    rto_report_table(r, "hit records", "ray");
    snprintf(r->tolerance, sizeof r->tolerance,
             "t |dt| <= 1e-5*max(1,|t|), bary 1e-4 absolute; IDs, customIndex, hitGroup, missFlag, objToWorld exact "
             "(padding ignored); ties (same t) and grazing hits (on an edge) accepted (DESIGN.md §9)");
    if ((d->ray_count && (!d->rays || !d->expected)) || (d->gpu_count && !d->gpu))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL rays, expected records or GPU records");
    rto_status s = check_scene(d, msg);
    if (!s)
        s = check_expected(d, msg);
    if (s)
        return s;

    const size_t n = d->ray_count, gn = d->gpu_count, m = n < gn ? n : gn;
    size_t hits = 0, first_hit = 0, ties = 0, wrong = 0, first_tie = 0;
    for (size_t i = 0; i < n; i++) {
        hits += !d->expected[i].miss_flag;
        first_hit += (d->rays[i].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
    }
    snprintf(r->context, sizeof r->context,
             "%zu rays (the oracle: %zu hits, %zu misses), GPU dump of %zu records; %" PRIu32 " instance%s, %" PRIu32
             " mesh%s", n, hits, n - hits, gn, d->instance_count, d->instance_count == 1 ? "" : "s", d->mesh_count,
             d->mesh_count == 1 ? "" : "es");
    rto_report_fact(r, "rays", (int64_t)n);
    rto_report_fact(r, "gpu_records", (int64_t)gn);
    rto_report_fact(r, "hits", (int64_t)hits);
    rto_report_fact(r, "misses", (int64_t)(n - hits));
    rto_report_fact(r, "first_hit_rays", (int64_t)first_hit);

    if (gn != n) {
        /* Reported at the first ray without a record (or the first record without a ray); the records both sides
         * have are still compared, so the other fault classes of a short dump are listed too. */
        rto_report_mark(r, "size", RTO_CHECK_FAILED);
        rto_report_claim(r, RTO_HIT_SIZE, rto_hit_fault_name(RTO_HIT_SIZE));
        rto_report_at(r, "ray", (int64_t)m);
        rto_report_summary(r, "size: the GPU dump holds %zu hit records for %zu rays (the first %s: ray %zu)", gn, n,
                           gn < n ? "ray without a record" : "record without a ray", m);
        rto_report_row *row = rto_report_row_add(r, m, "records");
        if (row) {
            row->expected = rto_val_uint(n);
            row->actual = rto_val_uint(gn);
            row->diff = rto_val_int((int64_t)gn - (int64_t)n);
        }
    } else {
        rto_report_mark(r, "size", RTO_CHECK_PASSED);
    }

    hcheck c = {.d = d};
    c.scene.meshes = (rto_mesh *)d->meshes; /* read only: crosscheck.h's functions take a const rto_scene */
    c.scene.mesh_count = d->mesh_count;
    c.scene.instances = (rto_instance *)d->instances;
    c.scene.instance_count = d->instance_count;
    size_t grazings = 0, first_grazing = 0;
    ray_result rr;
    for (size_t i = 0; i < m; i++) {
        compare_ray(&c, i, &rr);
        if (rr.tie && !ties++)
            first_tie = i;
        if (rr.grazing && !grazings++)
            first_grazing = i;
        if (!rr.faults) {
            if ((rr.tie || rr.grazing) && r->code == RTO_HIT_OK)
                report_rows(r, i, &rr); /* a passing report lists its ties and grazing rays */
            continue;
        }
        wrong++;
        int primary = 0;
        rto_hit_fault first = RTO_HIT_OK;
        for (int f = RTO_HIT_SIZE; f <= HIT_FAULT_LAST; f++) {
            if (!(rr.faults & (1u << f)))
                continue;
            rto_report_mark(r, check_of((rto_hit_fault)f), RTO_CHECK_FAILED);
            if (rto_report_claim(r, f, rto_hit_fault_name((rto_hit_fault)f))) {
                primary = 1;
                first = (rto_hit_fault)f;
            }
        }
        if (primary) {
            rto_report_at(r, "ray", (int64_t)i);
            rto_report_summary(r, "%s: %s", rto_hit_fault_name(first), rr.text[first]);
            r->tolerance_bound = rr.bound[first];
        }
        report_rows(r, i, &rr); /* the primary ray's rows, then those of later wrong rays while there is room */
    }
    for (size_t k = 0; k < sizeof check_names / sizeof check_names[0]; k++)
        rto_report_mark(r, check_names[k], RTO_CHECK_PASSED); /* FAILED is sticky */
    rto_report_fact(r, "ties", (int64_t)ties);
    rto_report_fact(r, "grazing", (int64_t)grazings);
    rto_report_fact(r, "wrong_rays", (int64_t)wrong);
    if (r->code != RTO_HIT_OK) {
        if (wrong)
            rto_report_append(r, "; %zu of %zu compared rays wrong", wrong, m);
        if (ties)
            rto_report_append(r, "; %zu tie(s) accepted", ties);
        if (grazings)
            rto_report_append(r, "; %zu grazing ray(s) accepted", grazings);
        if (c.graze_stopped)
            rto_report_append(r, "; the grazing rule stopped after %" PRIu64 " triangle tests (later disagreements "
                              "count as wrong)", c.graze_tests);
        return RTO_ERR_MISMATCH;
    }
    rto_report_summary(r, "ok: %zu rays agree with the oracle within the §9 tolerances", n);
    if (ties)
        rto_report_append(r, "; %zu tie(s) accepted (another primitive at the same t), the first at ray %zu", ties,
                          first_tie);
    if (grazings)
        rto_report_append(r, "; %zu grazing ray(s) accepted (a hit one side lacks lies on an edge of its triangle), "
                          "the first at ray %zu", grazings, first_grazing);
    return RTO_OK;
}
