/* The tracer's other paths, the packed one (trace/packed.c, the default on x86-64) and the SIMD lanes (trace/lanes.c),
 * against the scalar tracer they must equal bit for bit (hit records and counters, every ray): every ray set of the
 * library and the tests' own mixed-flag rays, both TLAS layouts, masks, one-triangle BLASes and one-instance TLASes,
 * 1 to 33 threads, and threads that trace one accel at once before its packed copy exists. A path this CPU cannot
 * run is reported and skipped. */
#include "testutil.h"

#include <pthread.h>
#include "trace/trace_internal.h"

/* Rays of every kind in one batch, so that neighbouring lanes disagree: origins in and around the bounds, directions
 * random or axis-parallel (+0 and -0 components), each ray's flags, cull mask and [tMin, tMax] drawn on its own. */
static rto_wf_ray *mixed_rays(const rto_scene *s, uint64_t seed, size_t n)
{
    static const uint32_t flag_sets[] = {RTO_RAY_FLAG_OPAQUE,
                                         RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT,
                                         RTO_RAY_FLAG_CULL_BACK_FACING,
                                         RTO_RAY_FLAG_CULL_FRONT_FACING | RTO_RAY_FLAG_SKIP_CLOSEST_HIT,
                                         RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_CULL_BACK_FACING};
    static const uint32_t masks[] = {0xFF, 0xFF, 0xFF, 0x01, 0x02, 0x00};
    rto_wf_ray *rays = calloc(n ? n : 1, sizeof *rays);
    assert_non_null(rays);
    const rto_aabb b = rto_scene_aabb(s);
    const float lo[3] = {b.min.x, b.min.y, b.min.z}, hi[3] = {b.max.x, b.max.y, b.max.z};
    uint64_t r = seed;
    for (size_t i = 0; i < n; i++) {
        rto_wf_ray *ray = &rays[i];
        for (int a = 0; a < 3; a++) {
            const float ext = hi[a] - lo[a];
            ray->origin[a] = lo[a] - 0.25f * ext + 1.5f * ext * (float)tu_rng_unit(&r);
            ray->dir[a] = (float)(2.0 * tu_rng_unit(&r) - 1.0);
        }
        if (i % 7 == 3) { /* axis-parallel, with signed zeros */
            const int keep = (int)(tu_rng_next(&r) % 3);
            for (int a = 0; a < 3; a++)
                if (a != keep)
                    ray->dir[a] = tu_rng_next(&r) & 1 ? -0.0f : 0.0f;
        }
        ray->t_min = i % 5 == 0 ? (float)tu_rng_unit(&r) : 0.0f;
        ray->t_max = i % 4 == 0 ? ray->t_min + (float)(tu_rng_unit(&r) * 4.0) : 1e30f;
        ray->flags = flag_sets[tu_rng_next(&r) % 5];
        ray->cull_mask = masks[tu_rng_next(&r) % 6];
        ray->pixel = (uint32_t)i;
    }
    return rays;
}

/* The first ray whose record or counters differ, named with its field, or the test passes. */
static void compare(const char *what, const rto_hit_record *want, const rto_trace_counters *wc,
                    const rto_hit_record *got, const rto_trace_counters *gc, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (memcmp(&want[i], &got[i], sizeof want[i]))
            fail_msg("%s: ray %zu: record differs (scalar t %.9g instance %u prim %u miss %u, path t %.9g instance %u "
                     "prim %u miss %u)", what, i, (double)want[i].t, want[i].instance_id, want[i].prim_id,
                     want[i].miss_flag, (double)got[i].t, got[i].instance_id, got[i].prim_id, got[i].miss_flag);
        if (memcmp(&wc[i], &gc[i], sizeof wc[i]))
            fail_msg("%s: ray %zu: counters differ (scalar nodes %u boxes %u triangles %u entries %u, path %u %u %u %u)",
                     what, i, wc[i].nodes_visited, wc[i].box_tests, wc[i].triangle_tests, wc[i].instance_entries,
                     gc[i].nodes_visited, gc[i].box_tests, gc[i].triangle_tests, gc[i].instance_entries);
    }
}

