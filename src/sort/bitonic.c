/* The canonical bitonic network of DESIGN.md §4: exactly the schedule the GPU kernel runs, one pass per (k, j), so
 * that the array after every pass is a checkpoint a GPU dump can be compared with. Data-oblivious: the schedule
 * depends only on n_padded, never on the keys (why it replaced the radix scatter in seeds/001). */
#include "bitonic_internal.h"
#include "sort_internal.h"

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

/* ---------------------------------------------------------------------------------------------------------------- */
/* The reference: the network as first written, kept as the tests' reference for every fast path.
 * One pass over u64 keys with their carried source indices. Equal keys never swap. The canonical loop visits every
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

rto_status rto__bitonic_sort_scalar(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                                    void *checkpoints, rto_msg *msg)
{
    rto_status st = rto__sort_args_check(f, keys, n, sorted, msg);
    if (st)
        return st;
    size_t np = rto_next_pow2(n);
    uint64_t *a = rto__alloc(np, sizeof *a);
    uint32_t *idx = rto__alloc(np, sizeof *idx);
    if (!a || !idx) {
        free(a);
        free(idx);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    }
    uint64_t sentinel = rto_key_sentinel(f);
    for (size_t i = 0; i < np; i++) {
        a[i] = i < n ? rto__key_get(f, keys, i) : sentinel;
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
                    rto__key_put(f, dst, i, a[i]);
            }
        }
    }
    for (size_t i = 0; i < np; i++)
        rto__key_put(f, sorted, i, a[i]);
    if (perm)
        memcpy(perm, idx, np * sizeof *idx);
    free(a);
    free(idx);
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The fast paths. The same compare-exchanges as the reference, reordered only where that cannot change a byte: the
 * pairs of one pass are disjoint, so they may run in any order, and a slot's value after passes p..q depends only on
 * the slots it meets in them. Hence (Batcher's network, blocked as in the usual cache-aware sorting-network codes):
 *   - passes whose stride j is below a block size touch only slots inside aligned blocks of 2j, so every stage's
 *     small strides run block by block while the block sits in L1 / L2;
 *   - consecutive passes j, j/2 (, j/4) act on groups of 4 (8) slots that no other pair of those passes touches, so
 *     they are fused: each slot is loaded and stored once for two (three) passes;
 *   - the compare-exchange is branch-free (a mask from one signed compare selects keys and indices alike);
 *   - strides below the vector width run inside a register (lane permutes); wider ones pair whole vectors.
 * Without checkpoints only the final array is observable; with checkpoints every pass is materialised on its own. */

/* Branch-free baseline kernels (any CPU). T: the signed working key type. */
#define BASELINE_CE(T, a, ix, x, y, d)                                                                                 \
    do {                                                                                                               \
        T kx_ = (a)[x], ky_ = (a)[y];                                                                                  \
        uint32_t ix_ = (ix)[x], iy_ = (ix)[y];                                                                         \
        T s_ = -(T)((kx_ ^ (d)) > (ky_ ^ (d)));                                                                        \
        T tk_ = (kx_ ^ ky_) & s_;                                                                                      \
        uint32_t ti_ = (ix_ ^ iy_) & (uint32_t)s_;                                                                     \
        (a)[x] = kx_ ^ tk_;                                                                                            \
        (a)[y] = ky_ ^ tk_;                                                                                            \
        (ix)[x] = ix_ ^ ti_;                                                                                           \
        (ix)[y] = iy_ ^ ti_;                                                                                           \
    } while (0)

#define DEFINE_BASELINE(T, NAME)                                                                                       \
    static void NAME##_pass1(void *av, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1)            \
    {                                                                                                                  \
        T *a = (T *)av + base;                                                                                         \
        ix += base;                                                                                                    \
        const T d = desc ? (T)-1 : 0;                                                                                  \
        for (size_t o = o0; o < o1; o++)                                                                               \
            BASELINE_CE(T, a, ix, o, o + j, d);                                                                        \
    }                                                                                                                  \
    static void NAME##_pass2(void *av, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1)            \
    {                                                                                                                  \
        T *a = (T *)av + base;                                                                                         \
        ix += base;                                                                                                    \
        const T d = desc ? (T)-1 : 0;                                                                                  \
        const size_t h = j >> 1;                                                                                       \
        for (size_t o = o0; o < o1; o++) {                                                                             \
            BASELINE_CE(T, a, ix, o, o + j, d);                                                                        \
            BASELINE_CE(T, a, ix, o + h, o + j + h, d);                                                                \
            BASELINE_CE(T, a, ix, o, o + h, d);                                                                        \
            BASELINE_CE(T, a, ix, o + j, o + j + h, d);                                                                \
        }                                                                                                              \
    }                                                                                                                  \
    static const rto__bitonic_kernels NAME##_kernels = {1, NAME##_pass1, NAME##_pass2, NULL, NULL, NULL};

