/* What the two files of unit.bvh share: test_bvh.c (trees against references, mutations, the tolerance model, main())
 * and test_bvh_accel.c (the acceleration-structure object), whose tests test_bvh.c's main() runs. */
#ifndef RTO_TEST_BVH_H
#define RTO_TEST_BVH_H

#include "testutil.h"

/* The sizes swept for every distribution: sweep trees of n boxes (test_bvh.c), instances:DIST:N scenes
 * (test_bvh_accel.c). */
static const size_t sizes[] = {0, 1, 2, 3, 4095, 4096, 4097, 65536};

/* Defined in test_bvh.c */
rto_aabb *make_boxes(const char *dist, size_t n, float h, uint32_t seed);
int64_t where_of(const rto_report *r, const char *name);

/* The tests of test_bvh_accel.c */
void test_procedural_scene_trees(void **state);
void test_fixture_trees(void **state);
void test_accel_bytes_do_not_depend_on_threads(void **state);
void test_karras_team_matches_scalar(void **state);
void test_empty_mesh_builds_an_empty_blas(void **state);
void test_tlas_keys_skip_empty_boxes(void **state);
void test_accel_contract(void **state);
void test_accel_tlas_key_refusals(void **state);
void test_accel_index_refusals(void **state);
void test_accel_instance_refusals(void **state);
void test_accel_null_mesh_precedence(void **state);
void test_accel_check_names_the_tree(void **state);

#endif /* RTO_TEST_BVH_H */
