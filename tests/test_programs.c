/* Acceptance tests of the wavefront frame's built-in programs and of its capacity rules (DESIGN.md §7), each against
 * an expectation derived here, independently of the code under test:
 * - `triangle` on the VulkanTriangle scene: per pixel, the binary64 pinhole ray of the camera, intersected with the
 *   triangle's plane, barycentrics from signed areas (not Möller–Trumbore): colour (1-u-v, u, v) inside, (0, 0, 0.2)
 *   outside; pixels whose ray passes within 1e-4 (barycentric) of an edge may go either way and are counted;
 * - `normals` on the level-5 icosphere: the exact unit-sphere normal at the binary64 ray/sphere intersection, within
 *   a tolerance derived from the tessellation (the facet angle), and the sky gradient where the ray misses;
 * - `normals` on the analytic stage2 scene: seed 002's generateRay / traceScene / shade transliterated from its WGSL
 *   to binary32 here, with the camera matrices built from gl-matrix's closed forms, written as rgba8 and compared
 *   with every pixel of the frame's image;
 * - capacity: programs defined here that overflow the 2 W H queues, exceed the per-invocation emit budget and
 *   accumulate into one pixel from several rays, checked against a serial simulation of the queue rules; thread
 *   counts 1, 2, 3 and 7 give the same bytes in every buffer. */
#include "testutil.h"

#include "frame/frame_internal.h"

#include <float.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Helpers                                                                                                          */

static rto_accel *build(const rto_scene *s)
{
    rto_accel *a = NULL;
    rto_msg msg = {{0}};
    if (rto_accel_build(s, NULL, &a, &msg))
        fail_msg("rto_accel_build(%s): %s", s->source, msg.text);
    return a;
}

static rto_frame *render(const rto_frame_desc *d)
{
    rto_frame *f = NULL;
    rto_msg msg = {{0}};
    rto_status s = rto_frame_render(d, &f, &msg);
    if (s)
        fail_msg("rto_frame_render(%s, %ux%u): %s: %s", d->program ? d->program->name : "(null)", d->width,
                 d->height, rto_status_string(s), msg.text);
    assert_non_null(f);
    return f;
}

static const rto_program *builtin(const char *name)
{
    const rto_program *p = rto_program_builtin(name);
    if (!p)
        fail_msg("no built-in program '%s'", name);
    return p;
}

/* A pinhole camera in binary64 from its definition (seed 002 §2.2, gl-matrix lookAt): z = normalize(eye - target),
 * x = normalize(up x z), y = z x x; the image plane at distance 1 spans tan(fovY / 2) vertically and aspect times
 * that horizontally. */
typedef struct cam64 {
    double eye[3], x[3], y[3], z[3];
    double tan_half, aspect;
    uint32_t width, height;
} cam64;

static cam64 cam64_make(const rto_camera *c, uint32_t w, uint32_t h)
{
    cam64 k;
    const double eye[3] = {c->position.x, c->position.y, c->position.z};
    const double tgt[3] = {c->target.x, c->target.y, c->target.z};
    const double up[3] = {c->up.x, c->up.y, c->up.z};
    memcpy(k.eye, eye, sizeof eye);
    for (int a = 0; a < 3; a++)
        k.z[a] = eye[a] - tgt[a];
    tu_unit3(k.z);
    tu_cross3(up, k.z, k.x);
    tu_unit3(k.x);
    tu_cross3(k.z, k.x, k.y);
    k.tan_half = tan((double)c->fov_y / 2.0);
    k.aspect = c->aspect > 0.0f ? (double)c->aspect : (double)w / (double)h;
    k.width = w;
    k.height = h;
    return k;
}

/* The unit direction through the centre of pixel (px, py), row 0 at the top. */
static void cam64_dir(const cam64 *k, uint32_t px, uint32_t py, double d[3])
{
    const double nx = ((px + 0.5) / k->width) * 2.0 - 1.0, ny = 1.0 - ((py + 0.5) / k->height) * 2.0;
    const double sx = nx * k->tan_half * k->aspect, sy = ny * k->tan_half;
    for (int a = 0; a < 3; a++)
        d[a] = sx * k->x[a] + sy * k->y[a] - k->z[a];
    tu_unit3(d);
}

/* The 144-byte block from gl-matrix's closed forms in binary64, rounded once: inverseView has the camera's axes x, y,
 * z as its first three columns and the eye as the fourth; inverseProjection of perspective(f = 1 / tan(fovY / 2),
 * A = (far + near) / (near - far), B = 2 far near / (near - far)) is diag(aspect / f, 1 / f) on the first two
 * columns, column 2 = (0, 0, 0, 1 / B), column 3 = (0, 0, -1, A / B). */
static rto_camera_uniforms uniforms64(const rto_camera *c, uint32_t w, uint32_t h)
{
    const cam64 k = cam64_make(c, w, h);
    const double zn = c->znear, zf = c->zfar;
    const double f = 1.0 / tan((double)c->fov_y / 2.0);
    const double A = (zf + zn) / (zn - zf), B = 2.0 * zf * zn / (zn - zf);
    double ip[16] = {0}, iv[16] = {0};
    ip[0] = k.aspect / f;
    ip[5] = 1.0 / f;
    ip[11] = 1.0 / B;
    ip[14] = -1.0;
    ip[15] = A / B;
    for (int r = 0; r < 3; r++) {
        iv[0 + r] = k.x[r];
        iv[4 + r] = k.y[r];
        iv[8 + r] = k.z[r];
        iv[12 + r] = k.eye[r];
    }
    iv[15] = 1.0;
    rto_camera_uniforms u;
    memset(&u, 0, sizeof u);
    for (int i = 0; i < 16; i++) {
        u.inverse_projection[i] = (float)ip[i];
        u.inverse_view[i] = (float)iv[i];
    }
    u.position[0] = c->position.x;
    u.position[1] = c->position.y;
    u.position[2] = c->position.z;
    return u;
}

/* Distance in ulp between two floats of the same sign (0 for equal values, +0 and -0 included). */
static uint32_t ulp_diff(float a, float b)
{
    if (a == b)
        return 0;
    int32_t ia, ib;
    memcpy(&ia, &a, 4);
    memcpy(&ib, &b, 4);
    if ((ia < 0) != (ib < 0))
        return UINT32_MAX;
    return (uint32_t)(ia > ib ? ia - ib : ib - ia);
}

/* The frame's uniform block equals the closed forms' within rounding: the library inverts the matrices by cofactors
 * in binary64, the closed forms are exact, so each element may differ by the last bit at most. Returns the number
 * of elements that differ at all. */
