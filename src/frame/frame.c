/* The wavefront frame (DESIGN.md §7): GENERATE -> PREP -> (TRACE -> SHADE -> PREP) x maxDepth -> RESOLVE, with the
 * seeds' ping-pong ray queues of capacity 2 W H, the emit counters a GPU bumps with atomics, PREP's indirect
 * dispatch arguments, the accum buffer, drops at capacity and accumulate conflicts.
 *
 * Determinism with threads: GENERATE and SHADE split their items (pixels, rays) into contiguous ranges, one per
 * worker, and each worker only logs what its program invocations emit and accumulate. The logs are then applied by
 * the calling thread in worker order, which is item order, so queues, accum sums and counters come out exactly as a
 * serial run makes them, whatever the thread count. */
#include "frame_internal.h"
#include "trace/trace_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Most pixels of a frame: 2^26 (an 8K x 8K image); queues then hold up to 2^27 rays. */
#define FRAME_MAX_PIXELS (UINT64_C(1) << 26)

/* Items (pixels of GENERATE, rays of TRACE + SHADE) per chunk. A pass runs its items chunk by chunk, in order, each
 * chunk's logs applied before the next: the same queues, sums and counters as one chunk, while hit records (unless
 * kept) and the logs only ever hold a chunk's worth. */
#define FRAME_CHUNK ((size_t)1 << 18)
size_t rto__frame_chunk = FRAME_CHUNK;

/* Bytes per pixel the frame holds throughout: accum (f32 RGBA), image (RGBA8), the not-comparable mask, and the
 * conflict detector's item and pass stamps. */
#define FRAME_PIXEL_BYTES (4 * sizeof(float) + 4 + 1 + 2 * sizeof(uint32_t))

static const char *const stage_names[RTO_FRAME_STAGE_COUNT] = {"generate", "prep", "trace", "shade", "resolve"};

