/* The wavefront frame's capacity rules (DESIGN.md §7), part of unit.programs (main() in test_programs.c): programs
 * defined here that overflow the 2 W H queues, exceed the per-invocation emit budget and accumulate into one pixel
 * from several rays, checked against a serial simulation of the queue rules; calls the frame must refuse; thread
 * counts 1, 2, 3 and 7, and passes run in chunks, give the same bytes in every buffer. */
#include "test_programs.h"

#include "frame/frame_internal.h"

/* ---------------------------------------------------------------------------------------------------------------- */
/* Capacity: drops, refused emits, conflicts                                                                         */

/* Payload of the test programs: where the ray came from. */
typedef struct test_payload {
    uint32_t depth, pixel, j, magic;
} test_payload;
#define TEST_MAGIC 0x5EEDC0DEu

/* A ray of the stage2 scene: from (0, 0, 5) down -z (hits sphere 1 at t = 4) for an even pixel, up +z (a miss) for
 * an odd one. */
static rto_wf_ray test_ray(uint32_t pixel, uint32_t depth)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    r.origin[2] = 5.0f;
    r.dir[2] = (pixel % 2) ? 1.0f : -1.0f;
    r.t_max = 1e30f;
    r.flags = 0x1u;
    r.cull_mask = 0xFFu;
    r.kind = depth;
    return r;
}

/* Flood: raygen emits 2 rays where x == 0 or (x + y) % 3 == 0, else 1, and tries a third where x == 0 (refused);
 * every shading invocation emits 2 rays of the next depth, and tries a third when its pixel % 7 == 0 (refused). */
static uint32_t flood_primary(uint32_t x, uint32_t y) { return (x == 0 || (x + y) % 3 == 0) ? 2u : 1u; }

static void flood_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const uint32_t n = flood_primary(x, y) + (x == 0);
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {0, p, j, TEST_MAGIC};
        const rto_wf_ray r = test_ray(p, 0);
        rto_emit_primary_ray(ctx, &r, &pl);
    }
}

static void flood_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const test_payload *in = payload;
    const uint32_t n = 2 + (ray->pixel % 7 == 0);
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {in->depth + 1, ray->pixel, j, in->magic};
        const rto_wf_ray r = test_ray(ray->pixel, in->depth + 1);
        rto_emit_ray(ctx, &r, &pl);
    }
}

static void flood_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    flood_shade(ctx, ray, payload);
}

static const rto_program flood_program = {
    RTO_PROGRAM_ABI_VERSION, "test-flood", "emits past the queue capacity", sizeof(test_payload), 2, NULL, 0, NULL,
    NULL, flood_raygen, flood_hit, flood_shade, NULL,
};

/* The serial queue rules, simulated: a queue is a list of (pixel, j) in emit order, cut at the capacity. */
typedef struct sim_queue {
    uint32_t *pixel, *j, *depth_payload;
    size_t n, emitted, refused, hits;
} sim_queue;

static void sim_push(sim_queue *q, size_t cap, uint32_t pixel, uint32_t j, uint8_t *dropped_mask)
{
    q->emitted++;
    if (q->n < cap) {
        q->pixel[q->n] = pixel;
        q->j[q->n] = j;
        q->n++;
    } else {
        dropped_mask[pixel] |= RTO_PIXEL_DROPPED;
    }
}

