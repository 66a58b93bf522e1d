/* Property test of check-sort's fast path: rto_sort_check (the dump compared with the sorted input, the full analysis
 * only on a mismatch) and the full analysis it replaced (rto__sort_check_reference: qsort of input and dump, every
 * check run) give the same status and the same report, text and JSON byte for byte, for correct dumps and for many
 * mutated ones (swap, flip a bit, duplicate, drop, reorder equal keys, wrong value, tail) across distributions, both
 * formats, dumps of n and n_padded slots and sizes 1, 2, 3, 255..257 and 4095..4097, and on a smaller grid above the
 * size where threads start. The fast path runs with the input matched inside (threads 1, 3 and all) and with
 * expected_keys (made here by qsort, as a bundle's sorted.npy would hold them). The matcher under it
 * (rto__sort_match) is held to qsort on its own: its sort gives qsort's bytes, and its verdict is qsort's memcmp. */
#include "testutil.h"

#include "sort/sort_internal.h"

enum { TEXT_CAP = 1 << 16 };

typedef enum mutation {
    MUT_NONE,
    MUT_SWAP,      /* two random slots of the real range exchanged */
    MUT_SWAP_NEXT, /* a slot and its successor exchanged */
    MUT_FLIP,      /* one bit of one slot flipped (the sentinel included) */
    MUT_DUPLICATE, /* a slot overwritten by another slot's key */
    MUT_DROP,      /* a slot removed, the real range shifted down, a sentinel appended */
    MUT_REORDER,   /* the values of two equal neighbouring keys exchanged */
    MUT_VALUE,     /* one carried value replaced by a random index (in or out of range) */
    MUT_TAIL,      /* a padded slot given a random key */
    MUT_COUNT
} mutation;

static const char *const mutation_names[] = {"none", "swap", "swap-next", "flip", "duplicate",
                                             "drop", "reorder", "value", "tail"};

typedef struct dump {
    rto_key_format f;
    size_t n, gn;
    void *input, *gpu, *expected; /* expected: the input in ascending order, native width */
    uint32_t *values;
} dump;

/* A correct key/value dump of gn slots made by qsort of (key, index) pairs: stable, padding p carrying n + p. */
static void dump_make(dump *dp, const char *dist, rto_key_format f, size_t n, int padded, uint32_t seed)
{
    const size_t ksz = f == RTO_KEY_U32 ? 4 : 8, np = rto_next_pow2(n);
    const uint64_t sentinel = f == RTO_KEY_U32 ? UINT32_MAX : UINT64_MAX;
    dp->f = f;
    dp->n = n;
    dp->gn = padded ? np : n;
    dp->input = tu_keys(dist, f, seed, n);
    dp->gpu = malloc(dp->gn * ksz);
    dp->expected = malloc(n * ksz);
    dp->values = malloc(dp->gn * 4);
    uint64_t *sorted = tu_qsorted(f, dp->input, n);
    assert_true(dp->gpu && dp->expected && dp->values);
    for (size_t i = 0; i < n; i++)
        tu_put(f, dp->expected, i, sorted[i]);
    tu_stable_dump(f, dp->input, n, dp->gn, sentinel, dp->gpu, dp->values);
    free(sorted);
}

static void dump_free(dump *dp)
{
    free(dp->input);
    free(dp->gpu);
    free(dp->expected);
    free(dp->values);
}

static void swap_slots(dump *dp, size_t a, size_t b)
{
    uint64_t k = tu_get(dp->f, dp->gpu, a);
    tu_put(dp->f, dp->gpu, a, tu_get(dp->f, dp->gpu, b));
    tu_put(dp->f, dp->gpu, b, k);
    uint32_t v = dp->values[a];
    dp->values[a] = dp->values[b];
    dp->values[b] = v;
}

