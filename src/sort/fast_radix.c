/* The sort the builds use (DESIGN.md §4): TLAS and BLAS keys are unique, so every correct sort gives the same array
 * and the builds need not run the canonical network, whose O(n log² n) compare-exchanges dominated a BLAS build.
 * This is a plain LSD radix sort tuned for those keys:
 *   - only the bits where the keys differ are sorted: [lowest differing bit, highest differing bit];
 *   - keys made by rto_tlas_keys / rto_blas_keys carry an index in their low 16 / 32 bits that grows with the input
 *     position. When that field never decreases along the input, the input is already sorted by it, and a stable
 *     sort by the bits above it alone gives the fully sorted array (ties keep input order, which is index order);
 *   - the remaining bits are split into the fewest passes of at most 11 bits (2048 counters, within L1), all
 *     histograms are counted in one read of the input, and a pass whose digit is the same in every key is skipped.
 * A sorted array is unique whatever the algorithm, so the output bytes equal the bitonic network's. */
#include "sort_internal.h"

#include <stdlib.h>
#include <string.h>

#define MAX_DIGIT_BITS 11u
#define MAX_PASSES 6u /* ceil(64 / 11) */

typedef struct plan {
    uint32_t lo;                   /* first bit sorted */
    uint32_t width;                /* bits per digit */
    uint32_t passes;               /* digits counted */
    uint32_t (*hist)[1u << MAX_DIGIT_BITS];
} plan;

static uint32_t ctz64(uint64_t v) { return v ? (uint32_t)__builtin_ctzll(v) : 64u; }

/* Generates the sort for one key type: KEY the C type, NAME the suffix, IDX_BITS the width of the index field. */
#define DEFINE_SORT(KEY, NAME, IDX_BITS)                                                                               \
    static void make_plan_##NAME(const KEY *k, size_t n, plan *p)                                                      \
    {                                                                                                                  \
        KEY diff = 0;                                                                                                  \
        int ordered_index = 1;                                                                                         \
        const KEY idx_mask = (KEY)((((KEY)1) << (IDX_BITS)) - 1);                                                      \
        for (size_t i = 1; i < n; i++) {                                                                               \
            diff |= k[i] ^ k[0];                                                                                       \
            ordered_index &= (k[i] & idx_mask) >= (k[i - 1] & idx_mask);                                               \
        }                                                                                                              \
        uint32_t lo = ctz64(diff), hi = rto__bitlen64(diff);                                                           \
        if (ordered_index && lo < (IDX_BITS))                                                                          \
            lo = (IDX_BITS);                                                                                           \
        p->lo = lo;                                                                                                    \
        p->passes = lo < hi ? (hi - lo + MAX_DIGIT_BITS - 1) / MAX_DIGIT_BITS : 0;                                     \
        p->width = p->passes ? (hi - lo + p->passes - 1) / p->passes : 0;                                              \
    }                                                                                                                  \
                                                                                                                       \
    /* Stable counting pass of src[0, n) by the digit at shift into dst, with counters h (radix words). */             \
    static void pass_##NAME(const KEY *src, size_t n, KEY *dst, uint32_t *h, uint32_t radix, uint32_t shift, KEY mask) \
    {                                                                                                                  \
        uint32_t run = 0;                                                                                              \
        for (uint32_t d = 0; d < radix; d++) {                                                                         \
            uint32_t c = h[d];                                                                                         \
            h[d] = run;                                                                                                \
            run += c;                                                                                                  \
        }                                                                                                              \
        for (size_t i = 0; i < n; i++)                                                                                 \
            dst[h[(src[i] >> shift) & mask]++] = src[i];                                                               \
    }                                                                                                                  \
                                                                                                                       \
    static void sort_##NAME(const KEY *in, size_t n, KEY *out, KEY *tmp, const plan *p)                                \
    {                                                                                                                  \
        const uint32_t radix = 1u << p->width;                                                                         \
        const KEY mask = (KEY)(radix - 1);                                                                             \
        for (size_t i = 0; i < n; i++)                                                                                 \
            for (uint32_t q = 0; q < p->passes; q++)                                                                   \
                p->hist[q][(in[i] >> (p->lo + q * p->width)) & mask]++;                                                \
        uint32_t active[MAX_PASSES], m = 0;                                                                            \
        for (uint32_t q = 0; q < p->passes; q++) {                                                                     \
            int constant = 0;                                                                                          \
            for (uint32_t d = 0; d < radix && !constant; d++)                                                          \
                constant = p->hist[q][d] == n;                                                                         \
            if (!constant)                                                                                             \
                active[m++] = q;                                                                                       \
        }                                                                                                              \
        if (m == 0) {                                                                                                  \
            memcpy(out, in, n * sizeof *in);                                                                           \
            return;                                                                                                    \
        }                                                                                                              \
        /* Ping-pong so that the last pass writes into out. */                                                         \
        const KEY *src = in;                                                                                           \
        for (uint32_t a = 0; a < m; a++) {                                                                             \
            KEY *dst = ((m - 1 - a) % 2 == 0) ? out : tmp;                                                             \
            pass_##NAME(src, n, dst, p->hist[active[a]], radix, p->lo + active[a] * p->width, mask);                   \
            src = dst;                                                                                                 \
        }                                                                                                              \
    }

