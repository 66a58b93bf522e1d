/* The conformance model of DESIGN.md §9 from the GPU's side, part of unit.conformance (main() and the simulated GPUs
 * in test_conformance.c): a record off by twice the model's bound fails, field by field, while one at the bound
 * passes; without freedoms (no fused multiply-add, an exact reciprocal) the simulated GPU and its traversal of the
 * oracle's own trees equal the oracle's records and counters bit for bit; each GPU fault of the corpus, planted in
 * the simulated traversal, is caught and named at the first ray it changes; ties and the slab test's range (§6). */
#include "test_conformance.h"

#include "trace/conform.h"

/* ------------------------------------------------------------------------------------------------------------------ */
/* The bound, from both sides                                                                                         */

static rto_status check_one(const rto_scene *sc, const rto_wf_ray *ray, const rto_hit_record *e,
                            const rto_hit_record *g, rto_report *r)
{
    const rto_hits_check_desc d = hits_desc(sc, ray, 1, e, g);
    rto_msg msg = {{0}};
    return rto_hits_check(&d, r, &msg);
}

/* For hit rays of a scene: t, u and v at the model's bound pass (counted as arithmetic); at twice the distance from
 * the oracle's value they fail, named t or bary. */
void test_twice_the_bound_fails(void **state)
{
    (void)state;
    rto_scene *sc = tu_load("Duck/glTF/Duck.gltf");
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, NULL), RTO_OK);
    rto_wf_ray rays[64];
    const size_t n = made_rays(sc, 5, 9, rays);
    rto_hit_record e[64];
    assert_int_equal(rto_trace(acc, rays, n, NULL, e, NULL, NULL), RTO_OK);
    cf_scene cs;
    rto_scene view = *sc;
    assert_int_equal(cf_scene_init(&cs, &view, NULL), RTO_OK);
    size_t tried = 0;
    for (size_t i = 0; i < n; i++) {
        if (e[i].miss_flag || (rays[i].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT))
            continue;
        cf_prim p;
        cf_prim_eval(&cs, e[i].instance_id, e[i].prim_id, &rays[i], rays[i].t_max, &p);
        if (p.hit != CF_CERTAIN)
            continue; /* on an edge: moving u or v may make it another primitive's */
        const cf_iv ivs[3] = {p.tri.t, p.tri.u, p.tri.v};
        const float refs[3] = {e[i].t, e[i].bary[0], e[i].bary[1]};
        for (int f = 0; f < 3; f++) {
            for (int side = -1; side <= 1; side += 2) {
                const double end = side > 0 ? ivs[f].hi : ivs[f].lo;
                /* the largest binary32 value inside the bound, and one twice as far out */
                float at = (float)end;
                if ((side > 0 && (double)at > end) || (side < 0 && (double)at < end))
                    at = nextafterf(at, side > 0 ? -INFINITY : INFINITY);
                const float twice = (float)((double)refs[f] + 2.0 * (end - (double)refs[f]));
                if (twice == refs[f] || at == refs[f])
                    continue; /* a bound under one ulp: nothing to move */
                rto_hit_record g = e[i];
                float *field = f == 0 ? &g.t : &g.bary[f - 1];
                *field = at;
                rto_report r;
                if (check_one(sc, &rays[i], &e[i], &g, &r) != RTO_OK)
                    fail_msg("ray %zu: field %d at its bound %.9g (interval [%.9g, %.9g]) rejected: %s", i, f,
                             (double)at, ivs[f].lo, ivs[f].hi, r.summary);
                *field = twice;
                if (check_one(sc, &rays[i], &e[i], &g, &r) != RTO_ERR_MISMATCH)
                    fail_msg("ray %zu: field %d at twice its bound (%.9g) accepted", i, f, (double)twice);
                assert_string_equal(r.fault, f == 0 ? "t" : "bary");
                tried++;
            }
        }
    }
    print_message("%zu fields moved to their bound (accepted) and to twice it (rejected)\n", tried);
    assert_true(tried >= 12);
    cf_scene_free(&cs);
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* §6 without its freedoms, bit for bit                                                                               */

/* With no fused multiply-add and an exact reciprocal, the simulated GPU is §6 itself: for every hit of the oracle, its
 * Möller–Trumbore of the oracle's primitive (through its own ray transform) gives the oracle's t, u and v bit for bit.
 * This is what holds the oracle's operation order (the transform's translation last, dot products left to right,
 * the reciprocal, u before v) to the contract, independently of the oracle's code. */
