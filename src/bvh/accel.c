/* The acceleration-structure object: every tree of a scene built once (DESIGN.md §5), the one build pipeline the
 * command, the benchmark and the tracer share. Per stage:
 *   meshes     triangle boxes (their union: the mesh's bounds) -> BLAS keys -> radix sort -> leaf order -> Karras
 *   instances  world boxes (the mesh's bounds through objToWorld) -> TLAS keys of the non-empty ones -> radix sort
 *              -> sweep or Karras tree
 * The sorts are rto_fast_radix_sort: real keys are unique, so any correct sort gives the canonical network's bytes
 * (§4). An instance of an empty BLAS has an empty world box and gets no key and no leaf; an empty mesh gets an
 * empty BLAS (§5). Building validates nothing beyond its inputs; rto_accel_check runs the tree validators. */
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct rto_accel {
    const rto_scene *scene;
    rto_accel_tlas tlas;
    uint32_t blas_count;
    rto_accel_blas *blas;
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
    free(a);
}

/* Union with min / max keeping the later operand when equal (rto_minf / rto_maxf). */
static rto_aabb union_box(rto_aabb a, rto_aabb b)
{
    a.min.x = rto_minf(a.min.x, b.min.x);
    a.min.y = rto_minf(a.min.y, b.min.y);
    a.min.z = rto_minf(a.min.z, b.min.z);
    a.max.x = rto_maxf(a.max.x, b.max.x);
    a.max.y = rto_maxf(a.max.y, b.max.y);
    a.max.z = rto_maxf(a.max.z, b.max.z);
    return a;
}

