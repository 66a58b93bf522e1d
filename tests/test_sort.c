/* The bitonic network and the radix reference against independent references: qsort for the final order, a
 * (key, index) qsort for stability, and a literal transcription of DESIGN.md §4's pseudo-code for every pass. */
#include "testutil.h"
#include "sort/bitonic_internal.h"
#include "sort/sort_internal.h"

/* DESIGN.md §4 verbatim: every i, l = i ^ j, act when l > i. Used to check the oracle's checkpoints. */
static void literal_network(uint64_t *a, size_t n, uint64_t *passes)
{
    size_t p = 0;
    for (size_t k = 2; k <= n; k <<= 1)
        for (size_t j = k >> 1; j > 0; j >>= 1, p++) {
            for (size_t i = 0; i < n; i++) {
                size_t l = i ^ j;
                if (l > i) {
                    int asc = (i & k) == 0;
                    if ((asc && a[i] > a[l]) || (!asc && a[i] < a[l])) {
                        uint64_t t = a[i];
                        a[i] = a[l];
                        a[l] = t;
                    }
                }
            }
            memcpy(passes + p * n, a, n * sizeof *a);
        }
}

static void test_pass_schedule(void **state)
{
    (void)state;
    assert_int_equal(rto_bitonic_pass_count(16384), 105); /* the seeds' figure */
    assert_int_equal(rto_bitonic_pass_count(0), 0);
    assert_int_equal(rto_bitonic_pass_count(1), 0);
    assert_int_equal(rto_bitonic_pass_count(2), 1);
    assert_int_equal(rto_next_pow2(0), 0);
    assert_int_equal(rto_next_pow2(1), 1);
    assert_int_equal(rto_next_pow2(4097), 8192);
    uint32_t p = 0, k, j;
    for (uint32_t kk = 2; kk <= (1u << 20); kk <<= 1)
        for (uint32_t jj = kk >> 1; jj > 0; jj >>= 1, p++) {
            rto_bitonic_pass_kj(p, &k, &j);
            assert_int_equal(k, kk);
            assert_int_equal(j, jj);
        }
}

/* Every distribution x size class x format: bitonic and radix equal qsort, and perm maps back to the input. */
static void test_sorts_equal_qsort_everywhere(void **state)
{
    (void)state;
    size_t sizes[RTO_SIZE_CLASS_MAX], nsizes = 0;
    assert_int_equal(rto_size_class("all", sizes, &nsizes, NULL), RTO_OK);
    size_t cases = 0;
    for (int fi = 0; fi < 2; fi++) {
        rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
        size_t ksz = fi ? 8 : 4;
        uint64_t sentinel = fi ? UINT64_MAX : UINT32_MAX;
        for (size_t d = 0; d < rto_dist_count(); d++) {
            const rto_dist_info *di = rto_dist_at(d);
            for (size_t z = 0; z < nsizes; z++) {
                size_t n = sizes[z], np = rto_next_pow2(n);
                if (!tu_dist_applies(di, f, n) || tu_sanitized_skip(di->name, n))
                    continue;
                uint32_t seed = (uint32_t)(1000 + d * 131 + z);
                void *keys = tu_keys(di->name, f, seed, n);
                uint64_t *e = tu_qsorted(f, keys, n);
                void *out = malloc((np ? np : 1) * ksz);
                uint32_t *perm = malloc((np ? np : 1) * 4);
                unsigned char *seen = calloc(np ? np : 1, 1);
                assert_int_equal(rto_bitonic_sort(f, keys, n, out, perm, NULL, NULL), RTO_OK);
                for (size_t i = 0; i < np; i++) {
                    uint64_t want = i < n ? e[i] : sentinel;
                    if (tu_get(f, out, i) != want)
                        fail_msg("bitonic %s n=%zu %s seed=%u: slot %zu", di->name, n, fi ? "u64" : "u32", seed, i);
                    assert_true(perm[i] < np && !seen[perm[i]]);
                    seen[perm[i]] = 1;
                    uint64_t src = perm[i] < n ? tu_get(f, keys, perm[i]) : sentinel;
                    assert_true(src == tu_get(f, out, i));
                }
                assert_int_equal(rto_fast_radix_sort(f, keys, n, out, NULL), RTO_OK);
                for (size_t i = 0; i < n; i++)
                    if (tu_get(f, out, i) != e[i])
                        fail_msg("fast radix %s n=%zu %s seed=%u: slot %zu", di->name, n, fi ? "u64" : "u32", seed, i);
                assert_int_equal(rto_radix_sort(f, keys, n, 8, 256, out, perm, NULL, NULL), RTO_OK);
                for (size_t i = 0; i < n; i++) {
                    if (tu_get(f, out, i) != e[i])
                        fail_msg("radix %s n=%zu seed=%u: slot %zu", di->name, n, seed, i);
                    assert_true(tu_get(f, keys, perm[i]) == e[i]);
                    if (i && e[i] == e[i - 1])
                        assert_true(perm[i - 1] < perm[i]); /* stable */
                }
                free(keys);
                free(e);
                free(out);
                free(perm);
                free(seen);
                cases++;
            }
        }
    }
    print_message("bitonic, radix and fast radix matched qsort on %zu distribution x size x format cases\n", cases);
    assert_true(cases > TU_SIZED(2000, 1000));
}