void test_exact_arithmetic(void **state)
{
    (void)state;
    static const char *const scenes[] = {"Box/glTF/Box.gltf", "Duck/glTF/Duck.gltf", "sphere:2", "random:5",
                                         "rtstress:2"};
    size_t checked = 0;
    for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; k++) {
        rto_scene *sc = tu_load(scenes[k]);
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(sc, NULL, &acc, NULL), RTO_OK);
        rto_wf_ray rays[MADE_PER * 60];
        const size_t n = made_rays(sc, 31 + k, 60, rays);
        rto_hit_record e[MADE_PER * 60];
        assert_int_equal(rto_trace(acc, rays, n, NULL, e, NULL, NULL), RTO_OK);
        sim exact = {FUSE_NONE, 0, 0, 0, 0};
        for (size_t i = 0; i < n; i++) {
            if (e[i].miss_flag)
                continue;
            const rto_instance *in = &sc->instances[e[i].instance_id];
            const float(*m)[4] = in->world_to_obj.m;
            float o[3], d[3];
            for (int r = 0; r < 3; r++) {
                o[r] = plus(&exact, sum2(&exact, m[r][0], rays[i].origin[0], m[r][1], rays[i].origin[1]), m[r][2],
                            rays[i].origin[2]) + m[r][3];
                d[r] = plus(&exact, sum2(&exact, m[r][0], rays[i].dir[0], m[r][1], rays[i].dir[1]), m[r][2],
                            rays[i].dir[2]);
            }
            const rto_mesh *mesh = &sc->meshes[in->blas];
            const uint32_t *ix = &mesh->indices[3 * (size_t)e[i].prim_id];
            sim_hit h;
            sim_triangle(&exact, &mesh->positions[3 * (size_t)ix[0]], &mesh->positions[3 * (size_t)ix[1]],
                         &mesh->positions[3 * (size_t)ix[2]], o, d, rays[i].t_min, INFINITY, &h);
            if (memcmp(&h.t, &e[i].t, 4) || memcmp(&h.u, &e[i].bary[0], 4) || memcmp(&h.v, &e[i].bary[1], 4))
                fail_msg("%s ray %zu: §6 gives t %.9g u %.9g v %.9g on triangle %u of instance %u, the oracle t %.9g "
                         "u %.9g v %.9g", scenes[k], i, (double)h.t, (double)h.u, (double)h.v, e[i].prim_id,
                         e[i].instance_id, (double)e[i].t, (double)e[i].bary[0], (double)e[i].bary[1]);
            checked++;
        }
        rto_accel_destroy(acc);
        rto_scene_destroy(sc);
    }
    print_message("%zu hits: the oracle's t, u, v are §6's bit for bit\n", checked);
    assert_true(checked > 200);
}

/* With no freedom taken, the simulated traversal is §6 itself: over the oracle's own trees (sweep and Karras TLAS),
 * every record and every counter (nodes visited, box tests, triangle tests, instance entries) equals the oracle's.
 * This holds the oracle's traversal to DESIGN.md's words — nearer child first, the left on equal entry t, the pop-time
 * skip, tNear from tMin, EMPTY items skipped without a box test, the masks, culling after Möller–Trumbore, first-hit
 * termination — independently of its code. */
