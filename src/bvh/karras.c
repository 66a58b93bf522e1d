/* Karras 2012, "Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d Trees", §3-§4: the binary
 * radix tree over sorted keys. Internal node i covers a key range found from the common-prefix length δ of its
 * neighbours, so every node can be built independently — which is what a GPU kernel does, one thread per node.
 *
 * Two builders give the same bytes:
 *   - rto__karras_build_scalar: that per-node procedure for every node, then boxes bottom-up over an explicit stack
 *     (kept as the tests' reference);
 *   - the fast builder (rto_karras_build, the accel): the tree is unique (the keys with their index appended are
 *     distinct, and a range's split is where its two halves differ first), so it is built bottom-up in one sweep over
 *     the leaves, as a Cartesian tree over the adjacent prefixes δ(k, k+1): a subtree [lo, hi] is the left child of
 *     split hi when δ(hi, hi+1) > δ(lo-1, lo) and the right child of split lo-1 otherwise (Apetrei 2014, "Fast and
 *     Simple Agglomerative LBVH Construction", without atomics: a stack holds the left siblings still waiting for
 *     their right one). Karras numbers a left child by the end of its range and a right child by the start (the
 *     root, 0, counts as a right child), so each node's index, links, parent and boxes are written as it is closed,
 *     and its height gives the tree's depth. With several workers the per-node procedure cuts the top of the tree
 *     into subtrees of at most n / (8 workers) leaves; each worker sweeps the subtrees whose first leaf lies in its
 *     static share of the leaves, and the few top nodes get their boxes last. Every node is a function of the keys
 *     alone, so the bytes do not depend on the worker count. */
#include "bvh_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct keyset {
    rto_key_format f;
    const void *keys;
    int64_t n;
} keyset;

static int clz64(uint64_t v) { return v ? __builtin_clzll(v) : 64; }

/* δ(i, j): common-prefix length of keys i and j, -1 when j is outside [0, n-1]. Equal keys fall back to the
 * prefix of their indices (Karras §4), so duplicate keys still give a valid tree. */
static int delta(const keyset *k, int64_t i, int64_t j)
{
    if (j < 0 || j >= k->n)
        return -1;
    uint64_t a = rto__key_get(k->f, k->keys, (size_t)i), b = rto__key_get(k->f, k->keys, (size_t)j);
    int width = k->f == RTO_KEY_U32 ? 32 : 64;
    if (a != b)
        return clz64(a ^ b) - (64 - width);
    return width + clz64((uint64_t)i ^ (uint64_t)j) - 32;
}

/* The per-node procedure (Karras §4): internal node i's range [lo, hi] and split gamma. */
static void karras_node(const keyset *k, int64_t i, int64_t *lo, int64_t *hi, int64_t *split)
{
    int d = delta(k, i, i + 1) - delta(k, i, i - 1) >= 0 ? 1 : -1;
    int dmin = delta(k, i, i - d);
    int64_t lmax = 2;
    while (delta(k, i, i + lmax * d) > dmin)
        lmax *= 2;
    int64_t l = 0;
    for (int64_t t = lmax / 2; t >= 1; t /= 2)
        if (delta(k, i, i + (l + t) * d) > dmin)
            l += t;
    int64_t j = i + l * d;
    int dnode = delta(k, i, j);
    int64_t s = 0;
    for (int64_t div = 2;; div *= 2) {
        int64_t t = (l + div - 1) / div;
        if (delta(k, i, i + (s + t) * d) > dnode)
            s += t;
        if (t == 1)
            break;
    }
    *split = i + s * d + (d < 0 ? -1 : 0);
    *lo = i < j ? i : j;
    *hi = i < j ? j : i;
}

static void box_set(float *mn, float *mx, const rto_aabb *b)
{
    mn[0] = b->min.x;
    mn[1] = b->min.y;
    mn[2] = b->min.z;
    mx[0] = b->max.x;
    mx[1] = b->max.y;
    mx[2] = b->max.z;
}

