/* unit.fluid_splat: the reference splat (DESIGN.md §12.2-§12.3) against a brute force written here (its own kernel
 * in binary64 with each binary32 step emulated by one rounding, summed over every voxel of the volume with no range
 * logic, in u64); the same bytes under particle shuffles, re-partitions and thread counts; overflow named with its
 * true sum; the occupancy grid conservative against required cells computed here, its mips the ORs of their children;
 * the conformance model's ranges contain the reference values. */
#include "testutil.h"
#include "fluid/fluid_internal.h"

/* The test's own stream (a 64-bit LCG), independent of the library's rto_unit. */
static uint64_t lcg_state;
static uint32_t lcg(void)
{
    lcg_state = lcg_state * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(lcg_state >> 33);
}
static float lcg_unit(void) { return (float)(lcg() >> 8) * 0x1p-23f; }

static rto_fluid_params params(uint32_t nx, uint32_t ny, uint32_t nz, float lo, float hi, float h, float scale)
{
    rto_fluid_params p;
    rto_fluid_params_default(&p);
    p.res[0] = nx;
    p.res[1] = ny;
    p.res[2] = nz;
    p.bounds.min = (rto_vec3){lo, lo * 0.9f, lo * 1.1f};
    p.bounds.max = (rto_vec3){hi, hi * 1.05f, hi};
    p.radius = h;
    p.scale = scale;
    p.occupancy = 8;
    return p;
}

static float f32(double x) { return (float)x; }

/* The brute force: every particle against every voxel; binary32 steps as one rounding of the binary64 operation
 * (exact for + - * of binary32 operands up to the final rounding, and correctly rounded sqrt and division: binary64
 * carries more than 2 * 24 + 2 bits). Sums in u64. */
static void brute(const rto_fluid_params *p, const float *pos, uint64_t n, uint64_t *sum)
{
    const double bmin[3] = {p->bounds.min.x, p->bounds.min.y, p->bounds.min.z};
    const double bmax[3] = {p->bounds.max.x, p->bounds.max.y, p->bounds.max.z};
    float vs[3];
    for (int a = 0; a < 3; a++)
        vs[a] = f32((bmax[a] - bmin[a]) / (double)p->res[a]);
    const double h = p->radius;
    const float S = f32(15.0 / (2.0 * 3.14159265358979323846 * h * h * h * h * h));
    const size_t nv = (size_t)p->res[0] * p->res[1] * p->res[2];
    memset(sum, 0, nv * sizeof *sum);
    for (size_t v = 0; v < nv; v++) {
        const uint32_t id[3] = {(uint32_t)(v % p->res[0]), (uint32_t)(v / p->res[0] % p->res[1]),
                                (uint32_t)(v / ((size_t)p->res[0] * p->res[1]))};
        float c[3];
        for (int a = 0; a < 3; a++)
            c[a] = f32(bmin[a] + (double)f32((double)f32((double)id[a] + 0.5) * (double)vs[a]));
        for (uint64_t i = 0; i < n; i++) {
            float d[3];
            for (int a = 0; a < 3; a++)
                d[a] = f32((double)c[a] - (double)pos[3 * i + a]);
            const float xy = f32((double)f32((double)d[0] * d[0]) + (double)f32((double)d[1] * d[1]));
            const float r2 = f32((double)xy + (double)f32((double)d[2] * d[2]));
            const float r = f32(sqrt((double)r2));
            if (!(r < p->radius))
                continue;
            const float w = f32((double)p->radius - (double)r);
            const float k = f32((double)f32((double)w * w) * (double)S);
            const double ks = (double)f32((double)k * (double)p->scale);
            sum[v] += ks >= 4294967296.0 ? 4294967295u : (uint64_t)ks;
        }
    }
}

static float *gen(const char *spec, const rto_fluid_params *p, uint64_t *n)
{
    float *pos = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_fluid_generate(spec, p, &pos, n, &msg), RTO_OK);
    return pos;
}