void test_exact_traversal(void **state)
{
    (void)state;
    static const char *const scenes[] = {"Box/glTF/Box.gltf", "CornellBox-nvpro-glTF/cornellBox.gltf", "sphere:2",
                                         "random:5", "random:13", "rtstress:2", "triangle"};
    size_t checked = 0, hits = 0;
    for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; k++) {
        rto_scene *sc = tu_load(scenes[k]);
        spread_masks(sc);
        for (int layout = 0; layout < 2; layout++) {
            const rto_accel_desc ad = {layout ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 1};
            rto_accel *acc = NULL;
            assert_int_equal(rto_accel_build(sc, &ad, &acc, NULL), RTO_OK);
            for (int set = 0; set <= RTO_RAY_SET_COUNT; set++) {
                rto_wf_ray *rays;
                size_t n = 0;
                if (set < RTO_RAY_SET_COUNT) {
                    rto_rays_desc rd;
                    memset(&rd, 0, sizeof rd);
                    rd.set = (rto_ray_set)set;
                    rd.seed = 5;
                    rd.width = 24;
                    rd.height = 16;
                    rd.count = 300;
                    const size_t cap = rto_rays_capacity(&rd);
                    rays = calloc(cap ? cap : 1, sizeof *rays);
                    assert_non_null(rays);
                    assert_int_equal(rto_rays_generate(acc, &rd, rays, cap, &n, NULL, NULL), RTO_OK);
                } else {
                    rays = calloc(MADE_PER * 40, sizeof *rays);
                    assert_non_null(rays);
                    n = made_rays(sc, 91 + k, 40, rays);
                }
                rto_hit_record *e = calloc(n ? n : 1, sizeof *e);
                rto_trace_counters *ec = calloc(n ? n : 1, sizeof *ec);
                assert_true(e && ec);
                assert_int_equal(rto_trace(acc, rays, n, NULL, e, ec, NULL), RTO_OK);
                sim exact = {FUSE_NONE, 0, 0, layout + 1, 0};
                for (size_t i = 0; i < n; i++) {
                    rto_trace_counters c;
                    const rto_hit_record g = sim_tree_trace(&exact, sc, acc, &rays[i], &c);
                    if (memcmp(&g, &e[i], offsetof(rto_hit_record, obj_to_world)))
                        fail_msg("%s, %s, set %d, ray %zu: §6 over the trees gives %s triangle %u of instance %u at t "
                                 "%.9g, the oracle %s triangle %u of instance %u at t %.9g", scenes[k],
                                 tree_names[layout + 1], set, i, g.miss_flag ? "a miss," : "", g.prim_id,
                                 g.instance_id, (double)g.t, e[i].miss_flag ? "a miss," : "", e[i].prim_id,
                                 e[i].instance_id, (double)e[i].t);
                    if (memcmp(&c, &ec[i], sizeof c))
                        fail_msg("%s, %s, set %d, ray %zu: §6 counts nodes %u, boxes %u, triangles %u, instances %u; "
                                 "the oracle %u, %u, %u, %u", scenes[k], tree_names[layout + 1], set, i,
                                 c.nodes_visited, c.box_tests, c.triangle_tests, c.instance_entries,
                                 ec[i].nodes_visited, ec[i].box_tests, ec[i].triangle_tests, ec[i].instance_entries);
                    hits += g.miss_flag == 0;
                }
                checked += n;
                free(e);
                free(ec);
                free(rays);
            }
            rto_accel_destroy(acc);
        }
        rto_scene_destroy(sc);
    }
    print_message("%zu rays (%zu hits) over both TLAS layouts: records and counters are §6's bit for bit\n", checked,
                  hits);
    assert_true(hits > checked / 4);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The fault corpus                                                                                                   */

static const char *const fault_names[GF_COUNT] = {"none", "t <= bestT", "translation first", "u and v swapped",
                                                  "tMin dropped", "CULL_BACK culls front faces",
                                                  "back faces under CULL_BACK", "masks ignored",
                                                  "customIndex of the next instance", "hitGroup from the mask",
                                                  "a transposed objToWorld element"};

/* Whether a faulty GPU's record departs from the conforming one evidently (far beyond any rounding): another
 * primitive, instance or hit / miss, t or a barycentric off by more than 1e-3, or an exact field different. */
static int evident(const rto_hit_record *good, const rto_hit_record *bad)
{
    if (good->miss_flag != bad->miss_flag)
        return 1;
    if (good->miss_flag)
        return 0;
    if (good->instance_id != bad->instance_id || good->prim_id != bad->prim_id ||
        good->custom_index != bad->custom_index || good->hit_group != bad->hit_group)
        return 1;
    if (fabs((double)good->t - bad->t) > 1e-3 * fmax(1, fabs((double)good->t)) ||
        fabs((double)good->bary[0] - bad->bary[0]) > 1e-3 || fabs((double)good->bary[1] - bad->bary[1]) > 1e-3)
        return 1;
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            if (good->obj_to_world[c][r] != bad->obj_to_world[c][r])
                return 1;
    return 0;
}

/* The fault class check-hits must name for an evident departure: the identity first (DESIGN.md §9's priority), then
 * the fields. */
static rto_hit_fault expected_class(gpu_fault f, const rto_hit_record *good, const rto_hit_record *bad)
{
    if (good->miss_flag || bad->miss_flag)
        return RTO_HIT_MISS_FLAG;
    if (good->instance_id != bad->instance_id)
        return RTO_HIT_INSTANCE;
    if (good->prim_id != bad->prim_id)
        return RTO_HIT_PRIM;
    switch (f) {
    case GF_SWAP_UV: return RTO_HIT_BARY;
    case GF_CUSTOM_INDEX: return RTO_HIT_CUSTOM_INDEX;
    case GF_HIT_GROUP: return RTO_HIT_HIT_GROUP;
    case GF_OBJ_TO_WORLD: return RTO_HIT_TRANSFORM;
    default: return fabs((double)good->t - bad->t) > 1e-3 * fmax(1, fabs((double)good->t)) ? RTO_HIT_T : RTO_HIT_BARY;
    }
}

