/* check-volume (DESIGN.md §12.6): a GPU's splat (the u32 volume its atomicAdds left, optionally the resolved binary16
 * volume and the occupancy grid) against the reference and the conformance model of §12.2: every voxel exact where
 * all its contributions are certain, else within [sum lo, sum hi]; every voxel whose true sum passes 2^32 - 1 a
 * fault whatever the GPU holds; the resolve of the GPU's own u32 values within the admissible f32 -> f16 range; the
 * occupancy grid lossless (§12.3) and each level the OR of its children. The first fault of the primary class is
 * named with its voxel (or cell) and the particles that reach it. */
#include "core/report_internal.h"
#include "fluid/fluid_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const fault_names[] = {"none",         "shape",   "overflow",         "radius",
                                          "contribution", "resolve", "resolve-rounding", "occupancy"};

const char *rto_volume_fault_name(rto_volume_fault f)
{
    return (unsigned)f < sizeof fault_names / sizeof *fault_names ? fault_names[f] : "unknown";
}

static int claim(rto_report *r, rto_volume_fault f)
{
    return rto__report_claim(r, (int)f, fault_names[f]);
}

static void at_voxel(rto_report *r, const uint32_t n[3], uint64_t v)
{
    rto__report_at(r, "x", (int64_t)(v % n[0]));
    rto__report_at(r, "y", (int64_t)(v / n[0] % n[1]));
    rto__report_at(r, "z", (int64_t)(v / ((uint64_t)n[0] * n[1])));
    rto__report_at(r, "voxel", (int64_t)v);
}

/* Up to 4 particles that may reach voxel v, as rows: the reference contribution, certain or not (the width of the
 * model's interval as the tolerance). */
static void reaching(rto_report *r, const rto_splat *s, const float *pos, uint64_t count, uint64_t v)
{
    const uint32_t *n = s->params.res;
    const uint32_t x = (uint32_t)(v % n[0]), y = (uint32_t)(v / n[0] % n[1]), z = (uint32_t)(v / ((uint64_t)n[0] * n[1]));
    const float c[3] = {rto__fluid_centre(&s->uniforms, 0, x), rto__fluid_centre(&s->uniforms, 1, y),
                        rto__fluid_centre(&s->uniforms, 2, z)};
    rto__report_table(r, "contributions", "particle");
    uint32_t found = 0;
    for (uint64_t i = 0; i < count && found < 4; i++) {
        uint32_t lo, hi;
        bool reach;
        rto__fluid_interval(&s->uniforms, pos + 3 * i, c, &lo, &hi, &reach);
        if (!reach)
            continue;
        rto_report_row *row = rto__report_row_add(r, i, lo == hi ? "certain" : "uncertain");
        if (row) {
            row->expected = rto__val_uint(rto__fluid_contribution(&s->uniforms, pos + 3 * i, c, NULL));
            row->tolerance = lo == hi ? rto__val_none() : rto__val_uint(hi - lo);
        }
        found++;
    }
}

/* The voxel values (§12.2): overflow, then radius (mass where no particle may reach, none where every admissible
 * sum is positive), then contribution (any other value outside its range). */
