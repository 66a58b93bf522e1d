/* check-vbuffer (DESIGN.md §11.6) against a simulated GPU written here from §11.1-11.5 alone: a brute-force rasterizer
 * (every sample against every triangle, long double on positions snapped to its own sub-pixel precision, its own
 * top-left rule from the edge functions' gradients), perspective-correct barycentrics at the pixel centre, quad
 * derivatives on the triangle's plane, its own binary16 conversion, the classifier and the `normals` material. It
 * shares no code with src/raster beyond the scene and the camera it is given. Controls pass (1x and 4x, a strongly
 * tilted quad, 4-bit sub-pixel precision, depth stored as unorm24); each planted fault fails with its class, at the
 * sample where it starts. */
#include "testutil.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------------------------------ */
/* The simulated GPU                                                                                                    */

typedef struct sim_opts {
    int bits;              /* sub-pixel precision; 0: 8 */
    int top_left_inverted; /* samples exactly on an edge covered by bottom and right edges instead */
    int rotate_samples;    /* sample s at position (s + 1) mod 4 */
    int affine;            /* screen-space barycentrics, no perspective division */
    int oct_sign;          /* octahedral fold with the sign of the other component */
    int unorm24;           /* depth stored (and tested) as unorm24 */
    int depth_step_up;     /* unorm24, one step up */
    int rtz;               /* binary16 rounded toward zero */
    float normal_threshold; /* the classifier's; 0: 0.95 */
    int shade_sample0;     /* edge pixels shaded once, from sample 0 */
    int instance_hi;       /* visibility word 3 (instance, high 16 bits) set to 1 */
    int ddx_sign;          /* ddx negated */
} sim_opts;

typedef struct sim_gpu {
    rto_vbuffer_planes p;
    uint8_t *mask;
    uint16_t *image;
} sim_gpu;

/* binary16 from binary32, nearest even or toward zero, on the binary64 number line. */
static uint16_t sim_f16(float f, int rtz)
{
    if (isnan(f))
        return 0x7e00;
    const uint16_t sign = signbit(f) ? 0x8000 : 0;
    const double a = fabs((double)f);
    if (isinf(f))
        return (uint16_t)(sign | 0x7c00);
    double m;
    uint32_t bits;
    if (a < 0x1p-14) {
        m = rtz ? floor(a * 0x1p24) : nearbyint(a * 0x1p24); /* subnormal steps of 2^-24 */
        bits = (uint32_t)m;
    } else {
        int e;
        frexp(a, &e); /* a in [2^(e-1), 2^e) */
        const double ulp = ldexp(1.0, e - 11);
        m = rtz ? floor(a / ulp) : nearbyint(a / ulp); /* 1024 .. 2048 */
        bits = (uint32_t)(e - 1 + 15) * 1024u + (uint32_t)m - 1024u;
    }
    if (bits >= 0x7c00u)
        bits = rtz ? 0x7bffu : 0x7c00u;
    return (uint16_t)(sign | bits);
}

static double sim_f16_value(uint16_t h)
{
    const int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(1024 + m, e - 25);
    return (h & 0x8000) ? -v : v;
}

static long double sign_not_zero(long double v) { return v >= 0 ? 1.0L : -1.0L; }

static void sim_oct_encode(const long double n[3], int sign_error, long double out[2])
{
    const long double l1 = fabsl(n[0]) + fabsl(n[1]) + fabsl(n[2]);
    long double px = n[0] / l1, py = n[1] / l1;
    if (n[2] < 0) {
        const long double sx = sign_error ? sign_not_zero(py) : sign_not_zero(px);
        const long double sy = sign_error ? sign_not_zero(px) : sign_not_zero(py);
        const long double ox = (1 - fabsl(py)) * sx, oy = (1 - fabsl(px)) * sy;
        px = ox;
        py = oy;
    }
    out[0] = px;
    out[1] = py;
}

static void sim_oct_decode(double ex, double ey, long double n[3])
{
    long double x = ex, y = ey, z = 1 - fabsl(x) - fabsl(y);
    if (z < 0) {
        const long double ox = (1 - fabsl(y)) * sign_not_zero(x), oy = (1 - fabsl(x)) * sign_not_zero(y);
        x = ox;
        y = oy;
    }
    const long double l = sqrtl(x * x + y * y + z * z);
    n[0] = x / l;
    n[1] = y / l;
    n[2] = z / l;
}

/* WebGPU's standard sample positions, 1x and 4x. */
static void sim_sample(uint32_t samples, uint32_t s, long double *sx, long double *sy)
{
    static const long double four[4][2] = {{0.375L, 0.125L}, {0.875L, 0.375L}, {0.125L, 0.625L}, {0.625L, 0.875L}};
    if (samples == 1) {
        *sx = *sy = 0.5L;
        return;
    }
    *sx = four[s][0];
    *sy = four[s][1];
}

/* One triangle after setup: snapped window positions (integers in 2^-bits pixel), 1/w, z_ndc, the world normal. */
typedef struct sim_tri {
    int64_t X[3], Y[3];
    long double x[3], y[3]; /* the snapped positions in pixels */
    long double inv_w[3], z[3];
    long double n[3];
    int64_t area2;
} sim_tri;

