/* Ordered traversal (DESIGN.md §6): the TLAS (sweep heap or Karras tree), then the BLAS of each instance entered,
 * with the ray in that instance's object space. A stack of (node, entry t) pairs: a popped node whose entry t is
 * beyond the best hit so far is skipped; at an internal node both children are slab-tested and pushed farther
 * first, so the nearer is visited first, and on equal entry t the left child first. Triangles must beat the best t
 * strictly, so the first hit found wins a tie. One ray at a time here on the accel's own trees: the reference the
 * other paths are held to. trace/packed.c, the default on x86-64, runs the same operations on a copy of the trees
 * laid out for a CPU; trace/lanes.c runs 8 or 16 rays side by side when RTO_TRACE_ISA asks. Rays are split
 * statically over threads (§2). */
#include "internal.h"
#include "trace_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef rto__trace_entry entry;
typedef rto__tracer tracer;

/* Per-ray state: the world ray, its best hit so far, counters, and the two stacks (TLAS and the BLAS in hand). */
typedef struct ray_state {
    const rto_wf_ray *ray;
    float inv[3];
    float best_t;
    int found;
    int done; /* TERMINATE_ON_FIRST_HIT and a hit: stop everything */
    rto_hit_record hit;
    rto_trace_counters c;
    entry *tstack, *bstack;
} ray_state;

/* Pushes the children of a Karras node (a, b = the left and right child, their boxes) in visiting order. */
static inline size_t push_pair(entry *stack, size_t top, int hit_l, uint32_t l, float tl, int hit_r, uint32_t r,
                               float tr)
{
    if (hit_l && hit_r) {
        if (tl <= tr) { /* left nearer, or equal: left is visited first, so pushed last */
            stack[top++] = (entry){r, tr};
            stack[top++] = (entry){l, tl};
        } else {
            stack[top++] = (entry){l, tl};
            stack[top++] = (entry){r, tr};
        }
    } else if (hit_l) {
        stack[top++] = (entry){l, tl};
    } else if (hit_r) {
        stack[top++] = (entry){r, tr};
    }
    return top;
}