/* Applies mutation m with the test's own random stream; 0 when it does not apply to this dump. */
static int mutate(dump *dp, mutation m, uint64_t *rng)
{
    const size_t n = dp->n, gn = dp->gn, ksz = dp->f == RTO_KEY_U32 ? 4 : 8;
    const uint64_t sentinel = dp->f == RTO_KEY_U32 ? UINT32_MAX : UINT64_MAX;
    const size_t i = (size_t)(tu_rng_next(rng) % n), j = (size_t)(tu_rng_next(rng) % n);
    switch (m) {
    case MUT_NONE: return 1;
    case MUT_SWAP: swap_slots(dp, i, j); return 1;
    case MUT_SWAP_NEXT:
        if (n < 2)
            return 0;
        swap_slots(dp, i % (n - 1), i % (n - 1) + 1);
        return 1;
    case MUT_FLIP: {
        const size_t s = (size_t)(tu_rng_next(rng) % gn);
        tu_put(dp->f, dp->gpu, s, tu_get(dp->f, dp->gpu, s) ^ (UINT64_C(1) << (tu_rng_next(rng) % (ksz * 8))));
        return 1;
    }
    case MUT_DUPLICATE:
        tu_put(dp->f, dp->gpu, i, tu_get(dp->f, dp->gpu, j));
        dp->values[i] = dp->values[j];
        return 1;
    case MUT_DROP: {
        unsigned char *g = dp->gpu;
        memmove(g + i * ksz, g + (i + 1) * ksz, (n - i - 1) * ksz);
        memmove(dp->values + i, dp->values + i + 1, (n - i - 1) * 4);
        tu_put(dp->f, dp->gpu, n - 1, sentinel);
        return 1;
    }
    case MUT_REORDER:
        for (size_t s = i; s + 1 < gn; s++)
            if (tu_get(dp->f, dp->gpu, s) == tu_get(dp->f, dp->gpu, s + 1)) {
                uint32_t v = dp->values[s];
                dp->values[s] = dp->values[s + 1];
                dp->values[s + 1] = v;
                return 1;
            }
        return 0;
    case MUT_VALUE: dp->values[i] = (uint32_t)(tu_rng_next(rng) % (2 * gn + 2)); return 1;
    case MUT_TAIL:
        if (gn == n)
            return 0;
        tu_put(dp->f, dp->gpu, n + (size_t)(tu_rng_next(rng) % (gn - n)), tu_get(dp->f, dp->input, i));
        return 1;
    case MUT_COUNT: break;
    }
    return 0;
}

/* Status, text and JSON of one check. */
typedef struct outcome {
    rto_status status;
    char text[TEXT_CAP], json[TEXT_CAP];
} outcome;

static void run_threads(const dump *dp, int values, int stable, int way, uint32_t threads, outcome *o)
{
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.format = dp->f;
    d.input = dp->input;
    d.n = dp->n;
    d.gpu_keys = dp->gpu;
    d.gpu_n = dp->gn;
    d.gpu_values = values ? dp->values : NULL;
    d.require_stable = stable;
    d.expected_keys = way == 2 ? dp->expected : NULL;
    d.threads = threads;
    rto_report r;
    rto_msg msg = {{0}};
    o->status = way == 0 ? rto__sort_check_reference(&d, &r, &msg) : rto_sort_check(&d, &r, &msg);
    if (o->status != RTO_OK && o->status != RTO_ERR_MISMATCH)
        fail_msg("check (way %d): %s", way, msg.text);
    size_t len = 0;
    assert_int_equal(rto_report_text(&r, o->text, TEXT_CAP, &len), RTO_OK);
    assert_int_equal(rto_report_json(&r, o->json, TEXT_CAP, &len, NULL), RTO_OK);
}

static void run(const dump *dp, int values, int stable, int way, outcome *o) { run_threads(dp, values, stable, way, 1, o); }

static void expect_same(const dump *dp, const char *dist, const char *mut_name, uint32_t seed, int kind, int way,
                        uint32_t threads, const outcome *fast, const outcome *ref)
{
    if (fast->status != ref->status || strcmp(fast->text, ref->text) || strcmp(fast->json, ref->json))
        fail_msg("%s %s n=%zu gn=%zu mutation %s seed %u kind %d way %d threads %u: fast path\n%s\nfull analysis\n%s",
                 dist, dp->f == RTO_KEY_U64 ? "u64" : "u32", dp->n, dp->gn, mut_name, seed, kind, way, threads,
                 fast->text, ref->text);
}

