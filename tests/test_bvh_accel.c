/* The acceleration-structure object, part of unit.bvh (main() in test_bvh.c): its trees against the step-by-step
 * pipeline with the canonical network on every fixture, rtstress and instances scenes, the same bytes with any thread
 * count, the Karras builder's team against the scalar builder, empty meshes, and the accel API contract (refusals,
 * precedence, the check naming its tree). */
#include "test_bvh.h"
#include "bvh/bvh_internal.h" /* rto__karras_build_scalar and the Karras team (rto__karras_plan / _run / _finish) */

#include <math.h>
#include <unistd.h>

/* ------------------------------------------------------------------------------------------------------------------ */
/* Trees of real scenes: every fixture, rtstress:1..40, instances:DIST:N                                               */

/* The TLAS statistics the accel computed in its stages, against the public functions over the reference tree. */
static void expect_stats(const rto_bvh_stats *got, rto_bvh_stats want, const char *spec)
{
    if (got->depth != want.depth || got->leaves != want.leaves || memcmp(&got->sah, &want.sah, sizeof want.sah))
        fail_msg("%s: TLAS stats depth %u leaves %u sah %.17g, the reference's %u %u %.17g", spec, got->depth,
                 got->leaves, got->sah, want.depth, want.leaves, want.sah);
}

/* The pipeline written out step by step with the canonical bitonic network, as the builds ran it before they sorted
 * with rto_fast_radix_sort: the accel must give the same bytes (§4: real keys are unique). */
static void reference_tlas(const rto_scene *sc, rto_tlas_kind kind, const rto_accel_tlas *t, const char *spec)
{
    const size_t n = sc->instance_count, np = rto_next_pow2(n);
    rto_aabb *boxes = malloc((n ? n : 1) * sizeof *boxes);
    rto_vec3 *c = malloc((n ? n : 1) * sizeof *c);
    uint32_t *keys = malloc((n ? n : 1) * 4), *sorted = malloc((np ? np : 1) * 4);
    for (size_t i = 0; i < n; i++) {
        boxes[i] = rto_instance_aabb(sc, (uint32_t)i);
        c[i] = rto_aabb_centroid(&boxes[i]);
    }
    assert_int_equal(rto_tlas_keys(c, n, keys, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U32, keys, n, sorted, NULL, NULL, NULL), RTO_OK);
    assert_int_equal(t->instance_count, n);
    assert_int_equal(t->key_count, n);
    assert_int_equal(t->n_padded, np);
    if (memcmp(t->instance_aabbs, boxes, n * sizeof *boxes) || memcmp(t->keys, keys, n * 4) ||
        memcmp(t->sorted_keys, sorted, np * 4))
        fail_msg("%s: TLAS boxes or keys differ from the step-by-step pipeline", spec);
    if (kind == RTO_TLAS_SWEEP) {
        rto_tlas_node *nodes = malloc(rto_tlas_sweep_node_count(n) * sizeof *nodes);
        assert_int_equal(rto_tlas_build_sweep(sorted, n, boxes, nodes, NULL), RTO_OK);
        assert_int_equal(t->node_count, rto_tlas_sweep_node_count(n));
        assert_null(t->karras_nodes);
        if (memcmp(t->sweep_nodes, nodes, t->node_count * sizeof *nodes))
            fail_msg("%s: sweep TLAS differs from the step-by-step pipeline", spec);
        expect_stats(&t->stats, rto_tlas_stats(nodes, n), spec);
        free(nodes);
    } else {
        rto_bvh_node *nodes = malloc((n ? n : 1) * sizeof *nodes);
        assert_int_equal(rto__karras_build_scalar(RTO_KEY_U32, sorted, n, boxes, nodes, NULL), RTO_OK);
        assert_int_equal(t->node_count, n >= 2 ? n - 1 : 0);
        assert_null(t->sweep_nodes);
        if (memcmp(t->karras_nodes, nodes, t->node_count * sizeof *nodes))
            fail_msg("%s: Karras TLAS differs from the step-by-step pipeline", spec);
        const rto_aabb root = rto_scene_aabb(sc); /* the union of the instances' world boxes */
        expect_stats(&t->stats, rto_karras_stats(nodes, n, &root), spec);
        free(nodes);
    }
    free(boxes);
    free(c);
    free(keys);
    free(sorted);
}

