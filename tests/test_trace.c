/* The tracer (DESIGN.md §6) against independent references: hand-derived Möller–Trumbore values, the brute-force
 * tracer (no tree) on every fixture and on seeded random scenes, both TLAS layouts, ray flags, masks, culling,
 * counters, and byte-identical output for any thread count. Rays come from the tests' own generator (splitmix64 of
 * testutil.h), not from the library's ray sets, so a bug there cannot hide one here. */
#include "testutil.h"

#include <math.h>

static double axis(rto_vec3 v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }

static rto_wf_ray make_ray(const float o[3], const float d[3], uint32_t flags)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    memcpy(r.origin, o, sizeof r.origin);
    memcpy(r.dir, d, sizeof r.dir);
    r.t_min = 0.0f;
    r.t_max = 1e30f;
    r.flags = flags;
    r.cull_mask = 0xFF;
    return r;
}

/* A world-space point of triangle p of instance k: barycentric (b1, b2), through objToWorld in binary64. */
static void world_point(const rto_scene *s, uint32_t k, uint32_t p, double b1, double b2, double out[3])
{
    const rto_instance *in = &s->instances[k];
    const rto_mesh *m = &s->meshes[in->blas];
    double obj[3];
    for (int a = 0; a < 3; a++) {
        const double v0 = m->positions[3 * m->indices[3 * p] + a], v1 = m->positions[3 * m->indices[3 * p + 1] + a],
                     v2 = m->positions[3 * m->indices[3 * p + 2] + a];
        obj[a] = (1.0 - b1 - b2) * v0 + b1 * v1 + b2 * v2;
    }
    for (int r = 0; r < 3; r++)
        out[r] = in->obj_to_world.m[r][0] * obj[0] + in->obj_to_world.m[r][1] * obj[1] +
                 in->obj_to_world.m[r][2] * obj[2] + in->obj_to_world.m[r][3];
}

/* Test rays: a third from random points of the bounds in random directions, a third aimed at random points inside
 * random triangles, a third aimed exactly at vertices and edges (the cases where ties and rounding live). */
static rto_wf_ray *test_rays(const rto_scene *s, uint64_t seed, size_t n, uint32_t flags)
{
    rto_wf_ray *rays = calloc(n ? n : 1, sizeof *rays);
    assert_non_null(rays);
    uint64_t r = seed;
    const rto_aabb b = rto_scene_aabb(s);
    double ext = 0;
    for (int a = 0; a < 3; a++)
        ext = fmax(ext, axis(b.max, a) - axis(b.min, a));
    uint32_t with_tris = 0;
    for (uint32_t k = 0; k < s->instance_count; k++)
        with_tris += s->meshes[s->instances[k].blas].triangle_count > 0;
    for (size_t i = 0; i < n; i++) {
        float o[3], d[3];
        double dd[3];
        tu_rng_dir(&r, dd);
        for (int a = 0; a < 3; a++)
            d[a] = (float)dd[a];
        const int kind = with_tris ? (int)(i % 3) : 0;
        if (kind == 0) {
            for (int a = 0; a < 3; a++)
                o[a] = (float)(axis(b.min, a) + tu_rng_unit(&r) * (axis(b.max, a) - axis(b.min, a)));
        } else {
            uint32_t k;
            do
                k = (uint32_t)(tu_rng_next(&r) % s->instance_count);
            while (!s->meshes[s->instances[k].blas].triangle_count);
            const uint32_t p = (uint32_t)(tu_rng_next(&r) % s->meshes[s->instances[k].blas].triangle_count);
            double b1 = tu_rng_unit(&r), b2 = tu_rng_unit(&r);
            if (b1 + b2 > 1) {
                b1 = 1 - b1;
                b2 = 1 - b2;
            }
            if (kind == 2) { /* a vertex or a point of an edge, exactly in barycentric terms */
                const uint64_t c = tu_rng_next(&r) % 6;
                if (c < 3) {
                    b1 = c == 1;
                    b2 = c == 2;
                } else if (c == 3) {
                    b2 = 0;
                } else if (c == 4) {
                    b1 = 0;
                } else {
                    b2 = 1 - b1;
                }
            }
            double w[3];
            world_point(s, k, p, b1, b2, w);
            for (int a = 0; a < 3; a++)
                o[a] = (float)(w[a] - (double)d[a] * (ext + 1.0));
        }
        rays[i] = make_ray(o, d, flags);
    }
    return rays;
}