/* The reference against the brute force on small volumes: generators, odd bounds, knife-edge lattices. */
static void test_against_brute_force(void **state)
{
    (void)state;
    const struct {
        const char *spec;
        rto_fluid_params p;
    } cases[] = {
        {"single", params(24, 24, 24, -1.0f, 1.0f, 0.2f, 1000.0f)},
        {"lattice", params(24, 20, 28, -0.7f, 1.3f, 0.15f, 1000.0f)},
        {"lattice", params(16, 16, 16, -1.0f, 1.0f, 0.125f, 1000.0f)}, /* power-of-two steps: exact knife edges */
        {"dambreak:300", params(24, 24, 24, -1.0f, 1.0f, 0.2f, 1000.0f)},
        {"splash:200", params(20, 26, 22, -0.3f, 2.1f, 0.25f, 12345.0f)},
        {"pool:150", params(24, 24, 24, 3.0f, 5.0f, 0.1f, 1.0f)},
    };
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        uint64_t n;
        float *pos = gen(cases[k].spec, &cases[k].p, &n);
        rto_splat s;
        rto_msg msg = {{0}};
        assert_int_equal(rto_splat_make(&cases[k].p, pos, n, 2, &s, &msg), RTO_OK);
        const size_t nv = (size_t)cases[k].p.res[0] * cases[k].p.res[1] * cases[k].p.res[2];
        uint64_t *sum = malloc(nv * sizeof *sum);
        brute(&cases[k].p, pos, n, sum);
        uint64_t nonzero = 0, maxs = 0;
        for (size_t v = 0; v < nv; v++) {
            if (s.volume_u32[v] != (uint32_t)sum[v])
                fail_msg("%s: voxel %zu: %u, brute force %llu", cases[k].spec, v, s.volume_u32[v],
                         (unsigned long long)sum[v]);
            const float d = f32((double)f32((double)(uint32_t)sum[v]) / (double)cases[k].p.scale);
            assert_int_equal(s.volume_f16[v], rto_f16_from_f32(d));
            nonzero += sum[v] != 0;
            maxs = sum[v] > maxs ? sum[v] : maxs;
        }
        assert_true(nonzero > 0);
        assert_int_equal(s.stats.voxels_nonzero, nonzero);
        assert_int_equal(s.stats.max_sum, maxs);
        assert_int_equal(s.stats.overflow_voxels, 0);
        free(sum);
        rto_splat_free(&s);
        free(pos);
    }
}

static void same_splat(const rto_splat *a, const rto_splat *b)
{
    const size_t nv = (size_t)a->params.res[0] * a->params.res[1] * a->params.res[2];
    assert_memory_equal(a->volume_u32, b->volume_u32, nv * 4);
    assert_memory_equal(a->volume_f16, b->volume_f16, nv * 2);
    assert_int_equal(a->occupancy_words, b->occupancy_words);
    assert_memory_equal(a->occupancy, b->occupancy, (size_t)a->occupancy_words * 4);
    assert_memory_equal(&a->stats, &b->stats, sizeof a->stats);
}

/* Thread counts, shuffles and a splat in three chunks (the u32 volumes added mod 2^32) give the same volume. */
static void test_order_and_threads(void **state)
{
    (void)state;
    rto_fluid_params p = params(32, 32, 32, -1.0f, 1.0f, 0.12f, 1000.0f);
    p.occupancy = 16;
    uint64_t n;
    float *pos = gen("splash:3000", &p, &n);
    rto_msg msg = {{0}};
    rto_splat base;
    assert_int_equal(rto_splat_make(&p, pos, n, 1, &base, &msg), RTO_OK);
    const uint32_t threads[] = {2, 3, 7};
    for (size_t t = 0; t < 3; t++) {
        rto_splat s;
        assert_int_equal(rto_splat_make(&p, pos, n, threads[t], &s, &msg), RTO_OK);
        same_splat(&base, &s);
        rto_splat_free(&s);
    }
    lcg_state = 7;
    float *sh = malloc((size_t)n * 3 * sizeof *sh);
    memcpy(sh, pos, (size_t)n * 3 * sizeof *sh);
    for (uint64_t i = n - 1; i > 0; i--) {
        const uint64_t j = lcg() % (i + 1);
        for (int a = 0; a < 3; a++) {
            const float f = sh[3 * i + a];
            sh[3 * i + a] = sh[3 * j + a];
            sh[3 * j + a] = f;
        }
    }
    rto_splat s;
    assert_int_equal(rto_splat_make(&p, sh, n, 3, &s, &msg), RTO_OK);
    same_splat(&base, &s);
    rto_splat_free(&s);
    const size_t nv = (size_t)32 * 32 * 32;
    uint32_t *acc = calloc(nv, sizeof *acc);
    const uint64_t cut[4] = {0, n / 3, n / 2 + 17, n};
    for (int c = 0; c < 3; c++) {
        assert_int_equal(rto_splat_make(&p, sh + 3 * cut[c], cut[c + 1] - cut[c], 2, &s, &msg), RTO_OK);
        for (size_t v = 0; v < nv; v++)
            acc[v] += s.volume_u32[v];
        rto_splat_free(&s);
    }
    assert_memory_equal(acc, base.volume_u32, nv * 4);
    free(acc);
    free(sh);
    rto_splat_free(&base);
    free(pos);
}

