/* The hit validator (rto_hits_check, DESIGN.md §9). Rays are aimed by this file at known points of known triangles,
 * and the "GPU" dump of a correct tracer is written here too, in binary64 from the scene alone (t as the distance to
 * the aimed point, bary as the aimed barycentrics, the instance's IDs and transform), so the passing case does not
 * rest on the oracle agreeing with itself. Each mutation is then caught, named with its fault class, and located at
 * the ray where it was made; a legitimate tie (a ray through the shared diagonal of a Box face answered with the
 * neighbour triangle) is accepted and listed, and a near-tie just outside the t tolerance is not. */
#include "testutil.h"

#include "core/tolerance.h"
#include "trace/conform.h"
#include "trace/trace_internal.h"

#include <math.h>

static void normalize(double v[3])
{
    const double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; a++)
        v[a] /= l;
}

/* The hit record a correct GPU writes, from the scene alone. */
static rto_hit_record record_of(const rto_scene *s, uint32_t k, uint32_t p, double t, double u, double v)
{
    return tu_hit_record(&s->instances[k], k, p, (float)t, (float)u, (float)v);
}

/* The record of triangle p of instance k for a binary32 ray, computed in binary64 from the scene alone (worldToObj
 * applied to the ray, then Möller–Trumbore): t, u, v within the model's bounds of any binary32 evaluation. */
static rto_hit_record exact_record_of(const rto_scene *s, uint32_t k, uint32_t p, const rto_wf_ray *ray)
{
    const rto_instance *in = &s->instances[k];
    const rto_mesh *m = &s->meshes[in->blas];
    double o[3], d[3], v[3][3], e1[3], e2[3], pv[3], sv[3], q[3];
    for (int r = 0; r < 3; r++) {
        const float *w = in->world_to_obj.m[r];
        o[r] = (double)w[0] * ray->origin[0] + (double)w[1] * ray->origin[1] + (double)w[2] * ray->origin[2] + w[3];
        d[r] = (double)w[0] * ray->dir[0] + (double)w[1] * ray->dir[1] + (double)w[2] * ray->dir[2];
    }
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 3; a++)
            v[c][a] = m->positions[3 * (size_t)m->indices[3 * (size_t)p + c] + a];
    for (int a = 0; a < 3; a++) {
        e1[a] = v[1][a] - v[0][a];
        e2[a] = v[2][a] - v[0][a];
        sv[a] = o[a] - v[0][a];
    }
    pv[0] = d[1] * e2[2] - d[2] * e2[1];
    pv[1] = d[2] * e2[0] - d[0] * e2[2];
    pv[2] = d[0] * e2[1] - d[1] * e2[0];
    q[0] = sv[1] * e1[2] - sv[2] * e1[1];
    q[1] = sv[2] * e1[0] - sv[0] * e1[2];
    q[2] = sv[0] * e1[1] - sv[1] * e1[0];
    const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
    const double u = (sv[0] * pv[0] + sv[1] * pv[1] + sv[2] * pv[2]) / det;
    const double w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    return record_of(s, k, p, t, u, w);
}

static rto_hit_record miss_of(float t_max) { return tu_miss_record(t_max); }

static rto_wf_ray ray_of(const double o[3], const double d[3], uint32_t flags, uint32_t index)
{
    rto_wf_ray r = tu_ray(o, d, 0.0f, RTO_RAY_T_MAX, flags);
    r.pixel = r.payload_slot = index;
    return r;
}

/* A scene, rays aimed by the test, the oracle's records (rto_trace) and a correct GPU dump written by the test. */
typedef struct fixture {
    rto_scene *scene;
    rto_accel *accel;
    size_t n;
    rto_wf_ray *rays;
    rto_hit_record *expected;
    rto_hit_record *gpu;
} fixture;

static void fixture_trace(fixture *f)
{
    rto_msg msg = {{0}};
    free(f->expected);
    f->expected = calloc(f->n ? f->n : 1, sizeof *f->expected);
    assert_non_null(f->expected);
    if (rto_trace(f->accel, f->rays, f->n, NULL, f->expected, NULL, &msg))
        fail_msg("rto_trace: %s", msg.text);
}

static void fixture_alloc(fixture *f, const char *spec, size_t n)
{
    memset(f, 0, sizeof *f);
    f->scene = tu_load(spec);
    rto_msg msg = {{0}};
    if (rto_accel_build(f->scene, NULL, &f->accel, &msg))
        fail_msg("build %s: %s", spec, msg.text);
    f->n = n;
    f->rays = calloc(n ? n : 1, sizeof *f->rays);
    f->gpu = calloc(n ? n : 1, sizeof *f->gpu);
    assert_true(f->rays && f->gpu);
}

/* n rays: every fifth one leaves the scene's bounding sphere outwards (a miss); the others are aimed from just
 * outside a random triangle's plane (0.3 away, in the gap between rtstress cubes) at an interior point of it with
 * barycentrics in [0.05, 0.9], so for these convex objects that triangle is the only closest hit. */
static void fixture_make(fixture *f, const char *spec, size_t n, uint64_t seed)
{
    fixture_alloc(f, spec, n);
    const rto_scene *s = f->scene;
    const rto_aabb b = rto_scene_aabb(s);
    const double c[3] = {0.5 * ((double)b.min.x + b.max.x), 0.5 * ((double)b.min.y + b.max.y),
                         0.5 * ((double)b.min.z + b.max.z)};
    const double radius = sqrt(((double)b.max.x - b.min.x) * ((double)b.max.x - b.min.x) +
                               ((double)b.max.y - b.min.y) * ((double)b.max.y - b.min.y) +
                               ((double)b.max.z - b.min.z) * ((double)b.max.z - b.min.z));
    for (size_t i = 0; i < n; i++) {
        double o[3], d[3];
        if (i % 5 == 4) {
            tu_rng_dir(&seed, d);
            for (int a = 0; a < 3; a++)
                o[a] = c[a] + 1.5 * radius * d[a];
            f->rays[i] = ray_of(o, d, RTO_RAY_FLAG_OPAQUE, (uint32_t)i);
            f->gpu[i] = miss_of(f->rays[i].t_max);
            continue;
        }
        const uint32_t k = (uint32_t)(tu_rng_next(&seed) % s->instance_count);
        const uint32_t p = (uint32_t)(tu_rng_next(&seed) % s->meshes[s->instances[k].blas].triangle_count);
        double u = 0.05 + 0.85 * tu_rng_unit(&seed), v = 0.05 + 0.85 * tu_rng_unit(&seed);
        if (u + v > 0.9) {
            u = 0.95 - u;
            v = 0.95 - v;
        }
        double w[3][3], e1[3], e2[3], nrm[3], pt[3], jitter[3];
        for (int q = 0; q < 3; q++)
            tu_world_vertex(s, k, p, q, w[q]);
        for (int a = 0; a < 3; a++) {
            e1[a] = w[1][a] - w[0][a];
            e2[a] = w[2][a] - w[0][a];
            pt[a] = (1.0 - u - v) * w[0][a] + u * w[1][a] + v * w[2][a];
        }
        nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
        normalize(nrm);
        /* outwards: away from the centre of the instance's world box (a flat mesh: either side) */
        const rto_aabb ib = rto_instance_aabb(s, k);
        const double ic[3] = {0.5 * ((double)ib.min.x + ib.max.x), 0.5 * ((double)ib.min.y + ib.max.y),
                              0.5 * ((double)ib.min.z + ib.max.z)};
        double side = 0;
        for (int a = 0; a < 3; a++)
            side += nrm[a] * (pt[a] - ic[a]);
        tu_rng_dir(&seed, jitter);
        for (int a = 0; a < 3; a++)
            d[a] = (side < 0 ? -nrm[a] : nrm[a]) + 0.3 * jitter[a];
        normalize(d);
        for (int a = 0; a < 3; a++) {
            o[a] = pt[a] + 0.3 * d[a];
            d[a] = -d[a];
        }
        f->rays[i] = ray_of(o, d, RTO_RAY_FLAG_OPAQUE, (uint32_t)i);
        f->gpu[i] = exact_record_of(s, k, p, &f->rays[i]);
    }
    fixture_trace(f);
    /* The rays must be what the test thinks they are: the oracle hits the aimed triangles and misses the rest. */
    for (size_t i = 0; i < n; i++)
        if (f->expected[i].miss_flag != f->gpu[i].miss_flag || f->expected[i].instance_id != f->gpu[i].instance_id ||
            f->expected[i].prim_id != f->gpu[i].prim_id)
            fail_msg("%s ray %zu: aimed at instance %u triangle %u, the oracle has %u / %u (miss %u)", spec, i,
                     f->gpu[i].instance_id, f->gpu[i].prim_id, f->expected[i].instance_id, f->expected[i].prim_id,
                     f->expected[i].miss_flag);
}

