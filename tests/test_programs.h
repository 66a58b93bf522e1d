/* What the two files of unit.programs share: test_programs.c (the built-in programs against expectations derived
 * there, main()) and test_programs_capacity.c (capacity rules, thread counts), whose tests test_programs.c's main()
 * runs. */
#ifndef RTO_TEST_PROGRAMS_H
#define RTO_TEST_PROGRAMS_H

#include "testutil.h"

/* Defined in test_programs.c */
rto_accel *build(const rto_scene *s);
rto_frame *render(const rto_frame_desc *d);
const rto_program *builtin(const char *name);
void frame_basics(const rto_frame *f, uint32_t w, uint32_t h);

/* The tests of test_programs_capacity.c */
void test_capacity_drops(void **state);
void test_conflicts(void **state);
void test_invalid_calls(void **state);
void test_threads_identical(void **state);
void test_chunks_identical(void **state);

#endif /* RTO_TEST_PROGRAMS_H */
