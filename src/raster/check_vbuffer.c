/* Validation of a GPU's visibility buffer, edge mask and image (DESIGN.md §11.6). Each pass is checked on its own
 * inputs. The visibility plane against the oracle's admissible sets (§11.3): a sample's (instance, primitive) must be
 * one of them, exactly where the set has one member. The attribute planes against the triangle the GPU chose, not the
 * oracle's: rto__raster_eval gives the range every admissible rasterization of that triangle produces at the sample,
 * which is rounded outward to the plane's format (binary16 down and up; depth as binary32, or as the unorm24 value a
 * depth24plus target stores). Two faults fit inside those per-sample intervals and are found over the whole plane:
 * binary16 rounded toward zero (the GPU holds the truncation wherever truncation and nearest differ) and a constant
 * depth offset (the mean difference from the reference, in unorm24 steps). The edge mask is compared with the
 * classifier run on the GPU's own planes, with a pixel whose decision turns on a comparison within 2^-10 of its
 * threshold free to go either way; the image with the material pass on the GPU's own planes and mask.
 *
 * Every class's first fault (in sample order: row by row, pixel by pixel, sample by sample) is kept, and the report
 * names the first class in rto_vb_fault's order: a visibility fault before an attribute fault before a plane-wide one
 * before the mask and the image, since each later check reads what the earlier ones vouch for. */
#include "internal.h"
#include "raster/material_internal.h"
#include "raster/raster_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *rto_vb_fault_name(rto_vb_fault fault)
{
    switch (fault) {
    case RTO_VB_PASS: return "pass";
    case RTO_VB_COVERAGE: return "coverage";
    case RTO_VB_ID: return "id";
    case RTO_VB_BARYCENTRIC: return "barycentric";
    case RTO_VB_NORMAL: return "normal";
    case RTO_VB_DERIVATIVE: return "derivative";
    case RTO_VB_DEPTH: return "depth";
    case RTO_VB_F16_ROUNDING: return "f16-rounding";
    case RTO_VB_EDGE_MASK: return "edge-mask";
    case RTO_VB_SHADING: return "shading";
    }
    return "unknown";
}

#define FAULT_COUNT (RTO_VB_SHADING + 1)

/* planes_checked bits, in the order of rto_vbuffer_check_result's comment. */
enum { BIT_VISIBILITY = 0, BIT_BARYCENTRIC, BIT_NORMAL, BIT_DERIVATIVES, BIT_DEPTH, BIT_MASK, BIT_IMAGE };

/* 2^24 - 1: the largest unorm24 value, 1.0 in depth24plus. */
#define UNORM24_MAX 16777215.0
/* §11.6's plane-wide tests: the rounding test's share (9 in 10) and least count, the depth offset test's least count
 * and bound (half a unorm24 step). */
#define ROUNDING_MIN_SAMPLES 32
#define OFFSET_MIN_SAMPLES 1000
#define OFFSET_BOUND 0.5
#define OFFSET_WINDOW 8.0
/* §11.6: a classifier decision within 2^-10 relative of a threshold may go either way. */
#define MASK_MARGIN 0x1p-10
/* §11.6: the image within 2 binary16 ulps plus 2^-12 of the material pass on the GPU's planes. */
#define IMAGE_ULPS 2.0
#define IMAGE_ABS 0x1p-12
/* §11.6: the normal within 2 binary16 ulps of the chosen triangle's encoded face normal. */
#define NORMAL_ULPS 2.0

/* ------------------------------------------------------------------------------------------------------------------ */
/* binary16 on the binary64 number line (every binary16 value is exact in binary64)                                    */

/* The spacing of binary16 values at magnitude a (finite, >= 0): 2^-24 among subnormals, 2^(e - 10) in [2^e, 2^e+1). */
static double f16_ulp(double a)
{
    if (a < 0x1p-14)
        return 0x1p-24;
    int e;
    frexp(a, &e); /* a = m 2^e, 0.5 <= m < 1: a lies in [2^(e-1), 2^e) */
    if (e > 16)
        e = 16;
    return ldexp(1.0, e - 11);
}

/* The largest binary16 value <= x (-inf below -65504), and the smallest >= x; NaN stays NaN. */
static double f16_down(double x)
{
    if (isnan(x))
        return x;
    if (x > 65504.0)
        return 65504.0;
    if (x < -65504.0)
        return -INFINITY;
    const double u = f16_ulp(fabs(x));
    return floor(x / u) * u; /* x / u and the product are exact: u is a power of two */
}