static void check_voxels(rto_report *r, const rto_splat *s, const float *pos, uint64_t count, const uint32_t *g,
                         const uint64_t *lo, const uint64_t *hi, const uint8_t *reach)
{
    const uint32_t *n = s->params.res;
    const uint64_t nv = (uint64_t)n[0] * n[1] * n[2];
    if (s->overflow_count) {
        rto__report_mark(r, "overflow", RTO_CHECK_FAILED);
        const uint64_t v = s->overflow[0], t = s->overflow[1];
        if (claim(r, RTO_VOLUME_OVERFLOW)) {
            at_voxel(r, n, v);
            rto__report_summary(r, "overflow: voxel (%" PRIu64 ", %" PRIu64 ", %" PRIu64 "): the true sum %" PRIu64
                                " passes 2^32 - 1 (the GPU holds %" PRIu32 ", the sum mod 2^32 is %" PRIu32 "); %"
                                PRIu64 " voxel(s) overflow: the volume is wrong whatever it holds",
                                v % n[0], v / n[0] % n[1], v / ((uint64_t)n[0] * n[1]), t, g[v], (uint32_t)t,
                                s->overflow_count);
            reaching(r, s, pos, count, v);
        }
    } else {
        rto__report_mark(r, "overflow", RTO_CHECK_PASSED);
    }
    uint64_t wrong = 0, radius = 0, first_wrong = UINT64_MAX, first_radius = UINT64_MAX;
    size_t ov = 0;
    for (uint64_t v = 0; v < nv; v++) {
        if (ov < s->overflow_count && s->overflow[2 * ov] == v) {
            ov++;
            continue;
        }
        const uint64_t e = s->volume_u32[v], gv = g[v];
        const bool ok = lo[v] == hi[v] ? gv == e : gv >= lo[v] && gv <= hi[v];
        if (ok)
            continue;
        wrong++;
        if (first_wrong == UINT64_MAX)
            first_wrong = v;
        if ((!reach[v] && gv != 0) || (lo[v] > 0 && gv == 0)) {
            radius++;
            if (first_radius == UINT64_MAX)
                first_radius = v;
        }
    }
    rto__report_fact(r, "wrong_voxels", (int64_t)wrong);
    rto__report_mark(r, "voxels", wrong ? RTO_CHECK_FAILED : RTO_CHECK_PASSED);
    if (!wrong)
        return;
    const rto_volume_fault f = radius ? RTO_VOLUME_RADIUS : RTO_VOLUME_CONTRIBUTION;
    const uint64_t v = radius ? first_radius : first_wrong;
    if (claim(r, f)) {
        at_voxel(r, n, v);
        char range[96];
        if (lo[v] == hi[v])
            snprintf(range, sizeof range, "expected %" PRIu32 " (every contribution certain)", s->volume_u32[v]);
        else
            snprintf(range, sizeof range, "expected %" PRIu32 ", admissible [%" PRIu64 ", %" PRIu64 "]",
                     s->volume_u32[v], lo[v], hi[v]);
        const char *why = f == RTO_VOLUME_CONTRIBUTION ? "a contribution's value is off (rounding, kernel, scale)"
                          : !reach[v] ? "mass beyond the kernel radius of every particle (a radius too large?)"
                                      : "no mass inside the kernel radius (a radius too small?)";
        rto__report_summary(r, "%s: voxel (%" PRIu64 ", %" PRIu64 ", %" PRIu64 ") holds %" PRIu32 ", %s: %s; %"
                            PRIu64 " voxel(s) wrong", fault_names[f], v % n[0], v / n[0] % n[1],
                            v / ((uint64_t)n[0] * n[1]), g[v], range, why, wrong);
        reaching(r, s, pos, count, v);
    }
    if (radius && wrong > radius)
        claim(r, RTO_VOLUME_CONTRIBUTION);
}

/* The resolve (§12.2) of the GPU's own u32 values: the density within the admissible binary16 range (round to
 * nearest even, or toward zero too unless nearest), and for rgba G = B = 0 and A = 1. */
