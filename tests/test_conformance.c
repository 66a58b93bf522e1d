/* The conformance model of DESIGN.md §9 from the GPU's side: simulated GPUs written here, not calling src/trace/,
 * run §6 — Möller–Trumbore, the ray transform, culling, masks and TERMINATE_ON_FIRST_HIT, by brute force (every
 * triangle of every visible instance, no box test) or by §6's traversal of the accel's own trees (sweep or Karras
 * TLAS, the BLAS, slab tests and all) — with the freedoms the model grants: every a*b + c fused or not (the first or
 * the second product of each sum, or a choice per site from a PRNG) and the reciprocal moved by up to 2 ulp.
 * check-hits must accept every record of every one of them, over every fixture, sphere:L, random:N triangle soups
 * (slivers included) and rtstress:2, with generated ray sets and rays made here at vertices, on edges, starting on
 * surfaces and ending at a hit's t, with cull flags and masks. Without freedoms the traversal must equal the oracle's
 * records and counters bit for bit; a record off by twice the model's bound must fail, field by field; and each GPU
 * fault of the corpus, planted in the simulated traversal, must be caught and named at the first ray it changes. */
#include "testutil.h"

#include "trace/conform.h"

/* ------------------------------------------------------------------------------------------------------------------ */
/* A simulated GPU                                                                                                    */

typedef enum fuse { FUSE_NONE = 0, FUSE_FIRST = 1, FUSE_SECOND = 2, FUSE_RANDOM = 3 } fuse;

typedef struct sim {
    fuse fuse;
    int div_ulps; /* the reciprocal moved by this many ulps (each within WGSL's 2.5) */
    uint64_t rng; /* FUSE_RANDOM's choices */
    int tree;     /* 0: brute force; 1: §6's traversal of the sweep TLAS and the BLAS; 2: of the Karras TLAS */
    int fault;    /* a planted GPU fault (gpu_fault, the fault corpus); 0 for a conforming GPU */
} sim;

/* Faults a GPU's trace kernel may have: the fault corpus every verdict must catch and name. */
typedef enum gpu_fault {
    GF_NONE = 0,
    GF_TIE_LATER,        /* t <= bestT: of equal t, the later triangle (a freedom of §9, not a fault: named a tie) */
    GF_TRANSLATION_FIRST, /* the ray transform adds the translation first: ((m3 + m0 x) + m1 y) + m2 z */
    GF_SWAP_UV,          /* u and v swapped in the record */
    GF_NO_TMIN,          /* tMin dropped from the triangle test */
    GF_CULL_WRONG,       /* CULL_BACK_FACING culls front faces */
    GF_CULL_IGNORED,     /* culling flags ignored: back faces hit under CULL_BACK_FACING */
    GF_MASK_IGNORED,     /* instances entered whatever their mask */
    GF_CUSTOM_INDEX,     /* customIndex of the next instance */
    GF_HIT_GROUP,        /* hitGroup from the mask */
    GF_OBJ_TO_WORLD,     /* objToWorld's column 2, row 1 (m[1][2]) written from m[2][1]: one transposed element */
    GF_COUNT
} gpu_fault;

static const char *const tree_names[] = {"brute force", "sweep TLAS", "Karras TLAS"};

static const char *const fuse_names[] = {"none", "first", "second", "random"};

static int fuse_choice(sim *s)
{
    if (s->fuse != FUSE_RANDOM)
        return (int)s->fuse;
    return (int)(tu_rng_next(&s->rng) % 3);
}

/* a*b + c*d as a GPU may evaluate it (this file is compiled with -ffp-contract=off: only fmaf fuses) */
static float sum2(sim *s, float a, float b, float c, float d)
{
    switch (fuse_choice(s)) {
    case 1: return fmaf(a, b, c * d);
    case 2: return fmaf(c, d, a * b);
    default: return a * b + c * d;
    }
}

/* x + a*b, the last step of a dot product or a transform row */
static float plus(sim *s, float x, float a, float b) { return fuse_choice(s) ? fmaf(a, b, x) : x + a * b; }

static float dot(sim *s, const float a[3], const float b[3])
{
    return plus(s, sum2(s, a[0], b[0], a[1], b[1]), a[2], b[2]);
}

