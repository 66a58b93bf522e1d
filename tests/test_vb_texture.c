/* unlit's texture sampling (DESIGN.md §11.5, §11.6; src/raster/texture_sample.c): the mip chain against a box filter
 * computed here by hand, trilinear sampling against an implementation written here in long double, and the hull
 * check-vbuffer accepts: a simulated GPU with 8-bit bilinear and mip weights (and its lod and texel coordinates
 * quantized) passes everywhere, a wrong mip level and swapped u/v fail on a test texture whose levels differ. */
#include "testutil.h"

#include "raster/texture_sample.h"

static float f16(float x) { return rto_f16_to_f32(rto_f16_from_f32(x)); }

/* A 5x3 texture: levels 5x3, 2x1, 1x1; an odd side's last column is not read, a side of 1 repeats its texel. */
static void test_mip_chain_by_hand(void **state)
{
    (void)state;
    uint8_t px[5 * 3 * 4];
    for (int i = 0; i < 5 * 3 * 4; i++)
        px[i] = (uint8_t)((i * 37 + 11) % 256);
    rto_texture t = {"hand", 5, 3, px};
    rto__vb_mips m;
    assert_int_equal(rto__vb_mips_make(&t, &m, NULL), RTO_OK);
    assert_int_equal(m.levels, 3);
    assert_int_equal(m.width[1], 2);
    assert_int_equal(m.height[1], 1);
    assert_int_equal(m.width[2], 1);
    assert_int_equal(m.height[2], 1);
    assert_int_equal(m.texels, 15 + 2 + 1);
    long double l1[2][4];
    for (int ch = 0; ch < 4; ch++) {
        for (int i = 0; i < 2; i++) { /* rows 0 and 1 of columns 2i, 2i + 1; row 2 and column 4 unread */
            long double s = 0.0L;
            for (int y = 0; y < 2; y++)
                for (int x = 2 * i; x < 2 * i + 2; x++)
                    s += (long double)px[4 * (y * 5 + x) + ch] / 255.0L;
            l1[i][ch] = s / 4.0L;
        }
        const long double l2 = (l1[0][ch] + l1[1][ch] + l1[0][ch] + l1[1][ch]) / 4.0L; /* height 1: its row twice */
        for (int k = 0; k < 15; k++)
            assert_true(m.rgba[4 * k + ch] == f16((float)px[4 * k + ch] / 255.0f));
        for (int i = 0; i < 2; i++)
            assert_true(fabsl((long double)m.rgba[4 * (15 + i) + ch] - l1[i][ch]) <= 0x1p-11L);
        assert_true(fabsl((long double)m.rgba[4 * 17 + ch] - l2) <= 0x1p-11L);
    }
    rto__vb_mips_free(&m);
    /* exact literals: black and white average to one half at every level */
    uint8_t bw[4 * 4 * 4];
    for (int k = 0; k < 16; k++)
        for (int ch = 0; ch < 4; ch++)
            bw[4 * k + ch] = (uint8_t)(((k % 4) + (k / 4)) % 2 ? 255 : 0);
    rto_texture t2 = {"bw", 4, 4, bw};
    assert_int_equal(rto__vb_mips_make(&t2, &m, NULL), RTO_OK);
    assert_int_equal(m.levels, 3);
    for (size_t k = 16; k < m.texels; k++)
        assert_true(m.rgba[4 * k] == 0.5f);
    rto__vb_mips_free(&m);
    assert_int_equal(rto__vb_mip_levels(1, 1), 1);
    assert_int_equal(rto__vb_mip_levels(512, 512), 10);
    assert_int_equal(rto__vb_mip_levels(513, 2), 10);
    assert_int_equal(rto__vb_mip_levels(1, 1024), 11);
}

/* The test texture: R a checkerboard of 8-texel squares (levels 0 to 3 black and white, then grey), G vertical stripes
 * 4 texels wide (u only), B a ramp in v, A opaque. 64 x 32: u and v have different scales too. */
static rto_texture checker(uint8_t *px)
{
    const uint32_t w = 64, h = 32;
    for (uint32_t j = 0; j < h; j++)
        for (uint32_t i = 0; i < w; i++) {
            uint8_t *p = px + 4 * (j * w + i);
            p[0] = ((i >> 3) ^ (j >> 3)) & 1 ? 255 : 0;
            p[1] = (i >> 2) & 1 ? 255 : 0;
            p[2] = (uint8_t)(j * 8);
            p[3] = 255;
        }
    return (rto_texture){"checker", w, h, px};
}

static double tu_uniform(uint64_t *s, double a, double b) { return a + (b - a) * tu_rng_unit(s); }

static long double wrapl(long double i, uint32_t n)
{
    long double r = fmodl(i, (long double)n);
    return r < 0 ? r + n : r;
}

