/* The reference raymarch of seed 003 (DESIGN.md §12.4-§12.5.1): a fixed-step march through the resolved density volume
 * (trilinear, binary32, no contraction), central and forward-difference normals, shadow transmittance towards the
 * sun, up to numRefractions bounces choosing refraction or reflection by a 4-step short march, an environment of a
 * checkered floor and a sky; the same march with empty-space skipping over the occupancy grid, compared with the
 * first one pixel by pixel; and the conformance envelope (per-sample intervals of a GPU's 8-bit trilinear weights,
 * the decisions they make certain, the image tolerance). Every pixel is a pure function of its inputs, so the bytes
 * do not depend on the thread count. */
#include "fluid/raymarch_internal.h"
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RM_NONE 0xFFFFFFFFu
#define RM_WALL_K 0xFFFFFFFEu /* a later bounce's exit found at the box's wall (a wall event, §12.5.1) */
#define RM_MAX_STEPS 512u     /* primary march: sample indices 0 .. 511 */
#define RM_SHADOW_STEPS 32u   /* shadow march: sample indices 0 .. 31 */
#define RM_SHADOW_EXIT 3.0f   /* optical depth that ends a shadow march */
#define RM_SHORT_STEPS 4u     /* refraction heuristic: 4 samples */
#define RM_SHORT_MAX 2.0f     /* ... over at most this distance */
#define RM_EPS 1.0e-4f        /* samples with uvw <= eps or >= 1 - eps read -densityOffset */
#define RM_WEIGHT_ERR (1.0 / 512.0 + 1.0 / 4096.0) /* a GPU's lerp weight error per axis: 8 bits rounded, + coords */
#define RM_COORD_ERR (1.0 / 4096.0)                 /* ... of it the coordinate's: the texels a sample may read */

uint32_t rto__rm_levels(uint32_t O, uint64_t level_offset[12], uint32_t level_res[12], uint64_t *words)
{
    if (O < 1 || O > 1024)
        return 0;
    uint64_t off = 0;
    uint32_t l = 0, r = O;
    for (;;) {
        level_offset[l] = off;
        level_res[l] = r;
        off += ((uint64_t)r * r * r + 31) / 32;
        l++;
        if (r == 1 || l == 12)
            break;
        r = (r + 1) / 2;
    }
    *words = off;
    return l;
}

