/* Cameras (DESIGN.md §7, seed 002 §2.2-2.3) and the procedural scenes made for tracing tests (sphere:L[:SEED],
 * random:SEED). Expected values come from independent derivations in binary64: the closed-form inverses of lookAt
 * (the transposed rotation plus the eye) and of the OpenGL perspective, the pinhole model's direction for each pixel,
 * frustum tests of the framing, and a half-edge count for closed meshes; main(). One executable (unit.rays) with
 * test_rays_sets.c (the generated ray sets). */
#include "test_rays.h"

#include <float.h>
#include <math.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Helpers                                                                                                          */

/* The camera's orthonormal frame in binary64, from its definition: forward f = normalize(target - eye), right
 * x = normalize(f x up), true up y = x x f. (lookAt's z axis is -f.) */
typedef struct frame {
    double eye[3], x[3], y[3], f[3];
} frame;

static frame camera_frame_d(const rto_camera *c)
{
    frame fr;
    const double eye[3] = {c->position.x, c->position.y, c->position.z};
    const double tgt[3] = {c->target.x, c->target.y, c->target.z};
    const double up[3] = {c->up.x, c->up.y, c->up.z};
    memcpy(fr.eye, eye, sizeof eye);
    tu_sub3(tgt, eye, fr.f);
    tu_unit3(fr.f);
    tu_cross3(fr.f, up, fr.x);
    tu_unit3(fr.x);
    tu_cross3(fr.x, fr.f, fr.y);
    return fr;
}

/* The pinhole direction of pixel (x, y) in binary64: the pixel centre on the image plane at distance 1,
 * ((2 (x + 0.5) / W - 1) tan(fov / 2) aspect, (1 - 2 (y + 0.5) / H) tan(fov / 2)), row 0 at the top. */
static void pinhole_dir(const rto_camera *c, const frame *fr, uint32_t w, uint32_t h, uint32_t x, uint32_t y,
                        double d[3])
{
    const double aspect = c->aspect > 0 ? c->aspect : (double)w / h, t = tan(c->fov_y / 2.0);
    const double sx = (2.0 * (x + 0.5) / w - 1.0) * t * aspect, sy = (1.0 - 2.0 * (y + 0.5) / h) * t;
    for (int k = 0; k < 3; k++)
        d[k] = fr->f[k] + sx * fr->x[k] + sy * fr->y[k];
    tu_unit3(d);
}

/* The glTF-like camera of the tests: an arbitrary pose (what the loader makes of a node: target one unit ahead,
 * unit up orthogonal to the view), its own aspect, near and far. */