static void fixture_free(fixture *f)
{
    rto_accel_destroy(f->accel);
    rto_scene_destroy(f->scene);
    free(f->rays);
    free(f->expected);
    free(f->gpu);
}

static rto_hits_check_desc desc_of(const fixture *f, const rto_hit_record *gpu, size_t gn)
{
    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = f->rays;
    d.ray_count = f->n;
    d.expected = f->expected;
    d.gpu = gpu;
    d.gpu_count = gn;
    d.instances = f->scene->instances;
    d.instance_count = f->scene->instance_count;
    d.meshes = f->scene->meshes;
    d.mesh_count = f->scene->mesh_count;
    return d;
}

static int64_t fact(const rto_report *r, const char *name)
{
    for (uint32_t i = 0; i < r->nfacts; i++)
        if (!strcmp(r->facts[i].name, name))
            return r->facts[i].value;
    fail_msg("no fact %s", name);
    return -1;
}

static int has_fault_seen(const rto_report *r, const char *name)
{
    for (uint32_t i = 0; i < r->nfaults_seen; i++)
        if (!strcmp(r->faults_seen[i], name))
            return 1;
    return 0;
}

/* A row of the table at ray i with this field. */
static const rto_report_row *row_at(const rto_report *r, size_t i, const char *field)
{
    for (uint32_t k = 0; k < r->nrows; k++)
        if (r->rows[k].index == i && !strcmp(r->rows[k].field, field))
            return &r->rows[k];
    return NULL;
}

/* The report renders as text and JSON. */
static void renders(const rto_report *r)
{
    char buf[8192];
    size_t len = 0;
    rto_msg msg = {{0}};
    assert_int_equal(rto_report_text(r, buf, sizeof buf, &len), RTO_OK);
    assert_non_null(strstr(buf, "check-hits"));
    assert_int_equal(rto_report_json(r, buf, sizeof buf, &len, &msg), RTO_OK);
    assert_non_null(strstr(buf, "\"command\": \"check-hits\""));
}

static void expect_pass(const fixture *f, const rto_hit_record *gpu, int64_t ties, rto_report *r)
{
    rto_msg msg = {{0}};
    rto_hits_check_desc d = desc_of(f, gpu, f->n);
    rto_status s = rto_hits_check(&d, r, &msg);
    if (s != RTO_OK)
        fail_msg("expected a pass, got %s: %s %s", rto_status_string(s), r->summary, msg.text);
    assert_int_equal(r->code, RTO_HIT_OK);
    assert_string_equal(r->fault, "none");
    assert_string_equal(r->validator, "check-hits");
    assert_int_equal(fact(r, "ties"), ties);
    assert_int_equal(fact(r, "rays"), (int64_t)f->n);
    for (int k = 0; k < 6; k++)
        assert_int_equal(r->checks[k].state, RTO_CHECK_PASSED);
    assert_true(!strncmp(r->summary, "ok: ", 4));
    renders(r);
}

/* The dump fails with fault `want` as the primary one, located at ray `ray`, and the summary names both. */
static void expect_fault(const fixture *f, const rto_hit_record *gpu, size_t gn, rto_hit_fault want, size_t ray,
                         rto_report *r)
{
    rto_msg msg = {{0}};
    rto_hits_check_desc d = desc_of(f, gpu, gn);
    rto_status s = rto_hits_check(&d, r, &msg);
    if (s != RTO_ERR_MISMATCH)
        fail_msg("want fault %s at ray %zu, got status %s: %s", rto_hit_fault_name(want), ray, rto_status_string(s),
                 s ? msg.text : r->summary);
    if (r->code != (int)want)
        fail_msg("want fault %s at ray %zu, got %s: %s", rto_hit_fault_name(want), ray, r->fault, r->summary);
    assert_string_equal(r->fault, rto_hit_fault_name(want));
    int64_t where = -1;
    assert_true(rto_report_where(r, "ray", &where));
    if (where != (int64_t)ray)
        fail_msg("fault %s at ray %lld, want ray %zu: %s", r->fault, (long long)where, ray, r->summary);
    char name[64], at[64];
    snprintf(name, sizeof name, "%s: ", rto_hit_fault_name(want));
    snprintf(at, sizeof at, "ray %zu", ray);
    if (strncmp(r->summary, name, strlen(name)) || !strstr(r->summary, at))
        fail_msg("summary does not name %s and %s: %s", name, at, r->summary);
    assert_string_equal(r->faults_seen[0], rto_hit_fault_name(want));
    assert_true(r->nrows > 0);
    renders(r);
}

/* The first ray at or after `from` that the oracle hits, with barycentrics apart by more than 0.01. */
static size_t hit_ray(const fixture *f, size_t from)
{
    for (size_t i = from; i < f->n; i++)
        if (!f->expected[i].miss_flag && fabs((double)f->expected[i].bary[0] - f->expected[i].bary[1]) > 0.01)
            return i;
    fail_msg("no hit ray after %zu", from);
    return 0;
}

static size_t miss_ray(const fixture *f, size_t from)
{
    for (size_t i = from; i < f->n; i++)
        if (f->expected[i].miss_flag)
            return i;
    fail_msg("no miss ray after %zu", from);
    return 0;
}

static rto_hit_record *copy_gpu(const fixture *f)
{
    rto_hit_record *g = malloc((f->n ? f->n : 1) * sizeof *g);
    assert_non_null(g);
    memcpy(g, f->gpu, f->n * sizeof *g);
    return g;
}

/* ------------------------------------------------------------------------------------------------------------------ */

/* The control cases: the test's own dump, the oracle's records and the brute-force tracer's all pass. */
static void test_correct_dumps_pass(void **state)
{
    (void)state;
    const char *specs[] = {"triangle", "rtstress:2", "Box/glTF/Box.gltf"};
    for (size_t sc = 0; sc < 3; sc++) {
        fixture f;
        fixture_make(&f, specs[sc], 200, 7 + sc);
        rto_report r;
        expect_pass(&f, f.gpu, 0, &r);
        assert_int_equal(fact(&r, "hits") + fact(&r, "misses"), 200);
        assert_int_equal(fact(&r, "misses"), 40);
        expect_pass(&f, f.expected, 0, &r);
        rto_hit_record *b = calloc(f.n, sizeof *b);
        assert_non_null(b);
        rto_msg msg = {{0}};
        assert_int_equal(rto_trace_brute(f.scene, f.rays, f.n, NULL, b, &msg), RTO_OK);
        expect_pass(&f, b, 0, &r);
        free(b);
        fixture_free(&f);
    }
}