static const char *const dists[] = {"random",   "few-unique", "clustered", "sentinel-heavy", "all-equal",
                                    "sorted",   "reversed",   "one-bucket", "tile-overflow", "entropy-9"};
static const size_t sizes[] = {1, 2, 3, 255, 256, 257, 4095, 4096, 4097};

static void test_fast_path_agrees_with_full_analysis(void **state)
{
    (void)state;
    static outcome ref, fast;
    size_t cases = 0, faults = 0, seen[MUT_COUNT] = {0};
    for (size_t di = 0; di < sizeof dists / sizeof dists[0]; di++)
        for (size_t zi = 0; zi < sizeof sizes / sizeof sizes[0]; zi++)
            for (int fi = 0; fi < 2; fi++)
                for (int padded = 0; padded < 2; padded++)
                    for (int m = 0; m < MUT_COUNT; m++)
                        for (int rep = 0; rep < (m == MUT_NONE ? 1 : TU_SIZED(2, 1)); rep++) {
                            const uint32_t seed = (uint32_t)(((di * 16 + zi) * 4 + (size_t)(fi * 2 + padded)) * 16 +
                                                             (size_t)m) * 4 + (uint32_t)rep;
                            uint64_t rng = seed;
                            dump dp;
                            dump_make(&dp, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, seed);
                            if (!mutate(&dp, (mutation)m, &rng)) {
                                dump_free(&dp);
                                continue;
                            }
                            seen[m]++;
                            /* keys only; values; values and stability */
                            for (int kind = 0; kind < 3; kind++) {
                                run(&dp, kind > 0, kind > 1, 0, &ref);
                                faults += ref.status == RTO_ERR_MISMATCH;
                                for (int way = 1; way <= 2; way++) {
                                    run(&dp, kind > 0, kind > 1, way, &fast);
                                    expect_same(&dp, dists[di], mutation_names[m], seed, kind, way, 1, &fast, &ref);
                                }
                                cases++;
                            }
                            dump_free(&dp);
                        }
    /* every mutation ran, and most of them were faults */
    for (int m = 0; m < MUT_COUNT; m++)
        assert_true(seen[m] > 0);
    assert_true(faults > cases / 2);
}

/* expected_keys that are not the input in ascending order are refused, not trusted: unsorted, one key changed, or
 * the keys of another input. */
static void test_wrong_expected_keys_refused(void **state)
{
    (void)state;
    for (int fi = 0; fi < 2; fi++) {
        dump dp;
        dump_make(&dp, "random", fi ? RTO_KEY_U64 : RTO_KEY_U32, 1000, 0, 5);
        rto_sort_check_desc d;
        memset(&d, 0, sizeof d);
        d.format = dp.f;
        d.input = dp.input;
        d.n = dp.n;
        d.gpu_keys = dp.gpu;
        d.gpu_n = dp.gn;
        d.expected_keys = dp.expected;
        rto_report r;
        rto_msg msg = {{0}};
        assert_int_equal(rto_sort_check(&d, &r, &msg), RTO_OK);
        uint64_t a = tu_get(dp.f, dp.expected, 10), b = tu_get(dp.f, dp.expected, 11);
        tu_put(dp.f, dp.expected, 10, b); /* out of order */
        tu_put(dp.f, dp.expected, 11, a);
        assert_int_equal(rto_sort_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
        assert_non_null(strstr(msg.text, "ascending"));
        tu_put(dp.f, dp.expected, 10, a);
        tu_put(dp.f, dp.expected, 11, a); /* ascending, but a key replaced by its neighbour */
        assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_INVALID_ARGUMENT);
        tu_put(dp.f, dp.expected, 11, b);
        /* the GPU's dump equal to the wrong expectation still fails: the input of another seed */
        dump other;
        dump_make(&other, "random", dp.f, 1000, 0, 6);
        d.expected_keys = other.expected;
        d.gpu_keys = other.expected;
        assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_INVALID_ARGUMENT);
        d.expected_keys = NULL;
        assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_MISMATCH);
        dump_free(&other);
        dump_free(&dp);
    }
}