/* Coincident particles at a large scale: the true sums pass 2^32 - 1, the volume holds them mod 2^32, the list names
 * every overflowing voxel with its true sum (the brute force's). */
static void test_overflow(void **state)
{
    (void)state;
    rto_fluid_params p = params(16, 16, 16, -1.0f, 1.0f, 0.3f, 16777216.0f);
    const uint64_t n = 6;
    float pos[18];
    for (uint64_t i = 0; i < n; i++) {
        pos[3 * i] = 0.01f;
        pos[3 * i + 1] = -0.02f;
        pos[3 * i + 2] = 0.03f;
    }
    rto_splat s;
    rto_msg msg = {{0}};
    assert_int_equal(rto_splat_make(&p, pos, n, 3, &s, &msg), RTO_OK);
    const size_t nv = 16 * 16 * 16;
    uint64_t *sum = malloc(nv * sizeof *sum), over = 0, first = UINT64_MAX;
    brute(&p, pos, n, sum);
    for (size_t v = 0; v < nv; v++) {
        assert_int_equal(s.volume_u32[v], (uint32_t)sum[v]);
        if (sum[v] > UINT32_MAX) {
            assert_true(over < s.overflow_count);
            assert_int_equal(s.overflow[2 * over], v);
            assert_int_equal(s.overflow[2 * over + 1], sum[v]);
            if (first == UINT64_MAX)
                first = v;
            over++;
        }
    }
    assert_true(over > 0);
    assert_int_equal(s.overflow_count, over);
    assert_int_equal(s.stats.overflow_voxels, over);
    assert_int_equal(s.stats.first_overflow, first);
    free(sum);
    rto_splat_free(&s);
}

/* Every cell a non-zero voxel's trilinear reach [c - vs, c + vs] meets is set (computed here from the brute force's
 * sums and from every voxel some particle reaches within h (1 + 2^-16) in binary64); each coarser level is the OR of
 * its children; the level layout is O, ceil(O / 2), ... 1. */
