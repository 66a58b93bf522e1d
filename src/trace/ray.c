/* Rays (DESIGN.md §7, seed 002 §2.2-2.3): the Stage-2 pinhole camera's uniform block and primary rays, an automatic
 * framing of a scene, and the generated ray sets (primary, shadow, random, grazing, axis). Everything is a pure
 * function of its inputs: the camera matrices are binary64 rounded once, a camera ray is the seed's generateRay in
 * binary32 term by term, and the random sets draw from the shared counter-based PRNG of §3, one stream per purpose.
 * docs/trace.md "Cameras and ray sets" states every formula. */
#include "internal.h"
#include "trace_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Camera uniforms                                                                                                  */

/* 4x4 matrices here are column-major like gl-matrix and WGSL: element [4c + r] is row r of column c. */

/* gl-matrix's lookAt (right-handed): z = normalize(eye - target), x = normalize(cross(up, z)), y = cross(z, x); the
 * view matrix has rows x, y, z and translation -(x . eye, y . eye, z . eye). Returns 0 (and names the fault in why)
 * for a degenerate pose. */
static int look_at(const double eye[3], const double target[3], const double up[3], double m[16], const char **why)
{
    double z[3] = {eye[0] - target[0], eye[1] - target[1], eye[2] - target[2]};
    const double zl = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    if (!(zl > 0) || !isfinite(zl)) {
        *why = "the target is at the eye";
        return 0;
    }
    for (int a = 0; a < 3; a++)
        z[a] /= zl;
    double x[3] = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]};
    const double xl = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    const double ul = sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    /* |up x z| = |up| sin(angle): below 1e-7 |up| the angle is under binary32's resolution of the inputs, and the
     * side axis would be decided by their rounding alone. */
    if (!(xl > 1e-7 * ul) || !isfinite(xl)) {
        *why = "the up vector is zero or parallel to the view direction";
        return 0;
    }
    for (int a = 0; a < 3; a++)
        x[a] /= xl;
    /* z and x are orthonormal, so y is a unit vector already (gl-matrix normalises it again; rounding only). */
    const double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    for (int c = 0; c < 3; c++) {
        m[4 * c + 0] = x[c];
        m[4 * c + 1] = y[c];
        m[4 * c + 2] = z[c];
        m[4 * c + 3] = 0.0;
    }
    m[12] = -(x[0] * eye[0] + x[1] * eye[1] + x[2] * eye[2]);
    m[13] = -(y[0] * eye[0] + y[1] * eye[1] + y[2] * eye[2]);
    m[14] = -(z[0] * eye[0] + z[1] * eye[1] + z[2] * eye[2]);
    m[15] = 1.0;
    return 1;
}

/* gl-matrix's perspective (perspectiveNO: OpenGL clip z in [-1, 1]): f = 1 / tan(fovY / 2), nf = 1 / (near - far). */
static void perspective(double fov_y, double aspect, double znear, double zfar, double m[16])
{
    const double f = 1.0 / tan(fov_y / 2.0), nf = 1.0 / (znear - zfar);
    memset(m, 0, 16 * sizeof *m);
    m[0] = f / aspect;
    m[5] = f;
    m[10] = (zfar + znear) * nf;
    m[11] = -1.0;
    m[14] = 2.0 * zfar * znear * nf;
}

/* The general 4x4 inverse by cofactors (the 2x2 minors of the upper and lower row pairs, Laplace expansion), as
 * mat4.invert computes it; a camera harness inverts the matrices it built, so the oracle does the same rather than
 * use the closed forms the tests check it against. Returns 0 for a singular or non-finite matrix. */
