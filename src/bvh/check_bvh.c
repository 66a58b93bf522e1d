/* Validation of GPU-built trees against the oracle's (exact topology and items, §9 box tolerances) or, when a GPU
 * builds differently, against the scene alone. Faults are classified so that a report names what broke: a cycle,
 * a dropped leaf, a wrong leaf item, swapped children, a box off by an ulp. */
#include "internal.h"

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

/* Distance in ulps between two floats (0 for +0 / -0; infinities are one ulp beyond FLT_MAX). */
static uint64_t ulps(float a, float b)
{
    if (a == b)
        return 0;
    if (isnan(a) || isnan(b))
        return UINT64_MAX;
    uint32_t ua, ub;
    memcpy(&ua, &a, 4);
    memcpy(&ub, &b, 4);
    int64_t oa = (ua & 0x80000000u) ? -(int64_t)(ua & 0x7FFFFFFFu) : (int64_t)ua;
    int64_t ob = (ub & 0x80000000u) ? -(int64_t)(ub & 0x7FFFFFFFu) : (int64_t)ub;
    return (uint64_t)(oa > ob ? oa - ob : ob - oa);
}

/* The worst per-bound ulp distance between two boxes given as min / max triples. */
static uint64_t box_ulps(const float *amn, const float *amx, const float *bmn, const float *bmx)
{
    uint64_t worst = 0;
    for (int a = 0; a < 3; a++) {
        uint64_t u = ulps(amn[a], bmn[a]), v = ulps(amx[a], bmx[a]);
        worst = u > worst ? u : worst;
        worst = v > worst ? v : worst;
    }
    return worst;
}

static void aabb_arrays(const rto_aabb *b, float *mn, float *mx)
{
    mn[0] = b->min.x, mn[1] = b->min.y, mn[2] = b->min.z;
    mx[0] = b->max.x, mx[1] = b->max.y, mx[2] = b->max.z;
}

/* Whether (mn, mx) is exactly the union of two boxes. */
static int is_union(const float *mn, const float *mx, const float *amn, const float *amx, const float *bmn,
                    const float *bmx)
{
    for (int a = 0; a < 3; a++)
        if (mn[a] != rto_minf(amn[a], bmn[a]) || mx[a] != rto_maxf(amx[a], bmx[a]))
            return 0;
    return 1;
}

/* Records a fault; the first one (in the caller's priority order) becomes the report's primary fault. */
static void note(rto_bvh_report *r, rto_bvh_fault f, int64_t node, int64_t leaf, const char *fmt, ...)
    RTO_PRINTF(5, 6);
static void note(rto_bvh_report *r, rto_bvh_fault f, int64_t node, int64_t leaf, const char *fmt, ...)
{
    r->faults |= 1u << f;
    if (r->fault != RTO_BVH_OK)
        return;
    r->fault = f;
    r->node = node;
    r->leaf = leaf;
    int used = snprintf(r->summary, sizeof r->summary, "%s: ", rto_bvh_fault_name(f));
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->summary + used, sizeof r->summary - (size_t)used, fmt, ap);
    va_end(ap);
}