/* Every mutation of a correct dump, one at a time, named and located at the mutated ray. */
static void test_mutations_named(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "rtstress:2", 300, 11);
    rto_report r;
    rto_hit_record *g = copy_gpu(&f);
    const size_t i = hit_ray(&f, 150), j = miss_ray(&f, 100);
    const rto_hit_record keep = g[i], keepm = g[j];
    const rto_scene *s = f.scene;

    /* another triangle of the same instance, which the ray does not hit at the oracle's t: not a tie */
    const uint32_t tris = s->meshes[s->instances[g[i].instance_id].blas].triangle_count;
    g[i].prim_id = (keep.prim_id + tris / 2) % tris;
    expect_fault(&f, g, f.n, RTO_HIT_PRIM, i, &r);
    assert_non_null(row_at(&r, i, "primId"));
    assert_int_equal(rto_report_check_state(&r, "primitive"), RTO_CHECK_FAILED);
    g[i] = keep;

    /* t off by 1e-3 relative */
    g[i].t = keep.t * 1.001f;
    expect_fault(&f, g, f.n, RTO_HIT_T, i, &r);
    const rto_report_row *row = row_at(&r, i, "t");
    assert_non_null(row);
    assert_int_equal(row->tolerance.type, RTO_VALUE_F64);
    /* the model's bound for this ray: above 0, far below the 1e-3 moved */
    assert_true(row->tolerance.v.f > 0 && row->tolerance.v.f < 1e-5 * fmax(1.0, fabs((double)f.expected[i].t)));
    assert_true(r.tolerance_bound > 0);
    assert_int_equal(rto_report_check_state(&r, "t"), RTO_CHECK_FAILED);
    g[i] = keep;

    /* barycentrics swapped */
    g[i].bary[0] = keep.bary[1];
    g[i].bary[1] = keep.bary[0];
    expect_fault(&f, g, f.n, RTO_HIT_BARY, i, &r);
    assert_non_null(row_at(&r, i, "bary.u"));
    assert_non_null(row_at(&r, i, "bary.v"));
    g[i] = keep;

    /* the miss flag flipped, both ways, and a flag that is neither 0 nor 1 */
    g[i].miss_flag = 1;
    expect_fault(&f, g, f.n, RTO_HIT_MISS_FLAG, i, &r);
    assert_non_null(row_at(&r, i, "missFlag"));
    g[i] = miss_of(f.rays[i].t_max);
    expect_fault(&f, g, f.n, RTO_HIT_MISS_FLAG, i, &r);
    g[i] = keep;
    g[j].miss_flag = 0;
    expect_fault(&f, g, f.n, RTO_HIT_MISS_FLAG, j, &r);
    g[j].miss_flag = 2;
    expect_fault(&f, g, f.n, RTO_HIT_MISS_FLAG, j, &r);
    g[j] = keepm;
    g[i].miss_flag = 7;
    expect_fault(&f, g, f.n, RTO_HIT_MISS_FLAG, i, &r);
    g[i] = keep;

    /* another instance (the same triangle of the next cube: not on the ray) */
    g[i].instance_id = (keep.instance_id + 1) % s->instance_count;
    expect_fault(&f, g, f.n, RTO_HIT_INSTANCE, i, &r);
    assert_non_null(row_at(&r, i, "instanceId"));
    g[i] = keep;

    /* customIndex, hitGroup */
    g[i].custom_index = keep.custom_index + 1;
    expect_fault(&f, g, f.n, RTO_HIT_CUSTOM_INDEX, i, &r);
    assert_int_equal(rto_report_check_state(&r, "instance-data"), RTO_CHECK_FAILED);
    assert_non_null(row_at(&r, i, "customIndex"));
    g[i] = keep;
    g[i].hit_group = keep.hit_group + 3;
    expect_fault(&f, g, f.n, RTO_HIT_HIT_GROUP, i, &r);
    assert_non_null(row_at(&r, i, "hitGroup"));
    g[i] = keep;

    /* objToWorld written row-major (the 12 floats of the 3x4 in order) instead of as mat4x3 columns: the
     * translation moves */
    const float *m = &s->instances[keep.instance_id].obj_to_world.m[0][0];
    for (int c = 0; c < 4; c++)
        for (int rr = 0; rr < 3; rr++)
            g[i].obj_to_world[c][rr] = m[3 * c + rr];
    expect_fault(&f, g, f.n, RTO_HIT_TRANSFORM, i, &r);
    assert_int_equal(rto_report_check_state(&r, "instance-data"), RTO_CHECK_FAILED);
    g[i] = keep;
    /* the padding is not compared */
    for (int c = 0; c < 4; c++)
        g[i].obj_to_world[c][3] = 12345.0f;
    expect_pass(&f, g, 0, &r);
    g[i] = keep;

    /* a truncated dump: size, at the first ray without a record; a longer one too */
    expect_fault(&f, g, f.n - 1, RTO_HIT_SIZE, f.n - 1, &r);
    assert_int_equal(rto_report_check_state(&r, "size"), RTO_CHECK_FAILED);
    assert_int_equal(r.nfaults_seen, 1);
    assert_int_equal(fact(&r, "gpu_records"), (int64_t)f.n - 1);
    rto_hit_record *longer = calloc(f.n + 1, sizeof *longer);
    assert_non_null(longer);
    memcpy(longer, g, f.n * sizeof *g);
    expect_fault(&f, longer, f.n + 1, RTO_HIT_SIZE, f.n, &r);
    free(longer);
    /* ... whose remaining records are still compared */
    g[i].t = keep.t * 1.001f;
    expect_fault(&f, g, f.n - 1, RTO_HIT_SIZE, f.n - 1, &r);
    assert_true(has_fault_seen(&r, "t"));
    g[i] = keep;

    expect_pass(&f, g, 0, &r);
    free(g);
    fixture_free(&f);
}

/* The Box node rotates its mesh (-90 degrees about x): a transposed rotation is a transform fault. */
static void test_transposed_rotation(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "Box/glTF/Box.gltf", 60, 3);
    rto_hit_record *g = copy_gpu(&f);
    const size_t i = hit_ray(&f, 20);
    int changed = 0;
    for (int c = 0; c < 3; c++)
        for (int rr = 0; rr < 3; rr++) {
            g[i].obj_to_world[c][rr] = f.gpu[i].obj_to_world[rr][c];
            changed |= g[i].obj_to_world[c][rr] != f.gpu[i].obj_to_world[c][rr];
        }
    assert_true(changed);
    rto_report r;
    expect_fault(&f, g, f.n, RTO_HIT_TRANSFORM, i, &r);
    assert_non_null(row_at(&r, i, "objToWorld[1][2]"));
    assert_non_null(row_at(&r, i, "objToWorld[2][1]"));
    assert_null(row_at(&r, i, "objToWorld[0][0]"));
    free(g);
    fixture_free(&f);
}

/* A miss record is exactly the miss record: each field off is its own fault. */
static void test_miss_record_fields(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "triangle", 50, 5);
    rto_hit_record *g = copy_gpu(&f);
    const size_t j = miss_ray(&f, 10);
    const rto_hit_record keep = g[j];
    rto_report r;
    g[j].t = 0.0f;
    expect_fault(&f, g, f.n, RTO_HIT_T, j, &r);
    g[j] = keep;
    g[j].instance_id = 0;
    expect_fault(&f, g, f.n, RTO_HIT_INSTANCE, j, &r);
    g[j] = keep;
    g[j].prim_id = 0;
    expect_fault(&f, g, f.n, RTO_HIT_PRIM, j, &r);
    g[j] = keep;
    g[j].custom_index = 0;
    expect_fault(&f, g, f.n, RTO_HIT_CUSTOM_INDEX, j, &r);
    g[j] = keep;
    g[j].hit_group = 0;
    expect_fault(&f, g, f.n, RTO_HIT_HIT_GROUP, j, &r);
    g[j] = keep;
    g[j].bary[1] = 0.25f;
    expect_fault(&f, g, f.n, RTO_HIT_BARY, j, &r);
    g[j] = keep;
    g[j].obj_to_world[3][0] = 1.0f;
    expect_fault(&f, g, f.n, RTO_HIT_TRANSFORM, j, &r);
    assert_non_null(row_at(&r, j, "objToWorld[3][0]"));
    g[j] = keep;
    /* several at once: the primary is the first in priority order, the others are listed */
    g[j].t = 1.0f;
    g[j].hit_group = 0;
    g[j].bary[0] = 0.5f;
    expect_fault(&f, g, f.n, RTO_HIT_T, j, &r);
    assert_true(has_fault_seen(&r, "bary") && has_fault_seen(&r, "hit-group"));
    assert_int_equal(r.nfaults_seen, 3);
    free(g);
    fixture_free(&f);
}

