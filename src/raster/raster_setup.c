/* One triangle of the visibility pass (DESIGN.md §11.1-11.4): its vertices in binary32, its window positions in
 * binary64, its admissible snapped choices (§11.3: every precision p = 4..8, a coordinate within 2^-12 px of a
 * rounding midpoint snapped both ways), coverage by exact 64-bit edge functions with the top-left rule, or, for a
 * triangle that crosses the near or far plane or reaches beyond +-2^16 px, Olano and Greer's homogeneous edge
 * functions (1997) in binary64 with a 2^-4 px band; the reference's attributes and the intervals a GPU's may lie in
 * (rto__raster_eval: every snapped choice and the unsnapped window positions, which devices that snap for coverage
 * only interpolate from). */
#include "raster_setup.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Vertices                                                                                                           */

uint32_t rto__rs_instance_of(const rto_raster *r, uint32_t t)
{
    uint32_t lo = 0, hi = r->instance_count; /* tri_base[lo] <= t < tri_base[hi] */
    while (hi - lo > 1) {
        const uint32_t m = lo + (hi - lo) / 2;
        if (r->tri_base[m] <= t)
            lo = m;
        else
            hi = m;
    }
    return lo;
}

/* Sample offsets within a pixel, RS_SUB units (§11.2: WebGPU's standard positions). */
static const int64_t sample4[4][2] = {{96, 32}, {224, 96}, {32, 160}, {160, 224}};

void rto__vb_sample_pos(uint32_t samples, uint32_t s, double *sx, double *sy)
{
    if (samples == 4 && s < 4) {
        *sx = (double)sample4[s][0] / RS_SUB;
        *sy = (double)sample4[s][1] / RS_SUB;
    } else {
        *sx = 0.5;
        *sy = 0.5;
    }
}

static void load_vertices(const rto_raster *r, uint32_t instance, uint32_t t, rs_tri *tri)
{
    const uint32_t mesh = r->inst_mesh[instance];
    const uint32_t prim = t - r->tri_base[instance];
    const uint32_t *ix = r->indices + r->idx_base[mesh] + 3 * (uint64_t)prim;
    tri->instance = instance;
    tri->prim = prim;
    for (int k = 0; k < 3; k++) {
        const uint64_t v = r->vtx_base[instance] + ix[k];
        memcpy(tri->world[k], r->world + 3 * v, sizeof tri->world[k]);
        memcpy(tri->clip[k], r->clip + 4 * v, sizeof tri->clip[k]);
    }
}