/* E_ab(P) over integer coordinates: (b - a) x (P - a). */
static int64_t edge_i(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py)
{
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

static long double edge_f(long double ax, long double ay, long double bx, long double by, long double px,
                          long double py)
{
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

/* Screen-space weights at (px, py) in pixels. */
static void sim_weights(const sim_tri *t, long double px, long double py, long double l[3])
{
    const long double a = edge_f(t->x[0], t->y[0], t->x[1], t->y[1], t->x[2], t->y[2]);
    l[0] = edge_f(t->x[1], t->y[1], t->x[2], t->y[2], px, py) / a;
    l[1] = edge_f(t->x[2], t->y[2], t->x[0], t->y[0], px, py) / a;
    l[2] = edge_f(t->x[0], t->y[0], t->x[1], t->y[1], px, py) / a;
}

/* (b1, b2) at (px, py): perspective-correct, or the screen-space weights. */
static void sim_bary(const sim_tri *t, int affine, long double px, long double py, long double b[2])
{
    long double l[3];
    sim_weights(t, px, py, l);
    if (affine) {
        b[0] = l[1];
        b[1] = l[2];
        return;
    }
    const long double q0 = l[0] * t->inv_w[0], q1 = l[1] * t->inv_w[1], q2 = l[2] * t->inv_w[2];
    const long double s = q0 + q1 + q2;
    b[0] = q1 / s;
    b[1] = q2 / s;
}

/* Whether the sample at integer position (px, py) is covered: the edge functions of the triangle in positive order,
 * a sample exactly on an edge covered when the interior lies below a horizontal edge (top) or to the +x side of it
 * (left), from the edge function's gradient (-(by - ay), bx - ax); the inverse of that when inverted. */
static int sim_covers(const sim_tri *t, int64_t px, int64_t py, int inverted)
{
    int o[3] = {0, 1, 2};
    if (t->area2 < 0) {
        o[1] = 2;
        o[2] = 1;
    }
    for (int i = 0; i < 3; i++) {
        const int a = o[i], b = o[(i + 1) % 3];
        const int64_t e = edge_i(t->X[a], t->Y[a], t->X[b], t->Y[b], px, py);
        if (e < 0)
            return 0;
        if (e == 0) {
            const int64_t gx = -(t->Y[b] - t->Y[a]), gy = t->X[b] - t->X[a];
            const int top_left = (gx == 0 && gy > 0) || gx > 0;
            if (top_left == inverted)
                return 0;
        }
    }
    return 1;
}

static void sim_free(sim_gpu *g)
{
    free(g->p.visibility);
    free(g->p.barycentric);
    free(g->p.normal);
    free(g->p.derivatives);
    free(g->p.depth);
    free(g->p.depth_unorm24);
    free(g->mask);
    free(g->image);
    memset(g, 0, sizeof *g);
}

static long double sim_view_depth(const rto_vbuffer_camera *cam, uint32_t W, uint32_t H, uint32_t x, uint32_t y,
                                  double d)
{
    const long double v[4] = {((long double)x + 0.5L) / W * 2 - 1, 1 - ((long double)y + 0.5L) / H * 2, d, 1};
    long double z = 0, w = 0;
    for (int c = 0; c < 4; c++) {
        z += (long double)cam->inverse_projection[4 * c + 2] * v[c];
        w += (long double)cam->inverse_projection[4 * c + 3] * v[c];
    }
    return z / w;
}

static int sim_is_bg(const uint16_t *v) { return v[0] == 0xFFFF && v[1] == 0xFFFF && v[2] == 0xFFFF && v[3] == 0xFFFF; }

static void sim_normal_of(const sim_gpu *g, size_t k, long double n[3])
{
    sim_oct_decode(sim_f16_value(g->p.normal[4 * k]), sim_f16_value(g->p.normal[4 * k + 1]), n);
}

/* The classifier of §11.5 on the simulated GPU's own planes. */
static void sim_classify(sim_gpu *g, const rto_vbuffer_camera *cam, float t_normal)
{
    const uint32_t W = g->p.width, H = g->p.height, S = g->p.samples;
    const long double t_depth = 0.02L, t_sample = 0.02L;
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            const size_t k0 = ((size_t)y * W + x) * S;
            const uint16_t *vis = g->p.visibility;
            int c0 = !sim_is_bg(&vis[4 * k0]), count = 0, instances = 0;
            long double vmin = 0, vmax = 0;
            for (uint32_t s = 0; s < S; s++) {
                const size_t k = k0 + s;
                if (sim_is_bg(&vis[4 * k]))
                    continue;
                const long double vd = sim_view_depth(cam, W, H, x, y, g->p.depth[k]);
                if (count == 0) {
                    vmin = vmax = vd;
                } else {
                    vmin = vd < vmin ? vd : vmin;
                    vmax = vd > vmax ? vd : vmax;
                }
                if (vis[4 * k + 2] != vis[4 * k0 + 2] || vis[4 * k + 3] != vis[4 * k0 + 3])
                    instances = 1;
                count++;
            }
            int edge = (!c0 && count > 0) || (c0 && instances) ||
                       (count >= 2 && vmax - vmin > t_sample * fabsl(0.5L * (vmin + vmax)));
            if (c0) {
                long double n0[3];
                sim_normal_of(g, k0, n0);
                const long double vd0 = sim_view_depth(cam, W, H, x, y, g->p.depth[k0]);
                const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
                for (int i = 0; i < 4; i++) {
                    const long nx = (long)x + dx[i], ny = (long)y + dy[i];
                    if (nx < 0 || ny < 0 || nx >= (long)W || ny >= (long)H)
                        continue;
                    const size_t kb = ((size_t)ny * W + (size_t)nx) * S;
                    if (sim_is_bg(&vis[4 * kb])) {
                        edge = 1;
                        continue;
                    }
                    long double nb[3];
                    sim_normal_of(g, kb, nb);
                    const long double dot = n0[0] * nb[0] + n0[1] * nb[1] + n0[2] * nb[2];
                    const long double vdb = sim_view_depth(cam, W, H, (uint32_t)nx, (uint32_t)ny, g->p.depth[kb]);
                    if (dot < (long double)t_normal || fabsl(vd0 - vdb) > t_depth * fabsl(vd0))
                        edge = 1;
                }
            }
            g->mask[(size_t)y * W + x] = (uint8_t)edge;
        }
}

/* The `normals` material: interior pixels from sample 0, edge pixels averaged over their samples. */
static void sim_shade(sim_gpu *g, int sample0_only)
{
    const uint32_t W = g->p.width, H = g->p.height, S = g->p.samples;
    for (size_t px = 0; px < (size_t)W * H; px++) {
        const uint32_t n = g->mask[px] && !sample0_only ? S : 1;
        long double c[4] = {0, 0, 0, 0};
        for (uint32_t s = 0; s < n; s++) {
            const size_t k = px * S + s;
            if (sim_is_bg(&g->p.visibility[4 * k]))
                continue;
            long double nv[3];
            sim_normal_of(g, k, nv);
            for (int a = 0; a < 3; a++)
                c[a] += nv[a] * 0.5L + 0.5L;
            c[3] += 1;
        }
        for (int a = 0; a < 4; a++)
            g->image[4 * px + (size_t)a] = sim_f16((float)(c[a] / n), 0);
    }
}

/* Renders geometry through cam into a width x height x samples G-buffer, mask and image. */
static void sim_render(const rto_vbuffer_geometry *geo, const rto_vbuffer_camera *cam, uint32_t W, uint32_t H,
                       uint32_t S, const sim_opts *o, sim_gpu *g)
{
    memset(g, 0, sizeof *g);
    const size_t N = (size_t)W * H * S;
    g->p.width = W;
    g->p.height = H;
    g->p.samples = S;
    g->p.visibility = malloc(N * 4 * sizeof(uint16_t));
    g->p.barycentric = calloc(N * 2, sizeof(uint16_t));
    g->p.normal = calloc(N * 4, sizeof(uint16_t));
    g->p.derivatives = calloc(N * 4, sizeof(uint16_t));
    g->p.depth = malloc(N * sizeof(float));
    if (o->unorm24)
        g->p.depth_unorm24 = malloc(N * sizeof(uint32_t));
    g->mask = malloc((size_t)W * H);
    g->image = malloc((size_t)W * H * 4 * sizeof(uint16_t));
    assert_non_null(g->p.visibility);
    assert_non_null(g->p.depth);
    memset(g->p.visibility, 0xFF, N * 4 * sizeof(uint16_t));
    for (size_t k = 0; k < N; k++) {
        g->p.depth[k] = 1.0f;
        if (g->p.depth_unorm24)
            g->p.depth_unorm24[k] = 16777215u;
    }
    const int bits = o->bits ? o->bits : 8;
    const long double scale = ldexpl(1.0L, bits);
    const double M = 16777215.0;
    for (uint32_t inst = 0; inst < geo->instance_count; inst++) {
        const rto_instance *in = &geo->instances[inst];
        const rto_mesh *m = &geo->meshes[in->blas];
        for (uint32_t prim = 0; prim < m->triangle_count; prim++) {
            sim_tri t;
            float wp[3][3];
            for (int v = 0; v < 3; v++) {
                const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)prim + (size_t)v]];
                for (int r = 0; r < 3; r++)
                    wp[v][r] = ((in->obj_to_world.m[r][0] * p[0] + in->obj_to_world.m[r][1] * p[1]) +
                                in->obj_to_world.m[r][2] * p[2]) + in->obj_to_world.m[r][3];
                float clip[4];
                for (int r = 0; r < 4; r++)
                    clip[r] = ((cam->view_proj[r] * wp[v][0] + cam->view_proj[4 + r] * wp[v][1]) +
                               cam->view_proj[8 + r] * wp[v][2]) + cam->view_proj[12 + r];
                if (!(clip[3] > 0 && clip[2] >= 0 && clip[2] <= clip[3]))
                    fail_msg("simulated GPU: instance %u primitive %u is clipped (the simulation does not clip)", inst,
                             prim);
                const long double xw = ((long double)clip[0] / clip[3] * 0.5L + 0.5L) * W;
                const long double yw = (0.5L - (long double)clip[1] / clip[3] * 0.5L) * H;
                t.X[v] = llroundl(xw * scale);
                t.Y[v] = llroundl(yw * scale);
                t.x[v] = (long double)t.X[v] / scale;
                t.y[v] = (long double)t.Y[v] / scale;
                t.inv_w[v] = 1.0L / clip[3];
                t.z[v] = (long double)clip[2] / clip[3];
            }
            t.area2 = edge_i(t.X[0], t.Y[0], t.X[1], t.Y[1], t.X[2], t.Y[2]);
            if (t.area2 == 0)
                continue;
            long double e1[3], e2[3];
            for (int r = 0; r < 3; r++) {
                e1[r] = (long double)wp[1][r] - wp[0][r];
                e2[r] = (long double)wp[2][r] - wp[0][r];
            }
            t.n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            t.n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            t.n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            const long double nl = sqrtl(t.n[0] * t.n[0] + t.n[1] * t.n[1] + t.n[2] * t.n[2]);
            for (int r = 0; r < 3; r++)
                t.n[r] /= nl;
            long double enc[2];
            sim_oct_encode(t.n, o->oct_sign, enc);
            for (uint32_t y = 0; y < H; y++)
                for (uint32_t x = 0; x < W; x++) {
                    int shaded = 0;
                    uint16_t bary[2], deriv[4];
                    for (uint32_t s = 0; s < S; s++) {
                        long double sx, sy;
                        sim_sample(S, o->rotate_samples ? (s + 1) % 4 : s, &sx, &sy);
                        const int64_t PX = llroundl(((long double)x + sx) * scale);
                        const int64_t PY = llroundl(((long double)y + sy) * scale);
                        if (!sim_covers(&t, PX, PY, o->top_left_inverted))
                            continue;
                        long double l[3];
                        sim_weights(&t, (long double)x + sx, (long double)y + sy, l);
                        long double z = l[0] * t.z[0] + l[1] * t.z[1] + l[2] * t.z[2];
                        z = z < 0 ? 0 : z > 1 ? 1 : z;
                        const size_t k = ((size_t)y * W + x) * S + s;
                        float depth;
                        uint32_t ku = 0;
                        if (o->unorm24) {
                            ku = (uint32_t)llround((double)z * M) + (o->depth_step_up ? 1u : 0u);
                            if (!(ku < g->p.depth_unorm24[k]))
                                continue;
                            depth = (float)(ku / M);
                        } else {
                            depth = (float)z;
                            if (!(depth < g->p.depth[k]))
                                continue;
                        }
                        if (!shaded) { /* the fragment shader, once per pixel and triangle, at the pixel centre */
                            shaded = 1;
                            long double b[2], bx0[2], bx1[2], by0[2], by1[2];
                            const long double cx = x + 0.5L, cy = y + 0.5L;
                            const long double qx = (x & ~1u) + 0.5L, qy = (y & ~1u) + 0.5L;
                            sim_bary(&t, o->affine, cx, cy, b);
                            sim_bary(&t, o->affine, qx, cy, bx0);
                            sim_bary(&t, o->affine, qx + 1, cy, bx1);
                            sim_bary(&t, o->affine, cx, qy, by0);
                            sim_bary(&t, o->affine, cx, qy + 1, by1);
                            for (int c = 0; c < 2; c++) {
                                bary[c] = sim_f16((float)b[c], o->rtz);
                                const long double ddx = bx1[c] - bx0[c];
                                deriv[c] = sim_f16((float)(o->ddx_sign ? -ddx : ddx), o->rtz);
                                deriv[2 + c] = sim_f16((float)(by1[c] - by0[c]), o->rtz);
                            }
                        }
                        uint16_t *vis = &g->p.visibility[4 * k];
                        vis[0] = (uint16_t)(prim & 0xFFFF);
                        vis[1] = (uint16_t)(prim >> 16);
                        vis[2] = (uint16_t)(inst & 0xFFFF);
                        vis[3] = (uint16_t)(inst >> 16);
                        g->p.barycentric[2 * k] = bary[0];
                        g->p.barycentric[2 * k + 1] = bary[1];
                        g->p.normal[4 * k] = sim_f16((float)enc[0], o->rtz);
                        g->p.normal[4 * k + 1] = sim_f16((float)enc[1], o->rtz);
                        g->p.normal[4 * k + 2] = 0;
                        g->p.normal[4 * k + 3] = 0x3C00;
                        memcpy(&g->p.derivatives[4 * k], deriv, sizeof deriv);
                        g->p.depth[k] = depth;
                        if (g->p.depth_unorm24)
                            g->p.depth_unorm24[k] = ku;
                    }
                }
        }
    }
    sim_classify(g, cam, o->normal_threshold > 0 ? o->normal_threshold : 0.95f);
    sim_shade(g, o->shade_sample0);
    if (o->instance_hi) /* after the material pass, which groups samples by instance: only the dump's word is wrong */
        for (size_t k = 0; k < N; k++)
            if (!sim_is_bg(&g->p.visibility[4 * k]))
                g->p.visibility[4 * k + 3] = 1;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Scenes and the check                                                                                                 */