/* IDs past the scene are faults of the dump, never reads past the arrays. */
static void test_out_of_range_ids(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "rtstress:2", 100, 13);
    rto_hit_record *g = copy_gpu(&f);
    const size_t i = hit_ray(&f, 30);
    const rto_hit_record keep = g[i];
    rto_report r;
    g[i].instance_id = 1000000;
    expect_fault(&f, g, f.n, RTO_HIT_INSTANCE, i, &r);
    assert_non_null(strstr(r.summary, "does not exist"));
    g[i].instance_id = UINT32_MAX;
    expect_fault(&f, g, f.n, RTO_HIT_INSTANCE, i, &r);
    g[i] = keep;
    g[i].prim_id = 12;
    expect_fault(&f, g, f.n, RTO_HIT_PRIM, i, &r);
    assert_non_null(strstr(r.summary, "does not exist"));
    g[i].prim_id = UINT32_MAX;
    expect_fault(&f, g, f.n, RTO_HIT_PRIM, i, &r);
    g[i] = keep;
    /* first-hit rays take the same range checks */
    f.rays[i].flags = RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT;
    fixture_trace(&f);
    g[i] = f.expected[i];
    g[i].instance_id = 1000000;
    expect_fault(&f, g, f.n, RTO_HIT_INSTANCE, i, &r);
    g[i] = f.expected[i];
    g[i].prim_id = 1000000;
    expect_fault(&f, g, f.n, RTO_HIT_PRIM, i, &r);
    free(g);
    fixture_free(&f);
}

/* The primary fault is the highest-priority fault of the first wrong ray; every class seen is listed. */
static void test_priority_and_faults_seen(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "rtstress:2", 200, 17);
    rto_hit_record *g = copy_gpu(&f);
    const size_t a = hit_ray(&f, 20), b = hit_ray(&f, a + 1), c = miss_ray(&f, b + 1);
    rto_report r;
    /* one ray, two faults: t before custom-index */
    g[a].custom_index += 1;
    g[a].t *= 1.01f;
    expect_fault(&f, g, f.n, RTO_HIT_T, a, &r);
    assert_true(has_fault_seen(&r, "custom-index"));
    assert_non_null(row_at(&r, a, "customIndex"));
    /* a later ray's higher-priority fault does not take over, but is listed */
    g[c].miss_flag = 0;
    g[b].bary[0] += 0.01f;
    expect_fault(&f, g, f.n, RTO_HIT_T, a, &r);
    assert_true(has_fault_seen(&r, "miss-flag") && has_fault_seen(&r, "bary"));
    assert_int_equal(r.nfaults_seen, 4);
    assert_int_equal(fact(&r, "wrong_rays"), 3);
    assert_int_equal(rto_report_check_state(&r, "miss"), RTO_CHECK_FAILED);
    assert_int_equal(rto_report_check_state(&r, "bary"), RTO_CHECK_FAILED);
    assert_int_equal(rto_report_check_state(&r, "primitive"), RTO_CHECK_PASSED);
    /* rows of later wrong rays follow the primary ray's */
    assert_non_null(row_at(&r, b, "bary.u"));
    assert_non_null(row_at(&r, c, "missFlag"));
    assert_int_equal(r.rows[0].index, a);
    free(g);
    fixture_free(&f);
}

/* The model's bounds (DESIGN.md §9) on a Box ray: t and a barycentric at the end of their intervals pass, at twice
 * the distance from the oracle's value fail; NaN and infinity fail. (tests/test_conformance.c does this field by
 * field on many rays.) */
static void test_tolerances(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "Box/glTF/Box.gltf", 50, 19);
    rto_hit_record *g = copy_gpu(&f);
    const size_t i = hit_ray(&f, 5);
    cf_scene cs;
    assert_int_equal(cf_scene_init(&cs, f.scene, NULL), RTO_OK);
    cf_prim p;
    cf_prim_eval(&cs, f.expected[i].instance_id, f.expected[i].prim_id, &f.rays[i], f.rays[i].t_max, &p);
    cf_scene_free(&cs);
    assert_int_equal(p.hit, CF_CERTAIN);
    const float t = f.expected[i].t, u = f.expected[i].bary[0];
    /* the bounds are small: the Box's coordinates are exact and its rays well conditioned */
    assert_true(p.tri.t.hi - p.tri.t.lo < 1e-5 * fmax(1.0, fabs((double)t)) && p.tri.t.hi > p.tri.t.lo);
    rto_report r;
    expect_pass(&f, g, 0, &r); /* the test's records, computed in binary64: most differ from the oracle's bits */
    const int64_t differ = fact(&r, "accepted_arithmetic");
    g[i].t = nextafterf((float)p.tri.t.hi, 0.0f);
    g[i].bary[0] = nextafterf((float)p.tri.u.lo, 1.0f);
    expect_pass(&f, g, 0, &r);
    assert_int_equal(fact(&r, "accepted_arithmetic"), differ + (memcmp(&f.gpu[i], &f.expected[i], 32) == 0));
    g[i].t = (float)((double)t + 2.0 * (p.tri.t.hi - (double)t));
    expect_fault(&f, g, f.n, RTO_HIT_T, i, &r);
    g[i].t = t;
    g[i].bary[0] = (float)((double)u - 2.0 * ((double)u - p.tri.u.lo));
    expect_fault(&f, g, f.n, RTO_HIT_BARY, i, &r);
    g[i].bary[0] = NAN;
    expect_fault(&f, g, f.n, RTO_HIT_BARY, i, &r);
    g[i] = f.gpu[i];
    g[i].t = NAN;
    expect_fault(&f, g, f.n, RTO_HIT_T, i, &r);
    g[i].t = INFINITY;
    expect_fault(&f, g, f.n, RTO_HIT_T, i, &r);
    free(g);
    fixture_free(&f);
}

/* Two triangles of one Box face share its diagonal: a ray through the diagonal's midpoint, along the face normal,
 * computes exactly (the Box's coordinates are +-0.5 and its rotation exact), so it hits both at the same t. The GPU
 * answering with the neighbour is a tie: accepted, counted, listed, and then held to the neighbour's own bary. */
/* The first two triangles p and q of the Box's mesh sharing two vertex indices a and b (one face's diagonal), the
 * diagonal's midpoint mid in world space, and a ray (o, d) along the face's inward normal that meets it there at
 * t = 2. */
typedef struct diagonal {
    uint32_t p, q, a, b;
    double wa[3], wb[3], mid[3], o[3], d[3];
} diagonal;

static diagonal face_diagonal(const rto_scene *s)
{
    diagonal g;
    memset(&g, 0, sizeof g);
    const rto_mesh *m = &s->meshes[s->instances[0].blas];
    int found = 0;
    for (uint32_t x = 0; x < m->triangle_count && !found; x++)
        for (uint32_t y = x + 1; y < m->triangle_count && !found; y++) {
            int shared = 0;
            uint32_t sv[3];
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    if (m->indices[3 * x + i] == m->indices[3 * y + j])
                        sv[shared++] = m->indices[3 * x + i];
            if (shared == 2) {
                g.p = x, g.q = y, g.a = sv[0], g.b = sv[1];
                found = 1;
            }
        }
    assert_true(found);
    /* the diagonal's midpoint and the face normal, in world space */
    double *wa = g.wa, *wb = g.wb, w[3][3], e1[3], e2[3], nrm[3];
    for (int c = 0; c < 3; c++)
        tu_world_vertex(s, 0, g.p, c, w[c]);
    for (int r = 0; r < 3; r++) {
        const rto_mat34 *M = &s->instances[0].obj_to_world;
        const float *va = &m->positions[3 * g.a], *vb = &m->positions[3 * g.b];
        wa[r] = (double)M->m[r][0] * va[0] + (double)M->m[r][1] * va[1] + (double)M->m[r][2] * va[2] + M->m[r][3];
        wb[r] = (double)M->m[r][0] * vb[0] + (double)M->m[r][1] * vb[1] + (double)M->m[r][2] * vb[2] + M->m[r][3];
        g.mid[r] = 0.5 * (wa[r] + wb[r]);
        e1[r] = w[1][r] - w[0][r];
        e2[r] = w[2][r] - w[0][r];
    }
    nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
    nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
    nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
    normalize(nrm);
    const double side = nrm[0] * g.mid[0] + nrm[1] * g.mid[1] + nrm[2] * g.mid[2]; /* the Box is centred on 0 */
    for (int r = 0; r < 3; r++) {
        g.d[r] = side < 0 ? nrm[r] : -nrm[r];
        g.o[r] = g.mid[r] - 2.0 * g.d[r];
    }
    return g;
}

