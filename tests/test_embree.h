/* What the two files of unit.embree share: test_embree.c (hand-made scenes, the Embree mirror, fixtures against a
 * binary64 tracer, main()) and test_embree_classes.c (the disagreement classes, mutations of the oracle's records),
 * whose tests test_embree.c's main() runs. */
#ifndef RTO_TEST_EMBREE_H
#define RTO_TEST_EMBREE_H

#include "testutil.h"

/* Defined in test_embree.c */
rto_scene *scene_new(uint32_t meshes, uint32_t instances);
void mesh_set(rto_scene *s, uint32_t m, const float *pos, uint32_t nv, const uint32_t *idx, uint32_t nt);
void inst_set(rto_scene *s, uint32_t i, uint32_t blas, double sx, double sy, double sz, double tx, double ty,
              double tz, uint32_t mask, uint32_t sbt, uint32_t custom);
void scene_free(rto_scene *s);
rto_scene *hand_scene(void);
rto_wf_ray ray_make(float ox, float oy, float oz, float dx, float dy, float dz);
/** n rays of a scene with origins in its bounds grown by half their size and directions uniform on the sphere
 * (test_embree_classes.c). */
rto_wf_ray *random_rays(const rto_scene *s, uint32_t n, uint32_t seed);

/* Defined in test_embree_classes.c */
rto_hit_record hit_rec(uint32_t inst, uint32_t prim, float t);
rto_hit_record miss_rec(void);

/* The tests of test_embree_classes.c */
void test_class_agree(void **state);
void test_class_tie(void **state);
void test_class_coplanar(void **state);
void test_class_crossing(void **state);
void test_class_t_rounding(void **state);
void test_class_grazing(void **state);
void test_class_robust_only(void **state);
void test_class_surface_start(void **state);
void test_class_sliver(void **state);
void test_oracle_mutations(void **state);

#endif /* RTO_TEST_EMBREE_H */