static void cross(sim *s, const float a[3], const float b[3], float o[3])
{
    o[0] = sum2(s, a[1], b[2], -a[2], b[1]);
    o[1] = sum2(s, a[2], b[0], -a[0], b[2]);
    o[2] = sum2(s, a[0], b[1], -a[1], b[0]);
}

static float recip(const sim *s, float x)
{
    float r = 1.0f / x;
    for (int k = 0; k < abs(s->div_ulps); k++)
        r = nextafterf(r, s->div_ulps > 0 ? INFINITY : -INFINITY);
    return r;
}

typedef struct sim_hit {
    float t, u, v, det;
} sim_hit;

static int sim_triangle(sim *s, const float *v0, const float *v1, const float *v2, const float o[3], const float d[3],
                        float t_min, float best, sim_hit *h)
{
    float e1[3], e2[3], p[3], sv[3], q[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = v1[a] - v0[a];
        e2[a] = v2[a] - v0[a];
        sv[a] = o[a] - v0[a];
    }
    cross(s, d, e2, p);
    h->det = dot(s, e1, p);
    if (h->det == 0.0f)
        return 0;
    const float inv = recip(s, h->det);
    cross(s, sv, e1, q);
    h->u = dot(s, sv, p) * inv;
    h->v = dot(s, d, q) * inv;
    h->t = dot(s, e2, q) * inv;
    if (s->fault == GF_TIE_LATER)
        return h->u >= 0.0f && h->v >= 0.0f && h->u + h->v <= 1.0f && t_min <= h->t && h->t <= best;
    if (s->fault == GF_NO_TMIN)
        return h->u >= 0.0f && h->v >= 0.0f && h->u + h->v <= 1.0f && h->t < best;
    return h->u >= 0.0f && h->v >= 0.0f && h->u + h->v <= 1.0f && t_min <= h->t && h->t < best;
}

/* The simulator's own shortcut, which changes no answer: triangles whose box, grown by a margin far beyond any
 * rounding (1e-3 of the box's size and position), the object-space ray misses in binary64 are skipped. */
typedef struct tri_box {
    double lo[3], hi[3];
} tri_box;

static tri_box *mesh_boxes(const rto_mesh *m)
{
    tri_box *b = calloc(m->triangle_count ? m->triangle_count : 1, sizeof *b);
    assert_non_null(b);
    for (uint32_t p = 0; p < m->triangle_count; p++) {
        double scale = 1.0;
        for (int a = 0; a < 3; a++) {
            b[p].lo[a] = INFINITY;
            b[p].hi[a] = -INFINITY;
            for (int c = 0; c < 3; c++) {
                const double v = m->positions[3 * (size_t)m->indices[3 * (size_t)p + c] + a];
                b[p].lo[a] = fmin(b[p].lo[a], v);
                b[p].hi[a] = fmax(b[p].hi[a], v);
                scale = fmax(scale, fabs(v));
            }
        }
        for (int a = 0; a < 3; a++) {
            const double grow = 1e-3 * (scale + b[p].hi[a] - b[p].lo[a]);
            b[p].lo[a] -= grow;
            b[p].hi[a] += grow;
        }
    }
    return b;
}

static int box_missed(const tri_box *b, const float o[3], const float d[3], float t_min, float t_max)
{
    double near = t_min, far = t_max;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0f) {
            if (o[a] < b->lo[a] || o[a] > b->hi[a])
                return 1;
            continue;
        }
        const double inv = 1.0 / d[a], t0 = (b->lo[a] - o[a]) * inv, t1 = (b->hi[a] - o[a]) * inv;
        const double lo = t0 < t1 ? t0 : t1, hi = t0 < t1 ? t1 : t0;
        near = lo > near ? lo : near;
        far = hi < far ? hi : far;
    }
    /* t itself may be off by rounding too: a generous slack on the range */
    return near > far + 1e-3 * (1.0 + fabs(far));
}

/* One ray, brute force: every instance the cull mask admits, every triangle, in order, strict t < best. boxes: one
 * array per mesh (mesh_boxes). */