const char *rto_frame_stage_name(rto_frame_stage stage)
{
    return (unsigned)stage < RTO_FRAME_STAGE_COUNT ? stage_names[stage] : NULL;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Per-worker logs                                                                                                  */

typedef struct acc_entry {
    uint32_t pixel;
    uint32_t invocation; /* the item (pixel or ray index) whose invocation accumulated: conflicts are per item */
    float rgb[3];
} acc_entry;

typedef struct worker {
    rto_frame_ctx pub; /* first: the program's ctx is a pointer to this */
    struct run *run;
    /* the invocation being run */
    int shading;          /* 0: raygen (emit_primary_ray allowed), 1: closest hit / miss (emit_ray allowed) */
    uint32_t pixel;       /* the pixel of the invocation */
    uint32_t item;        /* its item index */
    uint32_t emits;       /* emits made by this invocation */
    /* logs, applied in worker order */
    rto_wf_ray *rays;
    uint32_t *payloads; /* payload_words per logged ray */
    size_t nrays, caprays;
    acc_entry *acc;
    size_t nacc, capacc;
    uint64_t refused, invalid, hits, misses, shaded;
    int oom;
} worker;

typedef struct run {
    const rto_frame_desc *desc;
    const rto_program *prog;
    rto_frame *frame;
    rto_frame_env env;
    rto_frame_api api;
    uint32_t payload_words;
    uint32_t nworkers;
    worker *workers;
    /* the chunk being traced and shaded: items item_base .. of the queue */
    size_t item_base;
    const rto_wf_ray *rays;
    const uint32_t *payloads;
    rto_hit_record *hits;
    rto_trace_counters *trace_counters;
    /* conflict detection: the last item that accumulated into each pixel, stamped with the pass */
    uint32_t *acc_item;
    uint32_t *acc_pass;
    uint32_t pass;
    rto_status oom;
} run;

/* Grows *p (cap elements of size bytes) to hold need elements, doubling; large buffers are re-allocated as huge
 * pages (rto__alloc_large) rather than realloc'ed, which would lose the advice. */
static int grow(void **p, size_t *cap, size_t used, size_t need, size_t size)
{
    if (need <= *cap)
        return 1;
    size_t c = *cap ? *cap : 256;
    while (c < need)
        c *= 2;
    void *q = rto__alloc_large(c, size);
    if (!q)
        return 0;
    if (used)
        memcpy(q, *p, used * size);
    free(*p);
    *p = q;
    *cap = c;
    return 1;
}

/* Room in a worker's logs for `more` emits and accumulates (what one range makes in the common case). */
static int reserve(worker *w, size_t more)
{
    const run *r = w->run;
    size_t cap = w->caprays;
    if (!grow((void **)&w->rays, &w->caprays, w->nrays, w->nrays + more, sizeof *w->rays) ||
        (r->payload_words &&
         !grow((void **)&w->payloads, &cap, w->nrays, w->nrays + more, (size_t)r->payload_words * sizeof(uint32_t))) ||
        !grow((void **)&w->acc, &w->capacc, w->nacc, w->nacc + more, sizeof *w->acc)) {
        w->oom = 1;
        return 0;
    }
    return 1;
}

static int log_emit(worker *w, const rto_wf_ray *ray, const void *payload)
{
    const run *r = w->run;
    const rto_frame *f = r->frame;
    if (w->emits >= RTO_FRAME_EMITS_PER_INVOCATION) {
        w->refused++;
        return 0;
    }
    /* the payload log always has the capacity of the ray log (reserve grows both from the same count) */
    if (w->nrays == w->caprays && !reserve(w, w->caprays ? w->caprays : 256))
        return 0;
    rto_wf_ray e = *ray;
    e.pixel = w->pixel;
    e.payload_slot = w->pixel + w->emits * f->width * f->height;
    w->rays[w->nrays] = e;
    if (r->payload_words) {
        uint32_t *dst = w->payloads + w->nrays * r->payload_words;
        if (payload)
            memcpy(dst, payload, (size_t)r->payload_words * sizeof(uint32_t));
        else
            memset(dst, 0, (size_t)r->payload_words * sizeof(uint32_t));
    }
    w->nrays++;
    w->emits++;
    /* Whether the ray is stored or dropped at capacity is only known when the logs are applied in order; a
     * program that needs to know (none of the built-in ones does) sees 1 here and the drop in the counters. */
    return 1;
}

static int api_emit_primary(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    worker *w = (worker *)ctx;
    if (w->shading || !ray) {
        w->invalid++;
        return 0;
    }
    return log_emit(w, ray, payload);
}

static int api_emit_ray(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    worker *w = (worker *)ctx;
    if (!w->shading || !ray) {
        w->invalid++;
        return 0;
    }
    return log_emit(w, ray, payload);
}

static void api_accumulate(rto_frame_ctx *ctx, uint32_t pixel, const float rgb[3])
{
    worker *w = (worker *)ctx;
    const rto_frame *f = w->run->frame;
    if (!rgb || pixel >= (uint64_t)f->width * f->height) {
        w->invalid++;
        return;
    }
    if (w->nacc == w->capacc && !reserve(w, w->capacc ? w->capacc : 256))
        return;
    acc_entry *e = &w->acc[w->nacc++];
    e->pixel = pixel;
    e->invocation = w->item;
    memcpy(e->rgb, rgb, sizeof e->rgb);
}

static void api_surface(const rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, rto_surface *out)
{
    const worker *w = (const worker *)ctx;
    if (w->run->env.scene) {
        rto__surface_mesh(&w->run->env, ray, hit, out);
        return;
    }
    /* stage2: the seed's normal, no texture coordinates or materials */
    memset(out, 0, sizeof *out);
    for (int c = 0; c < 3; c++)
        out->position[c] = ray->origin[c] + hit->t * ray->dir[c];
    rto__stage2_normal(ray, hit, out->normal);
    memcpy(out->geometric_normal, out->normal, sizeof out->normal);
    for (int c = 0; c < 4; c++)
        out->base_color[c] = 1.0f;
    out->material = -1;
}

static void api_sample_texture(const rto_frame_ctx *ctx, int32_t texture, const float uv[2], float rgba[4])
{
    const worker *w = (const worker *)ctx;
    rto__texture_sample(w->run->env.scene, texture, uv, rgba);
}

static rto_wf_ray api_camera_ray(const rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    rto_wf_ray ray = rto_camera_ray(ctx->env->camera, ctx->env->width, ctx->env->height, x, y);
    ray.kind = RTO_RAY_KIND_PRIMARY;
    return ray;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Passes                                                                                                           */

static void reset_worker(worker *w)
{
    w->nrays = 0;
    w->nacc = 0;
    w->refused = w->invalid = w->hits = w->misses = w->shaded = 0;
}

static void generate_range(void *ctx, uint32_t wi, size_t begin, size_t end)
{
    run *r = ctx;
    worker *w = &r->workers[wi];
    const uint32_t width = r->frame->width;
    w->shading = 0;
    reserve(w, end - begin);
    for (size_t i = begin; i < end && !w->oom; i++) {
        const size_t p = r->item_base + i;
        w->pixel = w->item = (uint32_t)p;
        w->emits = 0;
        r->prog->raygen(&w->pub, (uint32_t)(p % width), (uint32_t)(p / width));
    }
}

static void shade_range(void *ctx, uint32_t wi, size_t begin, size_t end)
{
    run *r = ctx;
    worker *w = &r->workers[wi];
    w->shading = 1;
    reserve(w, end - begin);
    for (size_t i = begin; i < end && !w->oom; i++) {
        const rto_wf_ray *ray = &r->rays[i];
        const rto_hit_record *hit = &r->hits[i];
        const void *payload = r->payload_words ? (const void *)(r->payloads + i * r->payload_words) : NULL;
        uint32_t copy[RTO_PAYLOAD_MAX / 4];
        if (payload)
            memcpy(copy, payload, (size_t)r->payload_words * sizeof(uint32_t));
        w->pixel = ray->pixel;
        w->item = (uint32_t)(r->item_base + i);
        w->emits = 0;
        if (hit->miss_flag) {
            w->misses++;
            if (r->prog->miss) {
                w->shaded++;
                r->prog->miss(&w->pub, ray, payload ? copy : NULL);
            }
        } else {
            w->hits++;
            if (!(ray->flags & RTO_RAY_FLAG_SKIP_CLOSEST_HIT) && r->prog->closest_hit) {
                w->shaded++;
                r->prog->closest_hit(&w->pub, ray, hit, payload ? copy : NULL);
            }
        }
    }
}

/* Room in queue q for `more` rays past its count. The queue is allocated once at its capacity, as a GPU allocates
 * it: a large block is mapped, not touched, so only the rays stored take memory (pages on first write). */
static int grow_queue(rto_frame_queue *q, size_t *cap, size_t more, uint64_t capacity, uint32_t payload_words)
{
    if (q->count + more <= *cap)
        return 1;
    q->rays = rto__alloc_large(capacity, sizeof *q->rays);
    q->payloads = payload_words ? rto__alloc_large(capacity * payload_words, sizeof *q->payloads) : NULL;
    if (!q->rays || (payload_words && !q->payloads))
        return 0;
    *cap = (size_t)capacity;
    return 1;
}

/* Applies the workers' logs of one chunk in worker (= item) order: emits appended to queue q, accumulates into the
 * accum buffer. The chunks of a pass share its pass stamp (conflicts are per pass). */
static rto_status apply_logs(run *r, uint32_t q, size_t *qcap, uint32_t row, rto_msg *msg)
{
    rto_frame *f = r->frame;
    rto_frame_queue *dst = &f->queues[q];
    rto_frame_counters *cq = &f->counters[q], *cr = &f->counters[row];
    size_t total = 0;
    for (uint32_t i = 0; i < r->nworkers; i++) {
        if (r->workers[i].oom)
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the logs of a %s pass",
                            row == q ? "GENERATE" : "SHADE");
        total += r->workers[i].nrays;
    }
    const size_t room = (size_t)f->capacity - dst->count;
    const size_t store = total < room ? total : room;
    if (store && !grow_queue(dst, qcap, store, f->capacity, r->payload_words))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu rays of queue %u", dst->count + store, q);
    const size_t pixels = (size_t)f->width * f->height;
    for (uint32_t i = 0; i < r->nworkers; i++) {
        worker *w = &r->workers[i];
        for (size_t k = 0; k < w->nrays; k++) {
            cq->emitted++;
            if (dst->count < f->capacity) {
                dst->rays[dst->count] = w->rays[k];
                if (r->payload_words)
                    memcpy(dst->payloads + dst->count * r->payload_words, w->payloads + k * r->payload_words,
                           r->payload_words * sizeof(uint32_t));
                dst->count++;
            } else {
                cq->dropped++;
                f->not_comparable[w->rays[k].pixel % pixels] |= RTO_PIXEL_DROPPED;
            }
        }
        cq->refused += (uint32_t)w->refused;
        f->invalid_calls += w->invalid;
        cr->hits += (uint32_t)w->hits;
        cr->misses += (uint32_t)w->misses;
        cr->shaded += (uint32_t)w->shaded;
        for (size_t k = 0; k < w->nacc; k++) {
            const acc_entry *e = &w->acc[k];
            float *a = f->accum + 4 * (size_t)e->pixel;
            for (int c = 0; c < 3; c++)
                a[c] = a[c] + e->rgb[c];
            cr->accumulates++;
            if (r->acc_pass[e->pixel] == r->pass && r->acc_item[e->pixel] != e->invocation) {
                if (!(f->not_comparable[e->pixel] & RTO_PIXEL_CONFLICT))
                    cr->conflicts++;
                f->not_comparable[e->pixel] |= RTO_PIXEL_CONFLICT;
            }
            r->acc_pass[e->pixel] = r->pass;
            r->acc_item[e->pixel] = e->invocation;
        }
        reset_worker(w);
    }
    cq->queued = (uint32_t)dst->count;
    return RTO_OK;
}

static void trace_stage2_range(void *ctx, uint32_t wi, size_t begin, size_t end)
{
    (void)wi;
    run *r = ctx;
    rto_stage2_trace(r->rays + begin, end - begin, r->hits + begin);
    /* The seed's traceScene tests its four primitives without a tree: no traversal to count. */
    if (r->trace_counters)
        memset(r->trace_counters + begin, 0, (end - begin) * sizeof *r->trace_counters);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void free_queue(rto_frame_queue *q)
{
    free(q->rays);
    free(q->payloads);
    free(q->hits);
    free(q->trace_counters);
    memset(q, 0, sizeof *q);
}

void rto_frame_destroy(rto_frame *f)
{
    if (!f)
        return;
    if (f->queues)
        for (uint32_t d = 0; d <= f->max_depth; d++)
            free_queue(&f->queues[d]);
    free(f->queues);
    free(f->counters);
    free(f->indirect_args);
    free(f->accum);
    free(f->image);
    free(f->not_comparable);
    free(f);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Parameters                                                                                                       */

static rto_status resolve_params(const rto_frame_desc *desc, const rto_program *p, rto_frame *f, rto_msg *msg)
{
    f->param_count = p->param_count;
    for (uint32_t i = 0; i < p->param_count; i++) {
        rto_param_value *v = &f->params[i];
        snprintf(v->name, sizeof v->name, "%s", p->params[i].name);
        v->count = p->params[i].count;
        memcpy(v->value, p->params[i].value, sizeof v->value);
    }
    for (uint32_t k = 0; k < desc->param_count; k++) {
        const rto_param_value *o = &desc->params[k];
        uint32_t i = 0;
        while (i < p->param_count && strcmp(p->params[i].name, o->name))
            i++;
        if (i == p->param_count)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "program %s has no parameter '%s'", p->name, o->name);
        if (o->count != p->params[i].count)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "parameter %s of program %s takes %u value%s, not %u",
                            o->name, p->name, p->params[i].count, p->params[i].count == 1 ? "" : "s", o->count);
        for (uint32_t c = 0; c < o->count; c++)
            if (!isfinite(o->value[c]))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "parameter %s: value %u is not finite", o->name, c);
        memcpy(f->params[i].value, o->value, sizeof o->value);
    }
    return RTO_OK;
}