/* Every other supported path against the scalar tracer on these rays, with each thread count. */
static void check_rays(const char *what, const rto_accel *acc, const rto_wf_ray *rays, size_t n,
                       const uint32_t *threads, size_t nthreads)
{
    rto_hit_record *want = malloc((n ? n : 1) * sizeof *want), *got = malloc((n ? n : 1) * sizeof *got);
    rto_trace_counters *wc = malloc((n ? n : 1) * sizeof *wc), *gc = malloc((n ? n : 1) * sizeof *gc);
    assert_true(want && got && wc && gc);
    rto_msg msg = {{0}};
    rto_trace_desc one = {1};
    if (rto__trace_with(acc, rays, n, &one, RTO__TRACE_SCALAR, want, wc, &msg))
        fail_msg("%s: scalar: %s", what, msg.text);
    size_t hits = 0;
    for (size_t i = 0; i < n; i++)
        hits += !want[i].miss_flag;
    for (int isa = RTO__TRACE_SCALAR + 1; isa < RTO__TRACE_ISA_COUNT; isa++) {
        if (!rto__trace_isa_supported((rto__trace_isa)isa))
            continue;
        /* the packed path in each of its orders this CPU runs (one at a time, rays in turn, groups of 8 and 16); the
         * others have one */
        static const char *const orders[] = {"", "", " in turn", " in groups of 8", " in groups of 16"};
        const rto__trace_order last = isa == RTO__TRACE_SSE2 ? RTO__ORDER_GROUPS_16 : RTO__ORDER_ONE;
        for (size_t k = 0; k < nthreads; k++)
            for (rto__trace_order order = RTO__ORDER_ONE; order <= last; order++) {
                if (isa == RTO__TRACE_SSE2 && !rto__trace_packed_order_supported(order))
                    continue;
                char label[160];
                snprintf(label, sizeof label, "%s, %s%s, %u threads (%zu of %zu rays hit)", what,
                         rto__trace_isa_name((rto__trace_isa)isa), orders[order], threads[k], hits, n);
                rto_trace_desc d = {threads[k]};
                memset(got, 0xA5, n * sizeof *got);
                memset(gc, 0xA5, n * sizeof *gc);
                if (rto__trace_with_order(acc, rays, n, &d, (rto__trace_isa)isa, order, got, gc, &msg))
                    fail_msg("%s: %s", label, msg.text);
                /* the packed path ran on its copy, not on the scalar tracer it falls back to */
                if (isa == RTO__TRACE_SSE2 && !rto__trace_packed_trees(acc, 0))
                    fail_msg("%s: no packed copy was made", label);
                compare(label, want, wc, got, gc, n);
            }
    }
    free(want);
    free(got);
    free(wc);
    free(gc);
}

static const uint32_t one_thread[] = {1}, many_threads[] = {1, 2, 3, 33};

/* The library's ray sets (primary, shadow, random, grazing, axis) and the mixed rays on a scene, both TLAS layouts. */
static void check_scene(const char *spec, uint32_t width, uint32_t height, size_t count)
{
    rto_scene *s = tu_load(spec);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel *acc = tu_accel(s, kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP);
        for (int set = RTO_RAYS_PRIMARY; set <= RTO_RAYS_AXIS; set++) {
            rto_rays_desc d;
            memset(&d, 0, sizeof d);
            d.set = (rto_ray_set)set;
            d.seed = 7;
            d.width = width;
            d.height = height;
            d.count = count;
            const size_t cap = rto_rays_capacity(&d);
            rto_wf_ray *rays = malloc((cap ? cap : 1) * sizeof *rays);
            size_t n = 0;
            rto_msg msg = {{0}};
            assert_non_null(rays);
            if (rto_rays_generate(acc, &d, rays, cap, &n, NULL, &msg))
                fail_msg("%s: rays: %s", spec, msg.text);
            char what[128];
            snprintf(what, sizeof what, "%s, %s TLAS, %s rays", spec, kind ? "karras" : "sweep",
                     rto_ray_set_name((rto_ray_set)set));
            check_rays(what, acc, rays, n, one_thread, 1);
            free(rays);
        }
        rto_wf_ray *rays = mixed_rays(s, 11, count);
        char what[128];
        snprintf(what, sizeof what, "%s, %s TLAS, mixed rays", spec, kind ? "karras" : "sweep");
        check_rays(what, acc, rays, count, many_threads, 4);
        free(rays);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(s);
}