/* Above the size where the matcher starts threads: the same agreement with 1, 3 and all threads, on a grid cut
 * to fit the time (keys only; every mutation of the keys once). */
static void test_fast_path_threads_agree(void **state)
{
    (void)state;
    static outcome ref, fast;
    static const char *const big_dists[] = {"random", "all-equal", "one-bucket", "clustered", "sorted", "reversed",
                                            "few-unique", "entropy-9"};
    static const mutation muts[] = {MUT_NONE, MUT_SWAP, MUT_SWAP_NEXT, MUT_FLIP, MUT_DUPLICATE, MUT_DROP, MUT_TAIL};
    static const uint32_t threads[] = {1, 3, 0};
    const size_t big[] = {RTO__SORT_MATCH_TEAM_FROM + 1};
    size_t faults = 0, cases = 0;
    for (size_t di = 0; di < sizeof big_dists / sizeof big_dists[0]; di++)
        for (size_t zi = 0; zi < sizeof big / sizeof big[0]; zi++)
            for (int fi = 0; fi < 2; fi++)
                for (size_t mi = 0; mi < sizeof muts / sizeof muts[0]; mi++) {
                    if (!tu_dist_applies(rto_dist_find(big_dists[di]), fi ? RTO_KEY_U64 : RTO_KEY_U32, big[zi]) ||
                        tu_sanitized_skip(big_dists[di], big[zi]))
                        continue;
                    const uint32_t seed = (uint32_t)(((di * 4 + zi) * 2 + (size_t)fi) * 16 + mi) + 7000;
                    uint64_t rng = seed;
                    dump dp;
                    dump_make(&dp, big_dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, big[zi], muts[mi] == MUT_TAIL, seed);
                    if (!mutate(&dp, muts[mi], &rng)) {
                        dump_free(&dp);
                        continue;
                    }
                    run(&dp, 0, 0, 0, &ref);
                    faults += ref.status == RTO_ERR_MISMATCH;
                    cases++;
                    for (size_t ti = 0; ti < sizeof threads / sizeof threads[0]; ti++) {
                        if (tu_sanitized_thread_skip(cases, ti, sizeof threads / sizeof threads[0]))
                            continue;
                        run_threads(&dp, 0, 0, 1, threads[ti], &fast);
                        expect_same(&dp, big_dists[di], mutation_names[muts[mi]], seed, 0, 1, threads[ti], &fast, &ref);
                    }
                    dump_free(&dp);
                }
    assert_true(faults > cases / 2);
}

/* rto__sort_match alone, on keys from many distributions and sizes around its thresholds (the run length of its
 * insertion sort, the worker scratch, the team) with 1, 3 and all threads: sorting gives qsort's bytes; matching a
 * dump gives 1 exactly when the dump is qsort's order, also for dumps made to mislead the digit choice (first or last
 * slot changed, keys from another range, a reversed dump). */
