/* The material pass's private interface (DESIGN.md §11.5): the classifier's decision for one pixel with a margin about
 * its thresholds, what check_vbuffer.c compares a GPU's edge mask with (§11.6: a pixel whose decision lies within
 * 2^-10 relative of a threshold may go either way). Defined in material.c, beside rto_vbuffer_classify, so that the
 * classifier's rule has one home. */
#ifndef RTO_MATERIAL_INTERNAL_H
#define RTO_MATERIAL_INTERNAL_H

#include "rtoracle.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** The classifier's decisions for one pixel (rto__vbuffer_classify_pixel). */
#define RTO__VB_INTERIOR 0
#define RTO__VB_EDGE 1
#define RTO__VB_EITHER 2 /* the decision turns on a comparison within its tolerance (below) of its threshold */

/**
 * The classifier of §11.5 at pixel (x, y) of planes (visibility, normal and depth are read; planes must hold them),
 * every threshold comparison `a > t·b` (or `dot < t`) taken both ways where |a − t·b| is within the binary32 error of
 * evaluating its terms (a GPU's classifier runs in binary32; view depth near the far plane loses most of its digits)
 * plus margin·|t·b|: returns
 * RTO__VB_EDGE when the pixel is an edge whichever way those comparisons go, RTO__VB_INTERIOR when it is interior
 * whichever way they go, RTO__VB_EITHER otherwise. With margin 0 it is rto_vbuffer_classify's decision (never
 * RTO__VB_EITHER). check-vbuffer passes 2^-10.
 */
int rto__vbuffer_classify_pixel(const rto_vbuffer_planes *planes, const rto_vbuffer_camera *camera,
                                const rto_vb_thresholds *thresholds, uint32_t x, uint32_t y, double margin);

/**
 * The bounds check-vbuffer accepts for the `unlit` image (§11.6), per pixel and channel, resolved like
 * rto_vbuffer_shade (sample 0, or every sample averaged where mask is set): a textured sample contributes its base
 * colour factor times the hull of the texels a conforming GPU's filtering may read (rto__vb_texture_hull), any other
 * sample its exact colour. textured[px] = 1 where some shaded sample of the pixel is textured (lo and hi then hold
 * its bounds, before binary16 rounding); 0 elsewhere, where the exact rule applies. Other materials: all 0.
 */
rto_status rto__vbuffer_shade_bounds(const rto_vbuffer_planes *planes, const uint8_t *mask,
                                     const rto_vbuffer_geometry *geometry, const rto_vbuffer_material_desc *desc,
                                     float *lo, float *hi, uint8_t *textured, rto_msg *msg);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
