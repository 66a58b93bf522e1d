/* Mutation tests for the sort validator: a correct output (built here from qsort, not by the oracle) passes; each
 * injected fault is caught, classified as the right fault class, and located at the slot (and pass) where it was
 * injected. Every case runs for u32 and u64 keys and for dumps of n and of n_padded slots. */
#include "testutil.h"

typedef struct fixture {
    rto_key_format f;
    size_t n, np, gn, ksz;
    void *input;
    uint64_t *expect;  /* qsort of the input */
    void *gpu;         /* gn slots: expect, then sentinels */
    uint32_t *values;  /* stable source indices */
    uint64_t sentinel;
} fixture;

static void fixture_make(fixture *fx, const char *dist, rto_key_format f, size_t n, int padded, uint32_t seed)
{
    memset(fx, 0, sizeof *fx);
    fx->f = f;
    fx->n = n;
    fx->np = rto_next_pow2(n);
    fx->gn = padded ? fx->np : n;
    fx->ksz = f == RTO_KEY_U32 ? 4 : 8;
    fx->sentinel = f == RTO_KEY_U32 ? UINT32_MAX : UINT64_MAX;
    fx->input = tu_keys(dist, f, seed, n);
    fx->expect = tu_qsorted(f, fx->input, n);
    fx->gpu = malloc((fx->gn + 1) * fx->ksz);
    fx->values = malloc((fx->gn + 1) * 4);
    tu_stable_dump(f, fx->input, n, fx->gn, fx->sentinel, fx->gpu, fx->values);
}

static void fixture_free(fixture *fx)
{
    free(fx->input);
    free(fx->expect);
    free(fx->gpu);
    free(fx->values);
}

/* A location field of the report, or SIZE_MAX / -1 when absent. */
static size_t where_slot(const rto_report *r)
{
    int64_t v;
    return rto_report_where(r, "slot", &v) ? (size_t)v : SIZE_MAX;
}

static int64_t where_of(const rto_report *r, const char *name)
{
    int64_t v;
    return rto_report_where(r, name, &v) ? v : -1;
}

static rto_status run_check(const fixture *fx, int with_values, int stable, rto_report *r)
{
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.format = fx->f;
    d.input = fx->input;
    d.n = fx->n;
    d.gpu_keys = fx->gpu;
    d.gpu_n = fx->gn;
    d.gpu_values = with_values ? fx->values : NULL;
    d.require_stable = stable;
    rto_msg msg = {{0}};
    rto_status s = rto_sort_check(&d, r, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH)
        fail_msg("rto_sort_check: %s", msg.text);
    return s;
}

static void expect_fault(const fixture *fx, int with_values, int stable, rto_fault fault, size_t slot, const char *what)
{
    rto_report r;
    rto_status s = run_check(fx, with_values, stable, &r);
    if (s != RTO_ERR_MISMATCH || r.code != (int)fault || strcmp(r.fault, rto_fault_name(fault)) ||
        where_slot(&r) != slot)
        fail_msg("%s (n=%zu gn=%zu %s): got status %d fault %s slot %zu, want %s at slot %zu: %s", what, fx->n, fx->gn,
                 fx->f == RTO_KEY_U32 ? "u32" : "u64", (int)s, r.fault, where_slot(&r), rto_fault_name(fault), slot,
                 r.summary);
    /* the one-line summary starts with the fault's name and names the slot */
    char slot_text[32];
    snprintf(slot_text, sizeof slot_text, "%zu", slot);
    assert_int_equal(strncmp(r.summary, rto_fault_name(fault), strlen(rto_fault_name(fault))), 0);
    assert_non_null(strstr(r.summary, slot_text));
    assert_true(r.nrows > 0);
}

/* First slot at or after n / 2 whose key differs from the next one; SIZE_MAX if none. */
static size_t distinct_slot(const fixture *fx)
{
    for (size_t i = fx->n / 2; i + 1 < fx->n; i++)
        if (fx->expect[i] != fx->expect[i + 1])
            return i;
    return SIZE_MAX;
}