static rto_status oom(rto_msg *msg) { return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory"); }

static rto_status build_tlas(rto_accel *a, rto_tlas_kind kind, rto_msg *msg)
{
    const rto_scene *sc = a->scene;
    rto_accel_tlas *t = &a->tlas;
    const size_t n = sc->instance_count;
    t->kind = kind;
    t->instance_count = sc->instance_count;
    rto_aabb *boxes = rto_alloc(n, sizeof *boxes);
    uint32_t *keys = rto_alloc(n, sizeof *keys);
    t->instance_aabbs = boxes;
    t->keys = keys;
    if (!boxes || !keys)
        return oom(msg);
    /* The mesh's box through objToWorld, as rto_instance_aabb computes it, but with the mesh's box taken from its
     * BLAS instead of a scan of the mesh per instance. */
    for (size_t i = 0; i < n; i++)
        boxes[i] = rto_aabb_transform(&sc->instances[i].obj_to_world, &a->blas[sc->instances[i].blas].bounds);
    size_t m = 0;
    rto_status s = rto_tlas_keys_from_boxes(boxes, n, keys, &m, msg);
    if (s)
        return s;
    const size_t np = rto_next_pow2(m);
    t->key_count = (uint32_t)m;
    t->n_padded = (uint32_t)np;
    uint32_t *sorted = rto_alloc(np, sizeof *sorted);
    t->sorted_keys = sorted;
    if (!sorted)
        return oom(msg);
    s = rto_fast_radix_sort(RTO_KEY_U32, keys, m, sorted, msg);
    if (s)
        return s;
    for (size_t j = m; j < np; j++)
        sorted[j] = RTO_SENTINEL_U32;
    if (kind == RTO_TLAS_SWEEP) {
        t->node_count = rto_tlas_sweep_node_count(m);
        rto_tlas_node *nodes = rto_alloc(t->node_count, sizeof *nodes);
        t->sweep_nodes = nodes;
        if (!nodes)
            return oom(msg);
        s = rto_tlas_build_sweep(sorted, m, boxes, nodes, msg);
        if (!s)
            t->stats = rto_tlas_stats(nodes, m);
    } else {
        t->node_count = m >= 2 ? m - 1 : 0;
        rto_bvh_node *nodes = rto_alloc(t->node_count, sizeof *nodes);
        t->karras_nodes = nodes;
        if (!nodes)
            return oom(msg);
        s = rto_karras_build(RTO_KEY_U32, sorted, m, boxes, nodes, msg);
        /* The root box of the statistics: the union of the keyed instances' boxes (rto_scene_aabb's value). */
        rto_aabb root = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
        for (size_t i = 0; i < n; i++)
            if (!rto_aabb_is_empty(&boxes[i]))
                root = union_box(root, boxes[i]);
        if (!s)
            t->stats = rto_karras_stats(nodes, m, &root);
    }
    return s;
}

static rto_status build_blas(const rto_mesh *mesh, uint32_t index, rto_accel_blas *b, rto_msg *msg)
{
    const size_t n = mesh->triangle_count;
    b->mesh = index;
    b->triangle_count = mesh->triangle_count;
    b->node_count = n >= 2 ? n - 1 : 0;
    rto_aabb *boxes = rto_alloc(n, sizeof *boxes);
    uint64_t *keys = rto_alloc(n, sizeof *keys), *sorted = rto_alloc(n, sizeof *sorted);
    uint32_t *order = rto_alloc(n, sizeof *order);
    rto_bvh_node *nodes = rto_alloc(b->node_count, sizeof *nodes);
    b->prim_aabbs = boxes;
    b->sorted_keys = sorted;
    b->order = order;
    b->nodes = nodes;
    rto_status s = boxes && keys && sorted && order && nodes ? RTO_OK : oom(msg);
    /* The mesh's bounds as the union of its triangles' boxes, in triangle order: the same bytes as rto_mesh_aabb
     * (min / max over the referenced vertices in index order, the later operand kept when equal). */
    rto_aabb u = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    for (size_t t = 0; !s && t < n; t++) {
        boxes[t] = rto_mesh_triangle_aabb(mesh, (uint32_t)t);
        u = union_box(u, boxes[t]);
    }
    b->bounds = u;
    if (!s)
        s = rto_blas_keys_from_boxes(boxes, n, keys, msg);
    if (!s)
        s = rto_fast_radix_sort(RTO_KEY_U64, keys, n, sorted, msg);
    for (size_t j = 0; !s && j < n; j++)
        order[j] = rto_key_prim(RTO_KEY_U64, sorted[j]);
    if (!s) {
        rto__karras k;
        memset(&k, 0, sizeof k);
        k.f = RTO_KEY_U64;
        k.keys = sorted;
        k.n = n;
        k.boxes = boxes;
        k.nodes = nodes;
        s = rto__karras_plan(&k, 1, msg);
        if (!s) {
            rto__karras_run(&k, 0, 1);
            rto__karras_finish(&k);
            b->stats = rto__karras_stats_depth(nodes, n, &b->bounds, k.depth);
        }
        rto__karras_free(&k);
    }
    free(keys);
    return s;
}

rto_status rto_accel_build(const rto_scene *scene, const rto_accel_desc *desc, rto_accel **out, rto_msg *msg)
{
    if (!out)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");
    *out = NULL;
    if (!scene || (scene->mesh_count && !scene->meshes) || (scene->instance_count && !scene->instances))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene or scene arrays");
    rto_accel_desc d = {RTO_TLAS_SWEEP};
    if (desc)
        d = *desc;
    if (d.tlas != RTO_TLAS_SWEEP && d.tlas != RTO_TLAS_KARRAS)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown TLAS kind %d", (int)d.tlas);
    if (scene->instance_count > RTO_TLAS_MAX_INSTANCES)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "%u instances: a TLAS key indexes at most %u",
                        scene->instance_count, RTO_TLAS_MAX_INSTANCES);
    for (uint32_t i = 0; i < scene->instance_count; i++)
        if (scene->instances[i].blas >= scene->mesh_count)
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %u names BLAS %u of %u", i,
                            scene->instances[i].blas, scene->mesh_count);
    /* The loaders validate their meshes; a scene assembled by hand is checked here so that no box reads out of
     * bounds (3 compares per triangle, nothing beside the build). */
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
        const rto_mesh *me = &scene->meshes[m];
        if ((me->triangle_count && (!me->indices || !me->positions)) || (me->vertex_count && !me->positions))
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u (%s): NULL positions or indices", m, me->name);
        for (size_t k = 0; k < 3 * (size_t)me->triangle_count; k++)
            if (me->indices[k] >= me->vertex_count)
                return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u (%s): index %zu is %u, not below %u vertices",
                                m, me->name, k, me->indices[k], me->vertex_count);
    }
    rto_accel *a = calloc(1, sizeof *a);
    if (!a)
        return oom(msg);
    a->scene = scene;
    a->blas_count = scene->mesh_count;
    a->blas = calloc(a->blas_count ? a->blas_count : 1, sizeof *a->blas);
    /* BLAS first: the TLAS takes each mesh's bounds from its BLAS. */
    rto_status s = a->blas ? RTO_OK : oom(msg);
    for (uint32_t m = 0; !s && m < a->blas_count; m++) {
        s = build_blas(&scene->meshes[m], m, &a->blas[m], msg);
        if (s && msg) {
            /* Name the mesh: the key and tree messages only know their own indices. */
            rto_msg inner = *msg;
            rto_fail(msg, s, "mesh %u (%s): %s", m, scene->meshes[m].name, inner.text);
        }
    }
    if (!s)
        s = build_tlas(a, d.tlas, msg);
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
        return rto_fail(msg, s, "%s: %s", name, r->summary);
    return s;
}

rto_status rto_accel_check(const rto_accel *a, rto_report *r, rto_msg *msg)
{
    if (!a || !r)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel or report");
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
        uint32_t *prims = rto_alloc(t->key_count, sizeof *prims);
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