/* Checkpoints equal the literal schedule's array after each pass, for small n of every shape. */
static void test_checkpoints_follow_the_schedule(void **state)
{
    (void)state;
    const char *dists[] = {"random", "few-unique", "sentinel-heavy", "clustered", "reversed"};
    for (size_t d = 0; d < 5; d++)
        for (size_t n = 0; n <= 130; n += (n < 20 ? 1 : 11)) {
            for (int fi = 0; fi < 2; fi++) {
                rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                size_t np = rto_next_pow2(n), ksz = fi ? 8 : 4;
                uint32_t P = rto_bitonic_pass_count(np);
                void *keys = tu_keys(dists[d], f, (uint32_t)n, n);
                uint64_t *a = malloc((np ? np : 1) * 8), *ref = malloc((P ? P : 1) * (np ? np : 1) * 8);
                for (size_t i = 0; i < np; i++)
                    a[i] = i < n ? tu_get(f, keys, i) : (fi ? UINT64_MAX : UINT32_MAX);
                literal_network(a, np, ref);
                void *ck = malloc((P ? P : 1) * (np ? np : 1) * ksz), *out = malloc((np ? np : 1) * ksz);
                assert_int_equal(rto_bitonic_sort(f, keys, n, out, NULL, ck, NULL), RTO_OK);
                for (size_t i = 0; i < (size_t)P * np; i++)
                    if (tu_get(f, ck, i) != ref[i])
                        fail_msg("%s n=%zu: pass %zu slot %zu", dists[d], n, i / np, i % np);
                /* the kept scalar reference follows the literal schedule too */
                assert_int_equal(rto__bitonic_sort_scalar(f, keys, n, out, NULL, ck, NULL), RTO_OK);
                for (size_t i = 0; i < (size_t)P * np; i++)
                    if (tu_get(f, ck, i) != ref[i])
                        fail_msg("reference %s n=%zu: pass %zu slot %zu", dists[d], n, i / np, i % np);
                free(keys);
                free(a);
                free(ref);
                free(ck);
                free(out);
            }
        }
}

