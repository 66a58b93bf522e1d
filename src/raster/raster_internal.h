/* The rasterizer's private interface (DESIGN.md §11): what check_vbuffer.c and material.c need beyond the public
 * rto_vbuffer_* functions. */
#ifndef RTO_RASTER_INTERNAL_H
#define RTO_RASTER_INTERNAL_H

#include "rtoracle.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** Sample s of a pixel with `samples` samples (1 or 4): its position within the pixel (§11.2). */
void rto__vb_sample_pos(uint32_t samples, uint32_t s, double *sx, double *sy);

/** What the visibility pass writes for one triangle at one sample, before binary16 rounding. */
typedef struct rto__vb_attr {
    float b[2];   /* (b1, b2) at the pixel centre */
    float ddx[2]; /* dpdxFine of (b1, b2) */
    float ddy[2]; /* dpdyFine */
    float depth;  /* z at the sample, in [0, 1] */
} rto__vb_attr;

/**
 * Triangle `prim` of `instance` at sample `sample` of pixel (x, y): *ref the value at the reference precision
 * (p = 8), *lo and *hi the range over every admissible choice of §11.3, widened by binary32 evaluation (§11.6; not
 * yet rounded to binary16). Returns 1, or 0 when the triangle is degenerate or behind the camera at every choice
 * (nothing to evaluate).
 */
int rto__raster_eval(const rto_raster *r, uint32_t instance, uint32_t prim, uint32_t x, uint32_t y, uint32_t sample,
                     rto__vb_attr *ref, rto__vb_attr *lo, rto__vb_attr *hi);

/** The binary32 world-space face normal of triangle `prim` of `instance` as §11.4 computes it (unit length; (0, 0, 0)
 * for a degenerate triangle). */
void rto__raster_face_normal(const rto_raster *r, uint32_t instance, uint32_t prim, float n[3]);

/** The octahedral encoding of a unit vector (Cigolle et al. 2014, §11.4), in binary32. */
void rto__oct_encode(const float n[3], float out[2]);
/** Its inverse, normalised (binary32). */
void rto__oct_decode(const float e[2], float n[3]);

/** binary16 rounded toward zero (what check_vbuffer's rounding test compares against). */
uint16_t rto__f16_from_f32_rtz(float f);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