static void report_init(rto_bvh_report *r)
{
    memset(r, 0, sizeof *r);
    r->node = -1;
    r->leaf = -1;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Sweep TLAS                                                                                                           */

static int tnode_equal(const rto_tlas_node *a, const rto_tlas_node *b)
{
    return a->item == b->item && !memcmp(a->min, b->min, sizeof a->min) && !memcmp(a->max, b->max, sizeof a->max);
}

/* Whether the heap subtree rooted at ia in a equals the one rooted at ib in b (same shape: same level). */
static int tsubtree_equal(const rto_tlas_node *a, size_t ia, const rto_tlas_node *b, size_t ib, size_t count)
{
    for (size_t width = 1; ia < count && ib < count; width *= 2) {
        for (size_t k = 0; k < width; k++)
            if (!tnode_equal(&a[ia + k], &b[ib + k]))
                return 0;
        ia = 2 * ia + 1;
        ib = 2 * ib + 1;
    }
    return 1;
}

rto_status rto_tlas_check(const rto_tlas_node *gpu, size_t count, const rto_tlas_node *exp, const rto_aabb *boxes,
                          size_t n, rto_bvh_report *r, rto_msg *msg)
{
    if (!r || (count && !gpu) || (n && !boxes))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL nodes, boxes or report");
    report_init(r);
    const size_t np = rto_next_pow2(n), want = rto_tlas_sweep_node_count(n);
    if (count != want) {
        note(r, RTO_BVH_SIZE, -1, -1, "%zu nodes; a sweep tree over %zu instances has %zu (n_padded %zu)", count, n,
             want, np);
        return RTO_ERR_MISMATCH;
    }
    r->nodes_checked = count;
    if (np == 0) { /* no instances: one EMPTY root */
        const rto_tlas_node *t = &gpu[0];
        int empty = t->item == RTO_TLAS_EMPTY;
        for (int a = 0; a < 3; a++)
            empty &= t->min[a] == INFINITY && t->max[a] == -INFINITY;
        if (!empty)
            note(r, RTO_BVH_EMPTY, 0, -1, "the root of a TLAS without instances must be EMPTY with box (+inf, -inf)");
        return r->fault == RTO_BVH_OK ? RTO_OK : RTO_ERR_MISMATCH;
    }
    uint32_t *seen = calloc(n ? n : 1, sizeof *seen);
    if (!seen)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    /* Leaves: items, instance coverage, leaf boxes within RTO_TLAS_LEAF_ULPS. */
    size_t first_dup_node = SIZE_MAX;
    for (size_t j = 0; j < np; j++) {
        const rto_tlas_node *t = &gpu[np - 1 + j];
        if (t->item < n && seen[t->item]++ && first_dup_node == SIZE_MAX)
            first_dup_node = np - 1 + j;
    }
    size_t missing = 0, first_missing = SIZE_MAX;
    for (size_t i = 0; i < n; i++)
        if (!seen[i] && !missing++)
            first_missing = i;
    if (missing && first_dup_node == SIZE_MAX) {
        size_t node = SIZE_MAX;
        for (size_t j = 0; exp && j < np; j++)
            if (exp[np - 1 + j].item == first_missing)
                node = np - 1 + j;
        note(r, RTO_BVH_DROPPED_LEAF, node == SIZE_MAX ? -1 : (int64_t)node, (int64_t)first_missing,
             "instance %zu is in no leaf (%zu instance(s) missing)%s", first_missing, missing,
             node == SIZE_MAX ? "" : "; the oracle has it at this node");
    }
    /* Exact comparison with the oracle's tree locates the first differing node. */
    if (exp) {
        for (size_t i = 0; i < count && r->fault == RTO_BVH_OK; i++) {
            const rto_tlas_node *g = &gpu[i], *e = &exp[i];
            int leaf = i >= np - 1;
            uint64_t u = box_ulps(g->min, g->max, e->min, e->max);
            if (g->item == e->item && u <= (leaf ? RTO_TLAS_LEAF_ULPS : 0))
                continue;
            size_t p = i ? (i - 1) / 2 : 0;
            if (i && i == 2 * p + 1 && tsubtree_equal(gpu, 2 * p + 1, exp, 2 * p + 2, count) &&
                tsubtree_equal(gpu, 2 * p + 2, exp, 2 * p + 1, count))
                note(r, RTO_BVH_SWAPPED, (int64_t)p, -1, "the subtrees under node %zu (nodes %zu and %zu) are exchanged",
                     p, 2 * p + 1, 2 * p + 2);
            else if (g->item != e->item && leaf && g->item < n && e->item < n)
                note(r, RTO_BVH_ITEM, (int64_t)i, (int64_t)g->item,
                     "leaf node %zu (sorted leaf %zu) holds instance %" PRIu32 ", expected %" PRIu32, i, i - (np - 1),
                     g->item, e->item);
            else if (g->item != e->item && leaf && e->item < n)
                note(r, RTO_BVH_DROPPED_LEAF, (int64_t)i, (int64_t)e->item,
                     "leaf node %zu holds item 0x%08" PRIx32 " instead of instance %" PRIu32, i, g->item, e->item);
            else if (g->item != e->item)
                note(r, RTO_BVH_EMPTY, (int64_t)i, -1, "node %zu item 0x%08" PRIx32 ", expected 0x%08" PRIx32, i,
                     g->item, e->item);
            else
                note(r, RTO_BVH_BOX, (int64_t)i, leaf ? (int64_t)e->item : -1,
                     "node %zu box differs from the oracle's by %" PRIu64 " ulp (tolerance %u): min (%.9g %.9g %.9g) "
                     "max (%.9g %.9g %.9g), expected min (%.9g %.9g %.9g) max (%.9g %.9g %.9g)",
                     i, u, leaf ? RTO_TLAS_LEAF_ULPS : 0, g->min[0], g->min[1], g->min[2], g->max[0], g->max[1],
                     g->max[2], e->min[0], e->min[1], e->min[2], e->max[0], e->max[1], e->max[2]);
        }
    }
    /* Validity against the instance boxes alone. */
    if (missing && first_dup_node != SIZE_MAX)
        note(r, RTO_BVH_ITEM, (int64_t)first_dup_node, (int64_t)gpu[first_dup_node].item,
             "instance %" PRIu32 " appears in two leaves and instance %zu in none", gpu[first_dup_node].item,
             first_missing);
    for (size_t j = 0; j < np; j++) {
        size_t i = np - 1 + j;
        const rto_tlas_node *t = &gpu[i];
        float mn[3], mx[3];
        if (t->item < n) {
            aabb_arrays(&boxes[t->item], mn, mx);
            uint64_t u = box_ulps(t->min, t->max, mn, mx);
            if (u > RTO_TLAS_LEAF_ULPS)
                note(r, RTO_BVH_BOX, (int64_t)i, t->item, "leaf node %zu box is %" PRIu64
                     " ulp from instance %" PRIu32 "'s world box (tolerance %u)", i, u, t->item, RTO_TLAS_LEAF_ULPS);
        } else if (t->item == RTO_TLAS_EMPTY) {
            for (int a = 0; a < 3; a++)
                if (t->min[a] != INFINITY || t->max[a] != -INFINITY) {
                    note(r, RTO_BVH_EMPTY, (int64_t)i, -1, "EMPTY leaf node %zu has a box other than (+inf, -inf)", i);
                    break;
                }
        } else {
            note(r, RTO_BVH_EMPTY, (int64_t)i, -1, "leaf node %zu has item 0x%08" PRIx32 ": neither an instance < %zu nor "
                 "EMPTY", i, t->item, n);
        }
    }
    for (size_t i = np - 1; i-- > 0;) {
        const rto_tlas_node *t = &gpu[i], *a = &gpu[2 * i + 1], *b = &gpu[2 * i + 2];
        uint32_t want_item = (a->item == RTO_TLAS_EMPTY && b->item == RTO_TLAS_EMPTY) ? RTO_TLAS_EMPTY : RTO_TLAS_INTERNAL;
        if (t->item != want_item)
            note(r, RTO_BVH_EMPTY, (int64_t)i, -1, "internal node %zu item 0x%08" PRIx32 ", expected 0x%08" PRIx32
                 " from its children", i, t->item, want_item);
        if (!is_union(t->min, t->max, a->min, a->max, b->min, b->max))
            note(r, RTO_BVH_BOX, (int64_t)i, -1, "node %zu box is not the exact union of its children %zu and %zu", i,
                 2 * i + 1, 2 * i + 2);
    }
    free(seen);
    return r->fault == RTO_BVH_OK ? RTO_OK : RTO_ERR_MISMATCH;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Karras layout                                                                                                        */

static const float *child_min(const rto_bvh_node *nd, int side) { return side ? nd->rmin : nd->lmin; }
static const float *child_max(const rto_bvh_node *nd, int side) { return side ? nd->rmax : nd->lmax; }
static uint32_t child_of(const rto_bvh_node *nd, int side) { return side ? nd->right : nd->left; }

rto_status rto_karras_check(const rto_bvh_node *gpu, size_t count, const rto_bvh_node *exp, const uint32_t *leaf_prims,
                            const rto_aabb *prim_boxes, size_t n, uint32_t leaf_ulps, rto_bvh_report *r, rto_msg *msg)
{
    if (!r || (count && !gpu) || (n && (!leaf_prims || !prim_boxes)))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL nodes, leaf order, boxes or report");
    report_init(r);
    const size_t want = n >= 2 ? n - 1 : 0;
    if (count != want) {
        note(r, RTO_BVH_SIZE, -1, -1, "%zu nodes; a Karras tree over %zu leaves has %zu internal nodes", count, n,
             want);
        return RTO_ERR_MISMATCH;
    }
    r->nodes_checked = count;
    if (n < 2)
        return RTO_OK;
    unsigned char *state = calloc(count, 1); /* 0 unvisited, 1 on the current path, 2 done */
    uint32_t *leaf_refs = calloc(n, sizeof *leaf_refs), *stack = rto_alloc(2 * count + 2, sizeof *stack);
    int64_t *dup_node = malloc(n * sizeof *dup_node);
    if (!state || !leaf_refs || !stack || !dup_node) {
        free(state);
        free(leaf_refs);
        free(stack);
        free(dup_node);
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (size_t j = 0; j < n; j++)
        dup_node[j] = -1;
    /* Iterative DFS with enter/exit marks: a link to a node on the path is a cycle, to a finished node a share. */
    size_t top = 0, first_dup_leaf = SIZE_MAX;
    int broken = 0;
    stack[top++] = 0;
    state[0] = 1;
    while (top && !broken) {
        uint32_t e = stack[top - 1], i = e & 0x7FFFFFFFu;
        if (e & 0x80000000u) {
            state[i] = 2;
            top--;
            continue;
        }
        stack[top - 1] |= 0x80000000u;
        for (int side = 0; side < 2 && !broken; side++) {
            uint32_t c = child_of(&gpu[i], side);
            if (c & RTO_BVH_LEAF_BIT) {
                uint32_t j = c & ~RTO_BVH_LEAF_BIT;
                if (j >= n) {
                    note(r, RTO_BVH_BAD_LINK, i, -1, "node %" PRIu32 " %s child is leaf %" PRIu32 " of %zu", i,
                         side ? "right" : "left", j, n);
                    broken = 1;
                } else if (leaf_refs[j]++ && first_dup_leaf == SIZE_MAX) {
                    first_dup_leaf = j;
                    dup_node[j] = i;
                }
            } else if (c >= count) {
                note(r, RTO_BVH_BAD_LINK, i, -1, "node %" PRIu32 " %s child is internal node %" PRIu32 " of %zu", i,
                     side ? "right" : "left", c, count);
                broken = 1;
            } else if (state[c] == 1) {
                note(r, RTO_BVH_CYCLE, i, -1, "node %" PRIu32 " links back to its ancestor %" PRIu32 " (%s child)", i,
                     c, side ? "right" : "left");
                broken = 1;
            } else if (state[c] == 2) {
                note(r, RTO_BVH_SHARED, i, -1, "node %" PRIu32 " links to node %" PRIu32 ", already reached from "
                     "another parent", i, c);
                broken = 1;
            } else {
                if (gpu[c].parent != i)
                    note(r, RTO_BVH_PARENT, c, -1, "node %" PRIu32 " has parent %" PRIu32 " but is a child of %" PRIu32,
                         c, gpu[c].parent, i);
                state[c] = 1;
                stack[top++] = c;
            }
        }
    }
    rto_bvh_report parent_note = *r; /* a parent fault found during the walk ranks after leaves and exact faults */
    if (!broken && r->fault == RTO_BVH_PARENT)
        report_init(r);
    if (!broken) {
        size_t missing = 0, first_missing = SIZE_MAX;
        for (size_t j = 0; j < n; j++)
            if (!leaf_refs[j] && !missing++)
                first_missing = j;
        if (missing && first_dup_leaf == SIZE_MAX) {
            int64_t node = -1;
            for (size_t i = 0; exp && i < count && node < 0; i++)
                for (int side = 0; side < 2; side++)
                    if (child_of(&exp[i], side) == (RTO_BVH_LEAF_BIT | (uint32_t)first_missing))
                        node = (int64_t)i;
            char where[64] = "";
            if (node >= 0)
                snprintf(where, sizeof where, "; the oracle links it from node %lld", (long long)node);
            note(r, RTO_BVH_DROPPED_LEAF, node, (int64_t)leaf_prims[first_missing],
                 "sorted leaf %zu (primitive %" PRIu32 ") is reached from no node (%zu leaf/leaves missing)%s",
                 first_missing, leaf_prims[first_missing], missing, where);
        }
        if (exp) {
            for (size_t i = 0; i < count && r->fault == RTO_BVH_OK; i++) {
                const rto_bvh_node *g = &gpu[i], *e = &exp[i];
                if (g->left != e->left || g->right != e->right) {
                    if (g->left == e->right && g->right == e->left)
                        note(r, RTO_BVH_SWAPPED, (int64_t)i, -1, "node %zu has its children exchanged (left 0x%08" PRIx32
                             ", right 0x%08" PRIx32 ")", i, g->left, g->right);
                    else {
                        int side = g->left != e->left ? 0 : 1;
                        uint32_t gc = child_of(g, side), ec = child_of(e, side);
                        if ((gc & ec & RTO_BVH_LEAF_BIT))
                            note(r, RTO_BVH_ITEM, (int64_t)i, (int64_t)leaf_prims[gc & ~RTO_BVH_LEAF_BIT],
                                 "node %zu %s child is leaf %" PRIu32 ", expected leaf %" PRIu32, i,
                                 side ? "right" : "left", gc & ~RTO_BVH_LEAF_BIT, ec & ~RTO_BVH_LEAF_BIT);
                        else
                            note(r, RTO_BVH_TOPOLOGY, (int64_t)i, -1, "node %zu %s child is 0x%08" PRIx32
                                 ", expected 0x%08" PRIx32, i, side ? "right" : "left", gc, ec);
                    }
                } else if (g->parent != e->parent) {
                    note(r, RTO_BVH_PARENT, (int64_t)i, -1, "node %zu parent %" PRIu32 ", expected %" PRIu32, i,
                         g->parent, e->parent);
                } else {
                    for (int side = 0; side < 2; side++) {
                        uint32_t c = child_of(g, side);
                        uint32_t tol = (c & RTO_BVH_LEAF_BIT) ? leaf_ulps : 0;
                        uint64_t u = box_ulps(child_min(g, side), child_max(g, side), child_min(e, side),
                                              child_max(e, side));
                        if (u > tol) {
                            note(r, RTO_BVH_BOX, (int64_t)i, -1, "node %zu %s box differs from the oracle's by %" PRIu64
                                 " ulp (tolerance %" PRIu32 ")", i, side ? "right" : "left", u, tol);
                            break;
                        }
                    }
                }
            }
        }
        if (missing && first_dup_leaf != SIZE_MAX)
            note(r, RTO_BVH_ITEM, dup_node[first_dup_leaf], (int64_t)leaf_prims[first_dup_leaf],
                 "sorted leaf %zu is linked twice (second time from node %" PRId64 ") and leaf %zu never", first_dup_leaf,
                 dup_node[first_dup_leaf], first_missing);
        if (parent_note.fault == RTO_BVH_PARENT)
            note(r, RTO_BVH_PARENT, parent_note.node, -1, "%s", parent_note.summary + strlen("parent: "));
        if (gpu[0].parent != RTO_BVH_NO_PARENT)
            note(r, RTO_BVH_PARENT, 0, -1, "the root's parent is %" PRIu32 ", not 0xFFFFFFFF", gpu[0].parent);
        for (size_t i = 0; i < count; i++)
            if (state[i] == 0) {
                note(r, RTO_BVH_TOPOLOGY, (int64_t)i, -1, "internal node %zu is not reachable from the root", i);
                break;
            }
        /* Boxes: leaf children against the primitive boxes, internal children as exact unions. */
        for (size_t i = 0; i < count; i++) {
            if (state[i] != 2)
                continue;
            for (int side = 0; side < 2; side++) {
                uint32_t c = child_of(&gpu[i], side);
                const float *mn = child_min(&gpu[i], side), *mx = child_max(&gpu[i], side);
                if (c & RTO_BVH_LEAF_BIT) {
                    uint32_t j = c & ~RTO_BVH_LEAF_BIT, prim = leaf_prims[j];
                    float pmn[3], pmx[3];
                    aabb_arrays(&prim_boxes[prim], pmn, pmx);
                    uint64_t u = box_ulps(mn, mx, pmn, pmx);
                    if (u > leaf_ulps)
                        note(r, RTO_BVH_BOX, (int64_t)i, prim, "node %zu %s box is %" PRIu64 " ulp from primitive %"
                             PRIu32 "'s box (tolerance %" PRIu32 ")", i, side ? "right" : "left", u, prim, leaf_ulps);
                } else {
                    const rto_bvh_node *ch = &gpu[c];
                    if (!is_union(mn, mx, ch->lmin, ch->lmax, ch->rmin, ch->rmax))
                        note(r, RTO_BVH_BOX, (int64_t)i, -1, "node %zu %s box is not the exact union of node %" PRIu32
                             "'s child boxes", i, side ? "right" : "left", c);
                }
            }
        }
    }
    free(state);
    free(leaf_refs);
    free(stack);
    free(dup_node);
    return r->fault == RTO_BVH_OK ? RTO_OK : RTO_ERR_MISMATCH;
}