/* Where a ray really passes triangle p of mesh m: its barycentrics for the object-space f32 ray, in binary64, as the
 * smallest of u, v, 1 - u - v (negative: outside); and how far f32 Möller–Trumbore may be off in those terms: the
 * rounding of coordinates of magnitude `scale` (the object-space origin, the vertices) against the triangle's
 * smallest height, amplified by 1 / |cos| of the angle between the ray and the triangle's normal. */
static double edge_distance(const rto_mesh *m, uint32_t p, const float o[3], const float d[3], double *tolerance)
{
    double v[3][3], scale = 0;
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++) {
            v[k][a] = m->positions[3 * m->indices[3 * p + k] + a];
            scale = fmax(scale, fmax(fabs(v[k][a]), fabs((double)o[a])));
        }
    const double e1[3] = {v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]};
    const double e2[3] = {v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]};
    const double e3[3] = {v[2][0] - v[1][0], v[2][1] - v[1][1], v[2][2] - v[1][2]};
    const double s[3] = {o[0] - v[0][0], o[1] - v[0][1], o[2] - v[0][2]};
    const double pv[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
    const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
    const double nv[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
    const double u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
    const double w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    const double area2 = sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
    double longest = 0;
    const double *edges[3] = {e1, e2, e3};
    for (int k = 0; k < 3; k++)
        longest = fmax(longest, sqrt(edges[k][0] * edges[k][0] + edges[k][1] * edges[k][1] + edges[k][2] * edges[k][2]));
    const double dn = fabs(d[0] * nv[0] + d[1] * nv[1] + d[2] * nv[2]);
    const double dl = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
    const double cosine = dn / (dl * area2), height = area2 / longest;
    *tolerance = 1e-5 + 64.0 * 0x1p-24 * scale / (height * cosine);
    return fmin(fmin(u, w), 1.0 - u - w);
}

/* A hit of brute force that the tree did not reach is explained only when it lies on its triangle's boundary
 * (edge_distance within its tolerance): there Möller–Trumbore in f32 may accept a ray that passes just outside the
 * triangle and its box, and the slab test rightly turns the box down. */

typedef struct brute_stats {
    size_t ties;       /* a different primitive at the same t (within the §9 tolerance) */
    size_t exact_ties; /* of which at the bit-identical t */
    size_t boundary; /* brute force nearer, explained by a boundary hit */
} brute_stats;

/* Oracle hits against brute force: a miss on both sides, the same primitive with the same record byte for byte, or
 * a different primitive where both give the same t (§9: within 1e-5 max(1, |t|)); otherwise brute force found a nearer hit, which must be a
 * boundary hit (above). */
static brute_stats compare_with_brute(const char *what, uint64_t seed, const rto_scene *s, const rto_accel *acc,
                                      const rto_wf_ray *rays, size_t n)
{
    rto_hit_record *h = calloc(n ? n : 1, sizeof *h), *b = calloc(n ? n : 1, sizeof *b);
    assert_true(h && b);
    rto_msg msg = {{0}};
    if (rto_trace(acc, rays, n, NULL, h, NULL, &msg) || rto_trace_brute(s, rays, n, NULL, b, &msg))
        fail_msg("%s (seed %llu): %s", what, (unsigned long long)seed, msg.text);
    brute_stats st = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        if (h[i].miss_flag && b[i].miss_flag)
            continue;
        if (h[i].miss_flag == b[i].miss_flag && h[i].instance_id == b[i].instance_id && h[i].prim_id == b[i].prim_id) {
            if (memcmp(&h[i], &b[i], sizeof h[i]))
                fail_msg("%s (seed %llu) ray %zu: same primitive, records differ (t %.9g vs %.9g)", what,
                         (unsigned long long)seed, i, (double)h[i].t, (double)b[i].t);
            continue;
        }
        /* A tie: another primitive at the same t, within the §9 t tolerance (two triangles meeting at the hit
         * point give their t through different roundings). */
        if (!h[i].miss_flag && !b[i].miss_flag &&
            fabs((double)h[i].t - (double)b[i].t) <= 1e-5 * fmax(1.0, fabs((double)b[i].t))) {
            st.ties++;
            st.exact_ties += h[i].t == b[i].t;
            continue;
        }
        /* The tree missed or found a farther hit: brute force's hit must lie on its triangle's boundary. */
        double edge = -1, tol = 0;
        if (!b[i].miss_flag && (h[i].miss_flag || h[i].t > b[i].t)) {
            const rto_instance *in = &s->instances[b[i].instance_id];
            float o[3], d[3];
            rto_ray_to_object(&in->world_to_obj, rays[i].origin, rays[i].dir, o, d);
            edge = edge_distance(&s->meshes[in->blas], b[i].prim_id, o, d, &tol);
        }
        /* Only the rays aimed exactly at vertices and edges (every third ray of test_rays) may be boundary cases. */
        if (!(fabs(edge) <= tol) || i % 3 != 2)
            fail_msg("%s (seed %llu) ray %zu: oracle %s instance %u prim %u t %.9g, brute force %s instance %u prim %u "
                     "t %.9g (edge distance %.3g, tolerance %.3g)",
                     what, (unsigned long long)seed, i, h[i].miss_flag ? "miss" : "hit", h[i].instance_id,
                     h[i].prim_id, (double)h[i].t, b[i].miss_flag ? "miss" : "hit", b[i].instance_id, b[i].prim_id,
                     (double)b[i].t, edge, tol);
        st.boundary++;
    }
    free(h);
    free(b);
    return st;
}