int rto__rm_occ(const rto_splat *vol, uint32_t l, uint32_t x, uint32_t y, uint32_t z)
{
    const uint32_t R = vol->level_res[l];
    const uint64_t b = ((uint64_t)z * R + y) * R + x;
    const uint64_t w = vol->level_offset[l] + (b >> 5);
    if (w >= vol->occupancy_words)
        return 1; /* outside the buffer: treated as occupied (never skipped) */
    return (int)((vol->occupancy[w] >> (b & 31)) & 1u);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Shared state and per-render state                                                                                */

typedef struct rm_shared {
    const rto_splat *vol;
    const rto_raymarch_uniforms *u;
    rto_camera_uniforms cam;
    uint32_t W, H, n[3], O, levels;
    float bmin[3], bmax[3], ext[3], vs[3];
    double cs[3]; /* occupancy cell size, binary64 */
    double bmag;  /* largest |bound| */
    int skip_ok, quant, envelope;
    const rto_raymarch_params *params;
} rm_shared;

enum { MODE_NOMINAL = 0, MODE_LO = 1, MODE_HI = 2, MODE_FORWARD = 3, MODE_TILT = 4 /* .. MODE_TILT + 3 */ };
/* A GPU's normal may point anywhere within the angle its gradient's interval allows (§12.5.1): the envelope's tilt
 * renders turn every normal by that angle (plus 2^-12 rad of arithmetic) towards each of four directions. */
#define RM_TILTS 4

typedef struct rm_state {
    const rm_shared *S;
    int mode, skip, certainty;
    uint32_t pixel;
    uint32_t steps, skipped, taken;
    uint64_t hash;
    int uncertain;
    int wall;     /* the render met a wall event (below) */
    int wall_alt; /* 1: the first wall event takes the other outcome (then 2) */
} rm_state;

static void note(rm_state *st, uint64_t v)
{
    /* FNV-1a over the decisions of a render: two renders made the same decisions iff (barring collisions) equal. */
    for (int i = 0; i < 8; i++) {
        st->hash ^= (v >> (8 * i)) & 0xFFu;
        st->hash *= UINT64_C(0x100000001b3);
    }
}

static float minnan(float a, float b) { return (a < b || b != b) ? a : b; }
static float maxnan(float a, float b) { return (a > b || b != b) ? a : b; }

/* ---------------------------------------------------------------------------------------------------------------- */
/* Density                                                                                                          */

static float texel(const rm_shared *S, int x, int y, int z)
{
    const size_t i = ((size_t)z * S->n[1] + (size_t)y) * S->n[0] + (size_t)x;
    return rto_f16_to_f32(S->vol->volume_f16[i]);
}

static int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Trilinear at texel coordinates g (g_a = uvw_a * n_a - 0.5): clamp-to-edge neighbours, weights g - floor(g), lerps
 * a * (1 - w) + b * w in x, then y, then z. */
static float trilin_g(const rm_shared *S, const float g[3], int quant)
{
    int i0[3], i1[3];
    float w[3];
    for (int a = 0; a < 3; a++) {
        const float fl = floorf(g[a]);
        w[a] = g[a] - fl;
        if (quant)
            w[a] = floorf(w[a] * 256.0f + 0.5f) / 256.0f;
        const int i = !(fl == fl) ? 0 : fl < -2.0f ? -2 : fl > (float)S->n[a] + 2.0f ? (int)S->n[a] + 2 : (int)fl;
        if (!(w[a] >= 0.0f && w[a] <= 1.0f))
            w[a] = 0.0f; /* a non-finite coordinate (never inside the box) reads one texel */
        i0[a] = clampi(i, 0, (int)S->n[a] - 1);
        i1[a] = clampi(i + 1, 0, (int)S->n[a] - 1);
    }
    float c[2][2];
    for (int zz = 0; zz < 2; zz++)
        for (int yy = 0; yy < 2; yy++) {
            const int y = yy ? i1[1] : i0[1], z = zz ? i1[2] : i0[2];
            c[zz][yy] = texel(S, i0[0], y, z) * (1.0f - w[0]) + texel(S, i1[0], y, z) * w[0];
        }
    const float c0 = c[0][0] * (1.0f - w[1]) + c[0][1] * w[1];
    const float c1 = c[1][0] * (1.0f - w[1]) + c[1][1] * w[1];
    const float r = c0 * (1.0f - w[2]) + c1 * w[2];
    return quant == 2 ? rto_f16_to_f32(rto_f16_from_f32(r)) : r;
}

/* Texel coordinates of q; returns 0 when q is outside [eps, 1 - eps] (then the sample is -offset * multiplier), 1
 * inside, and sets *near when some uvw is within 2^-20 of either threshold (a GPU may decide it either way). */
static int coords(const rm_shared *S, const float q[3], float g[3], int *near)
{
    int inside = 1;
    *near = 0;
    for (int a = 0; a < 3; a++) {
        const float uvw = (q[a] - S->bmin[a]) / S->ext[a];
        if (!(uvw > RM_EPS && uvw < 1.0f - RM_EPS))
            inside = 0;
        if (fabsf(uvw - RM_EPS) <= 0x1p-20f || fabsf(uvw - (1.0f - RM_EPS)) <= 0x1p-20f || uvw != uvw)
            *near = 1;
        g[a] = uvw * (float)S->n[a] - 0.5f;
    }
    return inside;
}

/* The reference density at q: (trilinear - offset) * multiplier, or -offset * multiplier outside. */
static float density_nominal(const rm_shared *S, const float q[3])
{
    float g[3];
    int near;
    const float off = S->u->density_offset, mul = S->u->density_multiplier;
    if (!coords(S, q, g, &near))
        return -off * mul;
    return (trilin_g(S, g, S->quant) - off) * mul;
}

/* binary16's unit in the last place at |v| (subnormal spacing below 2^-14). */
static double ulp16(double v)
{
    v = fabs(v);
    if (!(v >= 0x1p-14))
        return 0x1p-24;
    int e;
    frexp(v, &e);
    return ldexp(1.0, e - 11);
}

/* The conformance interval [lo, hi] of the density at q (§12.5.1): a GPU's filtered value
 * is within 3 RM_WEIGHT_ERR (vmax - vmin) of the trilinear, over the texels any coordinate within RM_COORD_ERR may
 * read (each of the three lerps' weights off by up to RM_WEIGHT_ERR moves the result by at most that much of the
 * texels' spread), plus one binary16 ulp of the largest texel (a filter whose result has the format's precision) and
 * binary32 slack; merged with -offset * multiplier where some uvw is within 2^-20 of the box's eps thresholds. */
static void density_range(const rm_shared *S, const float q[3], float *lo, float *hi)
{
    float g[3];
    int near;
    const float off = S->u->density_offset, mul = S->u->density_multiplier;
    const float outside = -off * mul;
    const int in = coords(S, q, g, &near);
    if (!in && !near) {
        *lo = *hi = outside;
        return;
    }
    int a0[3], a1[3];
    for (int a = 0; a < 3; a++) {
        const double gl = (double)g[a] - RM_COORD_ERR, gh = (double)g[a] + RM_COORD_ERR;
        const double cl = gl < -2.0 ? -2.0 : gl > S->n[a] + 2.0 ? S->n[a] + 2.0 : gl; /* NaN: reads texel 0 */
        const double ch = gh < -2.0 ? -2.0 : gh > S->n[a] + 2.0 ? S->n[a] + 2.0 : gh;
        a0[a] = clampi((int)floor(cl == cl ? cl : 0.0), 0, (int)S->n[a] - 1);
        a1[a] = clampi((int)floor(ch == ch ? ch : 0.0) + 1, 0, (int)S->n[a] - 1);
    }
    float vmin = INFINITY, vmax = -INFINITY;
    for (int z = a0[2]; z <= a1[2]; z++)
        for (int y = a0[1]; y <= a1[1]; y++)
            for (int x = a0[0]; x <= a1[0]; x++) {
                const float t = texel(S, x, y, z);
                vmin = t < vmin ? t : vmin;
                vmax = t > vmax ? t : vmax;
            }
    const float tri = trilin_g(S, g, 0);
    const double big = fmax(fabs(vmin), fabs(vmax));
    const double e = 3.0 * RM_WEIGHT_ERR * ((double)vmax - vmin) + ulp16(big) + 0x1p-21 * (big + fabs(off)) + 0x1p-40;
    double l = ((double)tri - off - e) * mul, h = ((double)tri - off + e) * mul;
    l -= fabs(l) * 0x1p-22;
    h += fabs(h) * 0x1p-22;
    *lo = (float)l;
    *hi = (float)h;
    if (!in || near) {
        *lo = *lo < outside ? *lo : outside;
        *hi = *hi > outside ? *hi : outside;
    }
}

/* The sample a render takes: the nominal value, or its interval's low or high end in the envelope's renders. */
static float sample(rm_state *st, const float q[3])
{
    if (st->mode == MODE_LO || st->mode == MODE_HI) {
        float lo, hi;
        density_range(st->S, q, &lo, &hi);
        return st->mode == MODE_LO ? lo : hi;
    }
    return density_nominal(st->S, q);
}

float rto_raymarch_density(const rto_splat *vol, const rto_raymarch_uniforms *u, const float q[3])
{
    rm_shared S;
    memset(&S, 0, sizeof S);
    S.vol = vol;
    S.u = u;
    for (int a = 0; a < 3; a++) {
        S.n[a] = vol->params.res[a];
        S.bmin[a] = u->bounds_min[a];
        S.bmax[a] = u->bounds_max[a];
        S.ext[a] = S.bmax[a] - S.bmin[a];
    }
    return density_nominal(&S, q);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Geometry                                                                                                         */

/* Slab test in binary32: inv = 1 / d; per axis t = (min - o) * inv, (max - o) * inv; t0 the largest near, t1 the
 * smallest far (a NaN slab is ignored). Returns 1 when t1 > max(t0, 0). */
static int ray_box(const rm_shared *S, const float o[3], const float d[3], float *t0, float *t1)
{
    float tn = -INFINITY, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        const float inv = 1.0f / d[a];
        const float ta = (S->bmin[a] - o[a]) * inv, tb = (S->bmax[a] - o[a]) * inv;
        tn = maxnan(tn, minnan(ta, tb));
        tf = minnan(tf, maxnan(ta, tb));
    }
    *t0 = tn;
    *t1 = tf;
    return tf > rto__maxf(tn, 0.0f);
}

static void at(const float o[3], const float d[3], float t, float p[3])
{
    for (int a = 0; a < 3; a++)
        p[a] = o[a] + d[a] * t;
}

static float dot3(const float a[3], const float b[3]) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

/* Empty-space skipping (§12.5): when sample point p (index k of a march t_j = tb + j * step) lies in an empty
 * occupancy cell, the coarsest empty level L above it gives a box the ray leaves at t_exit; the next sample taken is
 * k' = max(k + 1, floor((t_exit - tb) / step)), so samples k .. k' - 1 (all inside the empty box) are skipped.
 * Returns k when p's cell is occupied (or p is outside the grid). */
static uint32_t skip_to(const rm_shared *S, const float o[3], const float d[3], const float p[3], float tb, float step,
                        uint32_t k, uint32_t kmax)
{
    uint32_t c[3];
    for (int a = 0; a < 3; a++) {
        if (!(p[a] >= S->bmin[a] && p[a] <= S->bmax[a]))
            return k;
        double cc = floor(((double)p[a] - S->bmin[a]) / S->cs[a]);
        if (cc < 0)
            cc = 0;
        if (cc > S->O - 1)
            cc = S->O - 1;
        c[a] = (uint32_t)cc;
    }
    if (rto__rm_occ(S->vol, 0, c[0], c[1], c[2]))
        return k;
    uint32_t L = 0;
    while (L + 1 < S->levels && !rto__rm_occ(S->vol, L + 1, c[0] >> (L + 1), c[1] >> (L + 1), c[2] >> (L + 1)))
        L++;
    double omax = 0;
    for (int a = 0; a < 3; a++)
        omax = fmax(omax, fabs(o[a]));
    const double tk = (double)tb + (double)k * step;
    const double m = 0x1p-20 * (omax + fabs(tk) + S->bmag);
    double texit = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0f)
            continue;
        const uint32_t first = (c[a] >> L) << L;
        uint32_t last = ((c[a] >> L) + 1) << L;
        if (last > S->O)
            last = S->O;
        const double lo = (double)S->bmin[a] + first * S->cs[a] + m;
        const double hi = (double)S->bmin[a] + last * S->cs[a] - m;
        const double te = ((d[a] > 0 ? hi : lo) - (double)o[a]) / (double)d[a];
        texit = te < texit ? te : texit;
    }
    double kn = floor((texit - (double)tb) / (double)step);
    if (!(kn < (double)kmax))
        kn = kmax;
    uint32_t k2 = kn > (double)k ? (uint32_t)kn : k;
    return k2 > k + 1 ? k2 : k + 1;
}