static int check_uniforms(const rto_frame *f, const rto_camera *c)
{
    const rto_camera_uniforms e = uniforms64(c, f->width, f->height);
    int differ = 0;
    for (int i = 0; i < 16; i++) {
        const uint32_t dp = ulp_diff(e.inverse_projection[i], f->camera_uniforms.inverse_projection[i]);
        const uint32_t dv = ulp_diff(e.inverse_view[i], f->camera_uniforms.inverse_view[i]);
        /* An exact zero of the closed form may come out of the cofactors as a tiny residue. */
        const int zp = e.inverse_projection[i] == 0.0f && fabsf(f->camera_uniforms.inverse_projection[i]) < 1e-12f;
        const int zv = e.inverse_view[i] == 0.0f && fabsf(f->camera_uniforms.inverse_view[i]) < 1e-12f;
        if ((dp > 1 && !zp) || (dv > 1 && !zv))
            fail_msg("camera uniforms element %d: inverseProjection %.9g (closed form %.9g), inverseView %.9g (closed "
                     "form %.9g)", i, (double)f->camera_uniforms.inverse_projection[i],
                     (double)e.inverse_projection[i], (double)f->camera_uniforms.inverse_view[i],
                     (double)e.inverse_view[i]);
        differ += (dp != 0) + (dv != 0);
    }
    for (int a = 0; a < 3; a++)
        assert_true(f->camera_uniforms.position[a] == e.position[a]);
    assert_true(f->camera_uniforms.pad == 0.0f);
    return differ;
}

/* DESIGN.md §7's 8-bit conversion of an expected value in binary64: clamp to [0, 1], round x * 255 to nearest. */
static int to8(double x)
{
    if (!(x > 0.0))
        return 0;
    if (x > 1.0)
        return 255;
    return (int)floor(x * 255.0 + 0.5);
}

