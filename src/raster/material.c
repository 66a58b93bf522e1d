/* The material pass of the visibility buffer (DESIGN.md §11.5): the seed's edge classifier on a G-buffer (the
 * oracle's or a GPU's own), and the shading of interior pixels once (sample 0) and of edge pixels per sample,
 * averaged. Thresholds, the sun and the built-in materials are parameters; every value is computed in binary32 in
 * the order written here, then rounded to binary16 (nearest even) like an RGBA16float store. */
#include "internal.h"
#include "raster/material_internal.h"
#include "raster/raster_internal.h"
#include "raster/texture_sample.h"

#include <math.h>
#include <string.h>

static size_t sample_index(const rto_vbuffer_planes *p, uint32_t x, uint32_t y, uint32_t s)
{
    return ((size_t)y * p->width + x) * p->samples + s;
}

static int covered(const rto_vbuffer_planes *p, size_t k)
{
    const uint16_t *v = p->visibility + 4 * k;
    return !(v[0] == 0xffffu && v[1] == 0xffffu);
}

static uint32_t instance_of(const rto_vbuffer_planes *p, size_t k)
{
    const uint16_t *v = p->visibility + 4 * k;
    return (uint32_t)v[2] | (uint32_t)v[3] << 16;
}

static void normal_of(const rto_vbuffer_planes *p, size_t k, float n[3])
{
    const float e[2] = {rto_f16_to_f32(p->normal[4 * k]), rto_f16_to_f32(p->normal[4 * k + 1])};
    rto__oct_decode(e, n);
}

/* View-space depth of a stored depth d at the centre of pixel (x, y): (P^-1 (ndc, d, 1)).z / .w, in binary64, and in
 * *err a bound on how far a binary32 evaluation (the GPU's: the seed computes it in WGSL) may be from it: the two
 * four-term dot products, fused or not, within 8 binary32 ulps of the sum of their terms' magnitudes (ndc's own
 * rounding included), the division within 2. Near the far plane .w is a difference of nearly equal terms, and the
 * bound grows with it. */
static double view_depth(const rto_vbuffer_planes *p, const rto_vbuffer_camera *cam, uint32_t x, uint32_t y, float d,
                         double *err)
{
    const double nx = ((double)x + 0.5) / p->width * 2.0 - 1.0, ny = 1.0 - ((double)y + 0.5) / p->height * 2.0;
    const double v[4] = {nx, ny, d, 1.0};
    const float *m = cam->inverse_projection;
    double z = 0.0, w = 0.0, sz = 0.0, sw = 0.0;
    for (int c = 0; c < 4; c++) {
        z += (double)m[4 * c + 2] * v[c];
        w += (double)m[4 * c + 3] * v[c];
        sz += fabs((double)m[4 * c + 2] * v[c]);
        sw += fabs((double)m[4 * c + 3] * v[c]);
    }
    const double vd = z / w, g = 8.0 * 0x1p-24;
    *err = (g * sz + fabs(vd) * g * sw) / fabs(w) + 2.0 * 0x1p-24 * fabs(vd);
    return vd;
}

/* Three-valued logic for comparisons taken both ways within a margin: 0 false, 1 true, 2 either. */
enum { NO = 0, YES = 1, EITHER = 2 };

/* a > b, where |a - b| <= tol may go either way (tol 0: the plain comparison). */
static int greater(double a, double b, double tol)
{
    if (tol > 0.0 && fabs(a - b) <= tol)
        return EITHER;
    return a > b ? YES : NO;
}

static int or3(int a, int b)
{
    if (a == YES || b == YES)
        return YES;
    return (a == EITHER || b == EITHER) ? EITHER : NO;
}

