/* Texture sampling for the visibility buffer's `unlit` material (DESIGN.md §11.5, §11.6): the oracle's mip chain
 * (2×2 box filter in binary32, each level stored as binary16 so that a GPU uploads exactly those values into an
 * rgba16float texture), the isotropic level of detail from the barycentric derivatives, trilinear sampling with
 * repeat wrap, and the hull check-vbuffer accepts: a GPU's bilinear and mip weights have few bits (8 on many
 * devices), so the image is checked against the range of the texels its filtering may read, not one value. */
#include "internal.h"
#include "raster/texture_sample.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

uint32_t rto__vb_mip_levels(uint32_t width, uint32_t height)
{
    uint32_t side = width > height ? width : height, levels = 1;
    while (side > 1) {
        side >>= 1;
        levels++;
    }
    return levels;
}

rto_status rto__vb_mips_make(const rto_texture *t, rto__vb_mips *out, rto_msg *msg)
{
    memset(out, 0, sizeof *out);
    if (!t || !t->rgba || t->width == 0 || t->height == 0 || t->width > 16384 || t->height > 16384)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "texture '%s': empty, or a side over 16384 texels",
                         t ? t->name : "(null)");
    out->levels = rto__vb_mip_levels(t->width, t->height);
    size_t texels = 0;
    for (uint32_t k = 0; k < out->levels; k++) {
        out->width[k] = t->width >> k ? t->width >> k : 1;
        out->height[k] = t->height >> k ? t->height >> k : 1;
        out->offset[k] = texels;
        texels += (size_t)out->width[k] * out->height[k];
    }
    out->texels = texels;
    out->rgba = malloc(texels * 4 * sizeof *out->rgba);
    float *exact = malloc(texels * 4 * sizeof *exact); /* the chain before rounding to binary16 */
    if (!out->rgba || !exact) {
        free(exact);
        rto__vb_mips_free(out);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the mip chain of '%s'", t->name);
    }
    for (size_t i = 0; i < 4 * (size_t)t->width * t->height; i++)
        exact[i] = (float)t->rgba[i] / 255.0f;
    for (uint32_t k = 0; k + 1 < out->levels; k++) {
        const uint32_t w = out->width[k], h = out->height[k];
        const float *src = exact + 4 * out->offset[k];
        float *dst = exact + 4 * out->offset[k + 1];
        /* texel (i, j) of level k + 1 averages (2i, 2j), (2i + 1, 2j), (2i, 2j + 1), (2i + 1, 2j + 1) of level k,
         * coordinates clamped to the level (a side of 1 repeats its texel); an odd side's last row or column is not
         * read (floor, as the level sizes are) */
        for (uint32_t j = 0; j < out->height[k + 1]; j++)
            for (uint32_t i = 0; i < out->width[k + 1]; i++) {
                const uint32_t x0 = 2 * i < w ? 2 * i : w - 1, x1 = 2 * i + 1 < w ? 2 * i + 1 : w - 1;
                const uint32_t y0 = 2 * j < h ? 2 * j : h - 1, y1 = 2 * j + 1 < h ? 2 * j + 1 : h - 1;
                const float *a = src + 4 * ((size_t)y0 * w + x0), *b = src + 4 * ((size_t)y0 * w + x1);
                const float *c = src + 4 * ((size_t)y1 * w + x0), *d = src + 4 * ((size_t)y1 * w + x1);
                float *o = dst + 4 * ((size_t)j * out->width[k + 1] + i);
                for (int ch = 0; ch < 4; ch++)
                    o[ch] = ((a[ch] + b[ch]) + (c[ch] + d[ch])) * 0.25f;
            }
    }
    for (size_t i = 0; i < 4 * texels; i++)
        out->rgba[i] = rto_f16_to_f32(rto_f16_from_f32(exact[i]));
    free(exact);
    return RTO_OK;
}

void rto__vb_mips_free(rto__vb_mips *m)
{
    if (!m)
        return;
    free(m->rgba);
    memset(m, 0, sizeof *m);
}

/* The texture a mesh's material samples for base colour: its index, or -1. */
static int32_t mesh_texture(const rto_vbuffer_geometry *g, const rto_vbuffer_material_desc *d, uint32_t mesh)
{
    if (!g || mesh >= g->mesh_count || !d->materials || !d->textures || !g->meshes[mesh].uvs)
        return -1;
    const int32_t m = g->meshes[mesh].material;
    if (m < 0 || (uint32_t)m >= d->material_count)
        return -1;
    const int32_t t = d->materials[m].base_color_texture;
    return t >= 0 && (uint32_t)t < d->texture_count ? t : -1;
}