/* A scene: a loaded one, or one mesh instanced once (tu_scene1); the visibility-pass camera and the oracle. */
typedef struct vscene {
    rto_scene *loaded;
    tu_scene1 one;
    rto_vbuffer_geometry geo;
    rto_vbuffer_camera cam;
    uint32_t width, height, samples;
    rto_vbuffer vb;
} vscene;

static void vscene_oracle(vscene *v)
{
    rto_vbuffer_desc d = {v->width, v->height, v->samples, 0};
    rto_msg msg = {{0}};
    if (rto_vbuffer_make(&v->geo, &v->cam, &d, &v->vb, &msg))
        fail_msg("rto_vbuffer_make: %s", msg.text);
}

static void vscene_camera(vscene *v, const rto_camera *c)
{
    rto_msg msg = {{0}};
    if (rto_vbuffer_camera_make(c, v->width, v->height, &v->cam, &msg))
        fail_msg("rto_vbuffer_camera_make: %s", msg.text);
}

static void vscene_load(vscene *v, const char *spec, uint32_t w, uint32_t h, uint32_t s)
{
    memset(v, 0, sizeof *v);
    v->loaded = tu_load(spec);
    v->geo = (rto_vbuffer_geometry){v->loaded->meshes, v->loaded->mesh_count, v->loaded->instances,
                                    v->loaded->instance_count};
    v->width = w;
    v->height = h;
    v->samples = s;
    const rto_camera c = v->loaded->camera_count ? v->loaded->cameras[0] : rto_camera_default();
    vscene_camera(v, &c);
    vscene_oracle(v);
}