/* §11.1: window coordinates in binary64 from the binary32 clip values; the kind of rasterization (§11.2). */
static int vertex_kind(const rto_raster *r, rs_tri *tri)
{
    int homog = 0;
    const double W = r->width, H = r->height;
    for (int k = 0; k < 3; k++) {
        const float *c = tri->clip[k];
        if (!isfinite(c[0]) || !isfinite(c[1]) || !isfinite(c[2]) || !isfinite(c[3]))
            return RS_NONE;
        const double x = c[0], y = c[1], z = c[2], w = c[3];
        tri->xw[k] = ((x / w) * 0.5 + 0.5) * W;
        tri->yw[k] = (0.5 - (y / w) * 0.5) * H;
        tri->z[k] = z / w;
        tri->w[k] = w;
        if (!(c[2] >= 0.0f && c[2] <= c[3]) || !(fabs(tri->xw[k]) <= 65536.0) || !(fabs(tri->yw[k]) <= 65536.0))
            homog = 1;
    }
    return homog ? RS_HOMOG : RS_SNAP;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Snapped choices                                                                                                    */

static inline int64_t edge_at(const rs_choice *c, int e, int64_t X, int64_t Y)
{
    return c->ea[e] * X + c->eb[e] * Y + c->ec[e];
}

static void choice_make(rs_choice *c, const int64_t vx[3], const int64_t vy[3], int p)
{
    memcpy(c->vx, vx, sizeof c->vx);
    memcpy(c->vy, vy, sizeof c->vy);
    c->p = p;
    c->pmask = RS_PCOV(p);
    c->area = (vx[1] - vx[0]) * (vy[2] - vy[0]) - (vx[2] - vx[0]) * (vy[1] - vy[0]);
    c->sgn = (c->area > 0) - (c->area < 0);
    for (int e = 0; e < 3; e++) {
        const int a = (e + 1) % 3, b = (e + 2) % 3; /* edge e runs from vertex a to b: E_e(v_e) = area */
        const int64_t dx = vx[b] - vx[a], dy = vy[b] - vy[a];
        c->ea[e] = -dy;
        c->eb[e] = dx;
        c->ec[e] = dy * vx[a] - dx * vy[a];
        /* Oriented so that the interior is E > 0: y points down, so a top edge runs towards +x (interior below)
         * and a left edge runs upwards (interior to its right). */
        const int64_t odx = c->sgn * dx, ody = c->sgn * dy;
        c->bias[e] = ((ody == 0 && odx > 0) || ody < 0) ? 0 : 1;
    }
}

static inline int choice_covers(const rs_choice *c, int64_t X, int64_t Y)
{
    if (!c->sgn)
        return 0;
    for (int e = 0; e < 3; e++)
        if (c->sgn * edge_at(c, e, X, Y) < c->bias[e])
            return 0;
    return 1;
}

/* lambda_e = E_e / (twice the area), binary64 (exact numerators); depth = sum lambda_i z_i, unclamped. */
static inline double choice_depth(const rs_tri *t, const rs_choice *c, int64_t X, int64_t Y)
{
    const double a = (double)c->area;
    const double l0 = (double)edge_at(c, 0, X, Y) / a, l1 = (double)edge_at(c, 1, X, Y) / a,
                 l2 = (double)edge_at(c, 2, X, Y) / a;
    return (l0 * t->z[0] + l1 * t->z[1]) + l2 * t->z[2];
}

static inline double clamp01(double v)
{
    return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
}

/* Candidates of one window coordinate at precision p, in RS_SUB units: the nearest, both near a midpoint. */
static int snap_candidates(double px, int p, int64_t out[2])
{
    const double v = ldexp(px, p), fl = floor(v), f = v - fl;
    const int64_t scale = (int64_t)1 << (RS_P_REF - p);
    if (fabs(f - 0.5) <= ldexp(RS_EPS_MID, p)) {
        out[0] = (int64_t)fl * scale;
        out[1] = ((int64_t)fl + 1) * scale;
        return 2;
    }
    out[0] = (int64_t)(f < 0.5 ? fl : fl + 1.0) * scale;
    return 1;
}

static void add_choice(rs_tri *t, const int64_t vx[3], const int64_t vy[3], int p)
{
    for (int i = 0; i < t->n; i++)
        if (!memcmp(t->ch[i].vx, vx, sizeof t->ch[i].vx) && !memcmp(t->ch[i].vy, vy, sizeof t->ch[i].vy)) {
            t->ch[i].pmask |= RS_PCOV(p);
            return;
        }
    if (t->n < RS_MAX_CHOICES)
        choice_make(&t->ch[t->n++], vx, vy, p);
}

static void snap_choices(rs_tri *t, int full)
{
    int64_t vx[3], vy[3];
    for (int k = 0; k < 3; k++) { /* the reference: p = 8, nearest even */
        vx[k] = (int64_t)rint(ldexp(t->xw[k], RS_P_REF));
        vy[k] = (int64_t)rint(ldexp(t->yw[k], RS_P_REF));
    }
    t->n = 0;
    add_choice(t, vx, vy, RS_P_REF);
    for (int p = RS_P_REF; full && p >= RS_P_MIN; p--) {
        int64_t cand[6][2];
        int cnt[6], combos = 1;
        for (int k = 0; k < 3; k++) {
            cnt[2 * k] = snap_candidates(t->xw[k], p, cand[2 * k]);
            cnt[2 * k + 1] = snap_candidates(t->yw[k], p, cand[2 * k + 1]);
        }
        for (int j = 0; j < 6; j++)
            combos *= cnt[j];
        for (int m = 0; m < combos; m++) {
            int rest = m;
            for (int k = 0; k < 3; k++) {
                vx[k] = cand[2 * k][rest % cnt[2 * k]];
                rest /= cnt[2 * k];
                vy[k] = cand[2 * k + 1][rest % cnt[2 * k + 1]];
                rest /= cnt[2 * k + 1];
            }
            add_choice(t, vx, vy, p);
        }
    }
    t->anchor = -1;
    for (int i = 0; i < t->n && t->anchor < 0; i++)
        if (t->ch[i].sgn)
            t->anchor = i;
    t->uniform = t->anchor == 0;
    for (int i = 1; i < t->n && t->uniform; i++)
        if (t->ch[i].sgn != t->ch[0].sgn)
            t->uniform = 0;
}

static inline int64_t cross3(int64_t ox, int64_t oy, int64_t ax, int64_t ay, int64_t bx, int64_t by)
{
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox);
}

static int cmp_pt(const void *a, const void *b)
{
    const int64_t *p = a, *q = b;
    if (p[0] != q[0])
        return p[0] < q[0] ? -1 : 1;
    return (p[1] > q[1]) - (p[1] < q[1]);
}

/* The convex hull of the boxes that hold every choice's vertices (Andrew's monotone chain, exact): no choice covers
 * a sample outside it. */
static void choice_hull(rs_tri *t)
{
    int64_t pts[12][2];
    for (int k = 0; k < 3; k++) {
        int64_t x0 = t->ch[0].vx[k], x1 = x0, y0 = t->ch[0].vy[k], y1 = y0;
        for (int i = 1; i < t->n; i++) {
            x0 = t->ch[i].vx[k] < x0 ? t->ch[i].vx[k] : x0;
            x1 = t->ch[i].vx[k] > x1 ? t->ch[i].vx[k] : x1;
            y0 = t->ch[i].vy[k] < y0 ? t->ch[i].vy[k] : y0;
            y1 = t->ch[i].vy[k] > y1 ? t->ch[i].vy[k] : y1;
        }
        const int64_t c[4][2] = {{x0, y0}, {x1, y0}, {x0, y1}, {x1, y1}};
        memcpy(pts[4 * k], c, sizeof c);
    }
    qsort(pts, 12, sizeof pts[0], cmp_pt);
    int64_t h[25][2];
    int n = 0;
    for (int i = 0; i < 12; i++) { /* lower chain */
        while (n >= 2 && cross3(h[n - 2][0], h[n - 2][1], h[n - 1][0], h[n - 1][1], pts[i][0], pts[i][1]) <= 0)
            n--;
        memcpy(h[n++], pts[i], sizeof pts[i]);
    }
    for (int i = 10, lower = n + 1; i >= 0; i--) { /* upper chain */
        while (n >= lower && cross3(h[n - 2][0], h[n - 2][1], h[n - 1][0], h[n - 1][1], pts[i][0], pts[i][1]) <= 0)
            n--;
        memcpy(h[n++], pts[i], sizeof pts[i]);
    }
    n--; /* the last point repeats the first */
    t->hull_n = n < 3 ? 0 : n;
    for (int i = 0; i < t->hull_n; i++) { /* counter-clockwise in (x, y): inside is cross >= 0 */
        const int64_t *a = h[i], *b = h[(i + 1) % n];
        t->ha[i] = -(b[1] - a[1]);
        t->hb[i] = b[0] - a[0];
        t->hc[i] = (b[1] - a[1]) * a[0] - (b[0] - a[0]) * a[1];
    }
}