static void reference_blas(const rto_mesh *mesh, const rto_accel_blas *b, const char *spec)
{
    const size_t t = mesh->triangle_count, tp = rto_next_pow2(t);
    uint64_t *bk = malloc((t ? t : 1) * 8), *bs = malloc((tp ? tp : 1) * 8);
    rto_aabb *tb = malloc((t ? t : 1) * sizeof *tb);
    rto_bvh_node *bn = malloc((t ? t : 1) * sizeof *bn);
    uint32_t *order = malloc((t ? t : 1) * 4);
    for (size_t i = 0; i < t; i++)
        tb[i] = rto_mesh_triangle_aabb(mesh, (uint32_t)i);
    assert_int_equal(rto_mesh_keys(mesh, bk, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U64, bk, t, bs, NULL, NULL, NULL), RTO_OK);
    for (size_t j = 0; j < t; j++)
        order[j] = (uint32_t)bs[j]; /* the low word of a BLAS key is the triangle */
    assert_int_equal(rto__karras_build_scalar(RTO_KEY_U64, bs, t, tb, bn, NULL), RTO_OK);
    assert_int_equal(b->triangle_count, t);
    assert_int_equal(b->node_count, t >= 2 ? t - 1 : 0);
    rto_aabb bounds = rto_mesh_aabb(mesh); /* the accel takes it as the union of the triangle boxes */
    if (memcmp(&b->bounds, &bounds, sizeof bounds))
        fail_msg("%s BLAS %u: bounds differ from rto_mesh_aabb", spec, b->mesh);
    if (memcmp(b->sorted_keys, bs, t * 8) || memcmp(b->order, order, t * 4) || memcmp(b->prim_aabbs, tb, t * sizeof *tb) ||
        memcmp(b->nodes, bn, b->node_count * sizeof *bn))
        fail_msg("%s BLAS %u: differs from the step-by-step pipeline", spec, b->mesh);
    /* statistics as rto_karras_stats computes them from the finished tree (a walk from the root for the depth) */
    const rto_bvh_stats st = rto_karras_stats(bn, t, &bounds);
    if (b->stats.depth != st.depth || b->stats.leaves != st.leaves || memcmp(&b->stats.sah, &st.sah, sizeof st.sah))
        fail_msg("%s BLAS %u: stats depth %u sah %.17g, rto_karras_stats %u %.17g", spec, b->mesh, b->stats.depth,
                 b->stats.sah, st.depth, st.sah);
    free(bk);
    free(bs);
    free(tb);
    free(bn);
    free(order);
}

/* Builds both accels of a scene (sweep and Karras TLAS) and checks them: the same bytes as the step-by-step
 * pipeline with the canonical network, each instance / triangle in exactly one leaf (counted here), and the
 * validators' structure checks through rto_accel_check. */
static void check_scene_trees(const char *spec)
{
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(spec, &sc, &msg))
        fail_msg("%s: %s", spec, msg.text);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        if (rto_accel_build(sc, &desc, &acc, &msg))
            fail_msg("%s: %s", spec, msg.text);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        reference_tlas(sc, desc.tlas, t, spec);
        const size_t n = t->instance_count, np = t->n_padded;
        unsigned char *seen = calloc(n ? n : 1, 1);
        if (desc.tlas == RTO_TLAS_SWEEP) {
            for (size_t j = 0; j < np; j++) {
                uint32_t it = t->sweep_nodes[np - 1 + j].item;
                if (j < n) {
                    assert_true(it < n && !seen[it]);
                    seen[it] = 1;
                } else {
                    assert_int_equal(it, RTO_TLAS_EMPTY);
                }
            }
        }
        assert_int_equal(rto_accel_blas_count(acc), sc->mesh_count);
        for (uint32_t m = 0; m < sc->mesh_count; m++)
            reference_blas(&sc->meshes[m], rto_accel_get_blas(acc, m), spec);
        assert_null(rto_accel_get_blas(acc, sc->mesh_count));
        rto_report r;
        if (rto_accel_check(acc, &r, &msg) != RTO_OK)
            fail_msg("%s %s: %s", spec, kind ? "karras" : "sweep", msg.text);
        free(seen);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(sc);
}

void test_procedural_scene_trees(void **state)
{
    (void)state;
    char spec[64];
    /* Under the sanitizer: every scene up to 8 objects, then every fourth up to the largest. */
    for (int n = 1; n <= 40; n += TU_SANITIZED && n >= 8 ? 4 : 1) {
        snprintf(spec, sizeof spec, "rtstress:%d", n);
        check_scene_trees(spec);
    }
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
            snprintf(spec, sizeof spec, "instances:%s:%zu", di->name, sizes[z]);
            check_scene_trees(spec);
        }
    }
    check_scene_trees("triangle");
}

void test_fixture_trees(void **state)
{
    (void)state;
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    const char *files[] = {"Box/glTF/Box.gltf", "SimpleMeshes/glTF/SimpleMeshes.gltf", "Duck/glTF/Duck.gltf",
                           "CornellBox-nvpro-glTF/cornellBox.gltf", "StanfordBunny/bunny.gltf",
                           "Suzanne/glTF/Suzanne.gltf", "WaterBottle/glTF/WaterBottle.gltf"};
    char path[1024];
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", fix, files[i]);
        check_scene_trees(path);
    }
}

/* The same bytes with any thread count (DESIGN.md §2): every array and statistic of every tree, built with 1 thread
 * and with several (big meshes split among the team, small ones one per worker). */
/* Field by field: the struct has padding. */
static int same_stats(const rto_bvh_stats *a, const rto_bvh_stats *b)
{
    return a->depth == b->depth && a->leaves == b->leaves && !memcmp(&a->sah, &b->sah, sizeof a->sah);
}