static double f16_up(double x) { return -f16_down(-x); }

static double f16_value(uint16_t h) { return (double)rto_f16_to_f32(h); }

/* ------------------------------------------------------------------------------------------------------------------ */
/* Findings                                                                                                             */

typedef struct finding {
    int set;
    size_t k; /* the sample (per-pixel planes: the pixel's sample 0) */
    const char *plane;
    char what[512];
} finding;

/* The plane-wide rounding test's count over one plane: samples where the nearest and the truncated binary16 of the
 * reference differ, those where the GPU holds the truncation, and the first of these. */
typedef struct rounding_count {
    uint64_t differ, truncated;
    size_t first_k;
    int first_channel;
    float first_ref;
    uint16_t first_gpu;
} rounding_count;

/* What one worker (a range of rows) finds; merged in row order, so the result does not depend on the threads. */
typedef struct part {
    finding first[FAULT_COUNT];
    uint64_t compared, other_admissible;
    rounding_count rounding[2]; /* barycentric, normal */
    int64_t offset_sum;         /* sum of (gpu - ref) (2^24 - 1), in 2^-20 steps: integers add in any order */
    uint64_t offset_count, offset_above, offset_below; /* ... how many, and how many above and below it */
    size_t offset_first_k;
} part;

#define OFFSET_FIXED 0x1p20

static void note(finding *f, size_t k, const char *plane, const char *fmt, ...) RTO_PRINTF(4, 5);
static void note(finding *f, size_t k, const char *plane, const char *fmt, ...)
{
    if (f->set)
        return;
    f->set = 1;
    f->k = k;
    f->plane = plane;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(f->what, sizeof f->what, fmt, ap);
    va_end(ap);
}

typedef struct checker {
    const rto_vbuffer_check_desc *d;
    const rto_vbuffer *e;
    const rto_vbuffer_planes *g;
    uint32_t width, height, samples;
    part *parts;
} checker;

/* "instance I primitive P", or "background". */
static void id_text(char *buf, size_t cap, uint32_t inst, uint32_t prim)
{
    if (inst == RTO_VB_BACKGROUND && prim == RTO_VB_BACKGROUND)
        snprintf(buf, cap, "background");
    else
        snprintf(buf, cap, "instance %" PRIu32 " primitive %" PRIu32, inst, prim);
}

/* The admissible set of sample k as text: "{instance 0 primitive 3, background}" (the first four members). */
static void set_text(const rto_vbuffer *e, size_t k, char *buf, size_t cap)
{
    const uint32_t *set = e->admissible + 2 * (size_t)e->admissible_offset[k];
    const uint32_t n = e->admissible_offset[k + 1] - e->admissible_offset[k];
    size_t len = (size_t)snprintf(buf, cap, "{");
    for (uint32_t j = 0; j < n && j < 4 && len < cap; j++) {
        char id[64];
        id_text(id, sizeof id, set[2 * j], set[2 * j + 1]);
        len += (size_t)snprintf(buf + len, cap - len, "%s%s", j ? ", " : "", id);
    }
    if (len < cap)
        snprintf(buf + len, cap - len, n > 4 ? ", ... %" PRIu32 " in all}" : "}", n);
}

static uint32_t word_pair(const uint16_t *w) { return (uint32_t)w[0] | (uint32_t)w[1] << 16; }

/* A binary16 channel of sample k against [lo, hi] rounded outward; 1 when inside. */
static int f16_inside(uint16_t h, float lo, float hi, double *glo, double *ghi)
{
    *glo = f16_down((double)lo);
    *ghi = f16_up((double)hi);
    const double v = f16_value(h);
    return v >= *glo && v <= *ghi;
}

static void count_rounding(rounding_count *rc, size_t k, int channel, float ref, uint16_t gpu)
{
    const uint16_t rne = rto_f16_from_f32(ref), rtz = rto__f16_from_f32_rtz(ref);
    if (rne == rtz || isnan(ref))
        return;
    rc->differ++;
    if (gpu != rtz)
        return;
    if (rc->truncated++ == 0) {
        rc->first_k = k;
        rc->first_channel = channel;
        rc->first_ref = ref;
        rc->first_gpu = gpu;
    }
}