static void test_sort_match_against_qsort(void **state)
{
    (void)state;
    static const char *const mdists[] = {"random",    "uniform",  "all-equal", "one-bucket", "clustered",
                                         "sorted",    "reversed", "few-unique", "entropy-9", "entropy-15",
                                         "sentinel-heavy", "digit-7-one-bucket", "tile-overflow"};
    const size_t sizes_m[] = {0,    1,    2,     3,     23,    24,    25,    63,    255,  257,
                              4097, 8191, 8193,  16385, 65535, 65537, RTO__SORT_MATCH_TEAM_FROM - 1,
                              RTO__SORT_MATCH_TEAM_FROM, RTO__SORT_MATCH_TEAM_FROM + 3};
    static const uint32_t threads[] = {1, 3, 0};
    size_t checked = 0;
    for (size_t di = 0; di < sizeof mdists / sizeof mdists[0]; di++)
        for (int fi = 0; fi < 2; fi++) {
            const rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
            const rto_dist_info *info = rto_dist_find(mdists[di]);
            assert_non_null(info);
            for (size_t zi = 0; zi < sizeof sizes_m / sizeof sizes_m[0]; zi++) {
                const size_t n = sizes_m[zi], ksz = fi ? 8 : 4;
                if (!tu_dist_applies(info, f, n) || tu_sanitized_skip(mdists[di], n) ||
                    (TU_SANITIZED && n > RTO__SORT_MATCH_TEAM_FROM + 3))
                    continue;
                const uint32_t seed = (uint32_t)((di * 2 + (size_t)fi) * 32 + zi) + 9000;
                void *keys = tu_keys(mdists[di], f, seed, n);
                uint64_t *wide = tu_qsorted(f, keys, n);
                void *want = malloc(n ? n * ksz : 1), *out = malloc(n ? n * ksz : 1);
                assert_true(want && out);
                for (size_t i = 0; i < n; i++)
                    tu_put(f, want, i, wide[i]);
                for (size_t ti = 0; ti < sizeof threads / sizeof threads[0]; ti++) {
                    if (tu_sanitized_thread_skip(zi + di, ti, sizeof threads / sizeof threads[0]))
                        continue;
                    /* sorted: qsort's bytes */
                    memset(out, 0xA5, n * ksz);
                    assert_int_equal(rto__sort_match(f, keys, n, NULL, out, threads[ti]), 1);
                    if (memcmp(out, want, n * ksz))
                        fail_msg("sort %s %s n=%zu threads %u differs from qsort", mdists[di], fi ? "u64" : "u32", n,
                                 threads[ti]);
                    assert_int_equal(rto__sort_match(f, keys, n, want, NULL, threads[ti]), 1);
                    if (n == 0)
                        continue;
                    /* misleading dumps: the verdict is qsort's memcmp */
                    uint64_t rng = seed * 31u + (uint32_t)ti;
                    for (int m = 0; m < 8; m++) {
                        memcpy(out, want, n * ksz);
                        const size_t i = (size_t)(tu_rng_next(&rng) % n), j = (size_t)(tu_rng_next(&rng) % n);
                        const uint64_t bit = UINT64_C(1) << (tu_rng_next(&rng) % (ksz * 8));
                        switch (m) {
                        case 0: tu_put(f, out, 0, tu_get(f, out, 0) ^ bit); break;         /* first slot */
                        case 1: tu_put(f, out, n - 1, tu_get(f, out, n - 1) ^ bit); break; /* last slot */
                        case 2: tu_put(f, out, n - 1, tu_get(f, out, 0)); break;           /* span collapsed */
                        case 3: tu_put(f, out, 0, 0); tu_put(f, out, n - 1, ~UINT64_C(0)); break; /* span widened */
                        case 4: tu_put(f, out, i, tu_get(f, out, i) ^ bit); break;
                        case 5: { /* two slots exchanged */
                            const uint64_t a = tu_get(f, out, i);
                            tu_put(f, out, i, tu_get(f, out, j));
                            tu_put(f, out, j, a);
                            break;
                        }
                        case 6: tu_put(f, out, i, tu_get(f, out, j)); break; /* a duplicate */
                        default: /* reversed */
                            for (size_t s = 0; s < n / 2; s++) {
                                const uint64_t a = tu_get(f, out, s);
                                tu_put(f, out, s, tu_get(f, out, n - 1 - s));
                                tu_put(f, out, n - 1 - s, a);
                            }
                        }
                        const int truth = memcmp(out, want, n * ksz) == 0;
                        const int got = rto__sort_match(f, keys, n, out, NULL, threads[ti]);
                        if (got != truth)
                            fail_msg("match %s %s n=%zu threads %u misleading dump %d: %d, qsort says %d", mdists[di],
                                     fi ? "u64" : "u32", n, threads[ti], m, got, truth);
                        checked++;
                    }
                }
                free(keys);
                free(wide);
                free(want);
                free(out);
            }
        }
    assert_true(checked > 1000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sort_match_against_qsort),
        cmocka_unit_test(test_fast_path_agrees_with_full_analysis),
        cmocka_unit_test(test_fast_path_threads_agree),
        cmocka_unit_test(test_wrong_expected_keys_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