static void test_paths_reported(void **state)
{
    (void)state;
    for (int isa = RTO__TRACE_SCALAR; isa < RTO__TRACE_ISA_COUNT; isa++)
        print_message("trace path %s: %s\n", rto__trace_isa_name((rto__trace_isa)isa),
                      rto__trace_isa_supported((rto__trace_isa)isa) ? "tested" : "not on this CPU");
    print_message("rto_trace runs: %s\n", rto__trace_isa_name(rto__trace_isa_resolve()));
}

/* One instance of one triangle: a Karras TLAS with one key (straight to the instance) and a BLAS without nodes. */
static void test_one_triangle(void **state)
{
    (void)state;
    check_scene("triangle", 64, 48, 4000);
}

/* Instanced scenes: a sweep TLAS padded with EMPTY leaves (27 and 64 instances), mirrored and masked instances. */
static void test_instanced(void **state)
{
    (void)state;
    check_scene("rtstress:3", 96, 64, TU_SIZED(20000, 4000));
    check_scene("rtstress:4", 96, 64, TU_SIZED(20000, 4000));
    check_scene("random:3", 64, 48, TU_SIZED(20000, 4000));
    check_scene("random:8", 64, 48, TU_SIZED(20000, 4000));
}

/* A deep BLAS of a real mesh and closed meshes. */
static void test_meshes(void **state)
{
    (void)state;
    check_scene("StanfordBunny/bunny.gltf", TU_SIZED(160, 64), TU_SIZED(120, 48), TU_SIZED(20000, 4000));
    check_scene("sphere:3:9", 64, 48, TU_SIZED(10000, 3000));
}

/* Empty meshes: a BLAS without triangles, whose instances get no key and no leaf; with every mesh empty, a Karras
 * TLAS of no key and a sweep TLAS whose root is EMPTY. */
static void test_empty_meshes(void **state)
{
    (void)state;
    for (int all = 0; all < 2; all++) {
        rto_scene *s = tu_load("random:3");
        rto_wf_ray *rays = mixed_rays(s, 29, 3000); /* around the bounds the meshes had */
        assert_true(s->mesh_count >= 2);
        for (uint32_t m = 0; m < s->mesh_count; m++)
            if (all || m == 0)
                s->meshes[m].triangle_count = 0;
        for (int kind = 0; kind < 2; kind++) {
            rto_accel *acc = tu_accel(s, kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP);
            char what[96];
            snprintf(what, sizeof what, "random:3 with %s empty, %s TLAS", all ? "every mesh" : "mesh 0",
                     kind ? "karras" : "sweep");
            check_rays(what, acc, rays, 3000, many_threads, 4);
            rto_accel_destroy(acc);
        }
        free(rays);
        rto_scene_destroy(s);
    }
}