static void test_tie_on_shared_edge(void **state)
{
    (void)state;
    fixture f;
    fixture_alloc(&f, "Box/glTF/Box.gltf", 1);
    const rto_scene *s = f.scene;
    const rto_mesh *m = &s->meshes[s->instances[0].blas];
    const diagonal g = face_diagonal(s);
    const uint32_t p = g.p, q = g.q, a = g.a, b = g.b;
    const double *o = g.o, *d = g.d;
    f.rays[0] = ray_of(o, d, RTO_RAY_FLAG_OPAQUE, 0);
    fixture_trace(&f);
    rto_hit_record *e = f.expected;
    assert_int_equal(e[0].miss_flag, 0);
    assert_true(e[0].prim_id == p || e[0].prim_id == q);
    const uint32_t other = e[0].prim_id == p ? q : p;
    /* precondition: the ray meets both triangles (the exact arithmetic above) */
    rto_tri_hit hp, hq;
    assert_true(rto_instance_triangle_hit(&s->instances[0], m, p, &f.rays[0], &hp));
    assert_true(rto_instance_triangle_hit(&s->instances[0], m, q, &f.rays[0], &hq));

    /* the neighbour's record, from the scene alone: the midpoint weighs its two diagonal vertices 1/2 each */
    double wt[3] = {0, 0, 0};
    for (int c = 0; c < 3; c++)
        wt[c] = (m->indices[3 * other + c] == a || m->indices[3 * other + c] == b) ? 0.5 : 0.0;
    f.gpu[0] = record_of(s, 0, other, 2.0, wt[1], wt[2]);
    rto_report r;
    expect_pass(&f, f.gpu, 1, &r);
    const rto_report_row *row = row_at(&r, 0, "accepted.primId");
    assert_non_null(row);
    assert_int_equal(row->expected.v.u, e[0].prim_id);
    assert_int_equal(row->actual.v.u, other);
    assert_non_null(row_at(&r, 0, "accepted.t"));
    assert_null(row_at(&r, 0, "accepted.instanceId"));
    assert_non_null(strstr(r.summary, "1 tie"));
    /* a tie is held to the neighbour's values: the oracle's own bary with the neighbour's ID is wrong (the midpoint
     * of the diagonal has one barycentric 0 in one triangle and 1/2 in the other at the same slot, or the slots
     * differ) unless both coincide */
    rto_hit_record mixed = e[0];
    mixed.prim_id = other;
    if (fabs((double)mixed.bary[0] - wt[1]) > 1e-4 || fabs((double)mixed.bary[1] - wt[2]) > 1e-4) {
        expect_fault(&f, &mixed, 1, RTO_HIT_BARY, 0, &r);
    }
    /* and a wrong t for the tied primitive is a t fault */
    f.gpu[0].t = 2.1f;
    expect_fault(&f, f.gpu, 1, RTO_HIT_T, 0, &r);
    fixture_free(&f);
}

/* A GPU's division and fused multiply-adds decide a ray through an edge differently (§9's grazing rule). Rays along
 * the inward normal of a Box face: 0 through the face's diagonal, 1 the same line from inside the Box (to find the
 * far face), 2 through the inside of triangle p, 3 the same line from inside. The point on the diagonal is chosen
 * so that the far face is met well inside one of its triangles (every barycentric of the oracle's hit >= 0.1), which
 * makes the far hit solid. */
static void test_grazing(void **state)
{
    (void)state;
    fixture f;
    fixture_alloc(&f, "Box/glTF/Box.gltf", 4);
    const rto_scene *s = f.scene;
    const diagonal g = face_diagonal(s);
    const rto_mesh *m = &s->meshes[s->instances[0].blas];
    /* a point inside triangle p: a quarter of the way from the midpoint to p's third vertex */
    uint32_t third = 0;
    for (int c = 0; c < 3; c++)
        if (m->indices[3 * g.p + c] != g.a && m->indices[3 * g.p + c] != g.b)
            third = (uint32_t)c;
    double w[3], in[3], o[3];
    tu_world_vertex(s, 0, g.p, (int)third, w);
    for (int r = 0; r < 3; r++)
        in[r] = g.mid[r] + 0.25 * (w[r] - g.mid[r]);
    /* tilted towards p's third vertex (the far face's diagonal may lie right behind the near one's) */
    double dir[3];
    for (int r = 0; r < 3; r++)
        dir[r] = g.d[r] + 0.3 * (w[r] - g.mid[r]);
    const double fractions[] = {0.5, 0.3, 0.7, 0.2, 0.8};
    double on[3];
    int solid = 0;
    for (size_t fi = 0; fi < sizeof fractions / sizeof fractions[0] && !solid; fi++) {
        for (int r = 0; r < 3; r++)
            on[r] = fractions[fi] * g.wa[r] + (1 - fractions[fi]) * g.wb[r];
        const double *start[2] = {on, in};
        for (int k = 0; k < 2; k++) {
            for (int r = 0; r < 3; r++)
                o[r] = start[k][r] - 2.0 * dir[r];
            f.rays[2 * k] = ray_of(o, dir, RTO_RAY_FLAG_OPAQUE, (uint32_t)(2 * k));
            for (int r = 0; r < 3; r++)
                o[r] = start[k][r] + 0.5 * dir[r];
            f.rays[2 * k + 1] = ray_of(o, dir, RTO_RAY_FLAG_OPAQUE, (uint32_t)(2 * k + 1));
        }
        fixture_trace(&f);
        const double u = f.expected[1].bary[0], v = f.expected[1].bary[1];
        solid = !f.expected[1].miss_flag && u >= 0.1 && v >= 0.1 && 1 - u - v >= 0.1;
    }
    assert_true(solid);
    const rto_hit_record *e = f.expected;
    for (int k = 0; k < 4; k++)
        assert_int_equal(e[k].miss_flag, 0);
    assert_true(fabs(e[0].t - 2.0) < 1e-5 && fabs(e[2].t - 2.0) < 1e-5);
    memcpy(f.gpu, e, 4 * sizeof *f.gpu);
    rto_report r;
    expect_pass(&f, f.gpu, 0, &r);
    assert_int_equal(fact(&r, "accepted_edge"), 0);

    /* ray 0 passes between the two triangles of the diagonal and hits the far face: an edge, listed and counted */
    f.gpu[0] = e[1];
    f.gpu[0].t = e[1].t + 2.5f;
    expect_pass(&f, f.gpu, 0, &r);
    assert_int_equal(fact(&r, "accepted_edge"), 1);
    assert_non_null(strstr(r.summary, "1 edge (the first at ray 0)"));
    const rto_report_row *row = row_at(&r, 0, "accepted.primId");
    assert_non_null(row);
    assert_int_equal(row->expected.v.u, e[0].prim_id);
    assert_int_equal(row->actual.v.u, e[1].prim_id);
    /* ... and is then held to the far face's values: a wrong t there is a t fault */
    f.gpu[0].t += 0.01f;
    expect_fault(&f, f.gpu, 4, RTO_HIT_T, 0, &r);
    /* a miss there is wrong: the far face is hit solidly behind the edge */
    f.gpu[0] = rto_hit_record_miss(f.rays[0].t_max);
    expect_fault(&f, f.gpu, 4, RTO_HIT_MISS_FLAG, 0, &r);
    f.gpu[0] = e[0];
    /* ray 2 meets triangle p far from its edges: passing it to the far face is a prim fault, a miss a miss-flag one */
    f.gpu[2] = e[3];
    f.gpu[2].t = e[3].t + 2.5f;
    expect_fault(&f, f.gpu, 4, RTO_HIT_PRIM, 2, &r);
    assert_int_equal(fact(&r, "accepted_edge"), 0);
    f.gpu[2] = rto_hit_record_miss(f.rays[2].t_max);
    expect_fault(&f, f.gpu, 4, RTO_HIT_MISS_FLAG, 2, &r);
    /* an expected miss where the GPU names the triangle every conforming implementation hits: the expected record
     * cannot be the oracle's, and the ray is named */
    const rto_hit_record solid_hit = f.expected[2];
    f.expected[2] = rto_hit_record_miss(f.rays[2].t_max);
    f.gpu[2] = solid_hit;
    expect_fault(&f, f.gpu, 4, RTO_HIT_MISS_FLAG, 2, &r);
    if (!strstr(r.summary, "does not hold the oracle's records"))
        fail_msg("%s", r.summary);
    f.expected[2] = solid_hit;
    fixture_free(&f);
}