/* Margins over the region's sample positions (corners of an affine function bound it). */
static void snap_margins(rs_tri *t, const rs_box *region)
{
    const int64_t xs[2] = {(int64_t)region->x0 * RS_SUB, (int64_t)region->x1 * RS_SUB + RS_SUB - 1};
    const int64_t ys[2] = {(int64_t)region->y0 * RS_SUB, (int64_t)region->y1 * RS_SUB + RS_SUB - 1};
    const rs_choice *a = &t->ch[t->anchor];
    memset(t->margin, 0, sizeof t->margin);
    double dz = 0.0, lsum = 1.0, zmax = 0.0;
    for (int k = 0; k < 3; k++)
        zmax = fmax(zmax, fabs(t->z[k]));
    for (int i = 0; i < t->n; i++) {
        const rs_choice *c = &t->ch[i];
        if (!c->sgn)
            continue;
        for (int j = 0; j < 4; j++) {
            const int64_t X = xs[j & 1], Y = ys[j >> 1];
            if (t->uniform)
                for (int e = 0; e < 3; e++) {
                    int64_t d = edge_at(c, e, X, Y) - edge_at(a, e, X, Y);
                    d = d < 0 ? -d : d;
                    t->margin[e] = d > t->margin[e] ? d : t->margin[e];
                }
            dz = fmax(dz, fabs(choice_depth(t, c, X, Y) - choice_depth(t, a, X, Y)));
            double l = 0.0;
            for (int e = 0; e < 3; e++)
                l += fabs((double)edge_at(c, e, X, Y) / (double)c->area);
            lsum = fmax(lsum, l);
        }
    }
    /* The corners' and the sample's binary64 rounding: a few ulps of the largest term, far below the widening. */
    t->dz = dz * (1.0 + 0x1p-40) + 0x1p-40 * (1.0 + lsum * zmax);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Homogeneous triangles (Olano and Greer 1997)                                                                       */

static void homog_setup(const rto_raster *r, rs_tri *t)
{
    double v[3][3];
    for (int k = 0; k < 3; k++) {
        const double x = t->clip[k][0], y = t->clip[k][1], w = t->clip[k][3];
        v[k][0] = (0.5 * x + 0.5 * w) * r->width; /* x_w w */
        v[k][1] = (0.5 * w - 0.5 * y) * r->height; /* y_w w */
        v[k][2] = w;
        t->z[k] = t->clip[k][2]; /* sum beta_i z_i is z_ndc where sum beta_i w_i = 1 */
    }
    double c[3][3];
    for (int i = 0; i < 3; i++) { /* row i of the inverse of [v0 v1 v2]: (v_j x v_k) / det */
        const double *a = v[(i + 1) % 3], *b = v[(i + 2) % 3];
        c[i][0] = a[1] * b[2] - a[2] * b[1];
        c[i][1] = a[2] * b[0] - a[0] * b[2];
        c[i][2] = a[0] * b[1] - a[1] * b[0];
    }
    const double det = (v[0][0] * c[0][0] + v[0][1] * c[0][1]) + v[0][2] * c[0][2];
    if (!(fabs(det) > 0.0) || !isfinite(det)) {
        t->kind = RS_NONE;
        return;
    }
    memset(t->f, 0, sizeof t->f);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            t->f[i][j] = c[i][j] / det;
            t->f[3][j] += t->f[i][j] * t->z[i];
            t->fs[j] = (i ? t->fs[j] : 0.0) + t->f[i][j];
        }
    t->f[4][0] = -t->f[3][0];
    t->f[4][1] = -t->f[3][1];
    t->f[4][2] = 1.0 - t->f[3][2];
    for (int k = 0; k < 5; k++) {
        t->g[k] = sqrt(t->f[k][0] * t->f[k][0] + t->f[k][1] * t->f[k][1]);
        if (!isfinite(t->g[k]) || !isfinite(t->f[k][2]))
            t->kind = RS_NONE;
    }
}