/* The stage2 scene's bounds (seed 002's traceScene): the ground slab spans x, z in [-10, 10], y in [-2, -1]; the
 * objects reach y = 1 and x = +-3.5. Only their largest magnitude matters (the ray offset). */
static const rto_aabb stage2_bounds = {{-10.0f, -2.0f, -10.0f}, {10.0f, 1.0f, 10.0f}};

/* ---------------------------------------------------------------------------------------------------------------- */
/* The frame                                                                                                        */

rto_status rto_frame_render(const rto_frame_desc *desc, rto_frame **out, rto_msg *msg)
{
    if (!desc || !out || !desc->program)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL frame description, program or output");
    *out = NULL;
    const rto_program *p = desc->program;
    rto_status s = rto_program_validate(p, msg);
    if (s)
        return s;
    const int stage2 = desc->scene_kind == RTO_FRAME_SCENE_STAGE2;
    if (!stage2 && (desc->scene_kind != RTO_FRAME_SCENE_MESH || !desc->accel))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "a mesh frame needs an accel (or scene kind stage2)");
    if (!desc->width || !desc->height || (uint64_t)desc->width * desc->height > FRAME_MAX_PIXELS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "image size %ux%u: need 1 .. %llu pixels", desc->width,
                        desc->height, (unsigned long long)FRAME_MAX_PIXELS);
    const uint32_t depth = desc->max_depth ? desc->max_depth : p->max_depth;
    if (depth > 64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "maxDepth %u: at most 64", depth);
    if (desc->keep & ~RTO_FRAME_KEEP_ALL)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown keep bits 0x%x", desc->keep & ~RTO_FRAME_KEEP_ALL);

    rto_frame *f = calloc(1, sizeof *f);
    if (!f)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for a frame");
    snprintf(f->program, sizeof f->program, "%s", p->name);
    f->width = desc->width;
    f->height = desc->height;
    f->max_depth = depth;
    f->payload_size = p->payload_size;
    f->keep = desc->keep;
    const size_t pixels = (size_t)f->width * f->height;
    f->capacity = 2 * (uint64_t)pixels;
    const rto_scene *scene = stage2 ? NULL : rto_accel_scene(desc->accel);
    const rto_aabb bounds = stage2 ? stage2_bounds : rto_scene_aabb(scene);
    if (desc->camera)
        f->camera = *desc->camera;
    else if (stage2)
        f->camera = rto_camera_default();
    else
        f->camera = rto_camera_frame(&bounds, (float)f->width / (float)f->height);
    if ((s = rto_camera_uniforms_make(&f->camera, f->width, f->height, &f->camera_uniforms, msg)) ||
        (s = resolve_params(desc, p, f, msg))) {
        rto_frame_destroy(f);
        return s;
    }
    f->counters = calloc(depth + 1, sizeof *f->counters);
    f->indirect_args = calloc(depth + 1, sizeof *f->indirect_args);
    f->queues = calloc(depth + 1, sizeof *f->queues);
    f->accum = rto__alloc_large(4 * pixels, sizeof *f->accum);
    f->image = rto__alloc_large(4 * pixels, 1);
    f->not_comparable = calloc(pixels, 1);

    run r;
    memset(&r, 0, sizeof r);
    r.desc = desc;
    r.prog = p;
    r.frame = f;
    r.payload_words = p->payload_size / 4;
    r.api = (rto_frame_api){RTO_PROGRAM_ABI_VERSION, api_emit_primary, api_emit_ray, api_accumulate, api_surface,
                            api_sample_texture, api_camera_ray};
    float params[RTO_PROGRAM_PARAMS_MAX][4];
    for (uint32_t i = 0; i < f->param_count; i++)
        memcpy(params[i], f->params[i].value, sizeof params[i]);
    r.env = (rto_frame_env){f->width, f->height, depth, &f->camera_uniforms, scene,
                            rto__ray_offset(&bounds, &f->camera_uniforms), (const float(*)[4])params, NULL};
    r.nworkers = rto__thread_count(desc->threads);
    r.workers = calloc(r.nworkers, sizeof *r.workers);
    r.acc_item = rto__alloc(pixels, sizeof *r.acc_item);
    r.acc_pass = calloc(pixels, sizeof *r.acc_pass);
    if (!f->counters || !f->indirect_args || !f->queues || !f->accum || !f->image || !f->not_comparable ||
        !r.workers || !r.acc_item || !r.acc_pass) {
        free(r.workers);
        free(r.acc_item);
        free(r.acc_pass);
        rto_frame_destroy(f);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for a %ux%u frame", f->width, f->height);
    }
    for (uint32_t i = 0; i < r.nworkers; i++) {
        r.workers[i].pub.api = &r.api;
        r.workers[i].pub.env = &r.env;
        r.workers[i].run = &r;
    }
    int inited = 0;
    if (p->init) {
        char why[256] = "";
        inited = p->init(&r.env, &r.env.user, why, sizeof why);
        if (!inited)
            s = rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s refuses the frame: %s", p->name,
                         why[0] ? why : "no reason given");
    }
    const double passes = 2.0 + 3.0 * depth;
    double done = 0;