/* Whether a trilinear read at q may touch a non-zero texel (any of the 8 around it, inside [eps, 1 - eps]). */
static int reads_nonzero(const rm_shared *S, const float q[3])
{
    float g[3];
    int near, i0[3], i1[3];
    if (!coords(S, q, g, &near) && !near)
        return 0;
    for (int a = 0; a < 3; a++) {
        if (!(g[a] > -2.0f && g[a] < (float)S->n[a] + 2.0f))
            return 0;
        const int f = (int)floorf(g[a]);
        i0[a] = clampi(f, 0, (int)S->n[a] - 1);
        i1[a] = clampi(f + 1, 0, (int)S->n[a] - 1);
    }
    for (int k = 0; k < 8; k++)
        if (texel(S, (k & 1) ? i1[0] : i0[0], (k & 2) ? i1[1] : i0[1], (k & 4) ? i1[2] : i0[2]) != 0.0f)
            return 1;
    return 0;
}

/* The test hook: every sample position a skip passes over (those the unskipped march would take: t_j < t1). */
static void report_skipped(const rm_state *st, const float o[3], const float d[3], float tb, float step, float t1,
                           uint32_t k, uint32_t k2)
{
    const rto_raymarch_params *p = st->S->params;
    if (!p->skipped_sample)
        return;
    for (uint32_t j = k; j < k2; j++) {
        const float t = tb + (float)j * step;
        if (!(t < t1))
            break;
        float q[3];
        at(o, d, t, q);
        p->skipped_sample(p->skipped_ctx, st->pixel, q);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Marches                                                                                                          */

/* Whether q is in the box's eps band or outside it, or within 2^-20 of the band's edge: a sample there reads (or may
 * read) -offset * multiplier. */
static int wall_band(const rm_shared *S, const float q[3])
{
    float g[3];
    int near;
    const int in = coords(S, q, g, &near);
    return !in || near;
}

/* The density at q as if q were inside the box's eps band (trilinear, clamp-to-edge). */
static float density_unbanded(const rm_shared *S, const float q[3])
{
    float g[3];
    int near;
    coords(S, q, g, &near);
    return (trilin_g(S, g, S->quant) - S->u->density_offset) * S->u->density_multiplier;
}

/* Where a ray leaves the box shrunk by eps on every side (where its eps band begins; ray_box's t1 is where it ends). */
static float band_exit(const rm_shared *S, const float o[3], const float d[3])
{
    float tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        const float inv = 1.0f / d[a], e = RM_EPS * S->ext[a];
        tf = minnan(tf, maxnan((S->bmin[a] + e - o[a]) * inv, (S->bmax[a] - e - o[a]) * inv));
    }
    return tf;
}

typedef struct rm_hit {
    int found;
    uint32_t k;
    float t;
    float p[3];
    float depth; /* optical depth (density * step summed) before the crossing */
} rm_hit;

/* findNextSurface (§12.4): t_k = tb + f32(k) * step, tb = max(t0, 0) (+ the jitter on the primary segment), k from 0
 * (primary) or 1 (later bounces), until a sample enters (> 0) / leaves (< 0) the fluid, t_k >= t1 or k = 512. */
static rm_hit search(rm_state *st, const float o[3], const float d[3], int exiting, int primary)
{
    const rm_shared *S = st->S;
    rm_hit h;
    memset(&h, 0, sizeof h);
    float t0, t1;
    if (!ray_box(S, o, d, &t0, &t1))
        return h;
    const float step = S->u->step_size;
    float tb = rto__maxf(t0, 0.0f);
    if (primary)
        tb = tb + (rto_unit(S->u->jitter_seed, st->pixel) * step) * S->u->jitter_scale;
    uint32_t k = primary ? 0 : 1;
    while (k < RM_MAX_STEPS) {
        const float t = tb + (float)k * step;
        if (!(t < t1))
            break;
        float p[3];
        at(o, d, t, p);
        st->steps++;
        if (st->skip && !exiting && S->skip_ok) {
            const uint32_t k2 = skip_to(S, o, d, p, tb, step, k, RM_MAX_STEPS);
            if (k2 != k) {
                report_skipped(st, o, d, tb, step, t1, k, k2);
                st->skipped += k2 - k;
                k = k2;
                continue;
            }
        }
        if (primary && !exiting && st->mode == MODE_NOMINAL && reads_nonzero(S, p))
            st->taken++; /* its cell is required (§12.3): no lossless skipper passes over it */
        const float v = sample(st, p);
        if (st->mode == MODE_NOMINAL && st->certainty) {
            float lo, hi;
            density_range(S, p, &lo, &hi);
            if (!(exiting ? (hi < 0.0f || lo >= 0.0f) : (lo > 0.0f || hi <= 0.0f)))
                st->uncertain = 1;
        }
        const int found = exiting ? v < 0.0f : v > 0.0f;
        /* A wall event (§12.5.1), outcome "wall": the exit found in the box's eps band. The other outcome: the sample
         * a hair inside the band, and the ray leaving the box. */
        const int wall = found && !primary && exiting && wall_band(S, p);
        if (wall) {
            st->wall = 1;
            if (st->wall_alt == 1) {
                st->wall_alt = 2;
                h.depth = h.depth + density_unbanded(S, p) * step;
                return h;
            }
        }
        if (found) {
            h.found = 1;
            h.k = wall ? RM_WALL_K : k;
            h.t = t;
            memcpy(h.p, p, sizeof p);
            return h;
        }
        if (exiting)
            h.depth = h.depth + v * step;
        k++;
    }
    /* A wall event (§12.5.1), outcome "leave": an exit search that leaves the box in the fluid. A GPU's ray a hair
     * away may put a last sample in the box's eps band, which reads -offset (outside): the other outcome is the exit
     * found in the band, where this ray crosses it. */
    if (!primary && exiting && k < RM_MAX_STEPS) {
        st->wall = 1;
        const float te = st->wall_alt == 1 ? band_exit(S, o, d) : NAN;
        if (te <= t1) {
            st->wall_alt = 2;
            h.found = 1;
            h.k = RM_WALL_K;
            h.t = 0.5f * (te + t1);
            at(o, d, h.t, h.p);
        }
    }
    return h;
}

/* The admissible first crossings of the primary entry search (§12.5.1): [first k whose interval's hi > 0, first k whose
 * lo > 0]; hi RM_NONE when no sample is certainly inside (then no crossing is admissible too), lo RM_NONE when no
 * sample may be. */
static void admissible(rm_state *st, const float o[3], const float d[3], uint32_t *klo, uint32_t *khi)
{
    const rm_shared *S = st->S;
    *klo = *khi = RM_NONE;
    float t0, t1;
    if (!ray_box(S, o, d, &t0, &t1))
        return;
    const float step = S->u->step_size;
    const float tb = rto__maxf(t0, 0.0f) + (rto_unit(S->u->jitter_seed, st->pixel) * step) * S->u->jitter_scale;
    for (uint32_t k = 0; k < RM_MAX_STEPS; k++) {
        const float t = tb + (float)k * step;
        if (!(t < t1))
            break;
        float p[3], lo, hi;
        at(o, d, t, p);
        density_range(S, p, &lo, &hi);
        if (hi > 0.0f && *klo == RM_NONE)
            *klo = k;
        if (lo > 0.0f) {
            *khi = k;
            return;
        }
    }
}

/* Optical depth towards direction d (§12.4): the shadow march, t_k = max(t0, 0) + f32(k) * (2 lightStepSize), k < 32,
 * t_k < t1, depth += max(density, 0) * step2, stopping once depth > 3. Skipping jumps k over empty cells. */
static float shadow_depth(rm_state *st, const float o[3], const float d[3])
{
    const rm_shared *S = st->S;
    float t0, t1;
    if (!ray_box(S, o, d, &t0, &t1)) {
        note(st, 0x5d00);
        return 0.0f;
    }
    const float step2 = S->u->light_step_size * 2.0f;
    const float tb = rto__maxf(t0, 0.0f);
    float depth = 0.0f;
    uint32_t k = 0;
    while (k < RM_SHADOW_STEPS) {
        const float t = tb + (float)k * step2;
        if (!(t < t1))
            break;
        float p[3];
        at(o, d, t, p);
        if (st->skip && S->skip_ok) {
            const uint32_t k2 = skip_to(S, o, d, p, tb, step2, k, RM_SHADOW_STEPS);
            if (k2 != k) {
                report_skipped(st, o, d, tb, step2, t1, k, k2);
                k = k2;
                continue;
            }
        }
        const float v = sample(st, p);
        depth = depth + rto__maxf(v, 0.0f) * step2;
        if (depth > RM_SHADOW_EXIT) {
            note(st, 0x5e00 + k);
            break;
        }
        k++;
    }
    return depth;
}

/* The refraction heuristic's short march: 4 samples at t = ts + (i + 0.5) * seg over [ts, min(t1, 2)]. */
static float short_depth(rm_state *st, const float o[3], const float d[3])
{
    const rm_shared *S = st->S;
    float t0, t1;
    if (!ray_box(S, o, d, &t0, &t1))
        return 0.0f;
    const float ts = rto__maxf(t0, 0.0f), te = rto__minf(t1, RM_SHORT_MAX);
    if (!(te > ts))
        return 0.0f;
    const float seg = (te - ts) * 0.25f;
    float depth = 0.0f;
    for (uint32_t i = 0; i < RM_SHORT_STEPS; i++) {
        float p[3];
        at(o, d, ts + ((float)i + 0.5f) * seg, p);
        depth = depth + rto__maxf(sample(st, p), 0.0f) * seg;
    }
    return depth;
}

static const float floor_a[3] = {0.85f, 0.85f, 0.8f}, floor_b[3] = {0.35f, 0.35f, 0.4f};
static const float sky_horizon[3] = {0.8f, 0.85f, 0.9f}, sky_zenith[3] = {0.2f, 0.45f, 0.85f};

/* The environment (§12.4): a checkered floor (2 squares a unit) lit by the sun through the fluid's shadow, or the sky
 * gradient with a sun highlight. */
static void environment(rm_state *st, const float o[3], const float d[3], float out[3])
{
    const rto_raymarch_uniforms *u = st->S->u;
    if (d[1] < 0.0f) {
        const float tf = (u->floor_height - o[1]) / d[1];
        if (tf > 0.0f) {
            const float fx = o[0] + d[0] * tf, fz = o[2] + d[2] * tf;
            if (fabsf(fx) < 1.0e4f && fabsf(fz) < 1.0e4f) {
                const int64_t ix = (int64_t)floorf(fx * 2.0f), iz = (int64_t)floorf(fz * 2.0f);
                const int parity = (int)((ix + iz) & 1);
                note(st, 0xf100 + (uint64_t)parity);
                const float fp[3] = {fx, u->floor_height, fz};
                const float sd = shadow_depth(st, fp, u->sun_dir);
                const float lit = 0.65f * rto__maxf(u->sun_dir[1], 0.0f);
                for (int c = 0; c < 3; c++) {
                    const float sT = expf(-(sd * u->extinction[c]));
                    out[c] = (parity ? floor_a[c] : floor_b[c]) * (0.35f + lit * sT);
                }
                return;
            }
        }
    }
    note(st, 0xf200);
    const float a = sqrtf(rto__maxf(d[1], 0.0f));
    float s = rto__maxf(dot3(d, u->sun_dir), 0.0f);
    for (int i = 0; i < 9; i++)
        s = s * s; /* s^512 */
    for (int c = 0; c < 3; c++)
        out[c] = (sky_horizon[c] + (sky_zenith[c] - sky_horizon[c]) * a) + s * 4.0f;
}

/* The tilt renders' normal (§12.5.1): the gradient's interval from its samples' intervals gives |dg| (the norm of
 * the component half-widths), so the GPU's normal lies within theta = atan(|dg| / (|g| - |dg|)) + 2^-12 of n; n is
 * turned by theta towards +u, -u, +v or -v (u, v orthonormal to n). theta >= pi/2 marks the render uncertain. */
static void tilt(rm_state *st, const float p[3], int forward, float len, float n[3])
{
    const rm_shared *S = st->S;
    double w2 = 0.0;
    for (int a = 0; a < 3; a++) {
        float q[3] = {p[0], p[1], p[2]}, lo, hi;
        double w = 0.0;
        q[a] = p[a] + S->vs[a];
        density_range(S, q, &lo, &hi);
        w += 0.5 * ((double)hi - lo);
        q[a] = forward ? p[a] : p[a] - S->vs[a];
        density_range(S, q, &lo, &hi);
        w += 0.5 * ((double)hi - lo);
        w2 += w * w;
    }
    const double dg = sqrt(w2) * (1.0 + 0x1p-20);
    if (!(dg < (double)len)) {
        st->uncertain = 1;
        return;
    }
    const double theta = atan(dg / ((double)len - dg)) + 0x1p-12;
    /* u: n x (the axis n is least aligned with), v = n x u */
    int m = 0;
    for (int a = 1; a < 3; a++)
        if (fabs(n[a]) < fabs(n[m]))
            m = a;
    double e[3] = {0, 0, 0}, u[3], v[3];
    e[m] = 1.0;
    u[0] = n[1] * e[2] - n[2] * e[1];
    u[1] = n[2] * e[0] - n[0] * e[2];
    u[2] = n[0] * e[1] - n[1] * e[0];
    const double ul = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; a++)
        u[a] /= ul;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
    const int k = st->mode - MODE_TILT;
    const double *t = k < 2 ? u : v;
    const double sg = (k & 1) ? -1.0 : 1.0, c = cos(theta), sn = sin(theta) * sg;
    for (int a = 0; a < 3; a++)
        n[a] = (float)(c * n[a] + sn * t[a]);
}