static void check_resolve(rto_report *r, const rto_splat *s, const rto_volume_dump *g, uint32_t ch, bool nearest)
{
    const uint32_t *n = s->params.res;
    const uint64_t nv = (uint64_t)n[0] * n[1] * n[2];
    uint64_t bad = UINT64_MAX, rounding = UINT64_MAX, nbad = 0, nround = 0;
    uint16_t blo = 0, bhi = 0;
    for (uint64_t v = 0; v < nv; v++) {
        const uint16_t *t = g->volume_f16 + v * ch;
        uint16_t alo, ahi, nlo, nhi;
        rto__fluid_resolve_range(g->volume_u32[v], s->uniforms.scale, false, &alo, &ahi);
        bool ok = t[0] >= alo && t[0] <= ahi && t[0] <= 0x7C00;
        if (ch == 4 && (t[1] != 0 || t[2] != 0 || t[3] != 0x3C00))
            ok = false;
        if (!ok) {
            if (!nbad++) {
                bad = v;
                blo = alo;
                bhi = ahi;
            }
            continue;
        }
        if (nearest) {
            rto__fluid_resolve_range(g->volume_u32[v], s->uniforms.scale, true, &nlo, &nhi);
            if (!(t[0] >= nlo && t[0] <= nhi) && !nround++)
                rounding = v;
        }
    }
    rto__report_mark(r, "resolve", nbad || nround ? RTO_CHECK_FAILED : RTO_CHECK_PASSED);
    if (nbad && claim(r, RTO_VOLUME_RESOLVE)) {
        at_voxel(r, n, bad);
        const uint16_t *t = g->volume_f16 + bad * ch;
        if (ch == 4 && (t[1] != 0 || t[2] != 0 || t[3] != 0x3C00))
            rto__report_summary(r, "resolve: voxel (%" PRIu64 ", %" PRIu64 ", %" PRIu64 "): rgba (0x%04x, 0x%04x, "
                                "0x%04x, 0x%04x); G and B must be 0 and A 1 (0x3c00); %" PRIu64 " voxel(s) wrong",
                                bad % n[0], bad / n[0] % n[1], bad / ((uint64_t)n[0] * n[1]), t[0], t[1], t[2], t[3],
                                nbad);
        else
            rto__report_summary(r, "resolve: voxel (%" PRIu64 ", %" PRIu64 ", %" PRIu64 "): the GPU's u32 %" PRIu32
                                " resolves to %.9g (0x%04x), admissible [%.9g, %.9g] (0x%04x..0x%04x); %" PRIu64
                                " voxel(s) wrong", bad % n[0], bad / n[0] % n[1], bad / ((uint64_t)n[0] * n[1]),
                                g->volume_u32[bad], (double)rto_f16_to_f32(t[0]), t[0], (double)rto_f16_to_f32(blo),
                                (double)rto_f16_to_f32(bhi), blo, bhi, nbad);
    }
    if (nround && claim(r, RTO_VOLUME_RESOLVE_ROUNDING)) {
        at_voxel(r, n, rounding);
        const uint16_t h = g->volume_f16[rounding * ch];
        rto__report_summary(r, "resolve-rounding: voxel (%" PRIu64 ", %" PRIu64 ", %" PRIu64 "): the GPU's u32 %"
                            PRIu32 " resolves to %.9g (0x%04x), below the round-to-nearest-even binary16 range "
                            "(--f16-rounding nearest; a store rounding toward zero?); %" PRIu64 " voxel(s)",
                            rounding % n[0], rounding / n[0] % n[1], rounding / ((uint64_t)n[0] * n[1]),
                            g->volume_u32[rounding], (double)rto_f16_to_f32(h), h, nround);
    }
}

static int gpu_bit(const rto_splat *s, const uint32_t *w, uint32_t l, uint32_t x, uint32_t y, uint32_t z)
{
    const uint32_t r = s->level_res[l];
    const uint64_t b = ((uint64_t)z * r + y) * r + x;
    return (int)((w[s->level_offset[l] + (b >> 5)] >> (b & 31)) & 1u);
}

/* The occupancy grid (§12.3): every cell a non-zero voxel's trilinear reach meets set at level 0; each cell of a
 * coarser level the OR of its children. */