/* Rays for the corpus, from a scene's primary and random sets: one in four with CULL_BACK_FACING, one in four with a
 * cull mask of four bits, one in four with tMin just past the conforming GPU's first hit (so a dropped tMin returns
 * that hit, before tMin). */
static size_t corpus_rays(const rto_scene *sc, const rto_accel *acc, rto_wf_ray **out)
{
    rto_wf_ray *all = NULL;
    size_t n = 0;
    for (int k = 0; k < 2; k++) {
        rto_rays_desc rd;
        memset(&rd, 0, sizeof rd);
        rd.set = k ? RTO_RAYS_RANDOM : RTO_RAYS_PRIMARY;
        rd.seed = 3;
        rd.width = 40;
        rd.height = 30;
        rd.count = 1200;
        const size_t cap = rto_rays_capacity(&rd);
        all = realloc(all, (n + cap) * sizeof *all);
        assert_non_null(all);
        size_t got = 0;
        assert_int_equal(rto_rays_generate(acc, &rd, all + n, cap, &got, NULL, NULL), RTO_OK);
        n += got;
    }
    sim good = {FUSE_NONE, 0, 0, 1, GF_NONE};
    for (size_t i = 0; i < n; i++) {
        all[i].flags &= ~(uint32_t)RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT;
        switch (i % 4) {
        case 1: all[i].flags |= RTO_RAY_FLAG_CULL_BACK_FACING; break;
        case 2: all[i].cull_mask = 0x0F << (i / 4 % 5); break;
        case 3: {
            rto_trace_counters c;
            const rto_hit_record h = sim_tree_trace(&good, sc, acc, &all[i], &c);
            if (!h.miss_flag)
                all[i].t_min = h.t + 1e-2f * fmaxf(1.0f, h.t);
            break;
        }
        default: break;
        }
    }
    *out = all;
    return n;
}

/* The translation fault's scene: a 0.05-unit triangle under an instance whose worldToObj's first row is
 * (1, 1, 0, 0.1), with rays from world origins near (1e4, -1e4): §6's (wx + wy) + 0.1 cancels exactly before the one
 * rounding, while (0.1 + wx) + wy rounds at 1e4 (up to 4.9e-4): the translation added first moves the object-space
 * origin by up to a hundredth of the triangle. Rays straight down in object space over the triangle's box. */
static size_t shear_case(tu_scene1 *one, float *pos, uint32_t *idx, rto_wf_ray *rays, size_t n)
{
    static const float tri[9] = {0.28f, 0.18f, 0, 0.33f, 0.18f, 0, 0.28f, 0.23f, 0};
    memcpy(pos, tri, sizeof tri);
    idx[0] = 0, idx[1] = 1, idx[2] = 2;
    const double xf[3][4] = {{0, 1, 0, 1e4}, {1, -1, 0, -10000.1}, {0, 0, 1, 0}};
    tu_scene1_make(one, pos, 3, idx, 1, xf);
    uint64_t seed = 41;
    for (size_t i = 0; i < n; i++) {
        const double ox = 0.28 + 0.05 * tu_rng_unit(&seed), oy = 0.18 + 0.05 * tu_rng_unit(&seed);
        const double o[3] = {oy + 1e4, ox - oy - 10000.1, 3}, d[3] = {0, 0, -1};
        rays[i] = tu_ray(o, d, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE);
    }
    return n;
}

/* Plants fault f in the simulated GPU (the traversal of the trees, otherwise §6 exactly) over the rays: check-hits
 * must fail and name the class the departure has at the first ray where the faulty GPU's record departs evidently
 * from the conforming one. Returns 0 when no record departs evidently (the fault does not show on these rays). */