static inline double lin(const double f[3], double px, double py)
{
    return (f[0] * px + f[1] * py) + f[2];
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Setup, bounds, coverage                                                                                            */

void rto__rs_setup(const rto_raster *r, uint32_t instance, uint32_t t, int full, const rs_box *region, rs_tri *tri)
{
    load_vertices(r, instance, t, tri);
    tri->kind = vertex_kind(r, tri);
    tri->n = 0;
    tri->anchor = -1;
    tri->uniform = 0;
    tri->hull_n = 0;
    if (tri->kind == RS_HOMOG) {
        homog_setup(r, tri);
        return;
    }
    if (tri->kind != RS_SNAP)
        return;
    snap_choices(tri, full);
    if (tri->anchor < 0) {
        tri->kind = RS_NONE;
        return;
    }
    if (full && region) { /* rasterizing (evaluations need neither) */
        if (!tri->uniform)
            choice_hull(tri);
        snap_margins(tri, region);
    }
}

/* Pixels whose samples may lie in [lo, hi] (pixel units) along one axis, clamped to [0, size - 1]. */
static void axis_range(double lo, double hi, uint32_t samples, uint32_t size, int32_t *a, int32_t *b)
{
    const double omin = samples == 4 ? 0.125 : 0.5, omax = samples == 4 ? 0.875 : 0.5;
    double p0 = ceil(lo - omax), p1 = floor(hi - omin);
    p0 = p0 < 0.0 ? 0.0 : p0;
    p1 = p1 > size - 1.0 ? size - 1.0 : p1;
    if (!(p0 <= p1)) {
        *a = 1;
        *b = 0;
        return;
    }
    *a = (int32_t)p0;
    *b = (int32_t)p1;
}

/* Sutherland-Hodgman against plane d(v) >= 0 (binary64 clip coordinates). */
static int clip_poly(double in[][4], int n, double out[][4], int plane)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        const double *a = in[i], *b = in[(i + 1) % n];
        const double da = plane ? a[3] - a[2] : a[2], db = plane ? b[3] - b[2] : b[2];
        if (da >= 0.0)
            memcpy(out[m++], a, sizeof out[0]);
        if ((da >= 0.0) != (db >= 0.0)) {
            const double s = da / (da - db);
            for (int j = 0; j < 4; j++)
                out[m][j] = a[j] + s * (b[j] - a[j]);
            m++;
        }
    }
    return m;
}

int rto__rs_bounds(const rto_raster *r, uint32_t instance, uint32_t t, rs_box *box)
{
    rs_tri tri;
    load_vertices(r, instance, t, &tri);
    tri.kind = vertex_kind(r, &tri);
    box->x0 = box->y0 = 1;
    box->x1 = box->y1 = 0;
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY, reach = RS_SNAP_REACH;
    if (tri.kind == RS_SNAP) {
        for (int k = 0; k < 3; k++) {
            x0 = fmin(x0, tri.xw[k]);
            x1 = fmax(x1, tri.xw[k]);
            y0 = fmin(y0, tri.yw[k]);
            y1 = fmax(y1, tri.yw[k]);
        }
    } else if (tri.kind == RS_HOMOG) {
        homog_setup(r, &tri);
        if (tri.kind == RS_NONE)
            return RS_NONE;
        double p[8][4], q[8][4];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 4; j++)
                p[k][j] = tri.clip[k][j];
        int n = clip_poly(p, 3, q, 0);
        n = clip_poly(q, n, p, 1);
        if (n == 0)
            return tri.kind = RS_NONE;
        for (int k = 0; k < n; k++) {
            if (!(p[k][3] > 0.0)) { /* a point at the eye: anywhere */
                x0 = y0 = -INFINITY;
                x1 = y1 = INFINITY;
                break;
            }
            const double xw = ((p[k][0] / p[k][3]) * 0.5 + 0.5) * r->width;
            const double yw = (0.5 - (p[k][1] / p[k][3]) * 0.5) * r->height;
            x0 = fmin(x0, xw);
            x1 = fmax(x1, xw);
            y0 = fmin(y0, yw);
            y1 = fmax(y1, yw);
        }
        /* The polygon's vertices are rounded, the band reaches 2^-4 px beyond its edges: one more pixel. */
        reach = 1.0;
    } else {
        return RS_NONE;
    }
    axis_range(x0 - reach, x1 + reach, r->samples, r->width, &box->x0, &box->x1);
    axis_range(y0 - reach, y1 + reach, r->samples, r->height, &box->y0, &box->y1);
    return tri.kind;
}

int rto__rs_classify(const rs_tri *t, int64_t X, int64_t Y)
{
    if (t->kind == RS_HOMOG) {
        const double px = (double)X / RS_SUB, py = (double)Y / RS_SUB;
        if (!(lin(t->fs, px, py) > 0.0))
            return 0;
        int ref = 1, poss = 1, cert = 1;
        for (int k = 0; k < 5; k++) {
            const double v = lin(t->f[k], px, py), b = RS_HBAND * t->g[k];
            ref &= v >= 0.0;
            poss &= v >= -b;
            cert &= v > b;
        }
        return (ref ? RS_REF : 0) | (poss ? RS_POSSIBLE : 0) | (cert ? RS_CERTAIN | RS_PCOV_ALL : 0);
    }
    if (t->uniform) {
        const rs_choice *c = &t->ch[0];
        int64_t m[3];
        for (int e = 0; e < 3; e++)
            m[e] = c->sgn * edge_at(c, e, X, Y);
        if (m[0] > t->margin[0] && m[1] > t->margin[1] && m[2] > t->margin[2])
            return RS_REF | RS_POSSIBLE | RS_CERTAIN | RS_PCOV_ALL;
        if (m[0] < -t->margin[0] || m[1] < -t->margin[1] || m[2] < -t->margin[2])
            return 0;
    } else {
        for (int i = 0; i < t->hull_n; i++)
            if (t->ha[i] * X + t->hb[i] * Y + t->hc[i] < 0)
                return 0;
    }
    int poss = 0, cert = 1, ref = 0, pcov = RS_PCOV_ALL;
    for (int i = 0; i < t->n; i++) {
        const int c = choice_covers(&t->ch[i], X, Y);
        poss |= c;
        cert &= c;
        if (!c) /* a precision with a midpoint variant that misses does not cover */
            pcov &= ~t->ch[i].pmask;
        if (i == 0)
            ref = c;
    }
    return (ref ? RS_REF : 0) | (poss ? RS_POSSIBLE : 0) | (cert ? RS_CERTAIN : 0) | pcov;
}

