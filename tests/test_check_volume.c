/* unit.check_volume: a GPU simulated here (its own splat, resolve and occupancy grid, written from the seed's
 * description: fused multiply-adds where a compiler may use them, particles in a shuffled order, binary16 stores
 * rounding either way) passes check-volume; each planted fault is caught and named with its class: rounding instead
 * of truncation, a radius one voxel too large or too small, an occupancy grid not dilated, a cleared occupied cell, a
 * resolve by integer division, binary16 truncation under --f16-rounding nearest, an overflowing voxel. */
#include "testutil.h"

typedef struct sim_opts {
    int fma;          /* c and r2 with fused multiply-adds */
    int shuffle;      /* particles in another order */
    int round;        /* u32(k * scale + 0.5): rounding instead of truncation */
    int radius_step;  /* -1, 0, +1: h moved by one voxel */
    int resolve_int;  /* f32(u / 1000) by integer division */
    int f16_rtz;      /* binary16 stores round toward zero */
    int undilated;    /* occupancy: only the cells holding a particle */
    int clear_cell;   /* occupancy: one required cell cleared (mips recomputed) */
    int rgba;         /* the f16 plane as rgba (density, 0, 0, 1) */
    int rgba_bad_alpha;
} sim_opts;

typedef struct sim_out {
    uint32_t *u32;
    uint16_t *f16;
    uint32_t *occ;
} sim_out;

static uint64_t lcg_state;
static uint32_t lcg(void)
{
    lcg_state = lcg_state * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(lcg_state >> 33);
}

/* binary16 of a non-negative float rounded toward zero, from its exponent and significand. */
static uint16_t f16_rtz(float f)
{
    if (f >= 65504.0f)
        return 0x7BFF;
    if (f < 0x1p-24f)
        return 0;
    int e;
    const float m = frexpf(f, &e); /* f = m 2^e, m in [0.5, 1) */
    if (e - 1 >= -14)
        return (uint16_t)(((uint32_t)(e - 1 + 15) << 10) | ((uint32_t)(m * 2048.0f) & 0x3FFu));
    return (uint16_t)(uint32_t)(f * 16777216.0f);
}

static void occ_set(const rto_splat *ref, uint32_t *w, uint32_t l, uint32_t x, uint32_t y, uint32_t z)
{
    const uint32_t r = ref->level_res[l];
    const uint64_t b = ((uint64_t)z * r + y) * r + x;
    w[ref->level_offset[l] + (b >> 5)] |= 1u << (b & 31);
}

static int occ_get(const rto_splat *ref, const uint32_t *w, uint32_t l, uint32_t x, uint32_t y, uint32_t z)
{
    const uint32_t r = ref->level_res[l];
    const uint64_t b = ((uint64_t)z * r + y) * r + x;
    return (int)(w[ref->level_offset[l] + (b >> 5)] >> (b & 31) & 1u);
}

/* The simulated GPU: clear, splat (one "thread" per particle, atomicAdd wrapping mod 2^32), resolve, occupancy. The
 * layout of the occupancy levels is the contract's (ref's level offsets and sizes). */
