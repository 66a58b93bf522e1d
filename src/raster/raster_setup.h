/* The rasterizer's triangle setup (raster_setup.c), shared by the visibility pass (raster.c) and its evaluations
 * (rto__raster_eval): one triangle's admissible choices of §11.3 and the coverage, depth and attribute rules of
 * §11.2 and §11.4 on them. Private to src/raster/. */
#ifndef RTO_RASTER_SETUP_H
#define RTO_RASTER_SETUP_H

#include "internal.h"
#include "raster_internal.h"

#pragma GCC visibility push(hidden)

/* Window positions are snapped on the p = 8 grid (`RS_SUB` units a pixel): a position snapped at any p = 4..8 and
 * every standard sample position (1x and 4x, in eighths of a pixel) lie on it, so every choice's edge function is an
 * exact 64-bit integer at every sample. */
#define RS_SUB 256
#define RS_P_REF 8
#define RS_P_MIN 4
/* Each coordinate lies within 2^-12 px of a rounding midpoint at one precision at most (the midpoints of p lie on
 * the grid of p + 1, 2^-9 px or more from those of any other p), so at most 2^6 choices at one p and one at each of
 * the four others. */
#define RS_MAX_CHOICES 68
/* §11.3: a coordinate within 2^-12 px of a midpoint is snapped both ways; a homogeneous triangle's band. */
#define RS_EPS_MID 0x1p-12
#define RS_HBAND 0x1p-4
/* A snapped position moves at most 2^-5 + 2^-12 px from the unsnapped one (p = 4); bounding boxes use 2^-4. */
#define RS_SNAP_REACH 0x1p-4
/* Binary32 widening of the intervals (§11.6): barycentrics by 4 binary32 ulps of max(1, |b|) (2^-21 max(1, |b|)),
 * derivatives by twice that of their larger term (2^-20 max(1, |B|)), depth by 4 ulps of values just below 1
 * (2^-22), where a GPU's interpolated depth lives. */
#define RS_WIDEN_B 0x1p-21
#define RS_WIDEN_D 0x1p-20
#define RS_WIDEN_Z 0x1p-22

enum { RS_NONE = 0, RS_SNAP = 1, RS_HOMOG = 2 };
/* classify's answer bits: the reference covers, some choice does, every choice does; and RS_PCOV(p), p = 4..8: every
 * choice at precision p covers (a homogeneous triangle: where it certainly covers). A GPU's precision is global, so
 * a sample whose bits, ORed over the triangles that draw there, hold every p is covered whatever the precision
 * (§11.3's background rule), though no one triangle may cover it at every precision (a shared edge). */
enum { RS_REF = 1, RS_POSSIBLE = 2, RS_CERTAIN = 4 };
#define RS_PCOV_SHIFT 8
#define RS_PCOV(p) (1 << (RS_PCOV_SHIFT + (p) - RS_P_MIN))
#define RS_PCOV_ALL (((1 << (RS_P_REF - RS_P_MIN + 1)) - 1) << RS_PCOV_SHIFT)

/** One snapped triangle: a choice of §11.3 (the reference is p = 8, each coordinate rounded to nearest even). */
typedef struct rs_choice {
    int64_t vx[3], vy[3]; /* RS_SUB units */
    int64_t area;         /* twice the signed area (RS_SUB units squared); 0 covers nothing */
    int64_t ea[3], eb[3], ec[3]; /* edge e, opposite vertex e: E_e(X, Y) = ea X + eb Y + ec; lambda_e = E_e / area */
    int64_t bias[3];      /* inside: sgn E_e >= bias_e (0 on a top or left edge, 1 otherwise) */
    int sgn;              /* sign of area */
    int p;                /* its precision (the highest that gives it) */
    int pmask;            /* RS_PCOV(p) of every precision that gives it */
} rs_choice;

