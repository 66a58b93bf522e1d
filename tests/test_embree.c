/* The Embree side of the cross-check (oracle/embree.c), on hand-made scenes with closed-form answers: instance IDs
 * mapped back, records filled like the oracle's, masks, culling, TERMINATE_ON_FIRST_HIT, refusals, Embree errors
 * through rto_msg with nothing printed, thread-count independence; then Embree on fixture scenes against a binary64
 * brute-force tracer written here (no oracle code), so the mirror is checked on its own; main(). One executable
 * (unit.embree) with test_embree_classes.c (the disagreement classes of src/trace/crosscheck.c). */
#include "test_embree.h"

#include "trace/crosscheck.h"
#include "embree.h"

#include <fcntl.h>
#include <math.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hand-made scenes                                                                                                 */

rto_scene *scene_new(uint32_t meshes, uint32_t instances)
{
    rto_scene *s = calloc(1, sizeof *s);
    assert_non_null(s);
    s->meshes = calloc(meshes, sizeof *s->meshes);
    s->instances = calloc(instances, sizeof *s->instances);
    assert_non_null(s->meshes);
    assert_non_null(s->instances);
    s->mesh_count = meshes;
    s->instance_count = instances;
    snprintf(s->source, sizeof s->source, "hand-made");
    return s;
}

void mesh_set(rto_scene *s, uint32_t m, const float *pos, uint32_t nv, const uint32_t *idx, uint32_t nt)
{
    rto_mesh *me = &s->meshes[m];
    me->vertex_count = nv;
    me->triangle_count = nt;
    me->positions = malloc(12 * (size_t)(nv ? nv : 1));
    me->indices = malloc(12 * (size_t)(nt ? nt : 1));
    assert_non_null(me->positions);
    assert_non_null(me->indices);
    if (nv)
        memcpy(me->positions, pos, 12 * (size_t)nv);
    if (nt)
        memcpy(me->indices, idx, 12 * (size_t)nt);
    me->material = -1;
}

/* obj_to_world = diag(sx, sy, sz) then + (tx, ty, tz). */
void inst_set(rto_scene *s, uint32_t i, uint32_t blas, double sx, double sy, double sz, double tx, double ty,
              double tz, uint32_t mask, uint32_t sbt, uint32_t custom)
{
    const double m[3][4] = {{sx, 0, 0, tx}, {0, sy, 0, ty}, {0, 0, sz, tz}};
    rto_msg msg = {{0}};
    rto_instance *in = &s->instances[i];
    assert_int_equal(rto_instance_set_transform(in, m, &msg), RTO_OK);
    in->blas = blas;
    in->mask = mask;
    in->sbt_offset = sbt;
    in->custom_index = custom;
}

void scene_free(rto_scene *s)
{
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        free(s->meshes[m].positions);
        free(s->meshes[m].indices);
    }
    free(s->meshes);
    free(s->instances);
    free(s);
}

/*
 * mesh 0: the unit quad in z = 0, triangles (0,1,2) and (0,2,3) sharing the diagonal (0,0)-(1,1), counter-clockwise
 *         seen from +z;
 * mesh 1: one triangle (0,0,0) (1,0,0) (0,1,0), counter-clockwise seen from +z;
 * mesh 2: empty;
 * mesh 3: the triangle (1,0,0) (2,0,0) (1,1,0) beside the quad (world vertices shared with quad triangle 0);
 * mesh 4: the triangle (0.2,0.2,0) (0.5,0.2,0) (0.2,0.5,0) inside the quad (coplanar, no vertex shared);
 * mesh 5: the triangle (0.6,-0.5,-1) (0.6,1.5,-1) (0.6,0.5,1) in the plane x = 0.6, crossing the quad along
 *         x = 0.6, 0 <= y <= 1 (no vertex shared);
 * mesh 6: the quad moved to x = 1000 in its own coordinates (large object-space coordinates).
 * instance 0: quad, identity, mask 0x01, sbt 3, custom 7
 * instance 1: quad scaled by 2, moved to x = 5, mask 0x02
 * instance 2: mesh 1 mirrored in x (x' = 1 - x), moved to z = -5, mask 0x04
 * instance 3: the empty mesh
 * instance 4: mesh 3, identity, mask 0x08
 * instance 5: mesh 4, identity, mask 0x10
 * instance 6: mesh 5, identity, mask 0x20
 * instance 7: mesh 6, identity, mask 0x40
 */
