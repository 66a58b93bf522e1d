/* Validation of GPU-built trees (DESIGN.md §5, §9): against the oracle's items and links (exact mode) or against the
 * primitives alone (structure-only), with the box rules of §9 — a leaf box within the transform bound of its
 * primitive's box (exact for triangles), every internal box the exact union of the dump's *own* children, an EMPTY
 * node's box the empty box. Faults are classified so that a report names what broke, and located where it starts:
 * boxes are checked bottom-up, so a bad leaf is reported at the leaf, not at the ancestor whose union it spoiled. */
#include "core/aabb.h"
#include "report_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *rto_bvh_fault_name(rto_bvh_fault f)
{
    switch (f) {
    case RTO_BVH_OK: return "none";
    case RTO_BVH_SIZE: return "size";
    case RTO_BVH_CYCLE: return "cycle";
    case RTO_BVH_SHARED: return "shared-node";
    case RTO_BVH_BAD_LINK: return "bad-link";
    case RTO_BVH_DROPPED_LEAF: return "dropped-leaf";
    case RTO_BVH_ITEM: return "item";
    case RTO_BVH_SWAPPED: return "swapped-children";
    case RTO_BVH_TOPOLOGY: return "topology";
    case RTO_BVH_PARENT: return "parent";
    case RTO_BVH_EMPTY: return "empty";
    case RTO_BVH_BOX: return "box";
    }
    return "unknown";
}

void rto_transform_box_tolerance(const rto_mat34 *m, const rto_aabb *b, double tol[3])
{
    tol[0] = tol[1] = tol[2] = 0;
    if (!m || !b || rto_aabb_is_empty(b) || rto__aabb_has_nan(b))
        return;
    const float lo[3] = {b->min.x, b->min.y, b->min.z}, hi[3] = {b->max.x, b->max.y, b->max.z};
    for (int row = 0; row < 3; row++) {
        /* Each term depends on one coordinate only, so the maximum over the 8 corners is the sum of the per-axis
         * maxima. A binary32 product is exact in binary64. */
        double s = fabs((double)m->m[row][3]);
        for (int c = 0; c < 3; c++) {
            double a = fabs((double)m->m[row][c] * lo[c]), z = fabs((double)m->m[row][c] * hi[c]);
            s += a > z ? a : z;
        }
        tol[row] = s * (8.0 / 16777216.0);
    }
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Shared helpers                                                                                                       */

static const char *const axis_name[3] = {"x", "y", "z"};

/* Exactly the empty box (+inf, -inf) (core/aabb.c): the one encoding of "no geometry" a tree holds. */
static int box_is_empty_identity(const float *mn, const float *mx)
{
    const rto_aabb b = rto__aabb_of(mn, mx), e = rto_aabb_empty();
    return rto_aabb_equal(&b, &e);
}

static void aabb_arrays(const rto_aabb *b, float *mn, float *mx)
{
    mn[0] = b->min.x, mn[1] = b->min.y, mn[2] = b->min.z;
    mx[0] = b->max.x, mx[1] = b->max.y, mx[2] = b->max.z;
}

/* Whether primitive p has an empty box: it must be in no leaf. */
static int prim_empty(const rto_aabb *boxes, size_t p) { return rto_aabb_is_empty(&boxes[p]); }

/* Counts the non-empty primitive boxes, refusing boxes that are neither finite (min <= max) nor the empty box. */
static rto_status count_keyed(const rto_aabb *boxes, size_t n, const double *tol, size_t *keyed, rto_msg *msg)
{
    size_t k = 0;
    for (size_t p = 0; p < n; p++) {
        const rto_aabb e = rto_aabb_empty();
        if (rto_aabb_equal(&boxes[p], &e))
            continue;
        if (!rto_aabb_is_finite(&boxes[p]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "primitive box %zu is neither finite with min <= max nor the empty box (+inf, -inf)", p);
        for (int a = 0; tol && a < 3; a++)
            if (!(tol[3 * p + a] >= 0))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "leaf tolerance %zu is negative or NaN", p);
        k++;
    }
    *keyed = k;
    return RTO_OK;
}

/* Whether a leaf bound is acceptable: exact, or within tol (a NaN never is). */
static int bound_ok(float actual, float expected, const double *tol, int a)
{
    if (!tol)
        return actual == expected;
    return fabs((double)actual - (double)expected) <= tol[a];
}

/* Whether leaf box (mn, mx) stands for primitive box pb within tol (NULL: exactly). */
static int leaf_box_ok(const float *mn, const float *mx, const rto_aabb *pb, const double *tol)
{
    float pmn[3], pmx[3];
    aabb_arrays(pb, pmn, pmx);
    for (int a = 0; a < 3; a++)
        if (!bound_ok(mn[a], pmn[a], tol, a) || !bound_ok(mx[a], pmx[a], tol, a))
            return 0;
    return 1;
}

/* Rows for every bound of a box (prefix "", "l" or "r") that differs from the expected one beyond tol (NULL:
 * exact); the report's bound becomes the first failing bound's tolerance. */
static void box_rows(rto_report *r, size_t node, const char *prefix, const float *mn, const float *mx,
                     const float *emn, const float *emx, const double *tol)
{
    int first = 1;
    for (int side = 0; side < 2; side++)
        for (int a = 0; a < 3; a++) {
            float g = side ? mx[a] : mn[a], e = side ? emx[a] : emn[a];
            if (bound_ok(g, e, tol, a))
                continue;
            char field[RTO_REPORT_NAME_MAX];
            snprintf(field, sizeof field, "%s%s.%s", prefix, side ? "max" : "min", axis_name[a]);
            if (r->nrows == 0)
                rto__report_table(r, "boxes", "node");
            rto_report_row *row = rto__report_row_add(r, node, field);
            if (!row)
                return;
            row->expected = rto__val_f32(e);
            row->actual = rto__val_f32(g);
            row->diff = rto__val_f64((double)g - (double)e);
            if (tol) {
                row->tolerance = rto__val_f64(tol[a]);
                if (first)
                    r->tolerance_bound = tol[a];
            }
            first = 0;
        }
}

static void union_of(const float *amn, const float *amx, const float *bmn, const float *bmx, float *mn, float *mx)
{
    for (int a = 0; a < 3; a++) {
        mn[a] = rto__minf(amn[a], bmn[a]);
        mx[a] = rto__maxf(amx[a], bmx[a]);
    }
}

static int same_box(const float *amn, const float *amx, const float *bmn, const float *bmx)
{
    const rto_aabb a = rto__aabb_of(amn, amx), b = rto__aabb_of(bmn, bmx);
    return rto_aabb_equal(&a, &b);
}

/* Claims fault f for check `check`; when it becomes the primary fault, sets the node (if >= 0) and the summary
 * "<name>: <text>" and returns 1 so that the caller adds the rest of the location and the rows. */
static int note(rto_report *r, rto_bvh_fault f, const char *check, int64_t node, const char *fmt, ...)
    RTO_PRINTF(5, 6);
static int note(rto_report *r, rto_bvh_fault f, const char *check, int64_t node, const char *fmt, ...)
{
    rto__report_mark(r, check, RTO_CHECK_FAILED);
    if (!rto__report_claim(r, (int)f, rto_bvh_fault_name(f)))
        return 0;
    rto__report_table(r, "nodes", "node");
    if (node >= 0)
        rto__report_at(r, "node", node);
    int used = snprintf(r->summary, sizeof r->summary, "%s: ", rto_bvh_fault_name(f));
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->summary + used, sizeof r->summary - (size_t)used, fmt, ap);
    va_end(ap);
    return 1;
}