static void sim(const rto_fluid_uniforms *u, const float *pos0, uint64_t n, const sim_opts *o, const rto_splat *ref,
                sim_out *out)
{
    const uint32_t nx = (uint32_t)u->res[0], ny = (uint32_t)u->res[1], nz = (uint32_t)u->res[2];
    const size_t nv = (size_t)nx * ny * nz;
    float *pos = malloc((size_t)n * 12);
    memcpy(pos, pos0, (size_t)n * 12);
    if (o->shuffle) {
        lcg_state = 12345;
        for (uint64_t i = n - 1; i > 0; i--) {
            const uint64_t j = lcg() % (i + 1);
            for (int a = 0; a < 3; a++) {
                const float t = pos[3 * i + a];
                pos[3 * i + a] = pos[3 * j + a];
                pos[3 * j + a] = t;
            }
        }
    }
    out->u32 = calloc(nv, 4);
    const float h = u->radius + (float)o->radius_step * u->voxel_size[0];
    const uint32_t nn[3] = {nx, ny, nz};
    for (uint64_t i = 0; i < n; i++) {
        const float *p = pos + 3 * i;
        /* the voxels within h + 2 voxels on each axis, as a splat kernel's loop bounds */
        uint32_t lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            const double f = floor(((double)p[a] - u->bounds_min[a]) / u->voxel_size[a]);
            const double w = ceil((double)h / u->voxel_size[a]) + 2.0;
            lo[a] = f - w < 0.0 ? 0 : f - w > nn[a] - 1 ? nn[a] - 1 : (uint32_t)(f - w);
            hi[a] = f + w < 0.0 ? 0 : f + w > nn[a] - 1 ? nn[a] - 1 : (uint32_t)(f + w);
        }
        for (uint32_t z = lo[2]; z <= hi[2]; z++)
            for (uint32_t y = lo[1]; y <= hi[1]; y++)
                for (uint32_t x = lo[0]; x <= hi[0]; x++) {
                    const float id[3] = {(float)x + 0.5f, (float)y + 0.5f, (float)z + 0.5f};
                    float c[3], d[3];
                    for (int a = 0; a < 3; a++) {
                        if (o->fma) {
                            c[a] = fmaf(id[a], u->voxel_size[a], u->bounds_min[a]);
                        } else {
                            const float t = id[a] * u->voxel_size[a];
                            c[a] = u->bounds_min[a] + t;
                        }
                        d[a] = c[a] - p[a];
                    }
                    float r2;
                    if (o->fma) {
                        r2 = fmaf(d[2], d[2], fmaf(d[1], d[1], d[0] * d[0]));
                    } else {
                        const float xx = d[0] * d[0], yy = d[1] * d[1], zz = d[2] * d[2];
                        const float s = xx + yy;
                        r2 = s + zz;
                    }
                    const float r = sqrtf(r2);
                    if (!(r < h))
                        continue;
                    const float v = h - r;
                    const float vv = v * v;
                    const float k = vv * u->kernel_factor;
                    float ks = o->fma ? fmaf(k, u->scale, 0.0f) : k * u->scale;
                    if (o->round)
                        ks = ks + 0.5f;
                    const uint32_t add = ks >= 4294967296.0f ? UINT32_MAX : (uint32_t)ks;
                    out->u32[((size_t)z * ny + y) * nx + x] += add;
                }
    }
    const uint32_t ch = o->rgba ? 4 : 1;
    out->f16 = calloc(nv * ch, 2);
    for (size_t v = 0; v < nv; v++) {
        const uint32_t w = out->u32[v];
        const float f = o->resolve_int ? (float)(w / 1000u) : (float)w / u->scale;
        out->f16[v * ch] = o->f16_rtz ? f16_rtz(f) : rto_f16_from_f32(f);
        if (o->rgba)
            out->f16[v * ch + 3] = o->rgba_bad_alpha ? 0 : 0x3C00;
    }
    out->occ = calloc((size_t)ref->occupancy_words, 4);
    const uint32_t O = (uint32_t)u->occupancy;
    uint32_t first[3] = {UINT32_MAX, 0, 0};
    for (uint64_t i = 0; i < n; i++) {
        uint32_t c0[3], c1[3];
        int any = 1;
        for (int a = 0; a < 3; a++) {
            const double bmin = u->bounds_min[a], bmax = u->bounds_max[a], cs = (bmax - bmin) / O;
            const double R = o->undilated ? 0.0 : (double)u->radius * (1.0 + 0x1p-12) + (double)u->voxel_size[a];
            const double lo = pos[3 * i + a] - R, hi = pos[3 * i + a] + R;
            if (hi < bmin || lo > bmax)
                any = 0;
            const double f0 = o->undilated ? floor((lo - bmin) / cs) : ceil((lo - bmin) / cs) - 1.0;
            const double f1 = floor((hi - bmin) / cs);
            c0[a] = f0 < 0.0 ? 0 : f0 > O - 1 ? O - 1 : (uint32_t)f0;
            c1[a] = f1 < 0.0 ? 0 : f1 > O - 1 ? O - 1 : (uint32_t)f1;
        }
        if (!any)
            continue;
        if (first[0] == UINT32_MAX)
            memcpy(first, c0, sizeof first);
        for (uint32_t z = c0[2]; z <= c1[2]; z++)
            for (uint32_t y = c0[1]; y <= c1[1]; y++)
                for (uint32_t x = c0[0]; x <= c1[0]; x++)
                    occ_set(ref, out->occ, 0, x, y, z);
    }
    if (o->clear_cell) { /* the cell holding the first particle: certainly required */
        const float *p = pos0;
        uint32_t c[3];
        for (int a = 0; a < 3; a++) {
            const double bmin = u->bounds_min[a], cs = ((double)u->bounds_max[a] - bmin) / O;
            c[a] = (uint32_t)floor((p[a] - bmin) / cs);
        }
        const uint64_t b = ((uint64_t)c[2] * O + c[1]) * O + c[0];
        out->occ[b >> 5] &= ~(1u << (b & 31));
    }
    for (uint32_t l = 0; l + 1 < ref->occupancy_levels; l++) {
        const uint32_t r = ref->level_res[l];
        for (uint32_t z = 0; z < r; z++)
            for (uint32_t y = 0; y < r; y++)
                for (uint32_t x = 0; x < r; x++)
                    if (occ_get(ref, out->occ, l, x, y, z))
                        occ_set(ref, out->occ, l + 1, x / 2, y / 2, z / 2);
    }
    free(pos);
}

