/* Image comparison, part of unit.image (main() and the file helpers in test_image.c): the metrics of
 * rto_image_compare against values computed here in binary64 from the pixels; idiff's verdict rule on both sides of
 * each threshold; non-finite values; images of different sizes; diff images; bundle entries with their sha256. */
#include "test_image.h"

#include <jansson.h>
#include <stdbool.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Metrics, computed here in binary64 from the pixels in [0, 1] units. */

typedef struct reference {
    double mean, rms, max, peak; /* peak: OpenImageIO's PSNR peak, max(1, the largest value of either image) */
    uint32_t max_x, max_y, max_c;
    uint64_t fail, warn;
} reference;

static double unit_value(const rto_image *im, size_t i)
{
    return im->type == RTO_PIXEL_U8 ? ((const unsigned char *)im->pixels)[i] / 255.0
                                    : (double)((const float *)im->pixels)[i];
}

static reference reference_metrics(const rto_image *a, const rto_image *b, double fail, double warn)
{
    reference r = {0};
    r.peak = 1;
    double sum = 0, sq = 0;
    const size_t c = a->channels;
    for (uint32_t y = 0; y < a->height; y++)
        for (uint32_t x = 0; x < a->width; x++) {
            bool f = false, w = false;
            for (uint32_t k = 0; k < c; k++) {
                size_t i = ((size_t)y * a->width + x) * c + k;
                double d = fabs(unit_value(a, i) - unit_value(b, i));
                r.peak = fmax(r.peak, fmax(unit_value(a, i), unit_value(b, i)));
                sum += d;
                sq += d * d;
                if (d > r.max) {
                    r.max = d;
                    r.max_x = x;
                    r.max_y = y;
                    r.max_c = k;
                }
                f |= d > fail;
                w |= d > warn;
            }
            r.fail += f;
            r.warn += w;
        }
    const double n = (double)a->width * a->height * c;
    r.mean = sum / n;
    r.rms = sqrt(sq / n);
    return r;
}

/* OpenImageIO converts values to binary32 and subtracts in binary32: each |difference| (of values within [0, 1])
 * is off by at most 2^-24 from the binary64 one, and so are mean, RMS and max. */
#define F32_SUM_TOL 1e-7

static void assert_close(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%s: got %.17g, want %.17g (tolerance %g)", what, got, want, tol);
}

/* PSNR = 20 log10(peak / RMS), peak = 1 for images within [0, 1] (OpenImageIO's definition): an RMS error e moves it by 20 / ln 10 * e / RMS dB. */
static double psnr_tol(double rms) { return 20 / log(10.0) * F32_SUM_TOL / rms * 1.01 + 1e-12; }

/* One channel of one pixel off by k/255: max error k/255 there, mean k/255 / (W H C), RMS k/255 / sqrt(W H C),
 * PSNR 20 log10(1 / RMS); one pixel over fail and warn: FAIL with the defaults. */
void test_one_pixel_off(void **state)
{
    (void)state;
    const uint32_t w = 8, h = 5, c = 3, k = 7, px = 6, py = 3, pc = 1;
    rto_image a = make_u8(w, h, c), b = make_u8(w, h, c);
    unsigned char *q = b.pixels;
    size_t i = ((size_t)py * w + px) * c + pc;
    q[i] = (unsigned char)(q[i] >= k ? q[i] - k : q[i] + k);
    rto_image_compare_result r;
    rto_msg msg = {{0}};
    assert_int_equal(rto_image_compare(&a, &b, NULL, &r, &msg), RTO_OK);
    const double n = (double)w * h * c, d = k / 255.0;
    assert_close(r.max_error, d, F32_SUM_TOL, "max error");
    assert_int_equal(r.max_x, px);
    assert_int_equal(r.max_y, py);
    assert_int_equal(r.max_c, pc);
    assert_close(r.mean_error, d / n, F32_SUM_TOL, "mean error");
    assert_close(r.rms_error, d / sqrt(n), F32_SUM_TOL, "RMS error");
    assert_close(r.psnr, 20 * log10(sqrt(n) / d), psnr_tol(d / sqrt(n)), "PSNR");
    assert_close(r.psnr, 20 * log10(1 / r.rms_error), 1e-9, "PSNR from its own RMS");
    assert_int_equal(r.pixels, (uint64_t)w * h);
    assert_int_equal(r.fail_count, 1);
    assert_int_equal(r.warn_count, 1);
    assert_int_equal(r.verdict, RTO_IMAGE_FAIL);
    /* identical: zero errors, PSNR +inf, PASS */
    assert_int_equal(rto_image_compare(&a, &a, NULL, &r, &msg), RTO_OK);
    assert_true(r.mean_error == 0 && r.rms_error == 0 && r.max_error == 0);
    assert_true(isinf(r.psnr) && r.psnr > 0);
    assert_int_equal(r.verdict, RTO_IMAGE_PASS);
    rto_image_free(&a);
    rto_image_free(&b);
}

