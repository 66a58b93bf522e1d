/* The tracer's packed path (DESIGN.md §6), rto_trace's default on x86-64: each ray walked as the scalar tracer
 * (traverse.c) walks it, on a copy of the accel's trees laid out for a CPU, made once per accel on first use:
 *   - every tree's internal nodes in depth-first order (a node, its left subtree, its right subtree), so a node's
 *     left child is the next cache line;
 *   - a node's two child boxes side by side per axis ({left min, right min, left max, right max} for x, y and z), so
 *     both slab tests run as one 4-wide SSE2 computation of the same binary32 operations in the same order, lane by
 *     lane, as rto__slab's (minps and maxps are the ternaries a < b ? a : b and a > b ? a : b, NaN and all);
 *   - a BLAS's triangles in the same array, each leaf's three vertices where its parent's subtree is, instead of an
 *     index, an index buffer and a position buffer apart;
 *   - the sweep TLAS's heap as the same nodes (its EMPTY children absent, untested and uncounted, as §6 says) and
 *     its instance leaves as references.
 * The traversal is §6's, pop for pop: of the children hit, the nearer is visited at once instead of being pushed and
 * popped straight back (its pop-time check cannot fail: its entry t is at most the best t, which only a triangle
 * changes). A worker walks its rays in one of three orders, each ray's walk the same node for node in all: one ray at
 * a time; eight rays in turn (one node of each, the next prefetched), which hides the fetches of rays that go separate
 * ways through trees larger than a core's cache; or groups of 8 (AVX2) or 16 (AVX-512) neighbouring rays walking the
 * trees together (trace/groups_kernel.h), each node fetched once and tested for the whole group in vector code, which
 * is the faster where neighbouring rays are alike (rto__trace_packed_order picks). Records and counters equal the
 * scalar tracer's bit for bit in every order: unit.trace_lanes holds every path and order to them.
 * Making the copy costs about what tracing a ray per slot does, on one thread; so rto_trace, left to choose, makes it
 * once the calls on the accel have brought threads * slots rays (a frame traces in chunks), and runs the scalar tracer
 * (the same bytes) until then. Where the copy cannot be made (out of memory, a tree of 2^31 slots or more) rto_trace
 * runs the scalar tracer too. */
#include "internal.h"
#include "trace_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>

/* A node: both child boxes per axis a at box[4a .. 4a + 3] = left min, right min, left max, right max; each child a
 * slot index, or RTO_BVH_LEAF_BIT with a triangle's slot (BLAS) or an instance index (TLAS). */
typedef struct packed_node {
    float box[12];
    uint32_t child[2];
    uint32_t present; /* bit 0: left, bit 1: right; an absent child (a sweep TLAS's EMPTY node) is never tested */
    uint32_t tests;   /* box tests the node counts: the children present */
} packed_node;

/* A BLAS leaf: the triangle's vertices as the mesh holds them, and its index. */
typedef struct packed_tri {
    float v[9];
    uint32_t prim;
    uint32_t pad[6];
} packed_tri;

typedef union packed_slot {
    packed_node node;
    packed_tri tri;
} packed_slot;
RTO_STATIC_ASSERT(sizeof(packed_slot) == 64, "a packed slot is one cache line");

/* One tree: the slots, and where a ray starts. */
typedef struct packed_tree {
    packed_slot *slots;
    uint32_t root;      /* a slot, or a leaf reference for a tree that is one leaf */
    int root_box;       /* sweep TLAS: the root's own box is tested first (box below) */
    float box[6];       /* that box: min, max */
    int empty;          /* no leaf at all */
} packed_tree;

typedef struct packed_accel {
    packed_tree tlas;
    uint32_t blas_count;
    packed_tree *blas;
    size_t bytes; /* the slots of every tree */
} packed_accel;

/* ---------------------------------------------------------------------------------------------------------------- */
/* The copy: a tree walked depth first with an explicit stack (a Karras tree can be deep), every internal node given */
/* the next slot when reached, a triangle the next slot when its leaf is reached.                                     */

/* What a node of one of the three trees is: its children (a source reference each, valid or absent) and boxes. */
typedef struct src_tree {
    int kind; /* 0: Karras BLAS, 1: Karras TLAS, 2: sweep TLAS */
    const rto_bvh_node *karras;
    const rto_tlas_node *sweep;
    size_t first_leaf; /* sweep */
    const rto_accel_blas *blas;
    const rto_mesh *mesh;
    const uint32_t *tlas_sorted_keys;
} src_tree;

static int src_leaf(const src_tree *t, uint32_t ref)
{
    return t->kind == 2 ? ref >= t->first_leaf : (ref & RTO_BVH_LEAF_BIT) != 0;
}

