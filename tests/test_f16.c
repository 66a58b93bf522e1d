/* binary16 conversions and the octahedral encoding (raster/f16.c, DESIGN.md §11.4) against independent references:
 on every binary16 value, its
 * neighbours and midpoints and 2^22 random binary32 bit patterns; rounding toward zero against the largest binary16
 * magnitude not above |x|, found by bisection over all finite binary16 values; the encoding against its definition
 * on the octants' corners and its inverse on random unit vectors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "raster/raster_internal.h"

static float bits_f(uint32_t x)
{
    float f;
    memcpy(&f, &x, sizeof f);
    return f;
}

/* Largest binary16 magnitude not above |f| (bisection over the ordered positive finite values 0 .. 0x7bff). */
static uint16_t ref_toward_zero(float f)
{
    const double a = fabs((double)f);
    const uint16_t sign = signbit(f) ? 0x8000u : 0;
    if (isinf(f))
        return (uint16_t)(sign | 0x7c00u);
    uint32_t lo = 0, hi = 0x7bff;
    while (lo < hi) {
        const uint32_t m = (lo + hi + 1) / 2;
        if ((double)rto_f16_to_f32((uint16_t)m) <= a)
            lo = m;
        else
            hi = m - 1;
    }
    return (uint16_t)(sign | lo);
}

/* The nearest binary16 to f: the magnitudes around |f| (ref_toward_zero and the next one up), ties to the even bit
 * pattern, infinity from 65520 (half an ulp past the largest finite value). */
static uint16_t ref_nearest(float f)
{
    const uint16_t lo = ref_toward_zero(f), sign = lo & 0x8000u, m = lo & 0x7fffu;
    if (m >= 0x7c00u)
        return lo;
    const double a = fabs((double)f), below = (double)rto_f16_to_f32(m);
    const double above = m == 0x7bffu ? 65536.0 : (double)rto_f16_to_f32((uint16_t)(m + 1));
    if (a == below)
        return lo;
    const double dl = a - below, du = above - a;
    const uint16_t up = (uint16_t)(sign | (m == 0x7bffu ? 0x7c00u : (unsigned)m + 1u));
    if (dl < du)
        return lo;
    if (du < dl)
        return up;
    return (m & 1u) ? up : lo;
}

static void check_one(float f)
{
    const uint16_t want = ref_nearest(f), got = rto_f16_from_f32(f);
    if (isnan(f)) {
        assert_true((got & 0x7c00u) == 0x7c00u && (got & 0x3ffu) != 0);
        return;
    }
    if (want != got)
        fail_msg("%a: got 0x%04x, the compiler's conversion 0x%04x", (double)f, got, want);
}

static void test_nearest_even(void **state)
{
    (void)state;
    for (uint32_t h = 0; h < 0x10000u; h++) {
        const float v = rto_f16_to_f32((uint16_t)h);
        /* the exact widening against the bit layout: (-1)^s 2^(e - 15) (1 + m / 1024), subnormals 2^-14 m / 1024 */
        const unsigned e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
        const double mag = e == 0 ? ldexp((double)m, -24) : ldexp(1.0 + m / 1024.0, (int)e - 15);
        if (e != 0x1fu)
            assert_true((double)v == ((h & 0x8000u) ? -mag : mag));
        uint32_t x;
        memcpy(&x, &v, sizeof x);
        /* the value itself, its binary32 neighbours, and the midpoint to the next binary16 value */
        for (int d = -2; d <= 2; d++)
            check_one(bits_f(x + (uint32_t)d));
        if ((h & 0x7c00u) != 0x7c00u) {
            const float next = rto_f16_to_f32((uint16_t)(h + 1));
            if (isfinite(next))
                check_one((float)(((double)v + (double)next) / 2.0));
        }
    }
    uint64_t s = 0x9e3779b97f4a7c15ull;
    for (int i = 0; i < (1 << 20); i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        check_one(bits_f((uint32_t)(s >> 32)));
    }
    assert_int_equal(rto_f16_from_f32(65520.0f), 0x7c00); /* the first value past the largest rounds to infinity */
    assert_int_equal(rto_f16_from_f32(65519.99f), 0x7bff);
    assert_int_equal(rto_f16_from_f32(0x1p-25f), 0x0000); /* a tie to even zero */
    assert_int_equal(rto_f16_from_f32(0x1.000002p-25f), 0x0001);
}

static void test_toward_zero(void **state)
{
    (void)state;
    uint64_t s = 12345;
    for (int i = 0; i < (1 << 18); i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        const float f = bits_f((uint32_t)(s >> 32));
        if (isnan(f))
            continue;
        const uint16_t want = ref_toward_zero(f), got = rto__f16_from_f32_rtz(f);
        if (want != got)
            fail_msg("%a: got 0x%04x toward zero, want 0x%04x", (double)f, got, want);
    }
    assert_int_equal(rto__f16_from_f32_rtz(1e9f), 0x7bff);
    assert_int_equal(rto__f16_from_f32_rtz(-0.33333334f), 0xb555); /* -0x1.554p-2: the truncation */
    assert_int_equal(rto_f16_from_f32(-0.33333334f), 0xb555);
    assert_int_equal(rto__f16_from_f32_rtz(0x1.557p-1f), 0x3955); /* 0x1.557p-1: 0x1.554p-1 toward zero ... */
    assert_int_equal(rto_f16_from_f32(0x1.557p-1f), 0x3956);      /* ... 0x1.558p-1 to nearest */
}

static void test_octahedral(void **state)
{
    (void)state;
    /* the definition on the axes and the lower hemisphere's corners */
    const float axes[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const float want[6][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {0, 0}, {1, 1}};
    for (int k = 0; k < 6; k++) {
        float e[2];
        rto__oct_encode(axes[k], e);
        assert_true(e[0] == want[k][0] && e[1] == want[k][1]);
    }
    /* n = (1, 1, -1)/sqrt 3: p = (1/3, 1/3), folded to (1 - 1/3, 1 - 1/3) */
    const float n[3] = {0.57735026f, 0.57735026f, -0.57735026f};
    float e[2];
    rto__oct_encode(n, e);
    assert_true(fabsf(e[0] - 2.0f / 3.0f) < 1e-6f && fabsf(e[1] - 2.0f / 3.0f) < 1e-6f);
    /* round trip on random unit vectors, both hemispheres */
    uint64_t s = 777;
    for (int i = 0; i < 100000; i++) {
        double v[3], l = 0;
        for (int a = 0; a < 3; a++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            v[a] = (double)(s >> 11) / 9007199254740992.0 * 2.0 - 1.0;
            l += v[a] * v[a];
        }
        if (l < 1e-6 || l > 1)
            continue;
        const float u[3] = {(float)(v[0] / sqrt(l)), (float)(v[1] / sqrt(l)), (float)(v[2] / sqrt(l))};
        float d[3];
        rto__oct_encode(u, e);
        assert_true(fabsf(e[0]) <= 1.0f && fabsf(e[1]) <= 1.0f);
        rto__oct_decode(e, d);
        for (int a = 0; a < 3; a++)
            assert_true(fabsf(d[a] - u[a]) < 1e-5f);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nearest_even),
        cmocka_unit_test(test_toward_zero),
        cmocka_unit_test(test_octahedral),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
