/* The frame's building blocks, each against an independent evaluation: texture sampling (binary64 sRGB decode and
 * bilinear weights written here), surface normals (binary64 cross products of the world-space vertices), the 8-bit
 * rounding, the stage list, program-table checks, plugin refusals, and the counters and indirect arguments of a
 * frame derived from its image size and hit count. */
#include "testutil.h"

#include "frame/frame_internal.h"

#include <math.h>
#include <string.h>

/* ---- textures ------------------------------------------------------------------------------------------------ */

static double srgb(double c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }

/* 3 x 2 texels, rows top first */
static const uint8_t texels[2][3][4] = {
    {{0, 64, 128, 255}, {255, 0, 10, 128}, {30, 200, 90, 0}},
    {{90, 90, 90, 40}, {5, 250, 120, 200}, {180, 20, 220, 255}},
};

static double texel(int x, int y, int c)
{
    x = ((x % 3) + 3) % 3;
    y = ((y % 2) + 2) % 2;
    const double v = texels[y][x][c] / 255.0;
    return c < 3 ? srgb(v) : v;
}

/* the bilinear REPEAT sample at (u, v), texel centres at +0.5: the texel coordinate u W - 0.5 in binary32, as the
 * contract computes it (a GPU does too), everything after it in binary64 */
static double expect_sample(float u, float v, int c)
{
    const double x = u * 3.0f - 0.5f, y = v * 2.0f - 0.5f;
    const double x0 = floor(x), y0 = floor(y), fx = x - x0, fy = y - y0;
    const int ix = (int)x0, iy = (int)y0;
    return (texel(ix, iy, c) * (1 - fx) + texel(ix + 1, iy, c) * fx) * (1 - fy) +
           (texel(ix, iy + 1, c) * (1 - fx) + texel(ix + 1, iy + 1, c) * fx) * fy;
}

static void test_texture_sampling(void **state)
{
    (void)state;
    uint8_t rgba[2 * 3 * 4];
    memcpy(rgba, texels, sizeof rgba);
    rto_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.width = 3;
    tex.height = 2;
    tex.rgba = rgba;
    rto_scene scene;
    memset(&scene, 0, sizeof scene);
    scene.textures = &tex;
    scene.texture_count = 1;
    /* texel centres, edges that wrap both ways, between texels, far outside [0, 1) */
    const float uv[][2] = {{0.5f / 3, 0.25f}, {2.5f / 3, 0.75f}, {0.0f, 0.0f},   {1.0f, 1.0f},  {0.999f, 0.01f},
                           {-0.2f, 0.6f},     {1.3f, -0.7f},     {0.41f, 0.33f}, {17.25f, -3.5f}, {-1000.1f, 250.9f}};
    for (size_t i = 0; i < sizeof uv / sizeof uv[0]; i++) {
        float got[4];
        rto__texture_sample(&scene, 0, uv[i], got);
        for (int c = 0; c < 4; c++) {
            const double want = expect_sample(uv[i][0], uv[i][1], c);
            if (fabs(got[c] - want) > 2e-5 + 1e-5 * fabs(want))
                fail_msg("uv (%g, %g) channel %d: %.9g, want %.9g", (double)uv[i][0], (double)uv[i][1], c,
                         (double)got[c], want);
        }
    }
    /* no texture, a bad index, no scene: white */
    float w[4];
    const float any[2] = {0.3f, 0.3f};
    rto__texture_sample(&scene, -1, any, w);
    assert_true(w[0] == 1.0f && w[1] == 1.0f && w[2] == 1.0f && w[3] == 1.0f);
    rto__texture_sample(&scene, 1, any, w);
    assert_true(w[0] == 1.0f && w[3] == 1.0f);
    rto__texture_sample(NULL, 0, any, w);
    assert_true(w[2] == 1.0f);
    /* a NaN coordinate samples at 0 rather than reading out of bounds */
    const float bad[2] = {NAN, INFINITY};
    rto__texture_sample(&scene, 0, bad, w);
    for (int c = 0; c < 4; c++)
        assert_true(fabs(w[c] - expect_sample(0.0f, 0.0f, c)) < 2e-5);
}

/* ---- 8-bit output -------------------------------------------------------------------------------------------- */

static void test_unorm8(void **state)
{
    (void)state;
    assert_int_equal(rto__unorm8(0.0f), 0);
    assert_int_equal(rto__unorm8(-0.0f), 0);
    assert_int_equal(rto__unorm8(-3.0f), 0);
    assert_int_equal(rto__unorm8(NAN), 0);
    assert_int_equal(rto__unorm8(1.0f), 255);
    assert_int_equal(rto__unorm8(7.5f), 255);
    assert_int_equal(rto__unorm8(INFINITY), 255);
    assert_int_equal(rto__unorm8(0.5f), 128); /* 127.5 rounds half up */
    assert_int_equal(rto__unorm8(100.0f / 255.0f), 100);
    assert_int_equal(rto__unorm8(0.49f / 255.0f), 0);
    assert_int_equal(rto__unorm8(0.51f / 255.0f), 1);
    for (int k = 0; k <= 255; k++)
        assert_int_equal(rto__unorm8((float)k / 255.0f), k);
}