rto_scene *hand_scene(void)
{
    rto_scene *s = scene_new(7, 8);
    static const float quad[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};
    static const float tri[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    static const float side[] = {1, 0, 0, 2, 0, 0, 1, 1, 0};
    static const float inner[] = {0.2f, 0.2f, 0, 0.5f, 0.2f, 0, 0.2f, 0.5f, 0};
    static const float cross_tri[] = {0.6f, -0.5f, -1, 0.6f, 1.5f, -1, 0.6f, 0.5f, 1};
    static const float far_quad[] = {1000, 0, 0, 1001, 0, 0, 1001, 1, 0, 1000, 1, 0};
    static const uint32_t tri_idx[] = {0, 1, 2};
    mesh_set(s, 0, quad, 4, quad_idx, 2);
    mesh_set(s, 1, tri, 3, tri_idx, 1);
    mesh_set(s, 2, NULL, 0, NULL, 0);
    mesh_set(s, 3, side, 3, tri_idx, 1);
    mesh_set(s, 4, inner, 3, tri_idx, 1);
    mesh_set(s, 5, cross_tri, 3, tri_idx, 1);
    mesh_set(s, 6, far_quad, 4, quad_idx, 2);
    inst_set(s, 0, 0, 1, 1, 1, 0, 0, 0, 0x01, 3, 7);
    inst_set(s, 1, 0, 2, 2, 2, 5, 0, 0, 0x02, 0, 0);
    inst_set(s, 2, 1, -1, 1, 1, 1, 0, -5, 0x04, 0, 0);
    inst_set(s, 3, 2, 1, 1, 1, 0, 0, 0, 0xFF, 0, 0);
    inst_set(s, 4, 3, 1, 1, 1, 0, 0, 0, 0x08, 0, 0);
    inst_set(s, 5, 4, 1, 1, 1, 0, 0, 0, 0x10, 0, 0);
    inst_set(s, 6, 5, 1, 1, 1, 0, 0, 0, 0x20, 0, 0);
    inst_set(s, 7, 6, 1, 1, 1, 0, 0, 0, 0x40, 0, 0);
    return s;
}

rto_wf_ray ray_make(float ox, float oy, float oz, float dx, float dy, float dz)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    r.origin[0] = ox, r.origin[1] = oy, r.origin[2] = oz;
    r.dir[0] = dx, r.dir[1] = dy, r.dir[2] = dz;
    r.t_min = 0;
    r.t_max = RTO_RAY_T_MAX;
    r.flags = RTO_RAY_FLAG_OPAQUE;
    r.cull_mask = 0xFF;
    return r;
}

typedef struct fixture {
    rto_scene *s;
    emb_device *d;
    emb_scene *e;
} fixture;

static fixture fixture_make(bool culling, bool robust)
{
    fixture f = {hand_scene(), NULL, NULL};
    rto_msg msg = {{0}};
    if (emb_device_create(1, NULL, &f.d, &msg))
        fail_msg("emb_device_create: %s", msg.text);
    emb_scene_desc desc = {EMB_QUALITY_DEFAULT, robust, culling};
    if (emb_scene_create(f.d, f.s, &desc, &f.e, &msg))
        fail_msg("emb_scene_create: %s", msg.text);
    return f;
}

static void fixture_free(fixture *f)
{
    emb_scene_destroy(f->e);
    emb_device_destroy(f->d);
    scene_free(f->s);
}

static rto_hit_record trace1(fixture *f, const rto_wf_ray *r)
{
    rto_hit_record h;
    rto_msg msg = {{0}};
    if (emb_trace(f->e, f->d, r, 1, 1, &h, &msg))
        fail_msg("emb_trace: %s", msg.text);
    return h;
}

static void expect_hit(const rto_hit_record *h, uint32_t inst, uint32_t prim, float t)
{
    assert_int_equal(h->miss_flag, 0);
    assert_int_equal(h->instance_id, inst);
    assert_int_equal(h->prim_id, prim);
    if (fabs((double)h->t - t) > 1e-6 * fmax(1, t))
        fail_msg("t %.9g, want %.9g", h->t, t);
}