/* The normal at p (§12.4): n = -grad / |grad|, grad by central differences (6 samples, one voxel on each axis) or
 * forward differences (4 samples); (0, 1, 0) where the gradient is 0. */
static void normal_at(rm_state *st, const float p[3], int forward, float n[3])
{
    const rm_shared *S = st->S;
    float g[3];
    /* The envelope's low and high renders tilt the gradient: the samples it subtracts take the other end of their
     * intervals (otherwise shifting every sample one way would leave differences, so normals, unperturbed). */
    const int mode = st->mode;
    const int other = mode == MODE_LO ? MODE_HI : mode == MODE_HI ? MODE_LO : mode;
    st->mode = other;
    const float d0 = forward ? sample(st, p) : 0.0f;
    st->mode = mode;
    for (int a = 0; a < 3; a++) {
        float q[3] = {p[0], p[1], p[2]};
        q[a] = p[a] + S->vs[a];
        const float plus = sample(st, q);
        if (forward) {
            g[a] = plus - d0;
        } else {
            q[a] = p[a] - S->vs[a];
            st->mode = other;
            g[a] = plus - sample(st, q);
            st->mode = mode;
        }
    }
    const float len2 = dot3(g, g);
    if (!(len2 > 0.0f) || len2 == INFINITY) {
        n[0] = 0.0f;
        n[1] = 1.0f;
        n[2] = 0.0f;
        return;
    }
    const float len = sqrtf(len2);
    for (int a = 0; a < 3; a++)
        n[a] = -(g[a] / len);
    if (mode >= MODE_TILT)
        tilt(st, p, forward, len, n);
}