static void test_occupancy(void **state)
{
    (void)state;
    const uint32_t occs[] = {8, 7, 13, 1};
    for (size_t k = 0; k < 4; k++) {
        rto_fluid_params p = params(24, 20, 28, -0.7f, 1.3f, 0.15f, 1000.0f);
        p.occupancy = occs[k];
        uint64_t n;
        float *pos = gen(k == 1 ? "lattice" : "dambreak:200", &p, &n);
        rto_splat s;
        rto_msg msg = {{0}};
        assert_int_equal(rto_splat_make(&p, pos, n, 2, &s, &msg), RTO_OK);
        uint32_t r = occs[k], l = 0;
        uint64_t off = 0;
        for (;; l++) {
            assert_int_equal(s.level_res[l], r);
            assert_int_equal(s.level_offset[l], off);
            off += ((uint64_t)r * r * r + 31) / 32;
            if (r == 1)
                break;
            r = (r + 1) / 2;
        }
        assert_int_equal(s.occupancy_levels, l + 1);
        assert_int_equal(s.occupancy_words, off);
        const size_t nv = (size_t)24 * 20 * 28;
        uint64_t *sum = malloc(nv * sizeof *sum);
        brute(&p, pos, n, sum);
        const double bmin[3] = {p.bounds.min.x, p.bounds.min.y, p.bounds.min.z};
        const double bmax[3] = {p.bounds.max.x, p.bounds.max.y, p.bounds.max.z};
        uint64_t required = 0;
        for (size_t v = 0; v < nv; v++) {
            const uint32_t id[3] = {(uint32_t)(v % 24), (uint32_t)(v / 24 % 20), (uint32_t)(v / (24 * 20))};
            double c[3], vs[3];
            for (int a = 0; a < 3; a++) {
                vs[a] = (bmax[a] - bmin[a]) / p.res[a];
                c[a] = bmin[a] + (id[a] + 0.5) * vs[a];
            }
            bool near = sum[v] != 0;
            for (uint64_t i = 0; i < n && !near; i++) {
                double r2 = 0.0;
                for (int a = 0; a < 3; a++)
                    r2 += (c[a] - pos[3 * i + a]) * (c[a] - pos[3 * i + a]);
                near = sqrt(r2) < p.radius * (1.0 + 0x1p-16);
            }
            if (!near)
                continue;
            const uint32_t O = p.occupancy;
            for (uint32_t z = 0; z < O; z++)
                for (uint32_t y = 0; y < O; y++)
                    for (uint32_t x = 0; x < O; x++) {
                        const uint32_t cell[3] = {x, y, z};
                        bool meets = true;
                        for (int a = 0; a < 3; a++) {
                            const double cs = (bmax[a] - bmin[a]) / O;
                            const double lo = bmin[a] + cell[a] * cs, hi = bmin[a] + (cell[a] + 1) * cs;
                            meets = meets && c[a] - vs[a] < hi - 1e-9 && c[a] + vs[a] > lo + 1e-9;
                        }
                        if (meets) {
                            required++;
                            if (!rto_occupancy_get(&s, 0, x, y, z))
                                fail_msg("occupancy %u: cell (%u, %u, %u) not set, voxel %zu needs it", O, x, y, z, v);
                        }
                    }
        }
        assert_true(required > 0);
        for (uint32_t lv = 1; lv < s.occupancy_levels; lv++) {
            const uint32_t rr = s.level_res[lv], rc = s.level_res[lv - 1];
            for (uint32_t z = 0; z < rr; z++)
                for (uint32_t y = 0; y < rr; y++)
                    for (uint32_t x = 0; x < rr; x++) {
                        int any = 0;
                        for (uint32_t dz = 0; dz < 2; dz++)
                            for (uint32_t dy = 0; dy < 2; dy++)
                                for (uint32_t dx = 0; dx < 2; dx++)
                                    if (2 * x + dx < rc && 2 * y + dy < rc && 2 * z + dz < rc)
                                        any |= rto_occupancy_get(&s, lv - 1, 2 * x + dx, 2 * y + dy, 2 * z + dz);
                        assert_int_equal(rto_occupancy_get(&s, lv, x, y, z), any);
                    }
        }
        free(sum);
        rto_splat_free(&s);
        free(pos);
    }
}

/* The model's range holds the reference: per contribution (random pairs, many at r close to h), per voxel (the
 * model's sums around the volume), and per resolve (nearest and any, every u near binary16 and binary32 edges). */