#define PROGRESS()                                                                                                  \
    do {                                                                                                            \
        done += 1;                                                                                                  \
        if (desc->progress)                                                                                         \
            desc->progress(desc->progress_arg, done / passes);                                                      \
    } while (0)

    /* GENERATE: clear accum, run raygen per pixel */
    double t0 = now();
    const size_t chunk = rto__frame_chunk ? rto__frame_chunk : 1;
    size_t qcap = 0; /* rays the queue being filled has room for */
    if (!s) {
        for (size_t i = 0; i < pixels; i++) {
            f->accum[4 * i] = f->accum[4 * i + 1] = f->accum[4 * i + 2] = 0.0f;
            f->accum[4 * i + 3] = 1.0f;
        }
        r.pass++;
        for (size_t begin = 0; !s && begin < pixels; begin += chunk) {
            r.item_base = begin;
            rto__parallel_ranges(pixels - begin < chunk ? pixels - begin : chunk, r.nworkers, generate_range, &r);
            s = apply_logs(&r, 0, &qcap, 0, msg);
        }
        PROGRESS();
    }
    f->seconds[RTO_STAGE_GENERATE] += now() - t0;
    rto_hit_record *chunk_hits = NULL;
    for (uint32_t d = 0; !s && d <= depth; d++) {
        /* PREP d */
        t0 = now();
        rto_frame_queue *q = &f->queues[d];
        f->indirect_args[d][0] = (uint32_t)((q->count + 63) / 64);
        f->indirect_args[d][1] = 1;
        f->indirect_args[d][2] = 1;
        f->seconds[RTO_STAGE_PREP] += now() - t0;
        if (d == depth)
            break;
        /* TRACE d and SHADE d, chunk by chunk: hit records a bundle keeps are stored whole, others a chunk at a
         * time (a 4K frame never holds a queue's hit records) */
        f->counters[d].traced = (uint32_t)q->count;
        const int keep_hits = (desc->keep & RTO_FRAME_KEEP_HITS) != 0;
        const int keep_counters = (desc->keep & RTO_FRAME_KEEP_TRACE_COUNTERS) != 0;
        const size_t chunk_max = q->count < chunk ? q->count : chunk;
        if (keep_hits)
            q->hits = rto__alloc_large(q->count, sizeof *q->hits);
        else if (!chunk_hits)
            chunk_hits = rto__alloc_large(chunk < f->capacity ? chunk : (size_t)f->capacity, sizeof *chunk_hits);
        if (keep_counters)
            q->trace_counters = rto__alloc_large(q->count, sizeof *q->trace_counters);
        if ((keep_hits ? !q->hits : !chunk_hits) || (keep_counters && !q->trace_counters)) {
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu hit records", keep_hits ? q->count
                                                                                                  : chunk_max);
            break;
        }
        qcap = 0;
        r.pass++;
        for (size_t begin = 0; !s && begin < q->count; begin += chunk) {
            const size_t n = q->count - begin < chunk ? q->count - begin : chunk;
            t0 = now();
            r.item_base = begin;
            r.rays = q->rays + begin;
            r.payloads = r.payload_words ? q->payloads + begin * r.payload_words : NULL;
            r.hits = keep_hits ? q->hits + begin : chunk_hits;
            r.trace_counters = keep_counters ? q->trace_counters + begin : NULL;
            if (stage2) {
                rto__parallel_ranges(n, r.nworkers, trace_stage2_range, &r);
            } else {
                const rto_trace_desc td = {desc->threads};
                s = rto_trace(desc->accel, r.rays, n, &td, r.hits, r.trace_counters, msg);
                if (s) {
                    rto__fail(msg, s, "bounce %u: %s", d, msg ? msg->text : "tracing failed");
                    break;
                }
            }
            const double t1 = now();
            f->seconds[RTO_STAGE_TRACE] += t1 - t0;
            rto__parallel_ranges(n, r.nworkers, shade_range, &r);
            s = apply_logs(&r, d + 1, &qcap, d, msg);
            f->seconds[RTO_STAGE_SHADE] += now() - t1;
        }
        PROGRESS();
        PROGRESS();
        /* what the bundle does not keep goes now: a 4K frame never holds every bounce at once */
        if (!(desc->keep & RTO_FRAME_KEEP_RAYS)) {
            free(q->rays);
            q->rays = NULL;
        }
        if (!(desc->keep & RTO_FRAME_KEEP_PAYLOADS)) {
            free(q->payloads);
            q->payloads = NULL;
        }
        PROGRESS();
    }
    free(chunk_hits);
    if (!s && !(desc->keep & RTO_FRAME_KEEP_RAYS)) {
        free(f->queues[depth].rays);
        f->queues[depth].rays = NULL;
    }
    if (!s && !(desc->keep & RTO_FRAME_KEEP_PAYLOADS)) {
        free(f->queues[depth].payloads);
        f->queues[depth].payloads = NULL;
    }
    /* RESOLVE */
    t0 = now();
    if (!s) {
        for (size_t i = 0; i < pixels; i++) {
            float rgba[4];
            const float *hdr = f->accum + 4 * i;
            if (p->resolve)
                p->resolve(&r.env, (uint32_t)(i % f->width), (uint32_t)(i / f->width), hdr, rgba);
            else
                memcpy(rgba, hdr, sizeof rgba);
            for (int c = 0; c < 4; c++)
                f->image[4 * i + c] = rto__unorm8(rgba[c]);
        }
        PROGRESS();
    }
    f->seconds[RTO_STAGE_RESOLVE] += now() - t0;