/* Many differences, 8-bit against float and float against float: every metric against the binary64 reference. */
void test_metrics_against_reference(void **state)
{
    (void)state;
    uint64_t seed = 0x1234;
    for (int round = 0; round < 6; round++) {
        const uint32_t w = 13 + (uint32_t)round, h = 9, c = 1 + (uint32_t)round % 4;
        rto_image a = round % 2 ? make_f32(w, h, c) : make_u8(w, h, c);
        rto_image b = make_f32(w, h, c);
        float *q = b.pixels;
        for (size_t i = 0; i < (size_t)w * h * c; i++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            double noise = ((double)(seed >> 40) / (double)(1 << 24) - 0.5) * 0.05;
            q[i] = (float)(unit_value(&a, i) + ((seed >> 20) % 3 == 0 ? noise : 0));
        }
        const double fail = 0.02, warn = 0.004;
        rto_image_compare_desc d = {0};
        d.fail = fail;
        d.warn = warn;
        rto_image_compare_result r;
        rto_msg msg = {{0}};
        assert_int_equal(rto_image_compare(&a, &b, &d, &r, &msg), RTO_OK);
        reference ref = reference_metrics(&a, &b, fail, warn);
        assert_close(r.mean_error, ref.mean, F32_SUM_TOL, "mean");
        assert_close(r.rms_error, ref.rms, F32_SUM_TOL, "rms");
        assert_close(r.max_error, ref.max, F32_SUM_TOL, "max");
        assert_close(r.psnr, 20 * log10(ref.peak / ref.rms), psnr_tol(ref.rms), "psnr");
        assert_close(r.psnr, 20 * log10(ref.peak / r.rms_error), 1e-6, "psnr from its own rms");
        assert_int_equal(r.max_x, ref.max_x);
        assert_int_equal(r.max_y, ref.max_y);
        assert_int_equal(r.max_c, ref.max_c);
        assert_int_equal(r.fail_count, ref.fail);
        assert_int_equal(r.warn_count, ref.warn);
        assert_int_equal(r.verdict, ref.fail ? RTO_IMAGE_FAIL : ref.warn ? RTO_IMAGE_WARN : RTO_IMAGE_PASS);
        rto_image_free(&a);
        rto_image_free(&b);
    }
}

