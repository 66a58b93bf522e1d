/* The acceleration-structure object: every tree of a scene built once (DESIGN.md §5), the one build pipeline the
 * command, the benchmark and the tracer share. Per stage:
 *   meshes     triangle boxes (their union: the mesh's bounds) -> BLAS keys -> radix sort -> leaf order -> Karras
 *   instances  world boxes (the mesh's bounds through objToWorld) -> TLAS keys of the non-empty ones -> radix sort
 *              -> sweep or Karras tree
 * The sorts are rto_fast_radix_sort's (run by a team): real keys are unique, so any correct sort gives the canonical
 * network's bytes (§4). The stages run on threads with static partitions (below; docs/bvh.md "Building"). An
 * instance of an empty BLAS has an empty world box and gets no key and no leaf; an empty mesh gets an empty BLAS
 * (§5). Building validates nothing beyond its inputs; rto_accel_check runs the tree validators. */
#include "bvh_internal.h"
#include "keys/keys_internal.h"
#include "sort/sort_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct rto_accel {
    const rto_scene *scene;
    rto_accel_tlas tlas;
    uint32_t blas_count;
    rto_accel_blas *blas;
    /* A reader's derived copy of the trees (rto__accel_derived): made once, on first use, under the lock. */
    pthread_mutex_t derived_lock;
    void *derived;
    void (*derived_free)(void *);
    uint64_t rays_traced; /* rto__accel_rays_traced */
};

/* The view structs hold const pointers for the reader; the accel owns and frees them. */
static void free_const(const void *p) { free((void *)(uintptr_t)p); }

void rto_accel_destroy(rto_accel *a)
{
    if (!a)
        return;
    free_const(a->tlas.instance_aabbs);
    free_const(a->tlas.keys);
    free_const(a->tlas.sorted_keys);
    free_const(a->tlas.sweep_nodes);
    free_const(a->tlas.karras_nodes);
    for (uint32_t m = 0; a->blas && m < a->blas_count; m++) {
        free_const(a->blas[m].sorted_keys);
        free_const(a->blas[m].order);
        free_const(a->blas[m].prim_aabbs);
        free_const(a->blas[m].nodes);
    }
    free(a->blas);
    if (a->derived_free)
        a->derived_free(a->derived);
    pthread_mutex_destroy(&a->derived_lock);
    free(a);
}

uint64_t rto__accel_rays_traced(const rto_accel *ca, uint64_t n)
{
    rto_accel *a = (rto_accel *)(uintptr_t)ca; /* a tally, not the trees */
    return __atomic_add_fetch(&a->rays_traced, n, __ATOMIC_RELAXED);
}