static void frame_basics(const rto_frame *f, uint32_t w, uint32_t h)
{
    assert_int_equal(f->width, w);
    assert_int_equal(f->height, h);
    assert_true(f->capacity == 2ull * w * h);
    assert_non_null(f->image);
    assert_non_null(f->not_comparable);
    assert_non_null(f->counters);
    assert_non_null(f->indirect_args);
    /* PREP's arguments from each queue's count. */
    for (uint32_t d = 0; d <= f->max_depth; d++) {
        const rto_frame_counters *c = &f->counters[d];
        assert_int_equal(c->queued, c->emitted < f->capacity ? c->emitted : (uint32_t)f->capacity);
        assert_int_equal(c->dropped, c->emitted - c->queued);
        assert_int_equal(f->indirect_args[d][0], (c->queued + 63) / 64);
        assert_int_equal(f->indirect_args[d][1], 1);
        assert_int_equal(f->indirect_args[d][2], 1);
        assert_int_equal(c->traced, d < f->max_depth ? c->queued : 0);
        assert_int_equal(c->hits + c->misses, c->traced);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* `triangle`: barycentric colours, analytic                                                                         */

static void triangle_case(uint32_t w, uint32_t h, uint32_t threads)
{
    rto_scene *s = tu_load("triangle");
    rto_accel *acc = build(s);
    assert_true(s->camera_count >= 1 && s->instance_count == 1 && s->meshes[0].triangle_count == 1);
    const rto_camera cam = s->cameras[0];
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = builtin("triangle");
    d.scene_kind = RTO_FRAME_SCENE_MESH;
    d.accel = acc;
    d.width = w;
    d.height = h;
    d.max_depth = 1;
    d.camera = &cam;
    d.keep = RTO_FRAME_KEEP_ACCUM;
    d.threads = threads;
    rto_frame *f = render(&d);
    frame_basics(f, w, h);
    assert_int_equal(f->max_depth, 1);
    assert_non_null(f->accum);
    check_uniforms(f, &cam);

    /* The triangle in world space (binary64) and its plane normal N = (v1 - v0) x (v2 - v0). */
    double v[3][3], e1[3], e2[3], n[3];
    for (int c = 0; c < 3; c++)
        tu_world_vertex(s, 0, 0, c, v[c]);
    for (int a = 0; a < 3; a++) {
        e1[a] = v[1][a] - v[0][a];
        e2[a] = v[2][a] - v[0][a];
    }
    tu_cross3(e1, e2, n);
    const double nn = tu_dot3(n, n);
    const cam64 k = cam64_make(&cam, w, h);
    size_t inside = 0, outside = 0, edge = 0, off1 = 0;
    double max_accum_err = 0.0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const size_t p = (size_t)y * w + x;
            double dir[3];
            cam64_dir(&k, x, y, dir);
            /* The plane hit, then barycentrics as signed area ratios: u = area(v0, P, v2) / area(v0, v1, v2),
             * v = area(v0, v1, P) / area(v0, v1, v2), each area the triple product with N. */
            double rel[3], o_v0[3], pp[3], c1[3], c2[3];
            for (int a = 0; a < 3; a++)
                o_v0[a] = v[0][a] - k.eye[a];
            const double t = tu_dot3(n, o_v0) / tu_dot3(n, dir);
            for (int a = 0; a < 3; a++) {
                pp[a] = k.eye[a] + t * dir[a];
                rel[a] = pp[a] - v[0][a];
            }
            tu_cross3(rel, e2, c1);
            tu_cross3(e1, rel, c2);
            const double u = tu_dot3(c1, n) / nn, vv = tu_dot3(c2, n) / nn, wv = 1.0 - u - vv;
            const double m = fmin(wv, fmin(u, vv));
            if (fabs(m) < 1e-4 || !(t > 0)) {
                edge++;
                continue;
            }
            double e[3];
            if (m > 0) {
                e[0] = wv;
                e[1] = u;
                e[2] = vv;
                inside++;
            } else {
                e[0] = 0.0;
                e[1] = 0.0;
                e[2] = 0.2;
                outside++;
            }
            const float *acc4 = &f->accum[4 * p];
            const uint8_t *img = &f->image[4 * p];
            for (int c = 0; c < 3; c++) {
                const double err = fabs((double)acc4[c] - e[c]);
                max_accum_err = fmax(max_accum_err, err);
                if (!(err <= 1e-5))
                    fail_msg("triangle %ux%u pixel (%u, %u): accum %.7g %.7g %.7g, expected %.7g %.7g %.7g", w, h,
                             x, y, (double)acc4[0], (double)acc4[1], (double)acc4[2], e[0], e[1], e[2]);
                const int de = abs((int)img[c] - to8(e[c]));
                if (de > 1)
                    fail_msg("triangle %ux%u pixel (%u, %u) channel %d: image %u, expected %d (%.6f)", w, h, x, y,
                             c, img[c], to8(e[c]), e[c]);
                off1 += de == 1;
            }
            assert_true(acc4[3] == 1.0f);
            assert_int_equal(img[3], 255);
            assert_int_equal(f->not_comparable[p], 0);
        }
    print_message("triangle %ux%u: %zu pixels inside, %zu outside, %zu within 1e-4 (barycentric) of an edge (either "
                  "way); accum max error %.3g (tolerance 1e-5); %zu 8-bit channels off by 1\n", w, h, inside, outside,
                  edge, max_accum_err, off1);
    assert_true(edge * 200 <= (size_t)w * h); /* at most 0.5 % */
    assert_true(inside > (size_t)w * h / 20 && outside > (size_t)w * h / 20);
    /* One primary ray per pixel, traced and shaded once, one accumulate each; nothing dropped, no conflict. */
    const rto_frame_counters *c0 = &f->counters[0];
    assert_int_equal(c0->emitted, w * h);
    assert_int_equal(c0->traced, w * h);
    assert_true(c0->hits >= inside && c0->hits <= inside + edge);
    assert_int_equal(c0->shaded, w * h);
    assert_int_equal(c0->accumulates, w * h);
    assert_int_equal(c0->conflicts, 0);
    assert_int_equal(c0->refused, 0);
    assert_int_equal(f->counters[1].emitted, 0);
    assert_true(f->invalid_calls == 0);
    rto_frame_destroy(f);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

static void test_triangle_analytic(void **state)
{
    (void)state;
    triangle_case(160, 120, 0);
    triangle_case(97, 61, 3); /* odd sizes: rows and columns cannot be swapped unnoticed */
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* `normals` on a tessellated unit sphere                                                                            */

static void test_normals_sphere(void **state)
{
    (void)state;
    const uint32_t w = 160, h = 120;
    rto_scene *s = tu_load("sphere:5");
    rto_accel *acc = build(s);
    const rto_mesh *mesh = &s->meshes[0];
    assert_true(s->instance_count == 1 && mesh->normals == NULL);
    /* The tessellation in binary64 (vertices are on the unit sphere, rounded to binary32): theta_c, the largest
     * angle between a facet's normal and one of its vertices (every point of the facet is within it of the normal,
     * the foot of the normal being the circumcentre), and r_in, the smallest distance from the centre to a facet's
     * plane (the convex mesh contains the ball of that radius). */
    double theta_c = 0.0, r_in = INFINITY, r_out = 0.0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) {
        double v[3][3], e1[3], e2[3], n[3];
        for (int c = 0; c < 3; c++) {
            tu_world_vertex(s, 0, t, c, v[c]);
            r_out = fmax(r_out, sqrt(tu_dot3(v[c], v[c])));
        }
        for (int a = 0; a < 3; a++) {
            e1[a] = v[1][a] - v[0][a];
            e2[a] = v[2][a] - v[0][a];
        }
        tu_cross3(e1, e2, n);
        tu_unit3(n);
        r_in = fmin(r_in, tu_dot3(n, v[0]));
        for (int c = 0; c < 3; c++) {
            double u[3] = {v[c][0], v[c][1], v[c][2]};
            tu_unit3(u);
            theta_c = fmax(theta_c, acos(fmin(1.0, tu_dot3(u, n))));
        }
    }
    const rto_camera cam = s->cameras[0];
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = builtin("normals");
    d.accel = acc;
    d.width = w;
    d.height = h;
    d.camera = &cam;
    d.keep = RTO_FRAME_KEEP_ACCUM;
    rto_frame *f = render(&d);
    frame_basics(f, w, h);
    check_uniforms(f, &cam);
    const cam64 k = cam64_make(&cam, w, h);
    size_t hit = 0, sky = 0, ring = 0;
    double max_err8 = 0.0, max_tol8 = 0.0, min_tol8 = INFINITY;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const size_t p = (size_t)y * w + x;
            const uint8_t *img = &f->image[4 * p];
            double dir[3];
            cam64_dir(&k, x, y, dir);
            /* Closest approach of the ray's line to the centre: hd^2 = |eye|^2 - (eye . dir)^2. */
            const double b = tu_dot3(k.eye, dir), hd2 = tu_dot3(k.eye, k.eye) - b * b;
            const double hd = sqrt(fmax(hd2, 0.0));
            double e[3], tol8;
            if (hd < r_in && b < 0) {
                /* Enters the unit sphere at t1 and the inscribed ball at t2; the facet it hits lies in between, so
                 * its hit point P_f is within s = t2 - t1 of the sphere point P_s, all at distance >= r_in from the
                 * centre: the angle between P_f and P_s is at most s / r_in, and the facet's normal is within
                 * theta_c of P_f. The colour n * 0.5 + 0.5 then differs by at most 0.5 |n_f - n_s| <= 0.5 theta per
                 * channel, theta = theta_c + s / r_in; 8-bit: that times 255 plus 0.5 for rounding and 0.01 for the
                 * binary32 ray. */
                const double t1 = -b - sqrt(1.0 - hd2), t2 = -b - sqrt(r_in * r_in - hd2);
                double ps[3];
                for (int a = 0; a < 3; a++)
                    ps[a] = k.eye[a] + t1 * dir[a];
                tu_unit3(ps);
                for (int c = 0; c < 3; c++)
                    e[c] = ps[c] * 0.5 + 0.5;
                const double theta = theta_c + (t2 - t1) / r_in;
                tol8 = 255.0 * 0.5 * theta + 0.51;
                hit++;
            } else if (hd > r_out * (1 + 1e-6) || b >= 0) {
                /* The sky gradient: mix(white, (0.5, 0.7, 1.0), 0.5 (dir.y + 1)). */
                const double a = 0.5 * (dir[1] + 1.0);
                const double sk[3] = {0.5, 0.7, 1.0};
                for (int c = 0; c < 3; c++)
                    e[c] = 1.0 * (1.0 - a) + sk[c] * a;
                tol8 = 0.51;
                sky++;
            } else {
                ring++; /* the silhouette: the ray passes between the inscribed ball and the sphere */
                continue;
            }
            max_tol8 = fmax(max_tol8, tol8);
            min_tol8 = fmin(min_tol8, tol8);
            for (int c = 0; c < 3; c++) {
                const double err = fabs((double)img[c] - 255.0 * e[c]);
                max_err8 = fmax(max_err8, err);
                if (!(err <= tol8))
                    fail_msg("normals on sphere:5, pixel (%u, %u) channel %d: image %u, expected %.3f +- %.3f (%s)",
                             x, y, c, img[c], 255.0 * e[c], tol8, tol8 > 0.6 ? "sphere" : "sky");
            }
            assert_int_equal(img[3], 255);
        }
    print_message("normals on sphere:5 (%u facets) at %ux%u: facet angle theta_c %.4f deg, inscribed radius %.6f; "
                  "%zu sphere pixels within %.2f .. %.2f 8-bit levels (0.5 * 255 * theta + 0.5), %zu sky pixels "
                  "within 0.51, %zu silhouette pixels skipped; max error %.2f levels\n", mesh->triangle_count, w, h,
                  theta_c * 180.0 / M_PI, r_in, hit, min_tol8, max_tol8, sky, ring, max_err8);
    assert_true(hit > (size_t)w * h / 10 && sky > (size_t)w * h / 10);
    assert_true(ring * 100 <= (size_t)w * h); /* the ring is a thin band: at most 1 % of the pixels */
    assert_int_equal(f->counters[0].emitted, w * h);
    assert_int_equal(f->counters[0].conflicts, 0);
    rto_frame_destroy(f);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The stage2 scene: seed 002's shader transliterated to binary32 here                                               */

/* WGSL vec3<f32> helpers as the seed uses them (DESIGN.md §7: dot left to right, normalize = v / length(v)). */
typedef struct v3 {
    float x, y, z;
} v3;
static v3 v3_make(float x, float y, float z)
{
    v3 r = {x, y, z};
    return r;
}
static v3 v3_add(v3 a, v3 b) { return v3_make(a.x + b.x, a.y + b.y, a.z + b.z); }
static v3 v3_sub(v3 a, v3 b) { return v3_make(a.x - b.x, a.y - b.y, a.z - b.z); }
static v3 v3_mul(v3 a, v3 b) { return v3_make(a.x * b.x, a.y * b.y, a.z * b.z); }
static v3 v3_scale(float s, v3 a) { return v3_make(s * a.x, s * a.y, s * a.z); }
static float v3_dot(v3 a, v3 b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }
static v3 v3_normalize(v3 a)
{
    const float l = sqrtf(v3_dot(a, a));
    return v3_make(a.x / l, a.y / l, a.z / l);
}
/* WGSL min / max: numbers as IEEE; for NaN the frame's documented choice (the second operand). */
static float wmin(float a, float b) { return a < b ? a : b; }
static float wmax(float a, float b) { return a > b ? a : b; }
static float wsign(float a) { return a > 0.0f ? 1.0f : (a < 0.0f ? -1.0f : 0.0f); }

typedef struct seed_ray {
    v3 origin, direction;
} seed_ray;
typedef struct seed_hit {
    int hit;
    float t;
    v3 position, normal;
} seed_hit;

static seed_hit seed_sphere(seed_ray ray, v3 center, float radius)
{
    seed_hit result = {0, 0.0f, {0, 0, 0}, {0, 0, 0}};
    const v3 oc = v3_sub(ray.origin, center);
    const float a = v3_dot(ray.direction, ray.direction);
    const float b = 2.0f * v3_dot(oc, ray.direction);
    const float c = v3_dot(oc, oc) - radius * radius;
    const float discriminant = b * b - 4.0f * a * c;
    if (discriminant < 0.0f)
        return result;
    const float sqrt_d = sqrtf(discriminant);
    float t = (-b - sqrt_d) / (2.0f * a);
    if (t < 0.001f)
        t = (-b + sqrt_d) / (2.0f * a);
    if (t < 0.001f)
        return result;
    result.hit = 1;
    result.t = t;
    result.position = v3_add(ray.origin, v3_scale(t, ray.direction));
    result.normal = v3_normalize(v3_sub(result.position, center));
    return result;
}

static seed_hit seed_box(seed_ray ray, v3 center, v3 half)
{
    seed_hit result = {0, 0.0f, {0, 0, 0}, {0, 0, 0}};
    const v3 inv_dir = v3_make(1.0f / ray.direction.x, 1.0f / ray.direction.y, 1.0f / ray.direction.z);
    const v3 t0 = v3_mul(v3_sub(v3_sub(center, half), ray.origin), inv_dir);
    const v3 t1 = v3_mul(v3_sub(v3_add(center, half), ray.origin), inv_dir);
    const v3 tmin = v3_make(wmin(t0.x, t1.x), wmin(t0.y, t1.y), wmin(t0.z, t1.z));
    const v3 tmax = v3_make(wmax(t0.x, t1.x), wmax(t0.y, t1.y), wmax(t0.z, t1.z));
    const float t_near = wmax(wmax(tmin.x, tmin.y), tmin.z);
    const float t_far = wmin(wmin(tmax.x, tmax.y), tmax.z);
    if (t_near > t_far || t_far < 0.0f)
        return result;
    float t = t_near;
    if (t < 0.001f)
        t = t_far;
    if (t < 0.001f)
        return result;
    result.hit = 1;
    result.t = t;
    result.position = v3_add(ray.origin, v3_scale(t, ray.direction));
    const v3 p = v3_sub(result.position, center);
    const v3 d = half;
    result.normal = v3_normalize(v3_make((fabsf(p.x) > d.x - 0.001f ? 1.0f : 0.0f) * wsign(p.x),
                                         (fabsf(p.y) > d.y - 0.001f ? 1.0f : 0.0f) * wsign(p.y),
                                         (fabsf(p.z) > d.z - 0.001f ? 1.0f : 0.0f) * wsign(p.z)));
    return result;
}

static seed_hit seed_trace(seed_ray ray)
{
    seed_hit closest = {0, 999999.0f, {0, 0, 0}, {0, 0, 0}};
    const seed_hit s1 = seed_sphere(ray, v3_make(0.0f, 0.0f, 0.0f), 1.0f);
    if (s1.hit && s1.t < closest.t)
        closest = s1;
    const seed_hit s2 = seed_sphere(ray, v3_make(2.5f, 0.0f, -1.0f), 1.0f);
    if (s2.hit && s2.t < closest.t)
        closest = s2;
    const seed_hit b1 = seed_box(ray, v3_make(-2.5f, 0.0f, 0.0f), v3_make(0.75f, 0.75f, 0.75f));
    if (b1.hit && b1.t < closest.t)
        closest = b1;
    const seed_hit g = seed_box(ray, v3_make(0.0f, -1.5f, 0.0f), v3_make(10.0f, 0.5f, 10.0f));
    if (g.hit && g.t < closest.t)
        closest = g;
    return closest;
}

/* generateRay(pixelCoord + 0.5, resolution) with the column-major matrices of the uniform block. */
static seed_ray seed_generate(const rto_camera_uniforms *u, float px, float py, float rx, float ry)
{
    const float ndc_x = (px / rx) * 2.0f - 1.0f, ndc_y = 1.0f - (py / ry) * 2.0f;
    const float clip[4] = {ndc_x, ndc_y, -1.0f, 1.0f};
    float eye[4];
    for (int r = 0; r < 4; r++)
        eye[r] = ((u->inverse_projection[0 + r] * clip[0] + u->inverse_projection[4 + r] * clip[1]) +
                  u->inverse_projection[8 + r] * clip[2]) + u->inverse_projection[12 + r] * clip[3];
    const float ray_eye[4] = {eye[0], eye[1], -1.0f, 0.0f};
    float world[4];
    for (int r = 0; r < 4; r++)
        world[r] = ((u->inverse_view[0 + r] * ray_eye[0] + u->inverse_view[4 + r] * ray_eye[1]) +
                    u->inverse_view[8 + r] * ray_eye[2]) + u->inverse_view[12 + r] * ray_eye[3];
    seed_ray ray;
    ray.origin = v3_make(u->position[0], u->position[1], u->position[2]);
    ray.direction = v3_normalize(v3_make(world[0], world[1], world[2]));
    return ray;
}

static v3 seed_shade(seed_hit hit, seed_ray ray)
{
    if (!hit.hit) {
        const float t = 0.5f * (ray.direction.y + 1.0f);
        /* mix(a, b, t) = a (1 - t) + b t */
        const v3 a = v3_make(1.0f, 1.0f, 1.0f), b = v3_make(0.5f, 0.7f, 1.0f);
        return v3_add(v3_scale(1.0f - t, a), v3_scale(t, b));
    }
    return v3_add(v3_scale(0.5f, hit.normal), v3_make(0.5f, 0.5f, 0.5f));
}

/* rgba8unorm store: clamp to [0, 1], x * 255 rounded to nearest (NaN -> 0). */
static uint8_t unorm8(float x)
{
    if (!(x > 0.0f))
        return 0;
    if (x >= 1.0f)
        return 255;
    return (uint8_t)floorf(x * 255.0f + 0.5f);
}

static void test_stage2_seed(void **state)
{
    (void)state;
    const uint32_t w = 160, h = 120;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = builtin("normals");
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.width = w;
    d.height = h;
    d.keep = RTO_FRAME_KEEP_ACCUM | RTO_FRAME_KEEP_HITS;
    rto_frame *f = render(&d);
    frame_basics(f, w, h);
    /* The seed's default camera (§2.2): position (0, 2, 5), target 0, up +y, fovY 60 degrees, the image's aspect. */
    rto_camera seed_cam;
    memset(&seed_cam, 0, sizeof seed_cam);
    seed_cam.position = (rto_vec3){0.0f, 2.0f, 5.0f};
    seed_cam.target = (rto_vec3){0.0f, 0.0f, 0.0f};
    seed_cam.up = (rto_vec3){0.0f, 1.0f, 0.0f};
    seed_cam.fov_y = (float)(M_PI / 3.0);
    seed_cam.znear = f->camera.znear; /* the seed gives none; they only reach the z and w rows */
    seed_cam.zfar = f->camera.zfar;
    assert_true(f->camera.position.x == 0.0f && f->camera.position.y == 2.0f && f->camera.position.z == 5.0f);
    assert_true(f->camera.target.x == 0.0f && f->camera.target.y == 0.0f && f->camera.target.z == 0.0f);
    assert_true(f->camera.up.x == 0.0f && f->camera.up.y == 1.0f && f->camera.up.z == 0.0f);
    assert_true(f->camera.fov_y == seed_cam.fov_y);
    const int differ = check_uniforms(f, &seed_cam);
    /* The evaluation runs on the frame's own block, checked above to be the closed forms' within the last bit, so a
     * rounding difference of the inverse cannot move a silhouette pixel; how many elements differ is printed. */
    const rto_camera_uniforms *u = &f->camera_uniforms;
    size_t exact = 0, off1 = 0, wrong = 0, hits = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const size_t p = (size_t)y * w + x;
            const seed_ray ray = seed_generate(u, (float)x + 0.5f, (float)y + 0.5f, (float)w, (float)h);
            const seed_hit hit = seed_trace(ray);
            hits += hit.hit != 0;
            const v3 c = seed_shade(hit, ray);
            const uint8_t e[4] = {unorm8(c.x), unorm8(c.y), unorm8(c.z), 255};
            const uint8_t *img = &f->image[4 * p];
            int worst = 0;
            for (int k = 0; k < 4; k++)
                worst = abs((int)img[k] - (int)e[k]) > worst ? abs((int)img[k] - (int)e[k]) : worst;
            exact += worst == 0;
            off1 += worst == 1;
            if (worst > 1 && wrong++ < 10)
                print_error("stage2 pixel (%u, %u): image %u %u %u %u, seed %u %u %u %u (%s t %.9g, colour %.9g %.9g "
                            "%.9g)\n", x, y, img[0], img[1], img[2], img[3], e[0], e[1], e[2], e[3],
                            hit.hit ? "hit" : "miss", (double)hit.t, (double)c.x, (double)c.y, (double)c.z);
            /* The linear accum is the colour itself (cleared to 0, one accumulate). */
            const float *a4 = &f->accum[4 * p];
            const float ec[3] = {c.x, c.y, c.z};
            for (int k = 0; k < 3; k++)
                if (!(a4[k] == ec[k] || (isnan(a4[k]) && isnan(ec[k]))) && wrong++ < 10)
                    print_error("stage2 pixel (%u, %u) accum[%d] %.9g, seed %.9g\n", x, y, k, (double)a4[k],
                                (double)ec[k]);
            /* And the frame's hit record of the primary ray has the seed's t. */
            const rto_hit_record *hr = &f->queues[0].hits[p];
            if ((hr->miss_flag == 0) != (hit.hit != 0) || (hit.hit && hr->t != hit.t))
                if (wrong++ < 10)
                    print_error("stage2 pixel (%u, %u): hit record %s t %.9g, seed %s t %.9g\n", x, y,
                                hr->miss_flag ? "miss" : "hit", (double)hr->t, hit.hit ? "hit" : "miss",
                                (double)hit.t);
        }
    print_message("stage2 160x120 against seed 002's shader in binary32: %zu pixels exact, %zu within +-1, %zu wrong; "
                  "%zu hits; %d uniform elements differ from the closed forms by one ulp\n", exact, off1, wrong, hits,
                  differ);
    assert_int_equal(wrong, 0);
    assert_int_equal(off1, 0);
    assert_int_equal(exact, (size_t)w * h);
    assert_true(hits > (size_t)w * h / 4 && hits < (size_t)w * h);
    rto_frame_destroy(f);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Capacity: drops, refused emits, conflicts                                                                         */

/* Payload of the test programs: where the ray came from. */
typedef struct test_payload {
    uint32_t depth, pixel, j, magic;
} test_payload;
#define TEST_MAGIC 0x5EEDC0DEu

/* A ray of the stage2 scene: from (0, 0, 5) down -z (hits sphere 1 at t = 4) for an even pixel, up +z (a miss) for
 * an odd one. */
static rto_wf_ray test_ray(uint32_t pixel, uint32_t depth)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    r.origin[2] = 5.0f;
    r.dir[2] = (pixel % 2) ? 1.0f : -1.0f;
    r.t_max = 1e30f;
    r.flags = 0x1u;
    r.cull_mask = 0xFFu;
    r.kind = depth;
    return r;
}

/* Flood: raygen emits 2 rays where x == 0 or (x + y) % 3 == 0, else 1, and tries a third where x == 0 (refused);
 * every shading invocation emits 2 rays of the next depth, and tries a third when its pixel % 7 == 0 (refused). */
static uint32_t flood_primary(uint32_t x, uint32_t y) { return (x == 0 || (x + y) % 3 == 0) ? 2u : 1u; }

static void flood_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const uint32_t n = flood_primary(x, y) + (x == 0);
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {0, p, j, TEST_MAGIC};
        const rto_wf_ray r = test_ray(p, 0);
        rto_emit_primary_ray(ctx, &r, &pl);
    }
}

