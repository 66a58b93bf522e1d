/* Shared helpers for the cmocka tests: independent references (qsort, literal schedules) and seeds. */
#ifndef RTO_TESTUTIL_H
#define RTO_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rtoracle.h"

static inline int tu_cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static inline uint64_t tu_get(rto_key_format f, const void *k, size_t i)
{
    return f == RTO_KEY_U32 ? ((const uint32_t *)k)[i] : ((const uint64_t *)k)[i];
}

static inline void tu_put(rto_key_format f, void *k, size_t i, uint64_t v)
{
    if (f == RTO_KEY_U32)
        ((uint32_t *)k)[i] = (uint32_t)v;
    else
        ((uint64_t *)k)[i] = v;
}

/* The keys widened to u64 and sorted by the C library's qsort: the independent reference order. */
static inline uint64_t *tu_qsorted(rto_key_format f, const void *keys, size_t n)
{
    uint64_t *e = malloc((n ? n : 1) * sizeof *e);
    assert_non_null(e);
    for (size_t i = 0; i < n; i++)
        e[i] = tu_get(f, keys, i);
    qsort(e, n, sizeof *e, tu_cmp_u64);
    return e;
}

/* Generates keys or fails the test with the library's message. */
static inline void *tu_keys(const char *dist, rto_key_format f, uint32_t seed, size_t n)
{
    void *k = malloc(n ? n * (f == RTO_KEY_U32 ? 4 : 8) : 1);
    assert_non_null(k);
    rto_msg msg = {{0}};
    rto_status s = rto_keys_generate(dist, f, seed, n, k, &msg);
    if (s)
        fail_msg("rto_keys_generate(%s, n=%zu): %s", dist, n, msg.text);
    return k;
}

/* Whether a distribution exists for (format, n): the same rule the suite applies. */
static inline int tu_dist_applies(const rto_dist_info *d, rto_key_format f, size_t n)
{
    if (d->u64_only && f == RTO_KEY_U32)
        return 0;
    if (d->kind == RTO_DIST_CENTROID && f == RTO_KEY_U32 && n > RTO_TLAS_MAX_INSTANCES)
        return 0;
    return 1;
}

#endif
