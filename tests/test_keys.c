/* PRNG, Morton keys and the named distributions (DESIGN.md §3), against independent formulations. */
#include "testutil.h"

#include <math.h>

/* The hash written a second way: 64-bit products masked to 32 bits, as a JS Math.imul port would compute. */
static uint32_t ref_hash(uint32_t x)
{
    uint64_t v = x;
    v ^= v >> 16;
    v = (v * 0x7feb352dULL) & 0xffffffffULL;
    v ^= v >> 15;
    v = (v * 0x846ca68bULL) & 0xffffffffULL;
    v ^= v >> 16;
    return (uint32_t)v;
}

static void test_prng_matches_reference(void **state)
{
    (void)state;
    assert_int_equal(rto_hash32(0), 0); /* every step of h maps 0 to 0 */
    for (uint32_t seed = 0; seed < 50; seed++)
        for (uint32_t i = 0; i < 2000; i += 7) {
            assert_int_equal(rto_hash32(i * 2654435761u), ref_hash(i * 2654435761u));
            assert_int_equal(rto_rng(seed, i), ref_hash(i ^ ref_hash(seed)));
            float u = rto_unit(seed, i);
            assert_true(u >= 0.0f && u < 1.0f);
            assert_true((double)u == (double)(ref_hash(i ^ ref_hash(seed)) >> 8) / 16777216.0);
        }
}

static void test_prng_is_not_degenerate(void **state)
{
    (void)state;
    /* Over 2^16 draws every bit should be set close to half the time. */
    unsigned ones[32] = {0};
    for (uint32_t i = 0; i < 65536; i++)
        for (int b = 0; b < 32; b++)
            ones[b] += (rto_rng(7, i) >> b) & 1u;
    for (int b = 0; b < 32; b++)
        assert_true(ones[b] > 31000 && ones[b] < 34500);
}

/* Bit-by-bit interleave: bit b of x goes to bit 3b + 2, y to 3b + 1, z to 3b. */
static uint32_t ref_morton(uint32_t x, uint32_t y, uint32_t z, int bits)
{
    uint32_t m = 0;
    for (int b = 0; b < bits; b++) {
        m |= ((x >> b) & 1u) << (3 * b + 2);
        m |= ((y >> b) & 1u) << (3 * b + 1);
        m |= ((z >> b) & 1u) << (3 * b);
    }
    return m;
}

static void test_morton_interleave(void **state)
{
    (void)state;
    for (uint32_t x = 0; x < 32; x++)
        for (uint32_t y = 0; y < 32; y++)
            for (uint32_t z = 0; z < 32; z++)
                assert_int_equal(rto_morton15(x, y, z), ref_morton(x, y, z, 5));
    for (uint32_t i = 0; i < 100000; i++) {
        uint32_t r = rto_rng(3, i);
        uint32_t x = r & 1023, y = (r >> 10) & 1023, z = (r >> 20) & 1023;
        assert_int_equal(rto_morton30(x, y, z), ref_morton(x, y, z, 10));
    }
    assert_int_equal(rto_morton15(31, 0, 0), 0x4924u); /* x owns the top bit of each triple */
}

/* The quantisation computed in long double: equal to the binary32 result except within rounding of a cell edge. */
static void check_quantised(float c, float lo, float hi, uint32_t cells, uint32_t q)
{
    if (hi == lo) {
        assert_int_equal(q, 0);
        return;
    }
    long double t = ((long double)c - lo) / ((long double)hi - lo) * cells;
    long double ft = floorl(t);
    uint32_t ref = ft >= cells - 1 ? cells - 1 : (uint32_t)ft;
    if (q != ref)
        assert_true(fabsl(t - roundl(t)) < 1e-4L * cells);
}