DEFINE_BASELINE(int32_t, base32)
DEFINE_BASELINE(int64_t, base64)

const char *rto__bitonic_isa_name(rto__bitonic_isa isa)
{
    static const char *const names[RTO__BITONIC_ISA_COUNT] = {"auto", "baseline", "avx2", "avx512"};
    return (unsigned)isa < RTO__BITONIC_ISA_COUNT ? names[isa] : "?";
}

int rto__bitonic_isa_supported(rto__bitonic_isa isa)
{
    if (isa == RTO__BITONIC_AUTO || isa == RTO__BITONIC_BASELINE)
        return 1;
    if ((unsigned)isa >= RTO__BITONIC_ISA_COUNT || !rto__bitonic_simd_kernels(isa, 4))
        return 0;
    return isa == RTO__BITONIC_AVX2 ? rto__cpu_avx2() : rto__cpu_avx512();
}

/* AUTO: the widest supported path, capped by RTO_BITONIC_ISA (baseline, avx2, avx512) when set, so that a user or a
 * test can force a narrower path. */
static const char *isa_name(int i) { return rto__bitonic_isa_name((rto__bitonic_isa)i); }
static int isa_supported(int i) { return rto__bitonic_isa_supported((rto__bitonic_isa)i); }

static rto__bitonic_isa resolve_isa(void)
{
    return (rto__bitonic_isa)rto__isa_resolve("RTO_BITONIC_ISA", isa_name, isa_supported, RTO__BITONIC_BASELINE,
                                              RTO__BITONIC_ISA_COUNT, RTO__BITONIC_AVX512);
}

/* Blocks, in slots: L1 (passes below it run on L1-resident blocks) and L2 (the unit of the parallel block phase),
 * rounded down to powers of two. 384 KiB gives 32768 slots to 4-byte keys with their indices (256 KiB) and to 8-byte
 * ones (384 KiB; 256 KiB gave them 16384 slots, and a whole-array pass more per later stage). */
#define L1_BYTES ((size_t)16 << 10)
#define L2_BYTES ((size_t)384 << 10)
/* From this many slots up the network uses threads: below it, starting them costs more than it saves. */
#define THREADS_FROM ((size_t)1 << 15)
/* Slots of one work unit of a parallel whole-array pass. */
#define CHUNK ((size_t)4096)

typedef struct net {
    const rto__bitonic_kernels *K;
    void *a;
    uint32_t *ix;
    size_t np, b1, b2;
    /* the phase being run in parallel */
    size_t k, j, cpb, chunk;
    uint32_t m;
} net;

/* How many passes from stride j down may be fused with the smallest fused stride still >= lowest (>= lanes). */
static uint32_t fuse_count(const rto__bitonic_kernels *K, size_t j, size_t lowest)
{
    if (K->pass3 && (j >> 2) >= lowest)
        return 3;
    return (j >> 1) >= lowest ? 2 : 1;
}

/* m fused passes from stride j over every 2j block of [lo, hi). */
static void span_passes(const net *t, size_t k, size_t j, uint32_t m, size_t lo, size_t hi)
{
    const rto__bitonic_kernels *K = t->K;
    void (*fn)(void *, uint32_t *, int, size_t, size_t, size_t, size_t) =
        m == 3 ? K->pass3 : m == 2 ? K->pass2 : K->pass1;
    const size_t w = j >> (m - 1);
    for (size_t base = lo; base < hi; base += 2 * j)
        fn(t->a, t->ix, (base & k) != 0, base, j, 0, w);
}

/* Passes j .. 1 of stage k on [lo, hi), a block of at most b1 slots (2j <= hi - lo). */
static void l1_passes(const net *t, size_t k, size_t j, size_t lo, size_t hi)
{
    const size_t lanes = t->K->lanes;
    if (t->K->tail) { /* strides of 8 vectors and up in sweeps, the rest in registers */
        while (j >= 8 * lanes) {
            uint32_t m = fuse_count(t->K, j, 8 * lanes);
            span_passes(t, k, j, m, lo, hi);
            j >>= m;
        }
        if (j)
            t->K->tail(t->a, t->ix, k, k, j, lo, hi);
        return;
    }
    while (j >= lanes) {
        uint32_t m = fuse_count(t->K, j, lanes);
        span_passes(t, k, j, m, lo, hi);
        j >>= m;
    }
    if (j)
        t->K->small(t->a, t->ix, k, j, 1, lo, hi);
}

