/* Private pieces of the sorting stage (src/sort/): the checks every sort entry point makes, the radix sort for a
 * team (which the accelerator build uses too), check-sort's fast verdict and its qsort reference (which the tests
 * and benchmarks hold rto_sort_check to). Not installed; not exported. */
#ifndef RTO_SORT_INTERNAL_H
#define RTO_SORT_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** The checks every sort entry point makes of its common arguments: a known format, n within RTO_MAX_KEYS, and
 * non-NULL arrays when n > 0. */
static inline rto_status rto__sort_args_check(rto_key_format f, const void *keys, size_t n, const void *sorted,
                                             rto_msg *msg)
{
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    if ((uint64_t)n > RTO_MAX_KEYS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu keys", n,
                        (unsigned long long)RTO_MAX_KEYS);
    if (n && (!keys || !sorted))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL keys or output");
    return RTO_OK;
}

/** Bits needed to write v: 0 for 0, else 1 + the index of its highest set bit. */
static inline uint32_t rto__bitlen64(uint64_t v) { return v ? 64u - (uint32_t)__builtin_clzll(v) : 0u; }

/** rto_fast_radix_sort for a team (sort/fast_radix.c): the same bytes. Scratch the caller provides for up to W workers:
 * hist rto__radix_team_hist_words(W) u32, first W * 2048 u32, diff W u64, ordered W bytes; tmp n keys. in and out must
 * not overlap. Every worker calls it; it returns after a sync, with out sorted. */
typedef struct rto__radix_team {
    rto_key_format f;
    const void *in;
    size_t n;
    void *out, *tmp;
    uint32_t *hist, *first;
    uint64_t *diff;
    uint8_t *ordered;
} rto__radix_team;
size_t rto__radix_team_hist_words(uint32_t workers);
void rto__radix_team_sort(rto__radix_team *r, rto__team *team, uint32_t worker, uint32_t workers);

/** check-sort's fast verdict (sort/sort_match.c): 1 when keys[0..n) in ascending order equal want[0..n) bit for bit,
 * 0 when they differ, -1 when out of memory. With want NULL it sorts keys into out instead (n keys, apart from keys)
 * and returns 1 or -1: the same partition, which the tests hold to qsort. threads: 0 = one per online CPU, used from
 * RTO__SORT_MATCH_TEAM_FROM keys on; the answer does not depend on it. */
#define RTO__SORT_MATCH_TEAM_FROM ((size_t)1 << 17)
int rto__sort_match(rto_key_format f, const void *keys, size_t n, const void *want, void *out, uint32_t threads);

/** rto_sort_check without its fast path: the dump and the input both sorted by the C library's qsort and analysed in
 * full, expected_keys ignored. The reference the tests hold rto_sort_check to, report for report. */
rto_status rto__sort_check_reference(const rto_sort_check_desc *desc, rto_report *report, rto_msg *msg);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
