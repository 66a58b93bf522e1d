/* The hit validator (rto_hits_check, DESIGN.md §9). Rays are aimed by this file at known points of known triangles,
 * and the "GPU" dump of a correct tracer is written here too, in binary64 from the scene alone (t as the distance to
 * the aimed point, bary as the aimed barycentrics, the instance's IDs and transform), so the passing case does not
 * rest on the oracle agreeing with itself. Each mutation is then caught, named with its fault class, and located at
 * the ray where it was made; t and barycentrics at the ends of the model's intervals pass. This file holds the
 * fixture and its helpers, the correct dumps, the mutations and the tolerances, and main(); one executable
 * (unit.check_hits) with test_check_hits_ties.c (ties, grazing rays, first-hit rays, generated sets, input errors,
 * records-only checks and the tolerance rules). */
#include "test_check_hits.h"

#include "trace/conform.h"

#include <math.h>

void normalize(double v[3])
{
    const double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; a++)
        v[a] /= l;
}

/* The hit record a correct GPU writes, from the scene alone. */
rto_hit_record record_of(const rto_scene *s, uint32_t k, uint32_t p, double t, double u, double v)
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

rto_hit_record miss_of(float t_max) { return tu_miss_record(t_max); }

rto_wf_ray ray_of(const double o[3], const double d[3], uint32_t flags, uint32_t index)
{
    rto_wf_ray r = tu_ray(o, d, 0.0f, RTO_RAY_T_MAX, flags);
    r.pixel = r.payload_slot = index;
    return r;
}

void fixture_trace(fixture *f)
{
    rto_msg msg = {{0}};
    free(f->expected);
    f->expected = calloc(f->n ? f->n : 1, sizeof *f->expected);
    assert_non_null(f->expected);
    if (rto_trace(f->accel, f->rays, f->n, NULL, f->expected, NULL, &msg))
        fail_msg("rto_trace: %s", msg.text);
}

void fixture_alloc(fixture *f, const char *spec, size_t n)
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
void fixture_make(fixture *f, const char *spec, size_t n, uint64_t seed)
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

void fixture_free(fixture *f)
{
    rto_accel_destroy(f->accel);
    rto_scene_destroy(f->scene);
    free(f->rays);
    free(f->expected);
    free(f->gpu);
}

rto_hits_check_desc desc_of(const fixture *f, const rto_hit_record *gpu, size_t gn)
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

int64_t fact(const rto_report *r, const char *name)
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
const rto_report_row *row_at(const rto_report *r, size_t i, const char *field)
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

void expect_pass(const fixture *f, const rto_hit_record *gpu, int64_t ties, rto_report *r)
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
void expect_fault(const fixture *f, const rto_hit_record *gpu, size_t gn, rto_hit_fault want, size_t ray,
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
size_t hit_ray(const fixture *f, size_t from)
{
    for (size_t i = from; i < f->n; i++)
        if (!f->expected[i].miss_flag && fabs((double)f->expected[i].bary[0] - f->expected[i].bary[1]) > 0.01)
            return i;
    fail_msg("no hit ray after %zu", from);
    return 0;
}

size_t miss_ray(const fixture *f, size_t from)
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