/* The cleared value of a background sample: binary16 0 (either sign) in the attribute planes, 1.0 in depth. */
static void check_background(const checker *c, part *p, size_t k)
{
    const rto_vbuffer_planes *g = c->g;
    static const char *const bary_names[2] = {"b1", "b2"};
    static const char *const deriv_names[4] = {"ddx.b1", "ddx.b2", "ddy.b1", "ddy.b2"};
    for (int ch = 0; g->barycentric && ch < 2; ch++)
        if (f16_value(g->barycentric[2 * k + (size_t)ch]) != 0.0)
            note(&p->first[RTO_VB_BARYCENTRIC], k, "barycentric",
                 "background sample: %s = %.9g (0x%04x), but a background sample holds the cleared value 0",
                 bary_names[ch], f16_value(g->barycentric[2 * k + (size_t)ch]), g->barycentric[2 * k + (size_t)ch]);
    for (int ch = 0; g->normal && ch < 4; ch++)
        if (f16_value(g->normal[4 * k + (size_t)ch]) != 0.0)
            note(&p->first[RTO_VB_NORMAL], k, "normal",
                 "background sample: channel %d = %.9g (0x%04x), but a background sample holds the cleared value 0",
                 ch, f16_value(g->normal[4 * k + (size_t)ch]), g->normal[4 * k + (size_t)ch]);
    for (int ch = 0; g->derivatives && ch < 4; ch++)
        if (f16_value(g->derivatives[4 * k + (size_t)ch]) != 0.0)
            note(&p->first[RTO_VB_DERIVATIVE], k, "derivatives",
                 "background sample: %s = %.9g (0x%04x), but a background sample holds the cleared value 0",
                 deriv_names[ch], f16_value(g->derivatives[4 * k + (size_t)ch]), g->derivatives[4 * k + (size_t)ch]);
    if (g->depth && g->depth[k] != 1.0f)
        note(&p->first[RTO_VB_DEPTH], k, "depth",
             "background sample: depth %.9g, but a background sample holds the cleared depth 1.0", (double)g->depth[k]);
    if (g->depth_unorm24 && g->depth_unorm24[k] != 16777215u)
        note(&p->first[RTO_VB_DEPTH], k, "depth",
             "background sample: unorm24 depth %" PRIu32 ", but a background sample holds the cleared 16777215 (1.0)",
             g->depth_unorm24[k]);
}

/* Depth d (binary32) inside [lo, hi], or stored as unorm24: d = k / (2^24 - 1) rounded to binary32 with k in
 * [floor(lo M), ceil(hi M)]. */
static int depth_inside(float d, float lo, float hi)
{
    if ((double)d >= (double)lo && (double)d <= (double)hi)
        return 1;
    const double kd = floor((double)d * UNORM24_MAX + 0.5);
    return (float)(kd / UNORM24_MAX) == d && kd >= floor((double)lo * UNORM24_MAX) &&
           kd <= ceil((double)hi * UNORM24_MAX);
}

/* The attribute planes of sample k, where the GPU chose triangle (inst, prim) and set tells whether the sample is
 * certain (one admissible member). */
