/* The canonical bitonic network of DESIGN.md §4: exactly the schedule the GPU kernel runs, one pass per (k, j), so
 * that the array after every pass is a checkpoint a GPU dump can be compared with. Data-oblivious: the schedule
 * depends only on n_padded, never on the keys (why it replaced the radix scatter in seeds/001). */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

size_t rto_next_pow2(size_t n)
{
    if (n <= 1)
        return n;
    size_t p = 1;
    while (p < n) {
        if (p > SIZE_MAX / 2)
            return 0;
        p <<= 1;
    }
    return p;
}

static uint32_t log2_exact(size_t p)
{
    uint32_t l = 0;
    while (((size_t)1 << l) < p)
        l++;
    return l;
}

uint32_t rto_bitonic_pass_count(size_t n_padded)
{
    if (n_padded <= 1)
        return 0;
    uint32_t l = log2_exact(n_padded);
    return l * (l + 1) / 2;
}

void rto_bitonic_pass_kj(uint32_t pass, uint32_t *k, uint32_t *j)
{
    /* Stage s (k = 2^s) holds s passes with j = 2^(s-1) ... 1. */
    uint32_t s = 1;
    while (pass >= s) {
        pass -= s;
        s++;
    }
    *k = UINT32_C(1) << s;
    *j = UINT32_C(1) << (s - 1 - pass);
}

/* One pass over u64 keys with their carried source indices. Equal keys never swap. The canonical loop visits every
 * i and acts when l = i ^ j > i, i.e. when bit j of i is clear: those i are the first halves of blocks of 2j, so
 * iterating the blocks runs the same compare-exchanges in the same order without the skipped half. */
static void run_pass(uint64_t *a, uint32_t *idx, size_t n, size_t k, size_t j)
{
    for (size_t base = 0; base < n; base += 2 * j) {
        int asc = (base & k) == 0; /* constant across the block: 2j <= k */
        for (size_t i = base; i < base + j; i++) {
            size_t l = i + j;
            if (asc ? a[i] > a[l] : a[i] < a[l]) {
                uint64_t t = a[i];
                a[i] = a[l];
                a[l] = t;
                uint32_t u = idx[i];
                idx[i] = idx[l];
                idx[l] = u;
            }
        }
    }
}

rto_status rto_bitonic_sort(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                            void *checkpoints, rto_msg *msg)
{
    rto_status st = rto_sort_args_check(f, keys, n, sorted, msg);
    if (st)
        return st;
    size_t np = rto_next_pow2(n);
    uint64_t *a = rto_alloc(np, sizeof *a);
    uint32_t *idx = rto_alloc(np, sizeof *idx);
    if (!a || !idx) {
        free(a);
        free(idx);
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    }
    uint64_t sentinel = rto_key_sentinel(f);
    for (size_t i = 0; i < np; i++) {
        a[i] = i < n ? rto_key_get(f, keys, i) : sentinel;
        idx[i] = (uint32_t)i;
    }
    uint32_t pass = 0;
    size_t ksz = rto_key_size(f);
    for (size_t k = 2; k <= np; k <<= 1) {
        for (size_t j = k >> 1; j > 0; j >>= 1, pass++) {
            run_pass(a, idx, np, k, j);
            if (checkpoints) {
                unsigned char *dst = (unsigned char *)checkpoints + (size_t)pass * np * ksz;
                for (size_t i = 0; i < np; i++)
                    rto_key_put(f, dst, i, a[i]);
            }
        }
    }
    for (size_t i = 0; i < np; i++)
        rto_key_put(f, sorted, i, a[i]);
    if (perm)
        memcpy(perm, idx, np * sizeof *idx);
    free(a);
    free(idx);
    return RTO_OK;
}