static void check_flood(const rto_frame *f, uint32_t w, uint32_t h)
{
    const size_t wh = (size_t)w * h, cap = 2 * wh;
    frame_basics(f, w, h);
    assert_int_equal(f->max_depth, 2);
    sim_queue q[3];
    uint8_t *mask = calloc(wh, 1);
    assert_non_null(mask);
    for (int d = 0; d < 3; d++) {
        memset(&q[d], 0, sizeof q[d]);
        q[d].pixel = calloc(cap, sizeof(uint32_t));
        q[d].j = calloc(cap, sizeof(uint32_t));
        assert_true(q[d].pixel && q[d].j);
    }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint32_t p = y * w + x;
            for (uint32_t j = 0; j < flood_primary(x, y); j++)
                sim_push(&q[0], cap, p, j, mask);
            q[0].refused += x == 0;
        }
    for (int d = 0; d < 2; d++)
        for (size_t i = 0; i < q[d].n; i++) {
            q[d].hits += q[d].pixel[i] % 2 == 0;
            for (uint32_t j = 0; j < 2; j++)
                sim_push(&q[d + 1], cap, q[d].pixel[i], j, mask);
            q[d + 1].refused += q[d].pixel[i] % 7 == 0;
        }
    for (int d = 0; d < 3; d++) {
        const rto_frame_counters *c = &f->counters[d];
        print_message("flood %ux%u queue %d: emitted %u (expected %zu), queued %u, dropped %u (expected %zu), refused "
                      "%u (expected %zu)\n", w, h, d, c->emitted, q[d].emitted, c->queued, c->dropped,
                      q[d].emitted - q[d].n, c->refused, q[d].refused);
        assert_int_equal(c->emitted, q[d].emitted);
        assert_int_equal(c->queued, q[d].n);
        assert_int_equal(c->dropped, q[d].emitted - q[d].n);
        assert_int_equal(c->refused, q[d].refused);
        if (d < 2) {
            assert_int_equal(c->hits, q[d].hits);
            assert_int_equal(c->misses, q[d].n - q[d].hits);
            assert_int_equal(c->shaded, q[d].n);
        }
        assert_int_equal(c->accumulates, 0);
        assert_int_equal(c->conflicts, 0);
        /* The kept queue in serial order: pixel, kind, payloadSlot = pixel + j W H, and the payload as emitted. */
        const rto_frame_queue *fq = &f->queues[d];
        assert_int_equal(fq->count, q[d].n);
        assert_non_null(fq->rays);
        assert_non_null(fq->payloads);
        for (size_t i = 0; i < q[d].n; i++) {
            const rto_wf_ray *r = &fq->rays[i];
            const uint32_t *pl = &fq->payloads[i * (sizeof(test_payload) / 4)];
            if (r->pixel != q[d].pixel[i] || r->payload_slot != q[d].pixel[i] + q[d].j[i] * (uint32_t)wh ||
                r->kind != (uint32_t)d || pl[0] != (uint32_t)d || pl[1] != q[d].pixel[i] || pl[2] != q[d].j[i] ||
                pl[3] != TEST_MAGIC)
                fail_msg("flood queue %d ray %zu: pixel %u slot %u kind %u payload %u %u %u %x; expected pixel %u "
                         "slot %u kind %d payload %d %u %u %x", d, i, r->pixel, r->payload_slot, r->kind, pl[0],
                         pl[1], pl[2], pl[3], q[d].pixel[i], q[d].pixel[i] + q[d].j[i] * (uint32_t)wh, d, d,
                         q[d].pixel[i], q[d].j[i], TEST_MAGIC);
        }
    }
    size_t marked = 0;
    for (size_t p = 0; p < wh; p++) {
        if (f->not_comparable[p] != mask[p])
            fail_msg("flood: pixel %zu not_comparable 0x%x, expected 0x%x", p, f->not_comparable[p], mask[p]);
        marked += mask[p] != 0;
    }
    assert_true(marked > 0);
    assert_true(f->invalid_calls == 0);
    for (int d = 0; d < 3; d++) {
        free(q[d].pixel);
        free(q[d].j);
    }
    free(mask);
}

void test_capacity_drops(void **state)
{
    (void)state;
    const uint32_t sizes[2][2] = {{8, 5}, {13, 7}};
    for (int k = 0; k < 2; k++) {
        rto_frame_desc d;
        memset(&d, 0, sizeof d);
        d.program = &flood_program;
        d.scene_kind = RTO_FRAME_SCENE_STAGE2;
        d.width = sizes[k][0];
        d.height = sizes[k][1];
        d.keep = RTO_FRAME_KEEP_ALL;
        rto_frame *f = render(&d);
        /* By hand for 8x5 (W H = 40, capacity 80): queue 0 holds 40 + 16 = 56 rays (two for the 5 pixels x == 0 and
         * the 11 with (x + y) % 3 == 0, x > 0), 5 refused; queue 1: 112 emits, 80 kept, 32 dropped, 7 refused (the
         * rays of pixels 0, 7, .., 35: pixel 0 has two); queue 2: 160 emits, 80 kept, 80 dropped. */
        if (k == 0) {
            assert_int_equal(f->counters[0].emitted, 56);
            assert_int_equal(f->counters[0].refused, 5);
            assert_int_equal(f->counters[1].emitted, 112);
            assert_int_equal(f->counters[1].dropped, 32);
            assert_int_equal(f->counters[1].refused, 7);
            assert_int_equal(f->counters[2].emitted, 160);
            assert_int_equal(f->counters[2].dropped, 80);
        }
        check_flood(f, d.width, d.height);
        rto_frame_destroy(f);
    }
}