/* The sampling rule of §11.5 in long double, from the chain's stored values. */
static void ld_bilinear(const rto__vb_mips *m, uint32_t l, long double u, long double v, long double c[4])
{
    const uint32_t w = m->width[l], h = m->height[l];
    const long double x = u * w - 0.5L, y = v * h - 0.5L, fx = floorl(x), fy = floorl(y);
    const long double ax = x - fx, ay = y - fy;
    const uint32_t i[2] = {(uint32_t)wrapl(fx, w), (uint32_t)wrapl(fx + 1, w)};
    const uint32_t j[2] = {(uint32_t)wrapl(fy, h), (uint32_t)wrapl(fy + 1, h)};
    for (int ch = 0; ch < 4; ch++) {
        c[ch] = 0.0L;
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++)
                c[ch] += (a ? ax : 1 - ax) * (b ? ay : 1 - ay) *
                         (long double)m->rgba[4 * (m->offset[l] + (size_t)j[b] * w + i[a]) + ch];
    }
}

static void ld_trilinear(const rto__vb_mips *m, long double u, long double v, long double lod, long double c[4])
{
    lod = lod < 0 ? 0 : lod > m->levels - 1 ? m->levels - 1 : lod;
    const uint32_t l0 = (uint32_t)floorl(lod), l1 = l0 + 1 < m->levels ? l0 + 1 : l0;
    long double a[4], b[4];
    ld_bilinear(m, l0, u, v, a);
    ld_bilinear(m, l1, u, v, b);
    for (int ch = 0; ch < 4; ch++)
        c[ch] = a[ch] + (lod - l0) * (b[ch] - a[ch]);
}

static void test_trilinear_against_long_double(void **state)
{
    (void)state;
    uint8_t px[64 * 32 * 4];
    rto_texture t = checker(px);
    rto__vb_mips m;
    assert_int_equal(rto__vb_mips_make(&t, &m, NULL), RTO_OK);
    uint64_t rng = 0x9e3779b97f4a7c15ull * 4u;
    for (int it = 0; it < 20000; it++) {
        const float uv[2] = {(float)tu_uniform(&rng, -3.0, 3.0), (float)tu_uniform(&rng, -3.0, 3.0)};
        const float lod = (float)tu_uniform(&rng, -1.0, 7.0);
        float c[4];
        long double r[4];
        rto__vb_texture_sample(&m, uv, lod, c);
        ld_trilinear(&m, uv[0], uv[1], lod, r);
        for (int ch = 0; ch < 4; ch++)
            if (fabsl(c[ch] - r[ch]) > 1e-5L)
                fail_msg("seed 4 it %d: uv (%.9g, %.9g) lod %.9g ch %d: %.9g, long double %.12Lg", it, (double)uv[0],
                         (double)uv[1], (double)lod, ch, (double)c[ch], r[ch]);
        float lo[4], hi[4];
        rto__vb_texture_hull(&m, uv, lod, lo, hi);
        for (int ch = 0; ch < 4; ch++)
            assert_true(c[ch] >= lo[ch] && c[ch] <= hi[ch]); /* the oracle's own value is admissible */
    }
    /* the level of detail: the Euclidean length of the footprint in texels, the larger of x and y */
    const float dx[2] = {3.0f / 64, 4.0f / 32}, dy[2] = {1.0f / 64, 0.0f};
    assert_true(fabsf(rto__vb_texture_lod(&m, dx, dy) - log2f(5.0f)) < 1e-6f);
    const float tiny[2] = {0.1f / 64, 0.0f}, huge[2] = {1e6f, 0.0f}, zero[2] = {0.0f, 0.0f};
    assert_true(rto__vb_texture_lod(&m, tiny, zero) == 0.0f);
    assert_true(rto__vb_texture_lod(&m, huge, zero) == 6.0f);
    assert_true(rto__vb_texture_lod(&m, zero, zero) == 0.0f);
    rto__vb_mips_free(&m);
}

enum { GPU_OK, GPU_LEVEL_UP2, GPU_LEVEL0, GPU_SWAP_UV };

static float q8(float w) { return roundf(w * 256.0f) / 256.0f; }

/* A GPU's filtering: uv perturbed by an ulp, its own lod quantized to 8 fractional bits, texel coordinates to 8
 * sub-texel bits, bilinear and mip weights of 8 bits. */
