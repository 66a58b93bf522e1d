/* Texture sampling of the material pass's `unlit` material (DESIGN.md §11.5): the mip chain the oracle defines, the
 * level of detail from the barycentric derivatives, trilinear sampling with repeat wrap, and the hull of the texels a
 * conforming GPU's filtering may read (§11.6). Private to src/raster/; defined in texture_sample.c. */
#ifndef RTO_TEXTURE_SAMPLE_H
#define RTO_TEXTURE_SAMPLE_H

#include "rtoracle.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** At most 15 levels: a side of up to 16384 texels. */
#define RTO__VB_MAX_LEVELS 15
/** §11.6: a GPU's level of detail may differ from the oracle's by this much (its binary32 log2 and length, a lod
 * quantized to 6 fractional bits before the levels are chosen). */
#define RTO__VB_LOD_EPS 0x1p-6
/** §11.6: a GPU's texel coordinate u·size − 0.5 may differ by 2^-16·max(1, |u|)·size (its binary32 evaluation of uv
 * in another order) plus 1/32 texel (Vulkan's least sub-texel precision, 4 bits, rounded). */
#define RTO__VB_UV_EPS 0x1p-16
#define RTO__VB_TEXEL_EPS 0x1p-5

/** A texture's mip chain (§11.5): level 0 the texels' values / 255, level k + 1 the 2×2 box filter of level k, both in
 * binary32, each level stored rounded to binary16 (what the bundle holds and a GPU uploads as rgba16float). rgba holds
 * the stored values, widened exactly to binary32, level after level, rows top first. */
typedef struct rto__vb_mips {
    uint32_t levels;
    uint32_t width[RTO__VB_MAX_LEVELS], height[RTO__VB_MAX_LEVELS];
    size_t offset[RTO__VB_MAX_LEVELS]; /* first texel of each level in rgba (texels, 4 floats each) */
    size_t texels;                     /* over every level */
    float *rgba;
} rto__vb_mips;

/** The number of levels of a width × height texture: floor(log2(max(width, height))) + 1; level k is
 * max(1, width >> k) × max(1, height >> k). */
uint32_t rto__vb_mip_levels(uint32_t width, uint32_t height);
/** The mip chain of t. RTO_ERR_INVALID_ARGUMENT for an empty texture or a side over 16384; RTO_ERR_OUT_OF_MEMORY. */
rto_status rto__vb_mips_make(const rto_texture *t, rto__vb_mips *out, rto_msg *msg);
void rto__vb_mips_free(rto__vb_mips *m);

/** The chains a material pass reads: one per texture some mesh of the geometry samples (NULL rgba for the rest). */
typedef struct rto__vb_texture_set {
    rto__vb_mips *mips;
    uint32_t count;
} rto__vb_texture_set;
rto_status rto__vb_texture_set_make(const rto_vbuffer_geometry *g, const rto_vbuffer_material_desc *d,
                                    rto__vb_texture_set *out, rto_msg *msg);
void rto__vb_texture_set_free(rto__vb_texture_set *s);

/** The texture coordinates of one covered sample k (§11.5): uv = b0·uv0 + b1·uv1 + b2·uv2 (b0 = 1 − b1 − b2) and
 * dUV/dx = ddx(b1)·(uv1 − uv0) + ddx(b2)·(uv2 − uv0), dUV/dy likewise, in binary32 from the planes' binary16 values.
 * Returns the chain of the texture the sample's mesh material names, or NULL where it has none (no material, no
 * texture, no UVs, an out-of-range ID): then the unlit colour is the base colour factor alone. */
const rto__vb_mips *rto__vb_texcoord(const rto_vbuffer_planes *p, size_t k, const rto_vbuffer_geometry *g,
                                     const rto_vbuffer_material_desc *d, const rto__vb_texture_set *ts, float uv[2],
                                     float duvdx[2], float duvdy[2]);

/** The level of detail: log2(max(‖dUV/dx ⊙ size‖₂, ‖dUV/dy ⊙ size‖₂)) with size level 0's (width, height), clamped to
 * [0, levels − 1] (0 for a zero or non-finite footprint), in binary32. */
float rto__vb_texture_lod(const rto__vb_mips *m, const float duvdx[2], const float duvdy[2]);
/** Trilinear sampling at uv and lod (clamped to [0, levels − 1]): bilinear in levels floor(lod) and floor(lod) + 1
 * (the last level twice at the top), texel centres at (i + 0.5)/size, repeat wrap, then (1 − f)·c0 + f·c1 with f the
 * fraction of lod; binary32. */
void rto__vb_texture_sample(const rto__vb_mips *m, const float uv[2], float lod, float rgba[4]);
/** The per-channel [lo, hi] hull of every texel a conforming GPU may read for uv and lod (§11.6): levels
 * floor(lod − RTO__VB_LOD_EPS) .. ceil(lod + RTO__VB_LOD_EPS) clamped to the chain, and in each the texels of the
 * bilinear footprints of every texel coordinate within RTO__VB_UV_EPS·max(1, |u|)·size + RTO__VB_TEXEL_EPS of
 * u·size − 0.5 (likewise v), wrapped. Non-finite uv or lod: the whole chain. */
void rto__vb_texture_hull(const rto__vb_mips *m, const float uv[2], float lod, float lo[4], float hi[4]);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