static void test_model_contains_reference(void **state)
{
    (void)state;
    rto_fluid_params p = params(24, 24, 24, -1.0f, 1.0f, 0.2f, 1000.0f);
    rto_fluid_uniforms u;
    rto_msg msg = {{0}};
    assert_int_equal(rto_fluid_uniforms_make(&p, &u, &msg), RTO_OK);
    lcg_state = 99;
    uint64_t uncertain = 0;
    for (int k = 0; k < 200000; k++) {
        float pp[3], c[3];
        for (int a = 0; a < 3; a++)
            c[a] = rto__fluid_centre(&u, a, lcg() % 24);
        double dir[3], len = 0.0;
        for (int a = 0; a < 3; a++) {
            dir[a] = lcg_unit() - 0.5;
            len += dir[a] * dir[a];
        }
        len = sqrt(len) + 1e-30;
        const double r = k & 1 ? p.radius * (1.0 + (lcg_unit() - 0.5) * 1e-5) : p.radius * lcg_unit() * 1.1;
        for (int a = 0; a < 3; a++)
            pp[a] = (float)(c[a] + dir[a] / len * r);
        uint32_t lo, hi;
        bool reach, inside;
        rto__fluid_interval(&u, pp, c, &lo, &hi, &reach);
        const uint32_t ref = rto__fluid_contribution(&u, pp, c, &inside);
        assert_true(lo <= ref && ref <= hi);
        assert_true(!inside || reach);
        uncertain += lo != hi;
    }
    assert_true(uncertain > 0);
    uint64_t n;
    float *pos = gen("dambreak:500", &p, &n);
    rto_splat s;
    assert_int_equal(rto_splat_make(&p, pos, n, 2, &s, &msg), RTO_OK);
    const size_t nv = (size_t)24 * 24 * 24;
    uint64_t *lo = calloc(nv, 8), *hi = calloc(nv, 8);
    uint8_t *reach = calloc(nv, 1);
    assert_int_equal(rto__fluid_model(&s.uniforms, pos, n, 3, lo, hi, reach, &uncertain, &msg), RTO_OK);
    assert_int_equal(uncertain, s.stats.uncertain);
    for (size_t v = 0; v < nv; v++) {
        assert_true(lo[v] <= s.volume_u32[v] && s.volume_u32[v] <= hi[v]);
        assert_true(s.volume_u32[v] == 0 || reach[v]);
    }
    free(lo);
    free(hi);
    free(reach);
    rto_splat_free(&s);
    free(pos);
    const float scales[] = {1000.0f, 1.0f, 3.0f, 16777216.0f};
    for (int si = 0; si < 4; si++)
        for (int k = 0; k < 100000; k++) {
            const uint32_t v = k < 2000 ? (uint32_t)k : k & 1 ? lcg() : (uint32_t)(lcg() % 70000000u);
            const uint16_t ref = rto__fluid_resolve(v, scales[si]);
            uint16_t a, b, c, d;
            rto__fluid_resolve_range(v, scales[si], true, &a, &b);
            rto__fluid_resolve_range(v, scales[si], false, &c, &d);
            assert_true(a <= ref && ref <= b);
            assert_true(c <= a && b == d);
        }
}