static void expect_same_accel(const rto_accel *x, const rto_accel *y, const char *spec, uint32_t threads)
{
    const rto_accel_tlas *a = rto_accel_get_tlas(x), *b = rto_accel_get_tlas(y);
    if (a->kind != b->kind || a->instance_count != b->instance_count || a->key_count != b->key_count ||
        a->n_padded != b->n_padded || a->node_count != b->node_count ||
        memcmp(a->instance_aabbs, b->instance_aabbs, a->instance_count * sizeof(rto_aabb)) ||
        memcmp(a->keys, b->keys, a->key_count * 4u) || memcmp(a->sorted_keys, b->sorted_keys, a->n_padded * 4u) ||
        (a->sweep_nodes && memcmp(a->sweep_nodes, b->sweep_nodes, a->node_count * sizeof(rto_tlas_node))) ||
        (a->karras_nodes && memcmp(a->karras_nodes, b->karras_nodes, a->node_count * sizeof(rto_bvh_node))) ||
        !same_stats(&a->stats, &b->stats))
        fail_msg("%s: the TLAS with %u threads differs from the one with 1", spec, threads);
    assert_int_equal(rto_accel_blas_count(x), rto_accel_blas_count(y));
    for (uint32_t m = 0; m < rto_accel_blas_count(x); m++) {
        const rto_accel_blas *p = rto_accel_get_blas(x, m), *q = rto_accel_get_blas(y, m);
        const size_t t = p->triangle_count;
        if (p->triangle_count != q->triangle_count || p->node_count != q->node_count ||
            memcmp(&p->bounds, &q->bounds, sizeof p->bounds) || memcmp(p->sorted_keys, q->sorted_keys, t * 8) ||
            memcmp(p->order, q->order, t * 4) || memcmp(p->prim_aabbs, q->prim_aabbs, t * sizeof(rto_aabb)) ||
            memcmp(p->nodes, q->nodes, p->node_count * sizeof(rto_bvh_node)) ||
            !same_stats(&p->stats, &q->stats))
            fail_msg("%s: BLAS %u with %u threads differs from the one with 1", spec, m, threads);
    }
}

static void check_threads(const rto_scene *sc, const char *spec)
{
    static const uint32_t threads[] = {2, 3, 8, 33};
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc one = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 1};
        rto_accel *ref = NULL;
        rto_msg msg = {{0}};
        if (rto_accel_build(sc, &one, &ref, &msg))
            fail_msg("%s: %s", spec, msg.text);
        for (size_t i = 0; i < sizeof threads / sizeof threads[0]; i++) {
            rto_accel_desc d = one;
            d.threads = threads[i];
            rto_accel *acc = NULL;
            if (rto_accel_build(sc, &d, &acc, &msg))
                fail_msg("%s, %u threads: %s", spec, threads[i], msg.text);
            expect_same_accel(ref, acc, spec, threads[i]);
            rto_accel_destroy(acc);
        }
        rto_accel_destroy(ref);
    }
}

static void check_threads_spec(const char *spec)
{
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(spec, &sc, &msg))
        fail_msg("%s: %s", spec, msg.text);
    check_threads(sc, spec);
    rto_scene_destroy(sc);
}

void test_accel_bytes_do_not_depend_on_threads(void **state)
{
    (void)state;
    char path[1024];
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    snprintf(path, sizeof path, "%s/StanfordBunny/bunny.gltf", fix); /* one big mesh: built by the whole team */
    check_threads_spec(path);
    const char *models = getenv("RTO_ASSIMP_MODELS"); /* 34 meshes: one worker each */
    if (models) {
        snprintf(path, sizeof path, "%s/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", models);
        if (access(path, R_OK) == 0)
            check_threads_spec(path);
    }
    check_threads_spec("rtstress:4");
    check_threads_spec("instances:clustered:4097");
    check_threads_spec("instances:uniform:65536");
    check_threads_spec("triangle"); /* one triangle */
    /* an empty mesh beside a non-empty one, its instances unkeyed; and a scene with nothing at all */
    rto_scene empty;
    memset(&empty, 0, sizeof empty);
    check_threads(&empty, "no meshes");
    rto_mesh none;
    memset(&none, 0, sizeof none);
    snprintf(none.name, sizeof none.name, "empty");
    none.material = -1;
    rto_instance inst;
    memset(&inst, 0, sizeof inst);
    const double m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&inst, m, NULL), RTO_OK);
    inst.mask = 0xFF;
    empty.meshes = &none;
    empty.mesh_count = 1;
    empty.instances = &inst;
    empty.instance_count = 1;
    check_threads(&empty, "one empty mesh");
}

/* The Karras builder's subtrees (several workers) on key sets of every distribution, duplicates included: the same
 * bytes as the kept per-node builder. */
