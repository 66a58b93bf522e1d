/* The reference splat (DESIGN.md §12.2-§12.3): every particle's kernel contributions in binary32 as splat_particles
 * computes them, summed exactly in u64 (stored mod 2^32 as an atomicAdd leaves them, overflow named), the resolve to
 * binary16, the conformance model's interval of every contribution, and the occupancy grid with its mip chain.
 *
 * Threads: the volume is cut into slabs of z planes, one contiguous range per worker (rto__parallel_ranges); each
 * worker visits every particle and adds only into the voxels of its own slab, so no two workers write one voxel and
 * no private copies of the volume are needed. The sums are integers, so neither the thread count nor the particles'
 * order changes a byte. */
#include "fluid/fluid_internal.h"
#include "internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

float rto__fluid_centre(const rto_fluid_uniforms *u, int a, uint32_t i)
{
    const float t = (float)i + 0.5f;
    const float off = t * u->voxel_size[a];
    return u->bounds_min[a] + off;
}

uint32_t rto__fluid_contribution(const rto_fluid_uniforms *u, const float p[3], const float c[3], bool *inside)
{
    const float dx = c[0] - p[0], dy = c[1] - p[1], dz = c[2] - p[2];
    const float xx = dx * dx, yy = dy * dy, zz = dz * dz;
    const float xy = xx + yy;
    const float r2 = xy + zz;
    const float r = sqrtf(r2);
    const float h = u->radius;
    if (inside)
        *inside = r < h;
    if (!(r < h))
        return 0;
    const float v = h - r;
    const float vv = v * v;
    const float k = vv * u->kernel_factor;
    const float ks = k * u->scale;
    if (ks >= 4294967296.0f) /* WGSL's u32(f32) saturates */
        return UINT32_MAX;
    return (uint32_t)ks;
}

/* An upper bound of the binary32 ulp of x >= 0 (2^-149 below the normal range). */
static double ulp32(double x)
{
    if (x < 0x1p-126)
        return 0x1p-149;
    int e;
    frexp(x, &e);
    return ldexp(1.0, e - 24);
}

static uint32_t floor_u32(double v)
{
    if (!(v > 0.0))
        return 0;
    if (v >= 4294967295.0)
        return UINT32_MAX;
    return (uint32_t)floor(v);
}

void rto__fluid_interval(const rto_fluid_uniforms *u, const float p[3], const float c[3], uint32_t *lo, uint32_t *hi,
                         bool *reach)
{
    double r2 = 0.0, um = 0.0;
    for (int a = 0; a < 3; a++) {
        const double d = (double)c[a] - (double)p[a];
        r2 += d * d;
        /* ulp(c_a), widened to ulp(|c_a| + |min_a|): a fused c = min + t * vs moves c by up to that much */
        const double ua = ulp32(fabs((double)c[a]) + fabs((double)u->bounds_min[a]));
        um = ua > um ? ua : um;
    }
    const double r = sqrt(r2);
    const double delta = 1.7320508075688773 * um + r * 0x1p-19;
    const double rlo = r - delta > 0.0 ? r - delta : 0.0, rhi = r + delta;
    const double h = u->radius, S = u->kernel_factor, sc = u->scale;
    if (!(rlo < h)) {
        *lo = *hi = 0;
        *reach = false;
        return;
    }
    *reach = true;
    const double vhi = h - rlo;
    *hi = floor_u32(vhi * vhi * S * sc * (1.0 + 0x1p-20));
    if (rhi >= h) {
        *lo = 0;
    } else {
        const double vlo = h - rhi;
        *lo = floor_u32(vlo * vlo * S * sc * (1.0 - 0x1p-20));
    }
}

bool rto__fluid_voxel_range(const rto_fluid_uniforms *u, const float p[3], uint32_t lo[3], uint32_t hi[3])
{
    for (int a = 0; a < 3; a++) {
        const double bmin = u->bounds_min[a], vs = u->voxel_size[a], n = u->res[a];
        const double R = (double)u->radius * (1.0 + 0x1p-10) + 1e-6 * (fabs(bmin) + fabs((double)u->bounds_max[a]));
        const double f0 = floor(((double)p[a] - R - bmin) / vs - 0.5) - 1.0;
        const double f1 = ceil(((double)p[a] + R - bmin) / vs - 0.5) + 1.0;
        if (!(f1 >= 0.0) || !(f0 <= n - 1.0))
            return false;
        lo[a] = f0 > 0.0 ? (uint32_t)f0 : 0;
        hi[a] = f1 < n - 1.0 ? (uint32_t)f1 : (uint32_t)(n - 1.0);
    }
    return true;
}

