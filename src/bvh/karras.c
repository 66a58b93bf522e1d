/* Karras 2012, "Maximizing Parallelism in the Construction of BVHs, Octrees, and k-d Trees", §3-§4: the binary
 * radix tree over sorted keys. Internal node i covers a key range found from the common-prefix length δ of its
 * neighbours, so every node is built independently — which is what a GPU kernel does, one thread per node; the
 * oracle runs the same per-node procedure sequentially. Boxes are filled bottom-up afterwards. */
#include "internal.h"

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
    uint64_t a = rto_key_get(k->f, k->keys, (size_t)i), b = rto_key_get(k->f, k->keys, (size_t)j);
    int width = k->f == RTO_KEY_U32 ? 32 : 64;
    if (a != b)
        return clz64(a ^ b) - (64 - width);
    return width + clz64((uint64_t)i ^ (uint64_t)j) - 32;
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

rto_status rto_karras_build(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                            rto_bvh_node *nodes, rto_msg *msg)
{
    if (n > (size_t)INT32_MAX)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu leaves: too many for a Karras tree", n);
    if (n >= 2 && (!sorted_keys || !prim_boxes || !nodes))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL keys, boxes or nodes");
    if (n < 2)
        return RTO_OK; /* no internal nodes: for n = 1 the root is leaf 0 */
    for (size_t i = 1; i < n; i++)
        if (rto_key_get(f, sorted_keys, i - 1) > rto_key_get(f, sorted_keys, i))
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "keys are not sorted at %zu", i);
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
    uint32_t *stack = rto_alloc(2 * n, sizeof *stack);
    if (!stack)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
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
                uint64_t key = rto_key_get(f, sorted_keys, c & ~RTO_BVH_LEAF_BIT);
                box_set(mn, mx, &prim_boxes[rto_key_prim(f, key)]);
            } else {
                const rto_bvh_node *ch = &nodes[c];
                for (int a = 0; a < 3; a++) {
                    mn[a] = rto_minf(ch->lmin[a], ch->rmin[a]);
                    mx[a] = rto_maxf(ch->lmax[a], ch->rmax[a]);
                }
            }
        }
    }
    free(stack);
    return RTO_OK;
}

rto_bvh_stats rto_karras_stats(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box)
{
    rto_bvh_stats st = {0, 0, (uint32_t)n};
    if (n < 2)
        return st;
    float rmn[3] = {root_box->min.x, root_box->min.y, root_box->min.z};
    float rmx[3] = {root_box->max.x, root_box->max.y, root_box->max.z};
    double root = rto_box_area(rmn, rmx), sum = root;
    /* Every child box is counted once: internal children as internal nodes, leaf children as leaves. */
    uint32_t *depth = calloc(n, sizeof *depth);
    if (!depth)
        return st;
    for (size_t i = 0; i + 1 < n; i++) {
        sum += rto_box_area(nodes[i].lmin, nodes[i].lmax) + rto_box_area(nodes[i].rmin, nodes[i].rmax);
    }
    /* Node depths in creation order are not topological, so walk from the root. */
    uint32_t *stack = rto_alloc(n, sizeof *stack);
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