static void flood_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const test_payload *in = payload;
    const uint32_t n = 2 + (ray->pixel % 7 == 0);
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {in->depth + 1, ray->pixel, j, in->magic};
        const rto_wf_ray r = test_ray(ray->pixel, in->depth + 1);
        rto_emit_ray(ctx, &r, &pl);
    }
}

static void flood_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    flood_shade(ctx, ray, payload);
}

static const rto_program flood_program = {
    RTO_PROGRAM_ABI_VERSION, "test-flood", "emits past the queue capacity", sizeof(test_payload), 2, NULL, 0, NULL,
    NULL, flood_raygen, flood_hit, flood_shade, NULL,
};

/* The serial queue rules, simulated: a queue is a list of (pixel, j) in emit order, cut at the capacity. */
typedef struct sim_queue {
    uint32_t *pixel, *j, *depth_payload;
    size_t n, emitted, refused, hits;
} sim_queue;

static void sim_push(sim_queue *q, size_t cap, uint32_t pixel, uint32_t j, uint8_t *dropped_mask)
{
    q->emitted++;
    if (q->n < cap) {
        q->pixel[q->n] = pixel;
        q->j[q->n] = j;
        q->n++;
    } else {
        dropped_mask[pixel] |= RTO_PIXEL_DROPPED;
    }
}