static void sim_free(sim_out *s)
{
    free(s->u32);
    free(s->f16);
    free(s->occ);
}

/* Simulates with o and checks; returns the report's fault name (static storage). */
static const char *run_case(const char *spec, const rto_fluid_params *p, const sim_opts *o, int nearest,
                            rto_report *r)
{
    uint64_t n;
    float *pos = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_fluid_generate(spec, p, &pos, &n, &msg), RTO_OK);
    rto_splat ref;
    assert_int_equal(rto_splat_make(p, pos, n, 2, &ref, &msg), RTO_OK);
    sim_out g;
    sim(&ref.uniforms, pos, n, o, &ref, &g);
    const size_t nv = (size_t)p->res[0] * p->res[1] * p->res[2];
    const rto_volume_dump d = {g.u32, nv, g.f16, nv * (o->rgba ? 4 : 1), g.occ, ref.occupancy_words};
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, nearest, 2, r, &msg), RTO_OK);
    sim_free(&g);
    rto_splat_free(&ref);
    free(pos);
    return r->fault;
}

static rto_fluid_params small(uint32_t res, float h)
{
    rto_fluid_params p;
    rto_fluid_params_default(&p);
    p.res[0] = p.res[1] = p.res[2] = res;
    p.bounds.min = (rto_vec3){-1.0f, -0.9f, -1.1f};
    p.bounds.max = (rto_vec3){1.0f, 1.2f, 0.9f};
    p.radius = h;
    p.occupancy = 8;
    return p;
}

static void expect(const char *spec, const rto_fluid_params *p, const sim_opts *o, int nearest, const char *fault)
{
    rto_report r;
    const char *got = run_case(spec, p, o, nearest, &r);
    if (strcmp(got, fault))
        fail_msg("%s: fault %s, want %s: %s", spec, got, fault, r.summary);
    if (strcmp(fault, "none") && !strstr(r.summary, fault))
        fail_msg("%s: the summary does not name %s: %s", spec, fault, r.summary);
}

/* Controls: conforming GPUs pass. */
static void test_controls(void **state)
{
    (void)state;
    const rto_fluid_params p = small(24, 0.2f), q = small(28, 0.13f);
    const sim_opts plain = {0}, fused = {.fma = 1, .shuffle = 1}, rtz = {.fma = 1, .f16_rtz = 1},
                   rgba = {.shuffle = 1, .rgba = 1};
    const char *specs[] = {TU_SIZED("dambreak:400", "dambreak:150"), "single", "lattice", "splash:300"};
    for (size_t k = 0; k < 4; k++) {
        expect(specs[k], &p, &plain, 1, "none");
        expect(specs[k], &p, &fused, 1, "none");
        expect(specs[k], &q, &fused, 0, "none");
        expect(specs[k], &q, &rtz, 0, "none");
        expect(specs[k], &p, &rgba, 1, "none");
    }
}