static void test_tlas_blas_keys(void **state)
{
    (void)state;
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        const size_t n = 4097;
        rto_vec3 *c = malloc(n * sizeof *c);
        uint32_t *k32 = malloc(n * sizeof *k32);
        uint64_t *k64 = malloc(n * sizeof *k64);
        assert_int_equal(rto_centroids_generate(di->name, 5, n, c, NULL), RTO_OK);
        assert_int_equal(rto_tlas_keys(c, n, k32, NULL), RTO_OK);
        assert_int_equal(rto_blas_keys(c, n, k64, NULL), RTO_OK);
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = 0; i < n; i++) {
            const float v[3] = {c[i].x, c[i].y, c[i].z};
            for (int a = 0; a < 3; a++) {
                lo[a] = fminf(lo[a], v[a]);
                hi[a] = fmaxf(hi[a], v[a]);
            }
        }
        for (size_t i = 0; i < n; i++) {
            const float v[3] = {c[i].x, c[i].y, c[i].z};
            assert_int_equal(k32[i] & 0xffffu, i);
            assert_int_equal(k32[i] >> 31, 0); /* never the sentinel */
            assert_int_equal(k64[i] & 0xffffffffu, i);
            uint32_t m15 = k32[i] >> 16, m30 = (uint32_t)(k64[i] >> 32);
            for (int a = 0; a < 3; a++) {
                uint32_t q5 = 0, q10 = 0;
                for (int b = 0; b < 10; b++) {
                    if (b < 5)
                        q5 |= ((m15 >> (3 * b + 2 - a)) & 1u) << b;
                    q10 |= ((m30 >> (3 * b + 2 - a)) & 1u) << b;
                }
                check_quantised(v[a], lo[a], hi[a], 32, q5);
                check_quantised(v[a], lo[a], hi[a], 1024, q10);
            }
        }
        free(c);
        free(k32);
        free(k64);
    }
}

/* rto_keys_generate makes BLAS keys of a centroid distribution chunk by chunk (2^16 centroids at a time, never
 * all of them): the bytes of rto_blas_keys over all the centroids (checked above against the quantisation), at sizes
 * below, at and across chunk boundaries, the last chunk partial. */
static void test_generated_blas_keys_whole(void **state)
{
    (void)state;
    const size_t sizes[] = {0, 1, 65535, 65536, 65537, 3 * 65536 + 5};
    const size_t most = 3 * 65536 + 5;
    rto_vec3 *c = malloc(most * sizeof *c);
    uint64_t *want = malloc(most * sizeof *want), *got = malloc(most * sizeof *got);
    assert_true(c && want && got);
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
            const size_t n = sizes[k];
            assert_int_equal(rto_centroids_generate(di->name, 9, n, c, NULL), RTO_OK);
            assert_int_equal(rto_blas_keys(c, n, want, NULL), RTO_OK);
            assert_int_equal(rto_keys_generate(di->name, RTO_KEY_U64, 9, n, got, NULL), RTO_OK);
            for (size_t i = 0; i < n; i++)
                if (got[i] != want[i])
                    fail_msg("%s n = %zu: key %zu is 0x%016llx, rto_blas_keys gives 0x%016llx", di->name, n, i,
                             (unsigned long long)got[i], (unsigned long long)want[i]);
        }
    }
    free(c);
    free(want);
    free(got);
}