/* ---- surfaces ------------------------------------------------------------------------------------------------ */

/* The world-space geometric normal of a hit's triangle in binary64: the cross product of the transformed vertices,
 * turned by the sign of det(M) (a mirroring transform reverses the winding), then normalised. */
static void expect_normal(const rto_scene *s, const rto_hit_record *h, double n[3], double *sine)
{
    const rto_instance *in = &s->instances[h->instance_id];
    const rto_mesh *m = &s->meshes[in->blas];
    double v[3][3];
    for (int k = 0; k < 3; k++) {
        const float *p = m->positions + 3 * (size_t)m->indices[3 * (size_t)h->prim_id + k];
        for (int r = 0; r < 3; r++)
            v[k][r] = (double)in->obj_to_world.m[r][0] * p[0] + (double)in->obj_to_world.m[r][1] * p[1] +
                      (double)in->obj_to_world.m[r][2] * p[2] + (double)in->obj_to_world.m[r][3];
    }
    const double a[3] = {v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]};
    const double b[3] = {v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]};
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    const float(*M)[4] = in->obj_to_world.m;
    const double det = (double)M[0][0] * ((double)M[1][1] * M[2][2] - (double)M[1][2] * M[2][1]) -
                       (double)M[0][1] * ((double)M[1][0] * M[2][2] - (double)M[1][2] * M[2][0]) +
                       (double)M[0][2] * ((double)M[1][0] * M[2][1] - (double)M[1][1] * M[2][0]);
    const double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) * (det < 0 ? -1 : 1);
    *sine = fabs(len) / (sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) * sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]));
    for (int r = 0; r < 3; r++)
        n[r] = c[r] / len;
}

static void test_surface_normals(void **state)
{
    (void)state;
    size_t checked = 0;
    for (uint32_t seed = 1; seed <= 8; seed++) {
        char spec[32];
        snprintf(spec, sizeof spec, "random:%u", seed);
        rto_scene *s = tu_load(spec);
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(s, NULL, &acc, NULL), RTO_OK);
        rto_rays_desc rd;
        memset(&rd, 0, sizeof rd);
        rd.set = RTO_RAYS_RANDOM;
        rd.seed = seed;
        rd.count = 400;
        rto_wf_ray rays[400];
        rto_hit_record hits[400];
        size_t n = 0;
        assert_int_equal(rto_rays_generate(acc, &rd, rays, 400, &n, NULL, NULL), RTO_OK);
        assert_int_equal(rto_trace(acc, rays, n, NULL, hits, NULL, NULL), RTO_OK);
        const rto_frame_env env = {1, 1, 1, NULL, s, 0.0f, NULL, NULL};
        for (size_t i = 0; i < n; i++) {
            if (hits[i].miss_flag)
                continue;
            rto_surface sf;
            rto__surface_mesh(&env, &rays[i], &hits[i], &sf);
            double want[3], sine = 0;
            expect_normal(s, &hits[i], want, &sine);
            if (!isfinite(want[0]) || !isfinite(want[1]) || !isfinite(want[2]))
                continue; /* a degenerate triangle has no normal to compare */
            const double *w = want;
            const double g[3] = {sf.geometric_normal[0], sf.geometric_normal[1], sf.geometric_normal[2]};
            const double dot = w[0] * g[0] + w[1] * g[1] + w[2] * g[2];
            const double x[3] = {w[1] * g[2] - w[2] * g[1], w[2] * g[0] - w[0] * g[2], w[0] * g[1] - w[1] * g[0]};
            /* the angle from the cross product: acos near 1 would only measure the rounding of |g| */
            const double angle = dot > 0 ? asin(fmin(1, sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]))) : M_PI;
            /* The binary32 cross product of a sliver loses digits as 1 / sin(angle between its edges), and the
             * rounded worldToObj differs from the inverse of the rounded objToWorld by a few ulp: the angle between
             * the two normals is held to 1e-5 + 4e-6 / sin. */
            const double tol = 1e-5 + 4e-6 / sine;
            if (!(angle <= tol))
                fail_msg("%s ray %zu (instance %u prim %u): normal (%g %g %g), want (%g %g %g), angle %g > %g", spec, i,
                         hits[i].instance_id, hits[i].prim_id, (double)sf.geometric_normal[0],
                         (double)sf.geometric_normal[1], (double)sf.geometric_normal[2], want[0], want[1], want[2],
                         angle, tol);
            /* no vertex normals in random scenes: the shading normal is the geometric one */
            assert_memory_equal(sf.normal, sf.geometric_normal, sizeof sf.normal);
            for (int c = 0; c < 3; c++) /* the position is o + t d, per component */
                assert_true(sf.position[c] == rays[i].origin[c] + hits[i].t * rays[i].dir[c]);
            checked++;
        }
        rto_accel_destroy(acc);
        rto_scene_destroy(s);
    }
    assert_true(checked > 200);
}