/* Radix intermediates against quantities computed here from the scattered arrays alone. */
static void test_radix_intermediates(void **state)
{
    (void)state;
    const uint32_t tiles_sz[] = {1, 7, 256, 1000};
    const char *dists[] = {"random", "tile-overflow", "digit-1-one-bucket", "all-equal", "entropy-9"};
    for (size_t d = 0; d < 5; d++)
        for (int fi = 0; fi < 2; fi++)
            for (uint32_t bits = 4; bits <= 8; bits += 4)
                for (size_t t = 0; t < 4; t++) {
                    rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                    const size_t n = 3001, ksz = fi ? 8 : 4;
                    const uint32_t T = tiles_sz[t], R = 1u << bits, P = rto_radix_pass_count(f, bits);
                    const size_t M = rto_radix_tile_count(n, T);
                    assert_int_equal(P, (fi ? 64 : 32) / bits);
                    void *keys = tu_keys(dists[d], f, 3, n), *out = malloc(n * ksz);
                    rto_radix_trace tr = {malloc(P * M * R * 4), malloc(P * R * 4), malloc(P * M * R * 4),
                                          malloc(P * n * ksz), malloc(P * n * 4)};
                    uint32_t *perm = malloc(n * 4);
                    assert_int_equal(rto_radix_sort(f, keys, n, bits, T, out, perm, &tr, NULL), RTO_OK);
                    uint32_t *ref_hist = malloc(M * R * 4), *prevpos = malloc(n * 4);
                    for (uint32_t p = 0; p < P; p++) {
                        const void *in = p ? (const unsigned char *)tr.scatter + (p - 1) * n * ksz : keys;
                        const void *sc = (const unsigned char *)tr.scatter + p * n * ksz;
                        const uint32_t shift = p * bits;
                        /* position of each source index in the array this pass reads */
                        for (size_t i = 0; i < n; i++)
                            prevpos[p ? tr.perm[(p - 1) * n + i] : i] = (uint32_t)i;
                        memset(ref_hist, 0, M * R * 4);
                        for (size_t i = 0; i < n; i++)
                            ref_hist[(i / T) * R + ((tu_get(f, in, i) >> shift) & (R - 1))]++;
                        uint32_t run = 0;
                        for (uint32_t dg = 0; dg < R; dg++) {
                            assert_int_equal(tr.prefix[p * R + dg], run);
                            uint32_t before = 0;
                            for (size_t tile = 0; tile < M; tile++) {
                                assert_int_equal(tr.hist[(p * M + tile) * R + dg], ref_hist[tile * R + dg]);
                                assert_int_equal(tr.base[(p * M + tile) * R + dg], run + before);
                                before += ref_hist[tile * R + dg];
                            }
                            run += before;
                        }
                        assert_int_equal(run, n);
                        /* the scatter is the stable partition of the previous array by this digit */
                        for (size_t i = 0; i < n; i++) {
                            assert_true(tu_get(f, keys, tr.perm[p * n + i]) == tu_get(f, sc, i));
                            if (i == 0)
                                continue;
                            uint64_t da = (tu_get(f, sc, i - 1) >> shift) & (R - 1);
                            uint64_t db = (tu_get(f, sc, i) >> shift) & (R - 1);
                            assert_true(da <= db);
                            if (da == db)
                                assert_true(prevpos[tr.perm[p * n + i - 1]] < prevpos[tr.perm[p * n + i]]);
                        }
                    }
                    free(ref_hist);
                    free(prevpos);
                    assert_memory_equal((const unsigned char *)tr.scatter + (P - 1) * n * ksz, out, n * ksz);
                    free(keys);
                    free(out);
                    free(perm);
                    free(tr.hist);
                    free(tr.prefix);
                    free(tr.base);
                    free(tr.scatter);
                    free(tr.perm);
                }
}

/* Key shapes that steer the fast radix sort down each of its paths: an index field in input order (strictly, or with
 * repeats), one out of order, differences only inside the index field, constant high bits of ones, all 64 bits
 * random, a single differing bit. Each result equals qsort and the canonical network's first n slots. */
static uint64_t shaped_key(int shape, rto_key_format f, uint32_t seed, size_t i, size_t n)
{
    const int w = f == RTO_KEY_U32 ? 16 : 32; /* index field width */
    uint64_t r = rto_rng(seed, (uint32_t)i), r2 = rto_rng(seed ^ 0x5bd1e995u, (uint32_t)i);
    uint64_t idx = (uint64_t)i;
    switch (shape) {
    case 0: return ((r & (f == RTO_KEY_U32 ? 0x7FFFu : 0x3FFFFFFFu)) << w) | idx; /* rto_tlas_keys / rto_blas_keys */
    case 1: return ((r & 0xFFu) << w) | (idx / 3);                                  /* index repeats, in order */
    case 2: return ((r & 0xFFu) << w) | (i == n / 2 ? (idx + 1) : i == n / 2 + 1 ? (idx - 1) : idx); /* one swap */
    case 3: return (UINT64_C(5) << w) | (uint64_t)(n - 1 - i);                     /* only the index differs, reversed */
    case 4: return (UINT64_C(5) << w) | idx;                                        /* already sorted */
    case 5: return (f == RTO_KEY_U32 ? 0xFFFF0000u : UINT64_C(0xFFFFFFFF00000000)) | (r & 0x3FFu); /* high ones */
    case 6: return (r << 32) | r2;                                                  /* every bit random */
    case 7: return (r & 1u) << (f == RTO_KEY_U32 ? 31 : 63);                        /* only the top bit differs */
    case 8: return r & 1u;                                                          /* only bit 0 differs */
    case 9: /* one key in 64 has high bits, the rest share their top digit: too skewed to deal out by it */
        return ((i % 64 ? r & 0xFFu : r & (f == RTO_KEY_U32 ? 0x7FFFu : 0x3FFFFFFFu)) << w) | idx;
    default: /* two clusters, one at each end of the key range: two top digits, half the keys each */
        return ((((uint64_t)(i & 1u) << (f == RTO_KEY_U32 ? 14 : 29)) | (r & 0xFFu)) << w) | idx;
    }
}