static void check_attributes(const checker *c, part *p, size_t k, uint32_t x, uint32_t y, uint32_t s, uint32_t inst,
                             uint32_t prim, int certain)
{
    const rto_vbuffer_planes *g = c->g;
    rto__vb_attr ref, lo, hi;
    if (!rto__raster_eval(c->e->raster, inst, prim, x, y, s, &ref, &lo, &hi))
        return; /* degenerate, or behind the camera at every choice: nothing the planes could be compared with */
    char who[64];
    id_text(who, sizeof who, inst, prim);
    double glo, ghi;
    if (g->barycentric) {
        static const char *const names[2] = {"b1", "b2"};
        for (int ch = 0; ch < 2; ch++) {
            const uint16_t h = g->barycentric[2 * k + (size_t)ch];
            if (!f16_inside(h, lo.b[ch], hi.b[ch], &glo, &ghi))
                note(&p->first[RTO_VB_BARYCENTRIC], k, "barycentric",
                     "%s = %.9g (0x%04x), outside [%.9g, %.9g], what the admissible rasterizations of %s give at the "
                     "pixel centre (reference %.9g, binary16 0x%04x)",
                     names[ch], f16_value(h), h, glo, ghi, who, (double)ref.b[ch], rto_f16_from_f32(ref.b[ch]));
            count_rounding(&p->rounding[0], k, ch, ref.b[ch], h);
        }
    }
    if (g->normal) {
        float n[3], enc[2];
        rto__raster_face_normal(c->e->raster, inst, prim, n);
        rto__oct_encode(n, enc);
        for (int ch = 0; ch < 2; ch++) {
            const uint16_t h = g->normal[4 * k + (size_t)ch];
            const double v = f16_value(h), tol = NORMAL_ULPS * f16_ulp(fabs((double)enc[ch]));
            if (!(fabs(v - (double)enc[ch]) <= tol))
                note(&p->first[RTO_VB_NORMAL], k, "normal",
                     "octahedral %c = %.9g (0x%04x), but %s's face normal (%.6g, %.6g, %.6g) encodes to %.9g (0x%04x); "
                     "the bound is 2 binary16 ulps (%.3g)",
                     ch ? 'y' : 'x', v, h, who, (double)n[0], (double)n[1], (double)n[2], (double)enc[ch],
                     rto_f16_from_f32(enc[ch]), tol);
            count_rounding(&p->rounding[1], k, ch, enc[ch], h);
        }
        const uint16_t angle = g->normal[4 * k + 2], hand = g->normal[4 * k + 3];
        if (f16_value(angle) != 0.0 || f16_value(hand) != 1.0)
            note(&p->first[RTO_VB_NORMAL], k, "normal",
                 "tangent channels (%.9g, %.9g) (0x%04x, 0x%04x), but they are the constants (0, 1): scenes carry no "
                 "vertex tangents",
                 f16_value(angle), f16_value(hand), angle, hand);
    }
    if (g->derivatives) {
        static const char *const names[4] = {"ddx.b1", "ddx.b2", "ddy.b1", "ddy.b2"};
        const float rv[4] = {ref.ddx[0], ref.ddx[1], ref.ddy[0], ref.ddy[1]};
        const float lv[4] = {lo.ddx[0], lo.ddx[1], lo.ddy[0], lo.ddy[1]};
        const float hv[4] = {hi.ddx[0], hi.ddx[1], hi.ddy[0], hi.ddy[1]};
        for (int ch = 0; ch < 4; ch++) {
            const uint16_t h = g->derivatives[4 * k + (size_t)ch];
            if (!f16_inside(h, lv[ch], hv[ch], &glo, &ghi))
                note(&p->first[RTO_VB_DERIVATIVE], k, "derivatives",
                     "%s = %.9g (0x%04x), outside [%.9g, %.9g], what dpdxFine / dpdyFine of %s's barycentrics give over "
                     "the pixel's 2x2 quad (reference %.9g)",
                     names[ch], f16_value(h), h, glo, ghi, who, (double)rv[ch]);
        }
    }
    if (g->depth) {
        const float d = g->depth[k];
        if (!depth_inside(d, lo.depth, hi.depth))
            note(&p->first[RTO_VB_DEPTH], k, "depth",
                 "depth %.9g (unorm24 %.1f), outside [%.9g, %.9g], what the admissible rasterizations of %s give at "
                 "the sample, as binary32 or as depth24plus's unorm24 (reference %.9g)",
                 (double)d, (double)d * UNORM24_MAX, (double)lo.depth, (double)hi.depth, who, (double)ref.depth);
        else if (certain) {
            /* The offset test reads the samples whose GPU depth lies within OFFSET_WINDOW steps of the reference: a
             * device's own sub-pixel precision moves depth by tens of steps on a tilted triangle, one way over the
             * whole triangle, and the samples near its zero are as many on either side; an offset moves every
             * sample of a device at the reference's precision, and stays inside the window. */
            const double diff = ((double)d - (double)ref.depth) * UNORM24_MAX;
            if (fabs(diff) <= OFFSET_WINDOW) {
                if (p->offset_count++ == 0)
                    p->offset_first_k = k;
                p->offset_sum += (int64_t)llround(diff * OFFSET_FIXED);
                p->offset_above += diff > 0.0;
                p->offset_below += diff < 0.0;
            }
        }
    }
    if (g->depth_unorm24) {
        const uint32_t u = g->depth_unorm24[k];
        const double klo = floor((double)lo.depth * UNORM24_MAX), khi = ceil((double)hi.depth * UNORM24_MAX);
        if (!((double)u >= klo && (double)u <= khi))
            note(&p->first[RTO_VB_DEPTH], k, "depth",
                 "unorm24 depth %" PRIu32 ", outside [%.0f, %.0f], the unorm24 values of what the admissible "
                 "rasterizations of %s give at the sample (reference %.9g, unorm24 %.0f)",
                 u, klo, khi, who, (double)ref.depth, floor((double)ref.depth * UNORM24_MAX + 0.5));
    }
}