void test_karras_team_matches_scalar(void **state)
{
    (void)state;
    const size_t ns[] = {2, 3, 1000, 4097, 30000};
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof ns / sizeof ns[0]; z++) {
            const size_t n = ns[z];
            rto_aabb *boxes = make_boxes(di->name, n, 1e-4f, 9);
            rto_vec3 *c = malloc(n * sizeof *c);
            uint64_t *keys = malloc(n * 8), *sorted = malloc(n * 8);
            for (size_t i = 0; i < n; i++)
                c[i] = rto_aabb_centroid(&boxes[i]);
            assert_int_equal(rto_blas_keys(c, n, keys, NULL), RTO_OK);
            assert_int_equal(rto_fast_radix_sort(RTO_KEY_U64, keys, n, sorted, NULL), RTO_OK);
            /* and the same keys with their index dropped: duplicates fall back to the index prefix */
            for (int dup = 0; dup < 2; dup++) {
                if (dup)
                    for (size_t i = 0; i < n; i++)
                        sorted[i] &= ~(uint64_t)0xFFFFFFFFu;
                rto_bvh_node *want = malloc(n * sizeof *want), *got = malloc(n * sizeof *got);
                assert_int_equal(rto__karras_build_scalar(RTO_KEY_U64, sorted, n, boxes, want, NULL), RTO_OK);
                const rto_bvh_stats st = rto_karras_stats(want, n, &boxes[0]);
                for (uint32_t workers = 1; workers <= 16; workers *= 2) {
                    memset(got, 0xA5, n * sizeof *got);
                    rto__karras k;
                    memset(&k, 0, sizeof k);
                    k.f = RTO_KEY_U64;
                    k.keys = sorted;
                    k.n = n;
                    k.boxes = boxes;
                    k.nodes = got;
                    assert_int_equal(rto__karras_plan(&k, workers, NULL), RTO_OK);
                    for (uint32_t w = workers; w-- > 0;) /* any order: the workers share nothing they write */
                        rto__karras_run(&k, w, workers);
                    rto__karras_finish(&k);
                    if (memcmp(got, want, (n - 1) * sizeof *got))
                        fail_msg("%s n=%zu dup=%d workers=%u: nodes differ from the per-node builder's", di->name, n,
                                 dup, workers);
                    if (k.depth != st.depth)
                        fail_msg("%s n=%zu dup=%d workers=%u: depth %u, rto_karras_stats %u", di->name, n, dup,
                                 workers, k.depth, st.depth);
                    rto__karras_free(&k);
                }
                free(want);
                free(got);
            }
            free(boxes);
            free(c);
            free(keys);
            free(sorted);
        }
    }
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Empty meshes (DESIGN.md §5): an empty BLAS, and no TLAS key or leaf for its instances                              */

/* A scene assembled by hand: mesh 0 a unit quad (two triangles), mesh 1 empty; instances of mesh (i % 2) translated
 * by offsets[i]. The arrays are static: the scene is never passed to rto_scene_destroy. */
typedef struct hand_scene {
    rto_scene sc;
    rto_mesh meshes[2];
    rto_instance inst[8];
} hand_scene;

static float quad_pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};
static float empty_pos[] = {7, 7, 7};

static void hand_scene_make(hand_scene *h, const uint32_t *blas, const float (*offsets)[3], uint32_t n)
{
    memset(h, 0, sizeof *h);
    snprintf(h->sc.source, sizeof h->sc.source, "hand-made");
    snprintf(h->meshes[0].name, sizeof h->meshes[0].name, "quad");
    h->meshes[0].vertex_count = 4;
    h->meshes[0].positions = quad_pos;
    h->meshes[0].triangle_count = 2;
    h->meshes[0].indices = quad_idx;
    h->meshes[0].material = -1;
    snprintf(h->meshes[1].name, sizeof h->meshes[1].name, "empty");
    h->meshes[1].vertex_count = 1; /* vertices but no triangle, as a glTF primitive with no indices left */
    h->meshes[1].positions = empty_pos;
    h->meshes[1].material = -1;
    for (uint32_t i = 0; i < n; i++) {
        const double m[3][4] = {{1, 0, 0, offsets[i][0]}, {0, 1, 0, offsets[i][1]}, {0, 0, 1, offsets[i][2]}};
        assert_int_equal(rto_instance_set_transform(&h->inst[i], m, NULL), RTO_OK);
        h->inst[i].blas = blas[i];
        h->inst[i].mask = 0xFF;
    }
    h->sc.meshes = h->meshes;
    h->sc.mesh_count = 2;
    h->sc.instances = h->inst;
    h->sc.instance_count = n;
}

