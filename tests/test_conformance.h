/* What the two files of unit.conformance share: test_conformance.c (the simulated GPUs, the rays made there, the
 * family of accepted cases, main()) and test_conformance_faults.c (the bound, §6 without freedoms, the fault corpus,
 * ties), whose tests test_conformance.c's main() runs. */
#ifndef RTO_TEST_CONFORMANCE_H
#define RTO_TEST_CONFORMANCE_H

#include "testutil.h"

/* A simulated GPU (test_conformance.c) */
typedef enum fuse { FUSE_NONE = 0, FUSE_FIRST = 1, FUSE_SECOND = 2, FUSE_RANDOM = 3 } fuse;

typedef struct sim {
    fuse fuse;
    int div_ulps; /* the reciprocal moved by this many ulps (each within WGSL's 2.5) */
    uint64_t rng; /* FUSE_RANDOM's choices */
    int tree;     /* 0: brute force; 1: §6's traversal of the sweep TLAS and the BLAS; 2: of the Karras TLAS */
    int fault;    /* a planted GPU fault (gpu_fault, the fault corpus); 0 for a conforming GPU */
} sim;

/* Faults a GPU's trace kernel may have: the fault corpus every verdict must catch and name. */
typedef enum gpu_fault {
    GF_NONE = 0,
    GF_TIE_LATER,        /* t <= bestT: of equal t, the later triangle (a freedom of §9, not a fault: named a tie) */
    GF_TRANSLATION_FIRST, /* the ray transform adds the translation first: ((m3 + m0 x) + m1 y) + m2 z */
    GF_SWAP_UV,          /* u and v swapped in the record */
    GF_NO_TMIN,          /* tMin dropped from the triangle test */
    GF_CULL_WRONG,       /* CULL_BACK_FACING culls front faces */
    GF_CULL_IGNORED,     /* culling flags ignored: back faces hit under CULL_BACK_FACING */
    GF_MASK_IGNORED,     /* instances entered whatever their mask */
    GF_CUSTOM_INDEX,     /* customIndex of the next instance */
    GF_HIT_GROUP,        /* hitGroup from the mask */
    GF_OBJ_TO_WORLD,     /* objToWorld's column 2, row 1 (m[1][2]) written from m[2][1]: one transposed element */
    GF_COUNT
} gpu_fault;

static const char *const tree_names[] = {"brute force", "sweep TLAS", "Karras TLAS"};

typedef struct sim_hit {
    float t, u, v, det;
} sim_hit;

/* Rays made_rays makes per triangle, at most */
#define MADE_PER 7

/* Defined in test_conformance.c */
float sum2(sim *s, float a, float b, float c, float d);
float plus(sim *s, float x, float a, float b);
int sim_triangle(sim *s, const float *v0, const float *v1, const float *v2, const float o[3], const float d[3],
                 float t_min, float best, sim_hit *h);
rto_hit_record sim_tree_trace(sim *s, const rto_scene *sc, const rto_accel *acc, const rto_wf_ray *ray,
                              rto_trace_counters *counters);
size_t made_rays(const rto_scene *sc, uint64_t seed, size_t n, rto_wf_ray *out);
rto_hits_check_desc hits_desc(const rto_scene *sc, const rto_wf_ray *rays, size_t n,
                              const rto_hit_record *expected, const rto_hit_record *gpu);
void spread_masks(rto_scene *sc);

/* The tests of test_conformance_faults.c */
void test_twice_the_bound_fails(void **state);
void test_exact_arithmetic(void **state);
void test_exact_traversal(void **state);
void test_fault_corpus(void **state);
void test_tie_freedom_named(void **state);
void test_tie_order(void **state);
void test_slab_range(void **state);

#endif /* RTO_TEST_CONFORMANCE_H */