/** One triangle, set up. */
typedef struct rs_tri {
    int kind; /* RS_NONE (nothing to draw), RS_SNAP, RS_HOMOG */
    uint32_t instance, prim;
    float world[3][3];
    float clip[3][4];
    double z[3], w[3]; /* z_ndc and clip w of the vertices (binary64 of binary32) */
    double xw[3], yw[3];
    /* RS_SNAP */
    int n;      /* choices; ch[0] is the reference */
    int anchor; /* the first choice of nonzero area (-1: none, the triangle covers nothing) */
    int uniform; /* every choice of nonzero area with the anchor's orientation (the fast paths apply) */
    int64_t margin[3]; /* |E_e(choice) - E_e(anchor)| over the region, every choice (uniform triangles) */
    double dz;         /* |z(choice) - z(anchor)| over the region, every choice, plus binary64 error */
    int hull_n;        /* the convex hull of every choice's vertices (non-uniform triangles) */
    int64_t ha[12], hb[12], hc[12]; /* inside the hull: ha X + hb Y + hc >= 0 for every edge */
    rs_choice ch[RS_MAX_CHOICES];
    /* RS_HOMOG: linear functions a px + b py + c of the pixel position: beta_0..2, z_ndc, 1 - z_ndc */
    double f[5][3];
    double g[5];    /* their gradients' lengths */
    double fs[3];   /* sum of the betas */
} rs_tri;

/** Pixel bounds of what a triangle may cover (inclusive; x0 > x1 when nothing). */
typedef struct rs_box {
    int32_t x0, y0, x1, y1;
} rs_box;

/** The raster's geometry: transformed vertices (binary32 world and clip positions) of every instance. */
struct rto_raster {
    uint64_t id; /* unique per raster made in this process: the key of rto__raster_eval's per-thread setup cache */
    uint32_t width, height, samples;
    float vp[16];
    uint32_t instance_count, mesh_count, tri_count;
    uint32_t *tri_base;  /* instance_count + 1: instance i's triangles are [tri_base[i], tri_base[i + 1]) */
    uint64_t *vtx_base;  /* instance_count + 1: its transformed vertices */
    uint32_t *inst_mesh; /* instance_count */
    uint64_t *idx_base;  /* mesh_count: first index of each mesh in indices */
    uint32_t *indices;
    float *world;        /* 3 per transformed vertex */
    float *clip;         /* 4 per transformed vertex */
};

/** The instance of triangle t (binary search of tri_base). */
uint32_t rto__rs_instance_of(const rto_raster *r, uint32_t t);
/** Sets up triangle t of instance `instance`: kind, vertices, choices. With full = 0 only the reference (ch[0]) and
 * the homogeneous functions; with full = 1 every choice and, over the pixel region box when non-NULL, what
 * rto__rs_classify and rto__rs_depth_coarse need (fast-path margins, hull, depth margin). */
void rto__rs_setup(const rto_raster *r, uint32_t instance, uint32_t t, int full, const rs_box *region, rs_tri *tri);
/** The pixel bounds of triangle t (conservative over every choice; clamped to the image) and its kind. */
int rto__rs_bounds(const rto_raster *r, uint32_t instance, uint32_t t, rs_box *box);
/** RS_REF | RS_POSSIBLE | RS_CERTAIN | RS_PCOV(p) bits at sample position (X, Y) (RS_SUB units), of a full setup. */
int rto__rs_classify(const rs_tri *t, int64_t X, int64_t Y);
/** Depth of the reference at (X, Y): in [0, 1], binary64 (ch[0] or the homogeneous functions). */
double rto__rs_ref_depth(const rs_tri *t, int64_t X, int64_t Y);
/** A conservative (coarse) depth interval at (X, Y), widened, within [0, 1]. */
void rto__rs_depth_coarse(const rs_tri *t, int64_t X, int64_t Y, double *lo, double *hi);
/** The depth interval over every choice at (X, Y), widened, within [0, 1]. */
void rto__rs_depth_exact(const rs_tri *t, int64_t X, int64_t Y, double *lo, double *hi);
/** The reference's attributes of pixel (x, y) at sample position (X, Y), binary64: b1, b2, ddx b1, ddx b2, ddy b1,
 * ddy b2, depth. Returns 0 when there is no reference (zero area at p = 8). */
int rto__rs_ref_attr(const rs_tri *t, uint32_t x, uint32_t y, int64_t X, int64_t Y, double a[7]);
/** The binary32 face normal (§11.4) of the triangle's world positions; (0, 0, 0) when degenerate. */
void rto__rs_normal(const rs_tri *t, float n[3]);

#pragma GCC visibility pop

#endif
