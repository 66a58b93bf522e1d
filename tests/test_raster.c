/* The visibility pass's reference rasterizer (src/raster/raster.c, DESIGN.md §11.1-11.4) against references of its
 * own: a brute-force rasterizer (every sample, every triangle, exact integers on the snapped p = 8 positions, the
 * top-left rule as a symbolic perturbation of the sample, (x + e, y + e^2), instead of the implementation's per-edge
 * classes), with the fill rule flipped as a control; watertightness and the top-left rule on samples exactly on
 * edges; admissible sets against an unsnapped binary64 rasterizer on random perspective scenes; perspective-correct
 * barycentrics against the ray-plane closed form (and unlike affine ones); depth and its unorm24 rounding against
 * integer arithmetic; identical bytes for 1, 2 and 3 threads; a triangle through the near plane; bad arguments. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "raster/raster_internal.h"

/* ---------------------------------------------------------------------------------------------------------------- */
/* Scenes                                                                                                             */

typedef struct tscene {
    rto_mesh mesh;
    rto_instance inst[4];
    uint32_t inst_count;
    rto_vbuffer_camera cam;
    float pos[3 * 3 * 512];
    uint32_t idx[3 * 512];
    uint32_t ntri;
} tscene;

static uint32_t rng_state;
static double urand(void)
{
    rng_state = rng_state * 1664525u + 1013904223u;
    return (double)(rng_state >> 8) / 16777216.0;
}

static void identity(rto_instance *in)
{
    memset(in, 0, sizeof *in);
    for (int r = 0; r < 3; r++) {
        in->obj_to_world.m[r][r] = 1.0f;
        in->world_to_obj.m[r][r] = 1.0f;
    }
}

static void scene_init(tscene *s)
{
    memset(s, 0, sizeof *s);
    s->inst_count = 1;
    identity(&s->inst[0]);
    for (int k = 0; k < 4; k++) /* identity view_proj: clip = (x, y, z, 1) */
        s->cam.view_proj[5 * k] = 1.0f;
}

static void add_tri(tscene *s, const float v[9])
{
    assert_true(s->ntri < 512);
    memcpy(s->pos + 9 * s->ntri, v, 9 * sizeof(float));
    for (int k = 0; k < 3; k++)
        s->idx[3 * s->ntri + k] = 3 * s->ntri + (uint32_t)k;
    s->ntri++;
}

/* A triangle given by window positions (pixels) under the identity view_proj of a w x h image (w, h powers of 2, so
 * that the inverse mapping is exact): x = 2 x_w / w - 1, y = 1 - 2 y_w / h. */
static void add_win(tscene *s, uint32_t w, uint32_t h, const double xy[6], const double z[3])
{
    float v[9];
    for (int k = 0; k < 3; k++) {
        v[3 * k] = (float)(2.0 * xy[2 * k] / w - 1.0);
        v[3 * k + 1] = (float)(1.0 - 2.0 * xy[2 * k + 1] / h);
        v[3 * k + 2] = (float)z[k];
    }
    add_tri(s, v);
}

static rto_vbuffer_geometry scene_geom(tscene *s)
{
    s->mesh.vertex_count = 3 * s->ntri;
    s->mesh.positions = s->pos;
    s->mesh.triangle_count = s->ntri;
    s->mesh.indices = s->idx;
    s->mesh.material = -1;
    for (uint32_t i = 0; i < s->inst_count; i++)
        s->inst[i].blas = 0;
    return (rto_vbuffer_geometry){&s->mesh, 1, s->inst, s->inst_count};
}

static void make(tscene *s, uint32_t w, uint32_t h, uint32_t samples, uint32_t threads, rto_vbuffer *vb)
{
    rto_vbuffer_geometry g = scene_geom(s);
    rto_vbuffer_desc d = {w, h, samples, threads};
    rto_msg msg = {{0}};
    const rto_status st = rto_vbuffer_make(&g, &s->cam, &d, vb, &msg);
    if (st != RTO_OK)
        fprintf(stderr, "rto_vbuffer_make: %s\n", msg.text);
    assert_int_equal(st, RTO_OK);
}

/* The test's own vertex stage (§11.1): binary32 objToWorld then view_proj, window coordinates in binary64. */
typedef struct tvert {
    float clip[4];
    double xw, yw, z;
} tvert;

static tvert vertex(const tscene *s, uint32_t inst, uint32_t vi, uint32_t w, uint32_t h)
{
    const float *p = s->pos + 3 * vi;
    const float(*m)[4] = s->inst[inst].obj_to_world.m;
    float wp[3];
    for (int r = 0; r < 3; r++)
        wp[r] = ((m[r][0] * p[0] + m[r][1] * p[1]) + m[r][2] * p[2]) + m[r][3];
    const float *vp = s->cam.view_proj;
    tvert v;
    for (int r = 0; r < 4; r++)
        v.clip[r] = ((vp[r] * wp[0] + vp[4 + r] * wp[1]) + vp[8 + r] * wp[2]) + vp[12 + r];
    v.xw = (((double)v.clip[0] / v.clip[3]) * 0.5 + 0.5) * w;
    v.yw = (0.5 - ((double)v.clip[1] / v.clip[3]) * 0.5) * h;
    v.z = (double)v.clip[2] / v.clip[3];
    return v;
}