/* Conflicts: raygen emits 2 rays for pixels p % 5 == 0, else 1; each shading accumulates (1, 2, 4) * (j + 1) into
 * its pixel; a ray of a pixel p % 7 == 3 accumulates twice into its pixel (one ray: not a conflict); the first ray
 * of a pixel p % 11 == 4 also accumulates (8, 0, 0) into pixel p + 1 (a second ray there: a conflict). */
static void conflict_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const uint32_t n = p % 5 == 0 ? 2u : 1u;
    for (uint32_t j = 0; j < n; j++) {
        const test_payload pl = {0, p, j, TEST_MAGIC};
        const rto_wf_ray r = test_ray(p, 0);
        rto_emit_primary_ray(ctx, &r, &pl);
    }
}

static void conflict_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const test_payload *in = payload;
    const uint32_t p = ray->pixel, wh = ctx->env->width * ctx->env->height;
    const float s = (float)(in->j + 1);
    const float rgb[3] = {1.0f * s, 2.0f * s, 4.0f * s};
    rto_accumulate(ctx, p, rgb);
    if (p % 7 == 3)
        rto_accumulate(ctx, p, rgb);
    if (p % 11 == 4 && in->j == 0 && p + 1 < wh) {
        const float other[3] = {8.0f, 0.0f, 0.0f};
        rto_accumulate(ctx, p + 1, other);
    }
}

static void conflict_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    conflict_shade(ctx, ray, payload);
}

static const rto_program conflict_program = {
    RTO_PROGRAM_ABI_VERSION, "test-conflict", "accumulates from two rays into one pixel", sizeof(test_payload), 1,
    NULL, 0, NULL, NULL, conflict_raygen, conflict_hit, conflict_shade, NULL,
};

static void check_conflicts(const rto_frame *f, uint32_t w, uint32_t h)
{
    const uint32_t wh = w * h;
    frame_basics(f, w, h);
    double *acc = calloc(3 * (size_t)wh, sizeof *acc);
    uint32_t *rays_in = calloc(wh, sizeof *rays_in); /* distinct rays accumulating into each pixel */
    assert_true(acc && rays_in);
    uint32_t calls = 0, emitted = 0;
    for (uint32_t p = 0; p < wh; p++) {
        const uint32_t n = p % 5 == 0 ? 2u : 1u;
        emitted += n;
        for (uint32_t j = 0; j < n; j++) {
            const double s = j + 1.0;
            const uint32_t times = p % 7 == 3 ? 2u : 1u;
            for (int c = 0; c < 3; c++)
                acc[3 * p + c] += times * s * (c == 0 ? 1.0 : c == 1 ? 2.0 : 4.0);
            calls += times;
            rays_in[p]++;
            if (p % 11 == 4 && j == 0 && p + 1 < wh) {
                acc[3 * (p + 1)] += 8.0;
                calls++;
                rays_in[p + 1]++;
            }
        }
    }
    uint32_t conflicts = 0;
    for (uint32_t p = 0; p < wh; p++) {
        const uint8_t want = rays_in[p] >= 2 ? RTO_PIXEL_CONFLICT : 0;
        conflicts += want != 0;
        if (f->not_comparable[p] != want)
            fail_msg("conflict %ux%u: pixel %u not_comparable 0x%x, expected 0x%x (%u rays)", w, h, p,
                     f->not_comparable[p], want, rays_in[p]);
        for (int c = 0; c < 3; c++)
            if ((double)f->accum[4 * (size_t)p + (size_t)c] != acc[3 * p + c])
                fail_msg("conflict %ux%u: pixel %u accum[%d] %g, expected %g", w, h, p, c,
                         (double)f->accum[4 * (size_t)p + (size_t)c], acc[3 * p + c]);
        assert_true(f->accum[4 * (size_t)p + 3] == 1.0f);
    }
    const rto_frame_counters *c0 = &f->counters[0];
    print_message("conflict %ux%u: %u accumulates, %u conflicts (expected %u, %u)\n", w, h, c0->accumulates,
                  c0->conflicts, calls, conflicts);
    assert_int_equal(c0->emitted, emitted);
    assert_int_equal(c0->accumulates, calls);
    assert_int_equal(c0->conflicts, conflicts);
    assert_true(conflicts > 0);
    assert_int_equal(c0->dropped, 0);
    assert_true(f->invalid_calls == 0);
    free(acc);
    free(rays_in);
}

void test_conflicts(void **state)
{
    (void)state;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = &conflict_program;
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.width = 17;
    d.height = 9;
    d.keep = RTO_FRAME_KEEP_ALL;
    rto_frame *f = render(&d);
    check_conflicts(f, d.width, d.height);
    rto_frame_destroy(f);
}