static void gpu_sample(const rto__vb_mips *m, const float uv_in[2], float lod, int fault, uint64_t *rng, float c[4])
{
    float uv[2] = {uv_in[0], uv_in[1]};
    for (int a = 0; a < 2; a++)
        uv[a] = tu_uniform(rng, 0.0, 1.0) < 0.5 ? nextafterf(uv[a], INFINITY) : nextafterf(uv[a], -INFINITY);
    if (fault == GPU_SWAP_UV) {
        const float s = uv[0];
        uv[0] = uv[1];
        uv[1] = s;
    }
    lod = q8(lod);
    if (fault == GPU_LEVEL_UP2)
        lod += 2.0f;
    if (fault == GPU_LEVEL0)
        lod = 0.0f;
    const float top = (float)(m->levels - 1);
    lod = lod < 0 ? 0 : lod > top ? top : lod;
    const uint32_t l0 = (uint32_t)lod, l1 = l0 + 1 < m->levels ? l0 + 1 : l0;
    const float f = q8(lod - (float)l0);
    float b[2][4];
    for (int k = 0; k < 2; k++) {
        const uint32_t l = k ? l1 : l0, w = m->width[l], h = m->height[l];
        const float x = roundf((uv[0] * (float)w - 0.5f) * 256.0f) / 256.0f;
        const float y = roundf((uv[1] * (float)h - 0.5f) * 256.0f) / 256.0f;
        const float fx = floorf(x), fy = floorf(y), ax = q8(x - fx), ay = q8(y - fy);
        const uint32_t i0 = (uint32_t)wrapl(fx, w), i1 = (uint32_t)wrapl(fx + 1, w);
        const uint32_t j0 = (uint32_t)wrapl(fy, h), j1 = (uint32_t)wrapl(fy + 1, h);
        const float *t = m->rgba + 4 * m->offset[l];
        for (int ch = 0; ch < 4; ch++)
            b[k][ch] = (1 - ay) * ((1 - ax) * t[4 * (j0 * w + i0) + ch] + ax * t[4 * (j0 * w + i1) + ch]) +
                       ay * ((1 - ax) * t[4 * (j1 * w + i0) + ch] + ax * t[4 * (j1 * w + i1) + ch]);
    }
    for (int ch = 0; ch < 4; ch++)
        c[ch] = (1 - f) * b[0][ch] + f * b[1][ch];
}

/* check-vbuffer's acceptance of one channel: within the hull widened by 2 binary16 ulps + 2^-12 (a bound of at most
 * 2^-10 + 2^-12 here, the values being at most 1). */
static int accepted(float v, float lo, float hi) { return v >= lo - (0x1p-10f + 0x1p-12f) && v <= hi + 0x1p-10f + 0x1p-12f; }

static void test_hull_accepts_gpu_rejects_faults(void **state)
{
    (void)state;
    uint8_t px[64 * 32 * 4];
    rto_texture t = checker(px);
    rto__vb_mips m;
    assert_int_equal(rto__vb_mips_make(&t, &m, NULL), RTO_OK);
    uint64_t rng = 0x9e3779b97f4a7c15ull * 7u;
    int rejected[4] = {0, 0, 0, 0};
    const int n = 20000;
    for (int it = 0; it < n; it++) {
        const float uv[2] = {(float)tu_uniform(&rng, -2.0, 2.0), (float)tu_uniform(&rng, -2.0, 2.0)};
        /* footprints from magnification to a few texels of level 0 per pixel: lod 0 to 3 */
        const float s = (float)tu_uniform(&rng, 0.3, 8.0);
        const float dx[2] = {s / 64, 0.0f}, dy[2] = {0.0f, s / 32};
        const float lod = rto__vb_texture_lod(&m, dx, dy);
        float lo[4], hi[4];
        rto__vb_texture_hull(&m, uv, lod, lo, hi);
        for (int fault = GPU_OK; fault <= GPU_SWAP_UV; fault++) {
            float c[4];
            gpu_sample(&m, uv, lod, fault, &rng, c);
            int ok = 1;
            for (int ch = 0; ch < 4; ch++)
                ok &= accepted(f16(c[ch]), lo[ch], hi[ch]);
            if (!ok && fault == GPU_OK)
                fail_msg("seed 7 it %d: the 8-bit GPU at uv (%.9g, %.9g) lod %.9g is rejected", it, (double)uv[0],
                         (double)uv[1], (double)lod);
            rejected[fault] += !ok;
        }
    }
    print_message("of %d samples rejected: 8-bit GPU %d, two levels up %d, level 0 %d, u and v swapped %d\n", n,
                  rejected[GPU_OK], rejected[GPU_LEVEL_UP2], rejected[GPU_LEVEL0], rejected[GPU_SWAP_UV]);
    /* each fault shows on a good share of the samples */
    assert_true(rejected[GPU_LEVEL_UP2] > n / 20);
    assert_true(rejected[GPU_LEVEL0] > n / 20);
    assert_true(rejected[GPU_SWAP_UV] > n / 5);
    rto__vb_mips_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mip_chain_by_hand),
        cmocka_unit_test(test_trilinear_against_long_double),
        cmocka_unit_test(test_hull_accepts_gpu_rejects_faults),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