static void sample_units(uint32_t samples, uint32_t s, long long *ox, long long *oy)
{
    static const int o4[4][2] = {{3, 1}, {7, 3}, {1, 5}, {5, 7}}; /* eighths: WebGPU's standard 4x positions */
    if (samples == 4) {
        *ox = 32LL * o4[s][0];
        *oy = 32LL * o4[s][1];
    } else {
        *ox = *oy = 128;
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The brute-force reference (p = 8)                                                                                  */

/* Inside the triangle of snapped positions (1/256 px), a sample exactly on an edge decided by moving it to
 * (X + e, Y + e^2) for an infinitesimal e > 0 (down and right, y down: a top or left edge keeps it); flip moves it
 * up and left (the bottom-right rule, the control). */
static int bf_inside(const long long vx[3], const long long vy[3], long long X, long long Y, int flip)
{
    const long long area = (vx[1] - vx[0]) * (vy[2] - vy[0]) - (vx[2] - vx[0]) * (vy[1] - vy[0]);
    if (area == 0)
        return 0;
    const long long o = area > 0 ? 1 : -1, f = flip ? -1 : 1;
    for (int e = 0; e < 3; e++) {
        const int a = e, b = (e + 1) % 3;
        const long long dx = vx[b] - vx[a], dy = vy[b] - vy[a];
        const long long c0 = o * (dx * (Y - vy[a]) - dy * (X - vx[a])), c1 = o * f * -dy, c2 = o * f * dx;
        if (c0 < 0 || (c0 == 0 && (c1 < 0 || (c1 == 0 && c2 <= 0))))
            return 0;
    }
    return 1;
}

typedef struct bf_tri {
    long long vx[3], vy[3];
    double z[3];
    uint32_t inst, prim;
} bf_tri;

static bf_tri *bf_setup(const tscene *s, uint32_t w, uint32_t h, uint32_t *n)
{
    bf_tri *t = calloc(s->inst_count * (size_t)s->ntri + 1, sizeof *t);
    assert_non_null(t);
    *n = 0;
    for (uint32_t i = 0; i < s->inst_count; i++)
        for (uint32_t p = 0; p < s->ntri; p++) {
            bf_tri *b = &t[(*n)++];
            b->inst = i;
            b->prim = p;
            for (int k = 0; k < 3; k++) {
                const tvert v = vertex(s, i, s->idx[3 * p + k], w, h);
                b->vx[k] = (long long)nearbyint(v.xw * 256.0);
                b->vy[k] = (long long)nearbyint(v.yw * 256.0);
                b->z[k] = v.z;
            }
        }
    return t;
}

/* The reference winner of one sample: index into t, or -1 (background). */
static int bf_sample(const bf_tri *t, uint32_t n, long long X, long long Y, int flip, float *depth)
{
    int win = -1;
    float best = 1.0f;
    for (uint32_t i = 0; i < n; i++) {
        if (!bf_inside(t[i].vx, t[i].vy, X, Y, flip))
            continue;
        const long long *x = t[i].vx, *y = t[i].vy;
        const double a = (double)((x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]));
        double l[3];
        for (int k = 0; k < 3; k++) { /* lambda_k: the edge opposite vertex k at the sample over twice the area */
            const int p = (k + 1) % 3, q = (k + 2) % 3;
            l[k] = (double)((x[q] - x[p]) * (Y - y[p]) - (y[q] - y[p]) * (X - x[p])) / a;
        }
        double z = (l[0] * t[i].z[0] + l[1] * t[i].z[1]) + l[2] * t[i].z[2];
        z = z < 0.0 ? 0.0 : (z > 1.0 ? 1.0 : z);
        if ((float)z < best) {
            best = (float)z;
            win = (int)i;
        }
    }
    *depth = best;
    return win;
}

static void vis_id(const rto_vbuffer *vb, size_t k, uint32_t *inst, uint32_t *prim)
{
    const uint16_t *v = vb->planes.visibility + 4 * k;
    *prim = v[0] | (uint32_t)v[1] << 16;
    *inst = v[2] | (uint32_t)v[3] << 16;
}

/* Samples where the planes differ from the brute force (IDs, coverage, depth), printed up to a few. */
static size_t bf_compare(const tscene *s, const rto_vbuffer *vb, int flip, int quiet)
{
    const uint32_t w = vb->planes.width, h = vb->planes.height, S = vb->planes.samples;
    uint32_t n;
    bf_tri *t = bf_setup(s, w, h, &n);
    size_t bad = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (uint32_t si = 0; si < S; si++) {
                long long ox, oy;
                sample_units(S, si, &ox, &oy);
                float depth;
                const int win = bf_sample(t, n, 256LL * x + ox, 256LL * y + oy, flip, &depth);
                const size_t k = ((size_t)y * w + x) * S + si;
                uint32_t inst, prim;
                vis_id(vb, k, &inst, &prim);
                const int ok = win < 0 ? (inst == RTO_VB_BACKGROUND && prim == RTO_VB_BACKGROUND &&
                                          vb->planes.depth[k] == 1.0f)
                                       : (inst == t[win].inst && prim == t[win].prim && vb->planes.depth[k] == depth);
                if (!ok && !quiet && bad < 5)
                    fprintf(stderr, "  (%u, %u) sample %u: brute force %d (%u, %u) depth %.9g, planes (%u, %u) %.9g\n", x,
                            y, si, win, win < 0 ? 0xFFFFFFFFu : t[win].inst, win < 0 ? 0xFFFFFFFFu : t[win].prim,
                            (double)depth, inst, prim, (double)vb->planes.depth[k]);
                bad += !ok;
            }
    free(t);
    return bad;
}

/* The admissible set's structure: offsets ascend, every set is non-empty, in draw order, background last; the
 * reference's answer is a member; the statistics add up. */
static int in_set(const rto_vbuffer *vb, size_t k, uint32_t inst, uint32_t prim)
{
    for (uint32_t i = vb->admissible_offset[k]; i < vb->admissible_offset[k + 1]; i++)
        if (vb->admissible[2 * (size_t)i] == inst && vb->admissible[2 * (size_t)i + 1] == prim)
            return 1;
    return 0;
}

static void check_sets(const rto_vbuffer *vb)
{
    const size_t n = (size_t)vb->planes.width * vb->planes.height * vb->planes.samples;
    assert_int_equal(vb->admissible_offset[0], 0);
    uint64_t sizes[5] = {0}, covered = 0;
    uint32_t maxs = 0;
    for (size_t k = 0; k < n; k++) {
        const uint32_t a = vb->admissible_offset[k], b = vb->admissible_offset[k + 1];
        assert_true(b > a);
        for (uint32_t i = a; i + 1 < b; i++) { /* draw order, background last */
            const uint32_t *p = vb->admissible + 2 * (size_t)i, *q = p + 2;
            assert_true(p[0] != RTO_VB_BACKGROUND);
            assert_true(q[0] > p[0] || (q[0] == p[0] && q[1] > p[1]));
        }
        uint32_t inst, prim;
        vis_id(vb, k, &inst, &prim);
        assert_true(in_set(vb, k, inst, prim)); /* background: 0xFFFF x 4, RTO_VB_BACKGROUND twice */
        covered += inst != 0xFFFFFFFFu;
        sizes[(b - a < 5 ? b - a : 5) - 1]++;
        maxs = b - a > maxs ? b - a : maxs;
    }
    assert_int_equal(vb->stats.samples, n);
    assert_int_equal(vb->stats.covered, covered);
    assert_int_equal(vb->stats.max_set, maxs);
    for (int i = 0; i < 5; i++)
        assert_int_equal(vb->stats.set_sizes[i], sizes[i]);
    assert_int_equal(vb->stats.certain, sizes[0]);
    assert_int_equal(vb->stats.uncertain, n - sizes[0]);
}

/* Random triangles under the identity view_proj: window positions continuous (grid = 0) or on a 1/grid px grid,
 * depths in [0.05, 0.95]. */
static void random_flat(tscene *s, uint32_t w, uint32_t h, uint32_t ntri, double grid, double size)
{
    scene_init(s);
    for (uint32_t i = 0; i < ntri; i++) {
        double xy[6], z[3];
        const double cx = urand() * w, cy = urand() * h;
        for (int k = 0; k < 3; k++) {
            xy[2 * k] = cx + (urand() - 0.5) * size;
            xy[2 * k + 1] = cy + (urand() - 0.5) * size;
            if (grid > 0) {
                xy[2 * k] = floor(xy[2 * k] * grid) / grid;
                xy[2 * k + 1] = floor(xy[2 * k + 1] * grid) / grid;
            }
            z[k] = 0.05 + 0.9 * urand();
        }
        add_win(s, w, h, xy, z);
    }
}

static void test_brute_force(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    size_t control = 0;
    for (uint32_t seed = 1; seed <= 12; seed++) {
        rng_state = seed;
        const uint32_t S = seed % 2 ? 1 : 4;
        const double grid = seed % 3 == 0 ? 0.0 : (seed % 3 == 1 ? 2.0 : 16.0);
        random_flat(s, 64, 64, 40 + seed * 5, grid, 8.0 + 3.0 * seed);
        if (seed % 4 == 0) { /* a second, translated instance */
            s->inst_count = 2;
            identity(&s->inst[1]);
            s->inst[1].obj_to_world.m[0][3] = 0.125f;
            s->inst[1].obj_to_world.m[1][3] = -0.0625f;
        }
        rto_vbuffer vb;
        make(s, 64, 64, S, 2, &vb);
        const size_t bad = bf_compare(s, &vb, 0, 0);
        if (bad)
            fprintf(stderr, "seed %u: %zu samples differ\n", seed, bad);
        assert_int_equal(bad, 0);
        check_sets(&vb);
        if (grid > 0)
            control += bf_compare(s, &vb, 1, 1);
        rto_vbuffer_free(&vb);
    }
    /* Control: the brute force with the bottom-right rule disagrees on the grid scenes (samples on edges). */
    assert_true(control > 0);
    free(s);
}

/* A perspective camera (rto_vbuffer_camera_make) over random 3D triangles, against the brute force too. */
static void perspective_scene(tscene *s, uint32_t w, uint32_t h, uint32_t ntri, double size)
{
    scene_init(s);
    rto_camera cam = {.position = {0.3f, 0.5f, 3.0f}, .target = {0, 0, 0}, .up = {0, 1, 0}, .fov_y = 1.0f,
                      .znear = 0.5f, .zfar = 20.0f};
    rto_msg msg = {{0}};
    assert_int_equal(rto_vbuffer_camera_make(&cam, w, h, &s->cam, &msg), RTO_OK);
    for (uint32_t i = 0; i < ntri; i++) {
        float v[9];
        const double c[3] = {(urand() - 0.5) * 2.0, (urand() - 0.5) * 2.0, (urand() - 0.5) * 2.0};
        for (int k = 0; k < 9; k++)
            v[k] = (float)(c[k % 3] + (urand() - 0.5) * size);
        add_tri(s, v);
    }
}

static void test_brute_force_perspective(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    for (uint32_t seed = 20; seed < 24; seed++) {
        rng_state = seed;
        perspective_scene(s, 96, 64, 120, 0.8);
        rto_vbuffer vb;
        make(s, 96, 64, seed % 2 ? 4 : 1, 3, &vb);
        assert_int_equal(vb.stats.clipped_triangles, 0);
        assert_int_equal(bf_compare(s, &vb, 0, 0), 0);
        check_sets(&vb);
        rto_vbuffer_free(&vb);
    }
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Watertightness and the top-left rule                                                                               */

static int covered_by(const rto_vbuffer *vb, size_t k, uint32_t prim)
{
    uint32_t inst, p;
    vis_id(vb, k, &inst, &p);
    return inst == 0 && p == prim;
}

static void test_watertight_top_left(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    /* A rectangle [4.5, 30.5] x [8.5, 20.5] (1x: pixel centres on all four edges) as two triangles along a diagonal
     * through pixel centres ((4.5, 8.5) to (16.5, 20.5) is not a diagonal of it: use a square for that below). */
    scene_init(s);
    const double z[3] = {0.5, 0.5, 0.5};
    add_win(s, 64, 64, (double[]){4.5, 8.5, 30.5, 8.5, 30.5, 20.5}, z);
    add_win(s, 64, 64, (double[]){4.5, 8.5, 30.5, 20.5, 4.5, 20.5}, z);
    rto_vbuffer vb;
    make(s, 64, 64, 1, 1, &vb);
    for (uint32_t y = 0; y < 64; y++)
        for (uint32_t x = 0; x < 64; x++) {
            const size_t k = (size_t)y * 64 + x;
            const int want = x >= 4 && x < 30 && y >= 8 && y < 20; /* top and left edges in, bottom and right out */
            uint32_t inst, p;
            vis_id(&vb, k, &inst, &p);
            assert_int_equal(inst != 0xFFFFFFFFu, want);
        }
    rto_vbuffer_free(&vb);

    /* A square (8, 8)-(40, 40) split along both diagonals in turn, both windings: every pixel centre of the square
     * is covered exactly once by the two triangles drawn alone, including the 32 on the shared diagonal. */
    for (int variant = 0; variant < 4; variant++) {
        double a[6], b[6];
        if (variant < 2) { /* diagonal (8, 8)-(40, 40) */
            memcpy(a, (double[]){8, 8, 40, 8, 40, 40}, sizeof a);
            memcpy(b, (double[]){8, 8, 40, 40, 8, 40}, sizeof b);
        } else { /* diagonal (40, 8)-(8, 40) */
            memcpy(a, (double[]){8, 8, 40, 8, 8, 40}, sizeof a);
            memcpy(b, (double[]){40, 8, 40, 40, 8, 40}, sizeof b);
        }
        if (variant % 2) { /* the other winding */
            double t[2];
            memcpy(t, a + 2, sizeof t);
            memcpy(a + 2, a + 4, sizeof t);
            memcpy(a + 4, t, sizeof t);
        }
        /* 1x: pixel centres lie on both diagonals; 4x: none does, every sample still covered once. */
        const uint32_t S = variant == 3 ? 4 : 1;
        rto_vbuffer va, vb2, vab;
        scene_init(s);
        add_win(s, 64, 64, a, z);
        make(s, 64, 64, S, 1, &va);
        scene_init(s);
        add_win(s, 64, 64, b, z);
        make(s, 64, 64, S, 1, &vb2);
        scene_init(s);
        add_win(s, 64, 64, a, z);
        add_win(s, 64, 64, b, z);
        make(s, 64, 64, S, 2, &vab);
        size_t on_diagonal = 0;
        for (uint32_t y = 0; y < 64; y++)
            for (uint32_t x = 0; x < 64; x++)
                for (uint32_t si = 0; si < S; si++) {
                    const size_t k = ((size_t)y * 64 + x) * S + si;
                    long long ox, oy;
                    sample_units(S, si, &ox, &oy);
                    const long long X = 256LL * x + ox, Y = 256LL * y + oy;
                    const int inside = X > 8 * 256 && X < 40 * 256 && Y > 8 * 256 && Y < 40 * 256;
                    const int ca = covered_by(&va, k, 0), cb = covered_by(&vb2, k, 0);
                    assert_int_equal(ca + cb, inside);
                    assert_int_equal(covered_by(&vab, k, 0) + covered_by(&vab, k, 1), inside);
                    on_diagonal += inside && (variant < 2 ? X == Y : X + Y == 48 * 256);
                }
        assert_true(S == 4 || on_diagonal == 32); /* the diagonal's 32 centres, all strictly inside the square */
        rto_vbuffer_free(&va);
        rto_vbuffer_free(&vb2);
        rto_vbuffer_free(&vab);
    }
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Admissible sets against an unsnapped binary64 rasterizer                                                           */

static double seg_dist(double px, double py, double ax, double ay, double bx, double by)
{
    const double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    double t = l2 > 0 ? ((px - ax) * dx + (py - ay) * dy) / l2 : 0.0;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    return hypot(px - (ax + t * dx), py - (ay + t * dy));
}

static void test_admissible_unsnapped(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    size_t far_checked = 0, uncertain = 0;
    for (uint32_t seed = 100; seed < 108; seed++) {
        rng_state = seed;
        const uint32_t w = 80, h = 60, S = seed % 2 ? 4 : 1;
        perspective_scene(s, w, h, 150, 0.7);
        rto_vbuffer vb;
        make(s, w, h, S, 2, &vb);
        check_sets(&vb);
        tvert *v = malloc(3 * (size_t)s->ntri * sizeof *v);
        assert_non_null(v);
        for (uint32_t i = 0; i < 3 * s->ntri; i++)
            v[i] = vertex(s, 0, s->idx[i], w, h);
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++)
                for (uint32_t si = 0; si < S; si++) {
                    long long ox, oy;
                    sample_units(S, si, &ox, &oy);
                    const double px = x + ox / 256.0, py = y + oy / 256.0;
                    const size_t k = ((size_t)y * w + x) * S + si;
                    int win = -1, near_edge = 0;
                    double best = 1.0, zs[512];
                    int nz = 0;
                    for (uint32_t t = 0; t < s->ntri; t++) {
                        const tvert *a = &v[3 * t], *b = a + 1, *c = a + 2;
                        for (int e = 0; e < 3; e++) {
                            const tvert *p = &v[3 * t + e], *q = &v[3 * t + (e + 1) % 3];
                            near_edge |= seg_dist(px, py, p->xw, p->yw, q->xw, q->yw) < 0.1;
                        }
                        const double area = (b->xw - a->xw) * (c->yw - a->yw) - (c->xw - a->xw) * (b->yw - a->yw);
                        const double l0 = ((c->xw - b->xw) * (py - b->yw) - (c->yw - b->yw) * (px - b->xw)) / area;
                        const double l1 = ((a->xw - c->xw) * (py - c->yw) - (a->yw - c->yw) * (px - c->xw)) / area;
                        const double l2 = ((b->xw - a->xw) * (py - a->yw) - (b->yw - a->yw) * (px - a->xw)) / area;
                        if (!(l0 > 0 && l1 > 0 && l2 > 0))
                            continue;
                        const double z = l0 * a->z + l1 * b->z + l2 * c->z;
                        zs[nz++] = z;
                        if (z < best) {
                            best = z;
                            win = (int)t;
                        }
                    }
                    /* The unsnapped answer is admissible. */
                    assert_true(in_set(&vb, k, win < 0 ? RTO_VB_BACKGROUND : 0,
                                       win < 0 ? RTO_VB_BACKGROUND : (uint32_t)win));
                    /* Far from every edge, depths apart: certain. */
                    int depth_close = 0;
                    for (int i = 0; i < nz; i++)
                        depth_close |= zs[i] != best && fabs(zs[i] - best) < 1e-3;
                    const uint32_t size = vb.admissible_offset[k + 1] - vb.admissible_offset[k];
                    if (!near_edge && !depth_close && best < 0.999) {
                        far_checked++;
                        assert_int_equal(size, 1);
                    }
                    uncertain += size > 1;
                }
        free(v);
        rto_vbuffer_free(&vb);
    }
    assert_true(far_checked > 10000);
    assert_true(uncertain > 0);
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Cracks: a GPU's precision is global (§11.3)                                                                        */

/* Does x round unambiguously at every precision p = 4..8 (more than 2^-11 px from each midpoint: the oracle's 2^-12
 * and the binary32 rounding of the test's vertex stage far inside)? */
static int snaps_cleanly(double x)
{
    for (int p = 4; p <= 8; p++) {
        const double v = ldexp(x, p), f = v - floor(v);
        if (fabs(f - 0.5) <= ldexp(0x1p-11, p))
            return 0;
    }
    return 1;
}

static int has_background(const rto_vbuffer *vb, size_t k)
{
    return in_set(vb, k, RTO_VB_BACKGROUND, RTO_VB_BACKGROUND);
}

static void test_shared_edge_no_crack(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    const uint32_t w = 128, h = 128;
    /* Two triangles sharing the edge P0-P1, vertices off the 1/16 px grid (each snaps differently at each p) and
     * halfway between the 2^-9 px points where the midpoints of every p lie, one depth: every sample near the shared
     * edge is the one's or the other's at any global precision. */
    const double P[4][2] = {{10539.5 / 512, 5355.5 / 512}, {51991.5 / 512, 41531.5 / 512},
                            {8333.5 / 512, 57243.5 / 512}, {59823.5 / 512, 12633.5 / 512}};
    const double z[3] = {0.5, 0.5, 0.5};
    const double A[6] = {P[0][0], P[0][1], P[1][0], P[1][1], P[2][0], P[2][1]};
    const double B[6] = {P[0][0], P[0][1], P[3][0], P[3][1], P[1][0], P[1][1]};
    rto_vbuffer vab, va, vbb;
    scene_init(s);
    add_win(s, w, h, A, z);
    add_win(s, w, h, B, z);
    make(s, w, h, 4, 2, &vab);
    check_sets(&vab);
    tvert v[4];
    v[0] = vertex(s, 0, 0, w, h);
    v[1] = vertex(s, 0, 1, w, h);
    for (int k = 0; k < 2; k++) {
        assert_true(snaps_cleanly(v[k].xw) && snaps_cleanly(v[k].yw));
        assert_true(fabs(v[k].xw - ldexp(rint(ldexp(v[k].xw, 4)), -4)) > 0x1p-8); /* well off the 1/16 grid */
        assert_true(fabs(v[k].yw - ldexp(rint(ldexp(v[k].yw, 4)), -4)) > 0x1p-8);
    }
    scene_init(s);
    add_win(s, w, h, A, z);
    make(s, w, h, 4, 1, &va);
    scene_init(s);
    add_win(s, w, h, B, z);
    make(s, w, h, 4, 1, &vbb);
    size_t near = 0, both = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (uint32_t si = 0; si < 4; si++) {
                long long ox, oy;
                sample_units(4, si, &ox, &oy);
                const double px = x + ox / 256.0, py = y + oy / 256.0;
                const size_t k = ((size_t)y * w + x) * 4 + si;
                const double d = seg_dist(px, py, v[0].xw, v[0].yw, v[1].xw, v[1].yw);
                if (!(d < 0.03) || hypot(px - v[0].xw, py - v[0].yw) < 1.0 || hypot(px - v[1].xw, py - v[1].yw) < 1.0)
                    continue;
                near++;
                /* Drawn together: no crack, whatever each triangle does alone. */
                assert_false(has_background(&vab, k));
                const uint32_t size = vab.admissible_offset[k + 1] - vab.admissible_offset[k];
                assert_true(size >= 1 && size <= 2);
                assert_true(in_set(&vab, k, 0, 0) || in_set(&vab, k, 0, 1));
                if (!(in_set(&vab, k, 0, 0) && in_set(&vab, k, 0, 1)))
                    continue;
                both++;
                /* The set is {A, B}: neither covers at every precision, so either drawn alone may leave it clear. */
                assert_int_equal(size, 2);
                assert_true(has_background(&va, k) && in_set(&va, k, 0, 0));
                assert_true(has_background(&vbb, k) && in_set(&vbb, k, 0, 0));
            }
    fprintf(stderr, "  shared edge: %zu samples within 0.03 px, %zu with the set {A, B}\n", near, both);
    assert_true(near >= 10);
    assert_true(both >= 3);
    rto_vbuffer_free(&vab);
    rto_vbuffer_free(&va);
    rto_vbuffer_free(&vbb);
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Attributes from unsnapped positions (§11.3: llvmpipe snaps for coverage only)                                      */

static void test_unsnapped_attributes(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    size_t checked = 0, outside_snapped = 0;
    for (uint32_t seed = 300; seed < 306; seed++) {
        rng_state = seed;
        const uint32_t w = 80, h = 60, S = seed % 2 ? 4 : 1;
        perspective_scene(s, w, h, 60, 1.0);
        rto_vbuffer vb;
        make(s, w, h, S, 2, &vb);
        for (uint32_t t = 0; t < s->ntri; t++) {
            tvert v[3];
            for (int k = 0; k < 3; k++)
                v[k] = vertex(s, 0, s->idx[3 * t + k], w, h);
            int skip = 0;
            for (int k = 0; k < 3; k++) /* the snapped rasterization (§11.2) only */
                skip |= !(v[k].clip[2] >= 0.0f && v[k].clip[2] <= v[k].clip[3]);
            /* The unsnapped barycentrics, independently: long double edge functions of the binary64 window
             * positions, perspective division by the binary32 clip w. */
            const long double area = ((long double)v[1].xw - v[0].xw) * ((long double)v[2].yw - v[0].yw) -
                                     ((long double)v[2].xw - v[0].xw) * ((long double)v[1].yw - v[0].yw);
            if (skip || fabsl(area) < 4.0L)
                continue;
            double x0 = w, x1 = 0, y0 = h, y1 = 0;
            for (int k = 0; k < 3; k++) {
                x0 = fmin(x0, v[k].xw), x1 = fmax(x1, v[k].xw);
                y0 = fmin(y0, v[k].yw), y1 = fmax(y1, v[k].yw);
            }
            x0 = fmax(x0, 0.0), x1 = fmin(x1, w - 1.0), y0 = fmax(y0, 0.0), y1 = fmin(y1, h - 1.0);
            for (int i = 0; i < 8 && x0 <= x1 && y0 <= y1; i++) { /* pixels of the triangle's box */
                const uint32_t x = (uint32_t)(x0 + urand() * (x1 - x0)), y = (uint32_t)(y0 + urand() * (y1 - y0));
                const long double px = x + 0.5L, py = y + 0.5L;
                long double l[3], q[3];
                for (int e = 0; e < 3; e++) {
                    const tvert *a = &v[(e + 1) % 3], *b = &v[(e + 2) % 3];
                    l[e] = (((long double)b->xw - a->xw) * (py - a->yw) - ((long double)b->yw - a->yw) * (px - a->xw)) /
                           area;
                }
                if (!(l[0] > -0.5L && l[1] > -0.5L && l[2] > -0.5L)) /* near the triangle: the plane stays finite */
                    continue;
                for (int e = 0; e < 3; e++)
                    q[e] = l[e] / v[e].clip[3];
                const long double qs = q[0] + q[1] + q[2];
                const long double b1 = q[1] / qs, b2 = q[2] / qs;
                rto__vb_attr ref, lo, hi;
                const uint32_t si = (uint32_t)(urand() * S);
                assert_int_equal(rto__raster_eval(vb.raster, 0, t, x, y, si, &ref, &lo, &hi), 1);
                if (!(lo.b[0] <= b1 && b1 <= hi.b[0] && lo.b[1] <= b2 && b2 <= hi.b[1]))
                    fprintf(stderr, "seed %u triangle %u pixel (%u, %u): unsnapped (%.9Lf, %.9Lf), interval "
                                    "[%.9f, %.9f] x [%.9f, %.9f]\n", seed, t, x, y, b1, b2, lo.b[0], hi.b[0],
                            lo.b[1], hi.b[1]);
                assert_true(lo.b[0] <= b1 && b1 <= hi.b[0]);
                assert_true(lo.b[1] <= b2 && b2 <= hi.b[1]);
                /* The widening alone (2^-21 max(1, |b|)) around the p = 8 reference would not always hold it. */
                const long double wb = 0x1p-21L * fmaxl(1.0L, fabsl(b1));
                outside_snapped += fabsl(b1 - ref.b[0]) > 2 * wb;
                checked++;
            }
        }
        rto_vbuffer_free(&vb);
    }
    assert_true(checked > 500);
    assert_true(outside_snapped > checked / 4);
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Perspective-correct barycentrics, derivatives                                                                      */

static int invert4(const double m[16], double o[16])
{
    double a[4][8];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 8; c++)
            a[r][c] = c < 4 ? m[4 * c + r] : (c - 4 == r);
    for (int c = 0; c < 4; c++) {
        int p = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[p][c]))
                p = r;
        if (a[p][c] == 0)
            return 0;
        for (int k = 0; k < 8; k++) {
            const double t = a[c][k];
            a[c][k] = a[p][k];
            a[p][k] = t;
        }
        for (int r = 0; r < 4; r++)
            if (r != c) {
                const double f = a[r][c] / a[c][c];
                for (int k = 0; k < 8; k++)
                    a[r][k] -= f * a[c][k];
            }
    }
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            o[4 * c + r] = a[r][4 + c] / a[r][r];
    return 1;
}

/* Barycentrics (b1, b2) of world triangle p0 p1 p2 where the ray through pixel centre (px, py) meets its plane. */
static void closed_form(const double inv[16], uint32_t w, uint32_t h, const float *p, double px, double py,
                        double b[2])
{
    const double nx = px / w * 2.0 - 1.0, ny = 1.0 - py / h * 2.0;
    double e[2][3];
    for (int d = 0; d < 2; d++) { /* the world points at ndc z 0 and 1 */
        const double q[4] = {nx, ny, (double)d, 1.0};
        double r[4] = {0, 0, 0, 0};
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++)
                r[i] += inv[4 * j + i] * q[j];
        for (int i = 0; i < 3; i++)
            e[d][i] = r[i] / r[3];
    }
    double u[3], v[3], dir[3], n[3], o[3];
    for (int i = 0; i < 3; i++) {
        u[i] = (double)p[3 + i] - p[i];
        v[i] = (double)p[6 + i] - p[i];
        dir[i] = e[1][i] - e[0][i];
        o[i] = e[0][i] - p[i];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    const double t = -(n[0] * o[0] + n[1] * o[1] + n[2] * o[2]) / (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]);
    double x[3];
    for (int i = 0; i < 3; i++)
        x[i] = o[i] + t * dir[i]; /* relative to p0: x = b1 u + b2 v */
    const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2],
                 uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2], xu = x[0] * u[0] + x[1] * u[1] + x[2] * u[2],
                 xv = x[0] * v[0] + x[1] * v[1] + x[2] * v[2], d = uu * vv - uv * uv;
    b[0] = (xu * vv - xv * uv) / d;
    b[1] = (xv * uu - xu * uv) / d;
}