#define SHAPES 10

/* Shapes whose index field is the position, which 16 bits hold only up to 65,536 keys. */
static int index_shape(int shape) { return shape == 0 || shape == 3 || shape == 4 || shape == 9 || shape == 10; }

static void test_fast_radix_sort_paths(void **state)
{
    (void)state;
    const size_t sizes[] = {0, 1, 2, 3, 7, 64, 255, 256, 257, 1000, 4097, 65536, 100003};
    size_t cases = 0;
    for (int fi = 0; fi < 2; fi++) {
        rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
        const size_t ksz = rto_key_size(f);
        for (int shape = 0; shape <= SHAPES; shape++)
            for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
                size_t n = sizes[z];
                if (f == RTO_KEY_U32 && index_shape(shape) && n > 65536)
                    continue; /* a 16-bit index field holds 65,536 positions */
                uint32_t seed = (uint32_t)(77 + 1000 * shape + 10 * z + fi);
                void *keys = malloc((n ? n : 1) * ksz), *out = malloc((n ? n : 1) * ksz);
                void *net = malloc((rto_next_pow2(n) ? rto_next_pow2(n) : 1) * ksz);
                for (size_t i = 0; i < n; i++)
                    tu_put(f, keys, i, shaped_key(shape, f, seed, i, n));
                uint64_t *e = tu_qsorted(f, keys, n);
                rto_msg msg = {{0}};
                if (rto_fast_radix_sort(f, keys, n, out, &msg))
                    fail_msg("shape %d n=%zu seed=%u: %s", shape, n, seed, msg.text);
                assert_int_equal(rto_bitonic_sort(f, keys, n, net, NULL, NULL, NULL), RTO_OK);
                for (size_t i = 0; i < n; i++)
                    if (tu_get(f, out, i) != e[i] || tu_get(f, net, i) != e[i])
                        fail_msg("fast radix %s shape %d n=%zu seed=%u: slot %zu is %llx, qsort %llx", fi ? "u64" : "u32",
                                 shape, n, seed, i, (unsigned long long)tu_get(f, out, i), (unsigned long long)e[i]);
                free(keys);
                free(out);
                free(net);
                free(e);
                cases++;
            }
    }
    print_message("fast radix matched qsort and the network on %zu shaped cases\n", cases);
}

/* The builds' team sort (most significant digit first, or the LSD team sort when the top digit is too skewed) at
 * several team sizes against qsort, over the same shapes. */
typedef struct team_job {
    rto__radix_team r;
} team_job;

static void team_sort_fn(void *ctx, rto__team *team, uint32_t w, uint32_t t)
{
    team_job *j = ctx;
    rto__radix_team_sort(&j->r, team, w, t);
}

