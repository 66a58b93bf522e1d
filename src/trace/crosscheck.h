/* Per-ray comparison of the oracle's hit records with another tracer's (Embree's), and the classification of every
 * disagreement (docs/trace.md "crosscheck"). Pure functions of the scene, the ray and the records (and the
 * conformance model's view of the scene, conform.h, which GPU records are judged by in check_hits.c), so the classes
 * are tested on hand-made cases (tests/test_embree.c) as well as used by `rtoracle crosscheck`.
 *
 * A ray agrees when both miss, or both hit the same (instance, primitive) with |t_oracle - t_embree| <=
 * 1e-5 max(1, |t_oracle|) (DESIGN.md §9; Embree's t differs by rounding: it inverts objToWorld itself and uses other
 * arithmetic). A TERMINATE_ON_FIRST_HIT ray agrees when both hit or both miss (only that is defined). Otherwise the
 * first class that fits, in this order:
 *   tie          both hit, different primitives, t within the t tolerance, and the two triangles share a vertex:
 *                the same vertex index in the same instance, or world positions equal within XC_SHARED_REL
 *   coplanar     both hit, different primitives, t within the t tolerance, the triangles lie in one plane (every
 *                vertex of each within XC_PLANE_REL of the other's plane) and the hit point lies in both (within
 *                the grazing distance below)
 *   crossing     both hit, different primitives, t within the t tolerance, not in one plane, and the hit point lies
 *                on both triangles (within the grazing distance): the ray meets the line where two triangles that
 *                share no vertex touch or cross (interpenetrating parts, T-junctions). Like a tie, both answers are
 *                right (DESIGN.md §9 accepts any primitive at the same t).
 *   t-rounding   both hit the same primitive but t differs by more than the t tolerance, and both t lie in the
 *                model's t interval for it (conform.h: a t a conforming implementation of §6 may compute), or the two
 *                hit points lie within XC_EDGE_REL S of each other across the triangle's plane
 *                (|dt| |d'| |cos a| <= XC_EDGE_REL S, S and a as for grazing): the rounding of coordinates much larger
 *                than t (an origin far from a near hit) or the ill-conditioning of t at a shallow angle
 *   robust-only  only when comparing against Embree's default mode: Embree default missed the oracle's triangle (or
 *                found another one) and Embree robust agrees with the oracle (default's non-watertight intersection
 *                or box test missed the hit)
 *   surface-start  the hit one side found and the other did not (or the nearer of two) lies on a plane the ray
 *                starts on: the triangle's binary64 plane crossing within the t-rounding bound of tMin, or the
 *                model's t interval reaching tMin
 *   grazing      the hit one side found and the other did not is one the model says a conforming implementation may
 *                hit or miss (an edge within rounding) or reach or not (a box at its edge); or it lies near the
 *                boundary of its triangle: its distance to the nearest edge line is at most XC_EDGE_REL S / |cos a|
 *                in object space, where S = max(1, the largest coordinate magnitude of the object-space origin, hit
 *                point and vertices) and a is the angle between the ray and the triangle's normal; or the ray runs
 *                nearly parallel to the triangle's plane (|cos a| <= XC_PARALLEL_COS). When both hit different
 *                triangles, the nearer hit is the one the other side missed; with equal t (or overlapping model
 *                intervals), either. Everything is recomputed in binary64 from the scene's vertices and worldToObj.
 *   sliver       an ill-conditioned triangle whose model intervals are wider than the fixed rules: both t within
 *                XC_MODEL_K spreads of the model's t interval about the binary64 crossing, or a hit the other side
 *                missed whose binary64 barycentrics lie within XC_MODEL_K spreads of the model's u, v or u + v
 *                interval from an edge. Embree's arithmetic is not §6's, but its rounding is of the same order.
 *   unexplained  anything else: a bug in one of the two tracers, or a case the classes above do not cover.
 * tie, coplanar, crossing, surface-start, grazing and sliver explain a disagreement by the triangles the records
 * name, so each such record must first be one its triangle can give: the ray meets the triangle's plane at the
 * record's t (within the t tolerance, the t-rounding bound, or XC_MODEL_K spreads of the model's interval where the
 * model says the triangle may be hit) at a point inside the triangle or within the grazing distance of it (rays
 * within XC_PARALLEL_COS of the plane pass). A record naming a wrong triangle is therefore never explained away. */
#ifndef RTO_TRACE_CROSSCHECK_H
#define RTO_TRACE_CROSSCHECK_H

#include "../core/tolerance.h"
#include "conform.h"
#include "rtoracle.h"

#include <stddef.h>
#include <stdint.h>

/* Tolerances (docs/trace.md). t: |dt| <= XC_T_REL max(1, |t|), DESIGN.md §9's t rule (rto__tol_t,
 * core/tolerance.h). */