static const char *const dists[] = {"random", "few-unique", "clustered", "sentinel-heavy", "one-bucket", "tile-overflow"};
static const size_t sizes[] = {2, 3, 5, 17, 256, 1000, 4097};

#define FOR_CASES                                                                                                      \
    for (size_t di = 0; di < sizeof dists / sizeof dists[0]; di++)                                                     \
        for (size_t zi = 0; zi < sizeof sizes / sizeof sizes[0]; zi++)                                                 \
            for (int fi = 0; fi < 2; fi++)                                                                             \
                for (int padded = 0; padded < 2; padded++)

static void test_correct_output_passes(void **state)
{
    (void)state;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)(di * 7 + zi));
        rto_report r;
        assert_int_equal(run_check(&fx, 1, 1, &r), RTO_OK);
        assert_int_equal(r.code, RTO_FAULT_NONE);
        assert_string_equal(r.fault, "none");
        for (uint32_t c = 0; c < r.nchecks; c++)
            assert_int_not_equal(r.checks[c].state, RTO_CHECK_FAILED);
        assert_int_equal(rto_report_check_state(&r, "stable"), RTO_CHECK_PASSED);
        fixture_free(&fx);
    }
}

static void test_swap_adjacent_is_order(void **state)
{
    (void)state;
    size_t hits = 0;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)zi);
        size_t i = distinct_slot(&fx);
        if (i != SIZE_MAX) {
            uint64_t a = tu_get(fx.f, fx.gpu, i);
            tu_put(fx.f, fx.gpu, i, tu_get(fx.f, fx.gpu, i + 1));
            tu_put(fx.f, fx.gpu, i + 1, a);
            expect_fault(&fx, 0, 0, RTO_FAULT_ORDER, i, "swap adjacent");
            hits++;
        }
        fixture_free(&fx);
    }
    assert_true(hits > 100);
}

static void test_duplicate_over_neighbour(void **state)
{
    (void)state;
    size_t hits = 0;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)zi);
        size_t i = distinct_slot(&fx);
        if (i != SIZE_MAX) {
            tu_put(fx.f, fx.gpu, i + 1, tu_get(fx.f, fx.gpu, i));
            expect_fault(&fx, 0, 0, RTO_FAULT_DUPLICATE, i + 1, "duplicate over neighbour");
            hits++;
        }
        fixture_free(&fx);
    }
    assert_true(hits > 100);
}

static void test_drop_and_append_sentinel(void **state)
{
    (void)state;
    size_t hits = 0;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)zi);
        size_t i = distinct_slot(&fx);
        if (i != SIZE_MAX) {
            unsigned char *g = fx.gpu;
            memmove(g + i * fx.ksz, g + (i + 1) * fx.ksz, (fx.gn - i - 1) * fx.ksz);
            tu_put(fx.f, fx.gpu, fx.gn - 1, fx.sentinel);
            expect_fault(&fx, 0, 0, RTO_FAULT_LOST, i, "drop and append sentinel");
            hits++;
        }
        fixture_free(&fx);
    }
    assert_true(hits > 100);
}

static int in_input(const fixture *fx, uint64_t v)
{
    for (size_t i = 0; i < fx->n; i++)
        if (fx->expect[i] == v)
            return 1;
    return 0;
}

static void test_flip_one_bit(void **state)
{
    (void)state;
    size_t hits = 0;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)zi);
        size_t i = fx.n / 2;
        for (int bit = 0; bit < (fi ? 64 : 32); bit++) {
            uint64_t v = tu_get(fx.f, fx.gpu, i) ^ ((uint64_t)1 << bit);
            if (v == fx.sentinel || in_input(&fx, v))
                continue;
            tu_put(fx.f, fx.gpu, i, v);
            expect_fault(&fx, 0, 0, RTO_FAULT_CORRUPT, i, "flip one bit");
            hits++;
            break;
        }
        fixture_free(&fx);
    }
    assert_true(hits > 150);
}