static void check_flood(const rto_frame *f, uint32_t w, uint32_t h)
{
    const size_t wh = (size_t)w * h, cap = 2 * wh;
    frame_basics(f, w, h);
    assert_int_equal(f->max_depth, 2);
    sim_queue q[3];
    uint8_t *mask = calloc(wh, 1);
    assert_non_null(mask);
    for (int d = 0; d < 3; d++) {
        memset(&q[d], 0, sizeof q[d]);
        q[d].pixel = calloc(cap, sizeof(uint32_t));
        q[d].j = calloc(cap, sizeof(uint32_t));
        assert_true(q[d].pixel && q[d].j);
    }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint32_t p = y * w + x;
            for (uint32_t j = 0; j < flood_primary(x, y); j++)
                sim_push(&q[0], cap, p, j, mask);
            q[0].refused += x == 0;
        }
    for (int d = 0; d < 2; d++)
        for (size_t i = 0; i < q[d].n; i++) {
            q[d].hits += q[d].pixel[i] % 2 == 0;
            for (uint32_t j = 0; j < 2; j++)
                sim_push(&q[d + 1], cap, q[d].pixel[i], j, mask);
            q[d + 1].refused += q[d].pixel[i] % 7 == 0;
        }
    for (int d = 0; d < 3; d++) {
        const rto_frame_counters *c = &f->counters[d];
        print_message("flood %ux%u queue %d: emitted %u (expected %zu), queued %u, dropped %u (expected %zu), refused "
                      "%u (expected %zu)\n", w, h, d, c->emitted, q[d].emitted, c->queued, c->dropped,
                      q[d].emitted - q[d].n, c->refused, q[d].refused);
        assert_int_equal(c->emitted, q[d].emitted);
        assert_int_equal(c->queued, q[d].n);
        assert_int_equal(c->dropped, q[d].emitted - q[d].n);
        assert_int_equal(c->refused, q[d].refused);
        if (d < 2) {
            assert_int_equal(c->hits, q[d].hits);
            assert_int_equal(c->misses, q[d].n - q[d].hits);
            assert_int_equal(c->shaded, q[d].n);
        }
        assert_int_equal(c->accumulates, 0);
        assert_int_equal(c->conflicts, 0);
        /* The kept queue in serial order: pixel, kind, payloadSlot = pixel + j W H, and the payload as emitted. */
        const rto_frame_queue *fq = &f->queues[d];
        assert_int_equal(fq->count, q[d].n);
        assert_non_null(fq->rays);
        assert_non_null(fq->payloads);
        for (size_t i = 0; i < q[d].n; i++) {
            const rto_wf_ray *r = &fq->rays[i];
            const uint32_t *pl = &fq->payloads[i * (sizeof(test_payload) / 4)];
            if (r->pixel != q[d].pixel[i] || r->payload_slot != q[d].pixel[i] + q[d].j[i] * (uint32_t)wh ||
                r->kind != (uint32_t)d || pl[0] != (uint32_t)d || pl[1] != q[d].pixel[i] || pl[2] != q[d].j[i] ||
                pl[3] != TEST_MAGIC)
                fail_msg("flood queue %d ray %zu: pixel %u slot %u kind %u payload %u %u %u %x; expected pixel %u "
                         "slot %u kind %d payload %d %u %u %x", d, i, r->pixel, r->payload_slot, r->kind, pl[0],
                         pl[1], pl[2], pl[3], q[d].pixel[i], q[d].pixel[i] + q[d].j[i] * (uint32_t)wh, d, d,
                         q[d].pixel[i], q[d].j[i], TEST_MAGIC);
        }
    }
    size_t marked = 0;
    for (size_t p = 0; p < wh; p++) {
        if (f->not_comparable[p] != mask[p])
            fail_msg("flood: pixel %zu not_comparable 0x%x, expected 0x%x", p, f->not_comparable[p], mask[p]);
        marked += mask[p] != 0;
    }
    assert_true(marked > 0);
    assert_true(f->invalid_calls == 0);
    for (int d = 0; d < 3; d++) {
        free(q[d].pixel);
        free(q[d].j);
    }
    free(mask);
}