#undef PROGRESS
    if (p->fini && inited)
        p->fini(r.env.user);
    for (uint32_t i = 0; i < r.nworkers; i++) {
        free(r.workers[i].rays);
        free(r.workers[i].payloads);
        free(r.workers[i].acc);
    }
    free(r.workers);
    free(r.acc_item);
    free(r.acc_pass);
    if (s) {
        rto_frame_destroy(f);
        return s;
    }
    *out = f;
    return RTO_OK;
}

/* Bytes per pixel the bundle writer may hold while encoding: the encoded file in a growing vector (up to twice its
 * size) and its copy, at most 16 bytes a pixel for accum.exr (zip-compressed floats, never larger than raw by more
 * than a header) and 4 for image.png. */
#define FRAME_EXR_PIXEL_BYTES (3 * 16)
#define FRAME_PNG_PIXEL_BYTES (3 * 4)

uint64_t rto_frame_memory_bound(const rto_frame_desc *desc)
{
    if (!desc || !desc->program || !desc->width || !desc->height)
        return 0;
    const uint64_t pixels = (uint64_t)desc->width * desc->height;
    const uint64_t depth = desc->max_depth ? desc->max_depth : desc->program->max_depth;
    if (pixels > FRAME_MAX_PIXELS || depth > 64 || desc->program->payload_size > RTO_PAYLOAD_MAX)
        return 0;
    const uint64_t cap = 2 * pixels, payload = desc->program->payload_size, k = desc->keep;
    const uint64_t chunk = rto__frame_chunk < cap ? (rto__frame_chunk ? rto__frame_chunk : 1) : cap;
    const uint64_t ray = sizeof(rto_wf_ray), hit = sizeof(rto_hit_record), tc = sizeof(rto_trace_counters);
    /* kept: every queue's rays and payloads (depth + 1 of them), every traced queue's hits and trace counters */
    const uint64_t kept = cap * ((depth + 1) * ((k & RTO_FRAME_KEEP_RAYS ? ray : 0) +
                                                (k & RTO_FRAME_KEEP_PAYLOADS ? payload : 0)) +
                                 depth * ((k & RTO_FRAME_KEEP_HITS ? hit : 0) +
                                          (k & RTO_FRAME_KEEP_TRACE_COUNTERS ? tc : 0)));
    /* rendering: the queue shaded and the queue filled, at capacity, where they are not kept; a chunk's hit records
     * (unless kept) and its logs: up to RTO_FRAME_EMITS_PER_INVOCATION rays and as many accumulates per item, the
     * logs doubling as they grow */
    const uint64_t in_flight = depth ? 2 * cap * ((k & RTO_FRAME_KEEP_RAYS ? 0 : ray) +
                                                  (k & RTO_FRAME_KEEP_PAYLOADS ? 0 : payload)) : 0;
    const uint64_t logs = 2 * chunk * RTO_FRAME_EMITS_PER_INVOCATION * (ray + payload + sizeof(acc_entry));
    const uint64_t rendering = in_flight + logs + (depth && !(k & RTO_FRAME_KEEP_HITS) ? chunk * hit : 0);
    /* writing: the encoded images */
    const uint64_t writing =
        pixels * ((k & RTO_FRAME_KEEP_ACCUM_EXR ? FRAME_EXR_PIXEL_BYTES : 0) + FRAME_PNG_PIXEL_BYTES);
    return pixels * FRAME_PIXEL_BYTES + kept + (rendering > writing ? rendering : writing);
}