/* What both builders require: at most INT32_MAX leaves, the arrays (from 2 leaves on), a known format, sorted keys. */
static rto_status karras_args(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                              const rto_bvh_node *nodes, rto_msg *msg)
{
    if (n > (size_t)INT32_MAX)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu leaves: too many for a Karras tree", n);
    if (n >= 2 && (!sorted_keys || !prim_boxes || !nodes))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL keys, boxes or nodes");
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    for (size_t i = 1; i < n; i++)
        if (rto__key_get(f, sorted_keys, i - 1) > rto__key_get(f, sorted_keys, i))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "keys are not sorted at %zu", i);
    return RTO_OK;
}

rto_status rto__karras_build_scalar(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                                   rto_bvh_node *nodes, rto_msg *msg)
{
    rto_status bad = karras_args(f, sorted_keys, n, prim_boxes, nodes, msg);
    if (bad || n < 2)
        return bad; /* n < 2: no internal nodes (for n = 1 the root is leaf 0) */
    keyset k = {f, sorted_keys, (int64_t)n};
    for (int64_t i = 0; i < (int64_t)n - 1; i++) {
        /* Direction of the range: towards the neighbour sharing the longer prefix. */
        int d = delta(&k, i, i + 1) - delta(&k, i, i - 1) >= 0 ? 1 : -1;
        int dmin = delta(&k, i, i - d);
        int64_t lmax = 2;
        while (delta(&k, i, i + lmax * d) > dmin)
            lmax *= 2;
        int64_t l = 0;
        for (int64_t t = lmax / 2; t >= 1; t /= 2)
            if (delta(&k, i, i + (l + t) * d) > dmin)
                l += t;
        int64_t j = i + l * d;
        /* Split: the last position in the range sharing more than δ(i, j) bits with i. */
        int dnode = delta(&k, i, j);
        int64_t s = 0;
        for (int64_t div = 2;; div *= 2) {
            int64_t t = (l + div - 1) / div;
            if (delta(&k, i, i + (s + t) * d) > dnode)
                s += t;
            if (t == 1)
                break;
        }
        int64_t gamma = i + s * d + (d < 0 ? -1 : 0);
        int64_t lo = i < j ? i : j, hi = i < j ? j : i;
        rto_bvh_node *nd = &nodes[i];
        memset(nd, 0, sizeof *nd);
        nd->left = lo == gamma ? (RTO_BVH_LEAF_BIT | (uint32_t)gamma) : (uint32_t)gamma;
        nd->right = hi == gamma + 1 ? (RTO_BVH_LEAF_BIT | (uint32_t)(gamma + 1)) : (uint32_t)(gamma + 1);
    }
    nodes[0].parent = RTO_BVH_NO_PARENT;
    for (size_t i = 0; i + 1 < n; i++) {
        if (!(nodes[i].left & RTO_BVH_LEAF_BIT))
            nodes[nodes[i].left].parent = (uint32_t)i;
        if (!(nodes[i].right & RTO_BVH_LEAF_BIT))
            nodes[nodes[i].right].parent = (uint32_t)i;
    }
    /* Boxes bottom-up: post-order over an explicit stack (depth can reach n - 1 for adversarial keys). */
    uint32_t *stack = rto__alloc(2 * n, sizeof *stack);
    if (!stack)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    size_t top = 0;
    stack[top++] = 0;
    while (top) {
        uint32_t i = stack[top - 1] & 0x7FFFFFFFu;
        int expanded = (stack[top - 1] & 0x80000000u) != 0;
        rto_bvh_node *nd = &nodes[i];
        if (!expanded) {
            stack[top - 1] |= 0x80000000u;
            if (!(nd->left & RTO_BVH_LEAF_BIT))
                stack[top++] = nd->left;
            if (!(nd->right & RTO_BVH_LEAF_BIT))
                stack[top++] = nd->right;
            continue;
        }
        top--;
        for (int side = 0; side < 2; side++) {
            uint32_t c = side ? nd->right : nd->left;
            float *mn = side ? nd->rmin : nd->lmin, *mx = side ? nd->rmax : nd->lmax;
            if (c & RTO_BVH_LEAF_BIT) {
                uint64_t key = rto__key_get(f, sorted_keys, c & ~RTO_BVH_LEAF_BIT);
                box_set(mn, mx, &prim_boxes[rto_key_prim(f, key)]);
            } else {
                const rto_bvh_node *ch = &nodes[c];
                for (int a = 0; a < 3; a++) {
                    mn[a] = rto__minf(ch->lmin[a], ch->rmin[a]);
                    mx[a] = rto__maxf(ch->lmax[a], ch->rmax[a]);
                }
            }
        }
    }
    free(stack);
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The fast builder                                                                                                 */

/* δ(k, k+1) of adjacent keys (the extended key's common prefix, as delta()), -1 when k or k+1 is outside [0, n-1]. */
static inline __attribute__((always_inline)) int adj_delta(rto_key_format f, const void *keys, int64_t n, int64_t k)
{
    if (k < 0 || k + 1 >= n)
        return -1;
    if (f == RTO_KEY_U64) {
        const uint64_t a = ((const uint64_t *)keys)[k], b = ((const uint64_t *)keys)[k + 1];
        if (a != b)
            return __builtin_clzll(a ^ b);
        return 64 + clz64((uint64_t)k ^ (uint64_t)(k + 1)) - 32;
    }
    const uint32_t a = ((const uint32_t *)keys)[k], b = ((const uint32_t *)keys)[k + 1];
    if (a != b)
        return __builtin_clz(a ^ b);
    return 32 + clz64((uint64_t)k ^ (uint64_t)(k + 1)) - 32;
}

/* A closed subtree waiting on the stack for its right sibling. */
typedef struct open_tree {
    float mn[3], mx[3];
    uint32_t ref; /* node index, or RTO_BVH_LEAF_BIT | leaf */
    uint32_t lo;  /* first leaf */
    int dl;       /* δ(lo - 1, lo) */
    uint32_t h;   /* height (leaf 0) */
} open_tree;

/* The stack holds left children whose parents are distinct ancestors of the current leaf, so it never holds more
 * entries than the tree is deep; and δ grows strictly down every path, from 0 at most to 95 (64 key bits, then 31
 * index bits for equal keys), so no tree is deeper than 97. */
#define OPEN_MAX 128
#define PREFETCH 16

/* The sweep over the leaves [job->lo, job->hi] (a subtree: its root is job->root). */
static inline __attribute__((always_inline)) void sweep(rto_key_format f, const rto__karras *k, rto__karras_job *job,
                                                        open_tree *stack)
{
    const void *keys = k->keys;
    const int64_t n = (int64_t)k->n;
    rto_bvh_node *nodes = k->nodes;
    const uint32_t lo = job->lo, hi = job->hi;
    size_t top = 0;
    int dl = adj_delta(f, keys, n, (int64_t)lo - 1);
    for (uint32_t i = lo; i <= hi; i++) {
        /* cur: leaf i, then each node it closes; its range is [clo, i]. Kept in scalars (registers): copying the
         * struct through memory stalls on store forwarding. */
        const rto_aabb *b = &k->boxes[rto_key_prim(f, rto__key_get(f, keys, i))];
        if (i + PREFETCH <= hi) /* leaves visit the boxes in key order, not memory order */
            __builtin_prefetch(&k->boxes[rto_key_prim(f, rto__key_get(f, keys, i + PREFETCH))]);
        float mn0 = b->min.x, mn1 = b->min.y, mn2 = b->min.z, mx0 = b->max.x, mx1 = b->max.y, mx2 = b->max.z;
        uint32_t ref = RTO_BVH_LEAF_BIT | i, clo = i, h = 0;
        int cdl = dl;
        const int dr = adj_delta(f, keys, n, i);
        dl = dr; /* the next leaf's left prefix */
        for (;;) {
            if (clo == lo && i == hi) { /* the subtree's root */
                job->height = h;
                nodes[job->root].parent = job->parent;
                break;
            }
            if (dr > cdl) { /* the left child of split i: its sibling starts at leaf i + 1 */
                open_tree *o = &stack[top++];
                o->mn[0] = mn0;
                o->mn[1] = mn1;
                o->mn[2] = mn2;
                o->mx[0] = mx0;
                o->mx[1] = mx1;
                o->mx[2] = mx2;
                o->ref = ref;
                o->lo = clo;
                o->dl = cdl;
                o->h = h;
                break;
            }
            /* The right child of split clo - 1, whose left child is on top of the stack. */
            const open_tree *l = &stack[--top];
            const uint32_t plo = l->lo;
            /* Is the new node [plo, i] a left child (index i) or a right child (index plo)? */
            const uint32_t idx = dr > l->dl ? i : plo;
            rto_bvh_node *nd = &nodes[idx];
            nd->lmin[0] = l->mn[0];
            nd->lmin[1] = l->mn[1];
            nd->lmin[2] = l->mn[2];
            nd->left = l->ref;
            nd->lmax[0] = l->mx[0];
            nd->lmax[1] = l->mx[1];
            nd->lmax[2] = l->mx[2];
            nd->right = ref;
            nd->rmin[0] = mn0;
            nd->rmin[1] = mn1;
            nd->rmin[2] = mn2;
            nd->rmax[0] = mx0;
            nd->rmax[1] = mx1;
            nd->rmax[2] = mx2;
            nd->pad = 0;
            if (k->areas) /* rto_karras_stats' term of this node, summed later in index order */
                k->areas[idx] = rto__box_area(nd->lmin, nd->lmax) + rto__box_area(nd->rmin, nd->rmax);
            if (!(l->ref & RTO_BVH_LEAF_BIT))
                nodes[l->ref].parent = idx;
            if (!(ref & RTO_BVH_LEAF_BIT))
                nodes[ref].parent = idx;
            mn0 = rto__minf(l->mn[0], mn0);
            mn1 = rto__minf(l->mn[1], mn1);
            mn2 = rto__minf(l->mn[2], mn2);
            mx0 = rto__maxf(l->mx[0], mx0);
            mx1 = rto__maxf(l->mx[1], mx1);
            mx2 = rto__maxf(l->mx[2], mx2);
            h = 1 + (l->h > h ? l->h : h);
            ref = idx;
            clo = plo;
            cdl = l->dl;
        }
    }
}

static void run_job(const rto__karras *k, rto__karras_job *job)
{
    open_tree stack[OPEN_MAX];
    if (k->f == RTO_KEY_U64)
        sweep(RTO_KEY_U64, k, job, stack);
    else
        sweep(RTO_KEY_U32, k, job, stack);
}

void rto__karras_free(rto__karras *k)
{
    if (!k)
        return;
    free(k->jobs);
    free(k->tops);
    k->jobs = NULL;
    k->tops = NULL;
}

/* A child of a top node: a leaf, a job's root or another top node. */
#define SLOT_LEAF (-1)

rto_status rto__karras_plan(rto__karras *k, uint32_t workers, rto_msg *msg)
{
    const size_t n = k->n;
    k->job_count = k->top_count = 0;
    k->depth = 0;
    k->workers = workers ? workers : 1;
    if (n < 2)
        return RTO_OK;
    /* Subtrees of at most `target` leaves, several per worker; a tree too deep to cut (adversarial keys) stops at
     * cap top nodes and leaves bigger subtrees. */
    const size_t share = n / (8 * (size_t)k->workers);
    const size_t target = k->workers == 1 ? n : (share > 1024 ? share : 1024);
    const size_t cap = k->workers == 1 ? 0 : 64 * (size_t)k->workers;
    /* Depth-first, left child first: jobs come out in leaf order. todo holds (node, lo, hi, parent, top, side). */
    struct todo {
        uint32_t node, lo, hi, parent;
        int64_t top;
        int side;
    } *todo = rto__alloc(cap + 2, sizeof *todo);
    k->jobs = rto__alloc(cap + 1, sizeof *k->jobs);
    k->tops = rto__alloc(cap + 1, sizeof *k->tops);
    if (!k->jobs || !k->tops || !todo) {
        free(todo);
        rto__karras_free(k);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    size_t nt = 0;
    todo[nt++] = (struct todo){0, 0, (uint32_t)(n - 1), RTO_BVH_NO_PARENT, -1, 0};
    keyset ks = {k->f, k->keys, (int64_t)n};
    while (nt) {
        struct todo c = todo[--nt];
        const size_t leaves = (size_t)c.hi - c.lo + 1;
        if (leaves <= target || k->top_count >= cap) {
            rto__karras_job *j = &k->jobs[k->job_count];
            *j = (rto__karras_job){c.lo, c.hi, c.node, c.parent, 0};
            if (c.top >= 0)
                k->tops[c.top].slot[c.side] = (int64_t)k->job_count;
            k->job_count++;
            continue;
        }
        int64_t lo, hi, g;
        karras_node(&ks, c.node, &lo, &hi, &g);
        rto__karras_top *t = &k->tops[k->top_count];
        rto_bvh_node *nd = &k->nodes[c.node];
        memset(nd, 0, sizeof *nd);
        nd->parent = c.parent;
        nd->left = lo == g ? (RTO_BVH_LEAF_BIT | (uint32_t)g) : (uint32_t)g;
        nd->right = hi == g + 1 ? (RTO_BVH_LEAF_BIT | (uint32_t)(g + 1)) : (uint32_t)(g + 1);
        t->node = c.node;
        t->slot[0] = t->slot[1] = SLOT_LEAF;
        t->height = 0;
        if (c.top >= 0)
            k->tops[c.top].slot[c.side] = -2 - (int64_t)k->top_count;
        const int64_t self = (int64_t)k->top_count++;
        if (!(nd->right & RTO_BVH_LEAF_BIT))
            todo[nt++] = (struct todo){nd->right, (uint32_t)(g + 1), (uint32_t)hi, c.node, self, 1};
        if (!(nd->left & RTO_BVH_LEAF_BIT))
            todo[nt++] = (struct todo){nd->left, (uint32_t)lo, (uint32_t)g, c.node, self, 0};
    }
    free(todo);
    return RTO_OK;
}

void rto__karras_run(rto__karras *k, uint32_t worker, uint32_t workers)
{
    if (k->n < 2)
        return;
    size_t begin, end;
    rto__part(k->n, worker, workers, &begin, &end);
    for (size_t j = 0; j < k->job_count; j++)
        if (k->jobs[j].lo >= begin && k->jobs[j].lo < end)
            run_job(k, &k->jobs[j]);
}

/* The child box and height of a top node's side. */
static void top_child(const rto__karras *k, const rto__karras_top *t, int side, float mn[3], float mx[3], uint32_t *h)
{
    const rto_bvh_node *nd = &k->nodes[t->node];
    const uint32_t c = side ? nd->right : nd->left;
    if (c & RTO_BVH_LEAF_BIT) {
        const rto_aabb *b = &k->boxes[rto_key_prim(k->f, rto__key_get(k->f, k->keys, c & ~RTO_BVH_LEAF_BIT))];
        box_set(mn, mx, b);
        *h = 0;
        return;
    }
    const rto_bvh_node *ch = &k->nodes[c];
    for (int a = 0; a < 3; a++) {
        mn[a] = rto__minf(ch->lmin[a], ch->rmin[a]);
        mx[a] = rto__maxf(ch->lmax[a], ch->rmax[a]);
    }
    const int64_t s = t->slot[side];
    *h = s >= 0 ? k->jobs[s].height : k->tops[-2 - s].height;
}

void rto__karras_finish(rto__karras *k)
{
    if (k->n < 2)
        return;
    /* Top nodes in reverse creation order: children before parents. */
    for (size_t i = k->top_count; i-- > 0;) {
        rto__karras_top *t = &k->tops[i];
        rto_bvh_node *nd = &k->nodes[t->node];
        uint32_t hl, hr;
        top_child(k, t, 0, nd->lmin, nd->lmax, &hl);
        top_child(k, t, 1, nd->rmin, nd->rmax, &hr);
        if (k->areas)
            k->areas[t->node] = rto__box_area(nd->lmin, nd->lmax) + rto__box_area(nd->rmin, nd->rmax);
        t->height = 1 + (hl > hr ? hl : hr);
    }
    k->depth = k->top_count ? k->tops[0].height : k->jobs[0].height;
}

rto_status rto_karras_build(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                            rto_bvh_node *nodes, rto_msg *msg)
{
    rto_status s = karras_args(f, sorted_keys, n, prim_boxes, nodes, msg);
    if (s)
        return s;
    rto__karras k;
    memset(&k, 0, sizeof k);
    k.f = f;
    k.keys = sorted_keys;
    k.n = n;
    k.boxes = prim_boxes;
    k.nodes = nodes;
    s = rto__karras_plan(&k, 1, msg);
    if (s)
        return s;
    rto__karras_run(&k, 0, 1);
    rto__karras_finish(&k);
    rto__karras_free(&k);
    return RTO_OK;
}

/* SAH cost as rto_karras_stats sums it (root, then both child boxes of every internal node in index order), with the
 * depth the builder measured and, when areas is not NULL, each node's term as the builder computed it. */
rto_bvh_stats rto__karras_stats_depth(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box, uint32_t depth,
                                      const double *areas)
{
    rto_bvh_stats st = {0, 0, (uint32_t)n};
    if (n < 2)
        return st;
    float rmn[3] = {root_box->min.x, root_box->min.y, root_box->min.z};
    float rmx[3] = {root_box->max.x, root_box->max.y, root_box->max.z};
    double root = rto__box_area(rmn, rmx), sum = root;
    if (areas)
        for (size_t i = 0; i + 1 < n; i++)
            sum += areas[i];
    else
        for (size_t i = 0; i + 1 < n; i++)
            sum += rto__box_area(nodes[i].lmin, nodes[i].lmax) + rto__box_area(nodes[i].rmin, nodes[i].rmax);
    st.depth = depth;
    st.sah = root > 0 ? sum / root : 0;
    return st;
}

rto_bvh_stats rto_karras_stats(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box)
{
    rto_bvh_stats st = {0, 0, (uint32_t)n};
    if (n < 2)
        return st;
    float rmn[3] = {root_box->min.x, root_box->min.y, root_box->min.z};
    float rmx[3] = {root_box->max.x, root_box->max.y, root_box->max.z};
    double root = rto__box_area(rmn, rmx), sum = root;
    /* Every child box is counted once: internal children as internal nodes, leaf children as leaves. */
    uint32_t *depth = calloc(n, sizeof *depth);
    if (!depth)
        return st;
    for (size_t i = 0; i + 1 < n; i++) {
        sum += rto__box_area(nodes[i].lmin, nodes[i].lmax) + rto__box_area(nodes[i].rmin, nodes[i].rmax);
    }
    /* Node depths in creation order are not topological, so walk from the root. */
    uint32_t *stack = rto__alloc(n, sizeof *stack);
    if (stack) {
        size_t top = 0;
        stack[top++] = 0;
        while (top) {
            uint32_t i = stack[--top];
            uint32_t c[2] = {nodes[i].left, nodes[i].right};
            for (int s = 0; s < 2; s++) {
                if (c[s] & RTO_BVH_LEAF_BIT) {
                    st.depth = depth[i] + 1 > st.depth ? depth[i] + 1 : st.depth;
                } else {
                    depth[c[s]] = depth[i] + 1;
                    stack[top++] = c[s];
                }
            }
        }
        free(stack);
    }
    free(depth);
    st.sah = root > 0 ? sum / root : 0;
    return st;
}