double rto__rs_ref_depth(const rs_tri *t, int64_t X, int64_t Y)
{
    if (t->kind == RS_HOMOG)
        return clamp01(lin(t->f[3], (double)X / RS_SUB, (double)Y / RS_SUB));
    return clamp01(choice_depth(t, &t->ch[0], X, Y));
}

static void widen_depth(double lo, double hi, double *wlo, double *whi)
{
    *wlo = fmax(0.0, clamp01(lo) - RS_WIDEN_Z);
    *whi = fmin(1.0, clamp01(hi) + RS_WIDEN_Z);
}

static void homog_depth(const rs_tri *t, int64_t X, int64_t Y, double *lo, double *hi)
{
    const double z = lin(t->f[3], (double)X / RS_SUB, (double)Y / RS_SUB);
    const double d = RS_HBAND * (fabs(t->f[3][0]) + fabs(t->f[3][1]));
    widen_depth(z - d, z + d, lo, hi);
}

void rto__rs_depth_coarse(const rs_tri *t, int64_t X, int64_t Y, double *lo, double *hi)
{
    if (t->kind == RS_HOMOG) {
        homog_depth(t, X, Y, lo, hi);
        return;
    }
    const double z = choice_depth(t, &t->ch[t->anchor], X, Y);
    widen_depth(z - t->dz, z + t->dz, lo, hi);
}