static void test_capacity_drops(void **state)
{
    (void)state;
    const uint32_t sizes[2][2] = {{8, 5}, {13, 7}};
    for (int k = 0; k < 2; k++) {
        rto_frame_desc d;
        memset(&d, 0, sizeof d);
        d.program = &flood_program;
        d.scene_kind = RTO_FRAME_SCENE_STAGE2;
        d.width = sizes[k][0];
        d.height = sizes[k][1];
        d.keep = RTO_FRAME_KEEP_ALL;
        rto_frame *f = render(&d);
        /* By hand for 8x5 (W H = 40, capacity 80): queue 0 holds 40 + 16 = 56 rays (two for the 5 pixels x == 0 and
         * the 11 with (x + y) % 3 == 0, x > 0), 5 refused; queue 1: 112 emits, 80 kept, 32 dropped, 7 refused (the
         * rays of pixels 0, 7, .., 35: pixel 0 has two); queue 2: 160 emits, 80 kept, 80 dropped. */
        if (k == 0) {
            assert_int_equal(f->counters[0].emitted, 56);
            assert_int_equal(f->counters[0].refused, 5);
            assert_int_equal(f->counters[1].emitted, 112);
            assert_int_equal(f->counters[1].dropped, 32);
            assert_int_equal(f->counters[1].refused, 7);
            assert_int_equal(f->counters[2].emitted, 160);
            assert_int_equal(f->counters[2].dropped, 80);
        }
        check_flood(f, d.width, d.height);
        rto_frame_destroy(f);
    }
}