rto_status rto__vb_texture_set_make(const rto_vbuffer_geometry *g, const rto_vbuffer_material_desc *d,
                                    rto__vb_texture_set *out, rto_msg *msg)
{
    memset(out, 0, sizeof *out);
    if (!d || !d->textures || d->texture_count == 0 || !g)
        return RTO_OK;
    out->mips = calloc(d->texture_count, sizeof *out->mips);
    if (!out->mips)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the mip chains");
    out->count = d->texture_count;
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        const int32_t t = mesh_texture(g, d, m);
        if (t < 0 || out->mips[t].rgba)
            continue;
        rto_status s = rto__vb_mips_make(&d->textures[t], &out->mips[t], msg);
        if (s) {
            rto__vb_texture_set_free(out);
            return s;
        }
    }
    return RTO_OK;
}

void rto__vb_texture_set_free(rto__vb_texture_set *s)
{
    if (!s)
        return;
    for (uint32_t t = 0; s->mips && t < s->count; t++)
        rto__vb_mips_free(&s->mips[t]);
    free(s->mips);
    memset(s, 0, sizeof *s);
}

const rto__vb_mips *rto__vb_texcoord(const rto_vbuffer_planes *p, size_t k, const rto_vbuffer_geometry *g,
                                     const rto_vbuffer_material_desc *d, const rto__vb_texture_set *ts, float uv[2],
                                     float duvdx[2], float duvdy[2])
{
    if (!ts || !ts->mips || !g || !p->barycentric || !p->derivatives)
        return NULL;
    const uint16_t *v = p->visibility + 4 * k;
    const uint32_t prim = (uint32_t)v[0] | (uint32_t)v[1] << 16, inst = (uint32_t)v[2] | (uint32_t)v[3] << 16;
    if (inst >= g->instance_count)
        return NULL;
    const uint32_t mesh = g->instances[inst].blas;
    const int32_t t = mesh_texture(g, d, mesh);
    if (t < 0 || (uint32_t)t >= ts->count || !ts->mips[t].rgba)
        return NULL;
    const rto_mesh *me = &g->meshes[mesh];
    if (prim >= me->triangle_count)
        return NULL;
    const float *u[3];
    for (int i = 0; i < 3; i++) {
        const uint32_t vi = me->indices[3 * (size_t)prim + (size_t)i];
        if (vi >= me->vertex_count)
            return NULL;
        u[i] = me->uvs + 2 * (size_t)vi;
    }
    const float b1 = rto_f16_to_f32(p->barycentric[2 * k]), b2 = rto_f16_to_f32(p->barycentric[2 * k + 1]);
    const float b0 = 1.0f - b1 - b2;
    const uint16_t *dd = p->derivatives + 4 * k;
    const float dx1 = rto_f16_to_f32(dd[0]), dx2 = rto_f16_to_f32(dd[1]);
    const float dy1 = rto_f16_to_f32(dd[2]), dy2 = rto_f16_to_f32(dd[3]);
    for (int a = 0; a < 2; a++) {
        uv[a] = (b0 * u[0][a] + b1 * u[1][a]) + b2 * u[2][a];
        const float e1 = u[1][a] - u[0][a], e2 = u[2][a] - u[0][a];
        duvdx[a] = dx1 * e1 + dx2 * e2;
        duvdy[a] = dy1 * e1 + dy2 * e2;
    }
    return &ts->mips[t];
}

float rto__vb_texture_lod(const rto__vb_mips *m, const float duvdx[2], const float duvdy[2])
{
    const float w = (float)m->width[0], h = (float)m->height[0];
    const float xu = duvdx[0] * w, xv = duvdx[1] * h, yu = duvdy[0] * w, yv = duvdy[1] * h;
    const float lx = sqrtf(xu * xu + xv * xv), ly = sqrtf(yu * yu + yv * yv);
    const float rho = lx > ly ? lx : ly;
    if (!(rho > 0.0f) || !isfinite(rho))
        return 0.0f;
    const float lod = log2f(rho), top = (float)(m->levels - 1);
    return lod < 0.0f ? 0.0f : lod > top ? top : lod;
}

/* i mod n in [0, n) (repeat wrap); 0 for a coordinate beyond binary64's range or not finite (a GPU dump's
 * barycentrics may reach 65504, and a scene's UVs may be huge: no such coordinate may reach the conversion). */
static uint32_t wrap(double i, uint32_t n)
{
    if (!isfinite(i))
        return 0;
    double r = fmod(i, (double)n);
    if (r < 0.0)
        r += (double)n;
    const uint32_t q = r >= 0.0 && r < (double)n ? (uint32_t)r : 0;
    return q < n ? q : 0;
}