static void link_row(rto_report *r, size_t node, const char *field, rto_value expected, uint32_t actual)
{
    if (r->nrows == 0)
        rto__report_table(r, strcmp(field, "item") ? "links" : "items", "node");
    rto_report_row *row = rto__report_row_add(r, node, field);
    if (row) {
        row->expected = expected;
        row->actual = rto__val_hex32(actual);
    }
}

static const char *const bvh_checks[] = {"size", "leaves", "oracle", "links", "boxes"};

static void begin(rto_report *r, const rto_bvh_check_desc *d)
{
    rto__report_begin(r, "check-bvh");
    for (size_t i = 0; i < sizeof bvh_checks / sizeof bvh_checks[0]; i++)
        rto__report_add_check(r, bvh_checks[i]);
    rto__report_table(r, "nodes", "node");
    snprintf(r->mode, sizeof r->mode, "%s", d->expected ? "exact" : "structure-only");
    if (d->leaf_tolerance)
        snprintf(r->tolerance, sizeof r->tolerance, "leaves within 8*2^-24*(|m0*x|+|m1*y|+|m2*z|+|t|) per "
                 "coordinate, internal boxes exact unions (§9)");
    else
        snprintf(r->tolerance, sizeof r->tolerance, "leaves exact, internal boxes exact unions of the dump's own "
                 "children (DESIGN.md §9)");
}