static void test_perspective_barycentrics(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    scene_init(s);
    const uint32_t w = 128, h = 96;
    /* A quad at a steep angle: a floor from z = -1 to z = -12 seen from just above it. */
    rto_camera cam = {.position = {0.0f, 0.6f, 0.0f}, .target = {0.0f, 0.0f, -4.0f}, .up = {0, 1, 0},
                      .fov_y = 1.2f, .znear = 0.1f, .zfar = 50.0f};
    rto_msg msg = {{0}};
    assert_int_equal(rto_vbuffer_camera_make(&cam, w, h, &s->cam, &msg), RTO_OK);
    add_tri(s, (float[]){-2, 0, -1, 2, 0, -1, 2, 0, -12});
    add_tri(s, (float[]){-2, 0, -1, 2, 0, -12, -2, 0, -12});
    rto_vbuffer vb;
    make(s, w, h, 4, 2, &vb);
    double vp[16], inv[16];
    for (int k = 0; k < 16; k++)
        vp[k] = s->cam.view_proj[k];
    assert_true(invert4(vp, inv));
    size_t checked = 0, affine_far = 0;
    double worst = 0, worst_d = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const size_t k = ((size_t)y * w + x) * 4;
            uint32_t inst, prim;
            vis_id(&vb, k, &inst, &prim);
            if (inst != 0)
                continue;
            const float *p = s->pos + 9 * prim;
            double b[2], bx1[2], bx0[2], by1[2], by0[2];
            closed_form(inv, w, h, p, x + 0.5, y + 0.5, b);
            closed_form(inv, w, h, p, (x | 1) + 0.5, y + 0.5, bx1);
            closed_form(inv, w, h, p, (x & ~1u) + 0.5, y + 0.5, bx0);
            closed_form(inv, w, h, p, x + 0.5, (y | 1) + 0.5, by1);
            closed_form(inv, w, h, p, x + 0.5, (y & ~1u) + 0.5, by0);
            const uint16_t *pb = vb.planes.barycentric + 2 * k, *pd = vb.planes.derivatives + 4 * k;
            for (int j = 0; j < 2; j++) {
                const double got = rto_f16_to_f32(pb[j]);
                worst = fmax(worst, fabs(got - b[j]));
                assert_true(fabs(got - b[j]) <= 1e-3);
                const double dx = bx1[j] - bx0[j], dy = by1[j] - by0[j];
                worst_d = fmax(worst_d, fmax(fabs(rto_f16_to_f32(pd[j]) - dx), fabs(rto_f16_to_f32(pd[2 + j]) - dy)));
                assert_true(fabs(rto_f16_to_f32(pd[j]) - dx) <= 1e-3);
                assert_true(fabs(rto_f16_to_f32(pd[2 + j]) - dy) <= 1e-3);
            }
            /* Affine (screen-space) weights of the same pixel centre: far from the plane's values over most of it. */
            tvert v[3];
            for (int i = 0; i < 3; i++)
                v[i] = vertex(s, 0, s->idx[3 * prim + i], w, h);
            const double px = x + 0.5, py = y + 0.5;
            const double area = (v[1].xw - v[0].xw) * (v[2].yw - v[0].yw) - (v[2].xw - v[0].xw) * (v[1].yw - v[0].yw);
            const double l1 = ((v[0].xw - v[2].xw) * (py - v[2].yw) - (v[0].yw - v[2].yw) * (px - v[2].xw)) / area;
            affine_far += fabs(l1 - b[0]) > 0.02;
            checked++;
        }
    fprintf(stderr, "  perspective: %zu pixels, worst |b - closed form| %.2g, derivatives %.2g, affine off by > 0.02 "
            "at %zu\n", checked, worst, worst_d, affine_far);
    assert_true(checked > 2000);
    assert_true(affine_far > checked / 4);
    /* The evaluation agrees with the planes at the reference and brackets it. */
    for (uint32_t y = 0; y < h; y += 7)
        for (uint32_t x = 0; x < w; x += 5)
            for (uint32_t si = 0; si < 4; si++) {
                const size_t k = ((size_t)y * w + x) * 4 + si;
                uint32_t inst, prim;
                vis_id(&vb, k, &inst, &prim);
                if (inst != 0)
                    continue;
                rto__vb_attr ref, lo, hi;
                assert_int_equal(rto__raster_eval(vb.raster, inst, prim, x, y, si, &ref, &lo, &hi), 1);
                assert_int_equal(rto_f16_from_f32(ref.b[0]), vb.planes.barycentric[2 * k]);
                assert_int_equal(rto_f16_from_f32(ref.ddy[1]), vb.planes.derivatives[4 * k + 3]);
                assert_true(ref.depth == vb.planes.depth[k]);
                assert_true(lo.b[0] <= ref.b[0] && ref.b[0] <= hi.b[0] && lo.b[1] <= ref.b[1] && ref.b[1] <= hi.b[1]);
                assert_true(lo.ddx[0] <= ref.ddx[0] && ref.ddx[0] <= hi.ddx[0]);
                assert_true(lo.depth <= ref.depth && ref.depth <= hi.depth);
                assert_true(hi.b[0] - lo.b[0] < 0.01);
            }
    /* The face normal: the floor faces +y (counter-clockwise seen from above), octahedral (0, 1) at n = (0, 1, 0). */
    float n[3];
    rto__raster_face_normal(vb.raster, 0, 0, n);
    assert_true(n[0] == 0.0f && n[1] == 1.0f && n[2] == 0.0f);
    uint32_t inst, prim;
    vis_id(&vb, ((size_t)(h / 2) * w + w / 2) * 4, &inst, &prim);
    assert_int_equal(inst, 0);
    const uint16_t *pn = vb.planes.normal + 4 * (((size_t)(h / 2) * w + w / 2) * 4);
    /* cross(u, v).x = 0 (-11) - 0 0 is -0 in binary32: the plane keeps its sign */
    assert_true((pn[0] & 0x7FFFu) == 0);
    assert_int_equal(pn[1], 0x3C00);
    assert_int_equal(pn[2], 0);
    assert_int_equal(pn[3], 0x3C00);
    rto_vbuffer_free(&vb);
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Depth and unorm24                                                                                                  */