static void test_team_radix_sort(void **state)
{
    (void)state;
    const size_t sizes[] = {0, 1, 2, 3, 7, 33, 257, 4097, 65536, 100003};
    const uint32_t teams[] = {1, 2, 3, 8, 33};
    size_t cases = 0;
    for (int fi = 0; fi < 2; fi++) {
        rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
        const size_t ksz = rto_key_size(f);
        for (int shape = 0; shape <= SHAPES; shape++)
            for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
                const size_t n = sizes[z];
                if (f == RTO_KEY_U32 && index_shape(shape) && n > 65536)
                    continue;
                const uint32_t seed = (uint32_t)(91 + 1000 * shape + 10 * z + fi);
                void *keys = malloc((n ? n : 1) * ksz), *out = malloc((n ? n : 1) * ksz), *tmp = malloc((n ? n : 1) * ksz);
                for (size_t i = 0; i < n; i++)
                    tu_put(f, keys, i, shaped_key(shape, f, seed, i, n));
                uint64_t *e = tu_qsorted(f, keys, n);
                for (size_t ti = 0; ti < sizeof teams / sizeof teams[0]; ti++) {
                    const uint32_t t = teams[ti];
                    /* scratch as the builds leave it: never zeroed between sorts */
                    const size_t hw = rto__radix_team_hist_words(t);
                    uint32_t *hist = malloc(hw * sizeof *hist), *first = malloc((size_t)t * 2048u * sizeof *first);
                    uint64_t *diff = malloc(t * sizeof *diff);
                    uint8_t *ordered = malloc(t);
                    assert_non_null(hist);
                    assert_non_null(first);
                    assert_non_null(diff);
                    assert_non_null(ordered);
                    memset(hist, 0xA5, hw * sizeof *hist);
                    memset(first, 0xA5, (size_t)t * 2048u * sizeof *first);
                    memset(diff, 0xA5, t * sizeof *diff);
                    memset(ordered, 0xA5, t);
                    memset(tmp, 0xA5, (n ? n : 1) * ksz);
                    memset(out, 0xA5, (n ? n : 1) * ksz);
                    team_job j = {{f, keys, n, out, tmp, hist, first, diff, ordered}};
                    rto__team_run(t, team_sort_fn, &j);
                    for (size_t i = 0; i < n; i++)
                        if (tu_get(f, out, i) != e[i])
                            fail_msg("team sort %s shape %d n=%zu team %u seed=%u: slot %zu is %llx, qsort %llx",
                                     fi ? "u64" : "u32", shape, n, t, seed, i, (unsigned long long)tu_get(f, out, i),
                                     (unsigned long long)e[i]);
                    free(hist);
                    free(first);
                    free(diff);
                    free(ordered);
                    cases++;
                }
                free(keys);
                free(out);
                free(tmp);
                free(e);
            }
    }
    print_message("team radix sort matched qsort on %zu cases\n", cases);
}

/* The first differing slot of two n-slot arrays of sz-byte elements, or n. */
static size_t first_diff(const void *x, const void *y, size_t n, size_t sz)
{
    for (size_t i = 0; i < n; i++)
        if (memcmp((const unsigned char *)x + i * sz, (const unsigned char *)y + i * sz, sz) != 0)
            return i;
    return n;
}

/* One path and thread count against the kept scalar reference: the final keys and permutation, and (when ref_ck is
 * given) every pass's checkpoint, byte for byte. */
/* ck_scratch: room for the path's checkpoints when ref_ck is given (one buffer for every case: a fresh 70 MB
 * allocation per case spent most of this test's time in page faults). */
static void check_path(rto__bitonic_isa isa, uint32_t threads, rto_key_format f, const char *dist, uint32_t seed,
                       const void *keys, size_t n, const void *ref, const uint32_t *ref_perm, const void *ref_ck,
                       void *ck_scratch)
{
    const size_t np = rto_next_pow2(n), ksz = rto_key_size(f);
    const uint32_t P = rto_bitonic_pass_count(np);
    void *out = malloc(np * ksz);
    uint32_t *perm = malloc(np * 4);
    const char *fmt = f == RTO_KEY_U32 ? "u32" : "u64", *name = rto__bitonic_isa_name(isa);
    rto_msg msg = {{0}};
    if (rto__bitonic_sort_with(f, keys, n, out, perm, NULL, isa, threads, &msg) != RTO_OK)
        fail_msg("%s: %s", name, msg.text);
    size_t i = first_diff(out, ref, np, ksz);
    if (i < np)
        fail_msg("bitonic:%s:threads=%u:fmt=%s:dist=%s:n=%zu seed=%u: key slot %zu is %llx, reference %llx", name,
                 threads, fmt, dist, n, seed, i, (unsigned long long)tu_get(f, out, i),
                 (unsigned long long)tu_get(f, ref, i));
    i = first_diff(perm, ref_perm, np, 4);
    if (i < np)
        fail_msg("bitonic:%s:threads=%u:fmt=%s:dist=%s:n=%zu seed=%u: perm slot %zu is %u, reference %u", name,
                 threads, fmt, dist, n, seed, i, perm[i], ref_perm[i]);
    if (ref_ck) {
        void *ck = ck_scratch;
        memset(ck, 0xA5, (size_t)P * np * ksz); /* nothing left from an earlier case can pass for a checkpoint */
        memset(perm, 0, np * 4);
        if (rto__bitonic_sort_with(f, keys, n, out, perm, ck, isa, threads, &msg) != RTO_OK)
            fail_msg("%s: %s", name, msg.text);
        for (uint32_t p = 0; p < P; p++) {
            i = first_diff((const unsigned char *)ck + (size_t)p * np * ksz,
                           (const unsigned char *)ref_ck + (size_t)p * np * ksz, np, ksz);
            if (i < np) {
                uint32_t k, j;
                rto_bitonic_pass_kj(p, &k, &j);
                fail_msg("bitonic:%s:fmt=%s:dist=%s:n=%zu seed=%u: checkpoint pass %u (k=%u, j=%u) slot %zu", name, fmt,
                         dist, n, seed, p, k, j, i);
            }
        }
        if (first_diff(out, ref, np, ksz) < np || first_diff(perm, ref_perm, np, 4) < np)
            fail_msg("bitonic:%s:fmt=%s:dist=%s:n=%zu seed=%u: final array with checkpoints", name, fmt, dist, n, seed);
    }
    free(out);
    free(perm);
}