/* The BLAS of instance inst, entered: the ray in object space, the tree in order, triangles against best_t. */
static void trace_blas(const tracer *tr, ray_state *st, uint32_t inst)
{
    const rto_instance *in = &tr->scene->instances[inst];
    const rto_accel_blas *b = rto_accel_get_blas(tr->accel, in->blas);
    const rto_mesh *mesh = &tr->scene->meshes[in->blas];
    const rto_wf_ray *ray = st->ray;
    float o[3], d[3], inv[3];
    rto__ray_to_object(&in->world_to_obj, ray->origin, ray->dir, o, d);
    /* The §2 clamp feeds only the slab tests; Möller–Trumbore takes the unclamped object-space direction. */
    rto__ray_inv_dir(d, inv);
    st->c.instance_entries++;
    rto_tri_hit h;
    if (b->triangle_count == 1) { /* no internal node: straight to the triangle */
        st->c.triangle_tests++;
        if (rto__mesh_triangle_hit(mesh, b->order[0], o, d, ray->t_min, st->best_t, ray->flags, &h)) {
            st->best_t = h.t;
            st->hit = rto_hit_record_make(in, inst, b->order[0], &h);
            st->found = 1;
            st->done = (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
        }
        return;
    }
    entry *stack = st->bstack;
    size_t top = 0;
    /* The root is internal node 0, entered without a box test of its own: its stored child boxes are the tests. */
    stack[top++] = (entry){0, ray->t_min};
    while (top) {
        const entry e = stack[--top];
        if (e.t > st->best_t)
            continue;
        st->c.nodes_visited++;
        if (e.ref & RTO_BVH_LEAF_BIT) {
            const uint32_t prim = b->order[e.ref & ~RTO_BVH_LEAF_BIT];
            st->c.triangle_tests++;
            if (rto__mesh_triangle_hit(mesh, prim, o, d, ray->t_min, st->best_t, ray->flags, &h)) {
                st->best_t = h.t;
                st->hit = rto_hit_record_make(in, inst, prim, &h);
                st->found = 1;
                if (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) {
                    st->done = 1;
                    return;
                }
            }
            continue;
        }
        const rto_bvh_node *n = &b->nodes[e.ref];
        float tl = 0.0f, trr = 0.0f;
        st->c.box_tests += 2;
        const int hl = rto__slab(n->lmin, n->lmax, o, inv, ray->t_min, st->best_t, &tl);
        const int hr = rto__slab(n->rmin, n->rmax, o, inv, ray->t_min, st->best_t, &trr);
        top = push_pair(stack, top, hl, n->left, tl, hr, n->right, trr);
    }
}

/* An instance leaf reached in the TLAS: entered when its mask meets the ray's cull mask. */
static void visit_instance(const tracer *tr, ray_state *st, uint32_t inst)
{
    if (tr->scene->instances[inst].mask & st->ray->cull_mask)
        trace_blas(tr, st, inst);
}

static void trace_sweep(const tracer *tr, ray_state *st)
{
    const rto_tlas_node *nodes = tr->tlas->sweep_nodes;
    const rto_wf_ray *ray = st->ray;
    const size_t first_leaf = (size_t)tr->tlas->n_padded - 1;
    entry *stack = st->tstack;
    size_t top = 0;
    float t;
    /* The root box is tested like any node; an EMPTY node is skipped by its item, never by a box test. */
    if (nodes[0].item != RTO_TLAS_EMPTY) {
        st->c.box_tests++;
        if (rto__slab(nodes[0].min, nodes[0].max, ray->origin, st->inv, ray->t_min, st->best_t, &t))
            stack[top++] = (entry){0, t};
    }
    while (top && !st->done) {
        const entry e = stack[--top];
        if (e.t > st->best_t)
            continue;
        st->c.nodes_visited++;
        if (e.ref >= first_leaf) {
            visit_instance(tr, st, nodes[e.ref].item);
            continue;
        }
        const uint32_t l = 2 * e.ref + 1, r = 2 * e.ref + 2;
        float tl = 0.0f, trr = 0.0f;
        int hl = 0, hr = 0;
        if (nodes[l].item != RTO_TLAS_EMPTY) {
            st->c.box_tests++;
            hl = rto__slab(nodes[l].min, nodes[l].max, ray->origin, st->inv, ray->t_min, st->best_t, &tl);
        }
        if (nodes[r].item != RTO_TLAS_EMPTY) {
            st->c.box_tests++;
            hr = rto__slab(nodes[r].min, nodes[r].max, ray->origin, st->inv, ray->t_min, st->best_t, &trr);
        }
        top = push_pair(stack, top, hl, l, tl, hr, r, trr);
    }
}

static void trace_karras_tlas(const tracer *tr, ray_state *st)
{
    const rto_accel_tlas *tl = tr->tlas;
    const rto_wf_ray *ray = st->ray;
    if (tl->key_count == 0)
        return;
    if (tl->key_count == 1) { /* no internal node: straight to the one instance */
        visit_instance(tr, st, rto_key_prim(RTO_KEY_U32, tl->sorted_keys[0]));
        return;
    }
    entry *stack = st->tstack;
    size_t top = 0;
    stack[top++] = (entry){0, ray->t_min};
    while (top && !st->done) {
        const entry e = stack[--top];
        if (e.t > st->best_t)
            continue;
        st->c.nodes_visited++;
        if (e.ref & RTO_BVH_LEAF_BIT) {
            visit_instance(tr, st, rto_key_prim(RTO_KEY_U32, tl->sorted_keys[e.ref & ~RTO_BVH_LEAF_BIT]));
            continue;
        }
        const rto_bvh_node *n = &tl->karras_nodes[e.ref];
        float t0 = 0.0f, t1 = 0.0f;
        st->c.box_tests += 2;
        const int hl = rto__slab(n->lmin, n->lmax, ray->origin, st->inv, ray->t_min, st->best_t, &t0);
        const int hr = rto__slab(n->rmin, n->rmax, ray->origin, st->inv, ray->t_min, st->best_t, &t1);
        top = push_pair(stack, top, hl, n->left, t0, hr, n->right, t1);
    }
}

typedef struct trace_job {
    const tracer *tr;
    const rto_wf_ray *rays;
    rto_hit_record *hits;
    rto_trace_counters *counters;
    const rto__trace_lanes *lanes; /* NULL: the scalar tracer or the packed path */
    const void *packed;            /* the packed trees (trace/packed.c), NULL: not that path */
    unsigned char *scratch;        /* per worker: the stacks (2 * stack_cap entries; the packed path's: see
                                      rto__trace_packed_scratch) or the lanes' scratch */
    size_t scratch_size;           /* per worker, a multiple of 64 */
} trace_job;

static void trace_range(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    const trace_job *job = ctx;
    const tracer *tr = job->tr;
    void *scratch = job->scratch + (size_t)worker * job->scratch_size;
    if (job->lanes) {
        job->lanes->trace(tr, job->rays, begin, end, job->hits, job->counters, scratch);
        return;
    }
    if (job->packed) {
        rto__trace_packed(tr, job->packed, job->rays, begin, end, job->hits, job->counters, scratch);
        return;
    }
    ray_state st;
    st.tstack = scratch;
    st.bstack = st.tstack + tr->stack_cap;
    for (size_t i = begin; i < end; i++) {
        st.ray = &job->rays[i];
        rto__ray_inv_dir(st.ray->dir, st.inv);
        st.best_t = st.ray->t_max;
        st.found = 0;
        st.done = 0;
        memset(&st.c, 0, sizeof st.c);
        if (tr->tlas->kind == RTO_TLAS_KARRAS)
            trace_karras_tlas(tr, &st);
        else
            trace_sweep(tr, &st);
        job->hits[i] = st.found ? st.hit : rto_hit_record_miss(st.ray->t_max);
        if (job->counters)
            job->counters[i] = st.c;
    }
}

const char *rto__trace_isa_name(rto__trace_isa isa)
{
    static const char *const names[RTO__TRACE_ISA_COUNT] = {"auto", "scalar", "sse2", "avx2", "avx512"};
    return (unsigned)isa < RTO__TRACE_ISA_COUNT ? names[isa] : "?";
}

int rto__trace_isa_supported(rto__trace_isa isa)
{
    if (isa == RTO__TRACE_AUTO || isa == RTO__TRACE_SCALAR)
        return 1;
    if (isa == RTO__TRACE_SSE2)
        return rto__trace_packed_built();
    if ((unsigned)isa >= RTO__TRACE_ISA_COUNT || !rto__trace_lanes_kernel(isa))
        return 0;
    return isa == RTO__TRACE_AVX2 ? rto__cpu_avx2() : rto__cpu_avx512();
}

static const char *isa_name(int i) { return rto__trace_isa_name((rto__trace_isa)i); }
static int isa_supported(int i) { return rto__trace_isa_supported((rto__trace_isa)i); }

rto__trace_isa rto__trace_isa_resolve(void)
{
    return (rto__trace_isa)rto__isa_resolve("RTO_TRACE_ISA", isa_name, isa_supported, RTO__TRACE_SCALAR,
                                            RTO__TRACE_ISA_COUNT, RTO__TRACE_SSE2);
}

rto_status rto__trace_with(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                           rto__trace_isa isa, rto_hit_record *hits, rto_trace_counters *counters, rto_msg *msg)
{
    return rto__trace_with_order(accel, rays, n, desc, isa, RTO__ORDER_AUTO, hits, counters, msg);
}

rto_status rto__trace_with_order(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                                 rto__trace_isa isa, rto__trace_order order, rto_hit_record *hits,
                                 rto_trace_counters *counters, rto_msg *msg)
{
    if (!accel)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel");
    if (n && !hits)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL hit output");
    if (!rto__trace_isa_supported(isa))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "trace path '%s' is not supported on this CPU",
                         rto__trace_isa_name(isa));
    if (isa == RTO__TRACE_SSE2 && !rto__trace_packed_order_supported(order))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "packed order %d is not supported on this CPU", (int)order);
    rto_status s = rto__rays_check(rays, n, msg);
    if (s)
        return s;
    if (!n)
        return RTO_OK;
    /* Left to choose (no path asked for by the caller or by RTO_TRACE_ISA), rto_trace makes the packed copy once the
     * calls on the accel have brought enough rays to pay for it (rto__trace_packed_worth); until then it runs the
     * scalar tracer, the same bytes. */
    const int chosen_here =
        isa == RTO__TRACE_AUTO && rto__isa_named("RTO_TRACE_ISA", isa_name, RTO__TRACE_SCALAR, RTO__TRACE_ISA_COUNT) < 0;
    if (isa == RTO__TRACE_AUTO)
        isa = rto__trace_isa_resolve();
    tracer tr = {accel, rto_accel_scene(accel), rto_accel_get_tlas(accel), 0, order};
    /* Ordered traversal pops one entry and pushes at most two, so a stack never holds more than depth + 1 entries. */
    uint32_t depth = tr.tlas->stats.depth;
    for (uint32_t m = 0; m < rto_accel_blas_count(accel); m++) {
        const uint32_t d = rto_accel_get_blas(accel, m)->stats.depth;
        depth = d > depth ? d : depth;
    }
    tr.stack_cap = (size_t)depth + 2;
    const uint32_t threads = rto__thread_count(desc ? desc->threads : 0);
    const rto__trace_lanes *lanes = rto__trace_lanes_kernel(isa);
    size_t size = lanes                      ? lanes->scratch_size(tr.stack_cap)
                  : isa == RTO__TRACE_SSE2 ? rto__trace_packed_scratch(tr.stack_cap)
                                           : 2 * tr.stack_cap * sizeof(entry);
    size = (size + 63) & ~(size_t)63;
    /* One block for every worker, 64-byte aligned (the lanes' vectors): 64 bytes more than the workers' slices. */
    unsigned char *block = rto__alloc((size_t)threads * size + 64, 1);
    if (!block)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u traversal stacks", threads);
    unsigned char *aligned = block + ((64 - (uintptr_t)block % 64) % 64);
    const void *packed = NULL;
    if (isa == RTO__TRACE_SSE2) {
        packed = rto__trace_packed_trees(accel, 0);
        if (!packed && (!chosen_here || rto__trace_packed_worth(accel, rto__accel_rays_traced(accel, n), threads)))
            packed = rto__trace_packed_trees(accel, 1);
        if (!packed) /* no copy of the trees (not made yet, or no memory): the scalar tracer, the same bytes */
            isa = RTO__TRACE_SCALAR;
    }
    trace_job job = {&tr, rays, hits, counters, lanes, packed, aligned, size};
    rto__parallel_ranges(n, threads, trace_range, &job);
    free(block);
    return RTO_OK;
}

rto_status rto_trace(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                     rto_hit_record *hits, rto_trace_counters *counters, rto_msg *msg)
{
    return rto__trace_with(accel, rays, n, desc, RTO__TRACE_AUTO, hits, counters, msg);
}
