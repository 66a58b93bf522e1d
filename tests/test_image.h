/* What the two files of unit.image share: test_image.c (hand-made files read back, writes, refusals, main()) and
 * test_image_compare.c (metrics, verdicts, diff images, bundle images), whose tests test_image.c's main() runs. */
#ifndef RTO_TEST_IMAGE_H
#define RTO_TEST_IMAGE_H

#include "testutil.h"

/* A byte buffer that grows as it is written (put and its kin in test_image.c). */
typedef struct bytes {
    unsigned char *p;
    size_t n, cap;
} bytes;

/* Defined in test_image.c */
void path_in(char *out, size_t cap, const char *name);
void save(const char *path, const void *p, size_t n);
bytes load(const char *path);
rto_image make_u8(uint32_t w, uint32_t h, uint32_t c);
rto_image make_f32(uint32_t w, uint32_t h, uint32_t c);

/* The tests of test_image_compare.c */
void test_one_pixel_off(void **state);
void test_metrics_against_reference(void **state);
void test_verdicts(void **state);
void test_non_finite(void **state);
void test_size_mismatch(void **state);
void test_diff_image(void **state);
void test_bundle_images(void **state);

#endif /* RTO_TEST_IMAGE_H */