static int corpus_case(const char *label, const rto_scene *sc, const rto_accel *acc, const rto_wf_ray *rays, size_t n,
                       gpu_fault f)
{
    rto_hit_record *expected = calloc(n, sizeof *expected), *good = calloc(n, sizeof *good),
                   *bad = calloc(n, sizeof *bad);
    assert_true(expected && good && bad);
    assert_int_equal(rto_trace(acc, rays, n, NULL, expected, NULL, NULL), RTO_OK);
    sim conforming = {FUSE_NONE, 0, 0, 1, GF_NONE}, faulty = {FUSE_NONE, 0, 0, 1, f};
    size_t first = n;
    for (size_t i = 0; i < n; i++) {
        rto_trace_counters c;
        good[i] = sim_tree_trace(&conforming, sc, acc, &rays[i], &c);
        bad[i] = sim_tree_trace(&faulty, sc, acc, &rays[i], &c);
        if (first == n && evident(&good[i], &bad[i]))
            first = i;
    }
    if (first == n) { /* the fault never fires here (a flat box keeps a dropped tMin from mattering on cubes) */
        print_message("%-38s %-34s changes no record evidently\n", label, fault_names[f]);
        free(expected);
        free(good);
        free(bad);
        return 0;
    }
    const rto_hits_check_desc d = hits_desc(sc, rays, n, expected, bad);
    rto_report r;
    rto_msg msg = {{0}};
    const rto_status st = rto_hits_check(&d, &r, &msg);
    if (st != RTO_ERR_MISMATCH)
        fail_msg("%s: the fault '%s' (first evident at ray %zu) not caught: %s", label, fault_names[f], first,
                 rto_status_string(st));
    int64_t where = -1;
    assert_true(rto_report_where(&r, "ray", &where));
    const rto_hit_fault want = expected_class(f, &good[first], &bad[first]);
    if (where != (int64_t)first || r.code != (int)want)
        fail_msg("%s: '%s' first departs at ray %zu (%s); check-hits says: %s", label, fault_names[f], first,
                 rto_hit_fault_name(want), r.summary);
    char at[48];
    snprintf(at, sizeof at, "ray %zu", first);
    assert_non_null(strstr(r.summary, at));
    print_message("%-38s %-34s caught: %.140s\n", label, fault_names[f], r.summary);
    free(expected);
    free(good);
    free(bad);
    return 1;
}

/* Every fault of the corpus on scenes with instances of several masks, mirrors and back faces, each caught on every
 * scene where it changes a record evidently and shown on one at least (the translation
 * fault on the one scene made for it: elsewhere its rounding stays within the model's bounds, where no verdict can
 * tell it from a conforming GPU's). t <= bestT is a freedom of §9, not a fault: check-hits accepts it and names
 * each such record a tie (test_tie_freedom_named). */
void test_fault_corpus(void **state)
{
    (void)state;
    static const char *const scenes[] = {"rtstress:2", "random:13", "CornellBox-nvpro-glTF/cornellBox.gltf",
                                         "Duck/glTF/Duck.gltf"};
    int shown[GF_COUNT] = {0};
    for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; k++) {
        rto_scene *sc = tu_load(scenes[k]);
        spread_masks(sc);
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(sc, NULL, &acc, NULL), RTO_OK);
        rto_wf_ray *rays = NULL;
        const size_t n = corpus_rays(sc, acc, &rays);
        for (int f = GF_SWAP_UV; f < GF_COUNT; f++)
            shown[f] += corpus_case(scenes[k], sc, acc, rays, n, (gpu_fault)f);
        free(rays);
        rto_accel_destroy(acc);
        rto_scene_destroy(sc);
    }
    tu_scene1 one;
    float pos[9];
    uint32_t idx[3];
    rto_wf_ray rays[400];
    const size_t n = shear_case(&one, pos, idx, rays, 400);
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(&one.scene, NULL, &acc, NULL), RTO_OK);
    shown[GF_TRANSLATION_FIRST] += corpus_case("a shear 1e4 from the origin", &one.scene, acc, rays, n,
                                               GF_TRANSLATION_FIRST);
    rto_accel_destroy(acc);
    for (int f = GF_TRANSLATION_FIRST; f < GF_COUNT; f++)
        if (!shown[f])
            fail_msg("the fault '%s' showed on no scene of the corpus", fault_names[f]);
}

/* Two copies of one triangle in one mesh (triangles 0 and 1), under an instance moved by (0.5, 0, -2): every ray
 * through it meets both at the same t. pos and idx hold the mesh for as long as the scene lives. */
static void twin_triangles(tu_scene1 *one, float pos[9], uint32_t idx[6])
{
    static const float p[9] = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
    static const uint32_t ix[6] = {0, 1, 2, 0, 1, 2};
    const double xf[3][4] = {{1, 0, 0, 0.5}, {0, 1, 0, 0}, {0, 0, 1, -2}};
    memcpy(pos, p, sizeof p);
    memcpy(idx, ix, sizeof ix);
    tu_scene1_make(one, pos, 3, idx, 2, xf);
}