/* Fills a node's boxes and presence from source node ref; returns its two source children. */
static void src_node(const src_tree *t, uint32_t ref, packed_node *n, uint32_t child[2])
{
    const float *mn[2], *mx[2];
    n->present = 3;
    if (t->kind == 2) {
        for (int c = 0; c < 2; c++) {
            const rto_tlas_node *s = &t->sweep[2 * (size_t)ref + 1 + c];
            child[c] = 2 * ref + 1 + (uint32_t)c;
            mn[c] = s->min;
            mx[c] = s->max;
            if (s->item == RTO_TLAS_EMPTY)
                n->present &= ~(1u << c);
        }
    } else {
        const rto_bvh_node *s = &t->karras[ref];
        child[0] = s->left;
        child[1] = s->right;
        mn[0] = s->lmin;
        mx[0] = s->lmax;
        mn[1] = s->rmin;
        mx[1] = s->rmax;
    }
    for (int a = 0; a < 3; a++) {
        n->box[4 * a + 0] = (n->present & 1) ? mn[0][a] : 0.0f;
        n->box[4 * a + 1] = (n->present & 2) ? mn[1][a] : 0.0f;
        n->box[4 * a + 2] = (n->present & 1) ? mx[0][a] : 0.0f;
        n->box[4 * a + 3] = (n->present & 2) ? mx[1][a] : 0.0f;
    }
    n->tests = (n->present & 1) + (n->present >> 1);
}

/* The packed reference of a source leaf: a triangle slot (BLAS, taken here) or an instance (TLAS). */
static uint32_t leaf_ref(const src_tree *t, uint32_t ref, packed_slot *slots, uint32_t *next)
{
    if (t->kind == 2)
        return RTO_BVH_LEAF_BIT | t->sweep[ref].item;
    const uint32_t leaf = ref & ~RTO_BVH_LEAF_BIT;
    if (t->kind == 1)
        return RTO_BVH_LEAF_BIT | rto_key_prim(RTO_KEY_U32, t->tlas_sorted_keys[leaf]);
    const uint32_t me = (*next)++;
    packed_tri *tri = &slots[me].tri;
    const uint32_t prim = t->blas->order[leaf];
    const uint32_t *ix = &t->mesh->indices[3 * (size_t)prim];
    memset(tri, 0, sizeof *tri);
    for (int v = 0; v < 3; v++)
        memcpy(&tri->v[3 * v], &t->mesh->positions[3 * (size_t)ix[v]], 3 * sizeof(float));
    tri->prim = prim;
    return RTO_BVH_LEAF_BIT | me;
}

/* Depth-first copy from source node root (internal). stack holds depth + 1 entries. */
static void copy_tree(const src_tree *t, uint32_t root, packed_slot *slots, uint32_t *stack_ref, uint32_t *stack_at)
{
    uint32_t next = 0;
    size_t top = 0;
    stack_ref[top] = root;
    stack_at[top++] = UINT32_MAX; /* where the parent keeps the reference: slot * 2 + side */
    while (top) {
        const uint32_t ref = stack_ref[--top], at = stack_at[top];
        uint32_t packed;
        uint32_t child[2] = {0, 0};
        if (src_leaf(t, ref)) {
            packed = leaf_ref(t, ref, slots, &next);
        } else {
            packed = next++;
            packed_node *n = &slots[packed].node;
            memset(n, 0, sizeof *n);
            src_node(t, ref, n, child);
            /* The right child is copied after the whole left subtree: pushed first. */
            for (int c = 1; c >= 0; c--)
                if (n->present & (1u << c)) {
                    stack_ref[top] = child[c];
                    stack_at[top++] = 2 * packed + (uint32_t)c;
                }
        }
        if (at != UINT32_MAX)
            slots[at / 2].node.child[at % 2] = packed;
    }
}

static void packed_free(void *p)
{
    packed_accel *pa = p;
    if (!pa)
        return;
    free(pa->tlas.slots);
    for (uint32_t m = 0; pa->blas && m < pa->blas_count; m++)
        free(pa->blas[m].slots);
    free(pa->blas);
    free(pa);
}

/* Slots for a tree's internal nodes and (BLAS) triangles, or 0 when 31-bit references cannot hold them. */
static size_t slot_count(size_t internal, size_t triangles)
{
    const size_t n = internal + triangles;
    return n > (size_t)(RTO_BVH_LEAF_BIT - 1) ? 0 : n;
}