void test_empty_mesh_builds_an_empty_blas(void **state)
{
    (void)state;
    /* instances 1 and 3 are of the empty mesh, and far away: were they keyed, the x and z quantisation would move */
    const uint32_t blas[] = {0, 1, 0, 1};
    const float off[][3] = {{0, 0, 0}, {50, 0, 50}, {0, 3, 0}, {-40, 9, 9}};
    hand_scene h;
    hand_scene_make(&h, blas, off, 4);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        rto_msg msg = {{0}};
        if (rto_accel_build(&h.sc, &desc, &acc, &msg))
            fail_msg("empty mesh scene: %s", msg.text);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        assert_int_equal(t->instance_count, 4);
        assert_int_equal(t->key_count, 2);
        assert_int_equal(t->n_padded, 2);
        /* Pinned: centroids (0.5, 0.5, 0) and (0.5, 3.5, 0); only y varies, so instance 2 gets q = (0, 31, 0) and
         * morton15 = 0x2492; the keys keep the real instance indices 0 and 2. */
        assert_int_equal(t->keys[0], 0x00000000u);
        assert_int_equal(t->keys[1], 0x24920002u);
        assert_int_equal(t->sorted_keys[0], 0x00000000u);
        assert_int_equal(t->sorted_keys[1], 0x24920002u);
        for (int i = 1; i < 4; i += 2) { /* the empty instances' world boxes are (+inf, -inf) */
            assert_true(rto_aabb_is_empty(&t->instance_aabbs[i]));
            assert_true(t->instance_aabbs[i].min.x == INFINITY && t->instance_aabbs[i].max.y == -INFINITY);
        }
        if (desc.tlas == RTO_TLAS_SWEEP) {
            assert_int_equal(t->node_count, 3);
            assert_int_equal(t->sweep_nodes[1].item, 0);
            assert_int_equal(t->sweep_nodes[2].item, 2);
            assert_int_equal(t->sweep_nodes[0].item, RTO_TLAS_INTERNAL);
            assert_true(t->sweep_nodes[0].min[1] == 0.0f && t->sweep_nodes[0].max[1] == 4.0f);
        } else {
            assert_int_equal(t->node_count, 1);
            assert_int_equal(t->karras_nodes[0].left, RTO_BVH_LEAF_BIT | 0u);
            assert_int_equal(t->karras_nodes[0].right, RTO_BVH_LEAF_BIT | 1u);
            assert_true(t->karras_nodes[0].rmin[1] == 3.0f && t->karras_nodes[0].rmax[1] == 4.0f);
        }
        assert_int_equal(t->stats.leaves, 2);
        const rto_accel_blas *e = rto_accel_get_blas(acc, 1);
        assert_non_null(e);
        assert_int_equal(e->mesh, 1);
        assert_int_equal(e->triangle_count, 0);
        assert_int_equal(e->node_count, 0);
        assert_int_equal(e->stats.depth, 0);
        assert_int_equal(rto_accel_get_blas(acc, 0)->node_count, 1);
        rto_report r;
        if (rto_accel_check(acc, &r, &msg))
            fail_msg("self-check: %s", msg.text);
        rto_accel_destroy(acc);
    }
    /* only empty instances: no key; the sweep TLAS is one EMPTY root, the Karras TLAS has no node */
    const uint32_t blas2[] = {1, 1};
    hand_scene_make(&h, blas2, off, 2);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(&h.sc, &desc, &acc, NULL), RTO_OK);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        assert_int_equal(t->key_count, 0);
        assert_int_equal(t->n_padded, 0);
        assert_int_equal(t->node_count, kind ? 0u : 1u);
        if (!kind)
            assert_int_equal(t->sweep_nodes[0].item, RTO_TLAS_EMPTY);
        rto_report r;
        assert_int_equal(rto_accel_check(acc, &r, NULL), RTO_OK);
        rto_accel_destroy(acc);
    }
}

/* rto_tlas_keys_from_boxes against rto_tlas_keys (tested in test_keys) of the non-empty boxes alone: the same Morton
 * bits, with the real box index in the low 16 bits. */