void *rto__accel_derived(const rto_accel *ca, void *(*make)(const rto_accel *), void (*release)(void *))
{
    rto_accel *a = (rto_accel *)(uintptr_t)ca; /* the copy is a cache: the accel's trees do not change */
    void *d = __atomic_load_n(&a->derived, __ATOMIC_ACQUIRE);
    if (d || !make)
        return d;
    pthread_mutex_lock(&a->derived_lock);
    d = a->derived;
    if (!d && !a->derived_free) { /* a failed make is not retried */
        d = make(a);
        a->derived_free = release;
        __atomic_store_n(&a->derived, d, __ATOMIC_RELEASE);
    }
    pthread_mutex_unlock(&a->derived_lock);
    return d;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The build: one team of threads for the whole accel (DESIGN.md §2: static partitions, bytes independent of the    */
/* thread count). Meshes of fewer than BIG_MESH triangles are built whole by one worker each,                        */
/* assigned before any work starts (largest first, each to the least loaded worker); bigger ones by the whole team,  */
/* one after the other, every stage split into static ranges: triangle boxes and keys, the radix sort, the leaf      */
/* order, the Karras subtrees. Then the TLAS: instance boxes in ranges, keys (worker 0), the team's sort, the tree.  */

#define BIG_MESH 16384u
#define SOLO UINT32_MAX
/* A level of the sweep TLAS is split between the team while it has this many nodes per worker. */
#define SWEEP_LEVEL_PER_WORKER 1024u

typedef struct blas_work {
    const rto_mesh *mesh;
    rto_accel_blas *b;
    size_t n;
    rto_aabb *boxes;
    uint64_t *keys, *sorted, *tmp;
    uint32_t *order;
    rto_bvh_node *nodes;
    rto__karras k;
    rto_status status; /* RTO_ERR_INVALID_ARGUMENT: an index out of range or keys refused (the message is made again
                        * afterwards) */
} blas_work;

typedef struct build_ctx {
    rto_accel *a;
    const rto_scene *scene;
    rto_tlas_kind kind;
    blas_work *work;
    uint32_t max_workers;
    /* scratch for max_workers workers */
    rto__key_part *parts;
    uint8_t *bad; /* per worker: its range of the current mesh has an index out of range */
    uint32_t *hist, *first;
    uint64_t *diff;
    uint8_t *ordered;
    uint64_t *load;
    size_t *keyed; /* per worker: keyed instances of its range */
    uint32_t *owner; /* per mesh: its worker, or SOLO for the team */
    uint64_t *by_size;
    /* the TLAS */
    rto_aabb *blas_bounds;
    uint32_t *tlas_tmp;
    rto__karras tk;
    rto_status tlas_status;
    rto_msg tlas_msg;
} build_ctx;

static rto_status oom(rto_msg *msg) { return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory"); }

/* The first index of triangles [begin, end) that names no vertex of the mesh, as a position in its index array, or
 * SIZE_MAX. A scene assembled by hand is checked here, where the build reads the indices anyway (the loaders check
 * theirs), so that no box reads out of bounds. */
static size_t first_bad_index(const rto_mesh *me, size_t begin, size_t end)
{
    const uint32_t *idx = me->indices, vc = me->vertex_count;
    uint32_t top = 0;
    for (size_t k = 3 * begin; k < 3 * end; k++) /* a maximum first: no branch, vectorised */
        top = idx[k] > top ? idx[k] : top;
    if (3 * begin == 3 * end || top < vc)
        return SIZE_MAX;
    for (size_t k = 3 * begin;; k++)
        if (idx[k] >= vc)
            return k;
}

/* The message of mesh m's first index out of range, if it has one (RTO_OK otherwise). */
static rto_status index_message(const rto_scene *scene, uint32_t m, rto_msg *msg)
{
    const rto_mesh *me = &scene->meshes[m];
    const size_t k = first_bad_index(me, 0, me->triangle_count);
    if (k == SIZE_MAX)
        return RTO_OK;
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u (%s): index %zu is %u, not below %u vertices", m, me->name,
                    k, me->indices[k], me->vertex_count);
}

/* The first of instances [begin, end) that names a BLAS the scene does not have, or SIZE_MAX. Checked by the build
 * itself, in the ranges of the instance boxes, before a box reads its BLAS's bounds. */
static size_t first_bad_instance(const rto_scene *scene, size_t begin, size_t end)
{
    for (size_t i = begin; i < end; i++)
        if (scene->instances[i].blas >= scene->mesh_count)
            return i;
    return SIZE_MAX;
}

/* The message of the first instance naming a BLAS the scene does not have, if there is one (RTO_OK otherwise). */
static rto_status instance_message(const rto_scene *scene, rto_msg *msg)
{
    const size_t i = first_bad_instance(scene, 0, scene->instance_count);
    if (i == SIZE_MAX)
        return RTO_OK;
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %zu names BLAS %u of %u", i, scene->instances[i].blas,
                    scene->mesh_count);
}

/* A refusal found before or during the build names what the sequential checks named first: an instance naming a
 * missing BLAS, then a mesh with an index out of range (both were checked before anything was allocated). */
static rto_status early_refusal(const rto_scene *scene, rto_msg *msg)
{
    rto_status s = instance_message(scene, msg);
    for (uint32_t m = 0; !s && m < scene->mesh_count; m++)
        s = index_message(scene, m, msg);
    return s;
}

/* Out of memory before the build: an instance or an index out of range is still named first. */
static rto_status oom_or_refusal(const rto_scene *scene, rto_msg *msg)
{
    if (early_refusal(scene, msg))
        return RTO_ERR_INVALID_ARGUMENT;
    return oom(msg);
}

/* Radix scratch of worker slot w (a worker building alone) or of the whole team (w = 0). */
static rto__radix_team radix_of(const build_ctx *c, rto_key_format f, const void *in, size_t n, void *out, void *tmp,
                                uint32_t w)
{
    rto__radix_team r = {f, in, n, out, tmp, c->hist + rto__radix_team_hist_words(w), c->first + (size_t)w * 2048u,
                         c->diff + w, c->ordered + w};
    return r;
}

/* One BLAS by worker w of t (team NULL: alone, with scratch slot `slot`). Every worker of a team calls it and
 * reaches the same syncs; a refusal is seen by all from shared data, so all return together. */
static void blas_stages(build_ctx *c, blas_work *W, rto__team *team, uint32_t w, uint32_t t, uint32_t slot)
{
    const size_t n = W->n;
    size_t b, e;
    rto__part(n, w, t, &b, &e);
    /* The centroids (3 floats a triangle) live in the sort's output and scratch arrays until the keys are made. */
    float *const cent[3] = {(float *)W->tmp, (float *)W->tmp + n, (float *)W->sorted};
    rto__key_part all;
    /* This range's indices first: no box reads a vertex the mesh does not have. */
    int bad = first_bad_index(W->mesh, b, e) != SIZE_MAX;
    if (bad)
        rto__key_part_init(&all);
    else
        rto__blas_boxes_part(W->mesh, b, e, W->boxes, cent, &all);
    if (team) {
        c->parts[w] = all;
        c->bad[w] = (uint8_t)bad;
        rto__team_sync(team);
        rto__key_part_init(&all);
        for (uint32_t v = 0; v < t; v++) {
            rto__key_part_merge(&all, &c->parts[v]);
            bad |= c->bad[v];
        }
    }
    if (bad || !rto__key_bounds_ok(&all, n)) {
        if (w == 0)
            W->status = RTO_ERR_INVALID_ARGUMENT;
        /* Every worker merged the same parts and comes here: none may reuse c->parts and c->bad (the next mesh)
         * before all have read them. */
        rto__team_sync(team);
        return;
    }
    if (w == 0)
        W->b->bounds = all.u;
    rto__blas_keys_part(cent, b, e, &all, W->keys);
    if (team) {
        /* First touches of the fresh node array, spread over the team: the plan below writes the top nodes, which lie
         * all over the array, and one worker taking every page fault there cost more than the rest of the plan. */
        size_t nb, ne;
        rto__part(n - 1, w, t, &nb, &ne);
        memset(W->nodes + nb, 0, (ne - nb) * sizeof *W->nodes);
    }
    rto__team_sync(team);
    rto__radix_team r = radix_of(c, RTO_KEY_U64, W->keys, n, W->sorted, W->tmp, slot);
    rto__radix_team_sort(&r, team, w, t);
    for (size_t j = b; j < e; j++)
        W->order[j] = (uint32_t)W->sorted[j];
    if (w == 0) {
        memset(&W->k, 0, sizeof W->k);
        W->k.f = RTO_KEY_U64;
        W->k.keys = W->sorted;
        W->k.n = n;
        W->k.boxes = W->boxes;
        W->k.nodes = W->nodes;
        /* Each node's SAH term is computed as the sweep closes it (by the team, while the node is in cache) into the
         * sort's scratch, which is free now; the statistics only add them up in index order. */
        W->k.areas = (double *)(void *)W->tmp;
        W->status = rto__karras_plan(&W->k, t, NULL);
    }
    rto__team_sync(team);
    if (W->status)
        return;
    rto__karras_run(&W->k, w, t);
    rto__team_sync(team);
    if (w == 0) {
        rto__karras_finish(&W->k);
        W->b->stats = rto__karras_stats_depth(W->nodes, n, &W->b->bounds, W->k.depth, W->k.areas);
        rto__karras_free(&W->k);
    }
}

/* Which worker builds which mesh, fixed before any work: meshes of at least BIG_MESH triangles go to the
 * team (SOLO); the others, largest first (then by index), each to the worker with the fewest triangles so far (then
 * the lowest). */
static int cmp_u64(const void *x, const void *y)
{
    const uint64_t i = *(const uint64_t *)x, j = *(const uint64_t *)y;
    return (i > j) - (i < j);
}

static void assign_meshes(build_ctx *c, uint32_t t)
{
    const uint32_t mc = c->a->blas_count;
    /* (UINT32_MAX - triangles) << 32 | mesh: ascending is largest first, then by index */
    for (uint32_t m = 0; m < mc; m++)
        c->by_size[m] = ((uint64_t)(UINT32_MAX - c->work[m].b->triangle_count) << 32) | m;
    qsort(c->by_size, mc, sizeof *c->by_size, cmp_u64);
    for (uint32_t v = 0; v < t; v++)
        c->load[v] = 0;
    for (uint32_t k = 0; k < mc; k++) {
        const uint32_t m = (uint32_t)c->by_size[k];
        if (t > 1 && c->work[m].n >= BIG_MESH) {
            c->owner[m] = SOLO;
            continue;
        }
        uint32_t best = 0;
        for (uint32_t v = 1; v < t; v++)
            if (c->load[v] < c->load[best])
                best = v;
        c->owner[m] = best;
        c->load[best] += c->work[m].n + 1;
    }
}

static void tlas_stages(build_ctx *c, rto__team *team, uint32_t w, uint32_t t)
{
    rto_accel *a = c->a;
    const rto_scene *sc = c->scene;
    rto_accel_tlas *tl = &a->tlas;
    const size_t n = sc->instance_count;
    rto_aabb *boxes = (rto_aabb *)(uintptr_t)tl->instance_aabbs;
    uint32_t *keys = (uint32_t *)(uintptr_t)tl->keys, *sorted = (uint32_t *)(uintptr_t)tl->sorted_keys;
    /* The mesh's box through objToWorld, as rto_instance_aabb computes it, but with the mesh's box taken from its
     * BLAS instead of a scan of the mesh per instance; with each range's centroid bounds and keyed count. */
    size_t b, e;
    rto__part(n, w, t, &b, &e);
    /* This range's BLAS indices first: no box reads the bounds of a BLAS the scene does not have. */
    c->bad[w] = first_bad_instance(sc, b, e) != SIZE_MAX;
    if (c->bad[w]) {
        rto__key_part_init(&c->parts[w]);
        c->keyed[w] = 0;
    } else {
        rto__instance_boxes_part(sc->instances, c->blas_bounds, b, e, boxes, &c->parts[w], &c->keyed[w]);
    }
    rto__team_sync(team);
    rto__key_part all;
    rto__key_part_init(&all);
    size_t first = 0, m = 0;
    int bad = 0;
    for (uint32_t v = 0; v < t; v++) {
        rto__key_part_merge(&all, &c->parts[v]);
        first += v < w ? c->keyed[v] : 0;
        m += c->keyed[v];
        bad |= c->bad[v];
    }
    if (bad) {
        if (w == 0) /* the message is build_message's: early_refusal names the first such instance */
            c->tlas_status = RTO_ERR_INVALID_ARGUMENT;
        return; /* every worker returns here, after the last sync */
    }
    if (!rto__key_bounds_ok(&all, m)) {
        /* Refused: the sequential function finds the same fault and gives its message. */
        if (w == 0) {
            size_t none = 0;
            c->tlas_status = rto_tlas_keys_from_boxes(boxes, n, keys, &none, &c->tlas_msg);
            if (!c->tlas_status) /* cannot happen: the same centroids */
                c->tlas_status = rto__fail(&c->tlas_msg, RTO_ERR_INVALID_ARGUMENT, "TLAS keys refused");
        }
        return; /* every worker returns here, after the last sync */
    }
    rto__tlas_keys_part(boxes, b, e, &all, first, keys);
    const size_t np = rto_next_pow2(m);
    if (w == 0) {
        tl->key_count = (uint32_t)m;
        tl->n_padded = (uint32_t)np;
    }
    rto__team_sync(team);
    rto__radix_team r = radix_of(c, RTO_KEY_U32, keys, m, sorted, c->tlas_tmp, 0);
    rto__radix_team_sort(&r, team, w, t);
    rto__part(np - m, w, t, &b, &e);
    for (size_t j = m + b; j < m + e; j++)
        sorted[j] = RTO_SENTINEL_U32;
    if (tl->kind == RTO_TLAS_SWEEP) {
        /* Level order, bottom-up, no atomics: the leaves in ranges, then each level of internal nodes in ranges
         * with a sync between levels, until a level is small enough for worker 0 to finish the tree alone. */
        rto_tlas_node *nodes = (rto_tlas_node *)(uintptr_t)tl->sweep_nodes;
        if (np == 0) {
            if (w == 0)
                c->tlas_status = rto_tlas_build_sweep(sorted, 0, boxes, nodes, &c->tlas_msg);
        } else {
            rto__part(np, w, t, &b, &e);
            rto__tlas_sweep_leaves(sorted, m, np, boxes, nodes, b, e);
            size_t level = np / 2; /* nodes of the level above: [level - 1, 2 level - 1) */
            for (; level >= SWEEP_LEVEL_PER_WORKER * t; level /= 2) {
                rto__team_sync(team);
                rto__part(level, w, t, &b, &e);
                rto__tlas_sweep_nodes(nodes, level - 1 + b, level - 1 + e);
            }
            rto__team_sync(team);
            if (w == 0 && level) /* (one leaf: the root is the leaf) */
                rto__tlas_sweep_nodes(nodes, 0, 2 * level - 1);
        }
        if (w == 0) {
            tl->node_count = rto_tlas_sweep_node_count(m);
            if (!c->tlas_status)
                tl->stats = rto_tlas_stats(nodes, m);
        }
        return;
    }
    rto_bvh_node *nodes = (rto_bvh_node *)(uintptr_t)tl->karras_nodes;
    if (w == 0) {
        tl->node_count = m >= 2 ? m - 1 : 0;
        memset(&c->tk, 0, sizeof c->tk);
        c->tk.f = RTO_KEY_U32;
        c->tk.keys = sorted;
        c->tk.n = m;
        c->tk.boxes = boxes;
        c->tk.nodes = nodes;
        c->tlas_status = rto__karras_plan(&c->tk, t, &c->tlas_msg);
    }
    rto__team_sync(team);
    if (c->tlas_status)
        return;
    rto__karras_run(&c->tk, w, t);
    rto__team_sync(team);
    if (w == 0) {
        rto__karras_finish(&c->tk);
        /* The root box of the statistics: the union of the keyed instances' boxes (rto_scene_aabb's value), merged
         * from the ranges' parts. */
        tl->stats = rto__karras_stats_depth(nodes, m, &all.u, c->tk.depth, NULL);
        rto__karras_free(&c->tk);
    }
}

static void build_team(void *arg, rto__team *team, uint32_t w, uint32_t t)
{
    build_ctx *c = arg;
    const uint32_t mc = c->a->blas_count;
    if (w == 0)
        assign_meshes(c, t);
    rto__team_sync(team);
    for (uint32_t m = 0; m < mc; m++)
        if (c->owner[m] == w)
            blas_stages(c, &c->work[m], NULL, 0, 1, w);
    for (uint32_t m = 0; m < mc; m++)
        if (c->owner[m] == SOLO)
            blas_stages(c, &c->work[m], team, w, t, 0);
    rto__team_sync(team);
    for (uint32_t m = 0; m < mc; m++)
        if (c->work[m].status)
            return;
    if (w == 0)
        for (uint32_t m = 0; m < mc; m++)
            c->blas_bounds[m] = c->a->blas[m].bounds;
    rto__team_sync(team);
    tlas_stages(c, team, w, t);
}

/* Arrays of one BLAS; the accel owns those it keeps. */
static rto_status blas_alloc(blas_work *W, const rto_mesh *mesh, uint32_t index, rto_accel_blas *b, uint32_t workers)
{
    const size_t n = mesh->triangle_count;
    W->mesh = mesh;
    W->b = b;
    W->n = n;
    b->mesh = index;
    b->triangle_count = mesh->triangle_count;
    b->node_count = n >= 2 ? n - 1 : 0;
    b->bounds = rto_aabb_empty();
    W->boxes = rto__alloc(n, sizeof *W->boxes);
    W->keys = rto__alloc(n, sizeof *W->keys);
    W->sorted = rto__alloc(n, sizeof *W->sorted);
    W->tmp = rto__alloc(n, sizeof *W->tmp);
    W->order = rto__alloc(n, sizeof *W->order);
    /* A BLAS built by one worker gets its nodes on transparent huge pages (rto__alloc_large): first touches of 4 KiB
     * pages cost more than building the tree. One built by a team takes 4 KiB pages, whose first touches the team
     * shares out (blas_stages); a huge page is cleared by the one thread that touches it first, and on the 16-core
     * Xeon that made the bunny's 16-thread build 0.5 ms slower. */
    W->nodes = workers > 1 && n >= BIG_MESH ? rto__alloc_lines(b->node_count, sizeof *W->nodes)
                                            : rto__alloc_large(b->node_count, sizeof *W->nodes);
    b->prim_aabbs = W->boxes;
    b->sorted_keys = W->sorted;
    b->order = W->order;
    b->nodes = W->nodes;
    return W->boxes && W->keys && W->sorted && W->tmp && W->order && W->nodes ? RTO_OK : RTO_ERR_OUT_OF_MEMORY;
}

static rto_status tlas_alloc(build_ctx *c)
{
    rto_accel_tlas *t = &c->a->tlas;
    const size_t n = c->scene->instance_count, np = rto_next_pow2(n);
    t->kind = c->kind;
    t->instance_count = c->scene->instance_count;
    t->instance_aabbs = rto__alloc(n, sizeof(rto_aabb));
    t->keys = rto__alloc(n, sizeof(uint32_t));
    t->sorted_keys = rto__alloc(np, sizeof(uint32_t));
    c->tlas_tmp = rto__alloc(n, sizeof(uint32_t));
    if (c->kind == RTO_TLAS_SWEEP)
        t->sweep_nodes = rto__alloc_lines(rto_tlas_sweep_node_count(n), sizeof(rto_tlas_node));
    else
        t->karras_nodes = rto__alloc_lines(n >= 2 ? n - 1 : 0, sizeof(rto_bvh_node));
    return t->instance_aabbs && t->keys && t->sorted_keys && c->tlas_tmp && (t->sweep_nodes || t->karras_nodes)
               ? RTO_OK
               : RTO_ERR_OUT_OF_MEMORY;
}

static void ctx_free(build_ctx *c)
{
    for (uint32_t m = 0; c->work && m < c->a->blas_count; m++) {
        free(c->work[m].keys);
        free(c->work[m].tmp);
    }
    free(c->work);
    free(c->parts);
    free(c->bad);
    free(c->hist);
    free(c->first);
    free(c->diff);
    free(c->ordered);
    free(c->load);
    free(c->keyed);
    free(c->owner);
    free(c->by_size);
    free(c->blas_bounds);
    free(c->tlas_tmp);
}

/* The message of a refused build, as the sequential pipeline gave it: the first mesh in order that failed (its keys'
 * own message, made again from its boxes), else the TLAS's. */
static rto_status build_message(build_ctx *c, rto_msg *msg)
{
    int early = c->tlas_status != RTO_OK;
    for (uint32_t m = 0; m < c->a->blas_count; m++)
        early |= c->work[m].status != RTO_OK;
    if (early && early_refusal(c->scene, msg)) /* the sequential checks' first refusal, where there is one */
        return RTO_ERR_INVALID_ARGUMENT;
    for (uint32_t m = 0; m < c->a->blas_count; m++) {
        blas_work *W = &c->work[m];
        if (!W->status)
            continue;
        rto_status s = W->status == RTO_ERR_OUT_OF_MEMORY /* early_refusal above found nothing */
                           ? oom(msg)
                           : rto_blas_keys_from_boxes(W->boxes, W->n, W->keys, msg);
        if (!s) /* cannot happen: the same boxes were refused */
            s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "keys refused");
        if (msg) {
            /* Name the mesh: the key and tree messages only know their own indices. */
            rto_msg inner = *msg;
            rto__fail(msg, s, "mesh %u (%s): %s", m, c->scene->meshes[m].name, inner.text);
        }
        return s;
    }
    if (c->tlas_status && msg)
        *msg = c->tlas_msg;
    return c->tlas_status;
}