/* Conflicts: raygen emits 2 rays for pixels p % 5 == 0, else 1; each shading accumulates (1, 2, 4) * (j + 1) into
 * its pixel; a ray of a pixel p % 7 == 3 accumulates twice into its pixel (one ray: not a conflict); the first ray
 * of a pixel p % 11 == 4 also accumulates (8, 0, 0) into pixel p + 1 (a second ray there: a conflict). */
static void conflict_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const uint32_t n = p % 5 == 0 ? 2u : 1u;
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {0, p, j, TEST_MAGIC};
        const rto_wf_ray r = test_ray(p, 0);
        rto_emit_primary_ray(ctx, &r, &pl);
    }
}

static void conflict_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const test_payload *in = payload;
    const uint32_t p = ray->pixel, wh = ctx->env->width * ctx->env->height;
    const float s = (float)(in->j + 1);
    const float rgb[3] = {1.0f * s, 2.0f * s, 4.0f * s};
    rto_accumulate(ctx, p, rgb);
    if (p % 7 == 3)
        rto_accumulate(ctx, p, rgb);
    if (p % 11 == 4 && in->j == 0 && p + 1 < wh) {
        const float other[3] = {8.0f, 0.0f, 0.0f};
        rto_accumulate(ctx, p + 1, other);
    }
}

static void conflict_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    conflict_shade(ctx, ray, payload);
}

static const rto_program conflict_program = {
    RTO_PROGRAM_ABI_VERSION, "test-conflict", "accumulates from two rays into one pixel", sizeof(test_payload), 1,
    NULL, 0, NULL, NULL, conflict_raygen, conflict_hit, conflict_shade, NULL,
};

static void check_conflicts(const rto_frame *f, uint32_t w, uint32_t h)
{
    const uint32_t wh = w * h;
    frame_basics(f, w, h);
    double *acc = calloc(3 * (size_t)wh, sizeof *acc);
    uint32_t *rays_in = calloc(wh, sizeof *rays_in); /* distinct rays accumulating into each pixel */
    assert_true(acc && rays_in);
    uint32_t calls = 0, emitted = 0;
    for (uint32_t p = 0; p < wh; p++) {
        const uint32_t n = p % 5 == 0 ? 2u : 1u;
        emitted += n;
        for (uint32_t j = 0; j < n; j++) {
            const double s = j + 1.0;
            const uint32_t times = p % 7 == 3 ? 2u : 1u;
            for (int c = 0; c < 3; c++)
                acc[3 * p + c] += times * s * (c == 0 ? 1.0 : c == 1 ? 2.0 : 4.0);
            calls += times;
            rays_in[p]++;
            if (p % 11 == 4 && j == 0 && p + 1 < wh) {
                acc[3 * (p + 1)] += 8.0;
                calls++;
                rays_in[p + 1]++;
            }
        }
    }
    uint32_t conflicts = 0;
    for (uint32_t p = 0; p < wh; p++) {
        const uint8_t want = rays_in[p] >= 2 ? RTO_PIXEL_CONFLICT : 0;
        conflicts += want != 0;
        if (f->not_comparable[p] != want)
            fail_msg("conflict %ux%u: pixel %u not_comparable 0x%x, expected 0x%x (%u rays)", w, h, p,
                     f->not_comparable[p], want, rays_in[p]);
        for (int c = 0; c < 3; c++)
            if ((double)f->accum[4 * (size_t)p + (size_t)c] != acc[3 * p + c])
                fail_msg("conflict %ux%u: pixel %u accum[%d] %g, expected %g", w, h, p, c,
                         (double)f->accum[4 * (size_t)p + (size_t)c], acc[3 * p + c]);
        assert_true(f->accum[4 * (size_t)p + 3] == 1.0f);
    }
    const rto_frame_counters *c0 = &f->counters[0];
    print_message("conflict %ux%u: %u accumulates, %u conflicts (expected %u, %u)\n", w, h, c0->accumulates,
                  c0->conflicts, calls, conflicts);
    assert_int_equal(c0->emitted, emitted);
    assert_int_equal(c0->accumulates, calls);
    assert_int_equal(c0->conflicts, conflicts);
    assert_true(conflicts > 0);
    assert_int_equal(c0->dropped, 0);
    assert_true(f->invalid_calls == 0);
    free(acc);
    free(rays_in);
}

static void test_conflicts(void **state)
{
    (void)state;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = &conflict_program;
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.width = 17;
    d.height = 9;
    d.keep = RTO_FRAME_KEEP_ALL;
    rto_frame *f = render(&d);
    check_conflicts(f, d.width, d.height);
    rto_frame_destroy(f);
}

/* Calls the frame must refuse: emit_ray from raygen, emit_primary_ray from shading, accumulate past the image. */
static void misuse_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const rto_wf_ray r = test_ray(p, 0);
    const test_payload pl = {0, p, 0, TEST_MAGIC};
    rto_emit_primary_ray(ctx, &r, &pl);
    if (p == 0)
        rto_emit_ray(ctx, &r, &pl);
}

static void misuse_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const float one[3] = {1.0f, 1.0f, 1.0f};
    rto_accumulate(ctx, ray->pixel, one);
    if (ray->pixel == 1)
        rto_accumulate(ctx, ctx->env->width * ctx->env->height, one);
    if (ray->pixel == 2)
        rto_emit_primary_ray(ctx, ray, payload);
}

static void misuse_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    misuse_shade(ctx, ray, payload);
}

static const rto_program misuse_program = {
    RTO_PROGRAM_ABI_VERSION, "test-misuse", "calls out of place", sizeof(test_payload), 1, NULL, 0, NULL, NULL,
    misuse_raygen, misuse_hit, misuse_shade, NULL,
};