/* round(d (2^24 - 1)), half to even, by integer arithmetic on d's bits. */
static uint32_t u24_ref(float d)
{
    int e;
    const double m = frexp(d, &e); /* d = m 2^e, m in [0.5, 1) */
    const uint64_t mi = (uint64_t)ldexp(m, 24);    /* d = mi 2^(e - 24) */
    const uint64_t num = mi * 16777215u; /* < 2^48 */
    const int sh = 24 - e;              /* value = num / 2^sh, sh >= 23 for d <= 1 */
    if (d == 0.0f || sh > 60)
        return 0;
    const uint64_t q = num >> sh, r = num - (q << sh), half = (uint64_t)1 << (sh - 1);
    return (uint32_t)(r > half || (r == half && (q & 1)) ? q + 1 : q);
}

static void test_depth_unorm24(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    scene_init(s);
    /* z = 0.5 everywhere: 0.5 (2^24 - 1) = 8388607.5, a tie, even: 8388608. */
    add_win(s, 64, 64, (double[]){2, 2, 30, 2, 2, 30}, (double[]){0.5, 0.5, 0.5});
    /* A sloped triangle, drawn over part of it and in front. */
    add_win(s, 64, 64, (double[]){10, 1, 60, 20, 20, 60}, (double[]){0.1, 0.3, 0.45});
    /* A triangle in front of the first but at depth exactly 1 - not drawn (less against the clear 1.0). */
    add_win(s, 64, 64, (double[]){40, 40, 63, 40, 40, 63}, (double[]){1.0, 1.0, 1.0});
    rto_vbuffer vb;
    make(s, 64, 64, 4, 1, &vb);
    uint32_t inst, prim;
    const size_t k_flat = ((size_t)4 * 64 + 4) * 4;
    vis_id(&vb, k_flat, &inst, &prim);
    assert_int_equal(prim, 0);
    assert_true(vb.planes.depth[k_flat] == 0.5f);
    assert_int_equal(vb.planes.depth_unorm24[k_flat], 8388608u);
    assert_int_equal(u24_ref(0.5f), 8388608u);
    /* The far triangle: background in the planes, but admissible with background (its depth may be below 1). */
    const size_t k_far = ((size_t)45 * 64 + 45) * 4;
    vis_id(&vb, k_far, &inst, &prim);
    assert_int_equal(inst, 0xFFFFFFFFu);
    assert_int_equal(vb.planes.depth_unorm24[k_far], 0xFFFFFFu);
    assert_true(in_set(&vb, k_far, 0, 2) && in_set(&vb, k_far, RTO_VB_BACKGROUND, RTO_VB_BACKGROUND));
    /* Every sample: unorm24 from its depth; the sloped triangle's depth against long double interpolation of the
     * snapped positions. */
    size_t sloped = 0;
    tvert v[3];
    for (int i = 0; i < 3; i++)
        v[i] = vertex(s, 0, s->idx[3 + i], 64, 64);
    for (uint32_t y = 0; y < 64; y++)
        for (uint32_t x = 0; x < 64; x++)
            for (uint32_t si = 0; si < 4; si++) {
                const size_t k = ((size_t)y * 64 + x) * 4 + si;
                assert_int_equal(vb.planes.depth_unorm24[k], u24_ref(vb.planes.depth[k]));
                vis_id(&vb, k, &inst, &prim);
                if (inst != 0 || prim != 1)
                    continue;
                long long ox, oy;
                sample_units(4, si, &ox, &oy);
                const long double X = 256.0L * x + ox, Y = 256.0L * y + oy;
                long double vx[3], vy[3];
                for (int i = 0; i < 3; i++) {
                    vx[i] = nearbyintl((long double)v[i].xw * 256);
                    vy[i] = nearbyintl((long double)v[i].yw * 256);
                }
                const long double area = (vx[1] - vx[0]) * (vy[2] - vy[0]) - (vx[2] - vx[0]) * (vy[1] - vy[0]);
                const long double l1 = ((vx[0] - vx[2]) * (Y - vy[2]) - (vy[0] - vy[2]) * (X - vx[2])) / area;
                const long double l2 = ((vx[1] - vx[0]) * (Y - vy[0]) - (vy[1] - vy[0]) * (X - vx[0])) / area;
                const long double z = (1 - l1 - l2) * v[0].z + l1 * v[1].z + l2 * v[2].z;
                assert_true(fabsl(z - vb.planes.depth[k]) <= 0x1p-24L);
                sloped++;
            }
    assert_true(sloped > 1000);
    rto_vbuffer_free(&vb);
    free(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Threads, near plane, arguments                                                                                     */

static void test_threads_identical(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    rng_state = 7;
    perspective_scene(s, 200, 150, 500, 0.5);
    rto_vbuffer v[3];
    for (uint32_t t = 0; t < 3; t++)
        make(s, 200, 150, 4, t + 1, &v[t]);
    const size_t n = (size_t)200 * 150 * 4;
    for (int t = 1; t < 3; t++) {
        assert_memory_equal(v[0].planes.visibility, v[t].planes.visibility, 8 * n);
        assert_memory_equal(v[0].planes.barycentric, v[t].planes.barycentric, 4 * n);
        assert_memory_equal(v[0].planes.normal, v[t].planes.normal, 8 * n);
        assert_memory_equal(v[0].planes.derivatives, v[t].planes.derivatives, 8 * n);
        assert_memory_equal(v[0].planes.depth, v[t].planes.depth, 4 * n);
        assert_memory_equal(v[0].planes.depth_unorm24, v[t].planes.depth_unorm24, 4 * n);
        assert_memory_equal(v[0].admissible_offset, v[t].admissible_offset, 4 * (n + 1));
        assert_memory_equal(v[0].admissible, v[t].admissible, 8 * (size_t)v[0].admissible_offset[n]);
        assert_memory_equal(&v[0].stats, &v[t].stats, sizeof v[0].stats);
    }
    assert_true(v[0].stats.covered > n / 4);
    for (int t = 0; t < 3; t++)
        rto_vbuffer_free(&v[t]);
    free(s);
}

static void test_near_plane(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    scene_init(s);
    const uint32_t w = 96, h = 64;
    rto_camera cam = {.position = {0, 0, 0}, .target = {0, 0, -1}, .up = {0, 1, 0}, .fov_y = 1.0f, .znear = 0.1f,
                      .zfar = 100.0f};
    rto_msg msg = {{0}};
    assert_int_equal(rto_vbuffer_camera_make(&cam, w, h, &s->cam, &msg), RTO_OK);
    /* A floor triangle at y = -1 reaching from 4 in front to 1 behind the camera (w < 0 at its back vertex). */
    add_tri(s, (float[]){-3, -1, -4, 3, -1, -4, 0, -1, 1});
    rto_vbuffer vb;
    make(s, w, h, 4, 2, &vb);
    assert_int_equal(vb.stats.clipped_triangles, 1);
    check_sets(&vb);
    double vp[16], inv[16];
    for (int k = 0; k < 16; k++)
        vp[k] = s->cam.view_proj[k];
    assert_true(invert4(vp, inv));
    size_t agree = 0, possible = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (uint32_t si = 0; si < 4; si++) {
                const size_t k = ((size_t)y * w + x) * 4 + si;
                long long ox, oy;
                sample_units(4, si, &ox, &oy);
                /* The sample's ray against the floor: inside the triangle (xz), in front of the near plane. */
                const double nx = (x + ox / 256.0) / w * 2 - 1, ny = 1 - (y + oy / 256.0) / h * 2;
                double e[2][3];
                for (int d = 0; d < 2; d++) {
                    const double q[4] = {nx, ny, (double)d, 1.0};
                    double r[4] = {0, 0, 0, 0};
                    for (int i = 0; i < 4; i++)
                        for (int j = 0; j < 4; j++)
                            r[i] += inv[4 * j + i] * q[j];
                    for (int i = 0; i < 3; i++)
                        e[d][i] = r[i] / r[3];
                }
                const double dir[3] = {e[1][0] - e[0][0], e[1][1] - e[0][1], e[1][2] - e[0][2]};
                uint32_t inst, prim;
                vis_id(&vb, k, &inst, &prim);
                const int got = inst == 0;
                possible += vb.admissible_offset[k + 1] - vb.admissible_offset[k] > 1 || got;
                if (!(dir[1] < 0))
                    continue; /* the ray does not go down: the floor is never hit */
                const double t = (-1.0 - e[0][1]) / dir[1], hx = e[0][0] + t * dir[0], hz = e[0][2] + t * dir[2];
                /* xz triangle (-3, -4), (3, -4), (0, 1): distances to its edges and to the near plane (z = -0.1). */
                const double d0 = hz + 4, d1 = (-3 * (hz + 4) - 5 * (hx - 3)) / sqrt(34.0),
                             d2 = (-3 * (hz - 1) + 5 * hx) / sqrt(34.0), dn = -0.1 - hz;
                const double m = fmin(fmin(d0, fabs(d1)), fmin(fabs(d2), fabs(dn)));
                if (m < 0.02)
                    continue;
                const int want = d0 > 0 && d1 > 0 && d2 > 0 && dn > 0;
                if (got != want)
                    fprintf(stderr, "  (%u, %u) sample %u: hit (%g, %g) d %g %g %g %g, covered %d\n", x, y, si, hx, hz,
                            d0, d1, d2, dn, got);
                assert_int_equal(got, want);
                if (got)
                    assert_true(vb.planes.depth[k] >= 0.0f && vb.planes.depth[k] <= 1.0f);
                agree++;
            }
    assert_true(agree > 5000);
    assert_true(possible > 1000);
    rto_vbuffer_free(&vb);
    free(s);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    tscene *s = malloc(sizeof *s);
    assert_non_null(s);
    scene_init(s);
    add_win(s, 64, 64, (double[]){2, 2, 30, 2, 2, 30}, (double[]){0.5, 0.5, 0.5});
    rto_vbuffer_geometry g = scene_geom(s);
    rto_vbuffer vb;
    rto_msg msg = {{0}};
    const rto_vbuffer_desc bad[] = {{0, 8, 1, 1}, {8, 0, 1, 1}, {8, 8, 3, 1}, {8, 8, 0, 1}, {16385, 8, 1, 1}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        msg.text[0] = 0;
        assert_int_equal(rto_vbuffer_make(&g, &s->cam, &bad[i], &vb, &msg), RTO_ERR_INVALID_ARGUMENT);
        assert_true(strlen(msg.text) > 0);
        assert_null(vb.planes.visibility);
    }
    const rto_vbuffer_desc ok = {8, 8, 1, 1};
    assert_int_equal(rto_vbuffer_make(NULL, &s->cam, &ok, &vb, &msg), RTO_ERR_INVALID_ARGUMENT);
    s->idx[2] = 99; /* an index past the vertices */
    assert_int_equal(rto_vbuffer_make(&g, &s->cam, &ok, &vb, &msg), RTO_ERR_INVALID_ARGUMENT);
    s->idx[2] = 2;
    s->inst[0].blas = 3;
    g.instances = s->inst;
    assert_int_equal(rto_vbuffer_make(&g, &s->cam, &ok, &vb, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_vbuffer_free(NULL);
    rto_vbuffer_free(&vb);
    /* Empty geometry: all background, every set is background alone. */
    rto_vbuffer_geometry empty = {NULL, 0, NULL, 0};
    assert_int_equal(rto_vbuffer_make(&empty, &s->cam, &ok, &vb, &msg), RTO_OK);
    assert_int_equal(vb.stats.set_sizes[0], 64);
    assert_int_equal(vb.admissible[0], RTO_VB_BACKGROUND);
    rto_vbuffer_free(&vb);
    double sx, sy;
    rto__vb_sample_pos(4, 2, &sx, &sy);
    assert_true(sx == 0.125 && sy == 0.625);
    rto__vb_sample_pos(1, 0, &sx, &sy);
    assert_true(sx == 0.5 && sy == 0.5);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_brute_force),
        cmocka_unit_test(test_brute_force_perspective),
        cmocka_unit_test(test_watertight_top_left),
        cmocka_unit_test(test_admissible_unsnapped),
        cmocka_unit_test(test_shared_edge_no_crack),
        cmocka_unit_test(test_unsnapped_attributes),
        cmocka_unit_test(test_perspective_barycentrics),
        cmocka_unit_test(test_depth_unorm24),
        cmocka_unit_test(test_threads_identical),
        cmocka_unit_test(test_near_plane),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
