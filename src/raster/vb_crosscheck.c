/* The rasterizer and the tracer as references for each other (DESIGN.md §11): a primary ray through every sample
 * position must find, as its closest hit, a triangle of the sample's admissible set (a miss: background admissible),
 * or another triangle that the ray meets at the same distance as an admissible one (a tie), or a hit on the near or
 * far plane, which clipping decides, or a triangle with an edge within half a 4-bit sub-pixel step of the sample
 * (the tracer does not snap vertices; a rasterizer does, and the snapped edge may pass on the other side), or an
 * instance whose mask no ray can meet (a visibility pass draws it). Anything else is a disagreement between two independent implementations of one
 * picture, and is named. */
#include "internal.h"
#include "raster/raster_internal.h"
#include "trace/trace_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Rows traced at once: bounded memory whatever the image size. */
#define CHUNK_ROWS 32

typedef struct cam64 {
    double iview[16], iproj[16], view[16];
    double znear, zfar;
    float eye[3];
} cam64;

/* The ray through window position (wx, wy): eye-space direction iproj (ndc, -1, 1) (x, y kept, z -1, w 0), to world
 * by iview, normalised, in binary64 then rounded once; tMin and tMax where it crosses the near and far planes. */
static rto_wf_ray sample_ray(const cam64 *c, uint32_t w, uint32_t h, double wx, double wy, uint32_t pixel)
{
    const double nx = wx / w * 2.0 - 1.0, ny = 1.0 - wy / h * 2.0;
    double e[2];
    for (int r = 0; r < 2; r++)
        e[r] = c->iproj[r] * nx + c->iproj[4 + r] * ny - c->iproj[8 + r] + c->iproj[12 + r];
    double d[3];
    for (int r = 0; r < 3; r++)
        d[r] = c->iview[r] * e[0] + c->iview[4 + r] * e[1] - c->iview[8 + r];
    const double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    rto_wf_ray ray;
    memset(&ray, 0, sizeof ray);
    memcpy(ray.origin, c->eye, sizeof ray.origin);
    double dv_z = 0.0; /* view-space z of the unit direction: -(distance along the view axis per unit t) */
    for (int k = 0; k < 3; k++) {
        ray.dir[k] = (float)(d[k] / l);
        dv_z += c->view[4 * k + 2] * ((double)ray.dir[k]);
    }
    ray.t_min = (float)(c->znear / -dv_z);
    ray.t_max = (float)(c->zfar / -dv_z);
    ray.pixel = pixel;
    ray.flags = RTO_RAY_FLAG_OPAQUE;
    ray.cull_mask = 0xFFu;
    ray.kind = RTO_RAYS_PRIMARY;
    ray.payload_slot = pixel;
    return ray;
}

/* The window position of a vertex (DESIGN.md §11.1: binary32 world and clip values, window coordinates in binary64). */
static void window_pos(const rto_vbuffer *vb, const rto_instance *in, const float p[3], double out[2])
{
    const rto_mat34 *m = &in->obj_to_world;
    const float *vp = vb->camera.view_proj;
    float w[3], c[4];
    for (int r = 0; r < 3; r++)
        w[r] = ((m->m[r][0] * p[0] + m->m[r][1] * p[1]) + m->m[r][2] * p[2]) + m->m[r][3];
    for (int r = 0; r < 4; r++)
        c[r] = ((vp[r] * w[0] + vp[4 + r] * w[1]) + vp[8 + r] * w[2]) + vp[12 + r];
    out[0] = ((double)c[0] / c[3] * 0.5 + 0.5) * vb->planes.width;
    out[1] = (0.5 - (double)c[1] / c[3] * 0.5) * vb->planes.height;
}

/* Distance in pixels from (px, py) to the nearest edge of a triangle's unsnapped window positions (infinity when a
 * vertex is behind the eye, where window positions mean nothing). */