#define XC_T_REL RTO__TOL_T_REL
#define XC_SHARED_REL 1e-6   /* shared vertex: |dx| <= XC_SHARED_REL max(1, |x|) per world coordinate */
#define XC_PLANE_REL 1e-6    /* coplanar: distance to the other plane <= XC_PLANE_REL max(1, largest coordinate) */
#define XC_EDGE_REL 1e-5     /* grazing: distance to an edge <= XC_EDGE_REL S / |cos a| (relative to S) */
#define XC_PARALLEL_COS 1e-4 /* grazing: the ray nearly parallel to the triangle's plane */
#define XC_MODEL_K 4.0       /* sliver: another binary32 evaluation lies within this many times the model's spread */

typedef enum xc_class {
    XC_AGREE = 0,
    XC_TIE = 1,
    XC_COPLANAR = 2,
    XC_CROSSING = 3,
    XC_T_ROUNDING = 4,
    XC_ROBUST_ONLY = 5,
    XC_SURFACE_START = 6,
    XC_GRAZING = 7,
    XC_SLIVER = 8,
    XC_UNEXPLAINED = 9
} xc_class;
#define XC_CLASS_COUNT 10

/** "agree", "tie", "coplanar", "crossing", "t-rounding", "robust-only", "grazing", "unexplained". */
const char *xc_class_name(xc_class c);

/** One ray's records. */
typedef struct xc_input {
    const rto_scene *scene;
    const rto_wf_ray *ray;
    const rto_hit_record *oracle;
    const rto_hit_record *embree; /* the Embree mode compared against (emb_trace) */
    /* For a TERMINATE_ON_FIRST_HIT ray Embree names no triangle (rtcOccluded1): its closest hit of the same ray
     * (emb_trace_closest), so a disagreement can be classified; NULL otherwise. */
    const rto_hit_record *embree_closest;
    /* Comparing against Embree default: the robust mirror's record of the ray (NULL when not traced). */
    const rto_hit_record *robust;
    const char *other; /* how `why` names the other tracer: NULL means "Embree" */
    /* The scene as the conformance model reads it (cf_scene_init): the model's classes need it; NULL skips them. */
    const cf_scene *model;
} xc_input;

typedef struct xc_result {
    xc_class cls;
    double rel_dt;   /* both hit the same primitive: |dt| / max(1, |t_oracle|); else 0 */
    double edge_rel; /* grazing: xc_edge_distance of the grazing hit (0 for a parallel ray); t-rounding:
                      * xc_t_rounding */
    char why[240];   /* one line saying why the class fits (empty for agree) */
} xc_result;

/** Compares one ray and classifies a disagreement. */
void xc_classify(const xc_input *in, xc_result *out);

/** Whether two records agree (the agreement rule above, without classification); *rel_dt as in xc_result. */
int xc_agree(const rto_wf_ray *ray, const rto_hit_record *a, const rto_hit_record *b, double *rel_dt);

/** How close a ray passes to the boundary of a triangle of an instance, in binary64 (the grazing rule): returns
 * the distance of its hit point on the triangle's plane to the nearest edge line (or, outside, beyond the farthest
 * edge line) times |cos a| / S, so grazing is a result <= XC_EDGE_REL; sets *parallel (and returns 0) when |cos a|
 * <= XC_PARALLEL_COS, the triangle is degenerate or the direction zero. */
double xc_edge_distance(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, int *parallel);

/** The grazing class of one hit record: whether it is one its triangle can give (see above) and lies within the
 * grazing distance of the triangle's boundary or on a ray nearly parallel to its plane; *rel as xc_edge_distance
 * (0 for a parallel ray). strict: a record on a nearly parallel ray must be one its triangle can give too (its t at
 * the binary64 plane crossing within the t or t-rounding bound, the crossing within the grazing distance of the
 * triangle), so only a ray exactly parallel to the plane fails it; check-hits asks this of a GPU's claimed hit. */
int xc_grazing_hit(const rto_scene *scene, const rto_wf_ray *ray, const rto_hit_record *h, int strict, double *rel);

/** Where a ray meets the plane of a triangle of an instance, in binary64: t and the barycentrics (u, v) of that
 * point. Returns 0 (and leaves them alone) for a ray parallel to the plane, a degenerate triangle or a zero
 * direction. */
int xc_plane_hit(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double *t, double *u,
                 double *v);

/** The t-rounding measure of a t difference dt on one triangle: |dt| |d'| |cos a| / S (object space, binary64); 0 for
 * a ray parallel to the plane, a degenerate triangle or a zero direction. */
double xc_t_rounding(const rto_scene *scene, uint32_t inst, uint32_t prim, const rto_wf_ray *ray, double dt);

#endif