static const float *texel(const rto__vb_mips *m, uint32_t level, uint32_t i, uint32_t j)
{
    return m->rgba + 4 * (m->offset[level] + (size_t)j * m->width[level] + i);
}

static void bilinear(const rto__vb_mips *m, uint32_t level, const float uv[2], float c[4])
{
    const uint32_t w = m->width[level], h = m->height[level];
    const float x = uv[0] * (float)w - 0.5f, y = uv[1] * (float)h - 0.5f;
    const float fx = floorf(x), fy = floorf(y);
    const float ax = isfinite(x) ? x - fx : 0.0f, ay = isfinite(y) ? y - fy : 0.0f;
    const uint32_t i0 = wrap(fx, w), i1 = wrap((double)fx + 1.0, w), j0 = wrap(fy, h), j1 = wrap((double)fy + 1.0, h);
    const float *t00 = texel(m, level, i0, j0), *t10 = texel(m, level, i1, j0);
    const float *t01 = texel(m, level, i0, j1), *t11 = texel(m, level, i1, j1);
    for (int ch = 0; ch < 4; ch++)
        c[ch] = (t00[ch] * (1.0f - ax) + t10[ch] * ax) * (1.0f - ay) + (t01[ch] * (1.0f - ax) + t11[ch] * ax) * ay;
}

void rto__vb_texture_sample(const rto__vb_mips *m, const float uv[2], float lod, float rgba[4])
{
    const float top = (float)(m->levels - 1);
    if (!(lod >= 0.0f))
        lod = 0.0f;
    if (lod > top)
        lod = top;
    if (!isfinite(uv[0]) || !isfinite(uv[1])) {
        memcpy(rgba, texel(m, 0, 0, 0), 4 * sizeof *rgba);
        return;
    }
    const uint32_t l0 = (uint32_t)lod, l1 = l0 + 1 < m->levels ? l0 + 1 : l0;
    const float f = lod - (float)l0;
    float c0[4], c1[4];
    bilinear(m, l0, uv, c0);
    bilinear(m, l1, uv, c1);
    for (int ch = 0; ch < 4; ch++)
        rgba[ch] = c0[ch] * (1.0f - f) + c1[ch] * f;
}

static void hull_add(const float *t, float lo[4], float hi[4])
{
    for (int ch = 0; ch < 4; ch++) {
        lo[ch] = t[ch] < lo[ch] ? t[ch] : lo[ch];
        hi[ch] = t[ch] > hi[ch] ? t[ch] : hi[ch];
    }
}

void rto__vb_texture_hull(const rto__vb_mips *m, const float uv[2], float lod, float lo[4], float hi[4])
{
    for (int ch = 0; ch < 4; ch++) {
        lo[ch] = INFINITY;
        hi[ch] = -INFINITY;
    }
    const int whole = !isfinite(uv[0]) || !isfinite(uv[1]) || isnan(lod);
    const double top = (double)(m->levels - 1);
    double lmin = floor((double)lod - RTO__VB_LOD_EPS), lmax = ceil((double)lod + RTO__VB_LOD_EPS);
    lmin = lmin < 0.0 ? 0.0 : lmin > top ? top : lmin;
    lmax = lmax < 0.0 ? 0.0 : lmax > top ? top : lmax;
    const uint32_t first = whole ? 0 : (uint32_t)lmin, last = whole ? m->levels - 1 : (uint32_t)lmax;
    for (uint32_t l = first; l <= last; l++) {
        const uint32_t size[2] = {m->width[l], m->height[l]};
        double from[2], to[2];
        for (int a = 0; a < 2 && !whole; a++) {
            const double c = (double)uv[a] * size[a] - 0.5;
            const double e = RTO__VB_UV_EPS * fmax(1.0, fabs((double)uv[a])) * size[a] + RTO__VB_TEXEL_EPS;
            from[a] = floor(c - e);
            to[a] = floor(c + e) + 1.0; /* the right-hand texel of the last footprint */
        }
        const int all_i = whole || to[0] - from[0] + 1.0 >= size[0];
        const int all_j = whole || to[1] - from[1] + 1.0 >= size[1];
        const uint32_t ni = all_i ? size[0] : (uint32_t)(to[0] - from[0]) + 1;
        const uint32_t nj = all_j ? size[1] : (uint32_t)(to[1] - from[1]) + 1;
        for (uint32_t jj = 0; jj < nj; jj++) {
            const uint32_t j = all_j ? jj : wrap(from[1] + jj, size[1]);
            for (uint32_t ii = 0; ii < ni; ii++) {
                const uint32_t i = all_i ? ii : wrap(from[0] + ii, size[0]);
                hull_add(texel(m, l, i, j), lo, hi);
            }
        }
    }
}