uint16_t rto__f16_rtz(float f)
{
    uint16_t h = rto_f16_from_f32(f);
    if (h == 0x7C00 && isfinite(f))
        return 0x7BFF;
    if (rto_f16_to_f32(h) > f)
        h--;
    return h;
}

uint16_t rto__fluid_resolve(uint32_t v, float scale)
{
    const float f = (float)v;
    const float d = f / scale;
    return rto_f16_from_f32(d);
}

void rto__fluid_resolve_range(uint32_t v, float scale, bool nearest, uint16_t *lo, uint16_t *hi)
{
    const float f = (float)v;
    float flo = f, fhi = f;
    if ((double)f > (double)v)
        flo = nextafterf(f, 0.0f);
    else if ((double)f < (double)v)
        fhi = nextafterf(f, INFINITY);
    /* the division within 2.5 ulp (relative 2.5 * 2^-23 for these normal quotients), rounded outward to binary32 */
    const double qlo = (double)flo / (double)scale * (1.0 - 2.5 * 0x1p-23);
    const double qhi = (double)fhi / (double)scale * (1.0 + 2.5 * 0x1p-23);
    float a = (float)qlo, b = (float)qhi;
    if ((double)a > qlo)
        a = nextafterf(a, 0.0f);
    if ((double)b < qhi)
        b = nextafterf(b, INFINITY);
    *lo = nearest ? rto_f16_from_f32(a) : rto__f16_rtz(a);
    *hi = rto_f16_from_f32(b);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The splat pass                                                                                                   */

typedef struct splat_job {
    const rto_fluid_uniforms *u;
    const float *pos;
    uint64_t count;
    uint32_t n[3];
    const float *centre[3];
    uint64_t *sum;    /* reference sums, or NULL */
    uint64_t *lo, *hi; /* model sums, or NULL */
    uint8_t *reach;   /* model reach, or NULL */
    bool model;       /* evaluate the model's intervals */
    double far2;      /* r^2 from which no conforming GPU reaches the voxel (the model's reach is false) */
    uint64_t contributions[RTO_THREADS_MAX], uncertain[RTO_THREADS_MAX];
} splat_job;

static void splat_slab(void *ctx, uint32_t worker, size_t zb, size_t ze)
{
    splat_job *j = ctx;
    const uint32_t nx = j->n[0], ny = j->n[1];
    uint64_t contributions = 0, uncertain = 0;
    for (uint64_t i = 0; i < j->count; i++) {
        const float *p = j->pos + 3 * i;
        uint32_t lo[3], hi[3];
        if (!rto__fluid_voxel_range(j->u, p, lo, hi) || hi[2] < zb || lo[2] >= ze)
            continue;
        const uint32_t z0 = lo[2] > zb ? lo[2] : (uint32_t)zb, z1 = hi[2] < ze - 1 ? hi[2] : (uint32_t)(ze - 1);
        for (uint32_t z = z0; z <= z1; z++)
            for (uint32_t y = lo[1]; y <= hi[1]; y++)
                for (uint32_t x = lo[0]; x <= hi[0]; x++) {
                    const float c[3] = {j->centre[0][x], j->centre[1][y], j->centre[2][z]};
                    const double dx = (double)c[0] - p[0], dy = (double)c[1] - p[1], dz = (double)c[2] - p[2];
                    if (dx * dx + dy * dy + dz * dz >= j->far2)
                        continue; /* beyond every conforming GPU's radius: contributes 0 everywhere */
                    const size_t v = ((size_t)z * ny + y) * nx + x;
                    if (j->sum) {
                        const uint32_t k = rto__fluid_contribution(j->u, p, c, NULL);
                        j->sum[v] += k;
                        contributions += k != 0;
                    }
                    if (j->model) {
                        uint32_t a, b;
                        bool reach;
                        rto__fluid_interval(j->u, p, c, &a, &b, &reach);
                        uncertain += a != b;
                        if (j->lo) {
                            j->lo[v] += a;
                            j->hi[v] += b;
                        }
                        if (j->reach && reach)
                            j->reach[v] = 1;
                    }
                }
    }
    j->contributions[worker] = contributions;
    j->uncertain[worker] = uncertain;
}

/* Candidate pairs of a splat (the voxel boxes of every particle), saturating; NULL pos is fine when count is 0. */
static uint64_t candidate_pairs(const rto_fluid_uniforms *u, const float *pos, uint64_t count)
{
    uint64_t total = 0;
    for (uint64_t i = 0; i < count && total <= RTO_FLUID_PAIRS_MAX; i++) {
        uint32_t lo[3], hi[3];
        if (rto__fluid_voxel_range(u, pos + 3 * i, lo, hi))
            total += (uint64_t)(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
    }
    return total;
}

/* Runs the slab pass; the job's arrays are set by the caller. */
static rto_status run_pass(splat_job *j, const rto_fluid_uniforms *u, const float *pos, uint64_t count,
                           uint32_t threads, rto_msg *msg)
{
    j->u = u;
    j->pos = pos;
    j->count = count;
    for (int a = 0; a < 3; a++)
        j->n[a] = (uint32_t)u->res[a];
    for (uint64_t i = 0; i < 3 * count; i++)
        if (!isfinite(pos[i]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "particle %" PRIu64 " has a non-finite coordinate",
                             i / 3);
    const uint64_t pairs = candidate_pairs(u, pos, count);
    if (pairs > RTO_FLUID_PAIRS_MAX)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "more than 2^33 (particle, voxel) pairs to visit: the radius "
                         "spans too many voxels for this many particles");
    /* The model's reach needs r (1 - 2^-19) < h + sqrt(3) ulp(|c_a| + |min_a|); every centre lies in the bounds, so
     * with that ulp's largest value a pair at r^2 >= far2 reaches nothing (a margin of 2^-30 for the binary64
     * arithmetic of both sides). */
    double umax = 0.0;
    for (int a = 0; a < 3; a++) {
        const double m = fabs((double)u->bounds_min[a]), M = fabs((double)u->bounds_max[a]);
        const double ua = ulp32((m > M ? m : M) + m);
        umax = ua > umax ? ua : umax;
    }
    const double far = ((double)u->radius + 1.7320508075688773 * umax) / (1.0 - 0x1p-19) * (1.0 + 0x1p-30);
    j->far2 = far * far;
    float *cen = malloc(((size_t)j->n[0] + j->n[1] + j->n[2]) * sizeof *cen);
    if (!cen)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    size_t off = 0;
    for (int a = 0; a < 3; a++) {
        j->centre[a] = cen + off;
        for (uint32_t i = 0; i < j->n[a]; i++)
            cen[off + i] = rto__fluid_centre(u, a, i);
        off += j->n[a];
    }
    memset(j->contributions, 0, sizeof j->contributions);
    memset(j->uncertain, 0, sizeof j->uncertain);
    rto__parallel_ranges(j->n[2], threads, splat_slab, j);
    free(cen);
    return RTO_OK;
}

rto_status rto__fluid_model(const rto_fluid_uniforms *u, const float *pos, uint64_t count, uint32_t threads,
                            uint64_t *lo, uint64_t *hi, uint8_t *reach, uint64_t *uncertain, rto_msg *msg)
{
    splat_job *j = calloc(1, sizeof *j);
    if (!j)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    j->lo = lo;
    j->hi = hi;
    j->reach = reach;
    j->model = true;
    rto_status s = run_pass(j, u, pos, count, threads, msg);
    uint64_t unc = 0;
    for (uint32_t w = 0; w < RTO_THREADS_MAX; w++)
        unc += j->uncertain[w];
    if (uncertain)
        *uncertain = unc;
    free(j);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Occupancy                                                                                                        */

static void occ_set(rto_splat *s, uint32_t l, uint32_t x, uint32_t y, uint32_t z)
{
    const uint32_t r = s->level_res[l];
    const uint64_t b = ((uint64_t)z * r + y) * r + x;
    s->occupancy[s->level_offset[l] + (b >> 5)] |= UINT32_C(1) << (b & 31);
}

int rto_occupancy_get(const rto_splat *s, uint32_t level, uint32_t x, uint32_t y, uint32_t z)
{
    if (!s || !s->occupancy || level >= s->occupancy_levels)
        return 0;
    const uint32_t r = s->level_res[level];
    if (x >= r || y >= r || z >= r)
        return 0;
    const uint64_t b = ((uint64_t)z * r + y) * r + x;
    return (int)((s->occupancy[s->level_offset[level] + (b >> 5)] >> (b & 31)) & 1u);
}

/* The level layout (§12.3): O, ceil(O / 2), ... down to 1 cell; each level ceil(cells / 32) words. */
static void occ_layout(rto_splat *s, uint32_t O)
{
    uint64_t off = 0;
    uint32_t l = 0, r = O;
    for (;;) {
        s->level_res[l] = r;
        s->level_offset[l] = off;
        off += ((uint64_t)r * r * r + 31) / 32;
        l++;
        if (r == 1)
            break;
        r = (r + 1) / 2;
    }
    s->occupancy_levels = l;
    s->occupancy_words = off;
}

/* Level 0 from the particles (each marks the cells its dilated kernel box meets), then the mips. */
static void occ_build(rto_splat *s, const float *pos, uint64_t count)
{
    const rto_fluid_uniforms *u = &s->uniforms;
    const uint32_t O = s->level_res[0];
    for (uint64_t i = 0; i < count; i++) {
        uint32_t c0[3], c1[3];
        bool any = true;
        for (int a = 0; a < 3 && any; a++) {
            const double bmin = u->bounds_min[a], bmax = u->bounds_max[a];
            const double cs = (bmax - bmin) / (double)O;
            const double R = (double)u->radius * (1.0 + 0x1p-12) + (double)u->voxel_size[a];
            const double lo = (double)pos[3 * i + a] - R, hi = (double)pos[3 * i + a] + R;
            if (hi < bmin || lo > bmax) {
                any = false;
                break;
            }
            const double f0 = ceil((lo - bmin) / cs) - 1.0, f1 = floor((hi - bmin) / cs);
            c0[a] = f0 > 0.0 ? (uint32_t)f0 : 0;
            c1[a] = f1 < (double)(O - 1) ? (uint32_t)f1 : O - 1;
        }
        if (!any)
            continue;
        for (uint32_t z = c0[2]; z <= c1[2]; z++)
            for (uint32_t y = c0[1]; y <= c1[1]; y++)
                for (uint32_t x = c0[0]; x <= c1[0]; x++)
                    occ_set(s, 0, x, y, z);
    }
    for (uint32_t l = 0; l + 1 < s->occupancy_levels; l++) {
        const uint32_t r = s->level_res[l];
        for (uint32_t z = 0; z < r; z++)
            for (uint32_t y = 0; y < r; y++)
                for (uint32_t x = 0; x < r; x++)
                    if (rto_occupancy_get(s, l, x, y, z))
                        occ_set(s, l + 1, x / 2, y / 2, z / 2);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */

rto_status rto_splat_make(const rto_fluid_params *p, const float *pos, uint64_t count, uint32_t threads, rto_splat *out,
                          rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL splat");
    memset(out, 0, sizeof *out);
    if (!pos && count)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL particles");
    if (count > (UINT64_C(1) << 24))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%" PRIu64 " particles: at most 2^24", count);
    rto_status s = rto_fluid_uniforms_make(p, &out->uniforms, msg);
    if (s)
        return s;
    out->params = *p;
    const size_t nv = (size_t)p->res[0] * p->res[1] * p->res[2];
    occ_layout(out, p->occupancy);
    uint64_t *sum = calloc(nv, sizeof *sum);
    splat_job *j = calloc(1, sizeof *j);
    out->volume_u32 = malloc(nv * sizeof *out->volume_u32);
    out->volume_f16 = malloc(nv * sizeof *out->volume_f16);
    out->occupancy = calloc((size_t)out->occupancy_words, sizeof *out->occupancy);
    if (!sum || !j || !out->volume_u32 || !out->volume_f16 || !out->occupancy)
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu voxels", nv);
    if (!s) {
        j->sum = sum;
        j->model = true;
        s = run_pass(j, &out->uniforms, pos, count, threads, msg);
    }
    if (s) {
        free(sum);
        free(j);
        rto_splat_free(out);
        return s;
    }
    rto_splat_stats *st = &out->stats;
    st->particles = count;
    st->first_overflow = UINT64_MAX;
    for (uint32_t w = 0; w < RTO_THREADS_MAX; w++) {
        st->contributions += j->contributions[w];
        st->uncertain += j->uncertain[w];
    }
    free(j);
    for (size_t v = 0; v < nv; v++) {
        const uint64_t t = sum[v];
        out->volume_u32[v] = (uint32_t)t;
        out->volume_f16[v] = rto__fluid_resolve((uint32_t)t, out->uniforms.scale);
        st->voxels_nonzero += t != 0;
        st->max_sum = t > st->max_sum ? t : st->max_sum;
        if (t > UINT32_MAX) {
            if (!st->overflow_voxels)
                st->first_overflow = v;
            st->overflow_voxels++;
        }
    }
    if (st->overflow_voxels) {
        out->overflow = malloc((size_t)st->overflow_voxels * 2 * sizeof *out->overflow);
        if (!out->overflow) {
            free(sum);
            rto_splat_free(out);
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the overflow list");
        }
        for (size_t v = 0; v < nv; v++)
            if (sum[v] > UINT32_MAX) {
                out->overflow[2 * out->overflow_count] = v;
                out->overflow[2 * out->overflow_count + 1] = sum[v];
                out->overflow_count++;
            }
    }
    free(sum);
    occ_build(out, pos, count);
    const uint32_t O = out->level_res[0];
    for (uint64_t b = 0; b < (uint64_t)O * O * O; b++)
        st->occupied_cells += (out->occupancy[b >> 5] >> (b & 31)) & 1u;
    return RTO_OK;
}

void rto_splat_free(rto_splat *s)
{
    if (!s)
        return;
    free(s->volume_u32);
    free(s->volume_f16);
    free(s->occupancy);
    free(s->overflow);
    memset(s, 0, sizeof *s);
}

float rto__fluid_sample(const rto_splat *s, const float p[3])
{
    const rto_fluid_uniforms *u = &s->uniforms;
    int32_t i0[3], i1[3];
    float w[3];
    const uint32_t n[3] = {s->params.res[0], s->params.res[1], s->params.res[2]};
    for (int a = 0; a < 3; a++) {
        const float ext = u->bounds_max[a] - u->bounds_min[a];
        const float q = (p[a] - u->bounds_min[a]) / ext;
        float t = q * u->res[a];
        t = t - 0.5f;
        if (!(t > -1.0f))
            t = -1.0f;
        if (!(t < (float)n[a]))
            t = (float)n[a];
        const float f = floorf(t);
        w[a] = t - f;
        const int32_t b = (int32_t)f;
        i0[a] = b < 0 ? 0 : (b > (int32_t)n[a] - 1 ? (int32_t)n[a] - 1 : b);
        i1[a] = b + 1 < 0 ? 0 : (b + 1 > (int32_t)n[a] - 1 ? (int32_t)n[a] - 1 : b + 1);
    }
    float cz[2];
    for (int k = 0; k < 2; k++) {
        const size_t z = (size_t)(k ? i1[2] : i0[2]);
        float cy[2];
        for (int m = 0; m < 2; m++) {
            const size_t y = (size_t)(m ? i1[1] : i0[1]);
            const size_t row = (z * n[1] + y) * n[0];
            const float a = rto_f16_to_f32(s->volume_f16[row + (size_t)i0[0]]);
            const float b = rto_f16_to_f32(s->volume_f16[row + (size_t)i1[0]]);
            const float wa = (1.0f - w[0]) * a, wb = w[0] * b;
            cy[m] = wa + wb;
        }
        const float wa = (1.0f - w[1]) * cy[0], wb = w[1] * cy[1];
        cz[k] = wa + wb;
    }
    const float wa = (1.0f - w[2]) * cz[0], wb = w[2] * cz[1];
    return wa + wb;
}