/* Two parallel triangles, delta apart along a ray that meets them at t = 10 and 10 + delta: claiming the farther one
 * is a tie when the model cannot tell the two t apart (delta under the bound of t at 10), and a prim fault when the
 * nearer one is certainly hit before it (delta twice the bound). */
static void near_tie(double delta, int want_tie)
{
    const float z = (float)-delta;
    float pos[18] = {-1, -1, 0, 1, -1, 0, 0, 1, 0, -1, -1, z, 1, -1, z, 0, 1, z};
    uint32_t idx[6] = {0, 1, 2, 3, 4, 5};
    const double id[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    tu_scene1 one;
    tu_scene1_make(&one, pos, 6, idx, 2, id);
    one.inst.custom_index = 5;
    one.inst.sbt_offset = 2;
    rto_scene sc = one.scene;
    rto_msg msg = {{0}};
    fixture f;
    memset(&f, 0, sizeof f);
    f.scene = &sc;
    assert_int_equal(rto_accel_build(&sc, NULL, &f.accel, &msg), RTO_OK);
    f.n = 3;
    f.rays = calloc(3, sizeof *f.rays);
    f.gpu = calloc(3, sizeof *f.gpu);
    assert_true(f.rays && f.gpu);
    const double o[3] = {0, 0, 10}, d[3] = {0, 0, -1}, away[3] = {0, 0, 1};
    f.rays[0] = ray_of(away, away, RTO_RAY_FLAG_OPAQUE, 0);
    f.rays[1] = ray_of(o, d, RTO_RAY_FLAG_OPAQUE, 1);
    f.rays[2] = ray_of(away, away, RTO_RAY_FLAG_OPAQUE, 2);
    fixture_trace(&f);
    assert_int_equal(f.expected[1].prim_id, 0);
    assert_true(f.expected[1].t == 10.0f);
    f.gpu[0] = miss_of(f.rays[0].t_max);
    f.gpu[2] = miss_of(f.rays[2].t_max);
    /* (0, 0) is at barycentrics (1/4, 1/2) in both triangles */
    f.gpu[1] = record_of(&sc, 0, 1, 10.0 + (double)-z, 0.25, 0.5);
    rto_report r;
    if (want_tie) {
        expect_pass(&f, f.gpu, 1, &r);
        assert_non_null(row_at(&r, 1, "accepted.primId"));
    } else {
        expect_fault(&f, f.gpu, 3, RTO_HIT_PRIM, 1, &r);
        assert_non_null(row_at(&r, 1, "primId"));
        assert_non_null(strstr(r.summary, "every conforming implementation reaches and hits triangle 0"));
    }
    rto_accel_destroy(f.accel);
    free(f.rays);
    free(f.expected);
    free(f.gpu);
}

/* The half-width of the model's interval for t on the near triangle of near_tie's scene (z = 0, t = 10). */
static double near_bound(void)
{
    float pos[9] = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
    cf_ray r;
    const rto_wf_ray ray = {{0, 0, 10}, 0, {0, 0, -1}, 1e30f, 0, 0, 0xFF, 0, 0, 0, 0, 0};
    cf_ray_world(&ray, &r);
    cf_tri x;
    cf_triangle(&pos[0], &pos[3], &pos[6], &r, &x);
    assert_true(x.t.lo <= 10.0 && x.t.hi >= 10.0);
    return fmax(x.t.hi - 10.0, 10.0 - x.t.lo);
}

static void test_near_tie(void **state)
{
    (void)state;
    const double w = near_bound();
    print_message("t at 10 on the near triangle: the model's bound is %.3g\n", w);
    assert_true(w > 0 && w < 1e-4);
    near_tie(0.5 * w, 1);
    near_tie(3.0 * w, 0);
}

/* TERMINATE_ON_FIRST_HIT rays: any primitive the ray hits, at its own t, is right; nothing else is compared. */
static void test_first_hit_rays(void **state)
{
    (void)state;
    fixture f;
    fixture_alloc(&f, "rtstress:2", 4);
    /* along +x through both cubes of a row (cubes at x = -1 and 1, y = z = -1) */
    const double o[3] = {-5, -1.1, -0.8}, d[3] = {1, 0, 0};
    for (size_t i = 0; i < 4; i++)
        f.rays[i] = ray_of(o, d, RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT, (uint32_t)i);
    fixture_trace(&f);
    memcpy(f.gpu, f.expected, 4 * sizeof *f.gpu);
    rto_report r;
    expect_pass(&f, f.gpu, 0, &r);
    assert_int_equal(fact(&r, "first_hit_rays"), 4);
    /* the far face of the second cube (instance 1, x in [0.5, 1.5]), found by the test */
    const rto_scene *s = f.scene;
    const rto_mesh *m = &s->meshes[0];
    uint32_t far = UINT32_MAX;
    float far_t = 0;
    for (uint32_t p = 0; p < m->triangle_count; p++) {
        double w[3][3];
        for (int c = 0; c < 3; c++)
            tu_world_vertex(s, 1, p, c, w[c]);
        rto_tri_hit h;
        if (w[0][0] == 1.5 && w[1][0] == 1.5 && w[2][0] == 1.5 &&
            rto_instance_triangle_hit(&s->instances[1], m, p, &f.rays[1], &h)) {
            far = p;
            far_t = h.t;
        }
    }
    assert_true(far != UINT32_MAX);
    assert_true(fabs((double)far_t - 6.5) < 1e-5);
    f.gpu[1] = record_of(s, 1, far, far_t, 0.5, 0.5); /* bary, customIndex: not compared for first-hit rays */
    f.gpu[1].custom_index = 99;
    expect_pass(&f, f.gpu, 0, &r);
    /* a hit on an instance the ray does not pass (instance 7, the cube at (1, 1, 1)) */
    f.gpu[2].instance_id = 7;
    expect_fault(&f, f.gpu, 4, RTO_HIT_INSTANCE, 2, &r);
    f.gpu[2] = f.expected[2];
    /* a triangle of the oracle's instance on a face parallel to the ray (y = const): missed */
    uint32_t missed = UINT32_MAX;
    for (uint32_t p = 0; p < m->triangle_count && missed == UINT32_MAX; p++) {
        double w[3][3];
        for (int c = 0; c < 3; c++)
            tu_world_vertex(s, f.expected[2].instance_id, p, c, w[c]);
        if (w[0][1] == w[1][1] && w[1][1] == w[2][1])
            missed = p;
    }
    f.gpu[2].prim_id = missed;
    expect_fault(&f, f.gpu, 4, RTO_HIT_PRIM, 2, &r);
    f.gpu[2] = f.expected[2];
    /* the right primitive at the wrong distance */
    f.gpu[3].t = f.expected[3].t * 1.001f;
    expect_fault(&f, f.gpu, 4, RTO_HIT_T, 3, &r);
    f.gpu[3] = f.expected[3];
    /* hit / miss is defined */
    f.gpu[3] = miss_of(f.rays[3].t_max);
    expect_fault(&f, f.gpu, 4, RTO_HIT_MISS_FLAG, 3, &r);
    fixture_free(&f);
}

/* Generated ray sets (rto_rays_generate) on the tracing-test scenes — mirroring transforms, a mask-0 instance, shared
 * edges, a closed sphere — checked against the brute-force tracer's records, an independent traversal: they pass,
 * with ties where brute force keeps another primitive at the same t (axis rays through the sphere's vertices and
 * edges), grazing rays included (brute force has no box to reject a ray just outside a triangle: a conforming
 * implementation, §9), and a mutation is still named at its ray. */
static void generated(const char *spec, rto_ray_set set, size_t count, int want_ties)
{
    fixture f;
    memset(&f, 0, sizeof f);
    f.scene = tu_load(spec);
    rto_msg msg = {{0}};
    if (rto_accel_build(f.scene, NULL, &f.accel, &msg))
        fail_msg("build %s: %s", spec, msg.text);
    rto_rays_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.set = set;
    rd.seed = 5;
    rd.width = 64;
    rd.height = 48;
    rd.count = count;
    const size_t cap = rto_rays_capacity(&rd);
    f.rays = calloc(cap ? cap : 1, sizeof *f.rays);
    assert_non_null(f.rays);
    if (rto_rays_generate(f.accel, &rd, f.rays, cap, &f.n, NULL, &msg))
        fail_msg("%s %s: %s", spec, rto_ray_set_name(set), msg.text);
    assert_true(f.n > 100);
    fixture_trace(&f);
    f.gpu = calloc(f.n, sizeof *f.gpu);
    assert_non_null(f.gpu);
    assert_int_equal(rto_trace_brute(f.scene, f.rays, f.n, NULL, f.gpu, &msg), RTO_OK);
    rto_report r;
    rto_hits_check_desc d = desc_of(&f, f.gpu, f.n);
    if (rto_hits_check(&d, &r, &msg) != RTO_OK)
        fail_msg("%s %s rays: brute force fails: %s %s", spec, rto_ray_set_name(set), r.summary, msg.text);
    if (want_ties)
        assert_true(fact(&r, "ties") > 0);
    expect_pass(&f, f.expected, 0, &r);
    /* a mutation in the middle */
    size_t i = f.n / 2;
    while (i < f.n && f.expected[i].miss_flag)
        i++;
    assert_true(i < f.n);
    memcpy(f.gpu, f.expected, f.n * sizeof *f.gpu);
    if (f.rays[i].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) {
        f.gpu[i].instance_id = f.scene->instance_count;
        expect_fault(&f, f.gpu, f.n, RTO_HIT_INSTANCE, i, &r);
    } else {
        f.gpu[i].t *= 1.001f;
        expect_fault(&f, f.gpu, f.n, RTO_HIT_T, i, &r);
    }
    fixture_free(&f);
}

static void test_generated_rays(void **state)
{
    (void)state;
    generated("random:2", RTO_RAYS_PRIMARY, 0, 0);
    generated("random:2", RTO_RAYS_RANDOM, 3000, 0);
    generated("random:2", RTO_RAYS_SHADOW, 0, 0);
    generated("sphere:2", RTO_RAYS_AXIS, 3000, 1);
    generated("sphere:2", RTO_RAYS_GRAZING, 3000, 0);
    generated("random:5", RTO_RAYS_GRAZING, 3000, 0);
    generated("Box/glTF/Box.gltf", RTO_RAYS_PRIMARY, 0, 0);
}

/* Unusable input is an error, not a verdict: NULLs, inconsistent expected records, a broken scene. */
static void test_input_errors(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, "rtstress:2", 40, 23);
    rto_report r;
    rto_msg msg = {{0}};
    rto_hits_check_desc d = desc_of(&f, f.gpu, f.n);
    assert_int_equal(rto_hits_check(NULL, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_hits_check(&d, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.rays = NULL;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = desc_of(&f, NULL, f.n);
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = desc_of(&f, f.gpu, f.n);
    d.instances = NULL;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = desc_of(&f, f.gpu, f.n);
    d.mesh_count = 0;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "names mesh"));
    /* a mesh index past its vertices */
    d = desc_of(&f, f.gpu, f.n);
    rto_mesh mesh = f.scene->meshes[0];
    uint32_t *idx = malloc(3 * mesh.triangle_count * sizeof *idx);
    assert_non_null(idx);
    memcpy(idx, mesh.indices, 3 * mesh.triangle_count * sizeof *idx);
    idx[7] = mesh.vertex_count;
    mesh.indices = idx;
    d.meshes = &mesh;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "index 7"));
    free(idx);
    /* expected records that are not the oracle's: each refused, naming the record */
    const size_t i = hit_ray(&f, 5), j = miss_ray(&f, 0);
    const rto_hit_record ke = f.expected[i], km = f.expected[j];
    rto_hit_record *e = f.expected;
    e[i].t *= 1.01f;
    d = desc_of(&f, f.gpu, f.n);
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    char want[64];
    snprintf(want, sizeof want, "expected record %zu", i);
    assert_non_null(strstr(msg.text, want));
    e[i] = ke;
    e[i].prim_id = 1000;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    e[i] = ke;
    e[i].custom_index ^= 1;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    e[i] = ke;
    e[i].miss_flag = 3;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    e[i] = ke;
    e[j].t = 1.0f;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    snprintf(want, sizeof want, "expected record %zu", j);
    assert_non_null(strstr(msg.text, want));
    e[j] = km;
    /* rays that cannot be traced */
    f.rays[3].dir[1] = NAN;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "ray 3"));
    f.rays[3] = f.rays[4];
    f.rays[3].t_min = 2e30f;
    assert_int_equal(rto_hits_check(&d, &r, &msg), RTO_ERR_INVALID_ARGUMENT);
    fixture_free(&f);
    /* nothing to compare passes */
    rto_hits_check_desc empty;
    memset(&empty, 0, sizeof empty);
    assert_int_equal(rto_hits_check(&empty, &r, &msg), RTO_OK);
    assert_true(rto_report_passed(&r));
    assert_int_equal(rto_hit_fault_name((rto_hit_fault)99)[0], 'u');
    static const char *const names[] = {"none", "size", "miss-flag", "instance", "prim", "t", "bary",
                                        "custom-index", "hit-group", "transform"};
    for (int k = 0; k < 10; k++)
        assert_string_equal(rto_hit_fault_name((rto_hit_fault)k), names[k]);
}