static void *packed_make(const rto_accel *accel)
{
    const rto_scene *scene = rto_accel_scene(accel);
    const rto_accel_tlas *tl = rto_accel_get_tlas(accel);
    packed_accel *pa = calloc(1, sizeof *pa);
    if (!pa)
        return NULL;
    pa->blas_count = rto_accel_blas_count(accel);
    pa->blas = calloc(pa->blas_count ? pa->blas_count : 1, sizeof *pa->blas);
    /* A stack for the deepest tree: a walk holds at most one pending right child per level, plus the root. */
    uint32_t depth = tl->stats.depth;
    for (uint32_t m = 0; m < pa->blas_count; m++) {
        const uint32_t d = rto_accel_get_blas(accel, m)->stats.depth;
        depth = d > depth ? d : depth;
    }
    uint32_t *stack = malloc(2 * ((size_t)depth + 2) * sizeof *stack);
    int ok = pa->blas && stack;
    for (uint32_t m = 0; ok && m < pa->blas_count; m++) {
        const rto_accel_blas *b = rto_accel_get_blas(accel, m);
        packed_tree *pt = &pa->blas[m];
        pt->empty = b->triangle_count == 0;
        if (pt->empty)
            continue;
        const size_t n = slot_count(b->node_count, b->triangle_count);
        pt->slots = n ? rto__alloc_large(n, sizeof *pt->slots) : NULL;
        ok = pt->slots != NULL;
        if (!ok)
            break;
        pa->bytes += n * sizeof *pt->slots;
        const src_tree src = {0, b->nodes, NULL, 0, b, &scene->meshes[m], NULL};
        if (b->triangle_count == 1) { /* no internal node: the one triangle */
            uint32_t next = 0;
            pt->root = leaf_ref(&src, RTO_BVH_LEAF_BIT, pt->slots, &next);
        } else {
            copy_tree(&src, 0, pt->slots, stack, stack + depth + 2);
            pt->root = 0;
        }
    }
    packed_tree *pt = &pa->tlas;
    if (ok && tl->kind == RTO_TLAS_KARRAS) {
        const src_tree src = {1, tl->karras_nodes, NULL, 0, NULL, NULL, tl->sorted_keys};
        pt->empty = tl->key_count == 0;
        if (tl->key_count == 1) {
            pt->root = RTO_BVH_LEAF_BIT | rto_key_prim(RTO_KEY_U32, tl->sorted_keys[0]);
        } else if (tl->key_count > 1) {
            const size_t n = slot_count(tl->node_count, 0);
            pt->slots = n ? rto__alloc_large(n, sizeof *pt->slots) : NULL;
            ok = pt->slots != NULL;
            pa->bytes += n * sizeof *pt->slots;
            if (ok)
                copy_tree(&src, 0, pt->slots, stack, stack + depth + 2);
        }
    } else if (ok) {
        const rto_tlas_node *nodes = tl->sweep_nodes;
        const src_tree src = {2, NULL, nodes, (size_t)tl->n_padded - 1, NULL, NULL, NULL};
        pt->empty = nodes[0].item == RTO_TLAS_EMPTY;
        pt->root_box = 1;
        memcpy(pt->box, nodes[0].min, sizeof nodes[0].min);
        memcpy(pt->box + 3, nodes[0].max, sizeof nodes[0].max);
        if (!pt->empty && tl->n_padded == 1) {
            pt->root = RTO_BVH_LEAF_BIT | nodes[0].item;
        } else if (!pt->empty) {
            /* Internal nodes not EMPTY: at most n_padded - 1. */
            pt->slots = rto__alloc_large((size_t)tl->n_padded - 1, sizeof *pt->slots);
            ok = pt->slots != NULL;
            pa->bytes += ((size_t)tl->n_padded - 1) * sizeof *pt->slots;
            if (ok)
                copy_tree(&src, 0, pt->slots, stack, stack + depth + 2);
        }
    }
    free(stack);
    if (!ok) {
        packed_free(pa);
        return NULL;
    }
    return pa;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The traversal.                                                                                                     */

/* A ray against one node's two child boxes (rto__slab's operations, both children at once): bit 0 left hit, bit 1
 * right hit, among the children present; their entry t in t[0], t[1]. */
typedef struct vray {
    __m128 o[3], inv[3], t_min;
} vray;

static inline vray vray_make(const float o[3], const float inv[3], float t_min)
{
    vray v;
    for (int a = 0; a < 3; a++) {
        v.o[a] = _mm_set1_ps(o[a]);
        v.inv[a] = _mm_set1_ps(inv[a]);
    }
    v.t_min = _mm_set1_ps(t_min);
    return v;
}

static inline int slab_pair(const packed_node *n, const vray *r, float best_t, float t[2])
{
    __m128 lo[3], hi[3];
#pragma GCC unroll 3
    for (int a = 0; a < 3; a++) {
        /* {t0 left, t0 right, t1 left, t1 right} = (box - origin) * inverse direction, then min and max of t0, t1 */
        const __m128 v = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(&n->box[4 * a]), r->o[a]), r->inv[a]);
        const __m128 w = _mm_shuffle_ps(v, v, _MM_SHUFFLE(1, 0, 3, 2));
        lo[a] = _mm_min_ps(v, w);
        hi[a] = _mm_max_ps(v, w);
    }
    const __m128 near = _mm_max_ps(_mm_max_ps(_mm_max_ps(lo[0], lo[1]), lo[2]), r->t_min);
    const __m128 far = _mm_min_ps(_mm_min_ps(_mm_min_ps(hi[0], hi[1]), hi[2]), _mm_set1_ps(best_t));
    t[0] = _mm_cvtss_f32(near);
    t[1] = _mm_cvtss_f32(_mm_shuffle_ps(near, near, _MM_SHUFFLE(1, 1, 1, 1)));
    return _mm_movemask_ps(_mm_cmple_ps(near, far)) & 3;
}

