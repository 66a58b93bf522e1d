/* The TLAS sweep tree of DESIGN.md §5: the seeds' implicit heap over N_PADDED sorted leaves, built bottom-up by
 * AABB union from already sorted TLAS keys (the keys and their sort live in src/keys and src/sort). Children of node
 * i are 2i+1 and 2i+2; leaf j (sorted position j) is node N_PADDED - 1 + j. EMPTY boxes are (+inf, -inf), the
 * identity of the union, so an internal node's box is the plain union of both children. */
#include "bvh_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

size_t rto_tlas_sweep_node_count(size_t n)
{
    size_t np = rto_next_pow2(n);
    return np ? 2 * np - 1 : 1;
}

static void set_empty(rto_tlas_node *t)
{
    memset(t, 0, sizeof *t);
    t->min[0] = t->min[1] = t->min[2] = INFINITY;
    t->max[0] = t->max[1] = t->max[2] = -INFINITY;
    t->item = RTO_TLAS_EMPTY;
}

rto_status rto_tlas_build_sweep(const uint32_t *sorted_keys, size_t n, const rto_aabb *boxes, rto_tlas_node *nodes,
                                rto_msg *msg)
{
    if (n > RTO_TLAS_MAX_INSTANCES)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu leaves: the sweep TLAS holds at most %u", n,
                        RTO_TLAS_MAX_INSTANCES);
    if ((n && (!sorted_keys || !boxes)) || !nodes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL keys, boxes or nodes");
    for (size_t i = 1; i < n; i++)
        if (sorted_keys[i - 1] >= sorted_keys[i])
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "keys are not sorted and distinct at %zu", i);
    const size_t np = rto_next_pow2(n);
    if (np == 0) {
        set_empty(&nodes[0]);
        return RTO_OK;
    }
    rto__tlas_sweep_leaves(sorted_keys, n, np, boxes, nodes, 0, np);
    rto__tlas_sweep_nodes(nodes, 0, np - 1);
    return RTO_OK;
}

void rto__tlas_sweep_leaves(const uint32_t *sorted_keys, size_t n, size_t np, const rto_aabb *boxes,
                            rto_tlas_node *nodes, size_t begin, size_t end)
{
    for (size_t j = begin; j < end; j++) {
        rto_tlas_node *t = &nodes[np - 1 + j];
        if (j >= n) {
            set_empty(t);
            continue;
        }
        uint32_t inst = rto_key_prim(RTO_KEY_U32, sorted_keys[j]);
        memset(t, 0, sizeof *t);
        t->min[0] = boxes[inst].min.x;
        t->min[1] = boxes[inst].min.y;
        t->min[2] = boxes[inst].min.z;
        t->max[0] = boxes[inst].max.x;
        t->max[1] = boxes[inst].max.y;
        t->max[2] = boxes[inst].max.z;
        t->item = inst;
    }
}

/* Internal nodes from the last down: every child (2i + 1, 2i + 2) is done before its parent. */
void rto__tlas_sweep_nodes(rto_tlas_node *nodes, size_t begin, size_t end)
{
    for (size_t i = end; i-- > begin;) {
        const rto_tlas_node *l = &nodes[2 * i + 1], *r = &nodes[2 * i + 2];
        rto_tlas_node *t = &nodes[i];
        memset(t, 0, sizeof *t);
        for (int a = 0; a < 3; a++) {
            t->min[a] = rto__minf(l->min[a], r->min[a]);
            t->max[a] = rto__maxf(l->max[a], r->max[a]);
        }
        t->item = (l->item == RTO_TLAS_EMPTY && r->item == RTO_TLAS_EMPTY) ? RTO_TLAS_EMPTY : RTO_TLAS_INTERNAL;
    }
}

rto_bvh_stats rto_tlas_stats(const rto_tlas_node *nodes, size_t n)
{
    rto_bvh_stats st = {0, 0, 0};
    size_t np = rto_next_pow2(n);
    if (np == 0)
        return st;
    double root = rto__box_area(nodes[0].min, nodes[0].max), sum = 0;
    for (size_t i = 0; i < 2 * np - 1; i++) {
        if (nodes[i].item == RTO_TLAS_EMPTY)
            continue;
        sum += rto__box_area(nodes[i].min, nodes[i].max);
        if (i >= np - 1)
            st.leaves++;
    }
    /* Every leaf of the heap lies log2(n_padded) levels below the root. */
    if (st.leaves)
        st.depth = (uint32_t)__builtin_ctzll((unsigned long long)np);
    st.sah = root > 0 ? sum / root : 0;
    return st;
}