/* rto__hits_check_records, the rule for primitives the model cannot re-intersect (check-frame's stage2 scene): each
 * record against the expected one, missFlag, IDs, customIndex, hitGroup and objToWorld exact, t within
 * 1e-5 max(1, |t|), u and v within 1e-4. Each bound from both sides, 1e-6 of the bound or more away from it (far above
 * binary32's spacing there: 2^-22 at 4, 2^-25 at 0.25); no scene is given, none is read. */
static rto_status records_check(const rto_wf_ray *rays, const rto_hit_record *e, const rto_hit_record *g, size_t n,
                                rto_report *r)
{
    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = rays;
    d.ray_count = n;
    d.expected = e;
    d.gpu = g;
    d.gpu_count = n;
    rto_msg msg = {{0}};
    return rto__hits_check_records(&d, r, &msg);
}

static void test_records_only(void **state)
{
    (void)state;
    const double o[3] = {0, 0, 5}, dir[3] = {0, 0, -1};
    rto_wf_ray rays[3];
    rto_hit_record e[3];
    for (int k = 0; k < 3; k++)
        rays[k] = tu_ray(o, dir, 0.001f, 1000.0f, 0);
    memset(e, 0, sizeof e);
    /* ray 0 hits primitive 0 of instance 2 at t 4, ray 1 primitive 0 of instance 1 at t 0.5, ray 2 misses */
    e[0].t = 4.0f;
    e[0].instance_id = 2;
    e[0].custom_index = 2;
    e[0].hit_group = 1;
    e[0].bary[0] = 0.25f;
    e[0].bary[1] = 0.5f;
    e[0].obj_to_world[0][0] = e[0].obj_to_world[1][1] = e[0].obj_to_world[2][2] = 1.0f;
    e[0].obj_to_world[3][2] = -1.0f;
    e[1] = e[0];
    e[1].t = 0.5f;
    e[1].instance_id = e[1].custom_index = 1;
    e[2] = tu_miss_record(1000.0f);
    rto_hit_record g[3];
    rto_report r;
    memcpy(g, e, sizeof g);
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_OK);
    assert_int_equal(fact(&r, "accepted_differences"), 0);

    /* t: 4e-5 at t = 4, 1e-5 at t = 0.5 (max(1, |t|)); u and v: 1e-4 */
    g[0].t = 4.000039f;
    g[1].t = 0.500009f;
    g[0].bary[0] = 0.250099f;
    g[0].bary[1] = 0.499901f;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_OK);
    assert_int_equal(fact(&r, "accepted_arithmetic"), 2);
    const struct {
        size_t ray;
        float *field, value;
        rto_hit_fault fault;
        const char *row;
    } over[] = {
        {0, &g[0].t, 4.000041f, RTO_HIT_T, "t"},
        {0, &g[0].t, 3.999959f, RTO_HIT_T, "t"},
        {1, &g[1].t, 0.500011f, RTO_HIT_T, "t"},
        {1, &g[1].t, 0.499989f, RTO_HIT_T, "t"},
        {0, &g[0].bary[0], 0.250101f, RTO_HIT_BARY, "bary.u"},
        {0, &g[0].bary[1], 0.499899f, RTO_HIT_BARY, "bary.v"},
        {1, &g[1].obj_to_world[3][2], -0.99999994f, RTO_HIT_TRANSFORM, "objToWorld[3][2]"},
        {2, &g[2].t, 999.98f, RTO_HIT_T, "t"}, /* a miss record's t too: 1e-2 at tMax 1000 */
        {0, &g[0].t, NAN, RTO_HIT_T, "t"},
    };
    for (size_t k = 0; k < sizeof over / sizeof over[0]; k++) {
        const float keep = *over[k].field;
        *over[k].field = over[k].value;
        assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
        assert_int_equal(r.code, over[k].fault);
        int64_t ray = -1;
        assert_true(rto_report_where(&r, "ray", &ray) && ray == (int64_t)over[k].ray);
        assert_true(r.nrows == 1 && !strcmp(r.rows[0].field, over[k].row));
        *over[k].field = keep;
    }
    g[2].t = 999.995f; /* within 1e-2 of tMax: accepted */
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_OK);
    assert_int_equal(fact(&r, "accepted_arithmetic"), 3);
    g[2].t = 1000.0f;

    /* IDs exact: another primitive, another instance, a miss for a hit and the reverse, customIndex, hitGroup */
    g[0].prim_id = 1;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_PRIM);
    assert_non_null(strstr(r.summary, "prim: ray 0: "));
    g[0] = e[0];
    g[1].instance_id = 3;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_INSTANCE);
    g[1] = tu_miss_record(1000.0f);
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_MISS_FLAG);
    g[1] = e[1];
    g[2] = e[0];
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_MISS_FLAG);
    g[2] = e[2];
    g[2].instance_id = 0; /* a miss record naming an instance */
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_INSTANCE);
    g[2] = e[2];
    g[0].custom_index = 3;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_CUSTOM_INDEX);
    g[0] = e[0];
    g[1].hit_group = 0;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_HIT_GROUP);
    g[1] = e[1];
    g[0].miss_flag = 2;
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_MISS_FLAG);
    g[0] = e[0];
    /* a short dump is a size fault, as in rto_hits_check */
    assert_int_equal(records_check(rays, e, g, 3, &r), RTO_OK);
    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = rays;
    d.ray_count = 3;
    d.expected = e;
    d.gpu = g;
    d.gpu_count = 2;
    rto_msg msg = {{0}};
    assert_int_equal(rto__hits_check_records(&d, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_HIT_SIZE);
}

