/* What the two files of unit.check_hits share: test_check_hits.c (the fixture and its helpers, correct dumps,
 * mutations, tolerances, main()) and test_check_hits_ties.c (ties, grazing, first-hit rays, generated sets, input
 * errors, records-only, tolerance rules), whose tests test_check_hits.c's main() runs. */
#ifndef RTO_TEST_CHECK_HITS_H
#define RTO_TEST_CHECK_HITS_H

#include "testutil.h"

/* A scene, rays aimed by the test, the oracle's records (rto_trace) and a correct GPU dump written by the test. */
typedef struct fixture {
    rto_scene *scene;
    rto_accel *accel;
    size_t n;
    rto_wf_ray *rays;
    rto_hit_record *expected;
    rto_hit_record *gpu;
} fixture;

/* Defined in test_check_hits.c */
void normalize(double v[3]);
rto_hit_record record_of(const rto_scene *s, uint32_t k, uint32_t p, double t, double u, double v);
rto_hit_record miss_of(float t_max);
rto_wf_ray ray_of(const double o[3], const double d[3], uint32_t flags, uint32_t index);
void fixture_trace(fixture *f);
void fixture_alloc(fixture *f, const char *spec, size_t n);
void fixture_make(fixture *f, const char *spec, size_t n, uint64_t seed);
void fixture_free(fixture *f);
rto_hits_check_desc desc_of(const fixture *f, const rto_hit_record *gpu, size_t gn);
int64_t fact(const rto_report *r, const char *name);
const rto_report_row *row_at(const rto_report *r, size_t i, const char *field);
void expect_pass(const fixture *f, const rto_hit_record *gpu, int64_t ties, rto_report *r);
void expect_fault(const fixture *f, const rto_hit_record *gpu, size_t gn, rto_hit_fault want, size_t ray,
                  rto_report *r);
size_t hit_ray(const fixture *f, size_t from);
size_t miss_ray(const fixture *f, size_t from);

/* The tests of test_check_hits_ties.c */
void test_tie_on_shared_edge(void **state);
void test_grazing(void **state);
void test_near_tie(void **state);
void test_first_hit_rays(void **state);
void test_generated_rays(void **state);
void test_input_errors(void **state);
void test_records_only(void **state);
void test_tolerance_rules(void **state);

#endif /* RTO_TEST_CHECK_HITS_H */