int rto__invert4(const double a[16], double out[16])
{
    /* a[4c + r]: a0r = row r of column 0 ... written as gl-matrix names them (aCR = column C, row R). */
    const double a00 = a[0], a01 = a[1], a02 = a[2], a03 = a[3];
    const double a10 = a[4], a11 = a[5], a12 = a[6], a13 = a[7];
    const double a20 = a[8], a21 = a[9], a22 = a[10], a23 = a[11];
    const double a30 = a[12], a31 = a[13], a32 = a[14], a33 = a[15];
    const double b00 = a00 * a11 - a01 * a10, b01 = a00 * a12 - a02 * a10, b02 = a00 * a13 - a03 * a10;
    const double b03 = a01 * a12 - a02 * a11, b04 = a01 * a13 - a03 * a11, b05 = a02 * a13 - a03 * a12;
    const double b06 = a20 * a31 - a21 * a30, b07 = a20 * a32 - a22 * a30, b08 = a20 * a33 - a23 * a30;
    const double b09 = a21 * a32 - a22 * a31, b10 = a21 * a33 - a23 * a31, b11 = a22 * a33 - a23 * a32;
    const double det = b00 * b11 - b01 * b10 + b02 * b09 + b03 * b08 - b04 * b07 + b05 * b06;
    if (det == 0.0 || !isfinite(det))
        return 0;
    const double id = 1.0 / det;
    out[0] = (a11 * b11 - a12 * b10 + a13 * b09) * id;
    out[1] = (a02 * b10 - a01 * b11 - a03 * b09) * id;
    out[2] = (a31 * b05 - a32 * b04 + a33 * b03) * id;
    out[3] = (a22 * b04 - a21 * b05 - a23 * b03) * id;
    out[4] = (a12 * b08 - a10 * b11 - a13 * b07) * id;
    out[5] = (a00 * b11 - a02 * b08 + a03 * b07) * id;
    out[6] = (a32 * b02 - a30 * b05 - a33 * b01) * id;
    out[7] = (a20 * b05 - a22 * b02 + a23 * b01) * id;
    out[8] = (a10 * b10 - a11 * b08 + a13 * b06) * id;
    out[9] = (a01 * b08 - a00 * b10 - a03 * b06) * id;
    out[10] = (a30 * b04 - a31 * b02 + a33 * b00) * id;
    out[11] = (a21 * b02 - a20 * b04 - a23 * b00) * id;
    out[12] = (a11 * b07 - a10 * b09 - a12 * b06) * id;
    out[13] = (a00 * b09 - a01 * b07 + a02 * b06) * id;
    out[14] = (a31 * b01 - a30 * b03 - a32 * b00) * id;
    out[15] = (a20 * b03 - a21 * b01 + a22 * b00) * id;
    for (int k = 0; k < 16; k++)
        if (!isfinite(out[k]))
            return 0;
    return 1;
}

/* The checks every camera passes and its view and (OpenGL) projection matrices in binary64, shared with the
 * visibility pass (raster/vb_camera.c). */
rto_status rto__camera_matrices(const rto_camera *camera, uint32_t width, uint32_t height, double view[16],
                                double proj[16], rto_msg *msg)
{
    if (!camera)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL camera");
    if (width == 0 || height == 0)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera image size %ux%u: both must be at least 1", width,
                        height);
    const float all[13] = {camera->position.x, camera->position.y, camera->position.z, camera->target.x,
                           camera->target.y,   camera->target.z,   camera->up.x,       camera->up.y,
                           camera->up.z,       camera->fov_y,      camera->aspect,     camera->znear,
                           camera->zfar};
    for (int k = 0; k < 13; k++)
        if (!isfinite(all[k]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': a parameter is not finite (%g)",
                            camera->name, (double)all[k]);
    const double fov = camera->fov_y, zn = camera->znear, zf = camera->zfar;
    if (!(fov > 0.0) || !(fov < 3.14159265358979323846))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': fovY %g is outside (0, pi) radians",
                        camera->name, fov);
    if (!(zn > 0.0) || !(zf > zn))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': near %g and far %g need 0 < near < far",
                        camera->name, zn, zf);
    if (camera->aspect < 0.0f)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': aspect %g is negative", camera->name,
                        (double)camera->aspect);
    const double aspect = camera->aspect > 0.0f ? (double)camera->aspect : (double)width / (double)height;
    const double eye[3] = {camera->position.x, camera->position.y, camera->position.z};
    const double target[3] = {camera->target.x, camera->target.y, camera->target.z};
    const double up[3] = {camera->up.x, camera->up.y, camera->up.z};
    double iview[16], iproj[16];
    const char *why = "";
    if (!look_at(eye, target, up, view, &why))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': %s", camera->name, why);
    perspective(fov, aspect, zn, zf, proj);
    if (!rto__invert4(view, iview) || !rto__invert4(proj, iproj))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': its view or projection matrix is singular",
                        camera->name);
    return RTO_OK;
}