/* One mesh (pos and idx must outlive the scene) through camera c, or through cam when c is NULL. */
static void vscene_mesh(vscene *v, float *pos, uint32_t nv, uint32_t *idx, uint32_t nt, const rto_camera *c,
                        const rto_vbuffer_camera *cam, uint32_t w, uint32_t h, uint32_t s)
{
    memset(v, 0, sizeof *v);
    static const double identity[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    tu_scene1_make(&v->one, pos, nv, idx, nt, identity);
    v->geo = (rto_vbuffer_geometry){&v->one.mesh, 1, &v->one.inst, 1};
    v->width = w;
    v->height = h;
    v->samples = s;
    if (c)
        vscene_camera(v, c);
    else
        v->cam = *cam;
    vscene_oracle(v);
}

static void vscene_free(vscene *v)
{
    rto_vbuffer_free(&v->vb);
    rto_scene_destroy(v->loaded);
    v->loaded = NULL;
}

static rto_vbuffer_check_result check(const vscene *v, const sim_gpu *g, int any_rounding)
{
    rto_vbuffer_material_desc mat;
    memset(&mat, 0, sizeof mat);
    mat.material = RTO_VB_NORMALS;
    const rto_vb_thresholds t = RTO_VB_THRESHOLDS_DEFAULT;
    mat.thresholds = t;
    rto_vbuffer_check_desc d;
    memset(&d, 0, sizeof d);
    d.expected = &v->vb;
    d.geometry = &v->geo;
    d.gpu = &g->p;
    d.gpu_mask = g->mask;
    d.gpu_image = g->image;
    d.material = &mat;
    d.any_f16_rounding = any_rounding;
    rto_vbuffer_check_result r;
    rto_msg msg = {{0}};
    if (rto_vbuffer_check(&d, &r, &msg))
        fail_msg("rto_vbuffer_check: %s", msg.text);
    print_message("    %s: %s at (%u, %u) #%u in %s: %s\n", v->loaded ? v->loaded->source : "mesh",
                  rto_vb_fault_name(r.fault), r.x, r.y, r.sample, r.plane, r.what);
    return r;
}

/* A control: the simulated GPU with options o passes, with every plane, the mask and the image compared. */
static rto_vbuffer_check_result expect_pass(const vscene *v, const sim_opts *o)
{
    sim_gpu g;
    sim_render(&v->geo, &v->cam, v->width, v->height, v->samples, o, &g);
    const rto_vbuffer_check_result r = check(v, &g, 0);
    if (r.fault != RTO_VB_PASS)
        fail_msg("control fails: %s at (%u, %u) #%u in %s: %s", rto_vb_fault_name(r.fault), r.x, r.y, r.sample,
                 r.plane, r.what);
    assert_int_equal(r.planes_checked, 0x7f);
    assert_int_equal(r.compared, (uint64_t)v->width * v->height * v->samples);
    assert_int_equal(r.mask_gpu_only + r.mask_oracle_only, 0);
    sim_free(&g);
    return r;
}

static const sim_opts plain = {0};

static void test_controls(void **state)
{
    (void)state;
    static const char *const specs[] = {"triangle", "rtstress:2"};
    static const uint32_t samples[] = {1, 4};
    for (size_t i = 0; i < 2; i++)
        for (size_t j = 0; j < 2; j++) {
            vscene v;
            vscene_load(&v, specs[i], 64, 48, samples[j]);
            expect_pass(&v, &plain);
            vscene_free(&v);
        }
}

/* A floor quad receding from a low, wide camera: w varies by a factor of ~30 across the image. */
static float quad_pos[] = {-3, 0, 1.5f, 3, 0, 1.5f, 3, 0, -40, -3, 0, -40};
static uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};