/* Parameters and generators: refused outside their limits with one line, deterministic inside. */
static void test_params_and_generators(void **state)
{
    (void)state;
    rto_fluid_params p;
    rto_fluid_uniforms u;
    rto_msg msg = {{0}};
    rto_fluid_params_default(&p);
    assert_int_equal(rto_fluid_uniforms_make(&p, &u, &msg), RTO_OK);
    assert_true(u.voxel_size[0] == 2.0f / 64.0f && u.res[2] == 64.0f && u.occupancy == 32.0f);
    assert_true(fabs(u.kernel_factor / (15.0 / (2.0 * 3.14159265358979 * pow(0.05f, 5))) - 1.0) < 1e-7);
    rto_fluid_params q = p;
    q.res[1] = 0;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q = p;
    q.res[0] = q.res[1] = q.res[2] = 1024;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q = p;
    q.radius = NAN;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q = p;
    q.scale = 16777217.0f * 2.0f;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q = p;
    q.bounds.max.y = q.bounds.min.y;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q = p; /* a radius the bounds' binary32 precision does not resolve: 2^13 sqrt(3) ulp(2) / (1 - 2^-7) = 0.0017 */
    q.radius = 0.0017f;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    q.radius = 0.0018f;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_OK);
    q = p;
    q.occupancy = 1025;
    assert_int_equal(rto_fluid_uniforms_make(&q, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    const char *bad[] = {"dambreak:0", "dambreak:16777217", "pool:", "pool:x", "splash:-1", "rain:5", "single:2", ""};
    for (size_t k = 0; k < sizeof bad / sizeof *bad; k++) {
        float *pos = (float *)1;
        uint64_t n = 1;
        assert_int_equal(rto_fluid_generate(bad[k], &p, &pos, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
        assert_null(pos);
    }
    const char *good[] = {"dambreak:1000", "pool:777", "splash:500", "single", "lattice"};
    for (size_t k = 0; k < 5; k++) {
        uint64_t n1, n2;
        float *a = gen(good[k], &p, &n1), *b = gen(good[k], &p, &n2);
        assert_int_equal(n1, n2);
        assert_memory_equal(a, b, (size_t)n1 * 12);
        for (uint64_t i = 0; i < 3 * n1; i++)
            assert_true(isfinite(a[i]));
        free(a);
        free(b);
    }
    float bad_pos[3] = {0.0f, INFINITY, 0.0f};
    rto_splat s;
    assert_int_equal(rto_splat_make(&p, bad_pos, 1, 1, &s, &msg), RTO_ERR_INVALID_ARGUMENT);
}

/* rto__fluid_sample: at voxel centres the texel itself; elsewhere trilinear over the clamped neighbours, against a
 * binary64 evaluation here (binary32 coordinates and lerps: within 2^-16 of the largest texel). */
static void test_sample(void **state)
{
    (void)state;
    rto_fluid_params p = params(12, 10, 14, -1.0f, 1.0f, 0.3f, 1000.0f);
    uint64_t n;
    float *pos = gen("dambreak:300", &p, &n);
    rto_splat s;
    rto_msg msg = {{0}};
    assert_int_equal(rto_splat_make(&p, pos, n, 1, &s, &msg), RTO_OK);
    const double bmin[3] = {p.bounds.min.x, p.bounds.min.y, p.bounds.min.z};
    const double bmax[3] = {p.bounds.max.x, p.bounds.max.y, p.bounds.max.z};
    double top = 0.0;
    for (size_t v = 0; v < (size_t)12 * 10 * 14; v++)
        top = fmax(top, rto_f16_to_f32(s.volume_f16[v]));
    assert_true(top > 0.0);
    lcg_state = 5;
    for (int k = 0; k < 20000; k++) {
        float q[3];
        double t[3];
        for (int a = 0; a < 3; a++) {
            const double ext = bmax[a] - bmin[a];
            q[a] = (float)(bmin[a] - 0.1 * ext + 1.2 * ext * lcg_unit());
            if (k < 1000) /* exactly on a voxel centre */
                q[a] = (float)(bmin[a] + ((double)(lcg() % p.res[a]) + 0.5) * ext / p.res[a]);
            t[a] = ((double)q[a] - bmin[a]) / ext * p.res[a] - 0.5;
            t[a] = fmin(fmax(t[a], -1.0), (double)p.res[a]);
        }
        double acc = 0.0;
        for (int c = 0; c < 8; c++) {
            double w = 1.0;
            size_t id[3];
            for (int a = 0; a < 3; a++) {
                const double f = floor(t[a]), frac = t[a] - f;
                long i = (long)f + ((c >> a) & 1);
                i = i < 0 ? 0 : i > (long)p.res[a] - 1 ? (long)p.res[a] - 1 : i;
                id[a] = (size_t)i;
                w *= (c >> a) & 1 ? frac : 1.0 - frac;
            }
            acc += w * rto_f16_to_f32(s.volume_f16[(id[2] * p.res[1] + id[1]) * p.res[0] + id[0]]);
        }
        const double got = rto__fluid_sample(&s, q);
        if (fabs(got - acc) > top * 0x1p-16)
            fail_msg("sample (%g, %g, %g): %.9g, binary64 %.9g", q[0], q[1], q[2], got, acc);
    }
    rto_splat_free(&s);
    free(pos);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_brute_force),
        cmocka_unit_test(test_order_and_threads),
        cmocka_unit_test(test_overflow),
        cmocka_unit_test(test_occupancy),
        cmocka_unit_test(test_model_contains_reference),
        cmocka_unit_test(test_params_and_generators),
        cmocka_unit_test(test_sample),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