void rto__rs_depth_exact(const rs_tri *t, int64_t X, int64_t Y, double *lo, double *hi)
{
    if (t->kind == RS_HOMOG) {
        homog_depth(t, X, Y, lo, hi);
        return;
    }
    double a = INFINITY, b = -INFINITY;
    for (int i = 0; i < t->n; i++)
        if (t->ch[i].sgn) {
            const double z = choice_depth(t, &t->ch[i], X, Y);
            a = fmin(a, z);
            b = fmax(b, z);
        }
    widen_depth(a, b, lo, hi);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Attributes (§11.4)                                                                                                 */

/* Perspective-correct (b1, b2) of a snapped choice at pixel centre (x + 0.5, y + 0.5). */
static void snap_bary(const rs_tri *t, const rs_choice *c, int64_t x, int64_t y, double b[2])
{
    const int64_t X = x * RS_SUB + RS_SUB / 2, Y = y * RS_SUB + RS_SUB / 2;
    const double a = (double)c->area;
    const double q0 = ((double)edge_at(c, 0, X, Y) / a) / t->w[0];
    const double q1 = ((double)edge_at(c, 1, X, Y) / a) / t->w[1];
    const double q2 = ((double)edge_at(c, 2, X, Y) / a) / t->w[2];
    const double s = (q0 + q1) + q2;
    b[0] = q1 / s;
    b[1] = q2 / s;
}

static void homog_bary(const rs_tri *t, double px, double py, double b[2])
{
    const double s = lin(t->fs, px, py);
    b[0] = lin(t->f[1], px, py) / s;
    b[1] = lin(t->f[2], px, py) / s;
}

/* a[7] from one choice's barycentrics at the pixel centre and at the centres of the quad's row (x | 1, x & ~1) and
 * column (y | 1, y & ~1), and its depth at the sample: (b1, b2), dpdxFine, dpdyFine, z; *babs the largest magnitude of
 * the barycentrics the derivatives difference (their widening's scale). */
static void quad_attr(const double b[2], const double bx1[2], const double bx0[2], const double by1[2],
                      const double by0[2], double z, double a[7], double *babs)
{
    a[0] = b[0];
    a[1] = b[1];
    a[2] = bx1[0] - bx0[0];
    a[3] = bx1[1] - bx0[1];
    a[4] = by1[0] - by0[0];
    a[5] = by1[1] - by0[1];
    a[6] = clamp01(z);
    double m = 0.0;
    for (int j = 0; j < 2; j++)
        m = fmax(m, fmax(fmax(fabs(bx1[j]), fabs(bx0[j])), fmax(fabs(by1[j]), fabs(by0[j]))));
    *babs = m;
}

/* a[7] of one snapped choice; *babs: the largest |B| of the derivatives' terms. coarse: WGSL's dpdx / dpdy may be
 * coarse (compatibility mode has no dpdxFine), the quad's top row for ddx and left column for ddy in every pixel
 * of the quad: one more admissible value of the derivatives (§11.6); the reference is fine. */
static void snap_attr(const rs_tri *t, const rs_choice *c, uint32_t x, uint32_t y, int64_t X, int64_t Y, int coarse,
                      double a[7], double *babs)
{
    const uint32_t ry = coarse ? y & ~1u : y, cx = coarse ? x & ~1u : x;
    double b[2], bx1[2], bx0[2], by1[2], by0[2];
    snap_bary(t, c, x, y, b);
    snap_bary(t, c, x | 1u, ry, bx1);
    snap_bary(t, c, x & ~1u, ry, bx0);
    snap_bary(t, c, cx, y | 1u, by1);
    snap_bary(t, c, cx, y & ~1u, by0);
    quad_attr(b, bx1, bx0, by1, by0, choice_depth(t, c, X, Y), a, babs);
}

/* The unsnapped choice (§11.3): devices that snap positions for coverage only (Mesa's llvmpipe) interpolate from the
 * binary64 window positions of the binary32 clip values. Edge e runs from vertex a to b, as choice_make's. Returns 0
 * when the unsnapped triangle has no area. */
static int unsnap_lambda(const rs_tri *t, double px, double py, double l[3])
{
    const double area =
        (t->xw[1] - t->xw[0]) * (t->yw[2] - t->yw[0]) - (t->xw[2] - t->xw[0]) * (t->yw[1] - t->yw[0]);
    if (!(area != 0.0) || !isfinite(area))
        return 0;
    for (int e = 0; e < 3; e++) {
        const int a = (e + 1) % 3, b = (e + 2) % 3;
        l[e] = ((t->xw[b] - t->xw[a]) * (py - t->yw[a]) - (t->yw[b] - t->yw[a]) * (px - t->xw[a])) / area;
    }
    return 1;
}

static void unsnap_bary(const rs_tri *t, double px, double py, double b[2])
{
    double l[3];
    unsnap_lambda(t, px, py, l);
    const double q0 = l[0] / t->w[0], q1 = l[1] / t->w[1], q2 = l[2] / t->w[2];
    const double s = (q0 + q1) + q2;
    b[0] = q1 / s;
    b[1] = q2 / s;
}

/* a[7] of the unsnapped choice, as snap_attr's (coarse too), its attribute points all moved by (ox, oy) pixels (a
 * device mixing snapped and unsnapped positions, §11.6); 0 when it has no area. */
static int unsnap_attr(const rs_tri *t, uint32_t x, uint32_t y, int64_t X, int64_t Y, int coarse, double ox, double oy,
                       double a[7], double *babs)
{
    double l[3];
    if (!unsnap_lambda(t, (double)X / RS_SUB, (double)Y / RS_SUB, l))
        return 0;
    const double cx = x + 0.5 + ox, cy = y + 0.5 + oy, ry = (coarse ? y & ~1u : y) + 0.5 + oy,
                 rx = (coarse ? x & ~1u : x) + 0.5 + ox;
    double b[2], bx1[2], bx0[2], by1[2], by0[2];
    unsnap_bary(t, cx, cy, b);
    unsnap_bary(t, (x | 1u) + 0.5 + ox, ry, bx1);
    unsnap_bary(t, (x & ~1u) + 0.5 + ox, ry, bx0);
    unsnap_bary(t, rx, (y | 1u) + 0.5 + oy, by1);
    unsnap_bary(t, rx, (y & ~1u) + 0.5 + oy, by0);
    quad_attr(b, bx1, bx0, by1, by0, (l[0] * t->z[0] + l[1] * t->z[1]) + l[2] * t->z[2], a, babs);
    return 1;
}

static void homog_attr(const rs_tri *t, uint32_t x, uint32_t y, int64_t X, int64_t Y, double a[7], double *babs)
{
    const double cx = x + 0.5, cy = y + 0.5, x1 = (x | 1u) + 0.5, x0 = (x & ~1u) + 0.5, y1 = (y | 1u) + 0.5,
                 y0 = (y & ~1u) + 0.5;
    double b[2], bx1[2], bx0[2], by1[2], by0[2];
    homog_bary(t, cx, cy, b);
    homog_bary(t, x1, cy, bx1);
    homog_bary(t, x0, cy, bx0);
    homog_bary(t, cx, y1, by1);
    homog_bary(t, cx, y0, by0);
    quad_attr(b, bx1, bx0, by1, by0, lin(t->f[3], (double)X / RS_SUB, (double)Y / RS_SUB), a, babs);
}

int rto__rs_ref_attr(const rs_tri *t, uint32_t x, uint32_t y, int64_t X, int64_t Y, double a[7])
{
    double m;
    if (t->kind == RS_HOMOG) {
        homog_attr(t, x, y, X, Y, a, &m);
        return 1;
    }
    if (t->kind != RS_SNAP || !t->ch[0].sgn)
        return 0;
    snap_attr(t, &t->ch[0], x, y, X, Y, 0, a, &m);
    return 1;
}

void rto__rs_normal(const rs_tri *t, float n[3])
{
    const float *p0 = t->world[0], *p1 = t->world[1], *p2 = t->world[2];
    const float a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    const float b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    const float c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    const float l = sqrtf((c[0] * c[0] + c[1] * c[1]) + c[2] * c[2]);
    if (!(l > 0.0f) || !isfinite(l)) {
        n[0] = n[1] = n[2] = 0.0f;
        return;
    }
    for (int k = 0; k < 3; k++)
        n[k] = c[k] / l;
}

void rto__raster_face_normal(const rto_raster *r, uint32_t instance, uint32_t prim, float n[3])
{
    n[0] = n[1] = n[2] = 0.0f;
    if (!r || instance >= r->instance_count || prim >= r->tri_base[instance + 1] - r->tri_base[instance])
        return;
    rs_tri t;
    load_vertices(r, instance, r->tri_base[instance] + prim, &t);
    rto__rs_normal(&t, n);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* How far a device's barycentrics at window point (px, py) may be from the unsnapped ones when it sets its attribute
 * planes up in binary32 from window positions of its own, each coordinate within eps pixels of ours: each screen
 * weight lambda_e = E_e(p) / A moves by at most eps (|p - a|_1 + |p - b|_1 + |b - a|_1 + |lambda_e| perimeter_1) / |A|
 * (first order in eps), and the perspective quotient b = (lambda / w) / sum(lambda / w) by at most twice that times
 * w_max / w_min. Negligible for a triangle of many pixels; for a triangle far under a pixel, evaluated at a pixel
 * centre well outside it, it is what binary32 arithmetic leaves. */
static double setup_slack(const rs_tri *t, double px, double py, double eps)
{
    const double A = fabs((t->xw[1] - t->xw[0]) * (t->yw[2] - t->yw[0]) - (t->xw[2] - t->xw[0]) * (t->yw[1] - t->yw[0]));
    if (!(A > 0.0) || !isfinite(A))
        return 0.0;
    double per = 0.0, worst = 0.0, wmin = INFINITY, wmax = 0.0;
    for (int e = 0; e < 3; e++) {
        const int a = (e + 1) % 3, b = (e + 2) % 3;
        per += fabs(t->xw[b] - t->xw[a]) + fabs(t->yw[b] - t->yw[a]);
        wmin = fmin(wmin, fabs(t->w[e]));
        wmax = fmax(wmax, fabs(t->w[e]));
    }
    for (int e = 0; e < 3; e++) {
        const int a = (e + 1) % 3, b = (e + 2) % 3;
        const double ex = t->xw[b] - t->xw[a], ey = t->yw[b] - t->yw[a];
        const double lam = fabs(ex * (py - t->yw[a]) - ey * (px - t->xw[a])) / A;
        const double d = fabs(px - t->xw[a]) + fabs(py - t->yw[a]) + fabs(px - t->xw[b]) + fabs(py - t->yw[b]) +
                         fabs(ex) + fabs(ey);
        worst = fmax(worst, eps * (d + lam * per) / A);
    }
    return wmin > 0.0 ? 2.0 * worst * (wmax / wmin) : 0.0;
}

/* Evaluation of a GPU's choice                                                                                        */

static float f32_down(double v)
{
    float f = (float)v;
    if ((double)f > v)
        f = nextafterf(f, -INFINITY);
    return f;
}

static float f32_up(double v)
{
    float f = (float)v;
    if ((double)f < v)
        f = nextafterf(f, INFINITY);
    return f;
}

static void attr_store(const double a[7], rto__vb_attr *o)
{
    o->b[0] = (float)a[0];
    o->b[1] = (float)a[1];
    o->ddx[0] = (float)a[2];
    o->ddx[1] = (float)a[3];
    o->ddy[0] = (float)a[4];
    o->ddy[1] = (float)a[5];
    o->depth = (float)a[6];
}

static void range_add(double lo[7], double hi[7], const double a[7])
{
    for (int j = 0; j < 7; j++) {
        if (isnan(a[j])) { /* a choice where the plane passes behind the eye: anything */
            lo[j] = -INFINITY;
            hi[j] = INFINITY;
            continue;
        }
        lo[j] = fmin(lo[j], a[j]);
        hi[j] = fmax(hi[j], a[j]);
    }
}

int rto__raster_eval(const rto_raster *r, uint32_t instance, uint32_t prim, uint32_t x, uint32_t y, uint32_t sample,
                     rto__vb_attr *ref, rto__vb_attr *lo, rto__vb_attr *hi)
{
    if (!r || instance >= r->instance_count || prim >= r->tri_base[instance + 1] - r->tri_base[instance])
        return 0;
    /* A validator evaluates the same triangle at neighbouring samples in turn: each thread keeps its last setup,
     * keyed by the raster's process-unique id (a raster freed and another made at its address differ). */
    static _Thread_local rs_tri cache;
    static _Thread_local uint64_t cache_id;
    static _Thread_local uint32_t cache_inst, cache_prim;
    rs_tri *t = &cache;
    if (cache_id != r->id || cache_inst != instance || cache_prim != prim) {
        rto__rs_setup(r, instance, r->tri_base[instance] + prim, 1, NULL, t);
        cache_id = r->id;
        cache_inst = instance;
        cache_prim = prim;
    }
    const uint32_t s = r->samples == 4 ? sample % 4 : 0;
    const int64_t X = (int64_t)x * RS_SUB + (r->samples == 4 ? sample4[s][0] : RS_SUB / 2);
    const int64_t Y = (int64_t)y * RS_SUB + (r->samples == 4 ? sample4[s][1] : RS_SUB / 2);
    double rv[7], l[7], h[7], a[7], babs = 0.0, m;
    for (int j = 0; j < 7; j++) {
        l[j] = INFINITY;
        h[j] = -INFINITY;
    }
    if (t->kind == RS_SNAP) {
        for (int i = 0; i < t->n; i++)
            if (t->ch[i].sgn)
                for (int coarse = 0; coarse < 2; coarse++) {
                    snap_attr(t, &t->ch[i], x, y, X, Y, coarse, a, &m);
                    range_add(l, h, a);
                    babs = fmax(babs, m);
                    if (i == t->anchor && !coarse)
                        memcpy(rv, a, sizeof rv);
                }
        /* one more choice for attributes and depth, not for coverage: unsnapped, and its attribute points moved by up
         * to half an 8-bit step in x and y (the plane of a device that mixes snapped and unsnapped positions; the
         * extremes of these smooth functions over so small a box are at or next to its corners) */
        static const double shift[5][2] = {{0, 0}, {-0x1p-9, -0x1p-9}, {0x1p-9, -0x1p-9}, {-0x1p-9, 0x1p-9},
                                           {0x1p-9, 0x1p-9}};
        for (int q = 0; q < 5; q++)
            for (int coarse = 0; coarse < 2; coarse++)
                if (unsnap_attr(t, x, y, X, Y, coarse, shift[q][0], shift[q][1], a, &m)) {
                    a[6] = q ? l[6] : a[6]; /* depth is per sample: not moved */
                    range_add(l, h, a);
                    babs = fmax(babs, m);
                }
    } else if (t->kind == RS_HOMOG) {
        /* The band: the functions at the point moved by up to 2^-4 px along each axis. A linear-fractional function
         * takes its extremes over a box at the box's corners (where its denominator keeps its sign); the
         * derivatives' terms are bounded separately (conservative). */
        homog_attr(t, x, y, X, Y, rv, &babs);
        range_add(l, h, rv);
        const double cx = x + 0.5, cy = y + 0.5, xs[2] = {(x | 1u) + 0.5, (x & ~1u) + 0.5},
                     ys[2] = {(y | 1u) + 0.5, (y & ~1u) + 0.5};
        double bl[5][2], bh[5][2]; /* centre, x|1, x&~1, y|1, y&~1 */
        const double px[5] = {cx, xs[0], xs[1], cx, cx}, py[5] = {cy, cy, cy, ys[0], ys[1]};
        int bad = 0;
        for (int q = 0; q < 5; q++) {
            bl[q][0] = bl[q][1] = INFINITY;
            bh[q][0] = bh[q][1] = -INFINITY;
            for (int c = 0; c < 4; c++) {
                const double ox = (c & 1) ? RS_HBAND : -RS_HBAND, oy = (c & 2) ? RS_HBAND : -RS_HBAND;
                if (!(lin(t->fs, px[q] + ox, py[q] + oy) > 0.0))
                    bad = 1;
                double b[2];
                homog_bary(t, px[q] + ox, py[q] + oy, b);
                for (int j = 0; j < 2; j++) {
                    bl[q][j] = fmin(bl[q][j], b[j]);
                    bh[q][j] = fmax(bh[q][j], b[j]);
                    babs = fmax(babs, fabs(b[j]));
                }
            }
        }
        const double dlo[7] = {bl[0][0], bl[0][1], bl[1][0] - bh[2][0], bl[1][1] - bh[2][1], bl[3][0] - bh[4][0],
                               bl[3][1] - bh[4][1], 0.0};
        const double dhi[7] = {bh[0][0], bh[0][1], bh[1][0] - bl[2][0], bh[1][1] - bl[2][1], bh[3][0] - bl[4][0],
                               bh[3][1] - bl[4][1], 0.0};
        for (int j = 0; j < 6; j++) {
            l[j] = bad ? -INFINITY : fmin(l[j], dlo[j]);
            h[j] = bad ? INFINITY : fmax(h[j], dhi[j]);
        }
        double zl, zh;
        homog_depth(t, X, Y, &zl, &zh);
        l[6] = zl;
        h[6] = zh;
    } else {
        return 0;
    }
    if (t->kind == RS_SNAP) {
        double zl = l[6], zh = h[6];
        widen_depth(zl, zh, &l[6], &h[6]);
        /* A device may build the attribute planes from a mix of snapped and unsnapped positions (Mesa's llvmpipe at
         * 4x MSAA: gradients of one, origin of the other), which is the plane of one choice evaluated at a point up
         * to half an 8-bit step (2^-9 px) from the pixel centre: the barycentrics move by at most that times their
         * x and y derivatives' magnitudes. */
        for (int j = 0; j < 2; j++) {
            const double g = fmax(fabs(l[2 + j]), fabs(h[2 + j])) + fmax(fabs(l[4 + j]), fabs(h[4 + j]));
            l[j] -= 0x1p-9 * g;
            h[j] += 0x1p-9 * g;
        }
        /* A device's own binary32 window positions: each coordinate within 8 binary32 ulps of the image size. */
        const double eps = 8.0 * 0x1p-24 * (double)(r->width > r->height ? r->width : r->height);
        const double sb = setup_slack(t, x + 0.5, y + 0.5, eps);
        double sd = 0.0;
        for (int q = 0; q < 4; q++)
            sd = fmax(sd, setup_slack(t, ((q & 1) ? x | 1u : x & ~1u) + 0.5, ((q & 2) ? y | 1u : y & ~1u) + 0.5, eps));
        for (int j = 0; j < 2; j++) {
            l[j] -= sb;
            h[j] += sb;
        }
        for (int j = 2; j < 6; j++) {
            l[j] -= 2.0 * sd;
            h[j] += 2.0 * sd;
        }
    }
    for (int j = 0; j < 2; j++) {
        const double w = RS_WIDEN_B * fmax(1.0, fmax(fabs(l[j]), fabs(h[j])));
        l[j] -= w;
        h[j] += w;
    }
    for (int j = 2; j < 6; j++) {
        const double w = RS_WIDEN_D * fmax(1.0, babs);
        l[j] -= w;
        h[j] += w;
    }
    attr_store(rv, ref);
    const float fl[7] = {f32_down(l[0]), f32_down(l[1]), f32_down(l[2]), f32_down(l[3]), f32_down(l[4]),
                         f32_down(l[5]), f32_down(l[6])};
    const float fh[7] = {f32_up(h[0]), f32_up(h[1]), f32_up(h[2]), f32_up(h[3]), f32_up(h[4]), f32_up(h[5]),
                         f32_up(h[6])};
    lo->b[0] = fl[0], lo->b[1] = fl[1], lo->ddx[0] = fl[2], lo->ddx[1] = fl[3], lo->ddy[0] = fl[4],
    lo->ddy[1] = fl[5], lo->depth = fl[6];
    hi->b[0] = fh[0], hi->b[1] = fh[1], hi->ddx[0] = fh[2], hi->ddx[1] = fh[3], hi->ddy[0] = fh[4],
    hi->ddy[1] = fh[5], hi->depth = fh[6];
    return 1;
}