/* Every path this CPU has (baseline, AVX2, AVX-512), 1 and N threads, against the kept scalar reference: keys,
 * permutation (so equal keys end where the reference's compare-exchanges leave them) and every checkpoint. */
static void test_paths_equal_scalar_reference(void **state)
{
    (void)state;
    static const size_t sizes[] = {1, 2, 3, 255, 256, 257, 4095, 4096, 4097, 16385};
    static const uint32_t thread_counts[] = {1, 3, 0};
    size_t cases = 0;
    /* The checkpoints of the largest case (u64 keys), allocated once for the reference and once for the paths. */
    const size_t ck_max = (size_t)rto_bitonic_pass_count(rto_next_pow2(sizes[sizeof sizes / sizeof sizes[0] - 1])) *
                          rto_next_pow2(sizes[sizeof sizes / sizeof sizes[0] - 1]) * 8;
    void *ref_ck = malloc(ck_max), *ck = malloc(ck_max);
    assert_true(ref_ck && ck);
    for (int isa = RTO__BITONIC_BASELINE; isa < RTO__BITONIC_ISA_COUNT; isa++)
        print_message("bitonic path %s: %s\n", rto__bitonic_isa_name((rto__bitonic_isa)isa),
                      rto__bitonic_isa_supported((rto__bitonic_isa)isa) ? "tested" : "not on this CPU");
    for (int fi = 0; fi < 2; fi++) {
        rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
        const size_t ksz = rto_key_size(f);
        for (size_t d = 0; d < rto_dist_count(); d++) {
            const rto_dist_info *di = rto_dist_at(d);
            for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
                const size_t n = sizes[z], np = rto_next_pow2(n);
                if (!tu_dist_applies(di, f, n) || tu_sanitized_skip(di->name, n))
                    continue;
                const uint32_t seed = (uint32_t)(4000 + d * 37 + z), P = rto_bitonic_pass_count(np);
                void *keys = tu_keys(di->name, f, seed, n);
                void *ref = malloc(np * ksz);
                assert_true((size_t)P * np * ksz <= ck_max);
                uint32_t *ref_perm = malloc(np * 4);
                assert_int_equal(rto__bitonic_sort_scalar(f, keys, n, ref, ref_perm, ref_ck, NULL), RTO_OK);
                for (int isa = RTO__BITONIC_BASELINE; isa < RTO__BITONIC_ISA_COUNT; isa++) {
                    if (!rto__bitonic_isa_supported((rto__bitonic_isa)isa))
                        continue;
                    for (size_t t = 0; t < sizeof thread_counts / sizeof thread_counts[0]; t++)
                        if (!tu_sanitized_thread_skip(cases, t, sizeof thread_counts / sizeof thread_counts[0]))
                            check_path((rto__bitonic_isa)isa, thread_counts[t], f, di->name, seed, keys, n, ref,
                                       ref_perm, t == 0 ? ref_ck : NULL, ck);
                    cases++;
                }
                free(keys);
                free(ref);
                free(ref_perm);
            }
        }
    }
    free(ref_ck);
    free(ck);
    print_message("every bitonic path matched the scalar reference on %zu path x format x dist x size cases\n",
                  cases);
    assert_true(cases > 300);
}