int rto__vbuffer_classify_pixel(const rto_vbuffer_planes *p, const rto_vbuffer_camera *cam,
                                const rto_vb_thresholds *t, uint32_t x, uint32_t y, double margin)
{
    const uint32_t S = p->samples;
    const size_t k0 = sample_index(p, x, y, 0);
    if (!covered(p, k0)) { /* sample 0 is background: an edge exactly when another sample is not */
        for (uint32_t s = 1; s < S; s++)
            if (covered(p, k0 + s))
                return RTO__VB_EDGE;
        return RTO__VB_INTERIOR;
    }
    int edge = NO;
    /* the samples: view-depth range over the covered ones, and more than one instance among them */
    /* With margin > 0 every comparison may go either way within the binary32 error of its terms (view_depth's
     * bound; 2^-20 for a dot product of two normals decoded and normalised in binary32) plus margin times the
     * threshold's side. */
    const int loose = margin > 0.0;
    uint32_t n = 0;
    double dmin = 0.0, dmax = 0.0, emin = 0.0, emax = 0.0, e;
    for (uint32_t s = 0; s < S; s++) {
        if (!covered(p, k0 + s))
            continue;
        const double vd = view_depth(p, cam, x, y, p->depth[k0 + s], &e);
        if (n == 0 || vd < dmin) {
            dmin = vd;
            emin = e;
        }
        if (n == 0 || vd > dmax) {
            dmax = vd;
            emax = e;
        }
        if (instance_of(p, k0 + s) != instance_of(p, k0))
            return RTO__VB_EDGE;
        n++;
    }
    if (n >= 2) {
        const double rhs = (double)t->sample_depth * fabs((dmax + dmin) * 0.5);
        const double tol = loose ? (emin + emax) * (1.0 + (double)t->sample_depth) + margin * rhs : 0.0;
        edge = or3(edge, greater(fabs(dmax - dmin), rhs, tol));
    }
    /* the 4-neighbours inside the image: background, a normal turned by more than the threshold, a depth step */
    float nc[3];
    normal_of(p, k0, nc);
    double ec;
    const double vc = view_depth(p, cam, x, y, p->depth[k0], &ec);
    const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
    for (int i = 0; i < 4 && edge != YES; i++) {
        const int64_t nx = (int64_t)x + dx[i], ny = (int64_t)y + dy[i];
        if (nx < 0 || ny < 0 || nx >= p->width || ny >= p->height)
            continue;
        const size_t kn = sample_index(p, (uint32_t)nx, (uint32_t)ny, 0);
        if (!covered(p, kn))
            return RTO__VB_EDGE;
        float nn[3];
        normal_of(p, kn, nn);
        const double dot = ((double)nc[0] * nn[0] + (double)nc[1] * nn[1]) + (double)nc[2] * nn[2];
        /* dot < threshold */
        edge = or3(edge, greater((double)t->normal, dot, loose ? 0x1p-20 + margin * fabs((double)t->normal) : 0.0));
        double en;
        const double vn = view_depth(p, cam, (uint32_t)nx, (uint32_t)ny, p->depth[kn], &en);
        const double rhs = (double)t->depth * fabs(vc);
        edge = or3(edge, greater(fabs(vc - vn), rhs, loose ? ec + en + (double)t->depth * ec + margin * rhs : 0.0));
    }
    return edge == YES ? RTO__VB_EDGE : edge == NO ? RTO__VB_INTERIOR : RTO__VB_EITHER;
}

static int planes_usable(const rto_vbuffer_planes *p)
{
    return p && p->visibility && p->normal && p->depth && p->width > 0 && p->height > 0 &&
           (p->samples == 1 || p->samples == 4);
}

rto_status rto_vbuffer_classify(const rto_vbuffer_planes *planes, const rto_vbuffer_camera *camera,
                                const rto_vb_thresholds *thresholds, uint8_t *mask, rto_msg *msg)
{
    if (!planes_usable(planes) || !camera || !thresholds || !mask)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                         "classify: NULL argument, or planes without visibility, normal or depth");
    for (uint32_t y = 0; y < planes->height; y++)
        for (uint32_t x = 0; x < planes->width; x++)
            mask[(size_t)y * planes->width + x] =
                (uint8_t)(rto__vbuffer_classify_pixel(planes, camera, thresholds, x, y, 0.0) == RTO__VB_EDGE);
    return RTO_OK;
}

/* The base colour of an instance's mesh material: white where there is none (or the ID is out of range). */
static void base_color(const rto_vbuffer_geometry *g, const rto_vbuffer_material_desc *d, uint32_t inst, float c[4])
{
    c[0] = c[1] = c[2] = c[3] = 1.0f;
    if (!g || inst >= g->instance_count || !d->materials)
        return;
    const uint32_t mesh = g->instances[inst].blas;
    if (mesh >= g->mesh_count)
        return;
    const int32_t m = g->meshes[mesh].material;
    if (m < 0 || (uint32_t)m >= d->material_count)
        return;
    memcpy(c, d->materials[m].base_color, 4 * sizeof *c);
}