/* ---- stages, programs, plugins ------------------------------------------------------------------------------- */

static void test_keep_parse(void **state)
{
    (void)state;
    uint32_t k = 99;
    rto_msg msg = {{0}};
    assert_true(rto_frame_keep_parse("rays,hits", &k, NULL));
    assert_int_equal(k, RTO_FRAME_KEEP_RAYS | RTO_FRAME_KEEP_HITS);
    assert_true(rto_frame_keep_parse("all", &k, NULL));
    assert_int_equal(k, RTO_FRAME_KEEP_ALL);
    assert_true(rto_frame_keep_parse("none", &k, NULL));
    assert_int_equal(k, 0);
    assert_true(rto_frame_keep_parse("accum,trace-counters,payloads", &k, NULL));
    assert_int_equal(k, RTO_FRAME_KEEP_ACCUM | RTO_FRAME_KEEP_TRACE_COUNTERS | RTO_FRAME_KEEP_PAYLOADS);
    assert_false(rto_frame_keep_parse("rays,,hits", &k, &msg));
    assert_false(rto_frame_keep_parse("hit", &k, &msg));
    assert_non_null(strstr(msg.text, "unknown stage 'hit'"));
    assert_false(rto_frame_keep_parse("", &k, &msg));
}

static void nop_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y) { (void)ctx, (void)x, (void)y; }

static void test_program_validate(void **state)
{
    (void)state;
    for (uint32_t i = 0; rto_program_builtin_at(i); i++) {
        const rto_program *p = rto_program_builtin_at(i);
        assert_int_equal(rto_program_validate(p, NULL), RTO_OK);
        assert_ptr_equal(rto_program_builtin(p->name), p);
    }
    assert_null(rto_program_builtin_at(3));
    assert_null(rto_program_builtin("sun_shadow"));
    assert_null(rto_program_builtin(NULL));
    static const rto_program_param good[] = {{"a", 2, {1, 2, 0, 0}, ""}};
    static const rto_program_param twice[] = {{"a", 1, {1, 0, 0, 0}, ""}, {"a", 1, {1, 0, 0, 0}, ""}};
    static const rto_program_param wide[] = {{"a", 5, {1, 0, 0, 0}, ""}};
    static const rto_program_param nan[] = {{"a", 1, {NAN, 0, 0, 0}, ""}};
    static const rto_program_param upper[] = {{"Sun", 1, {1, 0, 0, 0}, ""}};
    const rto_program base = {RTO_PROGRAM_ABI_VERSION, "mine", "", 8, 1, good, 1, NULL, NULL, nop_raygen, NULL,
                              NULL, NULL};
    assert_int_equal(rto_program_validate(&base, NULL), RTO_OK);
    struct {
        rto_program p;
        const char *why;
    } bad[] = {{base, "ABI version 2"}, {base, "program name"}, {base, "payload size 6"}, {base, "payload size 68"},
               {base, "maxDepth 0"},    {base, "no raygen"},    {base, "declared twice"}, {base, "has 5 values"},
               {base, "not finite"},    {base, "name must be"}};
    bad[0].p.abi_version = 2;
    bad[1].p.name = "My Program";
    bad[2].p.payload_size = 6;
    bad[3].p.payload_size = 68;
    bad[4].p.max_depth = 0;
    bad[5].p.raygen = NULL;
    bad[6].p.params = twice, bad[6].p.param_count = 2;
    bad[7].p.params = wide;
    bad[8].p.params = nan;
    bad[9].p.params = upper;
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rto_msg msg = {{0}};
        assert_int_equal(rto_program_validate(&bad[i].p, &msg), RTO_ERR_UNSUPPORTED);
        if (!strstr(msg.text, bad[i].why))
            fail_msg("case %zu: '%s' does not say '%s'", i, msg.text, bad[i].why);
    }
}

