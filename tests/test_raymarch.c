/* The fluid raymarch (DESIGN.md §12.4-§12.7): empty-space skipping is lossless on every generator at three volume
 * resolutions (identical image bytes and crossings, fewer steps), the premise it rests on checked by brute force
 * (every texel any point of an empty cell of any level can read is exactly 0, and every sample position a skip passes
 * over reads only zero texels, both by the test's own texel arithmetic),
 * the reference inside its own admissible sets, and check-raymarch's faults planted and named: a cleared occupancy
 * cell (a GPU skipping an occupied cell: "skip"), the jitter off and a wrong step size ("crossing"), a changed pixel
 * ("image"), a wrong size ("shape"); controls that must pass: the reference's own arrays, a simulated GPU with 8-bit
 * trilinear weights. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rtoracle.h"

#define NONE 0xFFFFFFFFu

typedef struct vol_case {
    rto_splat s;
    rto_raymarch_params p;
} vol_case;

/* A splat of spec at res^3 with h = 1.6 voxels; the raymarch's offset and multiplier scaled to one particle's peak
 * 15 / (2 pi h^3). */
static void make_case(const char *spec, uint32_t res, uint32_t w, uint32_t h, vol_case *c)
{
    rto_fluid_params fp;
    rto_fluid_params_default(&fp);
    fp.res[0] = fp.res[1] = fp.res[2] = res;
    fp.radius = (float)(1.6 * 2.0 / res);
    fp.occupancy = res / 2 < 32 ? res / 2 : 32;
    float *pos = NULL;
    uint64_t n = 0;
    rto_msg msg;
    assert_int_equal(rto_fluid_generate(spec, &fp, &pos, &n, &msg), RTO_OK);
    assert_int_equal(rto_splat_make(&fp, pos, n, 2, &c->s, &msg), RTO_OK);
    free(pos);
    rto_raymarch_params_default(&c->s, &c->p);
    c->p.width = w;
    c->p.height = h;
    c->p.camera = rto_camera_frame(&fp.bounds, (float)w / (float)h);
    const double peak = 15.0 / (2.0 * 3.14159265358979 * pow(fp.radius, 3));
    c->p.density_offset = (float)(0.3 * peak);
    c->p.density_multiplier = (float)(2.0 / peak);
    c->p.threads = 2;
    c->p.envelope = 0;
}

/* The texel index range [lo, hi] on axis a that trilinear reads at any point of world interval [x0, x1] (clamped). */
static void texel_range(const rto_splat *s, int a, double x0, double x1, int *lo, int *hi)
{
    const double mn = a == 0 ? s->params.bounds.min.x : a == 1 ? s->params.bounds.min.y : s->params.bounds.min.z;
    const double mx = a == 0 ? s->params.bounds.max.x : a == 1 ? s->params.bounds.max.y : s->params.bounds.max.z;
    const int n = (int)s->params.res[a];
    const double g0 = (x0 - mn) / (mx - mn) * n - 0.5, g1 = (x1 - mn) / (mx - mn) * n - 0.5;
    /* A point at g reads floor(g) and floor(g) + 1; allow one texel of rounding on either side. */
    *lo = (int)floor(g0) - 1;
    *hi = (int)floor(g1) + 2;
    if (*lo < 0)
        *lo = 0;
    if (*hi > n - 1)
        *hi = n - 1;
}

/* Brute force: every cell of every level that is clear has only zero texels within trilinear reach of its closed box
 * (widened by 2^-12 of a voxel), i.e. any sample a skip passes over reads exactly 0. Returns the empty cells seen. */