/* The checks that ran to the end: "ok" unless they failed (FAILED is sticky). */
static rto_status finish(rto_report *r, int exact)
{
    rto__report_mark(r, "leaves", RTO_CHECK_PASSED);
    rto__report_mark(r, "links", RTO_CHECK_PASSED);
    rto__report_mark(r, "boxes", RTO_CHECK_PASSED);
    if (exact)
        rto__report_mark(r, "oracle", RTO_CHECK_PASSED);
    if (r->code != RTO_BVH_OK)
        return RTO_ERR_MISMATCH;
    rto__report_summary(r, "ok: %s", r->mode[0] == 'e' ? "equal to the oracle's tree within tolerance"
                                                     : "a valid tree over the same primitives");
    return RTO_OK;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Sweep TLAS                                                                                                           */

/* Whether the items of the heap subtree at ia in a equal those of the subtree at ib in b (same level). */
static int titems_equal(const rto_tlas_node *a, size_t ia, const rto_tlas_node *b, size_t ib, size_t count)
{
    for (size_t width = 1; ia < count && ib < count; width *= 2) {
        for (size_t k = 0; k < width; k++)
            if (a[ia + k].item != b[ib + k].item)
                return 0;
        ia = 2 * ia + 1;
        ib = 2 * ib + 1;
    }
    return 1;
}

/* The first leaf whose item differs from the oracle's: an exchange of two subtrees (found at the lowest ancestor
 * whose children are exchanged), a wrong instance, a dropped one, or a wrong EMPTY marker. */
static void tlas_compare(rto_report *r, const rto_tlas_node *g, const rto_tlas_node *e, size_t count, size_t np,
                         size_t pc)
{
    for (size_t i = np - 1; i < count; i++) {
        if (g[i].item == e[i].item)
            continue;
        for (size_t c = i; c > 0;) {
            size_t p = (c - 1) / 2;
            if (titems_equal(g, 2 * p + 1, e, 2 * p + 2, count) && titems_equal(g, 2 * p + 2, e, 2 * p + 1, count)) {
                if (note(r, RTO_BVH_SWAPPED, "oracle", (int64_t)p, "the subtrees under node %zu (nodes %zu and %zu) "
                         "are exchanged", p, 2 * p + 1, 2 * p + 2))
                    for (size_t k = i; k < count; k++)
                        if (g[k].item != e[k].item)
                            link_row(r, k, "item", rto__val_hex32(e[k].item), g[k].item);
                return;
            }
            c = p;
        }
        const size_t j = i - (np - 1);
        const int marker = g[i].item == RTO_TLAS_EMPTY || g[i].item == RTO_TLAS_INTERNAL;
        int own;
        if (g[i].item < pc && e[i].item < pc)
            own = note(r, RTO_BVH_ITEM, "oracle", (int64_t)i, "leaf node %zu (sorted leaf %zu) holds instance %" PRIu32
                       ", expected %" PRIu32, i, j, g[i].item, e[i].item);
        else if (e[i].item < pc)
            own = note(r, RTO_BVH_DROPPED_LEAF, "oracle", (int64_t)i, "leaf node %zu (sorted leaf %zu) holds item "
                       "0x%08" PRIx32 " instead of instance %" PRIu32, i, j, g[i].item, e[i].item);
        else if (!marker)
            own = note(r, RTO_BVH_ITEM, "oracle", (int64_t)i, "leaf node %zu (sorted leaf %zu) holds item 0x%08" PRIx32
                       " where the oracle's leaf is EMPTY", i, j, g[i].item);
        else
            own = note(r, RTO_BVH_EMPTY, "oracle", (int64_t)i, "leaf node %zu (sorted leaf %zu) holds item 0x%08" PRIx32
                       ", expected 0x%08" PRIx32, i, j, g[i].item, e[i].item);
        if (own) {
            rto__report_at(r, "leaf", (int64_t)j);
            if (g[i].item < pc)
                rto__report_at(r, "primitive", g[i].item);
            for (size_t k = i; k < count; k++)
                if (g[k].item != e[k].item)
                    link_row(r, k, "item", rto__val_hex32(e[k].item), g[k].item);
        }
        return;
    }
    rto__report_mark(r, "oracle", RTO_CHECK_PASSED);
}

/* One leaf node on its own: its item and its box. */
static void tlas_leaf(rto_report *r, const rto_bvh_check_desc *d, const rto_tlas_node *t, size_t i, size_t j)
{
    const size_t pc = d->prim_count;
    if (t->item < pc && !prim_empty(d->prim_boxes, t->item)) {
        const double *tol = d->leaf_tolerance ? &d->leaf_tolerance[3 * (size_t)t->item] : NULL;
        if (leaf_box_ok(t->min, t->max, &d->prim_boxes[t->item], tol))
            return;
        if (note(r, RTO_BVH_BOX, "boxes", (int64_t)i, "leaf node %zu (sorted leaf %zu) box is not instance %" PRIu32
                 "'s box%s", i, j, t->item, tol ? " within the transform tolerance" : "")) {
            float pmn[3], pmx[3];
            aabb_arrays(&d->prim_boxes[t->item], pmn, pmx);
            rto__report_at(r, "leaf", (int64_t)j);
            rto__report_at(r, "primitive", t->item);
            box_rows(r, i, "", t->min, t->max, pmn, pmx, tol);
        }
    } else if (t->item == RTO_TLAS_EMPTY) {
        if (box_is_empty_identity(t->min, t->max))
            return;
        if (note(r, RTO_BVH_EMPTY, "boxes", (int64_t)i, "EMPTY leaf node %zu (sorted leaf %zu) has a box other than "
                 "(+inf, -inf)", i, j)) {
            const float inf[3] = {INFINITY, INFINITY, INFINITY}, ninf[3] = {-INFINITY, -INFINITY, -INFINITY};
            rto__report_at(r, "leaf", (int64_t)j);
            box_rows(r, i, "", t->min, t->max, inf, ninf, NULL);
        }
    } else if (t->item == RTO_TLAS_INTERNAL) {
        if (note(r, RTO_BVH_EMPTY, "links", (int64_t)i, "leaf node %zu (sorted leaf %zu) is marked INTERNAL", i, j)) {
            rto__report_at(r, "leaf", (int64_t)j);
            link_row(r, i, "item", rto__val_none(), t->item);
        }
    } else if (note(r, RTO_BVH_ITEM, "leaves", (int64_t)i, "leaf node %zu (sorted leaf %zu) holds item 0x%08" PRIx32
                    ": %s", i, j, t->item, t->item < pc ? "an instance of an empty BLAS, which has no leaf"
                                                        : "no such instance, nor EMPTY")) {
        rto__report_at(r, "leaf", (int64_t)j);
        if (t->item < pc)
            rto__report_at(r, "primitive", t->item);
        link_row(r, i, "item", rto__val_none(), t->item);
    }
}

/* One internal node on its own: its item from its children's, an EMPTY node's box, the union of its children. */
static void tlas_internal(rto_report *r, const rto_tlas_node *g, size_t i)
{
    const rto_tlas_node *t = &g[i], *a = &g[2 * i + 1], *b = &g[2 * i + 2];
    const uint32_t want = (a->item == RTO_TLAS_EMPTY && b->item == RTO_TLAS_EMPTY) ? RTO_TLAS_EMPTY : RTO_TLAS_INTERNAL;
    if (t->item != want) {
        if (note(r, RTO_BVH_EMPTY, "links", (int64_t)i, "internal node %zu item 0x%08" PRIx32 ", expected 0x%08" PRIx32
                 " from its children %zu and %zu", i, t->item, want, 2 * i + 1, 2 * i + 2))
            link_row(r, i, "item", rto__val_hex32(want), t->item);
        return;
    }
    if (want == RTO_TLAS_EMPTY && !box_is_empty_identity(t->min, t->max)) {
        if (note(r, RTO_BVH_EMPTY, "boxes", (int64_t)i, "EMPTY node %zu has a box other than (+inf, -inf)", i)) {
            const float inf[3] = {INFINITY, INFINITY, INFINITY}, ninf[3] = {-INFINITY, -INFINITY, -INFINITY};
            box_rows(r, i, "", t->min, t->max, inf, ninf, NULL);
        }
        return;
    }
    float umn[3], umx[3];
    union_of(a->min, a->max, b->min, b->max, umn, umx);
    if (!same_box(t->min, t->max, umn, umx) &&
        note(r, RTO_BVH_BOX, "boxes", (int64_t)i, "node %zu box is not the exact union of its children %zu and %zu", i,
             2 * i + 1, 2 * i + 2))
        box_rows(r, i, "", t->min, t->max, umn, umx, NULL);
}

rto_status rto_tlas_check(const rto_bvh_check_desc *d, rto_report *r, rto_msg *msg)
{
    if (!d || !r)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL description or report");
    begin(r, d);
    const rto_tlas_node *g = d->nodes, *exp = d->expected;
    const size_t count = d->node_count, pc = d->prim_count;
    if ((count && !g) || (pc && !d->prim_boxes))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL nodes or primitive boxes");
    size_t keyed = 0;
    rto_status s = count_keyed(d->prim_boxes, pc, d->leaf_tolerance, &keyed, msg);
    if (s)
        return s;
    const size_t np = rto_next_pow2(keyed), want = rto_tlas_sweep_node_count(keyed);
    if (keyed == pc)
        snprintf(r->context, sizeof r->context, "%zu nodes over %zu instances", count, pc);
    else
        snprintf(r->context, sizeof r->context, "%zu nodes over %zu instances (%zu of an empty BLAS, in no leaf)",
                 count, pc, pc - keyed);
    rto__report_fact(r, "nodes", (int64_t)count);
    rto__report_fact(r, "instances", (int64_t)pc);
    rto__report_fact(r, "leaves", (int64_t)keyed);
    rto__report_fact(r, "n_padded", (int64_t)np);
    if (count != want) {
        note(r, RTO_BVH_SIZE, "size", -1, "%zu nodes; a sweep tree over %zu instances with a leaf has %zu (n_padded "
             "%zu)", count, keyed, want, np);
        return RTO_ERR_MISMATCH;
    }
    rto__report_mark(r, "size", RTO_CHECK_PASSED);
    if (np == 0) { /* no instance with a leaf: one EMPTY root */
        if (g[0].item != RTO_TLAS_EMPTY) {
            if (note(r, RTO_BVH_EMPTY, "links", 0, "the root of a TLAS without leaves must be EMPTY, not 0x%08" PRIx32,
                     g[0].item))
                link_row(r, 0, "item", rto__val_hex32(RTO_TLAS_EMPTY), g[0].item);
        } else if (!box_is_empty_identity(g[0].min, g[0].max) &&
                   note(r, RTO_BVH_EMPTY, "boxes", 0, "the EMPTY root of a TLAS without leaves has a box other than "
                        "(+inf, -inf)")) {
            const float inf[3] = {INFINITY, INFINITY, INFINITY}, ninf[3] = {-INFINITY, -INFINITY, -INFINITY};
            box_rows(r, 0, "", g[0].min, g[0].max, inf, ninf, NULL);
        }
        return finish(r, exp != NULL);
    }
    uint32_t *seen = calloc(pc ? pc : 1, sizeof *seen);
    if (!seen)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    /* Leaves: every non-empty instance exactly once. */
    size_t first_dup = SIZE_MAX, first_odd = SIZE_MAX, first_empty_instance = SIZE_MAX;
    for (size_t j = 0; j < np; j++) {
        const rto_tlas_node *t = &g[np - 1 + j];
        int real = t->item < pc && !prim_empty(d->prim_boxes, t->item);
        if (real && seen[t->item]++ && first_dup == SIZE_MAX)
            first_dup = np - 1 + j;
        if (!real && t->item < pc && first_empty_instance == SIZE_MAX)
            first_empty_instance = np - 1 + j;
        /* a leaf that holds no instance yet is not a clean EMPTY leaf: where a dropped instance most likely was */
        if (!real && (t->item != RTO_TLAS_EMPTY || !box_is_empty_identity(t->min, t->max)) && first_odd == SIZE_MAX)
            first_odd = np - 1 + j;
    }
    size_t missing = 0, first_missing = SIZE_MAX;
    for (size_t p = 0; p < pc; p++)
        if (!prim_empty(d->prim_boxes, p) && !seen[p] && !missing++)
            first_missing = p;
    free(seen);
    /* A leaf holding an instance of an empty BLAS is where the fault starts (the GPU did not skip it), even when it
     * took the place of an instance that is now in no leaf: item, at that leaf. */
    if (first_empty_instance != SIZE_MAX) {
        tlas_leaf(r, d, &g[first_empty_instance], first_empty_instance, first_empty_instance - (np - 1));
        if (exp && r->nrows == 1 && r->rows[0].index == first_empty_instance) /* what the oracle has there */
            r->rows[0].expected = rto__val_hex32(exp[first_empty_instance].item);
    }
    if (missing && first_dup == SIZE_MAX) {
        size_t node = first_odd;
        for (size_t j = 0; exp && j < np; j++)
            if (exp[np - 1 + j].item == first_missing)
                node = np - 1 + j;
        if (note(r, RTO_BVH_DROPPED_LEAF, "leaves", node == SIZE_MAX ? -1 : (int64_t)node, "instance %zu is in no leaf "
                 "(%zu instance(s) missing)%s", first_missing, missing, node == SIZE_MAX ? ""
                 : exp ? "; the oracle has it at this node" : "; this leaf holds no instance")) {
            if (node != SIZE_MAX) {
                rto__report_at(r, "leaf", (int64_t)(node - (np - 1)));
                link_row(r, node, "item", rto__val_hex32((uint32_t)first_missing), g[node].item);
            }
            rto__report_at(r, "primitive", (int64_t)first_missing);
        }
    }
    /* Exact comparison of the items with the oracle's locates the first differing leaf. */
    if (exp)
        tlas_compare(r, g, exp, count, np, pc);
    if (missing && first_dup != SIZE_MAX &&
        note(r, RTO_BVH_ITEM, "leaves", (int64_t)first_dup, "instance %" PRIu32 " appears in two leaves and "
             "instance %zu in none", g[first_dup].item, first_missing)) {
        rto__report_at(r, "leaf", (int64_t)(first_dup - (np - 1)));
        rto__report_at(r, "primitive", g[first_dup].item);
        link_row(r, first_dup, "item", rto__val_none(), g[first_dup].item);
    }
    /* Every node on its own, bottom-up: the leaves, then each level of internal nodes from the deepest. */
    for (size_t j = 0; j < np; j++)
        tlas_leaf(r, d, &g[np - 1 + j], np - 1 + j, j);
    for (size_t level_start = (np - 1) / 2; np > 1;) {
        for (size_t i = level_start; i < 2 * level_start + 1; i++)
            tlas_internal(r, g, i);
        if (level_start == 0)
            break;
        level_start = (level_start - 1) / 2;
    }
    return finish(r, 0);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Karras layout                                                                                                        */

static const float *child_min(const rto_bvh_node *nd, int side) { return side ? nd->rmin : nd->lmin; }
static const float *child_max(const rto_bvh_node *nd, int side) { return side ? nd->rmax : nd->lmax; }
static uint32_t child_of(const rto_bvh_node *nd, int side) { return side ? nd->right : nd->left; }
static const char *side_name(int side) { return side ? "right" : "left"; }

typedef struct karras_walk {
    unsigned char *state;  /* per node: 0 unvisited, 1 on the current path, 2 done */
    uint32_t *leaf_refs;   /* per sorted leaf: how many links reach it */
    uint32_t *leaf_node;   /* per sorted leaf: the first node linking it */
    unsigned char *leaf_side;
    uint32_t *stack, *post; /* DFS stack; internal nodes in post-order */
    size_t npost;
    size_t first_dup_leaf;
    int64_t dup_node;
} karras_walk;

static void walk_free(karras_walk *w)
{
    free(w->state);
    free(w->leaf_refs);
    free(w->leaf_node);
    free(w->leaf_side);
    free(w->stack);
    free(w->post);
}

/* Iterative DFS with enter/exit marks: a link to a node on the path is a cycle, to a finished node a share. Returns
 * 1 when the structure is broken (a fault was noted and links cannot be followed further). Parent mismatches are
 * collected in *parent_note, ranked later. */
static int karras_walk_tree(rto_report *r, const rto_bvh_node *g, size_t count, size_t n, karras_walk *w,
                            rto_report *parent_note)
{
    size_t top = 0;
    w->stack[top++] = 0;
    w->state[0] = 1;
    while (top) {
        uint32_t e = w->stack[top - 1], i = e & 0x7FFFFFFFu;
        if (e & 0x80000000u) {
            w->state[i] = 2;
            w->post[w->npost++] = i;
            top--;
            continue;
        }
        w->stack[top - 1] |= 0x80000000u;
        for (int side = 0; side < 2; side++) {
            uint32_t c = child_of(&g[i], side);
            if (c & RTO_BVH_LEAF_BIT) {
                uint32_t j = c & ~RTO_BVH_LEAF_BIT;
                if (j >= n) {
                    if (note(r, RTO_BVH_BAD_LINK, "links", i, "node %" PRIu32 " %s child is leaf %" PRIu32 " of %zu", i,
                             side_name(side), j, n))
                        link_row(r, i, side_name(side), rto__val_none(), c);
                    return 1;
                }
                if (w->leaf_refs[j]++ == 0) {
                    w->leaf_node[j] = i;
                    w->leaf_side[j] = (unsigned char)side;
                } else if (w->first_dup_leaf == SIZE_MAX) {
                    w->first_dup_leaf = j;
                    w->dup_node = i;
                }
            } else if (c >= count) {
                if (note(r, RTO_BVH_BAD_LINK, "links", i, "node %" PRIu32 " %s child is internal node %" PRIu32
                         " of %zu", i, side_name(side), c, count))
                    link_row(r, i, side_name(side), rto__val_none(), c);
                return 1;
            } else if (w->state[c] == 1) {
                if (note(r, RTO_BVH_CYCLE, "links", i, "node %" PRIu32 " links back to its ancestor %" PRIu32
                         " (%s child)", i, c, side_name(side)))
                    link_row(r, i, side_name(side), rto__val_none(), c);
                return 1;
            } else if (w->state[c] == 2) {
                if (note(r, RTO_BVH_SHARED, "links", i, "node %" PRIu32 " links to node %" PRIu32 ", already reached "
                         "from another parent", i, c))
                    link_row(r, i, side_name(side), rto__val_none(), c);
                return 1;
            } else {
                if (g[c].parent != i && note(parent_note, RTO_BVH_PARENT, "links", c, "node %" PRIu32 " has parent %"
                                             PRIu32 " but is a child of %" PRIu32, c, g[c].parent, i))
                    link_row(parent_note, c, "parent", rto__val_hex32(i), g[c].parent);
                w->state[c] = 1;
                w->stack[top++] = c;
            }
        }
    }
    return 0;
}

/* The first sorted leaf whose primitive is out of range, of an empty box, or a repeat; SIZE_MAX when leaf_prims is
 * a permutation of the non-empty primitives. For a repeat, *other is the leaf holding it first. */
static size_t first_bad_prim(const rto_bvh_check_desc *d, size_t *other, rto_msg *msg, rto_status *st)
{
    const size_t n = d->leaf_count, pc = d->prim_count;
    uint32_t *where = rto__alloc(pc, sizeof *where);
    *st = RTO_OK;
    if (!where) {
        *st = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        return SIZE_MAX;
    }
    for (size_t p = 0; p < pc; p++)
        where[p] = UINT32_MAX;
    size_t bad = SIZE_MAX;
    *other = SIZE_MAX;
    for (size_t j = 0; j < n && bad == SIZE_MAX; j++) {
        uint32_t p = d->leaf_prims[j];
        if (p >= pc || prim_empty(d->prim_boxes, p))
            bad = j;
        else if (where[p] != UINT32_MAX) {
            bad = j;
            *other = where[p];
        } else {
            where[p] = (uint32_t)j;
        }
    }
    free(where);
    return bad;
}

/* Reports a leaf order that is not a permutation of the non-empty primitives at the leaf that holds the wrong
 * primitive. Of two leaves holding the same primitive, the wrong one is the one whose box in the tree does not
 * stand for that primitive's box (the tree was built over the right one), else the later one. */
static void leaf_order_fault(rto_report *r, const rto_bvh_check_desc *d, const karras_walk *w, size_t j, size_t other)
{
    const rto_bvh_node *g = d->nodes;
    const size_t pc = d->prim_count;
    const uint32_t p = d->leaf_prims[j];
    size_t bad = j;
    if (other != SIZE_MAX && w && w->leaf_refs[other] && w->leaf_refs[j]) {
        const rto_bvh_node *a = &g[w->leaf_node[other]], *b = &g[w->leaf_node[j]];
        const double *tol = d->leaf_tolerance ? &d->leaf_tolerance[3 * (size_t)p] : NULL;
        int a_ok = leaf_box_ok(child_min(a, w->leaf_side[other]), child_max(a, w->leaf_side[other]), &d->prim_boxes[p],
                               tol);
        int b_ok = leaf_box_ok(child_min(b, w->leaf_side[j]), child_max(b, w->leaf_side[j]), &d->prim_boxes[p], tol);
        if (!a_ok && b_ok)
            bad = other;
    }
    int64_t node = w && w->leaf_refs[bad] ? (int64_t)w->leaf_node[bad] : -1;
    int own;
    if (other != SIZE_MAX)
        own = note(r, RTO_BVH_ITEM, "leaves", node, "sorted leaf %zu holds primitive %" PRIu32 ", which sorted leaf "
                   "%zu holds too: the leaf order is not a permutation (a primitive is in no leaf)", bad, p,
                   bad == j ? other : j);
    else
        own = note(r, RTO_BVH_ITEM, "leaves", node, "sorted leaf %zu holds primitive %" PRIu32 ": %s", j, p,
                   p >= pc ? "no such primitive" : "an instance of an empty BLAS, which has no leaf");
    if (own) {
        rto__report_at(r, "leaf", (int64_t)bad);
        rto__report_at(r, "primitive", p);
        rto__report_table(r, "leaf order", "leaf");
        rto_report_row *row = rto__report_row_add(r, bad, "primitive");
        if (row)
            row->actual = rto__val_uint(p);
    }
}

/* Exact topology against the oracle's links: the first differing node. Every node is compared, also one the walk
 * never reached (its links were not range-checked there), so a leaf link is checked against n before its primitive
 * is looked up. */
static void karras_compare(rto_report *r, const rto_bvh_node *g, const rto_bvh_node *e, size_t count,
                           const uint32_t *prims, size_t n)
{
    for (size_t i = 0; i < count; i++) {
        const rto_bvh_node *x = &g[i], *y = &e[i];
        int own;
        if (x->left != y->left || x->right != y->right) {
            if (x->left == y->right && x->right == y->left) {
                own = note(r, RTO_BVH_SWAPPED, "oracle", (int64_t)i, "node %zu has its children exchanged (left 0x%08"
                           PRIx32 ", right 0x%08" PRIx32 ")", i, x->left, x->right);
            } else {
                int side = x->left != y->left ? 0 : 1;
                uint32_t gc = child_of(x, side), ec = child_of(y, side);
                if ((gc & RTO_BVH_LEAF_BIT) && (gc & ~RTO_BVH_LEAF_BIT) >= n) {
                    own = note(r, RTO_BVH_BAD_LINK, "links", (int64_t)i, "node %zu %s child is leaf %" PRIu32 " of %zu",
                               i, side_name(side), gc & ~RTO_BVH_LEAF_BIT, n);
                } else if (gc & ec & RTO_BVH_LEAF_BIT) {
                    own = note(r, RTO_BVH_ITEM, "oracle", (int64_t)i, "node %zu %s child is leaf %" PRIu32 ", expected "
                               "leaf %" PRIu32, i, side_name(side), gc & ~RTO_BVH_LEAF_BIT, ec & ~RTO_BVH_LEAF_BIT);
                    if (own) {
                        rto__report_at(r, "leaf", gc & ~RTO_BVH_LEAF_BIT);
                        rto__report_at(r, "primitive", prims[gc & ~RTO_BVH_LEAF_BIT]);
                    }
                } else {
                    own = note(r, RTO_BVH_TOPOLOGY, "oracle", (int64_t)i, "node %zu %s child is 0x%08" PRIx32
                               ", expected 0x%08" PRIx32, i, side_name(side), gc, ec);
                }
            }
        } else if (x->parent != y->parent) {
            own = note(r, RTO_BVH_PARENT, "oracle", (int64_t)i, "node %zu parent %" PRIu32 ", expected %" PRIu32, i,
                       x->parent, y->parent);
        } else {
            continue;
        }
        for (size_t k = i; own && k < count && r->nrows < RTO_REPORT_MAX_ROWS; k++) {
            const char *names[3] = {"left", "right", "parent"};
            uint32_t gv[3] = {g[k].left, g[k].right, g[k].parent}, ev[3] = {e[k].left, e[k].right, e[k].parent};
            for (int f = 0; f < 3; f++)
                if (gv[f] != ev[f])
                    link_row(r, k, names[f], rto__val_hex32(ev[f]), gv[f]);
        }
        return;
    }
    rto__report_mark(r, "oracle", RTO_CHECK_PASSED);
}

/* Boxes bottom-up: each node's child boxes after those of every node below it. */
static void karras_boxes(rto_report *r, const rto_bvh_check_desc *d, const karras_walk *w)
{
    const rto_bvh_node *g = d->nodes;
    for (size_t k = 0; k < w->npost; k++) {
        const uint32_t i = w->post[k];
        for (int side = 0; side < 2; side++) {
            const uint32_t c = child_of(&g[i], side);
            const float *mn = child_min(&g[i], side), *mx = child_max(&g[i], side);
            char prefix[2] = {side ? 'r' : 'l', '\0'};
            if (c & RTO_BVH_LEAF_BIT) {
                const uint32_t j = c & ~RTO_BVH_LEAF_BIT, p = d->leaf_prims[j];
                if (p >= d->prim_count || prim_empty(d->prim_boxes, p))
                    continue; /* reported as an item fault */
                const double *tol = d->leaf_tolerance ? &d->leaf_tolerance[3 * (size_t)p] : NULL;
                if (leaf_box_ok(mn, mx, &d->prim_boxes[p], tol))
                    continue;
                if (note(r, RTO_BVH_BOX, "boxes", i, "node %" PRIu32 " %s box (sorted leaf %" PRIu32 ") is not "
                         "primitive %" PRIu32 "'s box%s", i, side_name(side), j, p,
                         tol ? " within the transform tolerance" : "")) {
                    float pmn[3], pmx[3];
                    aabb_arrays(&d->prim_boxes[p], pmn, pmx);
                    rto__report_at(r, "leaf", j);
                    rto__report_at(r, "primitive", p);
                    box_rows(r, i, prefix, mn, mx, pmn, pmx, tol);
                }
            } else {
                const rto_bvh_node *ch = &g[c];
                float umn[3], umx[3];
                union_of(ch->lmin, ch->lmax, ch->rmin, ch->rmax, umn, umx);
                if (!same_box(mn, mx, umn, umx) &&
                    note(r, RTO_BVH_BOX, "boxes", i, "node %" PRIu32 " %s box is not the exact union of node %" PRIu32
                         "'s child boxes", i, side_name(side), c)) {
                    rto__report_at(r, "child", c);
                    box_rows(r, i, prefix, mn, mx, umn, umx, NULL);
                }
            }
        }
    }
}

rto_status rto_karras_check(const rto_bvh_check_desc *d, rto_report *r, rto_msg *msg)
{
    if (!d || !r)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL description or report");
    begin(r, d);
    const rto_bvh_node *g = d->nodes, *exp = d->expected;
    const size_t count = d->node_count, n = d->leaf_count, pc = d->prim_count;
    if ((count && !g) || (pc && !d->prim_boxes) || (n && !d->leaf_prims))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL nodes, leaf order or primitive boxes");
    size_t keyed = 0;
    rto_status s = count_keyed(d->prim_boxes, pc, d->leaf_tolerance, &keyed, msg);
    if (s)
        return s;
    const size_t want = n >= 2 ? n - 1 : 0;
    if (keyed == pc)
        snprintf(r->context, sizeof r->context, "%zu nodes over %zu leaves", count, n);
    else
        snprintf(r->context, sizeof r->context, "%zu nodes over %zu leaves (%zu of %zu primitives empty, in no leaf)",
                 count, n, pc - keyed, pc);
    rto__report_fact(r, "nodes", (int64_t)count);
    rto__report_fact(r, "primitives", (int64_t)pc);
    rto__report_fact(r, "leaves", (int64_t)n);
    if (n != keyed) {
        note(r, RTO_BVH_SIZE, "size", -1, "the leaf order holds %zu primitives; %zu primitives have a non-empty box",
             n, keyed);
        return RTO_ERR_MISMATCH;
    }
    if (count != want) {
        note(r, RTO_BVH_SIZE, "size", -1, "%zu nodes; a Karras tree over %zu leaves has %zu internal nodes", count, n,
             want);
        return RTO_ERR_MISMATCH;
    }
    rto__report_mark(r, "size", RTO_CHECK_PASSED);
    size_t other = SIZE_MAX;
    const size_t bad_prim = first_bad_prim(d, &other, msg, &s);
    if (s)
        return s;
    if (n < 2) { /* no internal node: the root is leaf 0 (or there is nothing) */
        if (bad_prim != SIZE_MAX)
            leaf_order_fault(r, d, NULL, bad_prim, other);
        return finish(r, exp != NULL);
    }
    karras_walk w;
    memset(&w, 0, sizeof w);
    w.state = calloc(count, 1);
    w.leaf_refs = calloc(n, sizeof *w.leaf_refs);
    w.leaf_node = calloc(n, sizeof *w.leaf_node);
    w.leaf_side = calloc(n, 1);
    w.stack = rto__alloc(2 * count + 2, sizeof *w.stack);
    w.post = rto__alloc(count, sizeof *w.post);
    w.first_dup_leaf = SIZE_MAX;
    w.dup_node = -1;
    if (!w.state || !w.leaf_refs || !w.leaf_node || !w.leaf_side || !w.stack || !w.post) {
        walk_free(&w);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    rto_report parents; /* parent faults found on the walk rank after the leaves and the oracle's links */
    rto__report_begin(&parents, "check-bvh");
    if (karras_walk_tree(r, g, count, n, &w, &parents)) {
        walk_free(&w);
        return RTO_ERR_MISMATCH;
    }
    size_t missing = 0, first_missing = SIZE_MAX;
    for (size_t j = 0; j < n; j++)
        if (!w.leaf_refs[j] && !missing++)
            first_missing = j;
    if (missing && w.first_dup_leaf == SIZE_MAX) {
        int64_t node = -1;
        for (size_t i = 0; exp && i < count && node < 0; i++)
            for (int side = 0; side < 2; side++)
                if (child_of(&exp[i], side) == (RTO_BVH_LEAF_BIT | (uint32_t)first_missing))
                    node = (int64_t)i;
        if (note(r, RTO_BVH_DROPPED_LEAF, "leaves", node, "sorted leaf %zu (primitive %" PRIu32 ") is reached from no "
                 "node (%zu leaf/leaves missing)%s", first_missing, d->leaf_prims[first_missing], missing,
                 node >= 0 ? "; the oracle links it from this node" : "")) {
            rto__report_at(r, "leaf", (int64_t)first_missing);
            rto__report_at(r, "primitive", d->leaf_prims[first_missing]);
        }
    }
    if (bad_prim != SIZE_MAX)
        leaf_order_fault(r, d, &w, bad_prim, other);
    if (exp)
        karras_compare(r, g, exp, count, d->leaf_prims, n);
    if (missing && w.first_dup_leaf != SIZE_MAX &&
        note(r, RTO_BVH_ITEM, "leaves", w.dup_node, "sorted leaf %zu is linked twice (second time from node %" PRId64
             ") and leaf %zu never", w.first_dup_leaf, w.dup_node, first_missing)) {
        rto__report_at(r, "leaf", (int64_t)w.first_dup_leaf);
        rto__report_at(r, "primitive", d->leaf_prims[w.first_dup_leaf]);
    }
    if (parents.code != RTO_BVH_OK && note(r, RTO_BVH_PARENT, "links", parents.where[0].value, "%s",
                                           parents.summary + strlen("parent: ")) && parents.nrows) {
        r->rows[0] = parents.rows[0];
        r->nrows = 1;
    }
    if (g[0].parent != RTO_BVH_NO_PARENT &&
        note(r, RTO_BVH_PARENT, "links", 0, "the root's parent is %" PRIu32 ", not 0xFFFFFFFF", g[0].parent))
        link_row(r, 0, "parent", rto__val_hex32(RTO_BVH_NO_PARENT), g[0].parent);
    for (size_t i = 0; i < count; i++)
        if (w.state[i] == 0) {
            note(r, RTO_BVH_TOPOLOGY, "links", (int64_t)i, "internal node %zu is not reachable from the root", i);
            break;
        }
    karras_boxes(r, d, &w);
    walk_free(&w);
    return finish(r, 0);
}