/* Arrays large enough for the fused whole-array passes (strides above the L2 block, split across threads). */
static void test_paths_equal_reference_large(void **state)
{
    (void)state;
    static const char *dists[] = {"random", "few-unique", "sentinel-heavy"};
    static const size_t sizes[] = {262145, (size_t)1 << 18};
    for (int fi = 0; fi < 2; fi++)
        for (size_t d = 0; d < 3; d++)
            for (size_t z = 0; z < TU_SIZED(2, 1); z++) {
                /* Under the sanitizer, half the format x distribution pairs: both formats, every distribution. */
                if (TU_SANITIZED && ((size_t)fi + d) % 2)
                    continue;
                rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                const size_t n = sizes[z], np = rto_next_pow2(n), ksz = rto_key_size(f);
                const uint32_t seed = (uint32_t)(9000 + 10 * d + z);
                void *keys = tu_keys(dists[d], f, seed, n), *ref = malloc(np * ksz);
                uint32_t *ref_perm = malloc(np * 4);
                assert_int_equal(rto__bitonic_sort_scalar(f, keys, n, ref, ref_perm, NULL, NULL), RTO_OK);
                for (int isa = RTO__BITONIC_BASELINE; isa < RTO__BITONIC_ISA_COUNT; isa++) {
                    if (!rto__bitonic_isa_supported((rto__bitonic_isa)isa))
                        continue;
                    check_path((rto__bitonic_isa)isa, 1, f, dists[d], seed, keys, n, ref, ref_perm, NULL, NULL);
                    check_path((rto__bitonic_isa)isa, 3, f, dists[d], seed, keys, n, ref, ref_perm, NULL, NULL);
                }
                free(keys);
                free(ref);
                free(ref_perm);
            }
}

/* RTO_BITONIC_ISA forces a narrower path (or the reference) for rto_bitonic_sort; an unknown path is refused by
 * rto__bitonic_sort_with, not guessed. */
static void test_path_selection(void **state)
{
    (void)state;
    const size_t n = 5000, np = 8192;
    void *keys = tu_keys("few-unique", RTO_KEY_U32, 5, n);
    uint32_t ref[8192], out[8192], ref_perm[8192], perm[8192];
    assert_int_equal(rto__bitonic_sort_scalar(RTO_KEY_U32, keys, n, ref, ref_perm, NULL, NULL), RTO_OK);
    const char *names[] = {"scalar", "baseline", "avx2", "avx512", "bogus"};
    for (size_t i = 0; i < 5; i++) {
        assert_int_equal(setenv("RTO_BITONIC_ISA", names[i], 1), 0);
        assert_int_equal(rto_bitonic_sort(RTO_KEY_U32, keys, n, out, perm, NULL, NULL), RTO_OK);
        assert_memory_equal(out, ref, np * 4);
        assert_memory_equal(perm, ref_perm, np * 4);
    }
    unsetenv("RTO_BITONIC_ISA");
    rto_msg msg = {{0}};
    assert_int_equal(rto__bitonic_sort_with(RTO_KEY_U32, keys, n, out, perm, NULL, (rto__bitonic_isa)9, 1, &msg),
                     RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "not available"));
    free(keys);
}

static void test_sort_refuses_bad_arguments(void **state)
{
    (void)state;
    uint32_t k[4] = {3, 2, 1, 0}, o[4];
    rto_msg msg = {{0}};
    assert_int_equal(rto_radix_sort(RTO_KEY_U32, k, 4, 5, 256, o, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "4 or 8"));
    assert_int_equal(rto_radix_sort(RTO_KEY_U32, k, 4, 8, 0, o, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U32, NULL, 4, o, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U32, k, (size_t)RTO_MAX_KEYS + 1, o, NULL, NULL, &msg),
                     RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_bitonic_sort((rto_key_format)9, k, 4, o, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_fast_radix_sort((rto_key_format)9, k, 4, o, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_fast_radix_sort(RTO_KEY_U32, NULL, 4, o, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_fast_radix_sort(RTO_KEY_U32, k, (size_t)RTO_MAX_KEYS + 1, o, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_fast_radix_sort(RTO_KEY_U32, k, 4, k + 1, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "overlap"));
    assert_int_equal(rto_fast_radix_sort(RTO_KEY_U32, NULL, 0, NULL, &msg), RTO_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pass_schedule),
        cmocka_unit_test(test_sorts_equal_qsort_everywhere),
        cmocka_unit_test(test_checkpoints_follow_the_schedule),
        cmocka_unit_test(test_paths_equal_scalar_reference),
        cmocka_unit_test(test_paths_equal_reference_large),
        cmocka_unit_test(test_path_selection),
        cmocka_unit_test(test_radix_intermediates),
        cmocka_unit_test(test_fast_radix_sort_paths),
        cmocka_unit_test(test_team_radix_sort),
        cmocka_unit_test(test_sort_refuses_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