static void test_reorder_equal_keys(void **state)
{
    (void)state;
    size_t hits = 0;
    FOR_CASES
    {
        fixture fx;
        fixture_make(&fx, dists[di], fi ? RTO_KEY_U64 : RTO_KEY_U32, sizes[zi], padded, (uint32_t)zi);
        for (size_t i = fx.n / 2; i + 1 < fx.n; i++) {
            if (fx.expect[i] != fx.expect[i + 1])
                continue;
            uint32_t t = fx.values[i];
            fx.values[i] = fx.values[i + 1];
            fx.values[i + 1] = t;
            expect_fault(&fx, 1, 1, RTO_FAULT_STABILITY, i, "reorder equal keys");
            /* without a stability promise (bitonic is not stable) the same output is valid */
            rto_report r;
            assert_int_equal(run_check(&fx, 1, 0, &r), RTO_OK);
            hits++;
            break;
        }
        fixture_free(&fx);
    }
    assert_true(hits > 50);
}

static void test_value_faults(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, "random", RTO_KEY_U32, 1000, 0, 4);
    fx.values[10] = fx.values[11]; /* slot 10 now names the source of slot 11's (different) key */
    expect_fault(&fx, 1, 0, RTO_FAULT_VALUE, 10, "value naming another key");
    fixture_free(&fx);
    fixture_make(&fx, "all-equal", RTO_KEY_U32, 1000, 0, 4);
    fx.values[10] = fx.values[11]; /* equal keys: the first bad slot is the second use of the index */
    expect_fault(&fx, 1, 0, RTO_FAULT_VALUE, 11, "duplicate value");
    fixture_free(&fx);
    fixture_make(&fx, "random", RTO_KEY_U64, 1000, 1, 4);
    fx.values[7] = 5000; /* out of range */
    expect_fault(&fx, 1, 0, RTO_FAULT_VALUE, 7, "value out of range");
    fixture_free(&fx);
}

static void test_size_and_tail(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, "random", RTO_KEY_U32, 1000, 1, 9);
    tu_put(fx.f, fx.gpu, 1000, 5); /* a padded slot that is not the sentinel */
    expect_fault(&fx, 0, 0, RTO_FAULT_TAIL, 1000, "tail");
    fx.gn = 1001;
    rto_report r;
    assert_int_equal(run_check(&fx, 0, 0, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_FAULT_SIZE);
    assert_non_null(strstr(r.summary, "1001"));
    fixture_free(&fx);
}

/* The oracle's own key/value output passes, for every distribution and both dump sizes (n slots as a bundle holds
 * them, n_padded as a GPU buffer does), bitonic and radix. Regression: an n-slot dump of sentinel-heavy keys carries
 * padding indices >= n where a padding sentinel overtook a real sentinel-valued key (docs/sort.md), and such values
 * were refused as out of range. */

/* The oracle's own sorted keys and carried values (gpu_n slots) pass rto_sort_check; names the case otherwise. */
static void expect_own_output_passes(const char *algo, const char *dist, rto_key_format f, const void *keys, size_t n,
                                     const void *sorted, size_t gpu_n, const uint32_t *perm, int stable)
{
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.format = f;
    d.input = keys;
    d.n = n;
    d.gpu_keys = sorted;
    d.gpu_n = gpu_n;
    d.gpu_values = perm;
    d.require_stable = stable;
    rto_report r;
    rto_msg msg = {{0}};
    if (rto_sort_check(&d, &r, &msg) != RTO_OK)
        fail_msg("%s %s %s n=%zu (%zu slots): %s%s", algo, dist, f == RTO_KEY_U64 ? "u64" : "u32", n, gpu_n,
                 r.summary, msg.text);
}