static void expect_miss(const rto_hit_record *h, float t_max)
{
    assert_int_equal(h->miss_flag, 1);
    assert_true(h->t == t_max);
    assert_int_equal(h->instance_id, UINT32_MAX);
    assert_int_equal(h->prim_id, UINT32_MAX);
    assert_int_equal(h->hit_group, UINT32_MAX);
    assert_int_equal(h->custom_index, UINT32_MAX);
    assert_true(h->bary[0] == 0 && h->bary[1] == 0);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The mirror                                                                                                       */

static void test_mirror_records(void **state)
{
    (void)state;
    fixture f = fixture_make(false, true);
    /* (0.25, 0.75) lies in quad triangle 1 (0, 2, 3): p = (1-u-v) v0 + u v2 + v v3 gives u = 0.25, v = 0.5 */
    rto_wf_ray r = ray_make(0.25f, 0.75f, 1, 0, 0, -1);
    rto_hit_record h = trace1(&f, &r);
    expect_hit(&h, 0, 1, 1);
    assert_true(fabs(h.bary[0] - 0.25) < 1e-6 && fabs(h.bary[1] - 0.5) < 1e-6);
    assert_int_equal(h.hit_group, 3);
    assert_int_equal(h.custom_index, 7);
    /* identity objToWorld as a column-major mat4x3, padding 0 */
    for (int c = 0; c < 4; c++)
        for (int k = 0; k < 4; k++)
            assert_true(h.obj_to_world[c][k] == (c == k && k < 3 ? 1.0f : 0.0f));
    /* instance 1 (scale 2 at x = 5): world (6.5, 0.5) is object (0.75, 0.25), triangle 0; t = 1 (z from 1 to 0) */
    r = ray_make(6.5f, 0.5f, 1, 0, 0, -1);
    h = trace1(&f, &r);
    expect_hit(&h, 1, 0, 1);
    assert_true(h.obj_to_world[0][0] == 2 && h.obj_to_world[3][0] == 5 && h.obj_to_world[3][3] == 0);
    /* t is shared between world and object space: a direction of length 2 halves it */
    r = ray_make(6.5f, 0.5f, 1, 0, 0, -2);
    h = trace1(&f, &r);
    expect_hit(&h, 1, 0, 0.5f);
    /* instance 2 (mirrored, z = -5) under the quad: world (0.75, 0.1) is object (0.25, 0.1); from below it is hit
     * first */
    r = ray_make(0.75f, 0.1f, -10, 0, 0, 1);
    h = trace1(&f, &r);
    expect_hit(&h, 2, 0, 5);
    /* a miss, with another tMax */
    r = ray_make(3, 3, 1, 0, 0, -1);
    r.t_max = 42;
    h = trace1(&f, &r);
    expect_miss(&h, 42);
    /* tMax before the surface: a miss */
    r = ray_make(0.25f, 0.75f, 1, 0, 0, -1);
    r.t_max = 0.5f;
    h = trace1(&f, &r);
    expect_miss(&h, 0.5f);
    /* the ray interval is the oracle's [tMin, tMax): a hit exactly at tMin counts (tMin = the hit's t), one exactly
     * at tMax does not */
    r = ray_make(0.75f, 0.25f, 1, 0, 0, -1);
    r.t_min = 1;
    h = trace1(&f, &r);
    expect_hit(&h, 0, 0, 1);
    r.t_min = 0;
    r.t_max = 1;
    h = trace1(&f, &r);
    expect_miss(&h, 1);
    r.t_max = 1.0000001f;
    h = trace1(&f, &r);
    expect_hit(&h, 0, 0, 1);
    /* tMin past the quad: instance 2 behind it */
    r = ray_make(0.75f, 0.1f, 1, 0, 0, -1);
    r.t_min = 2;
    h = trace1(&f, &r);
    expect_hit(&h, 2, 0, 6);
    fixture_free(&f);
}

static void test_mirror_masks(void **state)
{
    (void)state;
    fixture f = fixture_make(false, true);
    assert_true(emb_device_ray_masks(f.d)); /* Debian's Embree tests ray masks; the masks below need it */
    rto_wf_ray r = ray_make(0.75f, 0.1f, 1, 0, 0, -1);
    r.cull_mask = 0x01;
    rto_hit_record h = trace1(&f, &r);
    expect_hit(&h, 0, 0, 1);
    r.cull_mask = 0x04; /* only the mirrored triangle below */
    h = trace1(&f, &r);
    expect_hit(&h, 2, 0, 6);
    r.cull_mask = 0x02; /* instance 1 is elsewhere */
    h = trace1(&f, &r);
    expect_miss(&h, RTO_RAY_T_MAX);
    r.cull_mask = 0x100; /* only the low 8 bits count */
    h = trace1(&f, &r);
    expect_miss(&h, RTO_RAY_T_MAX);
    fixture_free(&f);
}

static void test_mirror_first_hit(void **state)
{
    (void)state;
    fixture f = fixture_make(false, false);
    rto_wf_ray r[2] = {ray_make(0.75f, 0.1f, 1, 0, 0, -1), ray_make(3, 3, 1, 0, 0, -1)};
    for (int i = 0; i < 2; i++)
        r[i].flags = RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT | RTO_RAY_FLAG_OPAQUE;
    rto_hit_record h[2];
    rto_msg msg = {{0}};
    assert_int_equal(emb_trace(f.e, f.d, r, 2, 1, h, &msg), RTO_OK);
    assert_int_equal(h[0].miss_flag, 0);
    assert_true(isinf(h[0].t) && h[0].t < 0);
    assert_int_equal(h[0].instance_id, UINT32_MAX);
    assert_int_equal(h[0].prim_id, UINT32_MAX);
    expect_miss(&h[1], RTO_RAY_T_MAX);
    /* the closest hit of the same ray names the triangle */
    rto_hit_record c;
    emb_trace_closest(f.e, &r[0], &c);
    expect_hit(&c, 0, 0, 1);
    fixture_free(&f);
}

static void test_mirror_culling(void **state)
{
    (void)state;
    fixture f = fixture_make(true, true);
    /* From above, the quad (instance 0) is front-facing (counter-clockwise seen from the origin); instance 2's
     * object-space triangle too (the mirror in x does not change the object-space direction (0, 0, -1)). */
    rto_wf_ray down = ray_make(0.75f, 0.1f, 1, 0, 0, -1), up = ray_make(0.75f, 0.1f, -10, 0, 0, 1);
    rto_hit_record h;
    down.flags |= RTO_RAY_FLAG_CULL_BACK_FACING;
    h = trace1(&f, &down);
    expect_hit(&h, 0, 0, 1);
    down.flags = RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_CULL_FRONT_FACING;
    h = trace1(&f, &down);
    expect_miss(&h, RTO_RAY_T_MAX);
    up.flags |= RTO_RAY_FLAG_CULL_BACK_FACING; /* from below both are back faces */
    h = trace1(&f, &up);
    expect_miss(&h, RTO_RAY_T_MAX);
    up.flags = RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_CULL_FRONT_FACING;
    h = trace1(&f, &up);
    expect_hit(&h, 2, 0, 5);
    up.flags = RTO_RAY_FLAG_OPAQUE;
    h = trace1(&f, &up);
    expect_hit(&h, 2, 0, 5);
    /* occlusion honours culling too */
    up.flags = RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_CULL_BACK_FACING;
    h = trace1(&f, &up);
    expect_miss(&h, RTO_RAY_T_MAX);
    fixture_free(&f);
}

static void test_mirror_refusals(void **state)
{
    (void)state;
    fixture f = fixture_make(false, false);
    rto_wf_ray r[4];
    for (int i = 0; i < 4; i++)
        r[i] = ray_make(0.5f, 0.5f, 1, 0, 0, -1);
    rto_hit_record h[4];
    rto_msg msg = {{0}};
    r[2].dir[1] = NAN;
    assert_int_equal(emb_trace(f.e, f.d, r, 4, 1, h, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "ray 2"));
    r[2] = r[0];
    r[3].t_min = 5, r[3].t_max = 4;
    assert_int_equal(emb_trace(f.e, f.d, r, 4, 1, h, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "ray 3: tMin"));
    r[3] = r[0];
    r[1].flags |= RTO_RAY_FLAG_CULL_BACK_FACING; /* a mirror made without culling cannot honour it */
    assert_int_equal(emb_trace(f.e, f.d, r, 4, 1, h, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "ray 1: culling"));
    r[1] = r[0];
    r[2].t_min = -1; /* Embree asserts tnear >= 0 */
    assert_int_equal(emb_trace(f.e, f.d, r, 4, 1, h, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "ray 2: tMin -1 < 0"));
    r[2] = r[0];
    r[0].origin[2] = 2e18f; /* and |coordinates| <= 1.844e18 */
    assert_int_equal(emb_trace(f.e, f.d, r, 4, 1, h, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "ray 0: an origin or direction component beyond"));
    fixture_free(&f);
}

/* Embree errors reach rto_msg through the device callback, one line, and nothing reaches stderr. */
static void test_device_errors(void **state)
{
    (void)state;
    fflush(stderr);
    char path[] = "/tmp/rto_test_embree_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    int saved = dup(2);
    assert_true(saved >= 0);
    assert_true(dup2(fd, 2) >= 0);

    emb_device *d = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(emb_device_create(2, "verbose=0", &d, &msg), RTO_OK);
    assert_string_equal(emb_device_config(d), "threads=2,verbose=0");
    RTCGeometry g = rtcNewGeometry(emb_device_rtc(d), (enum RTCGeometryType)9999);
    assert_null(g);
    rto_status s = emb_device_check(d, "a test", &msg);
    RTCScene sc = rtcNewScene(emb_device_rtc(d));
    rtcSetSceneBuildQuality(sc, (enum RTCBuildQuality)17);
    rto_msg msg2 = {{0}};
    rto_status s2 = emb_device_check(d, "the second test", &msg2);
    rto_msg msg3 = {{0}};
    rto_status s3 = emb_device_check(d, "nothing", &msg3);
    rtcReleaseScene(sc);
    emb_device_destroy(d);

    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    off_t size = lseek(fd, 0, SEEK_END);
    close(fd);
    unlink(path);
    /* Embree 3 files a bad geometry type and a bad build quality under RTC_ERROR_UNKNOWN */
    assert_int_equal(s, RTO_ERR_UNSUPPORTED);
    assert_string_equal(msg.text, "Embree error during a test: unknown error (invalid geometry type)");
    assert_int_equal(s2, RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg2.text, "during the second test"));
    assert_int_equal(s3, RTO_OK); /* reported once, then cleared */
    assert_string_equal(msg3.text, "");
    assert_int_equal(size, 0);
}