/* Passes j .. 1 of stage k on [lo, hi) (aligned, 2j <= hi - lo): strides >= b1 over the span, the rest per L1
 * block. */
static void stage_passes(const net *t, size_t k, size_t j, size_t lo, size_t hi)
{
    const size_t lowest = t->b1 > t->K->lanes ? t->b1 : t->K->lanes;
    while (j >= lowest) {
        uint32_t m = fuse_count(t->K, j, lowest);
        span_passes(t, k, j, m, lo, hi);
        j >>= m;
    }
    if (!j)
        return;
    const size_t blk = hi - lo < t->b1 ? hi - lo : t->b1;
    for (size_t b = lo; b < hi; b += blk)
        l1_passes(t, k, j, b, b + blk);
}

/* Stages 2 .. hi - lo of the network on the block [lo, hi): first every L1 block through the stages that fit in it,
 * then the larger stages over the block. */
static void block_sort(const net *t, size_t lo, size_t hi)
{
    const size_t size = hi - lo, blk = size < t->b1 ? size : t->b1;
    const size_t first = t->K->tail ? 8 * (size_t)t->K->lanes : 1; /* stages 2 .. first: one sweep in registers */
    for (size_t b = lo; b < hi; b += blk) {
        if (t->K->tail)
            t->K->tail(t->a, t->ix, 2, first, 1, b, b + blk);
        for (size_t k = 2 * first; k <= blk; k <<= 1)
            l1_passes(t, k, k >> 1, b, b + blk);
    }
    for (size_t k = 2 * blk; k <= size; k <<= 1)
        stage_passes(t, k, k >> 1, lo, hi);
}

static void phase_sort_blocks(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    (void)worker;
    const net *t = ctx;
    for (size_t b = begin; b < end; b++)
        block_sort(t, b * t->b2, (b + 1) * t->b2);
}

static void phase_stage_blocks(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    (void)worker;
    const net *t = ctx;
    for (size_t b = begin; b < end; b++)
        stage_passes(t, t->k, t->j, b * t->b2, (b + 1) * t->b2);
}

/* Work unit u of a whole-array fused pass: chunk (u % cpb) of the offsets of 2j block (u / cpb). */
static void phase_wide_pass(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    (void)worker;
    const net *t = ctx;
    const rto__bitonic_kernels *K = t->K;
    void (*fn)(void *, uint32_t *, int, size_t, size_t, size_t, size_t) =
        t->m == 3 ? K->pass3 : t->m == 2 ? K->pass2 : K->pass1;
    for (size_t u = begin; u < end;) {
        const size_t blk = u / t->cpb, c0 = u % t->cpb;
        size_t c1 = t->cpb;
        if (c1 - c0 > end - u)
            c1 = c0 + (end - u);
        const size_t base = blk * 2 * t->j;
        fn(t->a, t->ix, (base & t->k) != 0, base, t->j, c0 * t->chunk, c1 * t->chunk);
        u += c1 - c0;
    }
}

/* The whole network without checkpoints: L2 blocks sorted in parallel, then for each larger stage its wide strides
 * over the whole array (fused, split into equal ranges of work units) and its narrow strides per L2 block. */
static void run_fused(net *t, uint32_t threads)
{
    const size_t np = t->np;
    if (t->b2 > np)
        t->b2 = np;
    if (t->b1 > t->b2)
        t->b1 = t->b2;
    const size_t blocks = np / t->b2;
    rto__parallel_ranges(blocks, threads, phase_sort_blocks, t);
    for (size_t k = 2 * t->b2; k <= np; k <<= 1) {
        size_t j = k >> 1;
        while (j >= t->b2) {
            t->k = k;
            t->j = j;
            t->m = fuse_count(t->K, j, t->b2);
            const size_t w = j >> (t->m - 1);
            t->chunk = w < CHUNK ? w : CHUNK;
            t->cpb = w / t->chunk;
            rto__parallel_ranges((np / (2 * j)) * t->cpb, threads, phase_wide_pass, t);
            j >>= t->m;
        }
        t->k = k;
        t->j = j;
        rto__parallel_ranges(blocks, threads, phase_stage_blocks, t);
    }
}