rto_status rto_accel_build(const rto_scene *scene, const rto_accel_desc *desc, rto_accel **out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");
    *out = NULL;
    if (!scene || (scene->mesh_count && !scene->meshes) || (scene->instance_count && !scene->instances))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene or scene arrays");
    rto_accel_desc d;
    memset(&d, 0, sizeof d);
    if (desc)
        d = *desc;
    if (d.tlas != RTO_TLAS_SWEEP && d.tlas != RTO_TLAS_KARRAS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown TLAS kind %d", (int)d.tlas);
    if (scene->instance_count > RTO_TLAS_MAX_INSTANCES)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%u instances: a TLAS key indexes at most %u",
                        scene->instance_count, RTO_TLAS_MAX_INSTANCES);
    /* Instances' BLAS indices and triangles' vertex indices are checked by the build itself, in parallel, before
     * anything reads through them (first_bad_instance, first_bad_index). */
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
        const rto_mesh *me = &scene->meshes[m];
        if ((me->triangle_count && (!me->indices || !me->positions)) || (me->vertex_count && !me->positions)) {
            /* What the sequential checks named before it: a bad instance, then a bad index of an earlier mesh. */
            rto_status s = instance_message(scene, msg);
            for (uint32_t j = 0; !s && j < m; j++)
                s = index_message(scene, j, msg);
            if (s)
                return s;
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u (%s): NULL positions or indices", m, me->name);
        }
    }
    rto_accel *a = calloc(1, sizeof *a);
    if (!a)
        return oom_or_refusal(scene, msg);
    pthread_mutex_init(&a->derived_lock, NULL);
    a->scene = scene;
    a->blas_count = scene->mesh_count;
    a->blas = calloc(a->blas_count ? a->blas_count : 1, sizeof *a->blas);
    build_ctx c;
    memset(&c, 0, sizeof c);
    c.a = a;
    c.scene = scene;
    c.kind = d.tlas;
    const uint32_t W = rto__thread_count(d.threads), mc = a->blas_count;
    c.max_workers = W;
    c.work = calloc(mc ? mc : 1, sizeof *c.work);
    c.parts = rto__alloc(W, sizeof *c.parts);
    c.bad = rto__alloc(W, sizeof *c.bad);
    c.hist = rto__alloc(rto__radix_team_hist_words(W), sizeof *c.hist);
    c.first = rto__alloc((size_t)W * 2048u, sizeof *c.first);
    c.diff = rto__alloc(W, sizeof *c.diff);
    c.ordered = rto__alloc(W, sizeof *c.ordered);
    c.load = rto__alloc(W, sizeof *c.load);
    c.keyed = rto__alloc(W, sizeof *c.keyed);
    c.owner = rto__alloc(mc, sizeof *c.owner);
    c.by_size = rto__alloc(mc, sizeof *c.by_size);
    c.blas_bounds = rto__alloc(mc, sizeof *c.blas_bounds);
    rto_status s = a->blas && c.work && c.parts && c.bad && c.hist && c.first && c.diff && c.ordered && c.load &&
                           c.keyed && c.owner && c.by_size && c.blas_bounds
                       ? RTO_OK
                       : oom_or_refusal(scene, msg);
    for (uint32_t m = 0; !s && m < mc; m++)
        c.work[m].status = blas_alloc(&c.work[m], &scene->meshes[m], m, &a->blas[m], W);
    if (!s && tlas_alloc(&c))
        s = oom_or_refusal(scene, msg);
    for (uint32_t m = 0; !s && m < mc; m++)
        if (c.work[m].status)
            s = build_message(&c, msg);
    if (!s) {
        rto__team_run(W, build_team, &c);
        s = build_message(&c, msg);
    }
    ctx_free(&c);
    if (s) {
        rto_accel_destroy(a);
        return s;
    }
    *out = a;
    return RTO_OK;
}