uint8_t rto__unorm8(float x)
{
    if (!(x > 0.0f))
        return 0; /* NaN and <= 0 */
    if (x >= 1.0f)
        return 255;
    return (uint8_t)floorf(x * 255.0f + 0.5f);
}

/* The --stages names: one per kept buffer (the first KEEP_SINGLE, in bit order), then the sets. */
#define KEEP_SINGLE 6
static const struct {
    const char *name;
    uint32_t bit;
} keep_names[] = {{"rays", RTO_FRAME_KEEP_RAYS},
                 {"hits", RTO_FRAME_KEEP_HITS},
                 {"trace-counters", RTO_FRAME_KEEP_TRACE_COUNTERS},
                 {"payloads", RTO_FRAME_KEEP_PAYLOADS},
                 {"accum", RTO_FRAME_KEEP_ACCUM},
                 {"accum-exr", RTO_FRAME_KEEP_ACCUM_EXR},
                 {"lean", RTO_FRAME_KEEP_LEAN},
                 {"all", RTO_FRAME_KEEP_ALL},
                 {"none", 0}};

void rto__frame_keep_text(uint32_t keep, char *text, size_t cap)
{
    size_t len = 0;
    text[0] = '\0';
    for (int i = 0; i < KEEP_SINGLE; i++)
        if (keep & keep_names[i].bit)
            len += (size_t)snprintf(text + len, cap - len, "%s%s", len ? "," : "", keep_names[i].name);
    if (!len)
        snprintf(text, cap, "none");
}

int rto_frame_keep_parse(const char *list, uint32_t *keep, rto_msg *msg)
{
    const size_t count = sizeof keep_names / sizeof keep_names[0];
    if (!list || !keep) {
        rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL stage list");
        return 0;
    }
    uint32_t bits = 0;
    const char *p = list;
    for (;;) {
        const char *e = strchr(p, ',');
        const size_t len = e ? (size_t)(e - p) : strlen(p);
        size_t i = 0;
        while (i < count && (strlen(keep_names[i].name) != len || strncmp(keep_names[i].name, p, len)))
            i++;
        if (i == count) {
            rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                     "unknown stage '%.*s' (rays, hits, trace-counters, payloads, accum, accum-exr, lean, all, none)",
                     (int)len, p);
            return 0;
        }
        bits |= keep_names[i].bit;
        if (!e)
            break;
        p = e + 1;
    }
    *keep = bits;
    return 1;
}