static rto_camera quad_camera(void)
{
    rto_camera c = rto_camera_default();
    c.position = (rto_vec3){0.0f, 0.7f, 2.0f};
    c.target = (rto_vec3){0.0f, 0.0f, -4.0f};
    c.fov_y = 1.6f;
    c.zfar = 200.0f;
    return c;
}

static void test_control_tilted_quad(void **state)
{
    (void)state;
    const rto_camera c = quad_camera();
    for (uint32_t s = 1; s <= 4; s += 3) {
        vscene v;
        vscene_mesh(&v, quad_pos, 4, quad_idx, 2, &c, NULL, 48, 40, s);
        expect_pass(&v, &plain);
        vscene_free(&v);
    }
}

static void test_control_4bit_and_unorm24(void **state)
{
    (void)state;
    sim_opts four = {0}, unorm = {0};
    four.bits = 4;
    unorm.unorm24 = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 4);
    assert_true(expect_pass(&v, &four).other_admissible > 0); /* edges the 4-bit device draws otherwise, accepted */
    expect_pass(&v, &unorm);
    vscene_free(&v);
    /* seeded random scenes: slivers, degenerate triangles, mirroring instances */
    vscene_load(&v, "random:3", 80, 60, 4);
    expect_pass(&v, &four);
    expect_pass(&v, &plain);
    vscene_free(&v);
    const rto_camera c = quad_camera();
    vscene_mesh(&v, quad_pos, 4, quad_idx, 2, &c, NULL, 48, 40, 4);
    expect_pass(&v, &four);
    expect_pass(&v, &unorm);
    vscene_free(&v);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Planted faults                                                                                                       */