/* The t and barycentric rules of §9 as core/tolerance.c states them, on boundaries computed here by hand: for
 * |t| <= 1 the t bound is 1e-5 itself, which 0 + 1e-5 and 2e-5 - 1e-5 reach exactly (inside) and the next double up
 * leaves (outside); above 1 it grows as |t| (1e-5 2^20 = 10.48576 at t = 2^20, margins far above the spacing of
 * doubles there); NaN is never within, nor an infinite value of a finite one or of itself (bit-identical values are
 * accepted before the rule), while an infinite e has an infinite bound; the sign of zero does not matter. The
 * barycentric bound is 1e-4 at any value. */
static void test_tolerance_rules(void **state)
{
    (void)state;
    const double T = 1e-5, B = 1e-4, big = 1048576.0;
    assert_true(rto__tol_t_scale(0.0) == 1.0 && rto__tol_t_scale(-0.0) == 1.0 && rto__tol_t_scale(0.5) == 1.0);
    assert_true(rto__tol_t_scale(-1.0) == 1.0 && rto__tol_t_scale(2.0) == 2.0 && rto__tol_t_scale(-3.0) == 3.0);
    assert_true(rto__tol_t_scale(NAN) == 1.0 && rto__tol_t_scale(-INFINITY) == INFINITY);
    assert_true(rto__tol_t(0.25) == T && rto__tol_t(-1.0) == T && rto__tol_t(-4.0) == 4 * T);
    assert_true(fabs(rto__tol_t(big) - 10.48576) < 1e-14);
    assert_true(rto__tol_t_close(0.0, T) && rto__tol_t_close(0.0, -T) && rto__tol_t_close(-0.0, T));
    assert_true(rto__tol_t_close(T, 2 * T) && rto__tol_t_close(2 * T, T));
    assert_false(rto__tol_t_close(0.0, nextafter(T, 1.0)) || rto__tol_t_close(0.0, -nextafter(T, 1.0)));
    assert_false(rto__tol_t_close(T, nextafter(2 * T, 1.0)));
    assert_true(rto__tol_t_close(big, big + 10.48575) && rto__tol_t_close(-big, -big - 10.48575));
    assert_false(rto__tol_t_close(big, big + 10.48577) || rto__tol_t_close(-big, -big + 10.48577));
    assert_false(rto__tol_t_close(1.0, 1.0 + 1.1e-5) || rto__tol_t_close(0.5, 0.5 - 1.1e-5));
    assert_true(rto__tol_t_close(0.0, -0.0) && rto__tol_t_close(-0.0, 0.0));
    assert_false(rto__tol_t_close(NAN, NAN) || rto__tol_t_close(1.0, NAN) || rto__tol_t_close(NAN, 1.0));
    assert_false(rto__tol_t_close(INFINITY, INFINITY) || rto__tol_t_close(-INFINITY, -INFINITY) ||
                 rto__tol_t_close(1.0, INFINITY) || rto__tol_t_close(-big, -INFINITY));
    assert_true(rto__tol_t_close(INFINITY, 1.0) && rto__tol_t(-INFINITY) == INFINITY);

    assert_true(rto__tol_bary_close(0.0, B) && rto__tol_bary_close(0.0, -B) && rto__tol_bary_close(-0.0, B));
    assert_true(rto__tol_bary_close(B, 2 * B) && rto__tol_bary_close(0.0, -0.0));
    assert_false(rto__tol_bary_close(0.0, nextafter(B, 1.0)) || rto__tol_bary_close(0.0, -nextafter(B, 1.0)));
    assert_true(rto__tol_bary_close(0.5, 0.50009) && !rto__tol_bary_close(0.5, 0.50011));
    assert_false(rto__tol_bary_close(100.0, 100.00011)); /* no relative part */
    assert_false(rto__tol_bary_close(NAN, NAN) || rto__tol_bary_close(INFINITY, INFINITY) ||
                 rto__tol_bary_close(0.0, NAN));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_correct_dumps_pass),
        cmocka_unit_test(test_mutations_named),
        cmocka_unit_test(test_transposed_rotation),
        cmocka_unit_test(test_miss_record_fields),
        cmocka_unit_test(test_out_of_range_ids),
        cmocka_unit_test(test_priority_and_faults_seen),
        cmocka_unit_test(test_tolerances),
        cmocka_unit_test(test_tie_on_shared_edge),
        cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_near_tie),
        cmocka_unit_test(test_first_hit_rays),
        cmocka_unit_test(test_generated_rays),
        cmocka_unit_test(test_input_errors),
        cmocka_unit_test(test_records_only),
        cmocka_unit_test(test_tolerance_rules),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