static void check_occupancy(rto_report *r, const rto_splat *s, const uint32_t *w, const uint64_t *hi)
{
    const rto_fluid_uniforms *u = &s->uniforms;
    const uint32_t *n = s->params.res, O = s->level_res[0];
    const uint64_t nv = (uint64_t)n[0] * n[1] * n[2];
    for (uint64_t v = 0; v < nv; v++) {
        if (s->volume_u32[v] == 0 && hi[v] == 0) /* hi >= the true sum: an overflowing voxel has hi > 0 */
            continue;
        const uint32_t id[3] = {(uint32_t)(v % n[0]), (uint32_t)(v / n[0] % n[1]), (uint32_t)(v / ((uint64_t)n[0] * n[1]))};
        uint32_t c0[3], c1[3];
        for (int a = 0; a < 3; a++) {
            const double bmin = u->bounds_min[a], cs = ((double)u->bounds_max[a] - bmin) / (double)O;
            const double c = rto__fluid_centre(u, a, id[a]), vs = u->voxel_size[a];
            const double f0 = ceil((c - vs - bmin) / cs) - 1.0, f1 = floor((c + vs - bmin) / cs);
            c0[a] = f0 > 0.0 ? (uint32_t)f0 : 0;
            c1[a] = f1 < 0.0 ? 0 : f1 < (double)(O - 1) ? (uint32_t)f1 : O - 1;
        }
        for (uint32_t z = c0[2]; z <= c1[2]; z++)
            for (uint32_t y = c0[1]; y <= c1[1]; y++)
                for (uint32_t x = c0[0]; x <= c1[0]; x++)
                    if (!gpu_bit(s, w, 0, x, y, z)) {
                        rto__report_mark(r, "occupancy", RTO_CHECK_FAILED);
                        if (claim(r, RTO_VOLUME_OCCUPANCY)) {
                            rto__report_at(r, "level", 0);
                            rto__report_at(r, "cx", x);
                            rto__report_at(r, "cy", y);
                            rto__report_at(r, "cz", z);
                            at_voxel(r, n, v);
                            rto__report_summary(r, "occupancy: level 0 cell (%" PRIu32 ", %" PRIu32 ", %" PRIu32
                                                ") is not set, but voxel (%" PRIu32 ", %" PRIu32 ", %" PRIu32
                                                ") (value %" PRIu32 ", up to %" PRIu64 ") reaches it (not lossless: "
                                                "the grid must cover the kernel radius plus one voxel)", x, y, z,
                                                id[0], id[1], id[2], s->volume_u32[v], hi[v]);
                        }
                        return;
                    }
    }
    for (uint32_t l = 1; l < s->occupancy_levels; l++) {
        const uint32_t rr = s->level_res[l], rc = s->level_res[l - 1];
        for (uint32_t z = 0; z < rr; z++)
            for (uint32_t y = 0; y < rr; y++)
                for (uint32_t x = 0; x < rr; x++) {
                    int any = 0;
                    for (uint32_t k = 0; k < 8 && !any; k++) {
                        const uint32_t cx = 2 * x + (k & 1), cy = 2 * y + (k >> 1 & 1), cz = 2 * z + (k >> 2);
                        if (cx < rc && cy < rc && cz < rc)
                            any = gpu_bit(s, w, l - 1, cx, cy, cz);
                    }
                    if (gpu_bit(s, w, l, x, y, z) == any)
                        continue;
                    rto__report_mark(r, "occupancy", RTO_CHECK_FAILED);
                    if (claim(r, RTO_VOLUME_OCCUPANCY)) {
                        rto__report_at(r, "level", l);
                        rto__report_at(r, "cx", x);
                        rto__report_at(r, "cy", y);
                        rto__report_at(r, "cz", z);
                        rto__report_summary(r, "occupancy: level %" PRIu32 " cell (%" PRIu32 ", %" PRIu32 ", %" PRIu32
                                            ") is %d, but the OR of its children at level %" PRIu32 " is %d", l, x, y,
                                            z, !any, l - 1, any);
                    }
                    return;
                }
    }
    rto__report_mark(r, "occupancy", RTO_CHECK_PASSED);
}