/* The first sample where plane a and b differ in any of `words` words (16 bits). */
static size_t first_diff16(const uint16_t *a, const uint16_t *b, size_t n, int words)
{
    for (size_t k = 0; k < n; k++)
        if (memcmp(&a[(size_t)words * k], &b[(size_t)words * k], (size_t)words * sizeof *a))
            return k;
    return SIZE_MAX;
}

static size_t result_k(const vscene *v, const rto_vbuffer_check_result *r)
{
    return ((size_t)r->y * v->width + r->x) * v->samples + r->sample;
}

/* Renders the fault, checks it is reported with class f in plane, and returns the report; *clean is the unfaulted
 * simulation of the same scene. */
static rto_vbuffer_check_result expect_fault(const vscene *v, const sim_opts *o, rto_vb_fault f, const char *plane,
                                             sim_gpu *clean, sim_gpu *bad)
{
    sim_render(&v->geo, &v->cam, v->width, v->height, v->samples, &plain, clean);
    sim_render(&v->geo, &v->cam, v->width, v->height, v->samples, o, bad);
    const rto_vbuffer_check_result r = check(v, bad, 0);
    if (r.fault != f || strcmp(r.plane, plane))
        fail_msg("expected %s in %s, got %s in %s at (%u, %u) #%u: %s", rto_vb_fault_name(f), plane,
                 rto_vb_fault_name(r.fault), r.plane, r.x, r.y, r.sample, r.what);
    assert_true(strlen(r.what) > 20);
    return r;
}

/* A 32 x 32 image whose clip space is window space: x_w = X, y_w = Y, z = Z, w = 1 (every product exact), and a
 * rectangle of two triangles from (4, 4) + o to (20, 12) + o, o a sample's offset within the pixel (the pixel centre
 * at 1x, sample 0 at 4x), so that samples lie exactly on its top and left edges and on its diagonal (slope 1/2) at
 * every sub-pixel precision. The positions live in pos (12 floats), which must outlive the scene. */
static void grid_rect(float pos[12], float ox, float oy)
{
    const float p[12] = {4 + ox, 4 + oy, 0.5f, 20 + ox, 4 + oy, 0.5f, 20 + ox, 12 + oy, 0.5f, 4 + ox, 12 + oy, 0.5f};
    memcpy(pos, p, sizeof p);
}
static float grid_pos1[12], grid_pos4[12];
static uint32_t grid_idx[] = {0, 1, 2, 0, 2, 3};

static rto_vbuffer_camera grid_camera(void)
{
    rto_vbuffer_camera c;
    memset(&c, 0, sizeof c);
    /* column-major: x_clip = X / 16 - 1, y_clip = 1 - Y / 16, z_clip = Z, w = 1 */
    c.view_proj[0] = 1.0f / 16;
    c.view_proj[5] = -1.0f / 16;
    c.view_proj[10] = 1.0f;
    c.view_proj[12] = -1.0f;
    c.view_proj[13] = 1.0f;
    c.view_proj[15] = 1.0f;
    for (int i = 0; i < 4; i++)
        c.inverse_projection[5 * i] = 1.0f; /* view depth = depth */
    return c;
}

static void test_fault_top_left(void **state)
{
    (void)state;
    const rto_vbuffer_camera cam = grid_camera();
    grid_rect(grid_pos1, 0.5f, 0.5f);
    grid_rect(grid_pos4, 0.375f, 0.125f);
    for (uint32_t s = 1; s <= 4; s += 3) {
        vscene v;
        vscene_mesh(&v, s == 1 ? grid_pos1 : grid_pos4, 4, grid_idx, 2, NULL, &cam, 32, 32, s);
        if (s == 1)
            expect_pass(&v, &plain);
        sim_opts o = {0};
        o.top_left_inverted = 1;
        sim_gpu clean, bad;
        const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_COVERAGE, "visibility", &clean, &bad);
        const size_t k = first_diff16(clean.p.visibility, bad.p.visibility, (size_t)32 * 32 * s, 4);
        assert_int_equal(result_k(&v, &r), k);
        /* the rectangle's top-left corner, sample 0 of pixel (4, 4): on a top and a left edge, no longer covered */
        assert_int_equal(r.x, 4);
        assert_int_equal(r.y, 4);
        assert_int_equal(r.sample, 0);
        sim_free(&clean);
        sim_free(&bad);
        vscene_free(&v);
    }
}

static void test_fault_sample_pattern(void **state)
{
    (void)state;
    const rto_vbuffer_camera cam = grid_camera();
    grid_rect(grid_pos1, 0.5f, 0.5f);
    vscene v;
    vscene_mesh(&v, grid_pos1, 4, grid_idx, 2, NULL, &cam, 32, 32, 4);
    sim_opts o = {0};
    o.rotate_samples = 1;
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_COVERAGE, "visibility", &clean, &bad);
    assert_int_equal(result_k(&v, &r), first_diff16(clean.p.visibility, bad.p.visibility, (size_t)32 * 32 * 4, 4));
    /* pixel (4, 4): sample 2 at (4.125, 4.625) is left of the rectangle, but takes sample 3's position inside it */
    assert_int_equal(r.x, 4);
    assert_int_equal(r.y, 4);
    assert_int_equal(r.sample, 2);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