rto_status rto_camera_uniforms_make(const rto_camera *camera, uint32_t width, uint32_t height,
                                    rto_camera_uniforms *out, rto_msg *msg)
{
    if (!camera || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL camera or output");
    double view[16], proj[16], iview[16], iproj[16];
    rto_status st = rto__camera_matrices(camera, width, height, view, proj, msg);
    if (st != RTO_OK)
        return st;
    if (!rto__invert4(view, iview) || !rto__invert4(proj, iproj))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': its view or projection matrix is singular",
                        camera->name);
    rto_camera_uniforms u;
    memset(&u, 0, sizeof u);
    for (int k = 0; k < 16; k++) {
        u.inverse_projection[k] = (float)iproj[k];
        u.inverse_view[k] = (float)iview[k];
        if (!isfinite(u.inverse_projection[k]) || !isfinite(u.inverse_view[k]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "camera '%.64s': an inverse matrix element overflows binary32 (near %g, far %g)",
                            camera->name, (double)camera->znear, (double)camera->zfar);
    }
    u.position[0] = camera->position.x;
    u.position[1] = camera->position.y;
    u.position[2] = camera->position.z;
    u.pad = 0.0f;
    *out = u;
    return RTO_OK;
}

/* The framing (docs/trace.md): in binary64, centre c = (min + max) / 2 and radius r = |max - min| / 2 (the bounding
 * sphere of the box), raised to 1e-4 max(|c.x|, |c.y|, |c.z|), so that eye and target, rounded to binary32, stay
 * over a thousand ulp apart, and 1 for a point at the origin. The sphere fits a half-angle h = min(fovY / 2, atan(tan(fovY / 2) *
 * aspect)) at distance d = r / sin(h); the eye is c + d (0, 2, 5) / sqrt(29), near (d - r) / 2, far 2 (d + r). */
rto_camera rto_camera_frame(const rto_aabb *bounds, float aspect)
{
    rto_camera cam = rto_camera_default();
    if (!bounds || rto_aabb_is_empty(bounds))
        return cam;
    const double lo[3] = {bounds->min.x, bounds->min.y, bounds->min.z};
    const double hi[3] = {bounds->max.x, bounds->max.y, bounds->max.z};
    double c[3], r2 = 0.0, cmax = 0.0;
    for (int a = 0; a < 3; a++) {
        if (!isfinite(lo[a]) || !isfinite(hi[a]))
            return cam;
        c[a] = (lo[a] + hi[a]) * 0.5;
        r2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
        cmax = fmax(cmax, fabs(c[a]));
    }
    double r = 0.5 * sqrt(r2);
    r = fmax(r, 1e-4 * cmax);
    if (!(r > 0.0))
        r = 1.0;
    const double half = (double)cam.fov_y * 0.5;
    const double asp = aspect > 0.0f && isfinite(aspect) ? (double)aspect : 1.0;
    const double h = fmin(half, atan(tan(half) * asp));
    const double d = r / sin(h);
    const double s = 1.0 / sqrt(29.0);
    snprintf(cam.name, sizeof cam.name, "framing");
    cam.position = (rto_vec3){(float)c[0], (float)(c[1] + d * 2.0 * s), (float)(c[2] + d * 5.0 * s)};
    cam.target = (rto_vec3){(float)c[0], (float)c[1], (float)c[2]};
    cam.znear = (float)((d - r) * 0.5);
    cam.zfar = (float)((d + r) * 2.0);
    return cam;
}

/* WGSL's normalize as DESIGN §7 defines it: v / length(v), length = sqrt((x*x + y*y) + z*z), all binary32. */
static void normalize3f(const float v[3], float out[3])
{
    const float len = sqrtf((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]);
    out[0] = v[0] / len;
    out[1] = v[1] / len;
    out[2] = v[2] / len;
}

rto_wf_ray rto_camera_ray(const rto_camera_uniforms *u, uint32_t width, uint32_t height, uint32_t x, uint32_t y)
{
    /* generateRay(pixelCoord + 0.5, resolution), seed 002 §2.3, in binary32 term by term. */
    const float px = (float)x + 0.5f, py = (float)y + 0.5f;
    const float nx = (px / (float)width) * 2.0f - 1.0f;
    const float ny = 1.0f - (py / (float)height) * 2.0f;
    const float *ip = u->inverse_projection, *iv = u->inverse_view;
    /* rayEye = inverseProjection * (ndc, -1, 1), column by column, left to right; only .xy survive. */
    float eye[2];
    for (int r = 0; r < 2; r++)
        eye[r] = ((ip[0 + r] * nx + ip[4 + r] * ny) + ip[8 + r] * -1.0f) + ip[12 + r] * 1.0f;
    /* rayWorld = (inverseView * (rayEye.xy, -1, 0)).xyz the same way; the w = 0 term stays (it turns -0 into +0). */
    float world[3];
    for (int r = 0; r < 3; r++)
        world[r] = ((iv[0 + r] * eye[0] + iv[4 + r] * eye[1]) + iv[8 + r] * -1.0f) + iv[12 + r] * 0.0f;
    rto_wf_ray ray;
    memset(&ray, 0, sizeof ray);
    memcpy(ray.origin, u->position, sizeof ray.origin);
    normalize3f(world, ray.dir);
    ray.t_min = 0.0f;
    ray.t_max = RTO_RAY_T_MAX;
    ray.pixel = y * width + x;
    ray.flags = RTO_RAY_FLAG_OPAQUE;
    ray.cull_mask = 0xFFu;
    ray.kind = RTO_RAYS_PRIMARY;
    ray.payload_slot = ray.pixel;
    return ray;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Ray sets                                                                                                         */

static const char *const set_names[RTO_RAY_SET_COUNT] = {"primary", "shadow", "random", "grazing", "axis"};

const char *rto_ray_set_name(rto_ray_set set)
{
    return (unsigned)set < RTO_RAY_SET_COUNT ? set_names[set] : NULL;
}

int rto_ray_set_parse(const char *name, rto_ray_set *set)
{
    for (unsigned k = 0; name && k < RTO_RAY_SET_COUNT; k++)
        if (!strcmp(name, set_names[k])) {
            if (set)
                *set = (rto_ray_set)k;
            return 1;
        }
    return 0;
}

/* Most rays one set may hold: the library's array limit (RTO_MAX_KEYS, 2^28). */
#define RAYS_MAX RTO_MAX_KEYS

static uint64_t rays_needed(const rto_rays_desc *d)
{
    switch (d->set) {
    case RTO_RAYS_PRIMARY:
    case RTO_RAYS_SHADOW:
        return (uint64_t)d->width * d->height;
    case RTO_RAYS_RANDOM:
    case RTO_RAYS_GRAZING:
    case RTO_RAYS_AXIS:
        return (uint64_t)d->count;
    }
    return 0;
}

size_t rto_rays_capacity(const rto_rays_desc *desc)
{
    if (!desc)
        return 0;
    const uint64_t n = rays_needed(desc);
    return n > (uint64_t)SIZE_MAX ? SIZE_MAX : (size_t)n;
}

/* Streams of the PRNG (§3), one per purpose: stream p of a seed is rng(seed + p * 0x9E3779B9, i), the golden-ratio
 * offset dist.c uses for its streams; the numbers are distinct from dist.c's (0 .. 14), so ray sets and key
 * distributions of one seed never share a stream. Ray i of a set draws counters 8 i + k, k = 0 .. 7. */
enum {
    STREAM_RANDOM = 0x100,
    STREAM_GRAZING = 0x101,
    STREAM_AXIS = 0x102,
};
#define STREAM_SEED(seed, p) ((uint32_t)((seed) + (uint32_t)(p) * UINT32_C(0x9E3779B9)))
#define DRAWS_PER_RAY 8u

static uint32_t draw(uint32_t stream, size_t i, uint32_t k)
{
    return rto_rng(stream, (uint32_t)(i * DRAWS_PER_RAY + k));
}

/* A uniform double in [0, 1) with 24 random bits: rto_unit, exactly (24 bits fit a binary32 mantissa). */
static double draw_unit(uint32_t stream, size_t i, uint32_t k)
{
    return (double)rto_unit(stream, (uint32_t)(i * DRAWS_PER_RAY + k));
}

/* floor(u * n) for n >= 1 without float rounding: the high word of rng * n (Lemire's multiply-shift). */
static uint32_t draw_below(uint32_t stream, size_t i, uint32_t k, uint32_t n)
{
    return (uint32_t)(((uint64_t)draw(stream, i, k) * n) >> 32);
}

/* A direction uniform on the unit sphere (Archimedes: z uniform in [-1, 1], azimuth uniform), in binary64. */
static void sphere_dir(double u0, double u1, double d[3])
{
    const double z = 1.0 - 2.0 * u0, phi = 2.0 * 3.14159265358979323846 * u1;
    const double rr = sqrt(fmax(0.0, 1.0 - z * z));
    d[0] = rr * cos(phi);
    d[1] = rr * sin(phi);
    d[2] = z;
}

static rto_wf_ray ray_base(rto_ray_set set, size_t i)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    r.t_min = 0.0f;
    r.t_max = RTO_RAY_T_MAX;
    r.pixel = (uint32_t)i;
    r.flags = RTO_RAY_FLAG_OPAQUE;
    r.cull_mask = 0xFFu;
    r.kind = (uint32_t)set;
    r.payload_slot = (uint32_t)i;
    return r;
}

/* The instances that grazing and axis rays aim at: those whose mesh has triangles. */
typedef struct targets {
    uint32_t *inst;
    uint32_t count;
} targets;

static rto_status targets_find(const rto_scene *s, targets *t, rto_msg *msg)
{
    t->count = 0;
    t->inst = rto__alloc(s->instance_count, sizeof *t->inst);
    if (!t->inst)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u instances", s->instance_count);
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (s->meshes[s->instances[i].blas].triangle_count > 0)
            t->inst[t->count++] = i;
    return RTO_OK;
}

/* Vertex j (0 .. 2) of triangle tri of a mesh, widened to binary64. */
static void vertex_d(const rto_mesh *m, uint32_t tri, int j, double v[3])
{
    const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)tri + (size_t)j]];
    v[0] = p[0];
    v[1] = p[1];
    v[2] = p[2];
}