static void test_oracle_output_passes(void **state)
{
    (void)state;
    const size_t ns[] = {2, 3, 5, 17, 256, 1000, 4097};
    size_t padding_values_in_range = 0;
    for (size_t di = 0; di < rto_dist_count(); di++) {
        const rto_dist_info *dist = rto_dist_at(di);
        for (int fi = 0; fi < 2; fi++)
            for (size_t z = 0; z < sizeof ns / sizeof ns[0]; z++) {
                const rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                const size_t n = ns[z], np = rto_next_pow2(n), ksz = fi ? 8 : 4;
                if (!tu_dist_applies(dist, f, n))
                    continue;
                void *keys = tu_keys(dist->name, f, (uint32_t)(di + z), n), *sorted = malloc(np * ksz);
                uint32_t *perm = malloc(np * 4);
                assert_int_equal(rto_bitonic_sort(f, keys, n, sorted, perm, NULL, NULL), RTO_OK);
                for (size_t i = 0; i < n; i++)
                    padding_values_in_range += perm[i] >= n;
                for (int padded = 0; padded < 2; padded++)
                    expect_own_output_passes("bitonic", dist->name, f, keys, n, sorted, padded ? np : n, perm, 0);
                /* radix: n slots, stable */
                assert_int_equal(rto_radix_sort(f, keys, n, 8, 256, sorted, perm, NULL, NULL), RTO_OK);
                expect_own_output_passes("radix", dist->name, f, keys, n, sorted, n, perm, 1);
                free(keys);
                free(sorted);
                free(perm);
            }
    }
    /* the defect's case was exercised: padding indices in the real range of an n-slot dump */
    assert_true(padding_values_in_range > 0);
}

/* A value naming padding element p is valid only up to n_padded - 1 and only where the key is the sentinel. */
static void test_padding_values_bounds(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, "sentinel-heavy", RTO_KEY_U32, 1000, 0, 4); /* n = 1000, n_padded = 1024 */
    size_t last = fx.n - 1; /* the last slot holds a sentinel key (3 in 4 keys are) */
    assert_int_equal(tu_get(fx.f, fx.gpu, last), fx.sentinel);
    fx.values[last] = 1023; /* padding element 23: in range, a sentinel */
    rto_report r;
    assert_int_equal(run_check(&fx, 1, 0, &r), RTO_OK);
    fx.values[last] = 1024; /* one past n_padded */
    expect_fault(&fx, 1, 0, RTO_FAULT_VALUE, last, "padding value out of range");
    fx.values[last] = 1023;
    size_t real = 0; /* a slot holding a real key may not name padding */
    while (tu_get(fx.f, fx.gpu, real) == fx.sentinel)
        real++;
    uint32_t keep = fx.values[real];
    fx.values[real] = 1000;
    expect_fault(&fx, 1, 0, RTO_FAULT_VALUE, real, "padding value on a real key");
    fx.values[real] = keep;
    fixture_free(&fx);
}