static void test_partition_and_threads(void **state)
{
    (void)state;
    /* every item in exactly one part, parts contiguous and in order */
    for (size_t n = 0; n < 40; n++)
        for (uint32_t parts = 1; parts < 9; parts++) {
            size_t next = 0;
            for (uint32_t k = 0; k < parts; k++) {
                size_t b, e;
                emb_partition(n, parts, k, &b, &e);
                assert_int_equal(b, next);
                assert_true(b <= e && e <= n && e - b >= n / parts && e - b <= n / parts + 1);
                next = e;
            }
            assert_int_equal(next, n);
        }
    fixture f = fixture_make(false, false);
    enum { N = 997 };
    rto_wf_ray *r = malloc(N * sizeof *r);
    rto_hit_record *h1 = malloc(N * sizeof *h1), *h3 = malloc(N * sizeof *h3);
    assert_true(r && h1 && h3);
    for (uint32_t i = 0; i < N; i++)
        r[i] = ray_make(rto_unit(5, 2 * i) * 8 - 1, rto_unit(5, 2 * i + 1) * 3 - 1, 1, 0, 0, -1);
    rto_msg msg = {{0}};
    assert_int_equal(emb_trace(f.e, f.d, r, N, 1, h1, &msg), RTO_OK);
    assert_int_equal(emb_trace(f.e, f.d, r, N, 3, h3, &msg), RTO_OK);
    assert_memory_equal(h1, h3, N * sizeof *h1);
    free(r);
    free(h1);
    free(h3);
    fixture_free(&f);
}