static uint64_t check_empty_cells_read_zero(const rto_splat *s)
{
    uint64_t empty = 0;
    const uint32_t O = s->params.occupancy;
    for (uint32_t l = 0; l < s->occupancy_levels; l++) {
        const uint32_t R = s->level_res[l];
        for (uint32_t z = 0; z < R; z++)
            for (uint32_t y = 0; y < R; y++)
                for (uint32_t x = 0; x < R; x++) {
                    if (rto_occupancy_get(s, l, x, y, z))
                        continue;
                    empty++;
                    const uint32_t c[3] = {x, y, z};
                    int lo[3], hi[3];
                    for (int a = 0; a < 3; a++) {
                        const double mn = a == 0 ? s->params.bounds.min.x
                                        : a == 1 ? s->params.bounds.min.y
                                                 : s->params.bounds.min.z;
                        const double mx = a == 0 ? s->params.bounds.max.x
                                        : a == 1 ? s->params.bounds.max.y
                                                 : s->params.bounds.max.z;
                        const double cs = (mx - mn) / O;
                        uint32_t first = c[a] << l, last = (c[a] + 1) << l;
                        if (last > O)
                            last = O;
                        texel_range(s, a, mn + first * cs, mn + last * cs, &lo[a], &hi[a]);
                    }
                    /* Trilinear's reach is one texel short of texel_range's margin on each side: shrink by one,
                     * the texels a point strictly inside reads with weight > 0. */
                    for (int a = 0; a < 3; a++) {
                        lo[a] += 1;
                        hi[a] -= 1;
                    }
                    for (int k = lo[2]; k <= hi[2]; k++)
                        for (int j = lo[1]; j <= hi[1]; j++)
                            for (int i = lo[0]; i <= hi[0]; i++) {
                                const size_t v = ((size_t)k * s->params.res[1] + (size_t)j) * s->params.res[0] + i;
                                if (s->volume_f16[v] != 0) {
                                    print_error("level %u cell (%u %u %u) clear but texel (%d %d %d) = 0x%04x\n", l, x,
                                                y, z, i, j, k, s->volume_f16[v]);
                                    fail();
                                }
                            }
                }
    }
    return empty;
}

/* The test hook's check of every skipped sample position: by the test's own long double texel arithmetic, every texel
 * a trilinear read there may touch (both neighbours on each axis) is 0, or the point is outside [eps, 1 - eps]. */
typedef struct skip_check {
    const rto_splat *s;
    uint64_t checked, violations;
    float first[3];
} skip_check;

static void check_skipped(void *ctx, uint32_t pixel, const float p[3])
{
    (void)pixel;
    skip_check *c = ctx;
    const rto_splat *s = c->s;
    __atomic_add_fetch(&c->checked, 1, __ATOMIC_RELAXED);
    const double mn[3] = {s->params.bounds.min.x, s->params.bounds.min.y, s->params.bounds.min.z};
    const double mx[3] = {s->params.bounds.max.x, s->params.bounds.max.y, s->params.bounds.max.z};
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        const long double uvw = ((long double)p[a] - mn[a]) / ((long double)mx[a] - mn[a]);
        if (!(uvw > 0.99e-4L && uvw < 1.0L - 0.99e-4L))
            return; /* outside: -offset whatever the texels */
        const long double g = uvw * s->params.res[a] - 0.5L;
        lo[a] = (int)floorl(g);
        hi[a] = lo[a] + 1;
        lo[a] = lo[a] < 0 ? 0 : lo[a] > (int)s->params.res[a] - 1 ? (int)s->params.res[a] - 1 : lo[a];
        hi[a] = hi[a] < 0 ? 0 : hi[a] > (int)s->params.res[a] - 1 ? (int)s->params.res[a] - 1 : hi[a];
    }
    for (int z = lo[2]; z <= hi[2]; z++)
        for (int y = lo[1]; y <= hi[1]; y++)
            for (int x = lo[0]; x <= hi[0]; x++)
                if (s->volume_f16[((size_t)z * s->params.res[1] + (size_t)y) * s->params.res[0] + (size_t)x]) {
                    if (__atomic_add_fetch(&c->violations, 1, __ATOMIC_RELAXED) == 1)
                        memcpy(c->first, p, sizeof c->first);
                    return;
                }
}