/* Masks: instances on two bits, rays with one, the other or none. */
static void test_masks(void **state)
{
    (void)state;
    rto_scene *s = tu_load("rtstress:3");
    for (uint32_t k = 0; k < s->instance_count; k++)
        s->instances[k].mask = k % 3 == 0 ? 0x01 : 0x02;
    for (int kind = 0; kind < 2; kind++) {
        rto_accel *acc = tu_accel(s, kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP);
        rto_wf_ray *rays = mixed_rays(s, 5, 6000);
        check_rays(kind ? "rtstress:3 masked, karras" : "rtstress:3 masked, sweep", acc, rays, 6000, many_threads, 4);
        free(rays);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(s);
}

/* rto_trace takes the packed path where the build has it, else the scalar tracer; RTO_TRACE_ISA asks for a path,
 * and gets it or the best the CPU has below it; an unknown name is ignored and an unknown path refused by
 * rto__trace_with. */
static void test_isa_choice(void **state)
{
    (void)state;
    const rto__trace_isa def = rto__trace_isa_supported(RTO__TRACE_SSE2) ? RTO__TRACE_SSE2 : RTO__TRACE_SCALAR;
#if defined(__x86_64__)
    assert_int_equal(def, RTO__TRACE_SSE2); /* SSE2 is baseline x86-64 */
#endif
    unsetenv("RTO_TRACE_ISA");
    assert_int_equal(rto__trace_isa_resolve(), def);
    assert_int_equal(setenv("RTO_TRACE_ISA", "avx1024", 1), 0);
    assert_int_equal(rto__trace_isa_resolve(), def);
    static const char *const names[] = {"scalar", "sse2", "avx2", "avx512"};
    for (int i = 0; i < 4; i++) {
        assert_int_equal(setenv("RTO_TRACE_ISA", names[i], 1), 0);
        const rto__trace_isa got = rto__trace_isa_resolve();
        assert_true(got <= (rto__trace_isa)(RTO__TRACE_SCALAR + i));
        if (rto__trace_isa_supported((rto__trace_isa)(RTO__TRACE_SCALAR + i)))
            assert_int_equal(got, RTO__TRACE_SCALAR + i);
    }
    unsetenv("RTO_TRACE_ISA");
    rto_scene *s = tu_load("triangle");
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    rto_wf_ray *rays = mixed_rays(s, 3, 4);
    rto_hit_record h[4];
    rto_msg msg = {{0}};
    assert_int_equal(rto__trace_with(acc, rays, 4, NULL, (rto__trace_isa)9, h, NULL, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "not supported"));
    free(rays);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* Threads that trace one accel at once, each with its own rto_trace call, before any has made the packed copy of its
 * trees: the copy is made once (rto__accel_derived) and every thread's records equal the scalar tracer's. */
typedef struct racer {
    const rto_accel *acc;
    const rto_wf_ray *rays;
    size_t n;
    rto_hit_record *hits;
    rto_status status;
} racer;

static void *race(void *p)
{
    racer *r = p;
    rto_msg msg = {{0}};
    rto_trace_desc one = {1};
    /* the packed path asked for: left to choose, rto_trace would not make the copy for so few rays */
    const rto__trace_isa isa = rto__trace_isa_supported(RTO__TRACE_SSE2) ? RTO__TRACE_SSE2 : RTO__TRACE_SCALAR;
    r->status = rto__trace_with(r->acc, r->rays, r->n, &one, isa, r->hits, NULL, &msg);
    return NULL;
}

static void test_first_use_race(void **state)
{
    (void)state;
    enum { RACERS = 8, N = 3000 };
    rto_scene *s = tu_load("StanfordBunny/bunny.gltf");
    for (int round = 0; round < 4; round++) {
        rto_accel *acc = tu_accel(s, round % 2 ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP);
        rto_wf_ray *rays = mixed_rays(s, 17 + (uint64_t)round, N);
        rto_hit_record *want = malloc(N * sizeof *want);
        racer r[RACERS];
        pthread_t t[RACERS];
        rto_msg msg = {{0}};
        assert_non_null(want);
        for (int k = 0; k < RACERS; k++) {
            r[k] = (racer){acc, rays, N, malloc(N * sizeof(rto_hit_record)), RTO_ERR_MISMATCH};
            assert_non_null(r[k].hits);
        }
        for (int k = 0; k < RACERS; k++)
            assert_int_equal(pthread_create(&t[k], NULL, race, &r[k]), 0);
        for (int k = 0; k < RACERS; k++)
            assert_int_equal(pthread_join(t[k], NULL), 0);
        assert_int_equal(rto__trace_with(acc, rays, N, NULL, RTO__TRACE_SCALAR, want, NULL, &msg), RTO_OK);
        assert_true((rto__trace_packed_trees(acc, 0) != NULL) == rto__trace_isa_supported(RTO__TRACE_SSE2));
        for (int k = 0; k < RACERS; k++) {
            assert_int_equal(r[k].status, RTO_OK);
            for (size_t i = 0; i < N; i++)
                if (memcmp(&want[i], &r[k].hits[i], sizeof want[i]))
                    fail_msg("round %d, thread %d: ray %zu: record differs from the scalar tracer's", round, k, i);
            free(r[k].hits);
        }
        free(want);
        free(rays);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(s);
}

/* The bunny, for the packed path's tests; NULL (reported) where the build has no packed path. */
static rto_scene *packed_bunny(void)
{
    if (!rto__trace_isa_supported(RTO__TRACE_SSE2)) {
        print_message("no packed path in this build\n");
        return NULL;
    }
    return tu_load("StanfordBunny/bunny.gltf");
}

/* Left to choose, rto_trace makes the packed copy once the calls on the accel have brought threads * slots rays (the
 * bunny: 2 slots a triangle, 1 for the one-instance sweep TLAS) and runs the scalar tracer before, the same bytes;
 * asked for (RTO_TRACE_ISA=sse2) it makes it for any call. */
static void test_packed_when_worth(void **state)
{
    (void)state;
    rto_scene *s = packed_bunny();
    if (!s)
        return;
    const size_t slots = 2 * (size_t)s->meshes[0].triangle_count + 1, small = 2000;
    rto_wf_ray *rays = mixed_rays(s, 23, slots);
    rto_hit_record *want = malloc(slots * sizeof *want), *got = malloc(slots * sizeof *got);
    rto_msg msg = {{0}};
    assert_true(want && got);
    unsetenv("RTO_TRACE_ISA");
    for (uint32_t threads = 1; threads <= 2; threads++) {
        rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
        rto_trace_desc d = {threads};
        assert_int_equal(rto__trace_with(acc, rays, slots, &d, RTO__TRACE_SCALAR, want, NULL, &msg), RTO_OK);
        assert_int_equal(rto_trace(acc, rays, small, &d, got, NULL, &msg), RTO_OK);
        assert_null(rto__trace_packed_trees(acc, 0));
        assert_memory_equal(want, got, small * sizeof *got);
        assert_false(rto__trace_packed_worth(acc, slots - 1, 1));
        assert_true(rto__trace_packed_worth(acc, slots, 1));
        /* small + slots rays so far: enough on one thread, not on two */
        assert_int_equal(rto_trace(acc, rays, slots, &d, got, NULL, &msg), RTO_OK);
        assert_true((rto__trace_packed_trees(acc, 0) != NULL) == (threads == 1));
        assert_memory_equal(want, got, slots * sizeof *got);
        /* small + 2 slots rays, in calls smaller than 2 slots: enough on two */
        assert_int_equal(rto_trace(acc, rays, slots, &d, got, NULL, &msg), RTO_OK);
        assert_non_null(rto__trace_packed_trees(acc, 0));
        assert_memory_equal(want, got, slots * sizeof *got);
        rto_accel_destroy(acc);
    }
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    assert_int_equal(setenv("RTO_TRACE_ISA", "sse2", 1), 0);
    assert_int_equal(rto_trace(acc, rays, small, NULL, got, NULL, &msg), RTO_OK);
    unsetenv("RTO_TRACE_ISA");
    assert_non_null(rto__trace_packed_trees(acc, 0));
    assert_memory_equal(want, got, small * sizeof *got);
    rto_accel_destroy(acc);
    free(want);
    free(got);
    free(rays);
    rto_scene_destroy(s);
}

/* The order the packed path takes for rays alike: the widest groups the CPU runs. */
static rto__trace_order alike_order(void)
{
    return rto__cpu_avx512() ? RTO__ORDER_GROUPS_16 : rto__cpu_avx2() ? RTO__ORDER_GROUPS_8 : RTO__ORDER_ONE;
}

/* The packed path's order, left to choose (rto__trace_packed_order): rays in turn only on trees of more than
 * RTO__TRACE_PACKED_CACHE bytes and only where neighbouring rays diverge, the widest groups the CPU runs where they do
 * not, else one at a time; the bunny's copy holds 64 bytes per BLAS node and triangle (its one-instance sweep TLAS
 * has no node); rto_trace's records and counters on the bunny's primary, shadow and random rays (in groups, in groups
 * and in turn) equal the scalar tracer's; RTO_TRACE_GROUPS=8 and =1 cap the groups, other values do not. */
static void test_packed_order(void **state)
{
    (void)state;
    assert_int_equal(unsetenv("RTO_TRACE_GROUPS"), 0); /* the rule as the CPU has it */
    rto_scene *s = packed_bunny();
    if (!s)
        return;
    rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
    rto_msg msg = {{0}};
    static const rto_ray_set sets[] = {RTO_RAYS_PRIMARY, RTO_RAYS_SHADOW, RTO_RAYS_RANDOM};
    for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
        rto_rays_desc d;
        memset(&d, 0, sizeof d);
        d.set = sets[k];
        d.seed = 3;
        d.width = 96;
        d.height = 64;
        d.count = 96 * 64;
        const size_t cap = rto_rays_capacity(&d);
        rto_wf_ray *rays = malloc(cap * sizeof *rays);
        rto_hit_record *want = malloc(cap * sizeof *want), *got = malloc(cap * sizeof *got);
        rto_trace_counters *wc = malloc(cap * sizeof *wc), *gc = malloc(cap * sizeof *gc);
        size_t n = 0;
        assert_true(rays && want && got && wc && gc);
        assert_int_equal(rto_rays_generate(acc, &d, rays, cap, &n, NULL, &msg), RTO_OK);
        assert_true(n > 500);
        rto_trace_desc two = {2};
        assert_int_equal(rto__trace_with(acc, rays, n, &two, RTO__TRACE_SCALAR, want, wc, &msg), RTO_OK);
        assert_int_equal(rto__trace_with(acc, rays, n, &two, RTO__TRACE_SSE2, got, gc, &msg), RTO_OK);
        compare(rto_ray_set_name(sets[k]), want, wc, got, gc, n);
        const void *trees = rto__trace_packed_trees(acc, 0);
        assert_non_null(trees);
        const rto_accel_blas *b = rto_accel_get_blas(acc, 0);
        const size_t bytes = 64 * ((size_t)b->node_count + b->triangle_count);
        assert_int_equal(rto__trace_packed_bytes(trees), bytes);
        assert_true(bytes > RTO__TRACE_PACKED_CACHE);
        const rto__trace_order alike = alike_order();
        const rto__trace_order want_order = sets[k] == RTO_RAYS_RANDOM ? RTO__ORDER_IN_TURN : alike;
        assert_int_equal(rto__trace_packed_order(bytes, rays, 0, n), want_order);
        assert_int_equal(rto__trace_packed_order(bytes, rays, n / 2, n), want_order);
        assert_int_equal(rto__trace_packed_order(RTO__TRACE_PACKED_CACHE, rays, 0, n),
                         sets[k] == RTO_RAYS_RANDOM ? RTO__ORDER_ONE : alike);
        assert_int_equal(rto__trace_packed_order(bytes, rays, 0, 1), alike);
        free(rays);
        free(want);
        free(got);
        free(wc);
        free(gc);
    }
    /* Neighbours alike, or alternately opposite: -0 and +0 components, unnormalised directions. */
    rto_wf_ray r[64];
    memset(r, 0, sizeof r);
    for (int i = 0; i < 64; i++) {
        r[i].dir[0] = 3.0f;
        r[i].dir[1] = i % 2 ? -0.0f : 0.0f;
        r[i].dir[2] = 0.5f;
    }
    assert_int_equal(rto__trace_packed_order(SIZE_MAX, r, 0, 64), alike_order());
    /* RTO_TRACE_GROUPS caps the groups as a CPU without AVX-512 ("8") or without AVX2 ("1") would; anything else
     * leaves them to the CPU. Rays that diverge are not its concern. */
    static const struct {
        const char *value;
        rto__trace_order want;
    } caps[] = {{"8", RTO__ORDER_GROUPS_8}, {"1", RTO__ORDER_ONE}, {"16", RTO__ORDER_GROUPS_16}, {"4", -1}, {"", -1}};
    for (size_t k = 0; k < sizeof caps / sizeof caps[0]; k++) {
        assert_int_equal(setenv("RTO_TRACE_GROUPS", caps[k].value, 1), 0);
        rto__trace_order want = (int)caps[k].want < 0 ? alike_order() : caps[k].want;
        if (!rto__trace_packed_order_supported(want))
            want = want == RTO__ORDER_GROUPS_16 && rto__cpu_avx2() ? RTO__ORDER_GROUPS_8 : RTO__ORDER_ONE;
        assert_int_equal(rto__trace_packed_order(SIZE_MAX, r, 0, 64), want);
    }
    assert_int_equal(unsetenv("RTO_TRACE_GROUPS"), 0);
    for (int i = 0; i < 64; i += 2)
        r[i].dir[0] = r[i].dir[2] = -1e-3f;
    assert_int_equal(rto__trace_packed_order(SIZE_MAX, r, 0, 64), RTO__ORDER_IN_TURN);
    assert_int_equal(setenv("RTO_TRACE_GROUPS", "1", 1), 0);
    assert_int_equal(rto__trace_packed_order(SIZE_MAX, r, 0, 64), RTO__ORDER_IN_TURN);
    assert_int_equal(unsetenv("RTO_TRACE_GROUPS"), 0);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

/* rto__accel_derived: make runs once, its result is shared, release frees it with the accel; a make that fails
 * (returns NULL) is not retried, and release gets NULL. */
static int makes, releases;
static void *make_ok(const rto_accel *a)
{
    (void)a;
    makes++;
    return malloc(16);
}
static void *make_fail(const rto_accel *a)
{
    (void)a;
    makes++;
    return NULL;
}
static void release(void *p)
{
    releases++;
    free(p);
}

static void test_accel_derived(void **state)
{
    (void)state;
    rto_scene *s = tu_load("triangle");
    for (int fail = 0; fail < 2; fail++) {
        makes = releases = 0;
        rto_accel *acc = tu_accel(s, RTO_TLAS_SWEEP);
        void *(*make)(const rto_accel *) = fail ? make_fail : make_ok;
        assert_null(rto__accel_derived(acc, NULL, NULL)); /* nothing made yet, and looking makes nothing */
        void *first = rto__accel_derived(acc, make, release);
        assert_true(fail ? first == NULL : first != NULL);
        assert_ptr_equal(rto__accel_derived(acc, make, release), first);
        assert_ptr_equal(rto__accel_derived(acc, NULL, NULL), first); /* only looks */
        assert_int_equal(makes, 1);
        assert_int_equal(releases, 0);
        rto_accel_destroy(acc);
        assert_int_equal(releases, 1);
    }
    rto_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paths_reported), cmocka_unit_test(test_isa_choice),
        cmocka_unit_test(test_one_triangle),   cmocka_unit_test(test_masks),
        cmocka_unit_test(test_instanced),      cmocka_unit_test(test_meshes),
        cmocka_unit_test(test_first_use_race), cmocka_unit_test(test_accel_derived),
        cmocka_unit_test(test_packed_when_worth), cmocka_unit_test(test_empty_meshes),
        cmocka_unit_test(test_packed_order),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