/* A fault in the values of a plane (words per sample): the reported sample holds another value than the unfaulted
 * simulation's, and none before it differs by more than `slack` binary16 ulps (the check may let small departures
 * pass, not skip large ones). */
static void assert_starts(const vscene *v, const rto_vbuffer_check_result *r, const uint16_t *clean,
                          const uint16_t *bad, int words, double slack)
{
    const size_t k = result_k(v, r);
    assert_true(memcmp(&clean[(size_t)words * k], &bad[(size_t)words * k], (size_t)words * sizeof *clean) != 0);
    for (size_t j = 0; j < k; j++)
        for (int c = 0; c < words; c++) {
            const double a = sim_f16_value(clean[(size_t)words * j + (size_t)c]);
            const double b = sim_f16_value(bad[(size_t)words * j + (size_t)c]);
            const double ulp = fabs(a) < 0x1p-14 ? 0x1p-24 : ldexp(1.0, ilogb(a) - 10);
            if (fabs(a - b) > slack * ulp)
                fail_msg("sample %zu channel %d differs by %g ulps before the reported sample %zu", j, c,
                         fabs(a - b) / ulp, k);
        }
}

static void test_fault_affine(void **state)
{
    (void)state;
    const rto_camera c = quad_camera();
    vscene v;
    vscene_mesh(&v, quad_pos, 4, quad_idx, 2, &c, NULL, 48, 40, 1);
    sim_opts o = {0};
    o.affine = 1;
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_BARYCENTRIC, "barycentric", &clean, &bad);
    assert_starts(&v, &r, clean.p.barycentric, bad.p.barycentric, 2, 8.0);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

/* One triangle facing away from the camera, its world normal (0.30, -0.15, -0.94): the octahedral fold of n.z < 0
 * with p.y < 0 < p.x, where taking each component's sign from the other is wrong in both. */
static float back_pos[] = {-1.0f, -0.8f, 0.1f, 0.2f, 1.0f, 0.2f, 1.0f, -0.6f, 0.7f};
static uint32_t back_idx[] = {0, 1, 2};

static void test_fault_octahedral_sign(void **state)
{
    (void)state;
    const rto_camera c = rto_camera_default();
    vscene v;
    vscene_mesh(&v, back_pos, 3, back_idx, 1, &c, NULL, 40, 32, 1);
    sim_opts o = {0};
    o.oct_sign = 1;
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_NORMAL, "normal", &clean, &bad);
    assert_int_equal(result_k(&v, &r), first_diff16(clean.p.normal, bad.p.normal, (size_t)40 * 32, 4));
    const size_t k = result_k(&v, &r);
    assert_true(sim_f16_value(clean.p.normal[4 * k]) > 0.5); /* the fold: (1 - |p.y|, -(1 - |p.x|)) */
    assert_true(sim_f16_value(clean.p.normal[4 * k + 1]) < -0.5);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_depth_step(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.unorm24 = 1;
    o.depth_step_up = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 4);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_DEPTH, "depth", &clean, &bad);
    const size_t k = result_k(&v, &r);
    assert_false(sim_is_bg(&bad.p.visibility[4 * k]));
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_f16_rtz(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.rtz = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 1);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_F16_ROUNDING, "barycentric", &clean, &bad);
    const size_t k = result_k(&v, &r);
    assert_true(memcmp(&clean.p.barycentric[2 * k], &bad.p.barycentric[2 * k], 4) != 0);
    assert_non_null(strstr(r.what, "toward zero"));
    /* a device documented to truncate passes */
    const rto_vbuffer_check_result ok = check(&v, &bad, 1);
    assert_int_equal(ok.fault, RTO_VB_PASS);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_threshold(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.normal_threshold = 0.9f;
    vscene v;
    vscene_load(&v, "sphere:1", 64, 48, 1);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_EDGE_MASK, "edge-mask", &clean, &bad);
    const size_t px = (size_t)r.y * v.width + r.x;
    assert_int_equal(r.sample, 0);
    assert_int_equal(clean.mask[px], 1);
    assert_int_equal(bad.mask[px], 0);
    for (size_t j = 0; j < px; j++) /* the first pixel the threshold changes, unless the check has a margin there */
        if (clean.mask[j] != bad.mask[j])
            print_message("    pixel %zu differs before the reported %zu (within the margin)\n", j, px);
    assert_true(r.mask_oracle_only > 0);
    assert_int_equal(r.mask_gpu_only, 0);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_shade_once(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.shade_sample0 = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 4);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_SHADING, "image", &clean, &bad);
    const size_t px = (size_t)r.y * v.width + r.x;
    assert_int_equal(bad.mask[px], 1);
    assert_int_equal(px, first_diff16(clean.image, bad.image, (size_t)64 * 48, 4));
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_instance_word(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.instance_hi = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 4);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_ID, "visibility", &clean, &bad);
    assert_int_equal(result_k(&v, &r), first_diff16(clean.p.visibility, bad.p.visibility, (size_t)64 * 48 * 4, 4));
    const size_t k = result_k(&v, &r);
    char word[64];
    snprintf(word, sizeof word, "instance %u primitive", (unsigned)(bad.p.visibility[4 * k + 2] | 1u << 16));
    assert_non_null(strstr(r.what, word));
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