const rto_scene *rto_accel_scene(const rto_accel *a) { return a ? a->scene : NULL; }
const rto_accel_tlas *rto_accel_get_tlas(const rto_accel *a) { return a ? &a->tlas : NULL; }
uint32_t rto_accel_blas_count(const rto_accel *a) { return a ? a->blas_count : 0; }

const rto_accel_blas *rto_accel_get_blas(const rto_accel *a, uint32_t mesh)
{
    return a && mesh < a->blas_count ? &a->blas[mesh] : NULL;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Self-check                                                                                                       */

/* One tree through its validator, structure-only with exact leaf boxes (the oracle's own boxes are the reference):
 * every primitive box is given, the empty world boxes of instances of an empty BLAS included, which the validators
 * require to be in no leaf. A fault is returned with the tree named in the report and in msg. */
static rto_status check_tree(const rto_bvh_check_desc *d, int sweep, const char *what, const char *name,
                             rto_report *r, rto_msg *msg)
{
    rto_status s = sweep ? rto_tlas_check(d, r, msg) : rto_karras_check(d, r, msg);
    if (s == RTO_OK || s == RTO_ERR_MISMATCH)
        snprintf(r->what, sizeof r->what, "%s", what);
    if (s == RTO_ERR_MISMATCH)
        return rto__fail(msg, s, "%s: %s", name, r->summary);
    return s;
}

rto_status rto_accel_check(const rto_accel *a, rto_report *r, rto_msg *msg)
{
    if (!a || !r)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel or report");
    const rto_accel_tlas *t = &a->tlas;
    rto_bvh_check_desc d;
    memset(&d, 0, sizeof d);
    d.prim_boxes = t->instance_aabbs;
    d.prim_count = t->instance_count;
    rto_status s;
    if (t->kind == RTO_TLAS_SWEEP) {
        d.nodes = t->sweep_nodes;
        d.node_count = t->node_count;
        s = check_tree(&d, 1, "TLAS (sweep)", "the sweep TLAS", r, msg);
    } else {
        uint32_t *prims = rto__alloc(t->key_count, sizeof *prims);
        if (!prims)
            return oom(msg);
        for (uint32_t j = 0; j < t->key_count; j++)
            prims[j] = rto_key_prim(RTO_KEY_U32, t->sorted_keys[j]);
        d.nodes = t->karras_nodes;
        d.node_count = t->node_count;
        d.leaf_prims = prims;
        d.leaf_count = t->key_count;
        s = check_tree(&d, 0, "TLAS (karras)", "the Karras TLAS", r, msg);
        free(prims);
    }
    for (uint32_t m = 0; !s && m < a->blas_count; m++) {
        const rto_accel_blas *b = &a->blas[m];
        char what[32], name[64];
        snprintf(what, sizeof what, "BLAS %u", m);
        snprintf(name, sizeof name, "the BLAS of mesh %u", m);
        memset(&d, 0, sizeof d);
        d.nodes = b->nodes;
        d.node_count = b->node_count;
        d.prim_boxes = b->prim_aabbs;
        d.prim_count = b->triangle_count;
        d.leaf_prims = b->order;
        d.leaf_count = b->triangle_count;
        s = check_tree(&d, 0, what, name, r, msg);
    }
    return s;
}