DEFINE_SORT(uint32_t, u32, 16u)
DEFINE_SORT(uint64_t, u64, 32u)

rto_status rto_fast_radix_sort(rto_key_format f, const void *keys, size_t n, void *sorted, rto_msg *msg)
{
    rto_status st = rto__sort_args_check(f, keys, n, sorted, msg);
    if (st)
        return st;
    const size_t ksz = rto_key_size(f);
    const uintptr_t a = (uintptr_t)keys, b = (uintptr_t)sorted;
    if (n && a < b + n * ksz && b < a + n * ksz)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "keys and output overlap");
    plan p;
    memset(&p, 0, sizeof p);
    if (f == RTO_KEY_U32)
        make_plan_u32(keys, n, &p);
    else
        make_plan_u64(keys, n, &p);
    if (p.passes == 0) { /* already sorted: no bit above the ordered index field differs */
        if (n)
            memcpy(sorted, keys, n * ksz);
        return RTO_OK;
    }
    p.hist = calloc(p.passes, sizeof *p.hist);
    void *tmp = p.passes > 1 ? rto__alloc_large(n, ksz) : NULL;
    if (!p.hist || (p.passes > 1 && !tmp)) {
        free(p.hist);
        free(tmp);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    }
    if (f == RTO_KEY_U32)
        sort_u32(keys, n, sorted, tmp, &p);
    else
        sort_u64(keys, n, sorted, tmp, &p);
    free(p.hist);
    free(tmp);
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The same sort for a team (the accel's builds). Each worker takes a static range of the input, and the plan       */
/* (differing bits, index order) is merged from the ranges'. Then, most significant digit first:                    */
/*   1. each worker sorts its own range by the top digit alone, into the same range of tmp (a stable counting pass); */
/*   2. the digits are dealt out as contiguous runs, a worker's run starting with the digit whose first slot falls in */
/*      its share of the output (rto__part), so a run holds n / workers keys plus at most one digit's worth;         */
/*   3. each worker gathers its run's keys from every range (lower workers' first, so each digit's keys stay in input */
/*      order) into its own slice of out, and sorts that slice by the lower digits and then the top one, alone.      */
/* Every worker writes only its own slices, so no two workers share the cache lines they scatter into (the LSD team */
/* sort below had 16 workers scatter 69k keys into 16 x 1024 interleaved runs of 4 keys each, and spent 0.1 ms a    */
/* pass on it). When the top digit is too skewed for that (a run would exceed FAIR_RUNS shares), the LSD team sort    */
/* runs instead. A stable sort's output is unique, so both give the sequential sort's bytes.                          */

size_t rto__radix_team_hist_words(uint32_t workers) { return (size_t)workers * MAX_PASSES * (1u << MAX_DIGIT_BITS); }

#define FAIR_RUNS 4u

#define DEFINE_TEAM_SORT(KEY, NAME, IDX_BITS)                                                                          \
    /* The LSD team sort: every pass scatters every range into the whole array. */                                     \
    static void lsd_##NAME(rto__radix_team *r, rto__team *team, uint32_t w, uint32_t t, uint32_t lo, uint32_t passes,  \
                           uint32_t width)                                                                             \
    {                                                                                                                  \
        const KEY *in = r->in;                                                                                         \
        KEY *out = r->out, *tmp = r->tmp;                                                                              \
        const size_t n = r->n;                                                                                         \
        size_t b, e;                                                                                                   \
        rto__part(n, w, t, &b, &e);                                                                                    \
        const uint32_t radix = 1u << width;                                                                            \
        const KEY mask = (KEY)(radix - 1);                                                                             \
        uint32_t(*hist)[MAX_PASSES][1u << MAX_DIGIT_BITS] = (void *)r->hist; /* [worker][pass][digit] */              \
        uint32_t active[MAX_PASSES], m = 0;                                                                            \
        for (uint32_t q = 0; q < passes; q++)                                                                          \
            memset(hist[w][q], 0, radix * sizeof hist[w][q][0]);                                                       \
        for (size_t i = b; i < e; i++)                                                                                 \
            for (uint32_t q = 0; q < passes; q++)                                                                      \
                hist[w][q][(in[i] >> (lo + q * width)) & mask]++;                                                      \
        rto__team_sync(team);                                                                                          \
        for (uint32_t q = 0; q < passes; q++) {                                                                        \
            int constant = 0;                                                                                          \
            for (uint32_t d = 0; d < radix && !constant; d++) {                                                        \
                size_t total = 0;                                                                                      \
                for (uint32_t v = 0; v < t; v++)                                                                       \
                    total += hist[v][q][d];                                                                            \
                constant = total == n;                                                                                 \
            }                                                                                                          \
            if (!constant)                                                                                             \
                active[m++] = q;                                                                                       \
        }                                                                                                              \
        if (m == 0) {                                                                                                  \
            memcpy(out + b, in + b, (e - b) * sizeof *in);                                                             \
            rto__team_sync(team);                                                                                      \
            return;                                                                                                    \
        }                                                                                                              \
        const KEY *src = in;                                                                                           \
        uint32_t *first = r->first + (size_t)w * (1u << MAX_DIGIT_BITS);                                               \
        for (uint32_t a = 0; a < m; a++) {                                                                             \
            KEY *dst = ((m - 1 - a) % 2 == 0) ? out : tmp;                                                             \
            const uint32_t q = active[a], shift = lo + q * width;                                                      \
            if (a > 0 && t > 1) { /* this pass's counts over this worker's range of the array as it is now */         \
                memset(hist[w][q], 0, radix * sizeof hist[w][q][0]);                                                   \
                for (size_t i = b; i < e; i++)                                                                         \
                    hist[w][q][(src[i] >> shift) & mask]++;                                                            \
                rto__team_sync(team);                                                                                  \
            }                                                                                                          \
            uint32_t run = 0;                                                                                          \
            for (uint32_t d = 0; d < radix; d++) {                                                                     \
                uint32_t before = 0, all = 0;                                                                          \
                for (uint32_t v = 0; v < t; v++) {                                                                     \
                    before += v < w ? hist[v][q][d] : 0;                                                               \
                    all += hist[v][q][d];                                                                              \
                }                                                                                                      \
                first[d] = run + before;                                                                               \
                run += all;                                                                                            \
            }                                                                                                          \
            for (size_t i = b; i < e; i++)                                                                             \
                dst[first[(src[i] >> shift) & mask]++] = src[i];                                                       \
            rto__team_sync(team);                                                                                      \
            src = dst;                                                                                                 \
        }                                                                                                              \
    }                                                                                                                  \
                                                                                                                       \
    static void team_##NAME(rto__radix_team *r, rto__team *team, uint32_t w, uint32_t t)                               \
    {                                                                                                                  \
        const KEY *in = r->in;                                                                                         \
        KEY *out = r->out, *tmp = r->tmp;                                                                              \
        const size_t n = r->n;                                                                                         \
        size_t b, e;                                                                                                   \
        rto__part(n, w, t, &b, &e);                                                                                    \
        /* The plan: differing bits and whether the index field grows along the input. */                             \
        {                                                                                                              \
            KEY diff = 0;                                                                                              \
            int ordered = 1;                                                                                           \
            const KEY idx_mask = (KEY)((((KEY)1) << (IDX_BITS)) - 1);                                                  \
            for (size_t i = b > 0 ? b : 1; i < e; i++) {                                                               \
                diff |= in[i] ^ in[0];                                                                                 \
                ordered &= (in[i] & idx_mask) >= (in[i - 1] & idx_mask);                                               \
            }                                                                                                          \
            r->diff[w] = diff;                                                                                         \
            r->ordered[w] = (uint8_t)ordered;                                                                          \
        }                                                                                                              \
        rto__team_sync(team);                                                                                          \
        uint64_t diff = 0;                                                                                             \
        int ordered = 1;                                                                                               \
        for (uint32_t v = 0; v < t; v++) {                                                                             \
            diff |= r->diff[v];                                                                                        \
            ordered &= r->ordered[v];                                                                                  \
        }                                                                                                              \
        uint32_t lo = ctz64(diff), hi = rto__bitlen64(diff);                                                           \
        if (ordered && lo < (IDX_BITS))                                                                                \
            lo = (IDX_BITS);                                                                                           \
        const uint32_t passes = lo < hi ? (hi - lo + MAX_DIGIT_BITS - 1) / MAX_DIGIT_BITS : 0;                         \
        const uint32_t width = passes ? (hi - lo + passes - 1) / passes : 0;                                           \
        if (passes == 0) {                                                                                             \
            memcpy(out + b, in + b, (e - b) * sizeof *in);                                                             \
            rto__team_sync(team);                                                                                      \
            return;                                                                                                    \
        }                                                                                                              \
        if (t < 2) {                                                                                                   \
            lsd_##NAME(r, team, w, t, lo, passes, width);                                                              \
            return;                                                                                                    \
        }                                                                                                              \
        const uint32_t radix = 1u << width, top = passes - 1, tshift = lo + top * width;                               \
        const KEY mask = (KEY)(radix - 1);                                                                             \
        uint32_t(*hist)[MAX_PASSES][1u << MAX_DIGIT_BITS] = (void *)r->hist; /* [worker][pass][digit] */              \
        uint32_t *const mine = r->first + (size_t)w * (1u << MAX_DIGIT_BITS);                                          \
        /* 1. This range by the top digit, into the same range of tmp; its counts stay in hist[w][top]. */            \
        memset(hist[w][top], 0, radix * sizeof hist[w][top][0]);                                                       \
        for (size_t i = b; i < e; i++)                                                                                 \
            hist[w][top][(in[i] >> tshift) & mask]++;                                                                  \
        memcpy(mine, hist[w][top], radix * sizeof *mine);                                                              \
        pass_##NAME(in + b, e - b, tmp + b, mine, radix, tshift, mask);                                                \
        rto__team_sync(team);                                                                                          \
        /* 2. The runs of digits: run v is digits [g[v], g[v + 1]), output slots [at[v], at[v + 1]). */                \
        uint32_t g[RTO_THREADS_MAX + 1];                                                                               \
        size_t at[RTO_THREADS_MAX + 1];                                                                                \
        {                                                                                                              \
            uint32_t v = 1;                                                                                            \
            size_t slot = 0, share_b, share_e;                                                                         \
            g[0] = 0;                                                                                                  \
            at[0] = 0;                                                                                                 \
            for (uint32_t d = 0; d < radix; d++) {                                                                     \
                for (; v < t; v++) { /* digit d starts run v when its first slot is in v's share */                   \
                    rto__part(n, v, t, &share_b, &share_e);                                                            \
                    if (slot < share_b)                                                                                \
                        break;                                                                                         \
                    g[v] = d;                                                                                          \
                    at[v] = slot;                                                                                      \
                }                                                                                                      \
                for (uint32_t u = 0; u < t; u++)                                                                       \
                    slot += hist[u][top][d];                                                                           \
            }                                                                                                          \
            for (; v < t; v++) {                                                                                       \
                g[v] = radix;                                                                                          \
                at[v] = n;                                                                                             \
            }                                                                                                          \
            g[t] = radix;                                                                                              \
            at[t] = n;                                                                                                 \
        }                                                                                                              \
        size_t longest = 0;                                                                                            \
        for (uint32_t v = 0; v < t; v++)                                                                               \
            if (at[v + 1] - at[v] > longest)                                                                           \
                longest = at[v + 1] - at[v];                                                                           \
        if (longest > FAIR_RUNS * ((n + t - 1) / t)) {                                                                 \
            rto__team_sync(team); /* no worker still reads the top digit's counts, which the LSD sort recounts */      \
            lsd_##NAME(r, team, w, t, lo, passes, width);                                                              \
            return;                                                                                                    \
        }                                                                                                              \
        /* 3. Gather run w from every range's tmp, lower ranges first. */                                             \
        KEY *const slice = out + at[w];                                                                                \
        const size_t len = at[w + 1] - at[w];                                                                          \
        {                                                                                                              \
            size_t put = 0;                                                                                            \
            for (uint32_t v = 0; v < t; v++) {                                                                         \
                size_t vb, ve, from = 0, to = 0;                                                                       \
                rto__part(n, v, t, &vb, &ve);                                                                          \
                for (uint32_t d = 0; d < g[w + 1]; d++) {                                                              \
                    if (d == g[w])                                                                                     \
                        from = to;                                                                                     \
                    to += hist[v][top][d];                                                                             \
                }                                                                                                      \
                if (g[w] == g[w + 1])                                                                                  \
                    from = to;                                                                                         \
                memcpy(slice + put, tmp + vb + from, (to - from) * sizeof *tmp);                                       \
                put += to - from;                                                                                      \
            }                                                                                                          \
        }                                                                                                              \
        rto__team_sync(team); /* tmp is free again: every worker has gathered */                                       \
        /* The slice by the lower digits, then the top one, with tmp's same slots as scratch. */                       \
        uint32_t active[MAX_PASSES], m = 0;                                                                            \
        for (uint32_t q = 0; q < passes; q++)                                                                          \
            memset(hist[w][q], 0, radix * sizeof hist[w][q][0]);                                                       \
        for (size_t i = 0; i < len; i++)                                                                               \
            for (uint32_t q = 0; q < passes; q++)                                                                      \
                hist[w][q][(slice[i] >> (lo + q * width)) & mask]++;                                                   \
        for (uint32_t q = 0; q < passes; q++) {                                                                        \
            int constant = len == 0;                                                                                   \
            for (uint32_t d = 0; d < radix && !constant; d++)                                                          \
                constant = hist[w][q][d] == len;                                                                       \
            if (!constant)                                                                                             \
                active[m++] = q;                                                                                       \
        }                                                                                                              \
        KEY *src = slice, *dst = tmp + at[w];                                                                          \
        for (uint32_t a = 0; a < m; a++) {                                                                             \
            const uint32_t q = active[a];                                                                              \
            pass_##NAME(src, len, dst, hist[w][q], radix, lo + q * width, mask);                                       \
            KEY *x = src;                                                                                              \
            src = dst;                                                                                                 \
            dst = x;                                                                                                   \
        }                                                                                                              \
        if (src != slice)                                                                                              \
            memcpy(slice, src, len * sizeof *slice);                                                                   \
        rto__team_sync(team);                                                                                          \
    }

DEFINE_TEAM_SORT(uint32_t, u32, 16u)
DEFINE_TEAM_SORT(uint64_t, u64, 32u)

void rto__radix_team_sort(rto__radix_team *r, rto__team *team, uint32_t worker, uint32_t workers)
{
    if (r->f == RTO_KEY_U32)
        team_u32(r, team, worker, workers);
    else
        team_u64(r, team, worker, workers);
}