void test_tlas_keys_skip_empty_boxes(void **state)
{
    (void)state;
    for (uint32_t seed = 1; seed <= 20; seed++) {
        const size_t n = 1 + rto_rng(seed, 0) % 3000;
        rto_aabb *boxes = make_boxes("uniform", n, 1e-3f, seed);
        rto_vec3 *c = malloc(n * sizeof *c);
        uint32_t *index = malloc(n * 4), *keys = malloc(n * 4), *ref = malloc(n * 4);
        size_t m = 0;
        for (size_t i = 0; i < n; i++) {
            if (rto_rng(seed, (uint32_t)i + 1) % 4 == 0) { /* a quarter of the boxes are empty */
                boxes[i].min = (rto_vec3){INFINITY, INFINITY, INFINITY};
                boxes[i].max = (rto_vec3){-INFINITY, -INFINITY, -INFINITY};
                continue;
            }
            c[m] = rto_aabb_centroid(&boxes[i]);
            index[m++] = (uint32_t)i;
        }
        size_t got = SIZE_MAX;
        assert_int_equal(rto_tlas_keys_from_boxes(boxes, n, keys, &got, NULL), RTO_OK);
        assert_int_equal(got, m);
        assert_int_equal(rto_tlas_keys(c, m, ref, NULL), RTO_OK);
        for (size_t k = 0; k < m; k++)
            if (keys[k] != ((ref[k] & 0xFFFF0000u) | index[k]))
                fail_msg("seed %u: key %zu is %08x, want %08x", seed, k, keys[k], (ref[k] & 0xFFFF0000u) | index[k]);
        free(boxes);
        free(c);
        free(index);
        free(keys);
        free(ref);
    }
    /* an empty or NaN box through a transform stays the empty box */
    rto_mat34 xf = {{{1, 0, 0, 1}, {0, 1, 0, 2}, {0, 0, 1, 3}}};
    rto_aabb none = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    rto_aabb nan_box = {{NAN, 0, 0}, {1, 1, 1}};
    rto_aabb t1 = rto_aabb_transform(&xf, &none), t2 = rto_aabb_transform(&xf, &nan_box);
    assert_memory_equal(&t1, &none, sizeof none);
    assert_memory_equal(&t2, &none, sizeof none);
    /* a NaN bound is not empty: it is refused, naming the box */
    rto_aabb b[2] = {{{0, 0, 0}, {1, 1, 1}}, {{NAN, 0, 0}, {1, 1, 1}}};
    uint32_t k[2];
    size_t m = 9;
    rto_msg msg = {{0}};
    assert_int_equal(rto_tlas_keys_from_boxes(b, 2, k, &m, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "centroid 1"));
    assert_int_equal(m, 0);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The accel API contract                                                                                              */

void test_accel_contract(void **state)
{
    (void)state;
    rto_accel_destroy(NULL);
    assert_null(rto_accel_get_tlas(NULL));
    assert_null(rto_accel_get_blas(NULL, 0));
    assert_null(rto_accel_scene(NULL));
    assert_int_equal(rto_accel_blas_count(NULL), 0);
    rto_accel *acc = (rto_accel *)&acc; /* must be reset to NULL on failure */
    rto_msg msg = {{0}};
    assert_int_equal(rto_accel_build(NULL, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_null(acc);
    rto_scene *sc = NULL;
    assert_int_equal(rto_scene_load("rtstress:3", &sc, &msg), RTO_OK);
    assert_int_equal(rto_accel_build(sc, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_accel_desc bad = {(rto_tlas_kind)7, 0};
    assert_int_equal(rto_accel_build(sc, &bad, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "TLAS kind"));
    /* NULL and a zero-initialised description both mean the sweep TLAS, with identical bytes */
    rto_accel *a = NULL, *z = NULL;
    rto_accel_desc zero;
    memset(&zero, 0, sizeof zero);
    assert_int_equal(rto_accel_build(sc, NULL, &a, &msg), RTO_OK);
    assert_int_equal(rto_accel_build(sc, &zero, &z, &msg), RTO_OK);
    const rto_accel_tlas *ta = rto_accel_get_tlas(a), *tz = rto_accel_get_tlas(z);
    assert_int_equal(ta->kind, RTO_TLAS_SWEEP);
    assert_int_equal(ta->node_count, tz->node_count);
    assert_memory_equal(ta->sweep_nodes, tz->sweep_nodes, ta->node_count * sizeof(rto_tlas_node));
    assert_ptr_equal(rto_accel_scene(a), sc);
    assert_int_equal(ta->node_count, 2 * 32 - 1); /* 27 instances, n_padded 32 */
    rto_accel_destroy(a);
    rto_accel_destroy(z);
    /* a scene assembled by hand is checked before anything is read through it */
    uint32_t saved = sc->meshes[0].indices[4];
    sc->meshes[0].indices[4] = sc->meshes[0].vertex_count;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "mesh 0"));
    sc->meshes[0].indices[4] = saved;
    sc->instances[5].blas = 3;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "instance 5"));
    assert_null(acc);
    rto_scene_destroy(sc);
}

/* Instances whose keys are refused (a non-finite centroid): every thread count refuses the build with the message of
 * the sequential key function over the same world boxes, which names the first such instance. */
void test_accel_tlas_key_refusals(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load("instances:uniform:5000", &sc, &msg), RTO_OK);
    for (int fault = 0; fault < 2; fault++) {
        rto_mat34 saved[2] = {sc->instances[3001].obj_to_world, sc->instances[4998].obj_to_world};
        /* an infinite translation: a non-finite centroid in a middle worker's range, or two, the first and last */
        if (fault == 0) {
            sc->instances[3001].obj_to_world.m[1][3] = INFINITY;
        } else {
            sc->instances[4998].obj_to_world.m[0][3] = -INFINITY;
            sc->instances[3001].obj_to_world.m[2][3] = INFINITY;
        }
        /* the expected message: the sequential keys of the instances' world boxes */
        rto_aabb *boxes = calloc(sc->instance_count, sizeof *boxes);
        uint32_t *keys = calloc(sc->instance_count, sizeof *keys);
        assert_non_null(boxes);
        assert_non_null(keys);
        rto_aabb mesh = rto_mesh_aabb(&sc->meshes[0]);
        for (uint32_t i = 0; i < sc->instance_count; i++)
            boxes[i] = rto_aabb_transform(&sc->instances[i].obj_to_world, &mesh);
        size_t m = 0;
        rto_msg want = {{0}};
        assert_int_equal(rto_tlas_keys_from_boxes(boxes, sc->instance_count, keys, &m, &want),
                         RTO_ERR_INVALID_ARGUMENT);
        if (!strstr(want.text, "centroid 3001 has a non-finite coordinate"))
            fail_msg("fault %d: the sequential keys say \"%s\"", fault, want.text);
        static const uint32_t threads[] = {1, 2, 3, 8};
        for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
            rto_accel_desc d = {RTO_TLAS_SWEEP, threads[t]};
            rto_accel *acc = (rto_accel *)&acc;
            assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
            assert_null(acc);
            if (strcmp(msg.text, want.text) != 0)
                fail_msg("fault %d, %u threads: \"%s\", expected \"%s\"", fault, threads[t], msg.text, want.text);
        }
        free(boxes);
        free(keys);
        sc->instances[3001].obj_to_world = saved[0];
        sc->instances[4998].obj_to_world = saved[1];
    }
    rto_scene_destroy(sc);
}

/* A triangle naming a vertex the mesh does not have: the build checks indices in its own stages now (each worker its
 * range, before any box reads a vertex), and must still name the first one in mesh and index order, before any key
 * refusal, at every thread count; a team-built mesh (sphere:5, 20,480 triangles) and worker-built ones (rtstress). */