rto_status rto_volume_check(const rto_splat *s, const float *pos, uint64_t count, const rto_volume_dump *g,
                            int f16_nearest, uint32_t threads, rto_report *r, rto_msg *msg)
{
    if (!s || !g || !r || !g->volume_u32 || (!pos && count) || !s->volume_u32)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "incomplete volume check");
    rto__report_begin(r, "check-volume");
    static const char *const checks[] = {"shape", "overflow", "voxels", "resolve", "occupancy"};
    for (size_t k = 0; k < 5; k++)
        rto__report_add_check(r, checks[k]);
    const uint32_t *n = s->params.res;
    const uint64_t nv = (uint64_t)n[0] * n[1] * n[2];
    snprintf(r->context, sizeof r->context, "%" PRIu32 "x%" PRIu32 "x%" PRIu32 " voxels, %" PRIu64 " particles, "
             "occupancy %" PRIu32 "^3 in %" PRIu32 " levels", n[0], n[1], n[2], count, s->level_res[0],
             s->occupancy_levels);
    snprintf(r->mode, sizeof r->mode, "%s", f16_nearest ? "f16-nearest" : "f16-any");
    snprintf(r->tolerance, sizeof r->tolerance, "per contribution: r +- sqrt(3) ulp(|c| + |min|) + r 2^-19, k*scale "
             "+- 2^-20 relative, truncated; resolve: f32(u) either way, 2.5 ulp division (DESIGN.md §12.2)");
    rto__report_fact(r, "voxels", (int64_t)nv);
    rto__report_fact(r, "particles", (int64_t)count);
    uint32_t ch = 0;
    if (g->volume_f16)
        ch = g->f16_count == nv ? 1 : g->f16_count == 4 * nv ? 4 : 0;
    const bool occ_ok = !g->occupancy || g->occupancy_words == s->occupancy_words;
    if (g->u32_count != nv || (g->volume_f16 && !ch) || !occ_ok) {
        rto__report_mark(r, "shape", RTO_CHECK_FAILED);
        claim(r, RTO_VOLUME_SHAPE);
        if (g->u32_count != nv)
            rto__report_summary(r, "shape: the u32 volume holds %" PRIu64 " words, the bundle's %" PRIu32 "x%" PRIu32
                                "x%" PRIu32 " volume %" PRIu64, g->u32_count, n[0], n[1], n[2], nv);
        else if (g->volume_f16 && !ch)
            rto__report_summary(r, "shape: the f16 volume holds %" PRIu64 " values, neither %" PRIu64 " (density) nor %"
                                PRIu64 " (rgba)", g->f16_count, nv, 4 * nv);
        else
            rto__report_summary(r, "shape: the occupancy grid holds %" PRIu64 " words, the bundle's %" PRIu32
                                " levels %" PRIu64, g->occupancy_words, s->occupancy_levels, s->occupancy_words);
        return RTO_OK;
    }
    rto__report_mark(r, "shape", RTO_CHECK_PASSED);
    uint64_t *lo = malloc((size_t)nv * sizeof *lo), *hi = malloc((size_t)nv * sizeof *hi);
    uint8_t *reach = calloc((size_t)nv, 1);
    rto_status st = lo && hi && reach ? RTO_OK : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    if (!st) {
        memset(lo, 0, (size_t)nv * sizeof *lo);
        memset(hi, 0, (size_t)nv * sizeof *hi);
    }
    uint64_t uncertain = 0;
    if (!st)
        st = rto__fluid_model(&s->uniforms, pos, count, threads, lo, hi, reach, &uncertain, msg);
    if (!st) {
        uint64_t unsure = 0;
        for (uint64_t v = 0; v < nv; v++)
            unsure += lo[v] != hi[v];
        rto__report_fact(r, "uncertain_voxels", (int64_t)unsure);
        rto__report_fact(r, "uncertain_contributions", (int64_t)uncertain);
        check_voxels(r, s, pos, count, g->volume_u32, lo, hi, reach);
        if (ch)
            check_resolve(r, s, g, ch, f16_nearest != 0);
        if (g->occupancy)
            check_occupancy(r, s, g->occupancy, hi);
        if (rto_report_passed(r))
            rto__report_summary(r, "ok: %" PRIu64 " voxels (%" PRIu64 " uncertain) match the splat of %" PRIu64
                                " particles%s%s", nv, unsure, count, ch ? ", the resolve" : "",
                                g->occupancy ? ", the occupancy grid" : "");
    }
    free(lo);
    free(hi);
    free(reach);
    return st;
}