/* objToWorld (binary32 entries) applied to an object-space point in binary64: the exact world position of the
 * point on the instance as the scene defines it, before any binary32 rounding. */
static void to_world_d(const rto_mat34 *m, const double p[3], double w[3])
{
    for (int r = 0; r < 3; r++)
        w[r] = (((double)m->m[r][0] * p[0] + (double)m->m[r][1] * p[1]) + (double)m->m[r][2] * p[2]) +
               (double)m->m[r][3];
}

/* How far behind its aim point an aimed ray starts: 1.5 times the scene's diagonal, so the origin lies outside the
 * scene's bounds (the aim point is inside them) by at least half a diagonal; 1 for a scene that is one point. */
static double aim_distance(const rto_aabb *b)
{
    const double dx = (double)b->max.x - b->min.x, dy = (double)b->max.y - b->min.y,
                 dz = (double)b->max.z - b->min.z;
    const double diag = sqrt(dx * dx + dy * dy + dz * dz);
    return diag > 0.0 && isfinite(diag) ? 1.5 * diag : 1.0;
}

/* origin = aim - dir * dist in binary64, rounded once; dir is stored rounded once too. */
static rto_status aimed_ray(rto_wf_ray *r, const double aim[3], const double dir[3], double dist, size_t i,
                            rto_msg *msg)
{
    for (int a = 0; a < 3; a++) {
        r->origin[a] = (float)(aim[a] - dir[a] * dist);
        r->dir[a] = (float)dir[a];
        if (!isfinite(r->origin[a]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "ray %zu: its origin, %g behind its aim point, overflows binary32 (scene bounds too large)",
                            i, dist);
    }
    return RTO_OK;
}

static rto_status gen_random(const rto_scene *s, const targets *t, uint32_t seed, size_t count, rto_wf_ray *rays,
                             size_t *n)
{
    if (t->count == 0)
        return RTO_OK;
    const rto_aabb b = rto_scene_aabb(s);
    const double lo[3] = {b.min.x, b.min.y, b.min.z}, hi[3] = {b.max.x, b.max.y, b.max.z};
    const float flo[3] = {b.min.x, b.min.y, b.min.z}, fhi[3] = {b.max.x, b.max.y, b.max.z};
    const uint32_t st = STREAM_SEED(seed, STREAM_RANDOM);
    for (size_t i = 0; i < count; i++) {
        rto_wf_ray r = ray_base(RTO_RAYS_RANDOM, i);
        for (int a = 0; a < 3; a++) {
            /* lo + u (hi - lo) in binary64, rounded once, then clamped: rounding may not leave the box. */
            const float o = (float)(lo[a] + draw_unit(st, i, (uint32_t)a) * (hi[a] - lo[a]));
            r.origin[a] = rto__minf(rto__maxf(o, flo[a]), fhi[a]);
        }
        double d[3];
        sphere_dir(draw_unit(st, i, 3), draw_unit(st, i, 4), d);
        for (int a = 0; a < 3; a++)
            r.dir[a] = (float)d[a];
        rays[i] = r;
    }
    *n = count;
    return RTO_OK;
}

static rto_status gen_grazing(const rto_scene *s, const targets *t, uint32_t seed, size_t count, rto_wf_ray *rays,
                              size_t *n, rto_msg *msg)
{
    if (t->count == 0)
        return RTO_OK;
    const rto_aabb b = rto_scene_aabb(s);
    const double dist = aim_distance(&b);
    const uint32_t st = STREAM_SEED(seed, STREAM_GRAZING);
    for (size_t i = 0; i < count; i++) {
        const rto_instance *in = &s->instances[t->inst[draw_below(st, i, 0, t->count)]];
        const rto_mesh *m = &s->meshes[in->blas];
        const uint32_t tri = draw_below(st, i, 1, m->triangle_count);
        /* One ray in four aims exactly at a vertex, the others at a uniform point of an edge. */
        const uint32_t mode = draw(st, i, 2);
        const int e = (int)draw_below(st, i, 3, 3);
        double p[3], va[3], vb[3];
        vertex_d(m, tri, e, va);
        if ((mode & 3u) == 0) {
            memcpy(p, va, sizeof p);
        } else {
            vertex_d(m, tri, (e + 1) % 3, vb);
            const double u = draw_unit(st, i, 4);
            for (int a = 0; a < 3; a++)
                p[a] = va[a] + u * (vb[a] - va[a]);
        }
        double aim[3], d[3];
        to_world_d(&in->obj_to_world, p, aim);
        sphere_dir(draw_unit(st, i, 5), draw_unit(st, i, 6), d);
        rto_wf_ray r = ray_base(RTO_RAYS_GRAZING, i);
        rto_status stt = aimed_ray(&r, aim, d, dist, i, msg);
        if (stt)
            return stt;
        rays[i] = r;
    }
    *n = count;
    return RTO_OK;
}

static rto_status gen_axis(const rto_scene *s, const targets *t, uint32_t seed, size_t count, rto_wf_ray *rays,
                           size_t *n, rto_msg *msg)
{
    if (t->count == 0)
        return RTO_OK;
    const rto_aabb b = rto_scene_aabb(s);
    const double dist = aim_distance(&b);
    const uint32_t st = STREAM_SEED(seed, STREAM_AXIS);
    for (size_t i = 0; i < count; i++) {
        const rto_instance *in = &s->instances[t->inst[draw_below(st, i, 0, t->count)]];
        const rto_mesh *m = &s->meshes[in->blas];
        const uint32_t tri = draw_below(st, i, 1, m->triangle_count);
        double v[3][3], c[3], aim[3];
        for (int j = 0; j < 3; j++)
            vertex_d(m, tri, j, v[j]);
        for (int a = 0; a < 3; a++)
            c[a] = (v[0][a] + v[1][a] + v[2][a]) / 3.0;
        to_world_d(&in->obj_to_world, c, aim);
        /* Even rays: axis-parallel (+-x, +-y, +-z: two zero components). Odd rays: one zero component, the other two
         * (cos phi, sin phi). Every zero is +0 or -0 by a random bit, so both signs of zero reach the tracer. */
        const uint32_t axis = draw_below(st, i, 2, 3), bits = draw(st, i, 3);
        double d[3];
        if ((i & 1u) == 0) {
            for (int a = 0; a < 3; a++)
                d[a] = (bits >> a) & 1u ? -0.0 : 0.0;
            d[axis] = (bits >> 3) & 1u ? -1.0 : 1.0;
        } else {
            const double phi = 2.0 * 3.14159265358979323846 * draw_unit(st, i, 4);
            d[(axis + 1) % 3] = cos(phi);
            d[(axis + 2) % 3] = sin(phi);
            d[axis] = (bits >> 3) & 1u ? -0.0 : 0.0;
        }
        rto_wf_ray r = ray_base(RTO_RAYS_AXIS, i);
        rto_status stt = aimed_ray(&r, aim, d, dist, i, msg);
        if (stt)
            return stt;
        rays[i] = r;
    }
    *n = count;
    return RTO_OK;
}

static rto_status camera_for(const rto_scene *s, const rto_rays_desc *d, rto_camera_uniforms *u, rto_msg *msg)
{
    rto_camera cam;
    if (d->camera) {
        cam = *d->camera;
    } else {
        const rto_aabb b = rto_scene_aabb(s);
        cam = rto_camera_frame(&b, (float)((double)d->width / (double)d->height));
    }
    return rto_camera_uniforms_make(&cam, d->width, d->height, u, msg);
}

static void gen_primary(const rto_camera_uniforms *u, uint32_t w, uint32_t h, rto_wf_ray *rays)
{
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            rays[(size_t)y * w + x] = rto_camera_ray(u, w, h, x, y);
}

/* Primary rays traced per chunk, so the hit records of a 4K image never sit in memory at once. */
#define SHADOW_CHUNK ((size_t)1 << 16)

/* The self-intersection offset of shadow rays (docs/trace.md): 1e-4 max(1, M), M the largest magnitude among the
 * scene bounds' coordinates and the camera position's. A hit point o + t d carries a rounding error of a few ulp of
 * max(|o|, |t d|) <= ~2 M (2^-24 M each), so 1e-4 M, about 1700 ulp of M, clears it unless the light grazes the
 * surface at under ~1 degree. */
float rto__ray_offset(const rto_aabb *bounds, const rto_camera_uniforms *u)
{
    const rto_aabb b = *bounds;
    double m = 1.0;
    const float c[9] = {b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z, u->position[0], u->position[1],
                        u->position[2]};
    for (int k = 0; k < 9; k++)
        if (isfinite(c[k]))
            m = fmax(m, fabs((double)c[k]));
    return (float)(1e-4 * m);
}

static rto_status gen_shadow(const rto_accel *accel, const rto_rays_desc *d, const rto_camera_uniforms *u,
                             rto_wf_ray *rays, size_t *n, rto_msg *msg)
{
    const rto_scene *s = rto_accel_scene(accel);
    float light[3] = {d->light_dir[0], d->light_dir[1], d->light_dir[2]};
    if (!isfinite(light[0]) || !isfinite(light[1]) || !isfinite(light[2]))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "light direction (%g, %g, %g) is not finite",
                        (double)light[0], (double)light[1], (double)light[2]);
    if (light[0] == 0.0f && light[1] == 0.0f && light[2] == 0.0f) {
        light[0] = 0.3f;
        light[1] = 1.0f;
        light[2] = 0.2f;
    }
    float l[3];
    normalize3f(light, l);
    if (!isfinite(l[0]) || !isfinite(l[1]) || !isfinite(l[2]))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "light direction (%g, %g, %g) cannot be normalised",
                        (double)light[0], (double)light[1], (double)light[2]);
    const rto_aabb bounds = rto_scene_aabb(s);
    const float eps = rto__ray_offset(&bounds, u);
    const size_t total = (size_t)d->width * d->height;
    /* The primary rays go into the caller's array; shadow ray k is written over slot k <= the primary ray it comes
     * from, which has been read by then, so one array holds both. */
    gen_primary(u, d->width, d->height, rays);
    rto_hit_record *hits = rto__alloc(total < SHADOW_CHUNK ? total : SHADOW_CHUNK, sizeof *hits);
    if (!hits)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the primary hits");
    const rto_trace_desc td = {d->threads};
    size_t out = 0;
    for (size_t a = 0; a < total; a += SHADOW_CHUNK) {
        const size_t len = total - a < SHADOW_CHUNK ? total - a : SHADOW_CHUNK;
        rto_status st = rto_trace(accel, rays + a, len, &td, hits, NULL, msg);
        if (st) {
            free(hits);
            return st;
        }
        for (size_t k = 0; k < len; k++) {
            if (hits[k].miss_flag)
                continue;
            const rto_wf_ray p = rays[a + k];
            const float t = hits[k].t;
            rto_wf_ray r = ray_base(RTO_RAYS_SHADOW, out);
            for (int c = 0; c < 3; c++) {
                r.origin[c] = p.origin[c] + t * p.dir[c];
                r.dir[c] = l[c];
            }
            r.t_min = eps;
            r.pixel = p.pixel;
            r.flags = RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT | RTO_RAY_FLAG_OPAQUE;
            rays[out++] = r;
        }
    }
    free(hits);
    *n = out;
    return RTO_OK;
}