/* One sample's colour (§11.5). */
static void shade_sample(const rto_vbuffer_planes *p, size_t k, const rto_vbuffer_geometry *g,
                         const rto_vbuffer_material_desc *d, const rto__vb_texture_set *ts, const float sun[3],
                         float c[4])
{
    if (!covered(p, k)) {
        c[0] = c[1] = c[2] = c[3] = 0.0f;
        return;
    }
    float n[3];
    normal_of(p, k, n);
    if (d->material == RTO_VB_PLUGIN) { /* a user's material: the sample decoded, one call */
        rto_vb_sample v;
        memset(&v, 0, sizeof v);
        const size_t px = k / p->samples;
        v.x = (uint32_t)(px % p->width);
        v.y = (uint32_t)(px / p->width);
        v.sample = (uint32_t)(k % p->samples);
        v.instance = instance_of(p, k);
        v.primitive = (uint32_t)p->visibility[4 * k] | (uint32_t)p->visibility[4 * k + 1] << 16;
        for (int a = 0; a < 2; a++) {
            v.barycentric[a] = p->barycentric ? rto_f16_to_f32(p->barycentric[2 * k + (size_t)a]) : 0.0f;
            v.ddx[a] = p->derivatives ? rto_f16_to_f32(p->derivatives[4 * k + (size_t)a]) : 0.0f;
            v.ddy[a] = p->derivatives ? rto_f16_to_f32(p->derivatives[4 * k + 2 + (size_t)a]) : 0.0f;
        }
        memcpy(v.normal, n, sizeof v.normal);
        v.depth = p->depth ? p->depth[k] : 1.0f;
        base_color(g, d, v.instance, v.base_color);
        const float sun4[4] = {sun[0], sun[1], sun[2], d->ambient};
        v.sun = sun4;
        d->custom->shade(&v, c);
        return;
    }
    switch (d->material) {
    case RTO_VB_NORMALS:
        for (int a = 0; a < 3; a++)
            c[a] = n[a] * 0.5f + 0.5f;
        c[3] = 1.0f;
        return;
    case RTO_VB_LAMBERT: {
        base_color(g, d, instance_of(p, k), c);
        const float nl = (n[0] * sun[0] + n[1] * sun[1]) + n[2] * sun[2];
        const float light = d->ambient + (1.0f - d->ambient) * (nl > 0.0f ? nl : 0.0f);
        for (int a = 0; a < 3; a++)
            c[a] = c[a] * light;
        return;
    }
    case RTO_VB_UNLIT:
    default: {
        /* the base colour factor times its texture at uv, trilinear at the derivatives' level of detail */
        base_color(g, d, instance_of(p, k), c);
        float uv[2], dx[2], dy[2], t[4];
        const rto__vb_mips *m = rto__vb_texcoord(p, k, g, d, ts, uv, dx, dy);
        if (!m)
            return;
        rto__vb_texture_sample(m, uv, rto__vb_texture_lod(m, dx, dy), t);
        for (int a = 0; a < 4; a++)
            c[a] = c[a] * t[a];
        return;
    }
    }
}