typedef struct rm_pix {
    float rgba[4];
    uint32_t cross_k;
    float cross_t;
    float nc[3], nf[3];
    uint32_t steps, skipped, taken;
    uint64_t hash;
    int uncertain;
    int wall; /* the render met a wall event */
} rm_pix;

/* One pixel (§12.4). */
static void render(const rm_shared *S, uint32_t x, uint32_t y, int mode, int skip, int wall_alt, rm_pix *out)
{
    rm_state st;
    memset(&st, 0, sizeof st);
    st.S = S;
    st.mode = mode;
    st.skip = skip;
    st.certainty = S->envelope;
    st.wall_alt = wall_alt;
    st.pixel = y * S->W + x;
    st.hash = UINT64_C(0xcbf29ce484222325);
    memset(out, 0, sizeof *out);
    out->cross_k = RM_NONE;
    const rto_raymarch_uniforms *u = S->u;
    const rto_wf_ray ray = rto_camera_ray(&S->cam, S->W, S->H, x, y);
    float pos[3], dir[3], T[3] = {1.0f, 1.0f, 1.0f}, L[3] = {0.0f, 0.0f, 0.0f}, e[3];
    memcpy(pos, ray.origin, sizeof pos);
    memcpy(dir, ray.dir, sizeof dir);
    int inside = 0;
    const float ior = u->ior;
    float r0 = (1.0f - ior) / (1.0f + ior);
    r0 = r0 * r0;
    const uint32_t bounces = (uint32_t)u->num_refractions;
    for (uint32_t b = 0; b < bounces; b++) {
        const rm_hit h = search(&st, pos, dir, inside, b == 0);
        note(&st, ((uint64_t)b << 40) | ((uint64_t)h.found << 32) | (h.found ? h.k : 0));
        if (!h.found)
            break;
        for (int c = 0; c < 3; c++)
            T[c] = T[c] * expf(-(h.depth * u->extinction[c]));
        float nc[3], nf[3], n[3];
        normal_at(&st, h.p, 0, nc);
        normal_at(&st, h.p, 1, nf);
        if (b == 0) {
            out->cross_k = h.k;
            out->cross_t = h.t;
            memcpy(out->nc, nc, sizeof nc);
            memcpy(out->nf, nf, sizeof nf);
        }
        memcpy(n, mode == MODE_FORWARD ? nf : nc, sizeof n);
        if (dot3(n, dir) > 0.0f)
            for (int a = 0; a < 3; a++)
                n[a] = -n[a];
        const int entering = !inside;
        const float eta = entering ? 1.0f / ior : ior;
        const float cosi = -dot3(n, dir);
        float refl[3], refr[3] = {0.0f, 0.0f, 0.0f};
        for (int a = 0; a < 3; a++)
            refl[a] = dir[a] + (2.0f * cosi) * n[a];
        const float sin2t = (eta * eta) * (1.0f - cosi * cosi);
        const int tir = sin2t > 1.0f;
        float cost = 0.0f;
        if (!tir) {
            cost = sqrtf(1.0f - sin2t);
            const float k2 = eta * cosi - cost;
            for (int a = 0; a < 3; a++)
                refr[a] = eta * dir[a] + k2 * n[a];
        }
        float R = 1.0f;
        if (!tir) {
            const float xx = 1.0f - (entering ? cosi : cost);
            const float x5 = ((xx * xx) * (xx * xx)) * xx;
            R = r0 + (1.0f - r0) * x5;
        }
        const float Tr = 1.0f - R;
        const float dRefr = tir ? 0.0f : short_depth(&st, h.p, refr);
        const float dRefl = short_depth(&st, h.p, refl);
        const int trace_refr = dRefr * Tr > dRefl * R;
        if (st.mode == MODE_NOMINAL && st.certainty) {
            /* The path choice compares two marches whose samples a GPU may take anywhere in their intervals: it is
             * certain only where the intervals of the two sides (with 2^-10 of arithmetic) do not overlap. */
            st.mode = MODE_LO;
            const float rl = tir ? 0.0f : short_depth(&st, h.p, refr), ll = short_depth(&st, h.p, refl);
            st.mode = MODE_HI;
            const float rh = tir ? 0.0f : short_depth(&st, h.p, refr), lh = short_depth(&st, h.p, refl);
            st.mode = MODE_NOMINAL;
            const double ae = 0x1p-10;
            const double a_lo = (double)rl * Tr * (1 - ae), a_hi = (double)rh * Tr * (1 + ae) + 0x1p-30;
            const double b_lo = (double)ll * R * (1 - ae), b_hi = (double)lh * R * (1 + ae) + 0x1p-30;
            if (!(a_lo > b_hi || a_hi < b_lo) && !(tir && !trace_refr))
                st.uncertain = 1;
        }
        note(&st, 0x7000 + (uint64_t)tir * 2 + (uint64_t)trace_refr);
        if (trace_refr) {
            environment(&st, h.p, refl, e);
            for (int c = 0; c < 3; c++)
                L[c] = L[c] + ((e[c] * T[c]) * expf(-(dRefl * u->extinction[c]))) * R;
            memcpy(dir, refr, sizeof dir);
            for (int c = 0; c < 3; c++)
                T[c] = T[c] * Tr;
            inside = !inside;
        } else {
            if (!tir) {
                environment(&st, h.p, refr, e);
                for (int c = 0; c < 3; c++)
                    L[c] = L[c] + ((e[c] * T[c]) * expf(-(dRefr * u->extinction[c]))) * Tr;
            }
            memcpy(dir, refl, sizeof dir);
            for (int c = 0; c < 3; c++)
                T[c] = T[c] * R;
        }
        memcpy(pos, h.p, sizeof pos);
        if (T[0] < 0.01f && T[1] < 0.01f && T[2] < 0.01f) {
            note(&st, 0xe000);
            break;
        }
    }
    const float rem = shadow_depth(&st, pos, dir);
    environment(&st, pos, dir, e);
    for (int c = 0; c < 3; c++)
        L[c] = L[c] + (e[c] * T[c]) * expf(-(rem * u->extinction[c]));
    out->rgba[0] = L[0];
    out->rgba[1] = L[1];
    out->rgba[2] = L[2];
    out->rgba[3] = 1.0f;
    out->steps = st.steps;
    out->skipped = st.skipped;
    out->taken = st.taken;
    out->hash = st.hash;
    out->uncertain = st.uncertain;
    out->wall = st.wall;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Parameters, uniforms, the whole image                                                                            */

void rto_raymarch_params_default(const rto_splat *vol, rto_raymarch_params *p)
{
    memset(p, 0, sizeof *p);
    p->width = 160;
    p->height = 120;
    float vmin = 1.0f;
    rto_aabb bounds = {{-1.0f, -1.0f, -1.0f}, {1.0f, 1.0f, 1.0f}};
    if (vol) {
        bounds = vol->params.bounds;
        const float *vs = vol->uniforms.voxel_size;
        vmin = rto__minf(rto__minf(vs[0], vs[1]), vs[2]);
    }
    p->camera = rto_camera_frame(&bounds, (float)p->width / (float)p->height);
    p->step_size = vmin * 0.5f;
    p->light_step_size = vmin * 2.0f;
    p->density_offset = 100.0f;
    p->density_multiplier = 0.01f;
    p->extinction[0] = 1.2f;
    p->extinction[1] = 0.6f;
    p->extinction[2] = 0.25f;
    const double sx = 0.3, sy = 1.0, sz = 0.2, sl = sqrt(sx * sx + sy * sy + sz * sz);
    p->sun_dir[0] = (float)(sx / sl);
    p->sun_dir[1] = (float)(sy / sl);
    p->sun_dir[2] = (float)(sz / sl);
    p->ior = 1.33f;
    p->num_refractions = 4;
    p->floor_height = bounds.min.y;
    p->jitter_scale = 0.4f;
    p->jitter_seed = 3;
    p->skip = 1;
    p->envelope = 1;
}

static int finite_pos(float v) { return v > 0.0f && v < 3.0e38f; }

rto_status rto_raymarch_uniforms_make(const rto_splat *vol, const rto_raymarch_params *p, rto_raymarch_uniforms *u,
                                      rto_msg *msg)
{
    if (!vol || !p || !u || !vol->volume_f16)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: no volume");
    if (p->width < 1 || p->width > 16384 || p->height < 1 || p->height > 16384)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: image size %ux%u outside 1..16384", p->width,
                         p->height);
    if (!finite_pos(p->step_size) || !finite_pos(p->light_step_size) || !finite_pos(p->density_multiplier) ||
        !finite_pos(p->ior) || !(fabsf(p->density_offset) < 1.0e30f) || !(fabsf(p->floor_height) < 1.0e30f) ||
        !(p->jitter_scale >= 0.0f && p->jitter_scale <= 1.0f))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                         "raymarch: step, light step, multiplier and ior must be finite and > 0, offset and floor "
                         "finite, jitter in [0, 1]");
    for (int c = 0; c < 3; c++)
        if (!(p->extinction[c] >= 0.0f && p->extinction[c] < 1.0e30f))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: extinction must be finite and >= 0");
    if (p->num_refractions > 16)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: at most 16 refractions");
    const double sl = sqrt((double)p->sun_dir[0] * p->sun_dir[0] + (double)p->sun_dir[1] * p->sun_dir[1] +
                           (double)p->sun_dir[2] * p->sun_dir[2]);
    if (!(sl > 1e-6 && sl < 1e30))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: the sun direction must be finite and non-zero");
    for (int a = 0; a < 3; a++)
        if (vol->params.res[a] < 1 || vol->params.res[a] > 1024)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: volume resolution outside 1..1024");
    /* A march of 512 samples must stay cheap: refuse steps that make a volume cell thousands of samples long. */
    rto_camera_uniforms cu;
    rto_status s = rto_camera_uniforms_make(&p->camera, p->width, p->height, &cu, msg);
    if (s)
        return s;
    memset(u, 0, sizeof *u);
    memcpy(u->inverse_projection, cu.inverse_projection, sizeof u->inverse_projection);
    memcpy(u->inverse_view, cu.inverse_view, sizeof u->inverse_view);
    memcpy(u->eye, cu.position, sizeof u->eye);
    u->step_size = p->step_size;
    u->light_step_size = p->light_step_size;
    u->bounds_min[0] = vol->params.bounds.min.x;
    u->bounds_min[1] = vol->params.bounds.min.y;
    u->bounds_min[2] = vol->params.bounds.min.z;
    u->bounds_max[0] = vol->params.bounds.max.x;
    u->bounds_max[1] = vol->params.bounds.max.y;
    u->bounds_max[2] = vol->params.bounds.max.z;
    for (int a = 0; a < 3; a++)
        if (!(u->bounds_max[a] > u->bounds_min[a]) || !(fabsf(u->bounds_min[a]) < 1e30f) ||
            !(fabsf(u->bounds_max[a]) < 1e30f))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: empty or non-finite bounds");
    u->density_offset = p->density_offset;
    u->density_multiplier = p->density_multiplier;
    for (int c = 0; c < 3; c++) {
        u->extinction[c] = p->extinction[c];
        u->sun_dir[c] = (float)(p->sun_dir[c] / sl);
        u->res[c] = (float)vol->params.res[c];
    }
    u->ior = p->ior;
    u->floor_height = p->floor_height;
    u->num_refractions = (float)p->num_refractions;
    u->jitter_scale = p->jitter_scale;
    u->jitter_seed = p->jitter_seed;
    u->width = (float)p->width;
    u->height = (float)p->height;
    u->skip = (p->skip && p->density_offset > 0.0f && vol->occupancy && vol->occupancy_levels > 0) ? 1.0f : 0.0f;
    u->occupancy = (float)vol->params.occupancy;
    u->occupancy_levels = (float)vol->occupancy_levels;
    return RTO_OK;
}