static void check_scene(const char *spec, uint64_t seed, size_t n)
{
    rto_scene *s = tu_load(spec);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel *acc = tu_accel(s, kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP);
        rto_wf_ray *rays = test_rays(s, seed, n, RTO_RAY_FLAG_OPAQUE);
        char what[256];
        snprintf(what, sizeof what, "%s, %s TLAS", spec, kind ? "karras" : "sweep");
        const brute_stats st = compare_with_brute(what, seed, s, acc, rays, n);
        /* Boundary hits come only from the rays aimed exactly at vertices and edges (a third of them), and not
         * from most of those. */
        if (st.boundary > n / 6)
            fail_msg("%s (seed %llu): %zu of %zu rays are boundary disagreements", what, (unsigned long long)seed,
                     st.boundary, n);
        /* Culling both ways and first-hit rays take the same comparison (first-hit: only hit / miss is defined). */
        for (size_t i = 0; i < n; i++)
            rays[i].flags = i % 2 ? RTO_RAY_FLAG_CULL_BACK_FACING : RTO_RAY_FLAG_CULL_FRONT_FACING;
        compare_with_brute(what, seed, s, acc, rays, n);
        /* First-hit rays: a hit exactly when closest-hit traversal of the same tree finds one (compared with brute
         * force above), and the hit reported is a real hit of that ray. */
        rto_hit_record *h = calloc(n, sizeof *h), *b = calloc(n, sizeof *b);
        assert_true(h && b);
        rto_msg msg = {{0}};
        for (size_t i = 0; i < n; i++)
            rays[i].flags = 0;
        assert_int_equal(rto_trace(acc, rays, n, NULL, b, NULL, &msg), RTO_OK);
        for (size_t i = 0; i < n; i++)
            rays[i].flags = RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT;
        assert_int_equal(rto_trace(acc, rays, n, NULL, h, NULL, &msg), RTO_OK);
        for (size_t i = 0; i < n; i++) {
            if (h[i].miss_flag != b[i].miss_flag)
                fail_msg("%s (seed %llu) first-hit ray %zu: hit/miss differs from closest-hit traversal", what,
                         (unsigned long long)seed, i);
            if (!h[i].miss_flag) { /* the hit reported is a real hit of that ray */
                rto_tri_hit th;
                assert_true(h[i].instance_id < s->instance_count);
                const rto_instance *in = &s->instances[h[i].instance_id];
                assert_true(rto_instance_triangle_hit(in, &s->meshes[in->blas], h[i].prim_id, &rays[i], &th));
                assert_true(th.t == h[i].t);
            }
        }
        print_message("%-40s %zu rays: %zu ties (%zu at the identical t), %zu boundary hits beyond the tree\n",
                      what, n, st.ties, st.exact_ties, st.boundary);
        free(h);
        free(b);
        free(rays);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(s);
}

static void test_fixtures_match_brute_force(void **state)
{
    (void)state;
    static const char *const scenes[] = {
        "triangle",
        "rtstress:3",
        "instances:clustered:300",
        "Box/glTF/Box.gltf",
        "SimpleMeshes/glTF/SimpleMeshes.gltf",
        "Duck/glTF/Duck.gltf",
        "Suzanne/glTF/Suzanne.gltf",
        "WaterBottle/glTF/WaterBottle.gltf",
        "CornellBox-nvpro-glTF/cornellBox.gltf",
        "StanfordBunny/bunny.gltf",
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++)
        check_scene(scenes[i], 1000 + i, strstr(scenes[i], "bunny") ? TU_SIZED(600, 200) : TU_SIZED(3000, 1000));
}