static rto_hit_record sim_trace(sim *s, const rto_scene *sc, tri_box *const *boxes, const rto_wf_ray *ray)
{
    rto_hit_record best = tu_miss_record(ray->t_max);
    float best_t = ray->t_max;
    for (uint32_t k = 0; k < sc->instance_count; k++) {
        const rto_instance *in = &sc->instances[k];
        if (!(in->mask & ray->cull_mask))
            continue;
        const float(*m)[4] = in->world_to_obj.m;
        float o[3], d[3];
        for (int r = 0; r < 3; r++) {
            o[r] = plus(s, sum2(s, m[r][0], ray->origin[0], m[r][1], ray->origin[1]), m[r][2], ray->origin[2]) +
                   m[r][3];
            d[r] = plus(s, sum2(s, m[r][0], ray->dir[0], m[r][1], ray->dir[1]), m[r][2], ray->dir[2]);
        }
        const rto_mesh *mesh = &sc->meshes[in->blas];
        for (uint32_t p = 0; p < mesh->triangle_count; p++) {
            if (box_missed(&boxes[in->blas][p], o, d, ray->t_min, best_t))
                continue;
            const uint32_t *ix = &mesh->indices[3 * (size_t)p];
            sim_hit h;
            if (!sim_triangle(s, &mesh->positions[3 * (size_t)ix[0]], &mesh->positions[3 * (size_t)ix[1]],
                              &mesh->positions[3 * (size_t)ix[2]], o, d, ray->t_min, best_t, &h))
                continue;
            if (((ray->flags & RTO_RAY_FLAG_CULL_BACK_FACING) && h.det < 0.0f) ||
                ((ray->flags & RTO_RAY_FLAG_CULL_FRONT_FACING) && h.det > 0.0f))
                continue;
            best = tu_hit_record(in, k, p, h.t, h.u, h.v);
            best_t = h.t;
            if (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT)
                return best;
        }
    }
    return best;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* A simulated GPU traversing the accel's own trees (the bytes a build bundle holds), §6 as DESIGN.md states it      */

/* §2: a direction component below 1e-20 in magnitude becomes copysign(1e-20, d), +1e-20 for +-0, before 1 / d */
static float sim_inv(const sim *s, float d)
{
    const float c = d == 0.0f ? 1e-20f : fabsf(d) < 1e-20f ? copysignf(1e-20f, d) : d;
    return recip(s, c);
}

/* tNear = max(max3(min(t0, t1)), tMin), tFar = min(min3(max(t0, t1)), bestT); hit iff tNear <= tFar */
static int sim_slab(const float mn[3], const float mx[3], const float o[3], const float inv[3], float t_min,
                    float best, float *t_near)
{
    float near = -INFINITY, far = INFINITY;
    for (int a = 0; a < 3; a++) {
        const float t0 = (mn[a] - o[a]) * inv[a], t1 = (mx[a] - o[a]) * inv[a];
        near = fmaxf(near, fminf(t0, t1));
        far = fminf(far, fmaxf(t0, t1));
    }
    near = fmaxf(near, t_min);
    far = fminf(far, best);
    *t_near = near;
    return near <= far;
}

typedef struct sim_stack {
    uint32_t ref[256];
    float t[256];
    int n;
} sim_stack;

static void sim_push(sim_stack *st, uint32_t ref, float t)
{
    assert_true(st->n < 256);
    st->ref[st->n] = ref;
    st->t[st->n++] = t;
}

/* Both children of an internal node: push the farther (if hit), then the nearer; equal entry t: the left first. */
static void sim_children(sim_stack *st, int hl, float tl, uint32_t l, int hr, float tr, uint32_t r)
{
    if (hl && hr) {
        if (tr < tl) {
            sim_push(st, l, tl);
            sim_push(st, r, tr);
        } else {
            sim_push(st, r, tr);
            sim_push(st, l, tl);
        }
    } else if (hl) {
        sim_push(st, l, tl);
    } else if (hr) {
        sim_push(st, r, tr);
    }
}

typedef struct sim_best {
    rto_hit_record rec;
    float t;
    int done;              /* TERMINATE_ON_FIRST_HIT found one */
    rto_trace_counters c;  /* §6's counters, counted as DESIGN.md states them */
} sim_best;

static void sim_triangle_of(sim *s, const rto_scene *sc, uint32_t k, uint32_t p, const float o[3], const float d[3],
                            const rto_wf_ray *ray, sim_best *b)
{
    const rto_instance *in = &sc->instances[k];
    const rto_mesh *mesh = &sc->meshes[in->blas];
    const uint32_t *ix = &mesh->indices[3 * (size_t)p];
    sim_hit h;
    b->c.triangle_tests++;
    if (!sim_triangle(s, &mesh->positions[3 * (size_t)ix[0]], &mesh->positions[3 * (size_t)ix[1]],
                      &mesh->positions[3 * (size_t)ix[2]], o, d, ray->t_min, b->t, &h))
        return;
    const float back = s->fault == GF_CULL_WRONG ? -h.det : h.det;
    if (s->fault != GF_CULL_IGNORED && (((ray->flags & RTO_RAY_FLAG_CULL_BACK_FACING) && back < 0.0f) ||
                                        ((ray->flags & RTO_RAY_FLAG_CULL_FRONT_FACING) && h.det > 0.0f)))
        return;
    b->rec = tu_hit_record(in, k, p, h.t, h.u, h.v);
    switch (s->fault) {
    case GF_SWAP_UV:
        b->rec.bary[0] = h.v;
        b->rec.bary[1] = h.u;
        break;
    case GF_CUSTOM_INDEX: b->rec.custom_index = sc->instances[(k + 1) % sc->instance_count].custom_index; break;
    case GF_HIT_GROUP: b->rec.hit_group = in->mask; break;
    case GF_OBJ_TO_WORLD: b->rec.obj_to_world[2][1] = in->obj_to_world.m[2][1]; break;
    default: break;
    }
    b->t = h.t;
    b->done = (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
}

/* The ray through instance k's worldToObj as the simulator evaluates it (rows ((m0 x + m1 y) + m2 z) + m3) */
static void sim_object_ray(sim *s, const rto_instance *in, const rto_wf_ray *ray, float o[3], float d[3])
{
    const float(*m)[4] = in->world_to_obj.m;
    for (int r = 0; r < 3; r++) {
        o[r] = plus(s, sum2(s, m[r][0], ray->origin[0], m[r][1], ray->origin[1]), m[r][2], ray->origin[2]) + m[r][3];
        if (s->fault == GF_TRANSLATION_FIRST)
            o[r] = ((m[r][3] + m[r][0] * ray->origin[0]) + m[r][1] * ray->origin[1]) + m[r][2] * ray->origin[2];
        d[r] = plus(s, sum2(s, m[r][0], ray->dir[0], m[r][1], ray->dir[1]), m[r][2], ray->dir[2]);
    }
}

/* One instance's BLAS, run to its end with the shared best t */
static void sim_blas(sim *s, const rto_scene *sc, const rto_accel *acc, uint32_t k, const rto_wf_ray *ray,
                     sim_best *b)
{
    const rto_instance *in = &sc->instances[k];
    if (!(in->mask & ray->cull_mask) && s->fault != GF_MASK_IGNORED)
        return;
    const rto_accel_blas *bl = rto_accel_get_blas(acc, in->blas);
    if (!bl->triangle_count)
        return;
    float o[3], d[3], inv[3];
    sim_object_ray(s, in, ray, o, d);
    for (int a = 0; a < 3; a++)
        inv[a] = sim_inv(s, d[a]);
    b->c.instance_entries++;
    if (bl->triangle_count == 1) {
        sim_triangle_of(s, sc, k, bl->order[0], o, d, ray, b);
        return;
    }
    sim_stack st = {.n = 0};
    sim_push(&st, 0, ray->t_min);
    while (st.n && !b->done) {
        st.n--;
        const uint32_t ref = st.ref[st.n];
        if (st.t[st.n] > b->t)
            continue;
        b->c.nodes_visited++;
        if (ref & RTO_BVH_LEAF_BIT) {
            sim_triangle_of(s, sc, k, bl->order[ref & ~RTO_BVH_LEAF_BIT], o, d, ray, b);
            continue;
        }
        const rto_bvh_node *nd = &bl->nodes[ref];
        float tl, tr;
        b->c.box_tests += 2;
        const int hl = sim_slab(nd->lmin, nd->lmax, o, inv, ray->t_min, b->t, &tl);
        const int hr = sim_slab(nd->rmin, nd->rmax, o, inv, ray->t_min, b->t, &tr);
        sim_children(&st, hl, tl, nd->left, hr, tr, nd->right);
    }
}

/* The whole traversal: TLAS (sweep or Karras, as built), then each instance's BLAS */
static rto_hit_record sim_tree_trace(sim *s, const rto_scene *sc, const rto_accel *acc, const rto_wf_ray *ray,
                                     rto_trace_counters *counters)
{
    const rto_accel_tlas *tl = rto_accel_get_tlas(acc);
    sim_best b = {tu_miss_record(ray->t_max), ray->t_max, 0, {0, 0, 0, 0}};
    *counters = (rto_trace_counters){0, 0, 0, 0};
    float inv[3];
    for (int a = 0; a < 3; a++)
        inv[a] = sim_inv(s, ray->dir[a]);
    sim_stack st = {.n = 0};
    if (tl->kind == RTO_TLAS_SWEEP) {
        const rto_tlas_node *nodes = tl->sweep_nodes;
        const uint32_t first_leaf = tl->n_padded - 1;
        float t0;
        if (nodes[0].item != RTO_TLAS_EMPTY && (b.c.box_tests++, 1) &&
            sim_slab(nodes[0].min, nodes[0].max, ray->origin, inv, ray->t_min, b.t, &t0))
            sim_push(&st, 0, t0);
        while (st.n && !b.done) {
            st.n--;
            const uint32_t i = st.ref[st.n];
            if (st.t[st.n] > b.t)
                continue;
            b.c.nodes_visited++;
            if (i >= first_leaf) {
                sim_blas(s, sc, acc, nodes[i].item, ray, &b);
                continue;
            }
            const uint32_t l = 2 * i + 1, r = 2 * i + 2;
            float tlft = 0, trgt = 0;
            int hl = 0, hr = 0;
            if (nodes[l].item != RTO_TLAS_EMPTY) {
                b.c.box_tests++;
                hl = sim_slab(nodes[l].min, nodes[l].max, ray->origin, inv, ray->t_min, b.t, &tlft);
            }
            if (nodes[r].item != RTO_TLAS_EMPTY) {
                b.c.box_tests++;
                hr = sim_slab(nodes[r].min, nodes[r].max, ray->origin, inv, ray->t_min, b.t, &trgt);
            }
            sim_children(&st, hl, tlft, l, hr, trgt, r);
        }
        *counters = b.c;
        return b.rec;
    }
    if (tl->key_count == 0)
        return b.rec;
    if (tl->key_count == 1) {
        sim_blas(s, sc, acc, tl->sorted_keys[0] & 0xFFFF, ray, &b);
        *counters = b.c;
        return b.rec;
    }
    sim_push(&st, 0, ray->t_min);
    while (st.n && !b.done) {
        st.n--;
        const uint32_t ref = st.ref[st.n];
        if (st.t[st.n] > b.t)
            continue;
        b.c.nodes_visited++;
        if (ref & RTO_BVH_LEAF_BIT) {
            sim_blas(s, sc, acc, tl->sorted_keys[ref & ~RTO_BVH_LEAF_BIT] & 0xFFFF, ray, &b);
            continue;
        }
        const rto_bvh_node *nd = &tl->karras_nodes[ref];
        float tlft, trgt;
        b.c.box_tests += 2;
        const int hl = sim_slab(nd->lmin, nd->lmax, ray->origin, inv, ray->t_min, b.t, &tlft);
        const int hr = sim_slab(nd->rmin, nd->rmax, ray->origin, inv, ray->t_min, b.t, &trgt);
        sim_children(&st, hl, tlft, nd->left, hr, trgt, nd->right);
    }
    *counters = b.c;
    return b.rec;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Rays                                                                                                               */

/* Rays made_rays makes per triangle, at most */
#define MADE_PER 7

/* Rays made here for n random triangles: at a vertex, at an edge's midpoint, from a point on the triangle itself
 * (a surface start, tMin 0) outwards and inwards, and through the inside with tMax set to 1.0 (ending at the plane
 * when the origin is one unit away). Flags vary: culling, first hit; and cull masks. */
static size_t made_rays(const rto_scene *sc, uint64_t seed, size_t n, rto_wf_ray *out)
{
    size_t m = 0;
    static const uint32_t flag_sets[] = {RTO_RAY_FLAG_OPAQUE, RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_CULL_BACK_FACING,
                                         RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_CULL_FRONT_FACING,
                                         RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT};
    for (size_t i = 0; i < n; i++) {
        const uint32_t k = (uint32_t)(tu_rng_next(&seed) % sc->instance_count);
        const rto_mesh *mesh = &sc->meshes[sc->instances[k].blas];
        if (!mesh->triangle_count)
            continue;
        const uint32_t p = (uint32_t)(tu_rng_next(&seed) % mesh->triangle_count);
        double w[3][3];
        for (int c = 0; c < 3; c++)
            tu_world_vertex(sc, k, p, c, w[c]);
        double targets[3][3];
        const int c = (int)(tu_rng_next(&seed) % 3);
        for (int a = 0; a < 3; a++) {
            targets[0][a] = w[c][a];                             /* a vertex */
            targets[1][a] = 0.5 * (w[c][a] + w[(c + 1) % 3][a]); /* an edge's midpoint */
            targets[2][a] = (w[0][a] + w[1][a] + w[2][a]) / 3;   /* the centroid */
        }
        const uint32_t flags = flag_sets[tu_rng_next(&seed) % 4];
        /* one group in three sees some instances only */
        const uint32_t cull = tu_rng_next(&seed) % 3 ? 0xFF : (uint32_t)(1 + tu_rng_next(&seed) % 255);
        for (int t = 0; t < 3; t++) {
            double d[3], o[3];
            tu_rng_dir(&seed, d);
            for (int a = 0; a < 3; a++)
                o[a] = targets[t][a] - 2.0 * d[a];
            out[m] = tu_ray(o, d, 0.0f, 1e30f, flags);
            out[m++].cull_mask = cull;
        }
        /* surface starts, both ways */
        double d[3];
        tu_rng_dir(&seed, d);
        out[m++] = tu_ray(targets[2], d, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE);
        const double back[3] = {-d[0], -d[1], -d[2]};
        out[m++] = tu_ray(targets[2], back, 0.0f, 1e30f, RTO_RAY_FLAG_OPAQUE);
        /* ending at the plane: the ray from one unit away along -n with tMax 1 */
        double e1[3], e2[3], nrm[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = w[1][a] - w[0][a];
            e2[a] = w[2][a] - w[0][a];
        }
        nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
        const double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        if (len > 0) {
            double o[3], dn[3];
            for (int a = 0; a < 3; a++) {
                dn[a] = -nrm[a] / len;
                o[a] = targets[2][a] - dn[a];
            }
            out[m++] = tu_ray(o, dn, 0.0f, 1.0f, RTO_RAY_FLAG_OPAQUE);
            out[m++] = tu_ray(o, dn, 1.0f, 1e30f, RTO_RAY_FLAG_OPAQUE); /* starting at the plane */
        }
    }
    return m;
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The family                                                                                                         */

typedef struct family_totals {
    size_t rays, records, differing;
} family_totals;

/* check-hits' description of n rays of a scene, their expected records and a GPU's. */
static rto_hits_check_desc hits_desc(const rto_scene *sc, const rto_wf_ray *rays, size_t n,
                                     const rto_hit_record *expected, const rto_hit_record *gpu)
{
    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = rays;
    d.ray_count = n;
    d.expected = expected;
    d.gpu = gpu;
    d.gpu_count = n;
    d.instances = sc->instances;
    d.instance_count = sc->instance_count;
    d.meshes = sc->meshes;
    d.mesh_count = sc->mesh_count;
    return d;
}

/* Traces the rays with the oracle and with each simulated GPU; check-hits must accept every GPU. accs: the scene's
 * accel with the sweep TLAS (the oracle's) and with the Karras TLAS. */
static void run_case(const rto_scene *sc, tri_box *const *boxes, rto_accel *const accs[2], const char *spec,
                     const char *set, const rto_wf_ray *rays, size_t n, const sim *sims, size_t nsims,
                     family_totals *tot)
{
    char label[160];
    snprintf(label, sizeof label, "%s %s", spec, set);
    rto_hit_record *expected = calloc(n ? n : 1, sizeof *expected), *gpu = calloc(n ? n : 1, sizeof *gpu);
    assert_true(expected && gpu);
    rto_msg msg = {{0}};
    if (rto_trace(accs[0], rays, n, NULL, expected, NULL, &msg))
        fail_msg("%s: rto_trace: %s", label, msg.text);
    size_t differing = 0, hits = 0;
    for (size_t i = 0; i < n; i++)
        hits += expected[i].miss_flag == 0;
    for (size_t v = 0; v < nsims; v++) {
        sim s = sims[v];
        if (!s.tree && !boxes)
            continue; /* brute force only where the scene is small */
        for (size_t i = 0; i < n; i++) {
            rto_trace_counters c;
            gpu[i] = s.tree ? sim_tree_trace(&s, sc, accs[s.tree - 1], &rays[i], &c) : sim_trace(&s, sc, boxes, &rays[i]);
            differing += memcmp(&gpu[i], &expected[i], offsetof(rto_hit_record, obj_to_world)) != 0;
        }
        const rto_hits_check_desc d = hits_desc(sc, rays, n, expected, gpu);
        rto_report r;
        const rto_status st = rto_hits_check(&d, &r, &msg);
        if (st != RTO_OK)
            fail_msg("%s, GPU (%s, fuse %s, reciprocal %+d ulp): rejected (%s): %s %s", label, tree_names[s.tree],
                     fuse_names[s.fuse], s.div_ulps, rto_status_string(st), r.summary,
                     st == RTO_ERR_MISMATCH ? "" : msg.text);
        tot->records += n;
    }
    tot->differing += differing;
    tot->rays += n;
    size_t gpus = 0;
    for (size_t v = 0; v < nsims; v++)
        gpus += sims[v].tree || boxes;
    print_message("%-46s %6zu rays %6zu hits x %zu GPUs = %7zu records, %6zu differing: all accepted\n", label, n,
                  hits, gpus, n * gpus, differing);
    /* RTO_CONFORMANCE_JSON=FILE: one JSON object per case appended to FILE (tests/tools/conformance_table.py) */
    const char *json = getenv("RTO_CONFORMANCE_JSON");
    FILE *f = json && *json ? fopen(json, "a") : NULL;
    if (f) {
        fprintf(f, "{\"scene\": \"%s\", \"rays\": \"%s\", \"count\": %zu, \"hits\": %zu, \"gpus\": %zu, "
                "\"records\": %zu, \"differing\": %zu, \"rejected\": 0}\n", spec, set, n, hits, gpus, n * gpus,
                differing);
        fclose(f);
    }
    free(expected);
    free(gpu);
}

/* Instance masks for scenes that come with 0xFF everywhere: instance k gets bit k % 8, so rays with a cull mask of
 * some bits see some instances. */
static void spread_masks(rto_scene *sc)
{
    int all = 1;
    for (uint32_t k = 0; k < sc->instance_count; k++)
        all &= sc->instances[k].mask == 0xFF;
    if (all && sc->instance_count > 1)
        for (uint32_t k = 0; k < sc->instance_count; k++)
            sc->instances[k].mask = 1u << (k % 8);
}

/* brute: also the brute-force GPUs (small scenes only) */
static void family(const char *spec, size_t made, size_t generated, int brute, family_totals *tot)
{
    rto_scene *sc = tu_load(spec);
    spread_masks(sc);
    rto_accel *accs[2] = {NULL, NULL};
    rto_msg msg = {{0}};
    const rto_accel_desc karras = {RTO_TLAS_KARRAS, 0};
    if (rto_accel_build(sc, NULL, &accs[0], &msg) || rto_accel_build(sc, &karras, &accs[1], &msg))
        fail_msg("build %s: %s", spec, msg.text);
    tri_box **boxes = NULL;
    if (brute) {
        boxes = calloc(sc->mesh_count ? sc->mesh_count : 1, sizeof *boxes);
        assert_non_null(boxes);
        for (uint32_t m = 0; m < sc->mesh_count; m++)
            boxes[m] = mesh_boxes(&sc->meshes[m]);
    }
    /* each case meets nine GPUs: brute force with none fused and the reciprocal 2 ulp up, the first or second
     * product fused with it 1 or 2 ulp down, and per-site choices; the traversal of the trees, sweep and Karras TLAS,
     * with per-site choices and each product fused */
    const sim sims[9] = {{FUSE_NONE, 2, 1, 0, 0},   {FUSE_FIRST, -1, 2, 0, 0},  {FUSE_SECOND, -2, 3, 0, 0},
                         {FUSE_RANDOM, 1, 4, 0, 0}, {FUSE_RANDOM, 2, 5, 1, 0},  {FUSE_FIRST, -2, 6, 1, 0},
                         {FUSE_SECOND, 1, 7, 1, 0}, {FUSE_RANDOM, -1, 8, 2, 0}, {FUSE_FIRST, 2, 9, 2, 0}};
    for (int set = 0; set < RTO_RAY_SET_COUNT; set++) {
        rto_rays_desc rd;
        memset(&rd, 0, sizeof rd);
        rd.set = (rto_ray_set)set;
        rd.seed = 11;
        rd.width = TU_SIZED(40, 16);
        rd.height = TU_SIZED(30, 12);
        rd.count = generated;
        const size_t cap = rto_rays_capacity(&rd);
        rto_wf_ray *rays = calloc(cap ? cap : 1, sizeof *rays);
        size_t n = 0;
        assert_non_null(rays);
        if (rto_rays_generate(accs[0], &rd, rays, cap, &n, NULL, &msg))
            fail_msg("%s %s rays: %s", spec, rto_ray_set_name(rd.set), msg.text);
        run_case(sc, boxes, accs, spec, rto_ray_set_name(rd.set), rays, n, sims, 9, tot);
        free(rays);
    }
    rto_wf_ray *rays = calloc(MADE_PER * made + 1, sizeof *rays);
    assert_non_null(rays);
    const size_t n = made_rays(sc, 77, made, rays);
    run_case(sc, boxes, accs, spec, "vertex/edge/surface/range", rays, n, sims, 9, tot);
    free(rays);
    for (uint32_t m = 0; boxes && m < sc->mesh_count; m++)
        free(boxes[m]);
    free(boxes);
    rto_accel_destroy(accs[0]);
    rto_accel_destroy(accs[1]);
    rto_scene_destroy(sc);
}

static void test_simulated_gpus_accepted(void **state)
{
    (void)state;
    family_totals tot = {0, 0, 0};
    const size_t made = TU_SIZED(40, 10), generated = TU_SIZED(300, 60);
    family("Box/glTF/Box.gltf", made, generated, 1, &tot);
    family("SimpleMeshes/glTF/SimpleMeshes.gltf", made, generated, 1, &tot);
    family("Duck/glTF/Duck.gltf", made, generated, 1, &tot);
    family("CornellBox-nvpro-glTF/cornellBox.gltf", made, generated, 1, &tot);
    if (!TU_SANITIZED) { /* the larger meshes: the tree GPUs only, and not under the sanitizers */
        family("Suzanne/glTF/Suzanne.gltf", made, generated, 0, &tot);
        family("WaterBottle/glTF/WaterBottle.gltf", made, generated, 0, &tot);
        family("StanfordBunny/bunny.gltf", made, generated, 0, &tot);
    }
    family("sphere:2", made, generated, 1, &tot);
    family("random:3", made, generated, 1, &tot);
    family("random:5", made, generated, 1, &tot);
    family("random:13", made, generated, 1, &tot);
    family("rtstress:2", made, generated, 1, &tot);
    print_message("simulated GPUs: %zu rays, %zu records checked, %zu of them not the oracle's bit for bit: all "
                  "accepted\n", tot.rays, tot.records, tot.differing);
    assert_true(tot.differing > 0); /* the freedoms did change records: the test saw differences */
}

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
static void test_twice_the_bound_fails(void **state)
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
static void test_exact_arithmetic(void **state)
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
static void test_exact_traversal(void **state)
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
static void test_fault_corpus(void **state)
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
static void test_tie_freedom_named(void **state)
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
static void test_tie_order(void **state)
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
static void test_slab_range(void **state)
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simulated_gpus_accepted),
        cmocka_unit_test(test_twice_the_bound_fails),
        cmocka_unit_test(test_exact_arithmetic),
        cmocka_unit_test(test_exact_traversal),
        cmocka_unit_test(test_fault_corpus),
        cmocka_unit_test(test_tie_freedom_named),
        cmocka_unit_test(test_tie_order),
        cmocka_unit_test(test_slab_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