void rto_raymarch_free(rto_raymarch *r)
{
    if (!r)
        return;
    free(r->image);
    free(r->crossing);
    free(r->crossing_lo);
    free(r->crossing_hi);
    free(r->crossing_t);
    free(r->normal_central);
    free(r->normal_forward);
    free(r->steps);
    free(r->steps_skip);
    free(r->steps_min);
    free(r->certain);
    free(r->tolerance);
    free(r->image_wall);
    free(r->tolerance_wall);
    memset(r, 0, sizeof *r);
}

typedef struct rm_job {
    const rm_shared *S;
    rto_raymarch *r;
    uint8_t *differ;   /* per pixel: 1 image differs, 2 crossing differs */
    uint32_t *skipped; /* per pixel */
} rm_job;

/* The envelope of a pixel whose nominal render (wall_alt: of a wall event's other outcome) is a (§12.5.1): 1 and the
 * image tolerance when its decisions are certain and the low, high and tilt renders make the same ones, else 0. */
static int envelope(const rm_shared *S, uint32_t x, uint32_t y, int wall_alt, const rm_pix *a, float *tol)
{
    *tol = INFINITY;
    if (a->uncertain)
        return 0;
    rm_pix lo, hi, fw, tl[RM_TILTS];
    render(S, x, y, MODE_LO, 0, wall_alt, &lo);
    render(S, x, y, MODE_HI, 0, wall_alt, &hi);
    if (lo.hash != a->hash || hi.hash != a->hash)
        return 0;
    for (int k = 0; k < RM_TILTS; k++) {
        render(S, x, y, MODE_TILT + k, 0, wall_alt, &tl[k]);
        if (tl[k].uncertain || tl[k].hash != a->hash)
            return 0;
    }
    render(S, x, y, MODE_FORWARD, 0, wall_alt, &fw);
    double dev = 0;
    for (int c = 0; c < 3; c++) {
        dev = fmax(dev, fabs((double)lo.rgba[c] - a->rgba[c]));
        dev = fmax(dev, fabs((double)hi.rgba[c] - a->rgba[c]));
        if (fw.hash == a->hash)
            dev = fmax(dev, fabs((double)fw.rgba[c] - a->rgba[c]));
        for (int k = 0; k < RM_TILTS; k++)
            dev = fmax(dev, fabs((double)tl[k].rgba[c] - a->rgba[c]));
    }
    *tol = (float)(2.0 * dev + 0x1p-10);
    return 1;
}