/* With checkpoints: one pass at a time over the whole array, each copied out after it runs. */
static void run_checkpointed(const net *t, rto_key_format f, uint64_t bias, void *checkpoints)
{
    const size_t np = t->np, ksz = rto_key_size(f);
    uint32_t pass = 0;
    for (size_t k = 2; k <= np; k <<= 1)
        for (size_t j = k >> 1; j > 0; j >>= 1, pass++) {
            if (j >= t->K->lanes)
                span_passes(t, k, j, 1, 0, np);
            else
                t->K->small(t->a, t->ix, k, j, j, 0, np);
            unsigned char *dst = (unsigned char *)checkpoints + (size_t)pass * np * ksz;
            if (f == RTO_KEY_U32) {
                const uint32_t *a = t->a;
                uint32_t *o = (uint32_t *)dst;
                for (size_t i = 0; i < np; i++)
                    o[i] = a[i] ^ (uint32_t)bias;
            } else {
                const uint64_t *a = t->a;
                uint64_t *o = (uint64_t *)dst;
                for (size_t i = 0; i < np; i++)
                    o[i] = a[i] ^ bias;
            }
        }
}

rto_status rto__bitonic_sort_with(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                                  void *checkpoints, rto__bitonic_isa isa, uint32_t threads, rto_msg *msg)
{
    rto_status st = rto__sort_args_check(f, keys, n, sorted, msg);
    if (st)
        return st;
    if ((unsigned)isa >= RTO__BITONIC_ISA_COUNT || !rto__bitonic_isa_supported(isa))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "bitonic path %s is not available on this CPU",
                        rto__bitonic_isa_name(isa));
    if (isa == RTO__BITONIC_AUTO)
        isa = resolve_isa();
    const size_t np = rto_next_pow2(n), ksz = rto_key_size(f);
    if (np == 0)
        return RTO_OK;
    net t;
    memset(&t, 0, sizeof t);
    t.np = np;
    t.K = ksz == 4 ? &base32_kernels : &base64_kernels;
    if (isa != RTO__BITONIC_BASELINE) {
        const rto__bitonic_kernels *K = rto__bitonic_simd_kernels(isa, ksz);
        /* A vector path needs at least eight vectors of slots; smaller arrays take the baseline (same bytes). */
        if (K && np >= 8 * (size_t)K->lanes)
            t.K = K;
    }
    t.a = rto__alloc(np, ksz);
    t.ix = rto__alloc(np, sizeof *t.ix);
    if (!t.a || !t.ix) {
        free(t.a);
        free(t.ix);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    }
    const uint64_t bias = ksz == 4 ? UINT64_C(1) << 31 : UINT64_C(1) << 63;
    if (ksz == 4) {
        const uint32_t *in = keys;
        uint32_t *a = t.a;
        for (size_t i = 0; i < np; i++)
            a[i] = (i < n ? in[i] : UINT32_MAX) ^ (uint32_t)bias;
    } else {
        const uint64_t *in = keys;
        uint64_t *a = t.a;
        for (size_t i = 0; i < np; i++)
            a[i] = (i < n ? in[i] : UINT64_MAX) ^ bias;
    }
    for (size_t i = 0; i < np; i++)
        t.ix[i] = (uint32_t)i;
    const size_t slot = ksz + sizeof *t.ix;
    t.b1 = L1_BYTES / slot;
    t.b2 = L2_BYTES / slot;
    /* powers of two */
    t.b1 = (size_t)1 << (63 - __builtin_clzll((unsigned long long)t.b1));
    t.b2 = (size_t)1 << (63 - __builtin_clzll((unsigned long long)t.b2));
    if (checkpoints)
        run_checkpointed(&t, f, bias, checkpoints);
    else
        run_fused(&t, np >= THREADS_FROM ? threads : 1);
    if (ksz == 4) {
        const uint32_t *a = t.a;
        uint32_t *o = sorted;
        for (size_t i = 0; i < np; i++)
            o[i] = a[i] ^ (uint32_t)bias;
    } else {
        const uint64_t *a = t.a;
        uint64_t *o = sorted;
        for (size_t i = 0; i < np; i++)
            o[i] = a[i] ^ bias;
    }
    if (perm)
        memcpy(perm, t.ix, np * sizeof *t.ix);
    free(t.a);
    free(t.ix);
    return RTO_OK;
}

rto_status rto_bitonic_sort(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                            void *checkpoints, rto_msg *msg)
{
    const char *env = getenv("RTO_BITONIC_ISA");
    if (env && strcmp(env, "scalar") == 0)
        return rto__bitonic_sort_scalar(f, keys, n, sorted, perm, checkpoints, msg);
    return rto__bitonic_sort_with(f, keys, n, sorted, perm, checkpoints, RTO__BITONIC_AUTO, 0, msg);
}