static double edge_distance(const rto_vbuffer *vb, const rto_accel *accel, uint32_t inst, uint32_t prim, double px,
                            double py)
{
    const rto_scene *sc = rto_accel_scene(accel);
    const rto_instance *in = &sc->instances[inst];
    const rto_mesh *mesh = &sc->meshes[in->blas];
    double v[3][2];
    for (int k = 0; k < 3; k++)
        window_pos(vb, in, mesh->positions + 3 * (size_t)mesh->indices[3 * (size_t)prim + k], v[k]);
    double best = INFINITY;
    for (int k = 0; k < 3; k++) {
        const double *a = v[k], *b = v[(k + 1) % 3];
        const double ex = b[0] - a[0], ey = b[1] - a[1], l2 = ex * ex + ey * ey;
        double t = l2 > 0.0 ? ((px - a[0]) * ex + (py - a[1]) * ey) / l2 : 0.0;
        t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
        const double dx = px - (a[0] + t * ex), dy = py - (a[1] + t * ey), d = sqrt(dx * dx + dy * dy);
        best = isfinite(d) && d < best ? d : best;
    }
    return best;
}

/* The t at which ray meets an admissible member, or -1 when it misses it. */
static double member_t(const rto_accel *accel, uint32_t inst, uint32_t prim, const rto_wf_ray *ray)
{
    const rto_scene *sc = rto_accel_scene(accel);
    rto_wf_ray r = *ray;
    r.t_min = 0.0f;
    r.t_max = RTO_RAY_T_MAX;
    rto_tri_hit hit;
    if (inst >= sc->instance_count)
        return -1.0;
    const rto_instance *in = &sc->instances[inst];
    return rto_instance_triangle_hit(in, &sc->meshes[in->blas], prim, &r, &hit) ? (double)hit.t : -1.0;
}

static void classify(const rto_vbuffer *vb, const rto_accel *accel, size_t k, const rto_wf_ray *ray,
                     const rto_hit_record *hit, rto_vbuffer_crosscheck_result *out, uint32_t x, uint32_t y, uint32_t s)
{
    const uint32_t *set = vb->admissible + 2 * (size_t)vb->admissible_offset[k];
    const uint32_t n = vb->admissible_offset[k + 1] - vb->admissible_offset[k];
    const uint32_t inst = hit->miss_flag ? RTO_VB_BACKGROUND : hit->instance_id;
    const uint32_t prim = hit->miss_flag ? RTO_VB_BACKGROUND : hit->prim_id;
    for (uint32_t i = 0; i < n; i++)
        if (set[2 * i] == inst && set[2 * i + 1] == prim) {
            out->agree++;
            return;
        }
    if (!hit->miss_flag) {
        const double t = hit->t;
        if (fabs(t - ray->t_min) <= 1e-4 * fabs(t) || fabs(t - ray->t_max) <= 1e-4 * fabs(t)) {
            out->clip_plane++;
            return;
        }
        for (uint32_t i = 0; i < n; i++) {
            if (set[2 * i] == RTO_VB_BACKGROUND)
                continue;
            const double tm = member_t(accel, set[2 * i], set[2 * i + 1], ray);
            if (tm >= 0.0 && fabs(tm - t) <= 1e-5 * fmax(1.0, fabs(t))) {
                out->tie++;
                return;
            }
        }
    }
    /* the tracer's triangle (or, for a miss, an admissible one) has an edge within half a 4-bit step: 2^-5 pixel,
     * and 2^-12 for the vertices' binary32 rounding */
    double sx, sy;
    rto__vb_sample_pos(vb->planes.samples, s, &sx, &sy);
    const double px = x + sx, py = y + sy, reach = 0x1p-5 + 0x1p-12;
    int snap = !hit->miss_flag && edge_distance(vb, accel, hit->instance_id, hit->prim_id, px, py) <= reach;
    for (uint32_t i = 0; !snap && i < n; i++)
        snap = set[2 * i] != RTO_VB_BACKGROUND && edge_distance(vb, accel, set[2 * i], set[2 * i + 1], px, py) <= reach;
    if (snap) {
        out->snap++;
        return;
    }
    /* an admissible member on an instance no ray with cullMask 0xFF can meet (mask 0): drawn, never traced */
    const rto_scene *sc = rto_accel_scene(accel);
    for (uint32_t i = 0; i < n; i++)
        if (set[2 * i] != RTO_VB_BACKGROUND && set[2 * i] < sc->instance_count &&
            (sc->instances[set[2 * i]].mask & 0xFFu) == 0) {
            out->masked++;
            return;
        }
    if (out->unexplained++ == 0) {
        out->x = x;
        out->y = y;
        out->sample = s;
        if (hit->miss_flag)
            snprintf(out->first, sizeof out->first, "the tracer misses; the rasterizer's %" PRIu32
                     " admissible answer(s) start with triangle %" PRIu32 " of instance %" PRIu32, n, set[1], set[0]);
        else
            snprintf(out->first, sizeof out->first, "the tracer hits triangle %" PRIu32 " of instance %" PRIu32
                     " at t %.9g; the rasterizer's %" PRIu32 " admissible answer(s) start with %s%" PRIu32
                     " of instance %" PRIu32, hit->prim_id, hit->instance_id, (double)hit->t, n,
                     set[0] == RTO_VB_BACKGROUND ? "background " : "triangle ", set[1], set[0]);
    }
}