/* Planted faults, each named. */
static void test_faults(void **state)
{
    (void)state;
    const rto_fluid_params p = small(24, 0.2f);
    const char *specs[] = {TU_SIZED("dambreak:400", "dambreak:150"), "single", "splash:300"};
    for (size_t k = 0; k < 3; k++) {
        expect(specs[k], &p, &(sim_opts){.fma = 1, .round = 1}, 0, "contribution");
        expect(specs[k], &p, &(sim_opts){.radius_step = 1}, 0, "radius");
        expect(specs[k], &p, &(sim_opts){.radius_step = -1, .shuffle = 1}, 0, "radius");
        expect(specs[k], &p, &(sim_opts){.undilated = 1}, 0, "occupancy");
        expect(specs[k], &p, &(sim_opts){.clear_cell = 1}, 0, "occupancy");
        expect(specs[k], &p, &(sim_opts){.resolve_int = 1}, 0, "resolve");
        expect(specs[k], &p, &(sim_opts){.resolve_int = 1}, 1, "resolve");
        if (k != 1) /* the single particle's few distinct densities all happen to round down in binary16 */
            expect(specs[k], &p, &(sim_opts){.f16_rtz = 1, .fma = 1}, 1, "resolve-rounding");
        expect(specs[k], &p, &(sim_opts){.rgba = 1, .rgba_bad_alpha = 1}, 0, "resolve");
    }
    /* an overflowing voxel: named even though the GPU holds exactly the wrapped sum */
    rto_fluid_params o = small(16, 0.3f);
    o.scale = 16777216.0f;
    rto_report r;
    const char *got = run_case("dambreak:400", &o, &(sim_opts){0}, 0, &r);
    assert_string_equal(got, "overflow");
    assert_non_null(strstr(r.summary, "passes 2^32 - 1"));
    assert_true(r.nrows >= 1);
    /* the first wrong voxel of a rounding GPU names the particles that reach it */
    got = run_case("single", &p, &(sim_opts){.round = 1}, 0, &r);
    assert_string_equal(got, "contribution");
    assert_int_equal(r.nrows, 1);
    assert_int_equal(r.rows[0].index, 0);
    int64_t x;
    assert_true(rto_report_where(&r, "x", &x) && rto_report_where(&r, "voxel", &x));
}

/* A dump of the wrong size is a shape fault; a required array missing is refused. */
static void test_shape(void **state)
{
    (void)state;
    const rto_fluid_params p = small(12, 0.3f);
    uint64_t n;
    float *pos = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_fluid_generate("single", &p, &pos, &n, &msg), RTO_OK);
    rto_splat ref;
    assert_int_equal(rto_splat_make(&p, pos, n, 1, &ref, &msg), RTO_OK);
    rto_report r;
    rto_volume_dump d = {ref.volume_u32, 12 * 12 * 12 - 1, NULL, 0, NULL, 0};
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, 0, 1, &r, &msg), RTO_OK);
    assert_string_equal(r.fault, "shape");
    d.u32_count++;
    d.volume_f16 = ref.volume_f16;
    d.f16_count = 12 * 12 * 12 * 2;
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, 0, 1, &r, &msg), RTO_OK);
    assert_string_equal(r.fault, "shape");
    d.f16_count = 12 * 12 * 12;
    d.occupancy = ref.occupancy;
    d.occupancy_words = ref.occupancy_words - 1;
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, 0, 1, &r, &msg), RTO_OK);
    assert_string_equal(r.fault, "shape");
    d.occupancy_words++;
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, 1, 1, &r, &msg), RTO_OK);
    assert_string_equal(r.fault, "none");
    d.volume_u32 = NULL;
    assert_int_equal(rto_volume_check(&ref, pos, n, &d, 0, 1, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_splat_free(&ref);
    free(pos);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_controls),
        cmocka_unit_test(test_faults),
        cmocka_unit_test(test_shape),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