static void pixels(void *arg, uint32_t worker, size_t begin, size_t end)
{
    (void)worker;
    rm_job *j = arg;
    const rm_shared *S = j->S;
    rto_raymarch *r = j->r;
    for (size_t i = begin; i < end; i++) {
        const uint32_t x = (uint32_t)(i % S->W), y = (uint32_t)(i / S->W);
        rm_pix a, b;
        render(S, x, y, MODE_NOMINAL, r->params.skip_only && S->skip_ok, 0, &a);
        memcpy(r->image + 4 * i, a.rgba, sizeof a.rgba);
        r->crossing[i] = a.cross_k;
        r->crossing_t[i] = a.cross_t;
        memcpy(r->normal_central + 3 * i, a.nc, sizeof a.nc);
        memcpy(r->normal_forward + 3 * i, a.nf, sizeof a.nf);
        r->steps[i] = a.steps;
        r->steps_skip[i] = a.steps;
        r->steps_min[i] = a.taken;
        j->skipped[i] = 0;
        j->differ[i] = 0;
        if (S->skip_ok && !r->params.skip_only) {
            render(S, x, y, MODE_NOMINAL, 1, 0, &b);
            r->steps_skip[i] = b.steps;
            j->skipped[i] = b.skipped;
            if (memcmp(a.rgba, b.rgba, sizeof a.rgba) || a.hash != b.hash)
                j->differ[i] |= 1;
            if (a.cross_k != b.cross_k || memcmp(&a.cross_t, &b.cross_t, sizeof a.cross_t))
                j->differ[i] |= 2;
        }
        {
            rm_state st;
            memset(&st, 0, sizeof st);
            st.S = S;
            st.pixel = (uint32_t)i;
            const rto_wf_ray ray = rto_camera_ray(&S->cam, S->W, S->H, x, y);
            admissible(&st, ray.origin, ray.dir, &r->crossing_lo[i], &r->crossing_hi[i]);
        }
        r->certain[i] = 0;
        r->tolerance[i] = INFINITY;
        for (int c = 0; c < 4; c++)
            r->image_wall[4 * i + c] = NAN;
        r->tolerance_wall[i] = NAN;
        if (r->params.envelope && envelope(S, x, y, 0, &a, &r->tolerance[i])) {
            r->certain[i] = 1;
            if (a.wall) {
                /* the other outcome of the first wall event (§12.5.1), with its own envelope */
                rm_pix w;
                float tw;
                render(S, x, y, MODE_NOMINAL, 0, 1, &w);
                if (envelope(S, x, y, 1, &w, &tw)) {
                    memcpy(r->image_wall + 4 * i, w.rgba, sizeof w.rgba);
                    r->tolerance_wall[i] = tw;
                } else {
                    r->certain[i] = 0;
                    r->tolerance[i] = INFINITY;
                }
            }
        }
    }
}