rto_status rto_vbuffer_shade(const rto_vbuffer_planes *planes, const uint8_t *mask,
                             const rto_vbuffer_geometry *geometry, const rto_vbuffer_material_desc *desc,
                             uint16_t *image, rto_msg *msg)
{
    if (!planes || !planes->visibility || !planes->normal || !mask || !desc || !image || planes->width == 0 ||
        planes->height == 0 || (planes->samples != 1 && planes->samples != 4))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "shade: NULL argument, or planes without visibility or normal");
    if (desc->material > RTO_VB_PLUGIN || (desc->material == RTO_VB_PLUGIN && (!desc->custom || !desc->custom->shade)))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "shade: unknown material %d, or a plugin material without "
                         "its table", (int)desc->material);
    /* The sun normalised in binary64 and rounded once: any finite, non-zero direction has a unit one (binary32
     * squares would overflow from 2^64 and vanish under 2^-75). */
    const double sx = desc->sun[0], sy = desc->sun[1], sz = desc->sun[2], sl = sqrt(sx * sx + sy * sy + sz * sz);
    if (desc->material == RTO_VB_LAMBERT && !(sl > 0.0 && isfinite(sl)))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "shade: the sun direction is zero or not finite");
    float sun[3] = {0.0f, 0.0f, 0.0f};
    if (sl > 0.0 && isfinite(sl)) {
        sun[0] = (float)(sx / sl);
        sun[1] = (float)(sy / sl);
        sun[2] = (float)(sz / sl);
    }
    rto__vb_texture_set ts = {NULL, 0};
    if (desc->material == RTO_VB_UNLIT) {
        rto_status st = rto__vb_texture_set_make(geometry, desc, &ts, msg);
        if (st)
            return st;
    }
    const uint32_t S = planes->samples;
    for (uint32_t y = 0; y < planes->height; y++)
        for (uint32_t x = 0; x < planes->width; x++) {
            const size_t px = (size_t)y * planes->width + x, k0 = px * S;
            float c[4];
            shade_sample(planes, k0, geometry, desc, &ts, sun, c);
            if (mask[px]) {
                for (uint32_t s = 1; s < S; s++) {
                    float cs[4];
                    shade_sample(planes, k0 + s, geometry, desc, &ts, sun, cs);
                    for (int a = 0; a < 4; a++)
                        c[a] = c[a] + cs[a];
                }
                for (int a = 0; a < 4; a++)
                    c[a] = c[a] / (float)S;
            }
            for (int a = 0; a < 4; a++)
                image[4 * px + (size_t)a] = rto_f16_from_f32(c[a]);
        }
    rto__vb_texture_set_free(&ts);
    return RTO_OK;
}

/* One unlit sample's bounds (§11.6): the base colour factor times the hull of the texels a GPU's filtering may read;
 * returns 1 for a textured sample, 0 for one shaded exactly (lo = hi: background, or the factor alone). */
static int unlit_bounds(const rto_vbuffer_planes *p, size_t k, const rto_vbuffer_geometry *g,
                        const rto_vbuffer_material_desc *d, const rto__vb_texture_set *ts, float lo[4], float hi[4])
{
    float c[4] = {0.0f, 0.0f, 0.0f, 0.0f}, uv[2], dx[2], dy[2], tl[4], th[4];
    const rto__vb_mips *m = NULL;
    if (covered(p, k)) {
        base_color(g, d, instance_of(p, k), c);
        m = rto__vb_texcoord(p, k, g, d, ts, uv, dx, dy);
    }
    if (!m) {
        memcpy(lo, c, sizeof c);
        memcpy(hi, c, sizeof c);
        return 0;
    }
    rto__vb_texture_hull(m, uv, rto__vb_texture_lod(m, dx, dy), tl, th);
    for (int a = 0; a < 4; a++) {
        const float x = c[a] * tl[a], y = c[a] * th[a];
        lo[a] = x < y ? x : y;
        hi[a] = x < y ? y : x;
    }
    return 1;
}

rto_status rto__vbuffer_shade_bounds(const rto_vbuffer_planes *planes, const uint8_t *mask,
                                     const rto_vbuffer_geometry *geometry, const rto_vbuffer_material_desc *desc,
                                     float *lo, float *hi, uint8_t *textured, rto_msg *msg)
{
    const size_t pixels = (size_t)planes->width * planes->height;
    memset(textured, 0, pixels);
    if (desc->material != RTO_VB_UNLIT)
        return RTO_OK;
    rto__vb_texture_set ts;
    rto_status st = rto__vb_texture_set_make(geometry, desc, &ts, msg);
    if (st || !ts.mips)
        return st;
    const uint32_t S = planes->samples;
    for (size_t px = 0; px < pixels; px++) {
        const size_t k0 = px * S;
        float *l = lo + 4 * px, *h = hi + 4 * px;
        int any = unlit_bounds(planes, k0, geometry, desc, &ts, l, h);
        if (mask[px]) {
            for (uint32_t s = 1; s < S; s++) {
                float ls[4], hs[4];
                any |= unlit_bounds(planes, k0 + s, geometry, desc, &ts, ls, hs);
                for (int a = 0; a < 4; a++) {
                    l[a] = l[a] + ls[a];
                    h[a] = h[a] + hs[a];
                }
            }
            for (int a = 0; a < 4; a++) {
                l[a] = l[a] / (float)S;
                h[a] = h[a] / (float)S;
            }
        }
        textured[px] = (uint8_t)any;
    }
    rto__vb_texture_set_free(&ts);
    return RTO_OK;
}