static void test_skip_lossless(void **state)
{
    (void)state;
    static const char *const specs[] = {"dambreak:1500", "pool:1500", "splash:1500", "single", "lattice"};
    static const uint32_t res[] = {16, 32, 48};
    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++)
        for (size_t r = 0; r < 3; r++) {
            vol_case c;
            make_case(specs[i], res[r], 48, 32, &c);
            check_empty_cells_read_zero(&c.s);
            rto_raymarch rm;
            rto_msg msg;
            skip_check sc = {&c.s, 0, 0, {0, 0, 0}};
            c.p.skipped_sample = check_skipped;
            c.p.skipped_ctx = &sc;
            assert_int_equal(rto_raymarch_make(&c.s, &c.p, &rm, &msg), RTO_OK);
            const rto_raymarch_stats *st = &rm.stats;
            if (sc.violations)
                print_error("%llu skipped samples read a non-zero texel, the first at (%.9g, %.9g, %.9g)\n",
                            (unsigned long long)sc.violations, (double)sc.first[0], (double)sc.first[1],
                            (double)sc.first[2]);
            assert_int_equal(sc.violations, 0);
            assert_true(sc.checked > 0 || strcmp(specs[i], "lattice") == 0);
            print_message("%-14s %2u^3: %llu crossings, steps %.1f -> %.1f per pixel (%.0f%% fewer), %llu differing, "
                          "%llu skipped samples read 0\n",
                          specs[i], res[r], (unsigned long long)st->crossings,
                          (double)st->steps_total / st->pixels, (double)st->steps_skip_total / st->pixels,
                          100.0 * (1.0 - (double)st->steps_skip_total / (double)st->steps_total),
                          (unsigned long long)st->differing_pixels, (unsigned long long)sc.checked);
            assert_true(st->skip_enabled);
            assert_int_equal(st->differing_pixels, 0);
            assert_int_equal(st->differing_crossings, 0);
            /* lattice puts particles everywhere: every cell is occupied, nothing to skip. */
            if (strcmp(specs[i], "lattice") != 0)
                assert_true(st->steps_skip_total < st->steps_total);
            else
                assert_true(st->steps_skip_total <= st->steps_total);
            /* The reference's crossing is inside its own admissible set. */
            for (size_t k = 0; k < st->pixels; k++) {
                const uint32_t g = rm.crossing[k], lo = rm.crossing_lo[k], hi = rm.crossing_hi[k];
                if (lo == NONE)
                    assert_int_equal(g, NONE);
                else if (g != NONE)
                    assert_true(g >= lo && (hi == NONE || g <= hi));
                else
                    assert_int_equal(hi, NONE);
            }
            rto_raymarch_free(&rm);
            rto_splat_free(&c.s);
        }
}

/* The reference density inside its own interval, and against the splat's trilinear (rto_raymarch_density minus the
 * offset, times the multiplier, is rto__fluid_sample's definition: checked by an independent long double trilinear). */
static void test_density_definition(void **state)
{
    (void)state;
    vol_case c;
    make_case("dambreak:1500", 32, 8, 8, &c);
    rto_raymarch_uniforms u;
    rto_msg msg;
    assert_int_equal(rto_raymarch_uniforms_make(&c.s, &c.p, &u, &msg), RTO_OK);
    uint32_t checked = 0;
    for (uint32_t i = 0; i < 4000; i++) {
        float q[3];
        for (int a = 0; a < 3; a++)
            q[a] = -1.0f + 2.0f * rto_unit(77 + a, i);
        const float d = rto_raymarch_density(&c.s, &u, q);
        long double tri = 0;
        int inside = 1;
        long double g[3];
        for (int a = 0; a < 3; a++) {
            const long double uvw = ((long double)q[a] + 1.0L) / 2.0L;
            if (!(uvw > 1e-4L && uvw < 1.0L - 1e-4L))
                inside = 0;
            g[a] = uvw * 32 - 0.5L;
        }
        if (!inside)
            continue;
        for (int k = 0; k < 8; k++) {
            long double w = 1;
            size_t idx[3];
            for (int a = 0; a < 3; a++) {
                const long double f = floorl(g[a]);
                const int bit = (k >> a) & 1;
                int ii = (int)f + bit;
                ii = ii < 0 ? 0 : ii > 31 ? 31 : ii;
                idx[a] = (size_t)ii;
                w *= bit ? g[a] - f : 1 - (g[a] - f);
            }
            tri += w * rto_f16_to_f32(c.s.volume_f16[(idx[2] * 32 + idx[1]) * 32 + idx[0]]);
        }
        const long double want = (tri - c.p.density_offset) * c.p.density_multiplier;
        assert_true(fabsl(want - d) <= 1e-5L * (fabsl(want) + c.p.density_offset * c.p.density_multiplier));
        checked++;
    }
    assert_true(checked > 3000);
    rto_splat_free(&c.s);
}

static rto_raymarch_dump dump_of(const rto_raymarch *r)
{
    rto_raymarch_dump d;
    memset(&d, 0, sizeof d);
    d.width = r->params.width;
    d.height = r->params.height;
    d.image = r->image;
    d.crossing = r->crossing;
    d.steps = r->steps;
    d.steps_skip = r->steps_skip;
    return d;
}