/* Per-ray state, as the scalar tracer's. */
typedef struct pray {
    const rto_wf_ray *ray;
    float best_t;
    int found, done;
    uint32_t inst_hit, prim_hit;
    rto_tri_hit h;
    rto_trace_counters c;
    rto__trace_entry *tstack, *bstack;
} pray;

/* A node's hit children: the nearer (left on a tie) becomes *cur, the farther is pushed; 0 when none was hit. */
static inline int descend(const packed_node *n, int hit, const float t[2], rto__trace_entry *stack, size_t *top,
                          uint32_t *cur)
{
    if (hit == 3) {
        if (t[0] <= t[1]) {
            stack[(*top)++] = (rto__trace_entry){n->child[1], t[1]};
            *cur = n->child[0];
        } else {
            stack[(*top)++] = (rto__trace_entry){n->child[0], t[0]};
            *cur = n->child[1];
        }
        return 1;
    }
    /* Branches, not an index computed from the test: the CPU then fetches the predicted child while the test runs. */
    if (hit == 1) {
        *cur = n->child[0];
        return 1;
    }
    if (hit == 2) {
        *cur = n->child[1];
        return 1;
    }
    return 0;
}

/* Where a ray in turn (below) goes from a node, with no branch on the test: the child taken (the nearer of two hit,
 * left on a tie, the farther pushed) or, when none was hit, the top entry of the stack, taken without its check (its t
 * is checked when it is visited, against the same best t: nothing changes that in between). The farther child is
 * written to the stack always and kept only when both were hit (the stack has room: it never holds more than depth + 1
 * entries of its depth + 2). 1 when none was hit and the stack is empty. */
static inline int advance(const packed_node *n, int hit, const float t[2], rto__trace_entry *stack, size_t *top,
                          uint32_t *cur, float *cur_t)
{
    /* Selections as masks: written as conditionals, the compiler turns them back into branches. */
    const uint32_t both = hit == 3, any = hit != 0, c = (both & !(t[0] <= t[1])) | (hit == 2), m = 0u - any;
    const size_t at = *top, below = at - (at != 0);
    stack[at] = (rto__trace_entry){n->child[c ^ 1], t[c ^ 1]};
    const rto__trace_entry e = stack[below];
    uint32_t tc, et, bits;
    memcpy(&tc, &t[c], 4);
    memcpy(&et, &e.t, 4);
    *cur = (n->child[c] & m) | (e.ref & ~m);
    bits = (tc & m) | (et & ~m);
    memcpy(cur_t, &bits, 4);
    *top = below + ((at + both - below) & ((size_t)0 - any));
    return ((size_t)hit | at) == 0; /* one test: as !any && !at the compiler branches on any */
}

/* The top entry, unchecked, as advance takes it: 1 when the stack is empty. */
static inline int take(rto__trace_entry *stack, size_t *top, uint32_t *cur, float *cur_t)
{
    if (!*top)
        return 1;
    const rto__trace_entry e = stack[--*top];
    *cur = e.ref;
    *cur_t = e.t;
    return 0;
}

/* The next entry whose box still starts within the best t, or 0 when the stack is empty. */
static inline int pop(rto__trace_entry *stack, size_t *top, float best_t, uint32_t *cur)
{
    while (*top) {
        const rto__trace_entry e = stack[--*top];
        if (e.t > best_t)
            continue;
        *cur = e.ref;
        return 1;
    }
    return 0;
}