rto_camera gltf_like_camera(void)
{
    rto_camera c = rto_camera_default();
    snprintf(c.name, sizeof c.name, "gltf-like");
    double f[3] = {0.3, -0.4, -0.866}, up0[3] = {0, 1, 0}, x[3], y[3];
    tu_unit3(f);
    tu_cross3(f, up0, x);
    tu_unit3(x);
    tu_cross3(x, f, y);
    c.position = (rto_vec3){12.5f, -3.25f, 40.0f};
    c.target = (rto_vec3){(float)(12.5 + f[0]), (float)(-3.25 + f[1]), (float)(40.0 + f[2])};
    c.up = (rto_vec3){(float)y[0], (float)y[1], (float)y[2]};
    c.fov_y = 0.6911112f; /* 39.6 degrees, Blender's default */
    c.aspect = 1.5f;
    c.znear = 0.01f;
    c.zfar = 1000.0f;
    return c;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Names                                                                                                            */

static void test_ray_set_names(void **state)
{
    (void)state;
    static const char *names[] = {"primary", "shadow", "random", "grazing", "axis"};
    assert_int_equal(RTO_RAY_SET_COUNT, 5);
    for (int k = 0; k < RTO_RAY_SET_COUNT; k++) {
        assert_string_equal(rto_ray_set_name((rto_ray_set)k), names[k]);
        rto_ray_set s = (rto_ray_set)99;
        assert_int_equal(rto_ray_set_parse(names[k], &s), 1);
        assert_int_equal(s, k);
    }
    assert_null(rto_ray_set_name((rto_ray_set)5));
    assert_null(rto_ray_set_name((rto_ray_set)-1));
    rto_ray_set s = RTO_RAYS_AXIS;
    const char *bad[] = {"", "Primary", "primary ", "shadows", "rays.npy"};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        assert_int_equal(rto_ray_set_parse(bad[k], &s), 0);
        assert_int_equal(s, RTO_RAYS_AXIS);
    }
    assert_int_equal(rto_ray_set_parse(NULL, &s), 0);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Camera uniforms                                                                                                  */

/* The uniform block against closed forms: inverseView = [x | y | z | eye] with lookAt's axes z = -f, x, y (its
 * rotation transposed, then the eye as translation); inverseProjection of gl-matrix's perspectiveNO has
 * [0] = aspect tan(fov/2), [5] = tan(fov/2), [11] = (n - f) / (2 f n), [14] = -1, [15] = (f + n) / (2 f n), zeros
 * elsewhere. The library inverts the binary64 matrices by cofactors and rounds once, so each element is within one
 * binary32 ulp of the closed form (and within 1e-12 of a zero). */
static void check_uniforms(const rto_camera *c, uint32_t w, uint32_t h)
{
    rto_camera_uniforms u;
    memset(&u, 0xAB, sizeof u);
    rto_msg msg = {{0}};
    if (rto_camera_uniforms_make(c, w, h, &u, &msg))
        fail_msg("camera '%s' %ux%u: %s", c->name, w, h, msg.text);
    const frame fr = camera_frame_d(c);
    double iv[16] = {0}, ip[16] = {0};
    for (int k = 0; k < 3; k++) {
        iv[0 + k] = fr.x[k];
        iv[4 + k] = fr.y[k];
        iv[8 + k] = -fr.f[k];
        iv[12 + k] = fr.eye[k];
    }
    iv[15] = 1.0;
    const double aspect = c->aspect > 0 ? c->aspect : (double)w / h, t = tan(c->fov_y / 2.0);
    const double n = c->znear, f = c->zfar;
    ip[0] = aspect * t;
    ip[5] = t;
    ip[11] = (n - f) / (2.0 * f * n);
    ip[14] = -1.0;
    ip[15] = (f + n) / (2.0 * f * n);
    for (int k = 0; k < 16; k++) {
        const double tol_v = 0x1p-23 * fabs(iv[k]) + 1e-12, tol_p = 0x1p-23 * fabs(ip[k]) + 1e-12;
        if (fabs((double)u.inverse_view[k] - iv[k]) > tol_v)
            fail_msg("camera '%s' %ux%u: inverseView[%d] = %.9g, closed form %.17g", c->name, w, h, k,
                     (double)u.inverse_view[k], iv[k]);
        if (fabs((double)u.inverse_projection[k] - ip[k]) > tol_p)
            fail_msg("camera '%s' %ux%u: inverseProjection[%d] = %.9g, closed form %.17g", c->name, w, h, k,
                     (double)u.inverse_projection[k], ip[k]);
    }
    assert_true(u.position[0] == c->position.x && u.position[1] == c->position.y && u.position[2] == c->position.z);
    assert_true(u.pad == 0.0f && !signbit(u.pad));
}

static void test_camera_uniforms(void **state)
{
    (void)state;
    const rto_camera def = rto_camera_default();
    check_uniforms(&def, 160, 120);
    check_uniforms(&def, 1920, 1080);
    check_uniforms(&def, 1, 1);
    const rto_camera g = gltf_like_camera();
    check_uniforms(&g, 160, 120); /* aspect 1.5 from the camera, not 4 / 3 from the image */
    /* The default camera at 160x120, pinned: 0.1 / 100, tan(30 deg) = 0.57735..., aspect 4/3. */
    rto_camera_uniforms u;
    rto_msg msg = {{0}};
    assert_int_equal(rto_camera_uniforms_make(&def, 160, 120, &u, &msg), RTO_OK);
    assert_true(u.inverse_projection[0] == (float)(4.0 / 3.0 * tan(3.14159265358979323846 / 6.0)));
    assert_true(u.inverse_projection[14] == -1.0f);
    assert_true(u.inverse_view[15] == 1.0f);
    /* Seeded random cameras: any pose, fov, aspect and depth range. */
    for (uint32_t k = 0; k < 300; k++) {
        rto_camera c = rto_camera_default();
        snprintf(c.name, sizeof c.name, "random-%u", k);
        float v[9];
        for (int j = 0; j < 9; j++)
            v[j] = rto_unit(k, (uint32_t)j) * 20.0f - 10.0f;
        c.position = (rto_vec3){v[0], v[1], v[2]};
        c.target = (rto_vec3){v[3], v[4], v[5]};
        c.up = (rto_vec3){v[6], v[7], v[8]};
        c.fov_y = 0.05f + rto_unit(k, 9) * 3.0f;
        c.aspect = (k & 1) ? 0.25f + rto_unit(k, 10) * 3.0f : 0.0f;
        c.znear = 1e-3f + rto_unit(k, 11);
        c.zfar = c.znear * (2.0f + rto_unit(k, 12) * 1000.0f);
        /* The closed form needs the up vector's tilt to be taken out: the frame of check_uniforms does that. */
        check_uniforms(&c, 1 + rto_rng(k, 13) % 4000, 1 + rto_rng(k, 14) % 4000);
    }
}

static void expect_camera_refusal(rto_camera c, uint32_t w, uint32_t h, const char *substring)
{
    rto_camera_uniforms u;
    memset(&u, 0x5A, sizeof u);
    const rto_camera_uniforms before = u;
    rto_msg msg = {{0}};
    assert_int_equal(rto_camera_uniforms_make(&c, w, h, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    if (!strstr(msg.text, substring))
        fail_msg("expected '%s' in '%s'", substring, msg.text);
    assert_null(strchr(msg.text, '\n'));
    assert_memory_equal(&u, &before, sizeof u); /* nothing written on refusal */
}

static void test_camera_refusals(void **state)
{
    (void)state;
    const rto_camera d = rto_camera_default();
    rto_camera c = d;
    c.target = c.position;
    expect_camera_refusal(c, 16, 16, "target is at the eye");
    c = d;
    c.up = (rto_vec3){0, 0, 0};
    expect_camera_refusal(c, 16, 16, "up vector");
    c = d;
    c.up = (rto_vec3){0, -2, -5}; /* along the view direction (0, -2, -5) */
    expect_camera_refusal(c, 16, 16, "parallel to the view direction");
    c = d;
    c.fov_y = 0.0f;
    expect_camera_refusal(c, 16, 16, "fovY");
    c.fov_y = -0.5f;
    expect_camera_refusal(c, 16, 16, "fovY");
    c.fov_y = 3.1415927f; /* pi rounded up to binary32 */
    expect_camera_refusal(c, 16, 16, "fovY");
    c = d;
    c.znear = 0.0f;
    expect_camera_refusal(c, 16, 16, "0 < near < far");
    c.znear = -1.0f;
    expect_camera_refusal(c, 16, 16, "0 < near < far");
    c = d;
    c.zfar = c.znear;
    expect_camera_refusal(c, 16, 16, "0 < near < far");
    c.zfar = 0.05f;
    expect_camera_refusal(c, 16, 16, "0 < near < far");
    c = d;
    c.znear = 1e-39f; /* (n - f) / (2 f n) overflows binary32 */
    c.zfar = 1.0f;
    expect_camera_refusal(c, 16, 16, "overflows binary32");
    c = d;
    c.position.x = NAN;
    expect_camera_refusal(c, 16, 16, "not finite");
    c = d;
    c.zfar = INFINITY;
    expect_camera_refusal(c, 16, 16, "not finite");
    c = d;
    c.aspect = -1.0f;
    expect_camera_refusal(c, 16, 16, "aspect");
    expect_camera_refusal(d, 0, 16, "at least 1");
    expect_camera_refusal(d, 16, 0, "at least 1");
    rto_msg msg = {{0}};
    rto_camera_uniforms u;
    assert_int_equal(rto_camera_uniforms_make(NULL, 1, 1, &u, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_camera_uniforms_make(&d, 1, 1, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    /* Control: a nearly-parallel up that is still well defined is accepted. */
    c = d;
    c.up = (rto_vec3){1e-3f, -2.0f, -5.0f};
    assert_int_equal(rto_camera_uniforms_make(&c, 16, 16, &u, &msg), RTO_OK);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Camera rays                                                                                                      */

static void check_fields(const rto_wf_ray *r, uint32_t pixel, const rto_camera_uniforms *u)
{
    assert_true(r->origin[0] == u->position[0] && r->origin[1] == u->position[1] && r->origin[2] == u->position[2]);
    assert_true(r->t_min == 0.0f && !signbit(r->t_min));
    assert_true(r->t_max == RTO_RAY_T_MAX);
    assert_int_equal(r->pixel, pixel);
    assert_int_equal(r->flags, RTO_RAY_FLAG_OPAQUE);
    assert_int_equal(r->cull_mask, 0xFF);
    assert_int_equal(r->miss_index, 0);
    assert_int_equal(r->sbt_offset, 0);
    assert_int_equal(r->payload_slot, pixel);
    assert_int_equal(r->kind, RTO_RAYS_PRIMARY);
    assert_int_equal(r->pad, 0);
}

/* Every pixel of a small image against the binary64 pinhole model: within a few binary32 ulp of the unit vector
 * (the camera ray is rounded at every step: ndc, two matrix products, the normalisation). */
static void check_image(const rto_camera *c, uint32_t w, uint32_t h, double tol)
{
    rto_camera_uniforms u;
    rto_msg msg = {{0}};
    if (rto_camera_uniforms_make(c, w, h, &u, &msg))
        fail_msg("%s", msg.text);
    const frame fr = camera_frame_d(c);
    double worst = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const rto_wf_ray r = rto_camera_ray(&u, w, h, x, y);
            check_fields(&r, y * w + x, &u);
            double e[3];
            pinhole_dir(c, &fr, w, h, x, y, e);
            for (int k = 0; k < 3; k++) {
                const double diff = fabs((double)r.dir[k] - e[k]);
                worst = fmax(worst, diff);
                if (diff > tol)
                    fail_msg("camera '%s' %ux%u pixel (%u, %u): dir[%d] = %.9g, pinhole model %.17g", c->name, w, h,
                             x, y, k, (double)r.dir[k], e[k]);
            }
        }
    (void)worst;
}

static void test_camera_rays(void **state)
{
    (void)state;
    const rto_camera def = rto_camera_default();
    const rto_camera g = gltf_like_camera();
    /* 8 ulp of 1 covers the rounding of ndc, rayEye, rayWorld and normalize. */
    check_image(&def, 160, 120, 8 * 0x1p-24);
    check_image(&def, 31, 17, 8 * 0x1p-24);
    check_image(&g, 64, 48, 8 * 0x1p-24);
    check_image(&g, 1, 1, 8 * 0x1p-24);
    /* The centre ray of an odd-sized image is the view direction: ndc is exactly (0, 0). */
    const rto_camera cams[2] = {def, g};
    for (int k = 0; k < 2; k++) {
        rto_camera_uniforms u;
        rto_msg msg = {{0}};
        assert_int_equal(rto_camera_uniforms_make(&cams[k], 161, 121, &u, &msg), RTO_OK);
        const rto_wf_ray r = rto_camera_ray(&u, 161, 121, 80, 60);
        const frame fr = camera_frame_d(&cams[k]);
        for (int a = 0; a < 3; a++)
            if (fabs((double)r.dir[a] - fr.f[a]) > 4 * 0x1p-24)
                fail_msg("camera '%s': centre ray dir[%d] = %.9g, normalize(target - eye) = %.17g", cams[k].name, a,
                         (double)r.dir[a], fr.f[a]);
        assert_int_equal(r.pixel, 60 * 161 + 80);
    }
    /* Corner rays at the field of view: in a 2x2 image the pixel centres sit at ndc +-0.5, so the top-left ray's
     * vertical angle to the view direction is atan(0.5 tan(fov / 2)); at 1 x H the top pixel tends to fov / 2. */
    for (int k = 0; k < 2; k++) {
        const rto_camera *c = &cams[k];
        const frame fr = camera_frame_d(c);
        const uint32_t h = 4001;
        rto_camera_uniforms u;
        rto_msg msg = {{0}};
        assert_int_equal(rto_camera_uniforms_make(c, 4001, h, &u, &msg), RTO_OK);
        const rto_wf_ray top = rto_camera_ray(&u, 4001, h, 2000, 0);
        const double d[3] = {top.dir[0], top.dir[1], top.dir[2]};
        const double vertical = atan2(tu_dot3(d, fr.y), tu_dot3(d, fr.f));
        const double expect = atan((1.0 - 1.0 / h) * tan(c->fov_y / 2.0));
        if (fabs(vertical - expect) > 1e-6)
            fail_msg("camera '%s': top ray at %.9g rad above the view, expected %.9g", c->name, vertical, expect);
        assert_true(fabs(vertical - c->fov_y / 2.0) < 1e-3); /* the top edge of the field of view */
        const double aspect = c->aspect > 0 ? c->aspect : 1.0;
        const rto_wf_ray right = rto_camera_ray(&u, 4001, h, 4000, 2000);
        const double e[3] = {right.dir[0], right.dir[1], right.dir[2]};
        const double horizontal = atan2(tu_dot3(e, fr.x), tu_dot3(e, fr.f));
        assert_true(fabs(horizontal - atan((1.0 - 1.0 / 4001) * tan(c->fov_y / 2.0) * aspect)) < 1e-6);
        /* Row 0 is the top: its rays point above the view direction, the last row's below. */
        const rto_wf_ray bottom = rto_camera_ray(&u, 4001, h, 2000, h - 1);
        const double b[3] = {bottom.dir[0], bottom.dir[1], bottom.dir[2]};
        assert_true(tu_dot3(d, fr.y) > 0 && tu_dot3(b, fr.y) < 0);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Framing                                                                                                          */

/* The framing camera must see every corner of the box inside its frustum (both fields of view, near < depth < far),
 * and fit the bounding sphere tightly in the narrower one. */
static void check_framing(const rto_aabb *b, float aspect)
{
    const rto_camera c = rto_camera_frame(b, aspect);
    rto_camera_uniforms u;
    rto_msg msg = {{0}};
    if (rto_camera_uniforms_make(&c, 64, 64, &u, &msg))
        fail_msg("framing camera refused: %s", msg.text);
    const frame fr = camera_frame_d(&c);
    const double centre[3] = {((double)b->min.x + b->max.x) / 2, ((double)b->min.y + b->max.y) / 2,
                              ((double)b->min.z + b->max.z) / 2};
    const double tgt[3] = {c.target.x, c.target.y, c.target.z};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(tgt[k] - centre[k]) <= 0x1p-24 * fabs(centre[k]));
    /* The eye sits along (0, 2, 5) from the centre. */
    double dir[3];
    tu_sub3(fr.eye, tgt, dir);
    const double dist = sqrt(tu_dot3(dir, dir));
    tu_unit3(dir);
    const double stage2[3] = {0, 2 / sqrt(29.0), 5 / sqrt(29.0)};
    /* Up to the binary32 rounding of eye and target, a few ulp of their magnitude over the distance. */
    const double big = fmax(fmax(fabs(fr.eye[0]), fabs(fr.eye[1])), fmax(fabs(fr.eye[2]), 1e-30));
    for (int k = 0; k < 3; k++)
        assert_true(fabs(dir[k] - stage2[k]) < 1e-6 + 4 * 0x1p-24 * big / dist);
    const double a = aspect > 0 ? aspect : 1.0, t = tan(c.fov_y / 2.0);
    for (int corner = 0; corner < 8; corner++) {
        const double p[3] = {(corner & 1) ? b->max.x : b->min.x, (corner & 2) ? b->max.y : b->min.y,
                             (corner & 4) ? b->max.z : b->min.z};
        double q[3];
        tu_sub3(p, fr.eye, q);
        const double depth = tu_dot3(q, fr.f);
        assert_true(depth > c.znear && depth < c.zfar);
        assert_true(fabs(tu_dot3(q, fr.y)) <= depth * t * (1 + 1e-6));
        assert_true(fabs(tu_dot3(q, fr.x)) <= depth * t * a * (1 + 1e-6));
    }
    const double dx = (double)b->max.x - b->min.x, dy = (double)b->max.y - b->min.y, dz = (double)b->max.z - b->min.z;
    const double r = 0.5 * sqrt(dx * dx + dy * dy + dz * dz);
    if (r > 1e-4 * fmax(fabs(centre[0]), fmax(fabs(centre[1]), fabs(centre[2])))) {
        const double half = fmin(c.fov_y / 2.0, atan(t * a));
        assert_true(fabs(r / dist - sin(half)) < 1e-5); /* tight: the sphere touches the narrower field of view */
    }
}

static void test_camera_frame(void **state)
{
    (void)state;
    const rto_camera def = rto_camera_default();
    rto_aabb empty = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    rto_camera c = rto_camera_frame(&empty, 1.0f);
    assert_memory_equal(&c, &def, sizeof c);
    c = rto_camera_frame(NULL, 1.0f);
    assert_memory_equal(&c, &def, sizeof c);
    const rto_aabb boxes[] = {
        {{-1, -2, -3}, {3, 4, 5}},
        {{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}},
        {{1000, 1000, 1000}, {1000.001f, 1000, 1000}}, /* tiny and far from the origin */
        {{2, 2, 2}, {2, 2, 2}},                        /* a point */
        {{0, 0, 0}, {0, 0, 0}},                        /* the origin */
        {{-1e20f, -1, -1}, {1e20f, 1, 1}},
    };
    const float aspects[] = {1.0f, 4.0f / 3.0f, 16.0f / 9.0f, 0.5f, 0.0f};
    for (size_t i = 0; i < sizeof boxes / sizeof boxes[0]; i++)
        for (size_t k = 0; k < sizeof aspects / sizeof aspects[0]; k++)
            check_framing(&boxes[i], aspects[k]);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Procedural scenes                                                                                                */

/* Closed and consistently wound: every directed edge (a, b) appears once, and its twin (b, a) appears once, so every
 * undirected edge is shared by exactly two triangles of opposite orientation. Also V - E + F = 2 (a sphere). */
static void check_closed(const rto_mesh *m, const char *what)
{
    const size_t ne = 3 * (size_t)m->triangle_count;
    uint64_t *e = malloc(ne * sizeof *e);
    assert_non_null(e);
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int j = 0; j < 3; j++) {
            const uint64_t a = m->indices[3 * t + (size_t)j], b = m->indices[3 * t + (size_t)(j + 1) % 3];
            assert_true(a != b);
            e[3 * t + (size_t)j] = a << 32 | b;
        }
    qsort(e, ne, sizeof *e, tu_cmp_u64);
    for (size_t i = 0; i < ne; i++) {
        if (i + 1 < ne && e[i] == e[i + 1])
            fail_msg("%s: directed edge (%u, %u) in two triangles", what, (unsigned)(e[i] >> 32), (unsigned)e[i]);
        const uint64_t twin = (e[i] << 32) | (e[i] >> 32);
        if (!bsearch(&twin, e, ne, sizeof *e, tu_cmp_u64))
            fail_msg("%s: edge (%u, %u) has no opposite twin: not closed", what, (unsigned)(e[i] >> 32),
                     (unsigned)e[i]);
    }
    assert_int_equal((int64_t)m->vertex_count - (int64_t)(ne / 2) + (int64_t)m->triangle_count, 2);
    free(e);
}

static void test_sphere(void **state)
{
    (void)state;
    for (uint32_t level = 0; level <= 7; level++) {
        char spec[32], bumpy[32];
        snprintf(spec, sizeof spec, "sphere:%u", level);
        snprintf(bumpy, sizeof bumpy, "sphere:%u:%u", level, 1000 + level);
        rto_scene *s = tu_load(spec), *b = tu_load(bumpy);
        assert_int_equal(s->mesh_count, 1);
        assert_int_equal(s->instance_count, 1);
        assert_int_equal(s->camera_count, 1);
        const rto_mesh *m = &s->meshes[0], *mb = &b->meshes[0];
        const uint32_t pow4 = 1u << (2 * level);
        assert_int_equal(m->vertex_count, 10 * pow4 + 2);
        assert_int_equal(m->triangle_count, 20 * pow4);
        assert_int_equal(mb->vertex_count, m->vertex_count);
        assert_int_equal(mb->triangle_count, m->triangle_count);
        assert_memory_equal(m->indices, mb->indices, 3 * (size_t)m->triangle_count * sizeof *m->indices);
        check_closed(m, spec); /* level 7: 983,040 half-edges, sorted once: quick */
        double fmin_ = INFINITY, fmax_ = 0;
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            const double p[3] = {m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]};
            const double q[3] = {mb->positions[3 * v], mb->positions[3 * v + 1], mb->positions[3 * v + 2]};
            const double lp = sqrt(tu_dot3(p, p)), lq = sqrt(tu_dot3(q, q));
            assert_true(fabs(lp - 1.0) < 2e-7); /* on the unit sphere, binary64 rounded once */
            /* The bumpy vertex lies on the same radius, 0.6 .. 1.4 of the way out. */
            fmin_ = fmin(fmin_, lq);
            fmax_ = fmax(fmax_, lq);
            for (int k = 0; k < 3; k++)
                assert_true(fabs(q[k] / lq - p[k] / lp) < 1e-6);
        }
        assert_true(fmin_ >= 0.6 * (1 - 1e-6) && fmax_ <= 1.4 * (1 + 1e-6));
        if (level >= 2)
            assert_true(fmin_ < 0.7 && fmax_ > 1.3); /* the factors spread over the range */
        /* Counter-clockwise seen from outside: seen from the centre every triangle has det[a, b, c] > 0 (star-shaped
         * about the origin, plain and bumpy alike), and the plain sphere's normals point away from the origin. */
        const rto_mesh *ms[2] = {m, mb};
        for (int k = 0; k < 2; k++)
            for (uint32_t t = 0; t < m->triangle_count; t++) {
                double v[3][3], e1[3], e2[3], nrm[3];
                for (int j = 0; j < 3; j++)
                    for (int c = 0; c < 3; c++)
                        v[j][c] = ms[k]->positions[3 * (size_t)ms[k]->indices[3 * t + (uint32_t)j] + (size_t)c];
                tu_cross3(v[1], v[2], nrm);
                if (!(tu_dot3(v[0], nrm) > 0))
                    fail_msg("%s triangle %u: det[a, b, c] <= 0", k ? bumpy : spec, t);
                tu_sub3(v[1], v[0], e1);
                tu_sub3(v[2], v[0], e2);
                tu_cross3(e1, e2, nrm);
                if (k == 0)
                    assert_true(tu_dot3(nrm, v[0]) > 0);
            }
        rto_scene_destroy(s);
        rto_scene_destroy(b);
    }
    /* Seeded: the same seed gives the same bytes, another seed other radii. */
    rto_scene *a = tu_load("sphere:3:17"), *b = tu_load("sphere:3:17"), *c = tu_load("sphere:3:18");
    const size_t bytes = 3 * (size_t)a->meshes[0].vertex_count * sizeof(float);
    assert_memory_equal(a->meshes[0].positions, b->meshes[0].positions, bytes);
    assert_memory_not_equal(a->meshes[0].positions, c->meshes[0].positions, bytes);
    rto_scene_destroy(a);
    rto_scene_destroy(b);
    rto_scene_destroy(c);
}

static double det3(const rto_mat34 *m)
{
    const double a[3][3] = {{m->m[0][0], m->m[0][1], m->m[0][2]},
                            {m->m[1][0], m->m[1][1], m->m[1][2]},
                            {m->m[2][0], m->m[2][1], m->m[2][2]}};
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}

static void test_random_scene(void **state)
{
    (void)state;
    size_t shared_edges = 0, slivers = 0, degenerate = 0, masked_scenes = 0, max_inst = 0, max_tris = 0;
    uint32_t sbt_seen = 0, meshes_seen = 0;
    for (uint32_t seed = 0; seed < 200; seed++) {
        char spec[32];
        snprintf(spec, sizeof spec, "random:%u", seed);
        rto_scene *s = tu_load(spec), *again = tu_load(spec);
        /* Deterministic: the same meshes and instances, byte for byte. */
        assert_int_equal(s->mesh_count, again->mesh_count);
        assert_int_equal(s->instance_count, again->instance_count);
        for (uint32_t m = 0; m < s->mesh_count; m++) {
            assert_int_equal(s->meshes[m].vertex_count, again->meshes[m].vertex_count);
            assert_int_equal(s->meshes[m].triangle_count, again->meshes[m].triangle_count);
            assert_memory_equal(s->meshes[m].positions, again->meshes[m].positions,
                                3 * (size_t)s->meshes[m].vertex_count * sizeof(float));
            assert_memory_equal(s->meshes[m].indices, again->meshes[m].indices,
                                3 * (size_t)s->meshes[m].triangle_count * sizeof(uint32_t));
        }
        assert_memory_equal(s->instances, again->instances, s->instance_count * sizeof *s->instances);
        rto_scene_destroy(again);
        /* Within the limits. */
        if (s->mesh_count < 1 || s->mesh_count > 4 || s->instance_count < 1 || s->instance_count > 40)
            fail_msg("seed %u: %u meshes, %u instances", seed, s->mesh_count, s->instance_count);
        assert_int_equal(s->camera_count, 1);
        meshes_seen |= 1u << s->mesh_count;
        max_inst = s->instance_count > max_inst ? s->instance_count : max_inst;
        for (uint32_t m = 0; m < s->mesh_count; m++) {
            const rto_mesh *me = &s->meshes[m];
            if (me->triangle_count < 1 || me->triangle_count > 300)
                fail_msg("seed %u mesh %u: %u triangles", seed, m, me->triangle_count);
            max_tris = me->triangle_count > max_tris ? me->triangle_count : max_tris;
            /* Shared edges (an undirected edge in two triangles), slivers (height under 1e-3 of the longest edge)
             * and degenerate triangles (a repeated vertex). */
            for (uint32_t t = 0; t < me->triangle_count; t++) {
                const uint32_t *ix = &me->indices[3 * t];
                if (ix[0] == ix[1] || ix[1] == ix[2] || ix[2] == ix[0]) {
                    degenerate++;
                    continue;
                }
                double v[3][3], e1[3], e2[3], nrm[3], longest = 0;
                for (int j = 0; j < 3; j++)
                    for (int c = 0; c < 3; c++)
                        v[j][c] = me->positions[3 * (size_t)ix[j] + (size_t)c];
                for (int j = 0; j < 3; j++) {
                    double e[3];
                    tu_sub3(v[(j + 1) % 3], v[j], e);
                    longest = fmax(longest, sqrt(tu_dot3(e, e)));
                }
                tu_sub3(v[1], v[0], e1);
                tu_sub3(v[2], v[0], e2);
                tu_cross3(e1, e2, nrm);
                slivers += sqrt(tu_dot3(nrm, nrm)) / longest < 1e-3 * longest;
                /* (quadratic: over the first 40 seeds only) */
                for (uint32_t u = 0; seed < 40 && u < t; u++)
                    for (int j = 0; j < 3; j++)
                        for (int k = 0; k < 3; k++)
                            shared_edges += me->indices[3 * u + (uint32_t)k] == ix[(j + 1) % 3] &&
                                            me->indices[3 * u + (uint32_t)(k + 1) % 3] == ix[j];
            }
        }
        uint32_t mask0 = 0, mirrored = 0;
        for (uint32_t i = 0; i < s->instance_count; i++) {
            const rto_instance *in = &s->instances[i];
            assert_true(in->blas < s->mesh_count);
            assert_true(in->custom_index <= RTO_INSTANCE_CUSTOM_INDEX_MASK && in->mask <= 0xFF);
            mask0 += in->mask == 0;
            mirrored += det3(&in->obj_to_world) < 0;
            sbt_seen |= 1u << (in->sbt_offset & 31);
        }
        if (mask0 != (s->instance_count >= 3 ? 1u : 0u))
            fail_msg("seed %u: %u instances with mask 0 among %u", seed, mask0, s->instance_count);
        masked_scenes += mask0;
        if (mirrored < 1)
            fail_msg("seed %u: no mirroring instance", seed);
        /* The camera frames the scene: every instance box corner is in front of it. */
        rto_camera_uniforms u;
        rto_msg msg = {{0}};
        if (rto_camera_uniforms_make(&s->cameras[0], 64, 64, &u, &msg))
            fail_msg("seed %u: %s", seed, msg.text);
        const frame fr = camera_frame_d(&s->cameras[0]);
        const rto_aabb box = rto_scene_aabb(s);
        for (int corner = 0; corner < 8; corner++) {
            const double p[3] = {(corner & 1) ? box.max.x : box.min.x, (corner & 2) ? box.max.y : box.min.y,
                                 (corner & 4) ? box.max.z : box.min.z};
            double q[3];
            tu_sub3(p, fr.eye, q);
            assert_true(tu_dot3(q, fr.f) > s->cameras[0].znear);
        }
        rto_scene_destroy(s);
    }
    /* Over 200 seeds every feature shows up. */
    assert_true(shared_edges > 50 && slivers > 20 && degenerate > 5 && masked_scenes > 100);
    assert_true(max_inst >= 35 && max_tris >= 280);
    assert_int_equal(meshes_seen, 0x1E); /* 1, 2, 3 and 4 meshes */
    assert_true(sbt_seen == 0xFF);       /* sbtOffset 0 .. 7 */
    /* Different seeds, different scenes. */
    rto_scene *a = tu_load("random:1"), *b = tu_load("random:2");
    assert_true(a->instance_count != b->instance_count || a->mesh_count != b->mesh_count ||
                memcmp(a->instances, b->instances, a->instance_count * sizeof *a->instances));
    rto_scene_destroy(a);
    rto_scene_destroy(b);
    a = tu_load("random:4294967295");
    rto_scene_destroy(a);
}

static void test_procedural_refusals(void **state)
{
    (void)state;
    static const struct {
        const char *spec;
        const char *substring;
    } cases[] = {
        {"sphere:", "L must be an integer 0 .. 7"},
        {"sphere:8", "L must be an integer 0 .. 7"},
        {"sphere:-1", "L must be an integer 0 .. 7"},
        {"sphere:+1", "L must be an integer 0 .. 7"},
        {"sphere: 1", "L must be an integer 0 .. 7"},
        {"sphere:1x", "L must be an integer 0 .. 7"},
        {"sphere:99999999999999999999", "L must be an integer 0 .. 7"},
        {"sphere::5", "L must be an integer 0 .. 7"},
        {"sphere:3:", "SEED must be an integer 0 .. 4294967295"},
        {"sphere:3:abc", "SEED must be an integer"},
        {"sphere:3:-1", "SEED must be an integer"},
        {"sphere:3:4294967296", "SEED must be an integer"},
        {"sphere:3:1:2", "SEED must be an integer"},
        {"random:", "SEED must be an integer 0 .. 4294967295"},
        {"random:x", "SEED must be an integer"},
        {"random:4294967296", "SEED must be an integer"},
        {"random:12345678901", "SEED must be an integer"},
        {"random:1:2", "SEED must be an integer"},
        {"random: 1", "SEED must be an integer"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rto_scene *s = (rto_scene *)1;
        rto_msg msg = {{0}};
        assert_int_equal(rto_scene_load(cases[i].spec, &s, &msg), RTO_ERR_INVALID_ARGUMENT);
        assert_null(s);
        if (!strstr(msg.text, cases[i].substring) || !strstr(msg.text, cases[i].spec))
            fail_msg("'%s': expected '%s' and the spec in '%s'", cases[i].spec, cases[i].substring, msg.text);
        assert_null(strchr(msg.text, '\n'));
    }
    /* Controls: both ends of each range load. */
    const char *ok[] = {"sphere:0", "sphere:0:0", "sphere:1:4294967295", "random:0", "random:4294967295"};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
        rto_scene_destroy(tu_load(ok[i]));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ray_set_names),
        cmocka_unit_test(test_camera_uniforms),
        cmocka_unit_test(test_camera_refusals),
        cmocka_unit_test(test_camera_rays),
        cmocka_unit_test(test_camera_frame),
        cmocka_unit_test(test_random_rays),
        cmocka_unit_test(test_grazing_rays),
        cmocka_unit_test(test_axis_rays),
        cmocka_unit_test(test_primary_rays),
        cmocka_unit_test(test_shadow_rays),
        cmocka_unit_test(test_shadow_offset),
        cmocka_unit_test(test_empty_scenes),
        cmocka_unit_test(test_generate_refusals),
        cmocka_unit_test(test_sphere),
        cmocka_unit_test(test_random_scene),
        cmocka_unit_test(test_procedural_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