/* A GPU whose checkpoint pass p is wrong at slot s (final output still right) is named at pass p, slot s. */
static void test_corrupt_checkpoint_pass(void **state)
{
    (void)state;
    const size_t ns[] = {2, 5, 100, 1024, 4097};
    for (size_t z = 0; z < 5; z++)
        for (int fi = 0; fi < 2; fi++)
            for (int algo = 0; algo < 2; algo++) {
                rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                size_t n = ns[z], np = rto_next_pow2(n), ksz = fi ? 8 : 4;
                void *keys = tu_keys("random", f, (uint32_t)z, n);
                uint32_t P = algo ? rto_radix_pass_count(f, 4) : rto_bitonic_pass_count(np);
                size_t len = algo ? n : np;
                unsigned char *ck = malloc(P * len * ksz);
                void *out = malloc(np * ksz);
                uint32_t *perm = malloc(np * 4);
                if (algo) {
                    rto_radix_trace tr = {NULL, NULL, NULL, ck, NULL};
                    assert_int_equal(rto_radix_sort(f, keys, n, 4, 64, out, perm, &tr, NULL), RTO_OK);
                } else {
                    assert_int_equal(rto_bitonic_sort(f, keys, n, out, perm, ck, NULL), RTO_OK);
                }
                fixture fx;
                fixture_make(&fx, "random", f, n, 0, (uint32_t)z);
                rto_sort_check_desc d;
                memset(&d, 0, sizeof d);
                d.format = f;
                d.input = keys;
                d.n = n;
                d.gpu_keys = fx.gpu;
                d.gpu_n = n;
                d.gpu_passes = ck;
                d.gpu_pass_count = P;
                d.gpu_pass_len = len;
                d.algo = algo ? RTO_SORT_RADIX : RTO_SORT_BITONIC;
                d.radix_bits = 4;
                d.radix_tile = 64;
                rto_report r;
                assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_OK); /* control */
                uint32_t p = P / 2;
                size_t s = len / 2;
                tu_put(f, ck + p * len * ksz, s, tu_get(f, ck + p * len * ksz, s) ^ 0x10);
                assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_MISMATCH);
                assert_int_equal(r.code, RTO_FAULT_PASS);
                assert_int_equal(where_of(&r, "pass"), p);
                assert_int_equal(where_slot(&r), s);
                if (!algo) {
                    uint32_t k, j;
                    rto_bitonic_pass_kj(p, &k, &j);
                    assert_int_equal(where_of(&r, "k"), k);
                    assert_int_equal(where_of(&r, "j"), j);
                } else {
                    assert_int_equal(where_of(&r, "digit_bit"), p * 4);
                }
                assert_int_equal(strncmp(r.summary, "pass", 4), 0);
                /* with the final output out of order too, order is the primary fault and the summary's tail still
                 * names the pass, in the algorithm's own terms */
                size_t a = 0;
                while (a + 1 < n && tu_get(f, fx.gpu, a) == tu_get(f, fx.gpu, a + 1))
                    a++;
                if (a + 1 < n) {
                    const uint64_t ka = tu_get(f, fx.gpu, a);
                    tu_put(f, fx.gpu, a, tu_get(f, fx.gpu, a + 1));
                    tu_put(f, fx.gpu, a + 1, ka);
                    assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_MISMATCH);
                    assert_int_equal(r.code, RTO_FAULT_ORDER);
                    char tail[96];
                    if (algo) {
                        snprintf(tail, sizeof tail, "first diverge at radix pass %u (digit bits %u..%u) slot %zu",
                                 (unsigned)p, (unsigned)(4 * p), (unsigned)(4 * p + 3), s);
                    } else {
                        uint32_t k, j;
                        rto_bitonic_pass_kj(p, &k, &j);
                        snprintf(tail, sizeof tail, "first diverge at pass %u (k=%u, j=%u) slot %zu", (unsigned)p,
                                 (unsigned)k, (unsigned)j, s);
                    }
                    if (!strstr(r.summary, tail))
                        fail_msg("want \"%s\" in: %s", tail, r.summary);
                    tu_put(f, fx.gpu, a + 1, tu_get(f, fx.gpu, a));
                    tu_put(f, fx.gpu, a, ka);
                }
                /* a wrong number of passes is a size fault, not a crash */
                d.gpu_pass_count = P - 1;
                assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_MISMATCH);
                assert_int_equal(r.code, RTO_FAULT_SIZE);
                free(keys);
                free(ck);
                free(out);
                free(perm);
                fixture_free(&fx);
            }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_correct_output_passes),   cmocka_unit_test(test_swap_adjacent_is_order),
        cmocka_unit_test(test_duplicate_over_neighbour), cmocka_unit_test(test_drop_and_append_sentinel),
        cmocka_unit_test(test_flip_one_bit),            cmocka_unit_test(test_reorder_equal_keys),
        cmocka_unit_test(test_value_faults),            cmocka_unit_test(test_size_and_tail),
        cmocka_unit_test(test_corrupt_checkpoint_pass), cmocka_unit_test(test_oracle_output_passes),
        cmocka_unit_test(test_padding_values_bounds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