static inline void triangle(pray *st, const packed_tri *tri, const float o[3], const float d[3], uint32_t inst)
{
    const rto_wf_ray *ray = st->ray;
    rto_tri_hit h;
    st->c.triangle_tests++;
    if (rto__triangle_hit(&tri->v[0], &tri->v[3], &tri->v[6], o, d, ray->t_min, st->best_t, ray->flags, &h)) {
        st->best_t = h.t;
        st->h = h;
        st->inst_hit = inst;
        st->prim_hit = tri->prim;
        st->found = 1;
        st->done = (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
    }
}

/* The ray enters the BLAS of instance inst when its mask meets the ray's: the ray in object space (o, d) as
 * traverse.c's; a BLAS of one triangle is tested here. Returns the BLAS to walk from its root, or NULL when there is
 * no node to walk. */
static inline const packed_tree *blas_enter(const rto__tracer *tr, const packed_accel *pa, pray *st, uint32_t inst,
                                            float o[3], float d[3], float inv[3])
{
    const rto_instance *in = &tr->scene->instances[inst];
    if (!(in->mask & st->ray->cull_mask))
        return NULL;
    const packed_tree *pt = &pa->blas[in->blas];
    rto__ray_to_object(&in->world_to_obj, st->ray->origin, st->ray->dir, o, d);
    rto__ray_inv_dir(d, inv);
    st->c.instance_entries++;
    if (pt->root & RTO_BVH_LEAF_BIT) { /* no internal node: straight to the triangle */
        triangle(st, &pt->slots[pt->root & ~RTO_BVH_LEAF_BIT].tri, o, d, inst);
        return NULL;
    }
    return pt;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* One ray at a time, each to its end: where neighbouring rays are alike (primary and shadow rays) the branch        */
/* predictor learns the walk, and this order is the faster.                                                          */

static void trace_blas(const rto__tracer *tr, const packed_accel *pa, pray *st, uint32_t inst)
{
    float o[3], d[3], inv[3];
    const packed_tree *pt = blas_enter(tr, pa, st, inst, o, d, inv);
    if (!pt)
        return;
    const packed_slot *slots = pt->slots;
    const vray vr = vray_make(o, inv, st->ray->t_min);
    rto__trace_entry *stack = st->bstack;
    size_t top = 0;
    uint32_t cur = pt->root; /* entered without a box test of its own: its child boxes are the tests */
    for (;;) {
        st->c.nodes_visited++;
        if (cur & RTO_BVH_LEAF_BIT) {
            triangle(st, &slots[cur & ~RTO_BVH_LEAF_BIT].tri, o, d, inst);
            if (st->done)
                return;
        } else {
            const packed_node *n = &slots[cur].node;
            float t[2];
            st->c.box_tests += 2;
            if (descend(n, slab_pair(n, &vr, st->best_t, t), t, stack, &top, &cur))
                continue;
        }
        if (!pop(stack, &top, st->best_t, &cur))
            return;
    }
}

/* The ray's start in the TLAS: 0 when it ends there (an empty TLAS, the sweep root's box missed, a Karras TLAS of one
 * instance, walked here), else 1 with *cur the TLAS node to walk. */
static int tlas_start(const rto__tracer *tr, const packed_accel *pa, pray *st, const float winv[3], uint32_t *cur)
{
    const packed_tree *pt = &pa->tlas;
    const rto_wf_ray *ray = st->ray;
    if (pt->empty)
        return 0;
    *cur = pt->root;
    if (pt->root_box) { /* the sweep tree's root box is tested like any node */
        float t;
        st->c.box_tests++;
        return rto__slab(pt->box, pt->box + 3, ray->origin, winv, ray->t_min, st->best_t, &t);
    }
    if (*cur & RTO_BVH_LEAF_BIT) { /* a Karras tree of one key: straight to the instance */
        trace_blas(tr, pa, st, *cur & ~RTO_BVH_LEAF_BIT);
        return 0;
    }
    return 1;
}

static void trace_tlas(const rto__tracer *tr, const packed_accel *pa, pray *st, const float winv[3])
{
    const packed_tree *pt = &pa->tlas;
    uint32_t cur;
    if (!tlas_start(tr, pa, st, winv, &cur))
        return;
    const vray vr = vray_make(st->ray->origin, winv, st->ray->t_min);
    rto__trace_entry *stack = st->tstack;
    size_t top = 0;
    for (;;) {
        st->c.nodes_visited++;
        if (cur & RTO_BVH_LEAF_BIT) {
            trace_blas(tr, pa, st, cur & ~RTO_BVH_LEAF_BIT);
            if (st->done)
                return;
        } else {
            const packed_node *n = &pt->slots[cur].node;
            float t[2];
            st->c.box_tests += n->tests;
            if (descend(n, slab_pair(n, &vr, st->best_t, t) & (int)n->present, t, stack, &top, &cur))
                continue;
        }
        if (!pop(stack, &top, st->best_t, &cur))
            return;
    }
}

/* Starts a ray: its state reset. */
static inline void ray_reset(pray *st, const rto_wf_ray *ray)
{
    st->ray = ray;
    st->best_t = ray->t_max;
    st->found = 0;
    st->done = 0;
    memset(&st->c, 0, sizeof st->c);
}

/* Starts a ray: its state reset, its inverse direction. */
static inline void ray_begin(pray *st, const rto_wf_ray *ray, float winv[3])
{
    ray_reset(st, ray);
    rto__ray_inv_dir(ray->dir, winv);
}

/* The ray's record, stored in place (rto__hit_record_store). */
static inline void ray_record(const rto__tracer *tr, const pray *st, size_t i, rto_hit_record *hits)
{
    if (st->found)
        rto__hit_record_store(&hits[i], &tr->scene->instances[st->inst_hit], st->inst_hit, st->prim_hit, &st->h);
    else
        rto__hit_record_store_miss(&hits[i], st->ray->t_max);
}

/* The ray's record and counters. */
static inline void ray_end(const rto__tracer *tr, const pray *st, size_t i, rto_hit_record *hits,
                           rto_trace_counters *counters)
{
    ray_record(tr, st, i, hits);
    if (counters)
        counters[i] = st->c;
}

static void trace_one_at_a_time(const rto__tracer *tr, const packed_accel *pa, const rto_wf_ray *rays, size_t begin,
                                size_t end, rto_hit_record *hits, rto_trace_counters *counters,
                                rto__trace_entry *stacks)
{
    pray st;
    st.tstack = stacks;
    st.bstack = stacks + tr->stack_cap;
    for (size_t i = begin; i < end; i++) {
        float winv[3];
        ray_begin(&st, &rays[i], winv);
        trace_tlas(tr, pa, &st, winv);
        ray_end(tr, &st, i, hits, counters);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Rays in turn: RTO__TRACE_PACKED_STREAMS rays in flight, one node of each in turn, the next node of each prefetched */
/* when it is chosen, so that one ray's fetch from memory and its tests overlap the others'. A step has no branch on  */
/* its test (advance): a branch the predictor cannot learn would throw away the other rays' steps started behind it. */
/* Each ray's walk is the one above, node for node (the same pops, pushes, tests and counts): an entry taken from the */
/* stack is checked against the best t when it is visited instead of when it is taken, and a skipped entry is not    */
/* counted, as pop skips it; only the order in which the rays' steps run differs. Where neighbouring rays go separate */
/* ways (random rays), this order is the faster.                                                                      */

typedef struct stream {
    pray st;
    vray w, b;              /* the ray against TLAS nodes, and in object space against the BLAS in hand */
    float o[3], d[3];       /* the object-space ray, for triangles */
    const packed_slot *bslots;
    uint32_t inst, cur;     /* the BLAS's instance; the node (or leaf) visited next */
    float cur_t;            /* its entry t, checked when it is visited (-inf for a root: never skipped) */
    int in_blas;
    size_t ttop, btop, index;
} stream;

static inline void prefetch(const void *p) { _mm_prefetch((const char *)p, _MM_HINT_T0); }

/* What a TLAS reference visits next: an instance, or a node. */
static inline void prefetch_tlas(const rto__tracer *tr, const packed_accel *pa, uint32_t ref)
{
    if (ref & RTO_BVH_LEAF_BIT)
        prefetch(&tr->scene->instances[ref & ~RTO_BVH_LEAF_BIT]);
    else
        prefetch(&pa->tlas.slots[ref]);
}

/* The TLAS's next entry: 0, and prefetched; 1 when the ray is finished. */
static inline int stream_tlas_take(const rto__tracer *tr, const packed_accel *pa, stream *s)
{
    if (take(s->st.tstack, &s->ttop, &s->cur, &s->cur_t))
        return 1;
    prefetch_tlas(tr, pa, s->cur);
    return 0;
}

/* One node of the ray's walk (trace_tlas's and trace_blas's loop bodies): 1 when the ray is finished. */
static inline int stream_step(const rto__tracer *tr, const packed_accel *pa, stream *s)
{
    pray *st = &s->st;
    const int live = s->cur_t <= st->best_t; /* 0: an entry pop would skip, neither visited nor counted */
    float t[2];
    if (s->in_blas) {
        if (!(s->cur & RTO_BVH_LEAF_BIT)) {
            const packed_node *n = &s->bslots[s->cur].node;
            const int hit = slab_pair(n, &s->b, st->best_t, t) & -live;
            st->c.nodes_visited += (uint32_t)live;
            st->c.box_tests += 2u * (uint32_t)live;
            if (!advance(n, hit, t, st->bstack, &s->btop, &s->cur, &s->cur_t)) {
                prefetch(&s->bslots[s->cur & ~RTO_BVH_LEAF_BIT]);
                return 0;
            }
        } else {
            if (live) {
                st->c.nodes_visited++;
                triangle(st, &s->bslots[s->cur & ~RTO_BVH_LEAF_BIT].tri, s->o, s->d, s->inst);
                if (st->done)
                    return 1;
            }
            if (!take(st->bstack, &s->btop, &s->cur, &s->cur_t)) {
                prefetch(&s->bslots[s->cur & ~RTO_BVH_LEAF_BIT]);
                return 0;
            }
        }
        s->in_blas = 0; /* the BLAS is done: back to the TLAS's stack */
        return stream_tlas_take(tr, pa, s);
    }
    if (s->cur & RTO_BVH_LEAF_BIT) {
        if (live) {
            const uint32_t inst = s->cur & ~RTO_BVH_LEAF_BIT;
            float inv[3];
            st->c.nodes_visited++;
            const packed_tree *pt = blas_enter(tr, pa, st, inst, s->o, s->d, inv);
            if (pt) {
                s->b = vray_make(s->o, inv, st->ray->t_min);
                s->bslots = pt->slots;
                s->inst = inst;
                s->btop = 0;
                s->cur = pt->root;
                s->cur_t = -INFINITY;
                s->in_blas = 1;
                prefetch(&pt->slots[pt->root]);
                return 0;
            }
            if (st->done)
                return 1;
        }
        return stream_tlas_take(tr, pa, s);
    }
    const packed_node *n = &pa->tlas.slots[s->cur].node;
    const int hit = slab_pair(n, &s->w, st->best_t, t) & (int)n->present & -live;
    st->c.nodes_visited += (uint32_t)live;
    st->c.box_tests += n->tests & (0u - (uint32_t)live);
    if (advance(n, hit, t, st->tstack, &s->ttop, &s->cur, &s->cur_t))
        return 1;
    prefetch_tlas(tr, pa, s->cur);
    return 0;
}

/* Takes rays from *next on until one has a walk ahead (its record is written by then for those that had none):
 * 1 when s holds that ray, 0 when the range is used up. */
static int stream_load(const rto__tracer *tr, const packed_accel *pa, stream *s, const rto_wf_ray *rays,
                       size_t *next, size_t end, rto_hit_record *hits, rto_trace_counters *counters)
{
    while (*next < end) {
        const size_t i = (*next)++;
        float winv[3];
        ray_begin(&s->st, &rays[i], winv);
        if (!tlas_start(tr, pa, &s->st, winv, &s->cur)) {
            ray_end(tr, &s->st, i, hits, counters);
            continue;
        }
        s->w = vray_make(rays[i].origin, winv, rays[i].t_min);
        s->cur_t = -INFINITY;
        s->index = i;
        s->in_blas = 0;
        s->ttop = 0;
        return 1;
    }
    return 0;
}

static void trace_in_turn(const rto__tracer *tr, const packed_accel *pa, const rto_wf_ray *rays, size_t begin,
                          size_t end, rto_hit_record *hits, rto_trace_counters *counters, rto__trace_entry *stacks)
{
    stream s[RTO__TRACE_PACKED_STREAMS];
    int live[RTO__TRACE_PACKED_STREAMS], in_flight = 0;
    size_t next = begin;
    for (int j = 0; j < RTO__TRACE_PACKED_STREAMS; j++) {
        s[j].st.tstack = stacks + (size_t)j * 2 * tr->stack_cap;
        s[j].st.bstack = s[j].st.tstack + tr->stack_cap;
        live[j] = stream_load(tr, pa, &s[j], rays, &next, end, hits, counters);
        in_flight += live[j];
    }
    while (in_flight) {
        for (int j = 0; j < RTO__TRACE_PACKED_STREAMS; j++) {
            if (!live[j] || !stream_step(tr, pa, &s[j]))
                continue;
            ray_end(tr, &s[j].st, s[j].index, hits, counters);
            live[j] = stream_load(tr, pa, &s[j], rays, &next, end, hits, counters);
            in_flight -= !live[j];
        }
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Rays in groups (trace/groups_kernel.h): 8 with AVX2, 16 with AVX-512, compiled for those instruction sets function */
/* by function as trace/lanes.c's kernels are, and run only where rto__trace_packed_order_supported says so.         */

static inline int lanes_in(uint32_t m)
{
    m = m - ((m >> 1) & 0x5555u);
    m = (m & 0x3333u) + ((m >> 2) & 0x3333u);
    m = (m + (m >> 4)) & 0x0f0fu;
    return (int)((m + (m >> 8)) & 0x1fu);
}

#define PN_(p, x) p##_##x
#define PN__(p, x) PN_(p, x)
#define PN(x) PN__(GROUP_PREFIX, x)
#define LANES_IN lanes_in

RTO__TARGET_BEGIN("avx2")
/* v + k in the lanes of bit mask m. */
static inline __m256i add_lanes8(__m256i v, uint32_t m, int k)
{
    const __m256i bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const __m256i in = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32((int)m), bits), bits);
    return _mm256_add_epi32(v, _mm256_and_si256(in, _mm256_set1_epi32(k)));
}
#define VEC_AVX2
#include "vec_ops.h"
#define GROUP_PREFIX group8
#define VI_ADD add_lanes8
#include "groups_kernel.h"
#undef GROUP_PREFIX
#undef VI_ADD
#include "vec_ops_end.h"
RTO__TARGET_END

RTO__TARGET_BEGIN("avx512f,avx512bw,avx512dq,avx512vl")
#define VEC_AVX512
#include "vec_ops.h"
#define GROUP_PREFIX group16
#define VI_ADD(v, m, k) _mm512_mask_add_epi32((v), (__mmask16)(m), (v), _mm512_set1_epi32(k))
#include "groups_kernel.h"
#undef GROUP_PREFIX
#undef VI_ADD
#include "vec_ops_end.h"
RTO__TARGET_END

/* ---------------------------------------------------------------------------------------------------------------- */

/* Whether more than a quarter of neighbouring rays point more than 60 degrees apart, from up to 1024 pairs spread
 * over the range (a cheap look: it only picks the faster order, never the bytes). */
static int rays_diverge(const rto_wf_ray *rays, size_t begin, size_t end)
{
    if (end - begin < 2)
        return 0;
    const size_t pairs = end - begin - 1, stride = (pairs + 1023) / 1024;
    size_t looked = 0, apart = 0;
    for (size_t i = begin; i + 1 < end; i += stride, looked++) {
        const float *a = rays[i].dir, *b = rays[i + 1].dir;
        const float ab = rto__dot3(a, b), aa = rto__dot3(a, a), bb = rto__dot3(b, b);
        apart += !(ab > 0.0f) || 4.0f * ab * ab < aa * bb;
    }
    return 4 * apart > looked;
}

/* The widest groups RTO_TRACE_GROUPS allows: "8" what a CPU with AVX2 and without AVX-512 runs, "1" what a CPU
 * without AVX2 runs (one ray at a time); unset or anything else, no cap. */
static int groups_cap(void)
{
    const char *want = getenv("RTO_TRACE_GROUPS");
    return want && strcmp(want, "1") == 0 ? 1 : want && strcmp(want, "8") == 0 ? 8 : 16;
}

rto__trace_order rto__trace_packed_order(size_t tree_bytes, const rto_wf_ray *rays, size_t begin, size_t end)
{
    if (rays_diverge(rays, begin, end))
        return tree_bytes > RTO__TRACE_PACKED_CACHE ? RTO__ORDER_IN_TURN : RTO__ORDER_ONE;
    const int cap = groups_cap();
    return cap >= 16 && rto__cpu_avx512() ? RTO__ORDER_GROUPS_16
           : cap >= 8 && rto__cpu_avx2()  ? RTO__ORDER_GROUPS_8
                                          : RTO__ORDER_ONE;
}

size_t rto__trace_packed_bytes(const void *trees) { return ((const packed_accel *)trees)->bytes; }

size_t rto__trace_packed_scratch(size_t stack_cap)
{
    size_t size = RTO__TRACE_PACKED_STREAMS * 2 * stack_cap * sizeof(rto__trace_entry);
    const size_t groups[2] = {group8_scratch_size(stack_cap), group16_scratch_size(stack_cap)};
    for (int k = 0; k < 2; k++)
        size = groups[k] > size ? groups[k] : size;
    return size;
}

int rto__trace_packed_order_supported(rto__trace_order order)
{
    return order == RTO__ORDER_GROUPS_16 ? rto__cpu_avx512() : order == RTO__ORDER_GROUPS_8 ? rto__cpu_avx2() : 1;
}

int rto__trace_packed_built(void) { return 1; }

const void *rto__trace_packed_trees(const rto_accel *accel, int make)
{
    return make ? rto__accel_derived(accel, packed_make, packed_free) : rto__accel_derived(accel, NULL, NULL);
}

int rto__trace_packed_worth(const rto_accel *accel, uint64_t n, uint32_t threads)
{
    const rto_accel_tlas *tl = rto_accel_get_tlas(accel);
    size_t slots = tl->kind == RTO_TLAS_KARRAS ? tl->node_count : (size_t)tl->n_padded;
    for (uint32_t m = 0; m < rto_accel_blas_count(accel); m++)
        slots += 2 * (size_t)rto_accel_get_blas(accel, m)->triangle_count;
    return n / (threads ? threads : 1) >= (uint64_t)slots;
}

void rto__trace_packed(const rto__tracer *tr, const void *trees, const rto_wf_ray *rays, size_t begin, size_t end,
                       rto_hit_record *hits, rto_trace_counters *counters, rto__trace_entry *stacks)
{
    const rto__trace_order order = tr->order == RTO__ORDER_AUTO
                                       ? rto__trace_packed_order(rto__trace_packed_bytes(trees), rays, begin, end)
                                       : tr->order;
    if (order == RTO__ORDER_GROUPS_16)
        group16_trace(tr, trees, rays, begin, end, hits, counters, stacks);
    else if (order == RTO__ORDER_GROUPS_8)
        group8_trace(tr, trees, rays, begin, end, hits, counters, stacks);
    else if (order == RTO__ORDER_IN_TURN)
        trace_in_turn(tr, trees, rays, begin, end, hits, counters, stacks);
    else
        trace_one_at_a_time(tr, trees, rays, begin, end, hits, counters, stacks);
}

#else

int rto__trace_packed_built(void) { return 0; }

const void *rto__trace_packed_trees(const rto_accel *accel, int make)
{
    (void)accel, (void)make;
    return NULL;
}

int rto__trace_packed_worth(const rto_accel *accel, uint64_t n, uint32_t threads)
{
    (void)accel, (void)n, (void)threads;
    return 0;
}

rto__trace_order rto__trace_packed_order(size_t tree_bytes, const rto_wf_ray *rays, size_t begin, size_t end)
{
    (void)tree_bytes, (void)rays, (void)begin, (void)end;
    return RTO__ORDER_ONE;
}

size_t rto__trace_packed_bytes(const void *trees)
{
    (void)trees;
    return 0;
}

size_t rto__trace_packed_scratch(size_t stack_cap)
{
    (void)stack_cap;
    return 0;
}

int rto__trace_packed_order_supported(rto__trace_order order)
{
    (void)order;
    return 0;
}

void rto__trace_packed(const rto__tracer *tr, const void *trees, const rto_wf_ray *rays, size_t begin, size_t end,
                       rto_hit_record *hits, rto_trace_counters *counters, rto__trace_entry *stacks)
{
    (void)tr, (void)trees, (void)rays, (void)begin, (void)end, (void)hits, (void)counters, (void)stacks;
}

#endif