/* t <= bestT keeps the later of two triangles at one t: a tie, which §9 lets any GPU answer either way. check-hits
 * accepts it and names it (the "ties" fact). */
void test_tie_freedom_named(void **state)
{
    (void)state;
    float pos[9];
    uint32_t idx[6];
    tu_scene1 one;
    twin_triangles(&one, pos, idx);
    const rto_scene sc = one.scene;
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(&sc, NULL, &acc, NULL), RTO_OK);
    const double o1[3] = {0.5, 0, 3}, d1[3] = {0, 0, -1};
    const rto_wf_ray ray = tu_ray(o1, d1, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE);
    rto_hit_record e, g;
    assert_int_equal(rto_trace(acc, &ray, 1, NULL, &e, NULL, NULL), RTO_OK);
    sim later = {FUSE_NONE, 0, 0, 1, GF_TIE_LATER};
    rto_trace_counters c;
    g = sim_tree_trace(&later, &sc, acc, &ray, &c);
    assert_int_equal(e.prim_id, 0);
    assert_int_equal(g.prim_id, 1); /* the fault did fire */
    rto_report r;
    assert_int_equal(check_one(&sc, &ray, &e, &g, &r), RTO_OK);
    int found = 0;
    for (uint32_t i = 0; i < r.nfacts; i++)
        if (!strcmp(r.facts[i].name, "ties")) {
            assert_int_equal(r.facts[i].value, 1);
            found = 1;
        }
    assert_true(found);
    rto_accel_destroy(acc);
}

/* Ties (§6): two copies of one triangle in one mesh are hit at the same t; their leaves have equal boxes and equal
 * Morton codes, so the lower index sorts first, is the left child, and is visited first on equal entry t; strict
 * t < bestT keeps it. The oracle must answer triangle 0, with either TLAS layout and from either side. */
void test_tie_order(void **state)
{
    (void)state;
    float pos[9];
    uint32_t idx[6];
    tu_scene1 one;
    twin_triangles(&one, pos, idx);
    const rto_scene sc = one.scene;
    for (int layout = 0; layout < 2; layout++) {
        const rto_accel_desc ad = {layout ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 1};
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(&sc, &ad, &acc, NULL), RTO_OK);
        const double o1[3] = {0.5, 0, 3}, d1[3] = {0, 0, -1}, o2[3] = {0.4, 0.1, -7}, d2[3] = {0, 0, 1};
        const rto_wf_ray rays[2] = {tu_ray(o1, d1, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE),
                                    tu_ray(o2, d2, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE)};
        rto_hit_record h[2];
        assert_int_equal(rto_trace(acc, rays, 2, NULL, h, NULL, NULL), RTO_OK);
        for (int r = 0; r < 2; r++) {
            assert_int_equal(h[r].miss_flag, 0);
            if (h[r].prim_id != 0)
                fail_msg("%s TLAS, ray %d: triangle %u kept of two at the same t; §6 keeps the first visited, 0",
                         layout ? "Karras" : "sweep", r, h[r].prim_id);
        }
        rto_accel_destroy(acc);
    }
}

/* The slab test's range (§6): tNear = max(max3(min(t0, t1)), tMin), tFar = min(min3(max(t0, t1)), bestT). A box
 * the ray crosses at t in [5, 6] is entered from tMin 0 (entry 5), entered at tMin 5.5 (entry 5.5), not entered
 * from tMin 7 nor with bestT 4, and entered at bestT 5 exactly (hit iff tNear <= tFar). Exact binary32 values. */
void test_slab_range(void **state)
{
    (void)state;
    const float mn[3] = {0, 0, 0}, mx[3] = {1, 1, 1}, o[3] = {-5, 0.5f, 0.5f}, inv[3] = {1, 1e20f, 1e20f};
    float t = -1;
    assert_true(rto_slab_test(mn, mx, o, inv, 0.0f, 1e30f, &t));
    assert_true(t == 5.0f);
    assert_true(rto_slab_test(mn, mx, o, inv, 5.5f, 1e30f, &t));
    assert_true(t == 5.5f);
    assert_false(rto_slab_test(mn, mx, o, inv, 7.0f, 1e30f, &t));
    assert_false(rto_slab_test(mn, mx, o, inv, 0.0f, 4.0f, &t));
    assert_true(rto_slab_test(mn, mx, o, inv, 0.0f, 5.0f, &t));
    assert_true(t == 5.0f);
}
