/* Private pieces of the wavefront frame shared by its files (src/frame/). Not installed; not exported. */
#ifndef RTO_FRAME_INTERNAL_H
#define RTO_FRAME_INTERNAL_H

#include "rtoracle.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* ---------------------------------------------------------------------------------------------------------------- */
/* The stage2 scene (stage2.c): seed 002's analytic primitives                                                       */

/** Primitives of the stage2 scene, in traceScene's order: a hit record's instanceId and customIndex. */
#define RTO_STAGE2_PRIMITIVES 4u

/**
 * The seed's normal of a stage2 hit (intersectSphere / intersectBox of seed 002 §2.3) in binary32: position =
 * origin + t * dir per component; a sphere gives normalize(position - center); a box gives normalize(f32(|p.c| >
 * d.c - 0.001) * sign(p.c)) per component with p = position - center, d the half extents. normalize(v) is v / length(v)
 * (DESIGN.md §7), so a box hit whose position is further than 0.001 inside every face (possible only when rounding
 * moves the position: an origin or t far out of scale) has the zero vector and gets NaN, as that formula gives on a
 * GPU. sign(0) = 0 (WGSL). A miss record (or an instanceId past the primitives) gives NaN.
 */
void rto__stage2_normal(const rto_wf_ray *ray, const rto_hit_record *hit, float n[3]);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