/* Calls the frame must refuse: emit_ray from raygen, emit_primary_ray from shading, accumulate past the image. */
static void misuse_raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const uint32_t p = y * ctx->env->width + x;
    const rto_wf_ray r = test_ray(p, 0);
    const test_payload pl = {0, p, 0, TEST_MAGIC};
    rto_emit_primary_ray(ctx, &r, &pl);
    if (p == 0)
        rto_emit_ray(ctx, &r, &pl);
}

static void misuse_shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    const float one[3] = {1.0f, 1.0f, 1.0f};
    rto_accumulate(ctx, ray->pixel, one);
    if (ray->pixel == 1)
        rto_accumulate(ctx, ctx->env->width * ctx->env->height, one);
    if (ray->pixel == 2)
        rto_emit_primary_ray(ctx, ray, payload);
}

static void misuse_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)hit;
    misuse_shade(ctx, ray, payload);
}

static const rto_program misuse_program = {
    RTO_PROGRAM_ABI_VERSION, "test-misuse", "calls out of place", sizeof(test_payload), 1, NULL, 0, NULL, NULL,
    misuse_raygen, misuse_hit, misuse_shade, NULL,
};

void test_invalid_calls(void **state)
{
    (void)state;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = &misuse_program;
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.width = 5;
    d.height = 3;
    d.keep = RTO_FRAME_KEEP_ALL;
    rto_frame *f = render(&d);
    frame_basics(f, 5, 3);
    /* Three misplaced calls, none of which stored a ray or touched the accum. */
    assert_true(f->invalid_calls == 3);
    assert_int_equal(f->counters[0].emitted, 15);
    assert_int_equal(f->counters[1].emitted, 0);
    for (uint32_t p = 0; p < 15; p++)
        for (int c = 0; c < 3; c++)
            assert_true(f->accum[4 * p + (uint32_t)c] == 1.0f);
    rto_frame_destroy(f);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Thread counts: the same bytes                                                                                     */

/* `how` names the two runs compared ("1 and 3 threads"). */
static void same_bytes(const void *a, const void *b, size_t n, const char *what, const char *how)
{
    if (n == 0)
        return;
    if (!a || !b)
        fail_msg("%s: kept in the first run %s, in the second %s (%s)", what, a ? "yes" : "no", b ? "yes" : "no", how);
    if (memcmp(a, b, n)) {
        const uint8_t *x = a, *y = b;
        size_t i = 0;
        while (x[i] == y[i])
            i++;
        fail_msg("%s differs between %s at byte %zu of %zu", what, how, i, n);
    }
}

static void compare_frames(const rto_frame *a, const rto_frame *b, const char *threads)
{
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    assert_int_equal(a->max_depth, b->max_depth);
    assert_int_equal(a->payload_size, b->payload_size);
    assert_int_equal(a->keep, b->keep);
    const size_t wh = (size_t)a->width * a->height, rows = a->max_depth + 1;
    same_bytes(&a->camera_uniforms, &b->camera_uniforms, sizeof a->camera_uniforms, "camera uniforms", threads);
    same_bytes(a->counters, b->counters, rows * sizeof *a->counters, "frame counters", threads);
    same_bytes(a->indirect_args, b->indirect_args, rows * sizeof *a->indirect_args, "indirect args", threads);
    for (size_t d = 0; d < rows; d++) {
        const rto_frame_queue *qa = &a->queues[d], *qb = &b->queues[d];
        char what[64];
        assert_int_equal(qa->count, qb->count);
        snprintf(what, sizeof what, "queue %zu rays", d);
        same_bytes(qa->rays, qb->rays, qa->rays ? qa->count * sizeof *qa->rays : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu payloads", d);
        same_bytes(qa->payloads, qb->payloads, qa->payloads ? qa->count * a->payload_size : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu hits", d);
        same_bytes(qa->hits, qb->hits, qa->hits ? qa->count * sizeof *qa->hits : 0, what, threads);
        snprintf(what, sizeof what, "queue %zu trace counters", d);
        same_bytes(qa->trace_counters, qb->trace_counters,
                   qa->trace_counters ? qa->count * sizeof *qa->trace_counters : 0, what, threads);
    }
    same_bytes(a->accum, b->accum, a->accum ? 4 * wh * sizeof(float) : 0, "accum", threads);
    same_bytes(a->image, b->image, 4 * wh, "image", threads);
    same_bytes(a->not_comparable, b->not_comparable, wh, "not_comparable", threads);
    assert_true(a->invalid_calls == b->invalid_calls);
}

static void threads_case(rto_frame_desc *d, const char *label)
{
    d->threads = 1;
    d->keep = RTO_FRAME_KEEP_ALL;
    rto_frame *one = render(d);
    const uint32_t counts[3] = {2, 3, 7};
    for (int k = 0; k < 3; k++) {
        d->threads = counts[k];
        rto_frame *f = render(d);
        char how[48];
        snprintf(how, sizeof how, "1 and %u threads", counts[k]);
        compare_frames(one, f, how);
        rto_frame_destroy(f);
    }
    uint64_t rays = 0;
    for (uint32_t q = 0; q <= one->max_depth; q++)
        rays += one->counters[q].queued;
    print_message("%s: threads 1, 2, 3, 7 give the same bytes (%u queues, %llu rays in all)\n", label,
                  one->max_depth + 1, (unsigned long long)rays);
    rto_frame_destroy(one);
}

/* Chunk sizes: a pass run in chunks of 1, 5 or 64 items (each chunk's logs applied before the next) gives the bytes
 * of the same pass run whole, drops at capacity and conflicts included. */
static void chunks_case(rto_frame_desc *d, const char *label)
{
    const size_t saved = rto__frame_chunk;
    d->threads = 3;
    d->keep = RTO_FRAME_KEEP_ALL;
    rto__frame_chunk = SIZE_MAX;
    rto_frame *whole = render(d);
    const size_t chunks[3] = {1, 5, 64};
    for (int k = 0; k < 3; k++) {
        rto__frame_chunk = chunks[k];
        rto_frame *f = render(d);
        char how[64];
        snprintf(how, sizeof how, "one chunk and chunks of %zu", chunks[k]);
        compare_frames(whole, f, how);
        rto_frame_destroy(f);
    }
    rto__frame_chunk = saved;
    print_message("%s: chunks of 1, 5, 64 give the bytes of one chunk\n", label);
    rto_frame_destroy(whole);
}

/* The frames both sweeps below run, each at its own size (W, H in sizes): sun-shadow on a mesh scene (primary and
 * shadow rays, two bounces), normals on stage2, and the flood and conflict programs (drops and conflicts must be the
 * same pixels whatever the threads or chunks). */
static void frame_cases(void (*run)(rto_frame_desc *, const char *), const uint32_t sizes[4][2])
{
    rto_scene *s = tu_load("sphere:3");
    rto_accel *acc = build(s);
    char label[64];
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = builtin("sun-shadow");
    d.accel = acc;
    d.width = sizes[0][0];
    d.height = sizes[0][1];
    d.max_depth = 2;
    snprintf(label, sizeof label, "sun-shadow on sphere:3 %ux%u", d.width, d.height);
    run(&d, label);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
    const rto_program *const programs[3] = {builtin("normals"), &flood_program, &conflict_program};
    for (int k = 0; k < 3; k++) {
        memset(&d, 0, sizeof d);
        d.program = programs[k];
        d.scene_kind = RTO_FRAME_SCENE_STAGE2;
        d.width = sizes[k + 1][0];
        d.height = sizes[k + 1][1];
        snprintf(label, sizeof label, "%s on stage2 %ux%u", programs[k]->name, d.width, d.height);
        run(&d, label);
    }
}

void test_threads_identical(void **state)
{
    (void)state;
    static const uint32_t sizes[4][2] = {{67, 41}, {61, 37}, {23, 11}, {31, 13}};
    frame_cases(threads_case, sizes);
}

void test_chunks_identical(void **state)
{
    (void)state;
    static const uint32_t sizes[4][2] = {{29, 17}, {19, 11}, {13, 7}, {13, 7}};
    frame_cases(chunks_case, sizes);
    /* and against the serial simulations: queues cut at capacity, conflicts per pass */
    const size_t saved = rto__frame_chunk;
    rto__frame_chunk = 5;
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.scene_kind = RTO_FRAME_SCENE_STAGE2;
    d.keep = RTO_FRAME_KEEP_ALL;
    d.width = 13;
    d.height = 7;
    d.program = &flood_program;
    rto_frame *f = render(&d);
    check_flood(f, d.width, d.height);
    rto_frame_destroy(f);
    d.program = &conflict_program;
    d.width = 17;
    d.height = 9;
    f = render(&d);
    check_conflicts(f, d.width, d.height);
    rto_frame_destroy(f);
    rto__frame_chunk = saved;
}