static void test_keys_refuse_bad_input(void **state)
{
    (void)state;
    rto_vec3 c[2] = {{0, 0, 0}, {NAN, 0, 0}};
    uint32_t k[2];
    rto_msg msg = {{0}};
    assert_int_equal(rto_tlas_keys(c, 2, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "non-finite"));
    c[1].x = -3e38f;
    c[0].x = 3e38f;
    assert_int_equal(rto_tlas_keys(c, 2, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "span"));
    assert_int_equal(rto_tlas_keys(c, RTO_TLAS_MAX_INSTANCES + 1, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_keys_generate("uniform", RTO_KEY_U32, 1, 65537, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_keys_generate("nope", RTO_KEY_U32, 1, 1, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_keys_generate("digit-5-one-bucket", RTO_KEY_U32, 1, 1, k, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_keys_generate("random", RTO_KEY_U32, 1, (size_t)RTO_MAX_KEYS + 1, k, &msg),
                     RTO_ERR_INVALID_ARGUMENT);
}

/* Each distribution has the property its name promises. */
static void test_distribution_properties(void **state)
{
    (void)state;
    const size_t n = 4096;
    for (int fi = 0; fi < 2; fi++) {
        rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
        const int bits = fi ? 64 : 32;
        const uint64_t sentinel = fi ? UINT64_MAX : UINT32_MAX;
        for (size_t d = 0; d < rto_dist_count(); d++) {
            const rto_dist_info *di = rto_dist_at(d);
            if (!tu_dist_applies(di, f, n))
                continue;
            void *k = tu_keys(di->name, f, 11, n);
            uint64_t *s = tu_qsorted(f, k, n);
            size_t unique = 1, sentinels = 0, popcount = 0;
            for (size_t i = 1; i < n; i++)
                unique += s[i] != s[i - 1];
            for (size_t i = 0; i < n; i++) {
                sentinels += s[i] == sentinel;
                popcount += (size_t)__builtin_popcountll(s[i]);
            }
            const char *nm = di->name;
            if (!strcmp(nm, "one-bucket") || !strcmp(nm, "clustered") || !strcmp(nm, "clustered-far")) {
                /* Morton part of the keys: one code for one-bucket, several for the clustered ones */
                size_t codes = 1;
                for (size_t i = 1; i < n; i++)
                    codes += (s[i] >> (fi ? 32 : 16)) != (s[i - 1] >> (fi ? 32 : 16));
                if (!strcmp(nm, "one-bucket"))
                    assert_int_equal(codes, 1);
                else
                    assert_true(codes >= 2);
                /* the lone object is alone in its Morton cell */
                uint64_t last = tu_get(f, k, n - 1) >> (fi ? 32 : 16);
                size_t same = 0;
                for (size_t i = 0; i < n; i++)
                    same += (tu_get(f, k, i) >> (fi ? 32 : 16)) == last;
                if (strcmp(nm, "one-bucket"))
                    assert_int_equal(same, 1);
            } else if (!strcmp(nm, "sorted") || !strcmp(nm, "reversed")) {
                for (size_t i = 1; i < n; i++) {
                    if (nm[0] == 's')
                        assert_true(tu_get(f, k, i - 1) <= tu_get(f, k, i));
                    else
                        assert_true(tu_get(f, k, i - 1) >= tu_get(f, k, i));
                }
                assert_true(unique > n - 10);
            } else if (!strcmp(nm, "all-equal")) {
                assert_int_equal(unique, 1);
            } else if (!strcmp(nm, "few-unique")) {
                assert_true(unique >= 2 && unique <= 8);
            } else if (!strcmp(nm, "sentinel-heavy")) {
                assert_true(sentinels > n / 2 && sentinels < n);
            } else if (!strncmp(nm, "entropy-", 8)) {
                int k_and = atoi(nm + 8);
                double expect = (double)n * bits / (double)(1u << k_and), got = (double)popcount;
                assert_true(got > expect * 0.85 - 20 && got < expect * 1.15 + 20);
            } else if (!strncmp(nm, "digit-", 6)) {
                int byte = nm[6] - '0';
                uint64_t first = (s[0] >> (8 * byte)) & 0xff;
                size_t other_bytes_vary = 0;
                for (size_t i = 0; i < n; i++) {
                    assert_int_equal((s[i] >> (8 * byte)) & 0xff, first);
                    other_bytes_vary += ((s[i] >> (8 * ((byte + 1) % (bits / 8)))) & 0xff) != 0;
                }
                assert_true(other_bytes_vary > n / 2);
            } else if (!strcmp(nm, "tile-overflow")) {
                for (size_t i = 0; i < n; i++)
                    assert_true(tu_get(f, k, i) == tu_get(f, k, i - i % 512));
                assert_true(unique == n / 512);
            } else if (!strcmp(nm, "random") || !strcmp(nm, "entropy-1") || !strcmp(nm, "uniform")) {
                assert_true(unique > n - 10);
            }
            free(s);
            free(k);
        }
    }
}

static void test_keys_are_deterministic(void **state)
{
    (void)state;
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        void *a = tu_keys(di->name, RTO_KEY_U64, 99, 1000), *b = tu_keys(di->name, RTO_KEY_U64, 99, 1000);
        void *c = tu_keys(di->name, RTO_KEY_U64, 100, 1000);
        assert_memory_equal(a, b, 8000);
        if (strcmp(di->name, "one-bucket") != 0) /* the only seed-free distribution */
            assert_memory_not_equal(a, c, 8000);
        free(a);
        free(b);
        free(c);
    }
}

static void test_size_classes(void **state)
{
    (void)state;
    size_t sizes[RTO_SIZE_CLASS_MAX], n = 0;
    assert_int_equal(rto_size_class("all", sizes, &n, NULL), RTO_OK);
    const size_t must[] = {0, 1, 2, 3, 255, 256, 257, 4095, 4096, 4097, 16384, 65535, 65536};
    for (size_t m = 0; m < sizeof must / sizeof must[0]; m++) {
        int found = 0;
        for (size_t i = 0; i < n; i++)
            found |= sizes[i] == must[m];
        assert_true(found);
    }
    for (size_t i = 1; i < n; i++)
        assert_true(sizes[i - 1] < sizes[i]);
    assert_int_equal(sizes[n - 1], 65536);
    rto_msg msg = {{0}};
    assert_int_equal(rto_size_class("huge", sizes, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
}

/* The box rules of core/aabb.c against their definitions written here over every combination of special values per
 * bound (-inf, -1, -0, +0, 1, +inf, NaN on each of the six): empty = some min > max (a NaN bound is neither empty nor
 * finite), finite = six finite bounds with min <= max, equal = six == comparisons (+0 == -0, NaN never equal), and
 * rto_aabb_transform's documented rule (an empty or NaN box stays the empty box; otherwise an identity transform
 * gives the box back). */
static void test_box_rules(void **state)
{
    (void)state;
    const float v[7] = {-INFINITY, -1.0f, -0.0f, 0.0f, 1.0f, INFINITY, NAN};
    const rto_aabb e = rto_aabb_empty();
    assert_true(e.min.x == INFINITY && e.min.y == INFINITY && e.min.z == INFINITY);
    assert_true(e.max.x == -INFINITY && e.max.y == -INFINITY && e.max.z == -INFINITY);
    const rto_mat34 id = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    size_t empties = 0, finites = 0, nans = 0;
    for (unsigned code = 0; code < 7u * 7 * 7 * 7 * 7 * 7; code++) {
        float b[6];
        unsigned c = code;
        int nan = 0;
        for (int k = 0; k < 6; k++, c /= 7) {
            b[k] = v[c % 7];
            nan |= isnan(b[k]);
        }
        const rto_aabb box = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
        int want_empty = 0, want_finite = 1;
        for (int a = 0; a < 3; a++) {
            want_empty |= b[a] > b[3 + a];
            want_finite &= isfinite(b[a]) && isfinite(b[3 + a]) && b[a] <= b[3 + a];
        }
        assert_int_equal(rto_aabb_is_empty(&box), want_empty);
        assert_int_equal(rto_aabb_is_finite(&box), want_finite);
        assert_int_equal(rto_aabb_equal(&box, &box), !nan);
        assert_int_equal(rto_aabb_equal(&box, &e), b[0] == INFINITY && b[1] == INFINITY && b[2] == INFINITY &&
                                                        b[3] == -INFINITY && b[4] == -INFINITY && b[5] == -INFINITY);
        const rto_aabb w = rto_aabb_transform(&id, &box);
        if (want_empty || nan)
            assert_true(rto_aabb_equal(&w, &e));
        else if (want_finite)
            assert_true(rto_aabb_equal(&w, &box));
        empties += (size_t)want_empty;
        finites += (size_t)want_finite;
        nans += (size_t)nan;
    }
    assert_true(empties > 0 && finites > 0 && nans > 0);
    /* +0 and -0 bounds are the same box; one bound moved is another */
    const rto_aabb p = {{0.0f, 0.0f, 0.0f}, {1, 1, 1}}, q = {{-0.0f, 0.0f, -0.0f}, {1, 1, 1}},
                   r = {{0.0f, 0.0f, 0.0f}, {1, 1, nextafterf(1, 2)}};
    assert_true(rto_aabb_equal(&p, &q));
    assert_false(rto_aabb_equal(&p, &r));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_prng_matches_reference),  cmocka_unit_test(test_prng_is_not_degenerate),
        cmocka_unit_test(test_morton_interleave),       cmocka_unit_test(test_tlas_blas_keys),
        cmocka_unit_test(test_keys_refuse_bad_input),   cmocka_unit_test(test_distribution_properties),
        cmocka_unit_test(test_keys_are_deterministic),  cmocka_unit_test(test_size_classes),
        cmocka_unit_test(test_generated_blas_keys_whole), cmocka_unit_test(test_box_rules),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