static void test_invalid_calls(void **state)
{
    (void)state;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = &misuse_program;
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.width = 5;
    d.height = 3;
    d.keep = RTO_FRAME_KEEP_ALL;
    rto_frame *f = render(&d);
    frame_basics(f, 5, 3);
    /* Three misplaced calls, none of which stored a ray or touched the accum. */
    assert_true(f->invalid_calls == 3);
    assert_int_equal(f->counters[0].emitted, 15);
    assert_int_equal(f->counters[1].emitted, 0);
    for (uint32_t p = 0; p < 15; p++)
        for (int c = 0; c < 3; c++)
            assert_true(f->accum[4 * p + (uint32_t)c] == 1.0f);
    rto_frame_destroy(f);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Thread counts: the same bytes                                                                                     */

/* `how` names the two runs compared ("1 and 3 threads"). */
static void same_bytes(const void *a, const void *b, size_t n, const char *what, const char *how)
{
    if (n == 0)
        return;
    if (!a || !b)
        fail_msg("%s: kept in the first run %s, in the second %s (%s)", what, a ? "yes" : "no", b ? "yes" : "no", how);
    if (memcmp(a, b, n)) {
        const uint8_t *x = a, *y = b;
        size_t i = 0;
        while (x[i] == y[i])
            i++;
        fail_msg("%s differs between %s at byte %zu of %zu", what, how, i, n);
    }
}

static void compare_frames(const rto_frame *a, const rto_frame *b, const char *threads)
{
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    assert_int_equal(a->max_depth, b->max_depth);
    assert_int_equal(a->payload_size, b->payload_size);
    assert_int_equal(a->keep, b->keep);
    const size_t wh = (size_t)a->width * a->height, rows = a->max_depth + 1;
    same_bytes(&a->camera_uniforms, &b->camera_uniforms, sizeof a->camera_uniforms, "camera uniforms", threads);
    same_bytes(a->counters, b->counters, rows * sizeof *a->counters, "frame counters", threads);
    same_bytes(a->indirect_args, b->indirect_args, rows * sizeof *a->indirect_args, "indirect args", threads);
    for (size_t d = 0; d < rows; d++) {
        const rto_frame_queue *qa = &a->queues[d], *qb = &b->queues[d];
        char what[64];
        assert_int_equal(qa->count, qb->count);
        snprintf(what, sizeof what, "queue %zu rays", d);
        same_bytes(qa->rays, qb->rays, qa->rays ? qa->count * sizeof *qa->rays : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu payloads", d);
        same_bytes(qa->payloads, qb->payloads, qa->payloads ? qa->count * a->payload_size : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu hits", d);
        same_bytes(qa->hits, qb->hits, qa->hits ? qa->count * sizeof *qa->hits : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu trace counters", d);
        same_bytes(qa->trace_counters, qb->trace_counters,
                   qa->trace_counters ? qa->count * sizeof *qa->trace_counters : 0, what, threads);
    }
    same_bytes(a->accum, b->accum, a->accum ? 4 * wh * sizeof(float) : 0, "accum", threads);
    same_bytes(a->image, b->image, 4 * wh, "image", threads);
    same_bytes(a->not_comparable, b->not_comparable, wh, "not_comparable", threads);
    assert_true(a->invalid_calls == b->invalid_calls);
}

static void threads_case(rto_frame_desc *d, const char *label)
{
    d->threads = 1;
    d->keep = RTO_FRAME_KEEP_ALL;
    rto_frame *one = render(d);
    const uint32_t counts[3] = {2, 3, 7};
    for (int k = 0; k < 3; k++) {
        d->threads = counts[k];
        rto_frame *f = render(d);
        char how[48];
        snprintf(how, sizeof how, "1 and %u threads", counts[k]);
        compare_frames(one, f, how);
        rto_frame_destroy(f);
    }
    uint64_t rays = 0;
    for (uint32_t q = 0; q <= one->max_depth; q++)
        rays += one->counters[q].queued;
    print_message("%s: threads 1, 2, 3, 7 give the same bytes (%u queues, %llu rays in all)\n", label,
                  one->max_depth + 1, (unsigned long long)rays);
    rto_frame_destroy(one);
}

/* Chunk sizes: a pass run in chunks of 1, 5 or 64 items (each chunk's logs applied before the next) gives the bytes
 * of the same pass run whole, drops at capacity and conflicts included. */
static void chunks_case(rto_frame_desc *d, const char *label)
{
    const size_t saved = rto__frame_chunk;
    d->threads = 3;
    d->keep = RTO_FRAME_KEEP_ALL;
    rto__frame_chunk = SIZE_MAX;
    rto_frame *whole = render(d);
    const size_t chunks[3] = {1, 5, 64};
    for (int k = 0; k < 3; k++) {
        rto__frame_chunk = chunks[k];
        rto_frame *f = render(d);
        char how[64];
        snprintf(how, sizeof how, "one chunk and chunks of %zu", chunks[k]);
        compare_frames(whole, f, how);
        rto_frame_destroy(f);
    }
    rto__frame_chunk = saved;
    print_message("%s: chunks of 1, 5, 64 give the bytes of one chunk\n", label);
    rto_frame_destroy(whole);
}

/* The frames both sweeps below run, each at its own size (W, H in sizes): sun-shadow on a mesh scene (primary and
 * shadow rays, two bounces), normals on stage2, and the flood and conflict programs (drops and conflicts must be the
 * same pixels whatever the threads or chunks). */
static void frame_cases(void (*run)(rto_frame_desc *, const char *), const uint32_t sizes[4][2])
{
    rto_scene *s = tu_load("sphere:3");
    rto_accel *acc = build(s);
    char label[64];
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = builtin("sun-shadow");
    d.accel = acc;
    d.width = sizes[0][0];
    d.height = sizes[0][1];
    d.max_depth = 2;
    snprintf(label, sizeof label, "sun-shadow on sphere:3 %ux%u", d.width, d.height);
    run(&d, label);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
    const rto_program *const programs[3] = {builtin("normals"), &flood_program, &conflict_program};
    for (int k = 0; k < 3; k++) {
        memset(&d, 0, sizeof d);
        d.program = programs[k];
        d.scene_kind = RTO_FRAME_SCENE_STAGE2;
        d.width = sizes[k + 1][0];
        d.height = sizes[k + 1][1];
        snprintf(label, sizeof label, "%s on stage2 %ux%u", programs[k]->name, d.width, d.height);
        run(&d, label);
    }
}

static void test_threads_identical(void **state)
{
    (void)state;
    static const uint32_t sizes[4][2] = {{67, 41}, {61, 37}, {23, 11}, {31, 13}};
    frame_cases(threads_case, sizes);
}

static void test_chunks_identical(void **state)
{
    (void)state;
    static const uint32_t sizes[4][2] = {{29, 17}, {19, 11}, {13, 7}, {13, 7}};
    frame_cases(chunks_case, sizes);
    /* and against the serial simulations: queues cut at capacity, conflicts per pass */
    const size_t saved = rto__frame_chunk;
    rto__frame_chunk = 5;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.keep = RTO_FRAME_KEEP_ALL;
    d.width = 13;
    d.height = 7;
    d.program = &flood_program;
    rto_frame *f = render(&d);
    check_flood(f, d.width, d.height);
    rto_frame_destroy(f);
    d.program = &conflict_program;
    d.width = 17;
    d.height = 9;
    f = render(&d);
    check_conflicts(f, d.width, d.height);
    rto_frame_destroy(f);
    rto__frame_chunk = saved;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_triangle_analytic),
        cmocka_unit_test(test_normals_sphere),
        cmocka_unit_test(test_stage2_seed),
        cmocka_unit_test(test_capacity_drops),
        cmocka_unit_test(test_conflicts),
        cmocka_unit_test(test_invalid_calls),
        cmocka_unit_test(test_threads_identical),
        cmocka_unit_test(test_chunks_identical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
