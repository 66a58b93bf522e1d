/* Private pieces of the tree builders (src/bvh/): box areas for SAH statistics, the sweep TLAS in parts (tlas.c) and
 * the Karras builder in stages (karras.c), which the accelerator build (accel.c) runs on a team and the tests hold
 * to the kept per-node builder. Not installed; not exported. */
#ifndef RTO_BVH_INTERNAL_H
#define RTO_BVH_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** Surface area of a box given as min / max triples, in binary64; 0 for an empty box (SAH statistics). */
static inline double rto__box_area(const float *mn, const float *mx)
{
    double d[3];
    for (int a = 0; a < 3; a++) {
        d[a] = (double)mx[a] - (double)mn[a];
        if (!(d[a] >= 0))
            return 0;
    }
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/** The sweep TLAS (rto_tlas_build_sweep's bytes) in parts: leaves [begin, end) of n_padded over n sorted keys, then
 * each level's internal nodes [begin, end) (node indices), children's level first. */
void rto__tlas_sweep_leaves(const uint32_t *sorted_keys, size_t n, size_t np, const rto_aabb *boxes,
                            rto_tlas_node *nodes, size_t begin, size_t end);
void rto__tlas_sweep_nodes(rto_tlas_node *nodes, size_t begin, size_t end);

/* The Karras builder in stages (bvh/karras.c), for a team: plan (one worker), run (every worker, between syncs),
 * finish (one worker). rto_karras_build runs them with one worker. */
typedef struct rto__karras_job {
    uint32_t lo, hi;   /* leaves of the subtree */
    uint32_t root;     /* its root node */
    uint32_t parent;   /* the root's parent */
    uint32_t height;   /* out */
} rto__karras_job;
typedef struct rto__karras_top {
    uint32_t node;
    int64_t slot[2]; /* per child: -1 leaf, j >= 0 job j, -2 - t top node t */
    uint32_t height;
} rto__karras_top;
typedef struct rto__karras {
    rto_key_format f;
    const void *keys;        /* sorted */
    size_t n;
    const rto_aabb *boxes;   /* by primitive */
    rto_bvh_node *nodes;     /* n - 1 */
    double *areas;           /* NULL, or n - 1: each node's SAH term (rto__karras_stats_depth) */
    /* filled by plan */
    uint32_t workers;
    rto__karras_job *jobs;
    size_t job_count;
    rto__karras_top *tops;
    size_t top_count;
    uint32_t depth;          /* by finish: the deepest leaf's depth */
} rto__karras;
rto_status rto__karras_plan(rto__karras *k, uint32_t workers, rto_msg *msg);
void rto__karras_run(rto__karras *k, uint32_t worker, uint32_t workers);
void rto__karras_finish(rto__karras *k);
void rto__karras_free(rto__karras *k);
/** The per-node Karras procedure for every node, then boxes bottom-up: the reference the fast builder is tested on. */
rto_status rto__karras_build_scalar(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                                   rto_bvh_node *nodes, rto_msg *msg);
/** rto_karras_stats with the depth given (the builder's) and, unless NULL, the node terms (rto__karras.areas). */
rto_bvh_stats rto__karras_stats_depth(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box, uint32_t depth,
                                      const double *areas);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