/* Embree's stream API (rtcIntersect1M / rtcOccluded1M, as bench_trace times it) gives the records of its per-ray
 * API on rays that mix closest-hit and first-hit rays, masks and tMin / tMax, across stream boundaries (256 rays),
 * coherent or not, with 1 and 3 threads; a mirror made with culling is refused. */
static void test_stream_api(void **state)
{
    (void)state;
    fixture f = fixture_make(false, false);
    enum { N = 1237 };
    rto_wf_ray *r = malloc(N * sizeof *r);
    rto_hit_record *ref = malloc(N * sizeof *ref), *h = malloc(N * sizeof *h);
    assert_true(r && ref && h);
    for (uint32_t i = 0; i < N; i++) {
        r[i] = ray_make(rto_unit(7, 3 * i) * 8 - 1, rto_unit(7, 3 * i + 1) * 3 - 1, 1, 0, 0, -1);
        const uint32_t k = rto_hash32(i * 2654435761u) % 8;
        if (k < 3 || (i / 300) % 2) /* runs of first-hit rays longer and shorter than a stream */
            r[i].flags |= RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT;
        if (k == 4)
            r[i].cull_mask = 0x05;
        if (k == 5)
            r[i].t_min = 1.5f, r[i].t_max = 3.0f;
    }
    rto_msg msg = {{0}};
    assert_int_equal(emb_trace_api(f.e, f.d, r, N, 1, EMB_API_SINGLE, ref, &msg), RTO_OK);
    size_t hits = 0, occluded = 0;
    for (uint32_t i = 0; i < N; i++) {
        hits += ref[i].miss_flag == 0;
        occluded += ref[i].t == -INFINITY;
    }
    assert_true(hits > N / 10 && occluded > N / 10); /* the rays do hit, both ways */
    const emb_api apis[2] = {EMB_API_STREAM, EMB_API_STREAM_COHERENT};
    for (int a = 0; a < 2; a++)
        for (uint32_t threads = 1; threads <= 3; threads += 2) {
            memset(h, 0xA5, N * sizeof *h);
            assert_int_equal(emb_trace_api(f.e, f.d, r, N, threads, apis[a], h, &msg), RTO_OK);
            for (uint32_t i = 0; i < N; i++)
                if (memcmp(&h[i], &ref[i], sizeof *h))
                    fail_msg("stream api %d, %u threads: ray %u's record differs from rtcIntersect1's", (int)apis[a],
                             threads, i);
        }
    fixture_free(&f);
    fixture c = fixture_make(true, false);
    assert_int_equal(emb_trace_api(c.e, c.d, r, N, 1, EMB_API_STREAM, h, &msg), RTO_ERR_UNSUPPORTED);
    fixture_free(&c);
    free(r);
    free(ref);
    free(h);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Embree on fixtures against a binary64 brute-force tracer                                                         */

/* Closest hit over every triangle of every instance, Möller–Trumbore in binary64 on the ray taken to object space
 * with the scene's worldToObj (also in binary64). Independent of the oracle's code and of Embree. */
static rto_hit_record brute64(const rto_scene *s, const rto_wf_ray *r)
{
    rto_hit_record best = miss_rec();
    double best_t = r->t_max;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rto_instance *in = &s->instances[i];
        if (!(in->mask & r->cull_mask & 0xFF))
            continue;
        const rto_mesh *m = &s->meshes[in->blas];
        double o[3], d[3];
        for (int k = 0; k < 3; k++) {
            const float *w = in->world_to_obj.m[k];
            o[k] = (double)w[0] * r->origin[0] + (double)w[1] * r->origin[1] + (double)w[2] * r->origin[2] + w[3];
            d[k] = (double)w[0] * r->dir[0] + (double)w[1] * r->dir[1] + (double)w[2] * r->dir[2];
        }
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            const float *v[3];
            for (int k = 0; k < 3; k++)
                v[k] = m->positions + 3 * (size_t)m->indices[3 * (size_t)t + k];
            double e1[3], e2[3], sv[3];
            for (int k = 0; k < 3; k++) {
                e1[k] = (double)v[1][k] - v[0][k];
                e2[k] = (double)v[2][k] - v[0][k];
                sv[k] = o[k] - v[0][k];
            }
            double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
            double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
            if (det == 0)
                continue;
            double q[3] = {sv[1] * e1[2] - sv[2] * e1[1], sv[2] * e1[0] - sv[0] * e1[2], sv[0] * e1[1] - sv[1] * e1[0]};
            double u = (sv[0] * p[0] + sv[1] * p[1] + sv[2] * p[2]) / det;
            double vv = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
            double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
            if (u >= 0 && vv >= 0 && u + vv <= 1 && tt >= r->t_min && tt < best_t) {
                best_t = tt;
                best = hit_rec(i, t, (float)tt);
            }
        }
    }
    return best;
}

