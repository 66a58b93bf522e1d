/* What the two files of unit.rays share: test_rays.c (cameras, procedural scenes, main()) and test_rays_sets.c (the
 * generated ray sets), whose tests test_rays.c's main() runs. */
#ifndef RTO_TEST_RAYS_H
#define RTO_TEST_RAYS_H

#include "testutil.h"

/* Defined in test_rays.c */
rto_camera gltf_like_camera(void);

/* The tests of test_rays_sets.c */
void test_random_rays(void **state);
void test_grazing_rays(void **state);
void test_axis_rays(void **state);
void test_primary_rays(void **state);
void test_empty_scenes(void **state);
void test_shadow_rays(void **state);
void test_shadow_offset(void **state);
void test_generate_refusals(void **state);

#endif /* RTO_TEST_RAYS_H */
