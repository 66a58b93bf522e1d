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
 * - capacity (test_programs_capacity.c): programs defined there that overflow the 2 W H queues, exceed the
 *   per-invocation emit budget and accumulate into one pixel from several rays, checked against a serial simulation
 *   of the queue rules; thread counts 1, 2, 3 and 7 give the same bytes in every buffer.
 * This file holds the shared helpers, the built-in programs' tests and main(); one executable (unit.programs). */
#include "test_programs.h"

#include <float.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Helpers                                                                                                          */

rto_accel *build(const rto_scene *s)
{
    rto_accel *a = NULL;
    rto_msg msg = {{0}};
    if (rto_accel_build(s, NULL, &a, &msg))
        fail_msg("rto_accel_build(%s): %s", s->source, msg.text);
    return a;
}

rto_frame *render(const rto_frame_desc *d)
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

const rto_program *builtin(const char *name)
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

void frame_basics(const rto_frame *f, uint32_t w, uint32_t h)
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