static void check_fixture(const char *rel, uint32_t nrays, uint32_t seed)
{
    const char *dir = getenv("RTO_FIXTURES");
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir && *dir ? dir : "fixtures", rel);
    rto_scene *s = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(path, &s, &msg))
        fail_msg("%s: %s", path, msg.text);
    emb_device *d = NULL;
    emb_scene *e = NULL;
    emb_scene_desc desc = {EMB_QUALITY_DEFAULT, true, false};
    assert_int_equal(emb_device_create(1, NULL, &d, &msg), RTO_OK);
    if (emb_scene_create(d, s, &desc, &e, &msg))
        fail_msg("%s: %s", path, msg.text);
    rto_wf_ray *r = random_rays(s, nrays, seed); /* origins in the bounds grown by half their size, uniform dirs */
    rto_hit_record *h = malloc(nrays * sizeof *h);
    assert_non_null(h);
    assert_int_equal(emb_trace(e, d, r, nrays, 2, h, &msg), RTO_OK);
    uint32_t count[XC_CLASS_COUNT] = {0}, hits = 0;
    cf_scene model;
    assert_int_equal(cf_scene_init(&model, s, &msg), RTO_OK);
    for (uint32_t i = 0; i < nrays; i++) {
        rto_hit_record ref = brute64(s, &r[i]);
        xc_result res;
        xc_input in = {s, &r[i], &ref, &h[i], NULL, NULL, NULL, &model};
        xc_classify(&in, &res);
        count[res.cls]++;
        hits += ref.miss_flag == 0;
        if (res.cls == XC_UNEXPLAINED)
            fail_msg("%s, seed %u, ray %u: binary64 reference vs Embree: %s", rel, seed, i, res.why);
    }
    print_message("%-44s %u rays, %u hits: agree %u, tie %u, coplanar %u, grazing %u\n", rel, nrays, hits,
                  count[XC_AGREE], count[XC_TIE], count[XC_COPLANAR], count[XC_GRAZING]);
    assert_true(hits > nrays / 10);                      /* the rays do meet the scene */
    assert_true(count[XC_AGREE] >= nrays - nrays / 100); /* >= 99 % exact agreement */
    cf_scene_free(&model);
    free(r);
    free(h);
    emb_scene_destroy(e);
    emb_device_destroy(d);
    rto_scene_destroy(s);
}