void test_accel_index_refusals(void **state)
{
    (void)state;
    static const char *const specs[] = {"sphere:5", "rtstress:4"};
    static const uint32_t threads[] = {1, 2, 3, 8};
    for (size_t sp = 0; sp < sizeof specs / sizeof specs[0]; sp++) {
        rto_scene *sc = NULL;
        rto_msg msg = {{0}};
        assert_int_equal(rto_scene_load(specs[sp], &sc, &msg), RTO_OK);
        const uint32_t last = sc->mesh_count - 1;
        rto_mesh *me = &sc->meshes[last];
        assert_true(me->triangle_count >= 8);
        const size_t mid = 3 * (size_t)(me->triangle_count * 7 / 10) + 1, end = 3 * (size_t)me->triangle_count - 1;
        for (int fault = 0; fault < 3; fault++) {
            const uint32_t saved_mid = me->indices[mid], saved_end = me->indices[end];
            const float saved_pos = sc->meshes[0].positions[0];
            me->indices[mid] = me->vertex_count + (uint32_t)fault; /* just past the end, or further */
            if (fault >= 1)
                me->indices[end] = UINT32_MAX; /* a later one too: the first is named */
            if (fault == 2) {
                sc->meshes[0].positions[0] = INFINITY; /* a key refusal in the first mesh: the index is still named */
                const uint32_t bad_mid = me->indices[mid], bad_end = me->indices[end];
                me->indices[mid] = saved_mid;
                me->indices[end] = saved_end;
                rto_accel *alone = (rto_accel *)&alone;
                assert_int_equal(rto_accel_build(sc, NULL, &alone, &msg), RTO_ERR_INVALID_ARGUMENT); /* refused alone */
                assert_null(alone);
                assert_null(strstr(msg.text, "not below"));
                me->indices[mid] = bad_mid;
                me->indices[end] = bad_end;
            }
            char want[sizeof msg.text];
            snprintf(want, sizeof want, "mesh %u (%s): index %zu is %u, not below %u vertices", last, me->name, mid,
                     me->vertex_count + (uint32_t)fault, me->vertex_count);
            for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
                rto_accel_desc d = {RTO_TLAS_SWEEP, threads[t]};
                rto_accel *acc = (rto_accel *)&acc;
                assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
                assert_null(acc);
                if (strcmp(msg.text, want) != 0)
                    fail_msg("%s fault %d, %u threads: \"%s\", expected \"%s\"", specs[sp], fault, threads[t], msg.text,
                             want);
            }
            me->indices[mid] = saved_mid;
            me->indices[end] = saved_end;
            sc->meshes[0].positions[0] = saved_pos;
        }
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK); /* restored: it builds */
        rto_accel_destroy(acc);
        rto_scene_destroy(sc);
    }
}

/* An instance naming a BLAS the scene does not have: checked by the build in the instance boxes' ranges now, and
 * still named first (before an index out of range or a key refusal), at every thread count, for both TLAS kinds. */
void test_accel_instance_refusals(void **state)
{
    (void)state;
    static const uint32_t threads[] = {1, 2, 3, 8};
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load("instances:uniform:5000", &sc, &msg), RTO_OK);
    assert_int_equal(sc->mesh_count, 1);
    rto_mesh *me = &sc->meshes[0];
    for (int fault = 0; fault < 4; fault++) {
        const rto_instance saved[3] = {sc->instances[100], sc->instances[3001], sc->instances[4998]};
        const uint32_t saved_index = me->indices[1];
        sc->instances[3001].blas = 1 + (uint32_t)fault; /* in a middle worker's range */
        if (fault == 1)
            sc->instances[4998].blas = 7; /* a later one too: the first is named */
        if (fault == 2)
            me->indices[1] = me->vertex_count; /* an index out of range: the instance is still named first */
        if (fault == 3) {
            sc->instances[100].obj_to_world.m[0][3] = INFINITY; /* a TLAS key refusal, earlier in order */
            const uint32_t bad = sc->instances[3001].blas;
            sc->instances[3001].blas = 0;
            rto_accel *alone = (rto_accel *)&alone;
            assert_int_equal(rto_accel_build(sc, NULL, &alone, &msg), RTO_ERR_INVALID_ARGUMENT); /* refused alone */
            assert_null(alone);
            assert_null(strstr(msg.text, "names BLAS"));
            sc->instances[3001].blas = bad;
        }
        char want[sizeof msg.text];
        snprintf(want, sizeof want, "instance 3001 names BLAS %u of 1", 1 + (uint32_t)fault);
        for (int kind = 0; kind < 2; kind++)
            for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
                rto_accel_desc d = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, threads[t]};
                rto_accel *acc = (rto_accel *)&acc;
                assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
                assert_null(acc);
                if (strcmp(msg.text, want) != 0)
                    fail_msg("fault %d, kind %d, %u threads: \"%s\", expected \"%s\"", fault, kind, threads[t],
                             msg.text, want);
            }
        sc->instances[100] = saved[0];
        sc->instances[3001] = saved[1];
        sc->instances[4998] = saved[2];
        me->indices[1] = saved_index;
    }
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK); /* restored: it builds */
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
}

/* A mesh with NULL indices is refused before the build; what the sequential checks named before it still comes
 * first: a bad instance, then a bad index in an earlier mesh (but not in a later one). */