static void test_fault_derivative_sign(void **state)
{
    (void)state;
    sim_opts o = {0};
    o.ddx_sign = 1;
    vscene v;
    vscene_load(&v, "rtstress:2", 64, 48, 1);
    sim_gpu clean, bad;
    const rto_vbuffer_check_result r = expect_fault(&v, &o, RTO_VB_DERIVATIVE, "derivatives", &clean, &bad);
    assert_starts(&v, &r, clean.p.derivatives, bad.p.derivatives, 4, 4.0);
    sim_free(&clean);
    sim_free(&bad);
    vscene_free(&v);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Names and arguments                                                                                                  */

static void test_names(void **state)
{
    (void)state;
    static const char *const names[] = {"pass", "coverage", "id", "barycentric", "normal", "derivative", "depth",
                                        "f16-rounding", "edge-mask", "shading"};
    for (int f = RTO_VB_PASS; f <= RTO_VB_SHADING; f++)
        assert_string_equal(rto_vb_fault_name((rto_vb_fault)f), names[f]);
    assert_string_equal(rto_vb_fault_name((rto_vb_fault)99), "unknown");
}

/* The simulation's binary16 against the library's (rto_f16_from_f32): two codes from the same rule agree on every
 * binade's ends, midpoints and ties, subnormals and overflow, and on a seeded sweep. */
static void test_sim_f16(void **state)
{
    (void)state;
    static const float edges[] = {0.0f, -0.0f, 1.0f, 1.0f + 0x1p-11f, 1.0f + 0x1p-11f + 0x1p-23f, 1.0f + 3 * 0x1p-11f,
                                  0x1p-14f, 0x1p-14f - 0x1p-25f, 0x1p-25f, 0x1p-25f + 0x1p-40f, 3 * 0x1p-26f,
                                  65504.0f, 65519.0f, 65520.0f, 1e9f, -2.5f, 0.333333343f, -0x1p-24f};
    for (size_t i = 0; i < sizeof edges / sizeof edges[0]; i++)
        assert_int_equal(sim_f16(edges[i], 0), rto_f16_from_f32(edges[i]));
    uint64_t seed = 0x5eed004;
    for (int i = 0; i < 200000; i++) {
        const uint32_t bits = (uint32_t)tu_rng_next(&seed);
        float f;
        memcpy(&f, &bits, sizeof f);
        if (isnan(f))
            continue;
        if (sim_f16(f, 0) != rto_f16_from_f32(f))
            fail_msg("%a: simulation 0x%04x, library 0x%04x", (double)f, sim_f16(f, 0), rto_f16_from_f32(f));
        const double v = sim_f16_value(sim_f16(f, 1)), a = (double)f;
        assert_true(fabs(v) <= fabs(a) && (double)rto_f16_to_f32(sim_f16(f, 1)) == v); /* toward zero */
    }
}

static void test_arguments(void **state)
{
    (void)state;
    vscene v;
    vscene_load(&v, "triangle", 16, 12, 1);
    sim_gpu g;
    sim_render(&v.geo, &v.cam, 16, 12, 1, &plain, &g);
    rto_vbuffer_check_desc d;
    memset(&d, 0, sizeof d);
    rto_vbuffer_check_result r;
    rto_msg msg = {{0}};
    assert_int_equal(rto_vbuffer_check(NULL, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_vbuffer_check(&d, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.gpu = &g.p;
    assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT); /* no expected */
    d.expected = &v.vb;
    d.gpu = NULL;
    assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_vbuffer_planes wrong = g.p;
    wrong.width = 15;
    d.gpu = &wrong;
    assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "15 x 12"));
    /* only some planes dumped: those are compared, the rest read from the oracle */
    rto_vbuffer_planes some = g.p;
    some.normal = NULL;
    some.derivatives = NULL;
    d.gpu = &some;
    assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_OK);
    assert_int_equal(r.fault, RTO_VB_PASS);
    assert_int_equal(r.planes_checked, 0x13);
    /* no visibility plane: the others are compared where the oracle's answer is the only admissible one */
    some = g.p;
    some.visibility = NULL;
    assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_OK);
    assert_int_equal(r.fault, RTO_VB_PASS);
    assert_int_equal(r.planes_checked, 0x1e);
    assert_true(r.compared > 0 && r.compared <= 16 * 12);
    /* ... and still found wrong there */
    for (size_t k = 0; k < 16 * 12; k++)
        if (!sim_is_bg(&g.p.visibility[4 * k])) {
            g.p.barycentric[2 * k] ^= 0x4000;
            assert_int_equal(rto_vbuffer_check(&d, &r, &msg), RTO_OK);
            assert_int_equal(r.fault, RTO_VB_BARYCENTRIC);
            assert_int_equal(((size_t)r.y * 16 + r.x), k);
            break;
        }
    sim_free(&g);
    vscene_free(&v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_arguments),
        cmocka_unit_test(test_sim_f16),
        cmocka_unit_test(test_controls),
        cmocka_unit_test(test_control_tilted_quad),
        cmocka_unit_test(test_control_4bit_and_unorm24),
        cmocka_unit_test(test_fault_top_left),
        cmocka_unit_test(test_fault_sample_pattern),
        cmocka_unit_test(test_fault_affine),
        cmocka_unit_test(test_fault_octahedral_sign),
        cmocka_unit_test(test_fault_depth_step),
        cmocka_unit_test(test_fault_f16_rtz),
        cmocka_unit_test(test_fault_threshold),
        cmocka_unit_test(test_fault_shade_once),
        cmocka_unit_test(test_fault_instance_word),
        cmocka_unit_test(test_fault_derivative_sign),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