static void test_fixtures_against_binary64(void **state)
{
    (void)state;
    check_fixture("Box/glTF/Box.gltf", 4000, 11);
    check_fixture("SimpleMeshes/glTF/SimpleMeshes.gltf", 4000, 12);
    check_fixture("CornellBox-nvpro-glTF/cornellBox.gltf", 3000, 13);
    check_fixture("Duck/glTF/Duck.gltf", 400, 14);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mirror_records),
        cmocka_unit_test(test_mirror_masks),
        cmocka_unit_test(test_mirror_first_hit),
        cmocka_unit_test(test_mirror_culling),
        cmocka_unit_test(test_mirror_refusals),
        cmocka_unit_test(test_device_errors),
        cmocka_unit_test(test_partition_and_threads),
        cmocka_unit_test(test_stream_api),
        cmocka_unit_test(test_class_agree),
        cmocka_unit_test(test_class_tie),
        cmocka_unit_test(test_class_coplanar),
        cmocka_unit_test(test_class_crossing),
        cmocka_unit_test(test_class_t_rounding),
        cmocka_unit_test(test_class_grazing),
        cmocka_unit_test(test_class_robust_only),
        cmocka_unit_test(test_fixtures_against_binary64),
        cmocka_unit_test(test_oracle_mutations),
        cmocka_unit_test(test_class_surface_start),
        cmocka_unit_test(test_class_sliver),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