static void test_check_faults(void **state)
{
    (void)state;
    vol_case c;
    make_case("dambreak:4000", 32, 48, 32, &c);
    c.p.envelope = 1;
    rto_raymarch ref;
    rto_msg msg;
    assert_int_equal(rto_raymarch_make(&c.s, &c.p, &ref, &msg), RTO_OK);
    print_message("reference: %llu certain, %llu uncertain, %llu crossings\n", (unsigned long long)ref.stats.certain,
                  (unsigned long long)ref.stats.uncertain, (unsigned long long)ref.stats.crossings);
    assert_true(ref.stats.certain > ref.stats.pixels / 2);
    assert_true(ref.stats.crossings > 50);
    rto_raymarch_check_result res;

    /* Control: the reference's own arrays. */
    rto_raymarch_dump d = dump_of(&ref);
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "");

    /* Controls: a GPU with 8-bit trilinear weights, and one whose filtered value is also rounded to binary16 (an
     * H100's rgba16float filtering, §12.5.1). */
    rto_raymarch q;
    for (int mode = 1; mode <= 2; mode++) {
        rto_raymarch_params qp = c.p;
        qp.quantize_weights = mode;
        qp.envelope = 0;
        assert_int_equal(rto_raymarch_make(&c.s, &qp, &q, &msg), RTO_OK);
        d = dump_of(&q);
        assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
        if (res.fault[0])
            print_error("quantized %d: %s at (%u, %u): %s\n", mode, res.fault, res.x, res.y, res.detail);
        assert_string_equal(res.fault, "");
        print_message("%s: %llu pixels compared, largest deviation %.3f of the tolerance\n",
                      mode == 1 ? "8-bit weights" : "8-bit weights, binary16 result", (unsigned long long)res.compared,
                      res.max_excess);
        rto_raymarch_free(&q);
    }

    /* Wall events (§12.5.1): a GPU that takes the other outcome at every certain pixel that has one passes; the
     * other outcome's image moved by 4x its tolerance + 0.01 is named image at its pixel. */
    float *img = malloc(ref.stats.pixels * 4 * sizeof(float));
    assert_non_null(img);
    size_t wall = ref.stats.pixels, walls = 0;
    memcpy(img, ref.image, ref.stats.pixels * 4 * sizeof(float));
    for (size_t i = 0; i < ref.stats.pixels; i++)
        if (ref.certain[i] && ref.tolerance_wall[i] == ref.tolerance_wall[i]) {
            memcpy(img + 4 * i, ref.image_wall + 4 * i, 4 * sizeof(float));
            wall = wall < i ? wall : i;
            walls++;
        }
    print_message("wall events: %llu certain pixels with another admissible outcome\n", (unsigned long long)walls);
    assert_true(walls > 0 && walls == ref.stats.wall_pixels);
    d = dump_of(&ref);
    d.image = img;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "");
    img[4 * wall + 2] += 4.0f * fmaxf(ref.tolerance_wall[wall], ref.tolerance[wall]) + 0.01f;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "image");
    assert_int_equal(res.x + res.y * c.p.width, wall);
    print_message("wall outcome moved: %s at (%u, %u): %s\n", res.fault, res.x, res.y, res.detail);

    /* Fault: jitter off -> crossing. */
    rto_raymarch_params jp = c.p;
    jp.jitter_scale = 0.0f;
    jp.envelope = 0;
    assert_int_equal(rto_raymarch_make(&c.s, &jp, &q, &msg), RTO_OK);
    d = dump_of(&q);
    d.steps_skip = NULL;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "crossing");
    print_message("jitter off: %s at (%u, %u): %s\n", res.fault, res.x, res.y, res.detail);
    rto_raymarch_free(&q);

    /* Fault: step size 10% long -> crossing. */
    jp = c.p;
    jp.step_size = c.p.step_size * 1.1f;
    jp.envelope = 0;
    assert_int_equal(rto_raymarch_make(&c.s, &jp, &q, &msg), RTO_OK);
    d = dump_of(&q);
    d.steps_skip = NULL;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "crossing");
    print_message("step x1.1: %s at (%u, %u): %s\n", res.fault, res.x, res.y, res.detail);
    rto_raymarch_free(&q);

    /* Fault: an occupied cell cleared (with its ancestors): a skipping GPU passes over it. The cell holding the
     * first crossing point of the first pixel that has one. */
    size_t pix = 0;
    while (pix < ref.stats.pixels && (ref.crossing[pix] == NONE || !ref.certain[pix]))
        pix++;
    assert_true(pix < ref.stats.pixels);
    rto_splat bad = c.s;
    bad.occupancy = malloc(c.s.occupancy_words * sizeof(uint32_t));
    assert_non_null(bad.occupancy);
    memcpy(bad.occupancy, c.s.occupancy, c.s.occupancy_words * sizeof(uint32_t));
    /* The crossing point from the bundle's own t along the primary ray. */
    rto_camera_uniforms cu;
    assert_int_equal(rto_camera_uniforms_make(&c.p.camera, c.p.width, c.p.height, &cu, &msg), RTO_OK);
    const rto_wf_ray ray = rto_camera_ray(&cu, c.p.width, c.p.height, (uint32_t)(pix % c.p.width),
                                          (uint32_t)(pix / c.p.width));
    uint32_t cell[3];
    const uint32_t O = c.s.params.occupancy;
    for (int a = 0; a < 3; a++) {
        const double p = (double)ray.origin[a] + (double)ray.dir[a] * ref.crossing_t[pix];
        cell[a] = (uint32_t)floor((p + 1.0) / 2.0 * O);
    }
    for (uint32_t l = 0; l < bad.occupancy_levels; l++) {
        const uint32_t R = bad.level_res[l];
        const uint64_t b = ((uint64_t)(cell[2] >> l) * R + (cell[1] >> l)) * R + (cell[0] >> l);
        bad.occupancy[bad.level_offset[l] + (b >> 5)] &= ~(UINT32_C(1) << (b & 31));
    }
    rto_raymarch_params sp = c.p;
    sp.skip_only = 1;
    sp.envelope = 0;
    skip_check sc = {&c.s, 0, 0, {0, 0, 0}}; /* the true volume: skipped samples that read non-zero texels */
    sp.skipped_sample = check_skipped;
    sp.skipped_ctx = &sc;
    assert_int_equal(rto_raymarch_make(&bad, &sp, &q, &msg), RTO_OK);
    assert_true(sc.violations > 0); /* the brute-force check of skipped samples sees the planted fault too */
    assert_true(q.crossing[pix] != ref.crossing[pix]);
    d = dump_of(&q);
    d.steps = NULL;
    d.crossing_noskip = ref.crossing; /* the same GPU without skipping */
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "skip");
    print_message("cleared cell: %s at (%u, %u): %s\n", res.fault, res.x, res.y, res.detail);
    d.crossing_noskip = NULL; /* only steps_skip: fewer steps than the reference's lossless skipping */
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "skip");
    rto_raymarch_free(&q);
    free(bad.occupancy);

    /* Fault: one certain pixel's red channel moved by 4x its tolerance + 0.01 (and away from any wall outcome) ->
     * image. */
    memcpy(img, ref.image, ref.stats.pixels * 4 * sizeof(float));
    const float tw = ref.tolerance_wall[pix];
    if (tw == tw) /* far from the wall outcome too */
        img[4 * pix] += 4.0f * fmaxf(ref.tolerance[pix], tw) + 0.01f + fabsf(ref.image_wall[4 * pix] - img[4 * pix]);
    else
        img[4 * pix] += 4.0f * ref.tolerance[pix] + 0.01f;
    d = dump_of(&ref);
    d.image = img;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "image");
    assert_int_equal(res.x + res.y * c.p.width, pix);
    free(img);

    /* Fault: the wrong size -> shape. */
    d = dump_of(&ref);
    d.width = c.p.width - 1;
    assert_int_equal(rto_raymarch_check(&ref, &d, &res, &msg), RTO_OK);
    assert_string_equal(res.fault, "shape");

    rto_raymarch_free(&ref);
    rto_splat_free(&c.s);
}

/* The same bytes on 1 and 3 threads. */
static void test_threads(void **state)
{
    (void)state;
    vol_case c;
    make_case("splash:1500", 16, 40, 24, &c);
    c.p.envelope = 1;
    rto_raymarch a, b;
    rto_msg msg;
    c.p.threads = 1;
    assert_int_equal(rto_raymarch_make(&c.s, &c.p, &a, &msg), RTO_OK);
    c.p.threads = 3;
    assert_int_equal(rto_raymarch_make(&c.s, &c.p, &b, &msg), RTO_OK);
    const size_t n = a.stats.pixels;
    assert_memory_equal(a.image, b.image, n * 4 * sizeof(float));
    assert_memory_equal(a.crossing, b.crossing, n * sizeof(uint32_t));
    assert_memory_equal(a.tolerance, b.tolerance, n * sizeof(float));
    assert_memory_equal(a.certain, b.certain, n);
    assert_memory_equal(a.steps_skip, b.steps_skip, n * sizeof(uint32_t));
    rto_raymarch_free(&a);
    rto_raymarch_free(&b);
    rto_splat_free(&c.s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_skip_lossless),
        cmocka_unit_test(test_density_definition),
        cmocka_unit_test(test_check_faults),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