rto_status rto_vbuffer_crosscheck(const rto_vbuffer *vb, const rto_accel *accel, const rto_camera *camera,
                                  uint32_t threads, rto_vbuffer_crosscheck_result *out, rto_msg *msg)
{
    if (!vb || !accel || !camera || !out || !vb->admissible_offset)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "crosscheck: NULL argument");
    memset(out, 0, sizeof *out);
    const uint32_t W = vb->planes.width, H = vb->planes.height, S = vb->planes.samples;
    cam64 c;
    double proj[16];
    rto_status st = rto__camera_matrices(camera, W, H, c.view, proj, msg);
    if (st)
        return st;
    if (!rto__invert4(c.view, c.iview) || !rto__invert4(proj, c.iproj))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "crosscheck: a singular camera matrix");
    c.znear = camera->znear;
    c.zfar = camera->zfar;
    c.eye[0] = camera->position.x;
    c.eye[1] = camera->position.y;
    c.eye[2] = camera->position.z;
    const size_t cap = (size_t)CHUNK_ROWS * W * S;
    rto_wf_ray *rays = malloc(cap * sizeof *rays);
    rto_hit_record *hits = malloc(cap * sizeof *hits);
    if (!rays || !hits) {
        free(rays);
        free(hits);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "crosscheck: out of memory");
    }
    const rto_trace_desc td = {threads};
    for (uint32_t y0 = 0; !st && y0 < H; y0 += CHUNK_ROWS) {
        const uint32_t y1 = y0 + CHUNK_ROWS < H ? y0 + CHUNK_ROWS : H;
        size_t n = 0;
        for (uint32_t y = y0; y < y1; y++)
            for (uint32_t x = 0; x < W; x++)
                for (uint32_t s = 0; s < S; s++) {
                    double sx, sy;
                    rto__vb_sample_pos(S, s, &sx, &sy);
                    rays[n++] = sample_ray(&c, W, H, x + sx, y + sy, y * W + x);
                }
        st = rto_trace(accel, rays, n, &td, hits, NULL, msg);
        for (size_t i = 0; !st && i < n; i++) {
            const size_t k = (size_t)y0 * W * S + i;
            const uint32_t s = (uint32_t)(i % S), x = (uint32_t)(i / S % W), y = y0 + (uint32_t)(i / S / W);
            classify(vb, accel, k, &rays[i], &hits[i], out, x, y, s);
        }
        out->samples += n;
    }
    free(rays);
    free(hits);
    return st;
}
