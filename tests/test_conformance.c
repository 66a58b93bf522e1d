/* The conformance model of DESIGN.md §9 from the GPU's side: simulated GPUs written here, not calling src/trace/,
 * run §6 — Möller–Trumbore, the ray transform, culling, masks and TERMINATE_ON_FIRST_HIT, by brute force (every
 * triangle of every visible instance, no box test) or by §6's traversal of the accel's own trees (sweep or Karras
 * TLAS, the BLAS, slab tests and all) — with the freedoms the model grants: every a*b + c fused or not (the first or
 * the second product of each sum, or a choice per site from a PRNG) and the reciprocal moved by up to 2 ulp.
 * check-hits must accept every record of every one of them, over every fixture, sphere:L, random:N triangle soups
 * (slivers included) and rtstress:2, with generated ray sets and rays made here at vertices, on edges, starting on
 * surfaces and ending at a hit's t, with cull flags and masks. This file holds the simulated GPUs, the rays made
 * here, that family of cases and main(); one executable (unit.conformance) with test_conformance_faults.c: without
 * freedoms the traversal must equal the oracle's records and counters bit for bit; a record off by twice the model's
 * bound must fail, field by field; and each GPU fault of the corpus, planted in the simulated traversal, must be
 * caught and named at the first ray it changes. */
#include "test_conformance.h"

/* ------------------------------------------------------------------------------------------------------------------ */
/* A simulated GPU                                                                                                    */

static const char *const fuse_names[] = {"none", "first", "second", "random"};

static int fuse_choice(sim *s)
{
    if (s->fuse != FUSE_RANDOM)
        return (int)s->fuse;
    return (int)(tu_rng_next(&s->rng) % 3);
}

/* a*b + c*d as a GPU may evaluate it (this file is compiled with -ffp-contract=off: only fmaf fuses) */
float sum2(sim *s, float a, float b, float c, float d)
{
    switch (fuse_choice(s)) {
    case 1: return fmaf(a, b, c * d);
    case 2: return fmaf(c, d, a * b);
    default: return a * b + c * d;
    }
}

/* x + a*b, the last step of a dot product or a transform row */
float plus(sim *s, float x, float a, float b) { return fuse_choice(s) ? fmaf(a, b, x) : x + a * b; }

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

int sim_triangle(sim *s, const float *v0, const float *v1, const float *v2, const float o[3], const float d[3],
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
rto_hit_record sim_tree_trace(sim *s, const rto_scene *sc, const rto_accel *acc, const rto_wf_ray *ray,
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

/* Rays made here for n random triangles: at a vertex, at an edge's midpoint, from a point on the triangle itself
 * (a surface start, tMin 0) outwards and inwards, and through the inside with tMax set to 1.0 (ending at the plane
 * when the origin is one unit away). Flags vary: culling, first hit; and cull masks. */
size_t made_rays(const rto_scene *sc, uint64_t seed, size_t n, rto_wf_ray *out)
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
rto_hits_check_desc hits_desc(const rto_scene *sc, const rto_wf_ray *rays, size_t n,
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
void spread_masks(rto_scene *sc)
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