/* idiff's rule on both sides of each threshold: 4 of 100 pixels off by 3/255. */
void test_verdicts(void **state)
{
    (void)state;
    rto_image a = make_u8(10, 10, 1), b = make_u8(10, 10, 1);
    unsigned char *q = b.pixels;
    for (int i = 0; i < 4; i++)
        q[i * 17] = (unsigned char)(q[i * 17] + 3);
    rto_image_compare_result r;
    struct {
        double fail, fail_percent, hard_fail, warn, warn_percent, hard_warn;
        int hard_fail_set, hard_warn_set;
        rto_image_verdict want;
    } cases[] = {
        {0, 0, 0, 0, 0, 0, 0, 0, RTO_IMAGE_FAIL},                    /* defaults: any difference fails */
        {0, 4, 0, 0, 0, 0, 0, 0, RTO_IMAGE_WARN},                    /* 4 % may fail: then it warns */
        {0, 3.99, 0, 0, 0, 0, 0, 0, RTO_IMAGE_FAIL},                 /* 4 > 3.99 % */
        {0, 4, 0, 0, 4, 0, 0, 0, RTO_IMAGE_PASS},                    /* within both percentages */
        {0.0118, 0, 0, 0.0118, 0, 0, 0, 0, RTO_IMAGE_PASS},          /* 3/255 = 0.01176 is under both */
        {0.0117, 0, 0, 0.0118, 0, 0, 0, 0, RTO_IMAGE_FAIL},          /* ... and over 0.0117 */
        {0.02, 0, 0.0117, 0.02, 0, 0, 1, 0, RTO_IMAGE_FAIL},         /* hard fail */
        {0.02, 0, 0.0118, 0.02, 0, 0, 1, 0, RTO_IMAGE_PASS},         /* under the hard fail */
        {0.02, 0, 0, 0.02, 0, 0.0117, 0, 1, RTO_IMAGE_PASS},         /* hard warn, but no pixel fails: idiff 2.4.7 passes */
        {0.01, 4, 0, 0.02, 0, 0.0117, 0, 1, RTO_IMAGE_WARN},         /* hard warn with 4 % failing (tolerated) */
        {0.01, 4, 0, 0.001, 3, 0, 0, 0, RTO_IMAGE_WARN},             /* 4 % warn > 3 %, with failing pixels */
        {0.01, 4, 0, 0.001, 4, 0, 0, 0, RTO_IMAGE_PASS},             /* 4 % warn, not > 4 % */
        {0, 100, 0, 0, 100, 0, 0, 0, RTO_IMAGE_PASS},                /* everything may differ */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rto_image_compare_desc d = {cases[i].fail,      cases[i].fail_percent,  cases[i].hard_fail,
                                    cases[i].warn,      cases[i].warn_percent,  cases[i].hard_warn,
                                    cases[i].hard_fail_set, cases[i].hard_warn_set, NULL, 0};
        rto_msg msg = {{0}};
        assert_int_equal(rto_image_compare(&a, &b, &d, &r, &msg), RTO_OK);
        if (r.verdict != cases[i].want)
            fail_msg("case %zu: verdict %d, want %d", i, (int)r.verdict, (int)cases[i].want);
    }
    /* bad thresholds are refused */
    rto_image_compare_desc bad = {0};
    bad.fail = -1;
    rto_msg msg = {{0}};
    assert_int_equal(rto_image_compare(&a, &b, &bad, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    bad.fail = 0;
    bad.fail_percent = 101;
    assert_int_equal(rto_image_compare(&a, &b, &bad, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_image_free(&a);
    rto_image_free(&b);
}

/* NaN matches NaN; NaN against a number is an infinite error, which fails even with the default thresholds. */
void test_non_finite(void **state)
{
    (void)state;
    rto_image a = make_f32(4, 4, 3), b = make_f32(4, 4, 3);
    ((float *)a.pixels)[5] = NAN;
    ((float *)b.pixels)[5] = NAN;
    rto_image_compare_result r;
    rto_msg msg = {{0}};
    assert_int_equal(rto_image_compare(&a, &b, NULL, &r, &msg), RTO_OK);
    assert_int_equal(r.verdict, RTO_IMAGE_PASS);
    ((float *)b.pixels)[5] = 0.5f;
    rto_image_compare_desc d = {0};
    d.fail_percent = d.warn_percent = 100;
    assert_int_equal(rto_image_compare(&a, &b, &d, &r, &msg), RTO_OK);
    assert_true(isinf(r.max_error));
    assert_int_equal(r.max_x, 1);
    assert_int_equal(r.max_c, 2);
    assert_int_equal(r.verdict, RTO_IMAGE_FAIL);
    rto_image_free(&a);
    rto_image_free(&b);
}

/* Different sizes or channel counts: refused with both sizes named. */
/* Images of different sizes or channel counts compare over the union of the two, a value one lacks reading as 0
 * (idiff 2.4.7's way), percentages of the expected image's pixels: equal values plus extra zeros pass, extra
 * non-zero values fail where they are. */
static rto_image filled_u8(uint32_t w, uint32_t h, uint32_t c, unsigned char v, unsigned char alpha)
{
    rto_image im = {w, h, c, RTO_PIXEL_U8, malloc((size_t)w * h * c)};
    assert_non_null(im.pixels);
    unsigned char *p = im.pixels;
    for (size_t i = 0; i < (size_t)w * h * c; i++)
        p[i] = c == 4 && i % 4 == 3 ? alpha : v;
    return im;
}

void test_size_mismatch(void **state)
{
    (void)state;
    rto_image a = filled_u8(4, 3, 3, 100, 0), wide = filled_u8(5, 3, 3, 100, 0), rgba = filled_u8(4, 3, 4, 100, 255),
              rgba0 = filled_u8(4, 3, 4, 100, 0);
    unsigned char *w = wide.pixels;
    rto_image_compare_result r;
    rto_msg msg = {{0}};
    /* the extra column holds 100: its 3 pixels fail, of the expected image's 12 */
    assert_int_equal(rto_image_compare(&a, &wide, NULL, &r, &msg), RTO_OK);
    assert_int_equal(r.verdict, RTO_IMAGE_FAIL);
    assert_int_equal(r.pixels, 12);
    assert_int_equal(r.fail_count, 3);
    assert_int_equal(r.max_x, 4);
    assert_true(fabs(r.max_error - 100.0 / 255.0) < 1e-6);
    /* ... and 0: nothing differs */
    for (uint32_t y = 0; y < 3; y++)
        for (uint32_t c = 0; c < 3; c++)
            w[(y * 5 + 4) * 3 + c] = 0;
    assert_int_equal(rto_image_compare(&a, &wide, NULL, &r, &msg), RTO_OK);
    assert_int_equal(r.verdict, RTO_IMAGE_PASS);
    /* a fourth channel: alpha 1 against the missing 0 fails at channel 3, alpha 0 passes */
    assert_int_equal(rto_image_compare(&a, &rgba, NULL, &r, &msg), RTO_OK);
    assert_int_equal(r.verdict, RTO_IMAGE_FAIL);
    assert_int_equal(r.max_c, 3);
    assert_int_equal(rto_image_compare(&a, &rgba0, NULL, &r, &msg), RTO_OK);
    assert_int_equal(r.verdict, RTO_IMAGE_PASS);
    rto_image_free(&a);
    rto_image_free(&wide);
    rto_image_free(&rgba);
    rto_image_free(&rgba0);
}

/* The diff image is |expected - actual| * scale: 8-bit in a PNG (an alpha channel opaque), float in an OpenEXR. */
void test_diff_image(void **state)
{
    (void)state;
    char png[300], exr[300], bad[300];
    path_in(png, sizeof png, "diff.png");
    path_in(exr, sizeof exr, "diff.exr");
    path_in(bad, sizeof bad, "diff.bmp");
    rto_image a = make_u8(6, 4, 4), b = make_u8(6, 4, 4), d;
    unsigned char *q = b.pixels;
    q[(2 * 6 + 3) * 4 + 1] = (unsigned char)(q[(2 * 6 + 3) * 4 + 1] + 5);
    q[(1 * 6 + 0) * 4 + 3] = (unsigned char)(q[(1 * 6 + 0) * 4 + 3] + 9); /* alpha differs too */
    rto_image_compare_desc desc = {0};
    desc.diff_path = png;
    desc.diff_scale = 10;
    rto_image_compare_result r;
    rto_msg msg = {{0}};
    assert_int_equal(rto_image_compare(&a, &b, &desc, &r, &msg), RTO_OK);
    assert_int_equal(rto_image_read(png, &d, &msg), RTO_OK);
    assert_int_equal(d.type, RTO_PIXEL_U8);
    const unsigned char *p = d.pixels;
    for (uint32_t i = 0; i < 6 * 4; i++)
        for (uint32_t k = 0; k < 4; k++) {
            unsigned want = k == 3 ? 255 : i == 2 * 6 + 3 && k == 1 ? 50 : 0;
            if (p[i * 4 + k] != want)
                fail_msg("diff pixel %u channel %u: %u, want %u", i, k, p[i * 4 + k], want);
        }
    rto_image_free(&d);
    desc.diff_path = exr;
    desc.diff_scale = 0; /* 1 */
    assert_int_equal(rto_image_compare(&a, &b, &desc, &r, &msg), RTO_OK);
    assert_int_equal(rto_image_read(exr, &d, &msg), RTO_OK);
    assert_int_equal(d.type, RTO_PIXEL_F32);
    assert_close(((float *)d.pixels)[(2 * 6 + 3) * 4 + 1], 5 / 255.0, F32_SUM_TOL, "float diff");
    assert_true(((float *)d.pixels)[0] == 0);
    rto_image_free(&d);
    desc.diff_path = bad;
    assert_int_equal(rto_image_compare(&a, &b, &desc, &r, &msg), RTO_ERR_UNSUPPORTED);
    assert_int_equal(access(bad, F_OK), -1);
    rto_image_free(&a);
    rto_image_free(&b);
}

/* Bundle images: listed with role, sha256 and their "image" object; read back after the sha256 check; a changed
 * byte refused; a bad name kept as the bundle's error. */
void test_bundle_images(void **state)
{
    (void)state;
    char dir[300], file[400];
    path_in(dir, sizeof dir, "bundle");
    rto_image a = make_u8(5, 3, 4), f = make_f32(5, 3, 4), back;
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "frame", &b, &msg), RTO_OK);
    assert_int_equal(rto_bundle_add_image(b, "image.png", "image", &a, &msg), RTO_OK);
    assert_int_equal(rto_bundle_add_image(b, "accum.exr", "accum-image", &f, &msg), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK);

    snprintf(file, sizeof file, "%s/manifest.json", dir);
    json_error_t err;
    json_t *m = json_load_file(file, 0, &err);
    assert_non_null(m);
    json_t *files = json_object_get(m, "files");
    assert_int_equal(json_array_size(files), 2);
    json_t *e = json_array_get(files, 1);
    assert_string_equal(json_string_value(json_object_get(e, "name")), "accum.exr");
    assert_string_equal(json_string_value(json_object_get(e, "role")), "accum-image");
    json_t *info = json_object_get(e, "image");
    assert_int_equal(json_integer_value(json_object_get(info, "width")), 5);
    assert_int_equal(json_integer_value(json_object_get(info, "height")), 3);
    assert_int_equal(json_integer_value(json_object_get(info, "channels")), 4);
    assert_string_equal(json_string_value(json_object_get(info, "type")), "f32");
    char hex[65];
    snprintf(file, sizeof file, "%s/accum.exr", dir);
    assert_int_equal(rto_sha256_file(file, hex, &msg), RTO_OK);
    assert_string_equal(json_string_value(json_object_get(e, "sha256")), hex);
    json_decref(m);

    rto_bundle_reader *r = NULL;
    assert_int_equal(rto_bundle_open(dir, &r, &msg), RTO_OK);
    assert_int_equal(rto_bundle_read_image(r, "image.png", &back, &msg), RTO_OK);
    assert_memory_equal(back.pixels, a.pixels, 5 * 3 * 4);
    rto_image_free(&back);
    assert_int_equal(rto_bundle_read_image(r, "accum.exr", &back, &msg), RTO_OK);
    assert_memory_equal(back.pixels, f.pixels, 5 * 3 * 4 * 4);
    rto_image_free(&back);
    assert_int_equal(rto_bundle_read_image(r, "nope.png", &back, &msg), RTO_ERR_IO);
    /* one byte changed: the sha256 no longer matches */
    bytes x = load(file);
    x.p[x.n - 1] ^= 1;
    save(file, x.p, x.n);
    free(x.p);
    assert_int_equal(rto_bundle_read_image(r, "accum.exr", &back, &msg), RTO_ERR_PARSE);
    assert_non_null(strstr(msg.text, "sha256"));
    assert_null(back.pixels);
    rto_bundle_close(r);

    /* a name with a directory in it is refused, and the commit fails with that reason */
    path_in(dir, sizeof dir, "bundle2");
    assert_int_equal(rto_bundle_begin(dir, "frame", &b, &msg), RTO_OK);
    assert_int_equal(rto_bundle_add_image(b, "../image.png", "image", &a, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_not_equal(rto_bundle_commit(b, &msg), RTO_OK);
    assert_int_equal(access(dir, F_OK), -1);
    rto_image_free(&a);
    rto_image_free(&f);
}