static void test_plugin_refusals(void **state)
{
    (void)state;
    rto_plugin *pl = (rto_plugin *)1;
    rto_msg msg = {{0}};
    assert_int_equal(rto_plugin_load("/nonexistent/lib.so", &pl, &msg), RTO_ERR_IO);
    assert_null(pl);
    assert_int_equal(rto_plugin_load("/tmp", &pl, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a regular file"));
    /* a real shared library without the entry point */
    assert_int_equal(rto_plugin_load("/lib/x86_64-linux-gnu/libm.so.6", &pl, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, RTO_PROGRAM_ENTRY_SYMBOL));
    assert_null(rto_plugin_program(NULL));
    rto_plugin_unload(NULL);
}

/* ---- a frame's bookkeeping ------------------------------------------------------------------------------------ */

static void test_frame_counters(void **state)
{
    (void)state;
    rto_scene *s = tu_load("rtstress:3");
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(s, NULL, &acc, NULL), RTO_OK);
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = rto_program_builtin("sun-shadow");
    d.accel = acc;
    d.width = 67; /* not a multiple of 64 rays: the indirect args round up */
    d.height = 31;
    d.keep = RTO_FRAME_KEEP_ALL;
    rto_frame *f = NULL;
    assert_int_equal(rto_frame_render(&d, &f, NULL), RTO_OK);
    const uint32_t px = 67 * 31;
    assert_int_equal(f->max_depth, 2);
    assert_int_equal(f->capacity, 2 * px);
    const rto_frame_counters *c = f->counters;
    assert_int_equal(c[0].emitted, px);
    assert_int_equal(c[0].queued, px);
    assert_int_equal(c[0].traced, px);
    assert_int_equal(c[0].hits + c[0].misses, px);
    /* every primary ray is shaded; each lit hit sends one shadow ray, each shadow ray is shaded only on a miss */
    assert_int_equal(c[0].shaded, px);
    assert_true(c[1].emitted > 0 && c[1].emitted <= c[0].hits);
    assert_int_equal(c[1].traced, c[1].emitted);
    assert_int_equal(c[1].shaded, c[1].misses);
    assert_int_equal(c[2].emitted, 0);
    assert_int_equal(c[2].traced, 0);
    /* accumulates: one per primary ray (ambient or sky), one per shadow miss */
    assert_int_equal(c[0].accumulates, px);
    assert_int_equal(c[1].accumulates, c[1].misses);
    for (uint32_t q = 0; q <= 2; q++) {
        assert_int_equal(f->indirect_args[q][0], (c[q].queued + 63) / 64);
        assert_int_equal(f->indirect_args[q][1], 1);
        assert_int_equal(f->indirect_args[q][2], 1);
        assert_int_equal(c[q].dropped + c[q].refused + c[q].conflicts, 0);
    }
    /* the queues: pixels row-major, payload slots, kinds; shadow rays in their parents' order */
    for (uint32_t i = 0; i < px; i++) {
        const rto_wf_ray *r = &f->queues[0].rays[i];
        assert_int_equal(r->pixel, i);
        assert_int_equal(r->payload_slot, i);
        assert_int_equal(r->kind, RTO_RAY_KIND_PRIMARY);
    }
    uint32_t last = 0;
    for (uint32_t i = 0; i < c[1].queued; i++) {
        const rto_wf_ray *r = &f->queues[1].rays[i];
        assert_true(i == 0 || r->pixel > last);
        last = r->pixel;
        assert_int_equal(r->payload_slot, r->pixel);
        assert_int_equal(r->kind, RTO_RAY_KIND_SHADOW);
        assert_int_equal(f->queues[0].hits[r->pixel].miss_flag, 0);
    }
    for (uint32_t i = 0; i < px; i++) {
        assert_true(f->accum[4 * i + 3] == 1.0f);
        assert_int_equal(f->image[4 * i + 3], 255);
        assert_int_equal(f->not_comparable[i], 0);
    }
    rto_frame_destroy(f);
    /* refusals: sizes, depth, keep bits, a parameter */
    rto_msg msg = {{0}};
    d.width = 0;
    assert_int_equal(rto_frame_render(&d, &f, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.width = 8192, d.height = 8193;
    assert_int_equal(rto_frame_render(&d, &f, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.width = d.height = 4;
    d.max_depth = 65;
    assert_int_equal(rto_frame_render(&d, &f, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.max_depth = 0;
    d.keep = 0x100;
    assert_int_equal(rto_frame_render(&d, &f, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.keep = 0;
    rto_param_value p = {"sun_dir", 3, {0, 0, 0, 0}};
    d.params = &p;
    d.param_count = 1;
    assert_int_equal(rto_frame_render(&d, &f, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "cannot be normalised"));
    assert_null(f);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_texture_sampling),  cmocka_unit_test(test_unorm8),
        cmocka_unit_test(test_surface_normals),   cmocka_unit_test(test_keep_parse),
        cmocka_unit_test(test_program_validate),  cmocka_unit_test(test_plugin_refusals),
        cmocka_unit_test(test_frame_counters),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