/* Rows [begin, end): the visibility plane and the attribute planes. */
static void check_rows(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    const checker *c = ctx;
    part *p = &c->parts[worker];
    const rto_vbuffer *e = c->e;
    const rto_vbuffer_planes *g = c->g;
    const uint32_t S = c->samples;
    for (size_t y = begin; y < end; y++)
        for (uint32_t x = 0; x < c->width; x++)
            for (uint32_t s = 0; s < S; s++) {
                const size_t k = ((size_t)y * c->width + x) * S + s;
                const uint32_t *set = e->admissible + 2 * (size_t)e->admissible_offset[k];
                const uint32_t n = e->admissible_offset[k + 1] - e->admissible_offset[k];
                const uint32_t ref_prim = word_pair(&e->planes.visibility[4 * k]);
                const uint32_t ref_inst = word_pair(&e->planes.visibility[4 * k + 2]);
                uint32_t inst = ref_inst, prim = ref_prim;
                int admissible = 1;
                if (g->visibility) {
                    prim = word_pair(&g->visibility[4 * k]);
                    inst = word_pair(&g->visibility[4 * k + 2]);
                    admissible = 0;
                    for (uint32_t j = 0; j < n && !admissible; j++)
                        admissible = set[2 * j] == inst && set[2 * j + 1] == prim;
                } else if (n != 1) {
                    continue; /* not dumped: only where the oracle's answer is the only one are the others checked */
                }
                p->compared++;
                const int background_ok = n > 0 && set[2 * (n - 1)] == RTO_VB_BACKGROUND;
                const int gpu_background = inst == RTO_VB_BACKGROUND && prim == RTO_VB_BACKGROUND;
                const rto_vbuffer_geometry *geo = c->d->geometry;
                const int exists = gpu_background || !geo ||
                                   (inst < geo->instance_count && geo->instances[inst].blas < geo->mesh_count &&
                                    prim < geo->meshes[geo->instances[inst].blas].triangle_count);
                if (!admissible) {
                    char got[64], sets[320];
                    id_text(got, sizeof got, inst, prim);
                    set_text(e, k, sets, sizeof sets);
                    if (!exists)
                        note(&p->first[RTO_VB_ID], k, "visibility",
                             "%s, which the scene does not have (the words hold no triangle ID): admissible here %s",
                             got, sets);
                    else if (gpu_background && !background_ok)
                        note(&p->first[RTO_VB_COVERAGE], k, "visibility",
                             "background, but a triangle covers this sample under the top-left rule at every "
                             "admissible sub-pixel precision (4 to 8 bits): admissible here %s",
                             sets);
                    else if (!gpu_background && n == 1 && background_ok)
                        note(&p->first[RTO_VB_COVERAGE], k, "visibility",
                             "%s, but no triangle covers this sample at any admissible sub-pixel precision (4 to 8 "
                             "bits) under the top-left rule: background expected",
                             got);
                    else
                        note(&p->first[RTO_VB_ID], k, "visibility",
                             "%s (words 0x%04x 0x%04x 0x%04x 0x%04x), not in this sample's admissible set %s",
                             got, g->visibility[4 * k], g->visibility[4 * k + 1], g->visibility[4 * k + 2],
                             g->visibility[4 * k + 3], sets);
                    continue;
                }
                if (inst != ref_inst || prim != ref_prim)
                    p->other_admissible++;
                if (gpu_background)
                    check_background(c, p, k);
                else
                    check_attributes(c, p, k, x, (uint32_t)y, s, inst, prim, n == 1);
            }
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The whole check                                                                                                      */

static const char *const rounding_planes[2] = {"barycentric", "normal"};

static void set_fault(rto_vbuffer_check_result *r, const checker *c, rto_vb_fault f, const finding *fd)
{
    r->fault = f;
    r->plane = fd->plane;
    const size_t pixel = fd->k / c->samples;
    r->x = (uint32_t)(pixel % c->width);
    r->y = (uint32_t)(pixel / c->width);
    r->sample = (uint32_t)(fd->k % c->samples);
    snprintf(r->what, sizeof r->what, "%s", fd->what);
}

static const char *edge_word(int v) { return v ? "edge" : "interior"; }

rto_status rto_vbuffer_check(const rto_vbuffer_check_desc *desc, rto_vbuffer_check_result *result, rto_msg *msg)
{
    if (!desc || !result)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "rto_vbuffer_check: NULL description or result");
    memset(result, 0, sizeof *result);
    result->plane = "";
    const rto_vbuffer *e = desc->expected;
    const rto_vbuffer_planes *g = desc->gpu;
    if (!e || !e->raster || !e->admissible_offset || !e->planes.visibility)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "rto_vbuffer_check: no expected visibility buffer (make it "
                                                        "with rto_vbuffer_make)");
    if (!g)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "rto_vbuffer_check: no GPU planes");
    if (g->width != e->planes.width || g->height != e->planes.height || g->samples != e->planes.samples)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                         "the GPU's planes are %" PRIu32 " x %" PRIu32 " with %" PRIu32 " samples, the oracle's %" PRIu32
                         " x %" PRIu32 " with %" PRIu32,
                         g->width, g->height, g->samples, e->planes.width, e->planes.height, e->planes.samples);

    checker c = {desc, e, g, g->width, g->height, g->samples, NULL};
    const uint32_t workers = rto__thread_count(0);
    c.parts = calloc(workers, sizeof *c.parts);
    if (!c.parts)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "rto_vbuffer_check: out of memory");
    rto__parallel_ranges(c.height, workers, check_rows, &c);

    /* Merged in worker (row) order: each class's first finding is the first worker's that has one. */
    finding first[FAULT_COUNT];
    memset(first, 0, sizeof first);
    rounding_count rounding[2];
    memset(rounding, 0, sizeof rounding);
    int64_t offset_sum = 0;
    uint64_t offset_count = 0, offset_above = 0, offset_below = 0;
    size_t offset_first_k = 0;
    for (uint32_t w = 0; w < workers; w++) {
        const part *p = &c.parts[w];
        for (int f = 0; f < FAULT_COUNT; f++)
            if (!first[f].set && p->first[f].set)
                first[f] = p->first[f];
        result->compared += p->compared;
        result->other_admissible += p->other_admissible;
        for (int q = 0; q < 2; q++) {
            if (!rounding[q].truncated && p->rounding[q].truncated) {
                rounding[q].first_k = p->rounding[q].first_k;
                rounding[q].first_channel = p->rounding[q].first_channel;
                rounding[q].first_ref = p->rounding[q].first_ref;
                rounding[q].first_gpu = p->rounding[q].first_gpu;
            }
            rounding[q].differ += p->rounding[q].differ;
            rounding[q].truncated += p->rounding[q].truncated;
        }
        if (!offset_count && p->offset_count)
            offset_first_k = p->offset_first_k;
        offset_sum += p->offset_sum;
        offset_count += p->offset_count;
        offset_above += p->offset_above;
        offset_below += p->offset_below;
    }
    free(c.parts);

    if (g->visibility)
        result->planes_checked |= 1u << BIT_VISIBILITY;
    if (g->barycentric)
        result->planes_checked |= 1u << BIT_BARYCENTRIC;
    if (g->normal)
        result->planes_checked |= 1u << BIT_NORMAL;
    if (g->derivatives)
        result->planes_checked |= 1u << BIT_DERIVATIVES;
    if (g->depth || g->depth_unorm24)
        result->planes_checked |= 1u << BIT_DEPTH;

    /* Plane-wide: a constant depth offset (after any per-sample depth fault, which note keeps first). The mean must
     * be beyond half a step and 9 in 10 of the samples on its side: a device's own sub-pixel precision leaves a mean
     * of a few tenths of a step on some scenes (measured up to 0.34 at 5 bits), with the samples on both sides. */
    if (offset_count >= OFFSET_MIN_SAMPLES) {
        const double mean = (double)offset_sum / OFFSET_FIXED / (double)offset_count;
        const uint64_t side = mean > 0.0 ? offset_above : offset_below;
        if (fabs(mean) > OFFSET_BOUND && side * 10 >= offset_count * 9)
            note(&first[RTO_VB_DEPTH], offset_first_k, "depth",
                 "systematic offset of %+.3f unorm24 steps: the mean of (GPU - reference) depth over the %" PRIu64
                 " certain samples within 8 steps of it is beyond +-0.5 step, %" PRIu64 " of them on that side, "
                 "though each sample alone is within its interval; first of them here",
                 mean, offset_count, side);
    }
    /* Plane-wide: binary16 rounded toward zero. */
    for (int q = 0; q < 2 && !desc->any_f16_rounding; q++) {
        const rounding_count *rc = &rounding[q];
        if (rc->differ >= ROUNDING_MIN_SAMPLES && rc->truncated * 10 >= rc->differ * 9) {
            const uint16_t rne = rto_f16_from_f32(rc->first_ref), rtz = rto__f16_from_f32_rtz(rc->first_ref);
            note(&first[RTO_VB_F16_ROUNDING], rc->first_k, rounding_planes[q],
                 "binary16 rounded toward zero: of the %" PRIu64 " values whose nearest and truncated binary16 differ, "
                 "the GPU holds the truncation in %" PRIu64 " (here channel %d: reference %.9g, nearest 0x%04x, "
                 "truncated 0x%04x, GPU 0x%04x); RG16float / RGBA16float round to nearest even",
                 rc->differ, rc->truncated, rc->first_channel, (double)rc->first_ref, rne, rtz, rc->first_gpu);
        }
    }

    /* The material pass's inputs: the GPU's own planes, the oracle's where the GPU dumped none. */
    rto_vbuffer_planes own = *g;
    if (!own.visibility)
        own.visibility = e->planes.visibility;
    if (!own.barycentric)
        own.barycentric = e->planes.barycentric;
    if (!own.normal)
        own.normal = e->planes.normal;
    if (!own.derivatives)
        own.derivatives = e->planes.derivatives;
    if (!own.depth) {
        own.depth = e->planes.depth;
        own.depth_unorm24 = e->planes.depth_unorm24;
    }
    rto_vbuffer_material_desc fallback;
    memset(&fallback, 0, sizeof fallback);
    fallback.material = RTO_VB_NORMALS;
    const rto_vb_thresholds defaults = RTO_VB_THRESHOLDS_DEFAULT;
    fallback.thresholds = defaults;
    const rto_vbuffer_material_desc *mat = desc->material ? desc->material : &fallback;
    const size_t pixels = (size_t)c.width * c.height;

    if (desc->gpu_mask) {
        result->planes_checked |= 1u << BIT_MASK;
        size_t first_k = 0;
        int first_oracle = -1;
        for (uint32_t y = 0; y < c.height; y++)
            for (uint32_t x = 0; x < c.width; x++) {
                const size_t px = (size_t)y * c.width + x;
                const int dec = rto__vbuffer_classify_pixel(&own, &e->camera, &mat->thresholds, x, y, MASK_MARGIN);
                const int gm = desc->gpu_mask[px] != 0;
                if (dec == RTO__VB_EITHER) {
                    result->mask_either++;
                    continue;
                }
                if (dec == gm)
                    continue;
                if (gm)
                    result->mask_gpu_only++;
                else
                    result->mask_oracle_only++;
                if (first_oracle < 0) {
                    first_oracle = dec;
                    first_k = px * c.samples;
                }
            }
        if (first_oracle >= 0) {
            const rto_vb_thresholds *t = &mat->thresholds;
            note(&first[RTO_VB_EDGE_MASK], first_k, "edge-mask",
                 "%s (mask %u), but the classifier (thresholds normal %g, depth %g, sample depth %g) on the GPU's own "
                 "planes makes it %s, beyond 2^-10 of every threshold; %" PRIu64 " pixels differ (%" PRIu64
                 " edge only in the GPU's mask, %" PRIu64 " only in the classifier's)",
                 edge_word(!first_oracle), desc->gpu_mask[first_k / c.samples], (double)t->normal, (double)t->depth,
                 (double)t->sample_depth, edge_word(first_oracle), result->mask_gpu_only + result->mask_oracle_only,
                 result->mask_gpu_only, result->mask_oracle_only);
        }
    }

    rto_status st = RTO_OK;
    if (desc->gpu_image) {
        result->planes_checked |= 1u << BIT_IMAGE;
        uint8_t *mask = NULL;
        uint16_t *image = malloc(pixels * 4 * sizeof *image + 1);
        const uint8_t *use_mask = desc->gpu_mask;
        if (!use_mask) {
            mask = malloc(pixels + 1);
            if (mask && image)
                st = rto_vbuffer_classify(&own, &e->camera, &mat->thresholds, mask, msg);
            use_mask = mask;
        }
        if (!image || !use_mask)
            st = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "rto_vbuffer_check: out of memory");
        if (st == RTO_OK)
            st = rto_vbuffer_shade(&own, use_mask, desc->geometry, mat, image, msg);
        /* unlit's textured pixels: within the hull of what a GPU's filtering may read (§11.6) */
        float *lo = NULL, *hi = NULL;
        uint8_t *textured = NULL;
        if (st == RTO_OK && mat->material == RTO_VB_UNLIT) {
            lo = malloc(pixels * 4 * sizeof *lo + 1);
            hi = malloc(pixels * 4 * sizeof *hi + 1);
            textured = malloc(pixels + 1);
            st = lo && hi && textured ? rto__vbuffer_shade_bounds(&own, use_mask, desc->geometry, mat, lo, hi,
                                                                  textured, msg)
                                      : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "rto_vbuffer_check: out of memory");
        }
        static const char channels[4] = {'R', 'G', 'B', 'A'};
        for (size_t px = 0; st == RTO_OK && px < pixels && !first[RTO_VB_SHADING].set; px++)
            for (int ch = 0; ch < 4; ch++) {
                const uint16_t hr = image[4 * px + (size_t)ch], hg = desc->gpu_image[4 * px + (size_t)ch];
                const double r = f16_value(hr), v = f16_value(hg);
                if (hr == hg || (isnan(r) && isnan(v)))
                    continue;
                if (textured && textured[px]) {
                    const double l = lo[4 * px + (size_t)ch], h = hi[4 * px + (size_t)ch];
                    const double tl = IMAGE_ULPS * f16_ulp(fabs(l)) + IMAGE_ABS;
                    const double th = IMAGE_ULPS * f16_ulp(fabs(h)) + IMAGE_ABS;
                    if (v >= l - tl && v <= h + th)
                        continue;
                    note(&first[RTO_VB_SHADING], px * c.samples, "image",
                         "%c = %.9g (0x%04x), outside [%.9g, %.9g]: the base colour factor times the texels a GPU's "
                         "trilinear filtering may read at the lod and uv of the GPU's own planes (lod +-2^-6, uv +-2^-16 "
                         "+ 1/32 texel; the oracle's value %.9g, an %s pixel), widened by 2 binary16 ulps + 2^-12",
                         channels[ch], v, hg, l, h, r, edge_word(use_mask[px] != 0));
                    break;
                }
                const double tol = IMAGE_ULPS * f16_ulp(fabs(r)) + IMAGE_ABS;
                if (fabs(v - r) <= tol)
                    continue;
                note(&first[RTO_VB_SHADING], px * c.samples, "image",
                     "%c = %.9g (0x%04x), but the material pass on the GPU's own planes and mask (an %s pixel there) "
                     "gives %.9g (0x%04x); the bound is 2 binary16 ulps + 2^-12 (%.3g)",
                     channels[ch], v, hg, edge_word(use_mask[px] != 0), r, hr, tol);
                break;
            }
        free(mask);
        free(image);
        free(lo);
        free(hi);
        free(textured);
    }
    if (st != RTO_OK)
        return st;

    for (int f = RTO_VB_COVERAGE; f < FAULT_COUNT; f++)
        if (first[f].set) {
            set_fault(result, &c, (rto_vb_fault)f, &first[f]);
            break;
        }
    if (result->fault == RTO_VB_PASS)
        snprintf(result->what, sizeof result->what,
                 "%" PRIu64 " samples compared, %" PRIu64 " with another admissible triangle than the oracle's",
                 result->compared, result->other_admissible);
    return RTO_OK;
}