/* The hand-derived Möller–Trumbore of the VulkanTriangle (v0 (1,1,0), v1 (-1,1,0), v2 (0,-1,0)) and its counters. */
static void test_triangle_by_hand(void **state)
{
    (void)state;
    rto_scene *s = tu_load("triangle");
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    const float o[3] = {0.0f, 0.5f, 5.0f}, d[3] = {0.0f, 0.0f, -1.0f};
    rto_wf_ray rays[3] = {make_ray(o, d, 0), make_ray(o, d, RTO_RAY_FLAG_CULL_FRONT_FACING), make_ray(o, d, 0)};
    rays[2].t_max = 4.0f; /* the box lies beyond tMax: one box test, nothing else */
    rto_hit_record h[3];
    rto_trace_counters c[3];
    rto_msg msg = {{0}};
    assert_int_equal(rto_trace(acc, rays, 3, NULL, h, c, &msg), RTO_OK);
    /* e1 = (-2,0,0), e2 = (-1,-2,0), p = (-2,1,0), det = 4; s = (-1,-0.5,5), q = (0,-10,-1):
     * u = 1.5/4, v = 1/4, t = 20/4. */
    assert_int_equal(h[0].miss_flag, 0);
    assert_true(h[0].t == 5.0f && h[0].bary[0] == 0.375f && h[0].bary[1] == 0.25f);
    assert_int_equal(h[0].instance_id, 0);
    assert_int_equal(h[0].prim_id, 0);
    assert_int_equal(h[0].hit_group, s->instances[0].sbt_offset);
    assert_int_equal(h[0].custom_index, s->instances[0].custom_index);
    /* the identity objToWorld as column-major mat4x3 with zero padding */
    for (int col = 0; col < 4; col++)
        for (int r = 0; r < 4; r++)
            assert_true(h[0].obj_to_world[col][r] == (r == col && r < 3 ? 1.0f : 0.0f));
    /* one instance: the sweep root is its leaf; one triangle: no BLAS node */
    assert_int_equal(c[0].box_tests, 1);
    assert_int_equal(c[0].nodes_visited, 1);
    assert_int_equal(c[0].instance_entries, 1);
    assert_int_equal(c[0].triangle_tests, 1);
    /* det > 0: a front face, culled by CULL_FRONT_FACING; the miss record has t = tMax and all-ones IDs */
    assert_int_equal(h[1].miss_flag, 1);
    assert_true(h[1].t == 1e30f);
    assert_int_equal(h[1].instance_id, UINT32_MAX);
    assert_int_equal(h[1].prim_id, UINT32_MAX);
    assert_int_equal(h[1].hit_group, UINT32_MAX);
    assert_int_equal(h[1].custom_index, UINT32_MAX);
    assert_int_equal(c[1].triangle_tests, 1);
    assert_int_equal(h[2].miss_flag, 1);
    assert_true(h[2].t == 4.0f);
    assert_int_equal(c[2].box_tests, 1);
    assert_int_equal(c[2].nodes_visited + c[2].instance_entries + c[2].triangle_tests, 0);
    /* A ray in the triangle's plane: det = 0, a miss. */
    const float o2[3] = {-5.0f, 0.0f, 0.0f}, d2[3] = {1.0f, 0.0f, 0.0f};
    rto_tri_hit th;
    const float *p = s->meshes[0].positions;
    assert_false(rto_triangle_intersect(p, p + 3, p + 6, o2, d2, 0.0f, 1e30f, &th));
    assert_true(th.det == 0.0f);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* §2: tiny and zero direction components are clamped for the slab test only, +-0 to +1e-20. */
static void test_inv_dir_clamp(void **state)
{
    (void)state;
    const float d[3] = {-0.0f, -1e-30f, 2.0f};
    float inv[3];
    rto_ray_inv_dir(d, inv);
    assert_true(inv[0] == 1e20f);
    assert_true(inv[1] == -1e20f);
    assert_true(inv[2] == 0.5f);
    /* An axis-parallel ray along a box face: the slab test stays defined (no NaN from 0 * inf). */
    const float mn[3] = {0, 0, 0}, mx[3] = {1, 1, 1}, o[3] = {0.5f, 0.0f, -1.0f}, dz[3] = {0, 0, 1};
    rto_ray_inv_dir(dz, inv);
    float t;
    assert_true(rto_slab_test(mn, mx, o, inv, 0.0f, 1e30f, &t));
    assert_true(t == 1.0f);
}

static void test_threads_byte_identical(void **state)
{
    (void)state;
    rto_scene *s = tu_load("rtstress:4");
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    const size_t n = 20000;
    rto_wf_ray *rays = test_rays(s, 77, n, RTO_RAY_FLAG_OPAQUE);
    rto_hit_record *h1 = calloc(n, sizeof *h1), *h2 = calloc(n, sizeof *h2);
    rto_trace_counters *c1 = calloc(n, sizeof *c1), *c2 = calloc(n, sizeof *c2);
    assert_true(h1 && h2 && c1 && c2);
    rto_msg msg = {{0}};
    rto_trace_desc one = {1};
    assert_int_equal(rto_trace(acc, rays, n, &one, h1, c1, &msg), RTO_OK);
    static const uint32_t counts[] = {2, 3, 7, 64};
    for (size_t k = 0; k < 4; k++) {
        rto_trace_desc many = {counts[k]};
        memset(h2, 0xA5, n * sizeof *h2);
        assert_int_equal(rto_trace(acc, rays, n, &many, h2, c2, &msg), RTO_OK);
        assert_memory_equal(h1, h2, n * sizeof *h1);
        assert_memory_equal(c1, c2, n * sizeof *c1);
    }
    /* Some rays hit, some miss: the comparison means something. */
    size_t hits = 0;
    for (size_t i = 0; i < n; i++)
        hits += !h1[i].miss_flag;
    assert_true(hits > n / 10 && hits < n);
    free(h1);
    free(h2);
    free(c1);
    free(c2);
    free(rays);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* Instances whose mask misses the ray's cull mask are never entered; brute force agrees. */
static void test_masks(void **state)
{
    (void)state;
    rto_scene *s = tu_load("rtstress:3");
    for (uint32_t k = 0; k < s->instance_count; k++)
        s->instances[k].mask = k % 3 == 0 ? 0x01 : 0x02;
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    const size_t n = 3000;
    rto_wf_ray *rays = test_rays(s, 5, n, 0);
    for (size_t i = 0; i < n; i++)
        rays[i].cull_mask = i % 3 == 0 ? 0x01 : i % 3 == 1 ? 0x02 : 0x00;
    compare_with_brute("rtstress:3 with masks", 5, s, acc, rays, n);
    rto_hit_record *h = calloc(n, sizeof *h);
    rto_trace_counters *c = calloc(n, sizeof *c);
    rto_msg msg = {{0}};
    assert_int_equal(rto_trace(acc, rays, n, NULL, h, c, &msg), RTO_OK);
    for (size_t i = 0; i < n; i++) {
        if (rays[i].cull_mask == 0) {
            assert_int_equal(h[i].miss_flag, 1);
            assert_int_equal(c[i].instance_entries, 0);
        } else if (!h[i].miss_flag) {
            assert_true(s->instances[h[i].instance_id].mask & rays[i].cull_mask);
        }
    }
    free(h);
    free(c);
    free(rays);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* Rays that cannot be traced are refused before anything is written. */
static void test_bad_rays(void **state)
{
    (void)state;
    rto_scene *s = tu_load("triangle");
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    const float o[3] = {0, 0, 5}, d[3] = {0, 0, -1};
    rto_wf_ray rays[2] = {make_ray(o, d, 0), make_ray(o, d, 0)};
    rto_hit_record h[2];
    rto_msg msg = {{0}};
    rays[1].origin[1] = NAN;
    assert_int_equal(rto_trace(acc, rays, 2, NULL, h, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "ray 1"));
    rays[1] = make_ray(o, d, 0);
    rays[1].t_min = 2.0f;
    rays[1].t_max = 1.0f;
    assert_int_equal(rto_trace(acc, rays, 2, NULL, h, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    rays[1].t_max = INFINITY;
    assert_int_equal(rto_trace_brute(s, rays, 2, NULL, h, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_trace(NULL, rays, 2, NULL, h, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_trace(acc, rays, 0, NULL, NULL, NULL, &msg), RTO_OK);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* Seeded random scenes (random:SEED: triangle soups with shared edges and slivers, instanced with rotations,
 * non-uniform and mirroring scales, a mask-0 instance) and closed meshes: the seed is in every failure message. */
static void test_random_scenes_match_brute_force(void **state)
{
    (void)state;
    char spec[32];
    for (uint32_t seed = 1; seed <= 12; seed++) {
        snprintf(spec, sizeof spec, "random:%u", seed);
        check_scene(spec, seed, TU_SIZED(1500, 500));
    }
    check_scene("sphere:3", 21, TU_SIZED(1500, 500));
    check_scene("sphere:3:9", 22, TU_SIZED(1500, 500));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_triangle_by_hand),
        cmocka_unit_test(test_inv_dir_clamp),
        cmocka_unit_test(test_bad_rays),
        cmocka_unit_test(test_masks),
        cmocka_unit_test(test_threads_byte_identical),
        cmocka_unit_test(test_fixtures_match_brute_force),
        cmocka_unit_test(test_random_scenes_match_brute_force),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