rto_status rto_raymarch_make(const rto_splat *vol, const rto_raymarch_params *p, rto_raymarch *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: no output");
    memset(out, 0, sizeof *out);
    rto_raymarch_uniforms u;
    rto_status s = rto_raymarch_uniforms_make(vol, p, &u, msg);
    if (s)
        return s;
    rm_shared S;
    memset(&S, 0, sizeof S);
    S.vol = vol;
    S.u = &out->uniforms;
    S.W = p->width;
    S.H = p->height;
    S.quant = p->quantize_weights;
    S.envelope = p->envelope;
    S.params = p;
    S.O = vol->params.occupancy;
    S.levels = vol->occupancy_levels;
    s = rto_camera_uniforms_make(&p->camera, p->width, p->height, &S.cam, msg);
    if (s)
        return s;
    for (int a = 0; a < 3; a++) {
        S.n[a] = vol->params.res[a];
        S.bmin[a] = u.bounds_min[a];
        S.bmax[a] = u.bounds_max[a];
        S.ext[a] = S.bmax[a] - S.bmin[a];
        S.vs[a] = vol->uniforms.voxel_size[a];
        S.cs[a] = ((double)S.bmax[a] - S.bmin[a]) / (S.O ? S.O : 1);
        S.bmag = fmax(S.bmag, fmax(fabs(S.bmin[a]), fabs(S.bmax[a])));
    }
    S.skip_ok = u.skip != 0.0f && S.O >= 1 && S.levels >= 1;
    out->params = *p;
    out->uniforms = u;
    const size_t n = (size_t)p->width * p->height;
    out->image = malloc(n * 4 * sizeof(float));
    out->crossing = malloc(n * sizeof(uint32_t));
    out->crossing_lo = malloc(n * sizeof(uint32_t));
    out->crossing_hi = malloc(n * sizeof(uint32_t));
    out->crossing_t = malloc(n * sizeof(float));
    out->normal_central = malloc(n * 3 * sizeof(float));
    out->normal_forward = malloc(n * 3 * sizeof(float));
    out->steps = malloc(n * sizeof(uint32_t));
    out->steps_skip = malloc(n * sizeof(uint32_t));
    out->steps_min = malloc(n * sizeof(uint32_t));
    out->certain = malloc(n);
    out->tolerance = malloc(n * sizeof(float));
    out->image_wall = malloc(4 * n * sizeof(float));
    out->tolerance_wall = malloc(n * sizeof(float));
    rm_job j = {&S, out, malloc(n), malloc(n * sizeof(uint32_t))};
    if (!out->image || !out->crossing || !out->crossing_lo || !out->crossing_hi || !out->crossing_t ||
        !out->normal_central || !out->normal_forward || !out->steps || !out->steps_skip || !out->steps_min || !out->certain ||
        !out->tolerance || !out->image_wall || !out->tolerance_wall || !j.differ || !j.skipped) {
        free(j.differ);
        free(j.skipped);
        rto_raymarch_free(out);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "raymarch: out of memory for a %ux%u image", p->width,
                         p->height);
    }
    rto__parallel_ranges(n, p->threads, pixels, &j);
    rto_raymarch_stats *st = &out->stats;
    st->pixels = n;
    st->skip_enabled = S.skip_ok;
    double asum = 0;
    uint64_t an = 0;
    for (size_t i = 0; i < n; i++) {
        st->steps_total += out->steps[i];
        st->steps_skip_total += out->steps_skip[i];
        st->steps_max = out->steps[i] > st->steps_max ? out->steps[i] : st->steps_max;
        st->steps_skip_max = out->steps_skip[i] > st->steps_skip_max ? out->steps_skip[i] : st->steps_skip_max;
        st->skipped_samples += j.skipped[i];
        st->differing_pixels += (j.differ[i] & 1) != 0;
        st->differing_crossings += (j.differ[i] & 2) != 0;
        if (out->certain[i])
            st->certain++;
        if (out->certain[i] && out->tolerance_wall[i] == out->tolerance_wall[i])
            st->wall_pixels++;
        if (out->crossing[i] != RM_NONE) {
            st->crossings++;
            const float *a = out->normal_central + 3 * i, *b = out->normal_forward + 3 * i;
            double c = ((double)a[0] * b[0] + (double)a[1] * b[1]) + (double)a[2] * b[2];
            c = c > 1 ? 1 : c < -1 ? -1 : c;
            const double ang = acos(c) * (180.0 / 3.14159265358979323846);
            asum += ang;
            an++;
            st->normal_angle_max = ang > st->normal_angle_max ? ang : st->normal_angle_max;
        }
    }
    st->uncertain = n - st->certain;
    st->normal_angle_mean = an ? asum / (double)an : 0.0;
    free(j.differ);
    free(j.skipped);
    return RTO_OK;
}