void test_accel_null_mesh_precedence(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    char path[4096];
    snprintf(path, sizeof path, "%s/CornellBox-nvpro-glTF/cornellBox.gltf", fix);
    if (rto_scene_load(path, &sc, &msg))
        fail_msg("%s: %s", path, msg.text);
    assert_true(sc->mesh_count >= 2 && sc->instance_count >= 1);
    assert_true(sc->meshes[0].triangle_count >= 2 && sc->meshes[sc->mesh_count - 1].triangle_count >= 2);
    rto_mesh *first = &sc->meshes[0], *last = &sc->meshes[sc->mesh_count - 1];
    uint32_t *first_idx = first->indices, *last_idx = last->indices;
    const uint32_t saved_first = first_idx[4], saved_last = last_idx[4], saved_blas = sc->instances[0].blas;
    char want[sizeof msg.text];
    for (int fault = 0; fault < 3; fault++) {
        if (fault == 0) { /* a bad index in mesh 0, NULL indices in the last mesh: the index */
            first_idx[4] = first->vertex_count;
            last->indices = NULL;
            snprintf(want, sizeof want, "mesh 0 (%s): index 4 is %u, not below %u vertices", first->name,
                     first->vertex_count, first->vertex_count);
        } else if (fault == 1) { /* NULL indices in mesh 0, a bad index in the last mesh: the NULL */
            first->indices = NULL;
            last_idx[4] = last->vertex_count;
            snprintf(want, sizeof want, "mesh 0 (%s): NULL positions or indices", first->name);
        } else { /* a bad instance beside NULL indices: the instance */
            last->indices = NULL;
            sc->instances[0].blas = sc->mesh_count;
            snprintf(want, sizeof want, "instance 0 names BLAS %u of %u", sc->mesh_count, sc->mesh_count);
        }
        for (uint32_t threads = 1; threads <= 3; threads++) {
            rto_accel_desc d = {RTO_TLAS_SWEEP, threads};
            rto_accel *acc = (rto_accel *)&acc;
            assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
            assert_null(acc);
            if (strcmp(msg.text, want) != 0)
                fail_msg("fault %d, %u threads: \"%s\", expected \"%s\"", fault, threads, msg.text, want);
        }
        first->indices = first_idx;
        last->indices = last_idx;
        first_idx[4] = saved_first;
        last_idx[4] = saved_last;
        sc->instances[0].blas = saved_blas;
    }
    rto_scene_destroy(sc);
}

/* rto_accel_check names the tree and the fault of a damaged accel. The views are const for readers; the test casts
 * that away on purpose to damage one tree at a time. */
void test_accel_check_names_the_tree(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    rto_report r;
    assert_int_equal(rto_scene_load("rtstress:4", &sc, &msg), RTO_OK);
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK);
    const rto_accel_tlas *t = rto_accel_get_tlas(acc);
    rto_tlas_node *leaves = (rto_tlas_node *)(uintptr_t)(t->sweep_nodes + t->n_padded - 1);
    uint32_t item = leaves[3].item;
    leaves[3].item = leaves[4].item; /* an instance twice, another in no leaf */
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_string_equal(r.fault, "item");
    assert_non_null(strstr(msg.text, "the sweep TLAS: item"));
    leaves[3].item = item;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    rto_bvh_node *bn = (rto_bvh_node *)(uintptr_t)rto_accel_get_blas(acc, 0)->nodes;
    bn[2].lmax[1] = nextafterf(bn[2].lmax[1], INFINITY);
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_BOX);
    assert_int_equal(where_of(&r, "node"), 2);
    assert_string_equal(r.what, "BLAS 0");
    assert_non_null(strstr(msg.text, "the BLAS of mesh 0: box"));
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);

    /* with empty instances: a leaf that holds an instance of the empty mesh is caught */
    const uint32_t blas[] = {0, 1, 0, 0};
    const float off[][3] = {{0, 0, 0}, {50, 0, 50}, {0, 3, 0}, {4, 0, 0}};
    hand_scene h;
    hand_scene_make(&h, blas, off, 4);
    assert_int_equal(rto_accel_build(&h.sc, NULL, &acc, &msg), RTO_OK);
    t = rto_accel_get_tlas(acc);
    assert_int_equal(t->key_count, 3);
    leaves = (rto_tlas_node *)(uintptr_t)(t->sweep_nodes + t->n_padded - 1);
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    /* the EMPTY leaf given the empty instance, then a real instance's leaf given it instead */
    assert_int_equal(leaves[3].item, RTO_TLAS_EMPTY);
    leaves[3].item = 1;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_int_equal(where_of(&r, "node"), (int64_t)t->n_padded - 1 + 3);
    leaves[3].item = RTO_TLAS_EMPTY;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    leaves[0].item = 1;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_int_equal(where_of(&r, "leaf"), 0);
    assert_int_equal(where_of(&r, "primitive"), 1); /* the real instance index: no renumbering */
    assert_int_equal(where_of(&r, "node"), (int64_t)t->n_padded - 1);
    assert_string_equal(r.what, "TLAS (sweep)");
    assert_non_null(strstr(msg.text, "the sweep TLAS: item"));
    rto_accel_destroy(acc);
}