rto_status rto_rays_generate(const rto_accel *accel, const rto_rays_desc *desc, rto_wf_ray *rays, size_t cap,
                             size_t *n, rto_camera_uniforms *camera_out, rto_msg *msg)
{
    if (n)
        *n = 0;
    if (camera_out)
        memset(camera_out, 0, sizeof *camera_out);
    if (!accel || !desc || !n)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel, description or count");
    const char *name = rto_ray_set_name(desc->set);
    if (!name)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown ray set %d", (int)desc->set);
    const int camera = desc->set == RTO_RAYS_PRIMARY || desc->set == RTO_RAYS_SHADOW;
    const uint64_t need = rays_needed(desc);
    if (camera && (desc->width == 0 || desc->height == 0))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s rays: image size %ux%u, both must be at least 1", name,
                        desc->width, desc->height);
    if (need > RAYS_MAX)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s rays: %llu rays exceed the limit of %llu", name,
                        (unsigned long long)need, (unsigned long long)RAYS_MAX);
    if ((uint64_t)cap < need)
        return rto__fail(msg, RTO_ERR_BUFFER_TOO_SMALL, "%s rays: room for %zu rays, %llu needed", name, cap,
                        (unsigned long long)need);
    if (need && !rays)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL ray array");
    const rto_scene *s = rto_accel_scene(accel);
    if (camera) {
        rto_camera_uniforms u;
        rto_status st = camera_for(s, desc, &u, msg);
        if (st)
            return st;
        if (desc->set == RTO_RAYS_PRIMARY) {
            gen_primary(&u, desc->width, desc->height, rays);
            *n = (size_t)need;
        } else {
            st = gen_shadow(accel, desc, &u, rays, n, msg);
            if (st)
                return st;
        }
        if (camera_out)
            *camera_out = u;
        return RTO_OK;
    }
    targets t;
    rto_status st = targets_find(s, &t, msg);
    if (st)
        return st;
    const size_t count = (size_t)need;
    if (desc->set == RTO_RAYS_RANDOM)
        st = gen_random(s, &t, desc->seed, count, rays, n);
    else if (desc->set == RTO_RAYS_GRAZING)
        st = gen_grazing(s, &t, desc->seed, count, rays, n, msg);
    else
        st = gen_axis(s, &t, desc->seed, count, rays, n, msg);
    free(t.inst);
    if (st)
        *n = 0;
    return st;
}

rto_status rto_rays_read(const char *path, size_t max, rto_wf_ray **rays, size_t *n, rto_msg *msg)
{
    if (!path || !rays || !n)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL ray file, array or count");
    *rays = NULL;
    *n = 0;
    rto_npy npy = {0};
    size_t count = 0;
    rto_status s = rto_npy_read(path, &npy, msg);
    if (!s && (s = rto_layout_accept(RTO_LAYOUT_WF_RAY, &npy, &count, msg)))
        rto__fail(msg, s, "%s: %s", path, msg ? msg->text : "");
    if (!s && count > max)
        s = rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: %zu rays (at most %zu)", path, count, max);
    if (!s) {
        *rays = rto__alloc(count, sizeof **rays);
        if (!*rays)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", count);
        else if (count)
            memcpy(*rays, npy.data, count * sizeof **rays);
        *n = s ? 0 : count;
    }
    rto_npy_free(&npy);
    return s;
}
