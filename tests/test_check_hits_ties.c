/* The hit validator (rto_hits_check, DESIGN.md §9), part of unit.check_hits (main() and the fixture in
 * test_check_hits.c): what a conforming GPU may answer differently. A legitimate tie (a ray through the shared
 * diagonal of a Box face answered with the neighbour triangle) is accepted and listed, and a near-tie just outside
 * the t tolerance is not; grazing rays, TERMINATE_ON_FIRST_HIT rays and the generated ray sets on the tracing-test
 * scenes. Then unusable input (an error, not a verdict), the records-only check and the t and barycentric rules of
 * core/tolerance.c on boundaries computed by hand. */
#include "test_check_hits.h"

#include "core/tolerance.h"
#include "trace/conform.h"
#include "trace/trace_internal.h"

#include <math.h>

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

void test_tie_on_shared_edge(void **state)
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
void test_grazing(void **state)
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

void test_near_tie(void **state)
{
    (void)state;
    const double w = near_bound();
    print_message("t at 10 on the near triangle: the model's bound is %.3g\n", w);
    assert_true(w > 0 && w < 1e-4);
    near_tie(0.5 * w, 1);
    near_tie(3.0 * w, 0);
}

/* TERMINATE_ON_FIRST_HIT rays: any primitive the ray hits, at its own t, is right; nothing else is compared. */
void test_first_hit_rays(void **state)
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

void test_generated_rays(void **state)
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
void test_input_errors(void **state)
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

void test_records_only(void **state)
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
void test_tolerance_rules(void **state)
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
