/* One lane kernel of the tracer (trace/lanes.c includes this once per instruction set, after trace/vec_ops.h). Before
 * it: PN(x) (a prefixed name), VLD / VST (aligned loads and stores of VF) and VGATHER(rows, f) (float f of each
 * lane's 16-float row).
 *
 * Each lane is one ray doing DESIGN.md §6 in §6's order with its own two stacks, the way a GPU thread of a warp does:
 * a lane pops until it needs a box pair or a triangle (step), then the slab tests of every lane at a box pair run as
 * one vector computation (box_pair) and the Möller–Trumbore tests of every lane at a triangle as another (triangle);
 * each lane then pushes, or takes its hit, on its own. Vector operations are lane-wise, one binary32 operation each,
 * the same as the scalar tracer's, so a lane computes the bits the scalar tracer does. */

typedef struct PN(lanes) {
    /* The box pair of each lane as it lies in memory (64 bytes: a BLAS or Karras node, or a sweep node's two
     * children): lmin at float 0, lmax at 4, rmin at 8, rmax at 12. box_pair gathers them by field. */
    float row[W][16];
    /* The ray in the lane's current space (world in the TLAS, object space in a BLAS), its tMin and best t. */
    float o[3][W], d[3][W], inv[3][W], tmin[W], best[W];
    float v0[3][W], v1[3][W], v2[3][W]; /* the triangle */
    float tl[W], tr[W];              /* box_pair: entry t of each box */
    float ht[W], hu[W], hv[W], hdet[W]; /* triangle: t, u, v, det */
    rto__lane s[W];
} PN(lanes);

static size_t PN(scratch_size)(size_t stack_cap)
{
    return sizeof(PN(lanes)) + (size_t)W * 2 * stack_cap * sizeof(rto__trace_entry);
}

static inline void PN(set_ray)(PN(lanes) *L, uint32_t l, const float o[3], const float inv[3])
{
    for (int a = 0; a < 3; a++) {
        L->o[a][l] = o[a];
        L->inv[a][l] = inv[a];
    }
}

/* A Karras node (BLAS or TLAS): both children are tested. */
static inline void PN(stage_node)(PN(lanes) *L, uint32_t l, rto__lane *s, const rto_bvh_node *n)
{
    memcpy(L->row[l], n, sizeof *n);
    s->lref = n->left;
    s->rref = n->right;
    s->lvalid = s->rvalid = 1;
}

static inline void PN(stage_triangle)(PN(lanes) *L, uint32_t l, rto__lane *s, uint32_t prim)
{
    const uint32_t *ix = &s->mesh->indices[3 * (size_t)prim];
    const float *p = s->mesh->positions;
    s->prim = prim;
    for (int a = 0; a < 3; a++) {
        L->v0[a][l] = p[3 * (size_t)ix[0] + a];
        L->v1[a][l] = p[3 * (size_t)ix[1] + a];
        L->v2[a][l] = p[3 * (size_t)ix[2] + a];
    }
}

/* An instance leaf reached: entered when its mask meets the ray's (the ray to object space, its BLAS root pushed, or
 * its one triangle staged). */
static inline int PN(enter)(const rto__tracer *tr, PN(lanes) *L, uint32_t l, rto__lane *s, uint32_t inst)
{
    const rto_instance *in = &tr->scene->instances[inst];
    if (!(in->mask & s->ray->cull_mask))
        return LANE_NONE;
    float o[3], d[3], inv[3];
    rto_ray_to_object(&in->world_to_obj, s->ray->origin, s->ray->dir, o, d);
    rto_ray_inv_dir(d, inv);
    PN(set_ray)(L, l, o, inv);
    for (int a = 0; a < 3; a++)
        L->d[a][l] = d[a];
    s->object = 1;
    s->c.instance_entries++;
    s->inst = inst;
    s->blas = rto_accel_get_blas(tr->accel, in->blas);
    s->mesh = &tr->scene->meshes[in->blas];
    if (s->blas->triangle_count == 1) { /* no internal node: straight to the triangle */
        PN(stage_triangle)(L, l, s, s->blas->order[0]);
        return LANE_TRIANGLE;
    }
    s->bstack[0] = (rto__trace_entry){0, s->ray->t_min};
    s->btop = 1;
    return LANE_NONE;
}

/* A new ray in lane l: the TLAS start of §6. */
static inline int PN(start)(const rto__tracer *tr, PN(lanes) *L, uint32_t l, rto__lane *s, const rto_wf_ray *ray,
                            size_t index)
{
    s->ray = ray;
    s->index = index;
    s->found = 0;
    s->done = 0;
    s->object = 0;
    s->ttop = 0;
    s->btop = 0;
    memset(&s->c, 0, sizeof s->c);
    rto_ray_inv_dir(ray->dir, s->winv);
    PN(set_ray)(L, l, ray->origin, s->winv);
    L->tmin[l] = ray->t_min;
    L->best[l] = ray->t_max;
    const rto_accel_tlas *tl = tr->tlas;
    if (tl->kind == RTO_TLAS_KARRAS) {
        if (tl->key_count == 1) /* no internal node: straight to the one instance */
            return PN(enter)(tr, L, l, s, rto_key_prim(RTO_KEY_U32, tl->sorted_keys[0]));
        if (tl->key_count > 1)
            s->tstack[s->ttop++] = (rto__trace_entry){0, ray->t_min};
        return LANE_NONE;
    }
    const rto_tlas_node *root = &tl->sweep_nodes[0];
    float t;
    if (root->item != RTO_TLAS_EMPTY) {
        s->c.box_tests++;
        if (rto__slab(root->min, root->max, ray->origin, s->winv, ray->t_min, ray->t_max, &t))
            s->tstack[s->ttop++] = (rto__trace_entry){0, t};
    }
    return LANE_NONE;
}

/* Runs lane l until it needs a box pair (LANE_BOX) or a triangle (LANE_TRIANGLE) tested, finishing rays and taking
 * the next of [*next, end) as it goes; LANE_NONE when no ray is left for it. */
static int PN(step)(const rto__tracer *tr, PN(lanes) *L, uint32_t l, const rto_wf_ray *rays, size_t *next,
                    size_t end, rto_hit_record *hits, rto_trace_counters *counters)
{
    rto__lane *s = &L->s[l];
    const rto_accel_tlas *tl = tr->tlas;
    for (;;) {
        if (s->btop) { /* inside a BLAS */
            const rto__trace_entry e = s->bstack[--s->btop];
            if (e.t > L->best[l])
                continue;
            s->c.nodes_visited++;
            if (e.ref & RTO_BVH_LEAF_BIT) {
                PN(stage_triangle)(L, l, s, s->blas->order[e.ref & ~RTO_BVH_LEAF_BIT]);
                return LANE_TRIANGLE;
            }
            PN(stage_node)(L, l, s, &s->blas->nodes[e.ref]);
            s->blas_pair = 1;
            return LANE_BOX;
        }
        if (s->object) { /* back in the TLAS: the world ray */
            PN(set_ray)(L, l, s->ray->origin, s->winv);
            s->object = 0;
        }
        if (s->done || !s->ttop) {
            if (s->ray) {
                hits[s->index] = s->found ? rto_hit_record_make(&tr->scene->instances[s->inst_hit], s->inst_hit,
                                                                s->prim_hit, &s->h)
                                          : rto_hit_record_miss(s->ray->t_max);
                if (counters)
                    counters[s->index] = s->c;
                s->ray = NULL;
            }
            if (*next >= end)
                return LANE_NONE;
            const size_t i = (*next)++;
            if (PN(start)(tr, L, l, s, &rays[i], i) == LANE_TRIANGLE)
                return LANE_TRIANGLE;
            continue;
        }
        const rto__trace_entry e = s->tstack[--s->ttop];
        if (e.t > L->best[l])
            continue;
        s->c.nodes_visited++;
        if (tl->kind == RTO_TLAS_KARRAS) {
            if (e.ref & RTO_BVH_LEAF_BIT) {
                const uint32_t inst = rto_key_prim(RTO_KEY_U32, tl->sorted_keys[e.ref & ~RTO_BVH_LEAF_BIT]);
                if (PN(enter)(tr, L, l, s, inst) == LANE_TRIANGLE)
                    return LANE_TRIANGLE;
                continue;
            }
            PN(stage_node)(L, l, s, &tl->karras_nodes[e.ref]);
            s->blas_pair = 0;
            return LANE_BOX;
        }
        const rto_tlas_node *nodes = tl->sweep_nodes;
        if (e.ref >= tl->n_padded - 1) {
            if (PN(enter)(tr, L, l, s, nodes[e.ref].item) == LANE_TRIANGLE)
                return LANE_TRIANGLE;
            continue;
        }
        /* An EMPTY child is skipped by its item, never by a box test: its box is staged, its result unused. */
        s->blas_pair = 0;
        s->lref = 2 * e.ref + 1;
        s->rref = 2 * e.ref + 2;
        s->lvalid = nodes[s->lref].item != RTO_TLAS_EMPTY;
        s->rvalid = nodes[s->rref].item != RTO_TLAS_EMPTY;
        memcpy(L->row[l], &nodes[s->lref], 2 * sizeof *nodes); /* the two children lie side by side */
        return LANE_BOX;
    }
}

/* The slab tests of both staged boxes in every lane (§6): bit l of the result for the left box, of *right_hits for
 * the right one; entry t in L->tl / L->tr. */
static inline uint32_t PN(box_pair)(PN(lanes) *L, uint32_t *right_hits)
{
    const VF o0 = VLD(L->o[0]), o1 = VLD(L->o[1]), o2 = VLD(L->o[2]);
    const VF i0 = VLD(L->inv[0]), i1 = VLD(L->inv[1]), i2 = VLD(L->inv[2]);
    const VF tmin = VLD(L->tmin), best = VLD(L->best);
    uint32_t hits[2];
    const float *rows = &L->row[0][0];
    for (int k = 0; k < 2; k++) {
        const int f = 8 * k; /* the box's min at float f of each row, its max at f + 4 */
        const VF a0 = VMUL(VSUB(VGATHER(rows, f), o0), i0), c0 = VMUL(VSUB(VGATHER(rows, f + 4), o0), i0);
        const VF a1 = VMUL(VSUB(VGATHER(rows, f + 1), o1), i1), c1 = VMUL(VSUB(VGATHER(rows, f + 5), o1), i1);
        const VF a2 = VMUL(VSUB(VGATHER(rows, f + 2), o2), i2), c2 = VMUL(VSUB(VGATHER(rows, f + 6), o2), i2);
        const VF near = VMAX(VMAX(VMAX(VMIN(a0, c0), VMIN(a1, c1)), VMIN(a2, c2)), tmin);
        const VF far = VMIN(VMIN(VMIN(VMAX(a0, c0), VMAX(a1, c1)), VMAX(a2, c2)), best);
        hits[k] = VLE(near, far);
        VST(k ? L->tr : L->tl, near);
    }
    *right_hits = hits[1];
    return hits[0];
}

/* Möller–Trumbore of every lane's staged triangle against its object-space ray (§6, rto_triangle_intersect's
 * operations): bit l set when lane l's test accepts (before culling); t, u, v, det in L->ht, hu, hv, hdet. */
static inline uint32_t PN(triangle)(PN(lanes) *L)
{
    const VF d0 = VLD(L->d[0]), d1 = VLD(L->d[1]), d2 = VLD(L->d[2]);
    const VF v00 = VLD(L->v0[0]), v01 = VLD(L->v0[1]), v02 = VLD(L->v0[2]);
    const VF e10 = VSUB(VLD(L->v1[0]), v00), e11 = VSUB(VLD(L->v1[1]), v01), e12 = VSUB(VLD(L->v1[2]), v02);
    const VF e20 = VSUB(VLD(L->v2[0]), v00), e21 = VSUB(VLD(L->v2[1]), v01), e22 = VSUB(VLD(L->v2[2]), v02);
    const VF p0 = VSUB(VMUL(d1, e22), VMUL(d2, e21));
    const VF p1 = VSUB(VMUL(d2, e20), VMUL(d0, e22));
    const VF p2 = VSUB(VMUL(d0, e21), VMUL(d1, e20));
    const VF det = VADD(VADD(VMUL(e10, p0), VMUL(e11, p1)), VMUL(e12, p2));
    const uint32_t nonzero = VNEQ(det, VSET1(0.0f));
    const VF inv = VDIV(VSET1(1.0f), det);
    const VF s0 = VSUB(VLD(L->o[0]), v00), s1 = VSUB(VLD(L->o[1]), v01), s2 = VSUB(VLD(L->o[2]), v02);
    const VF q0 = VSUB(VMUL(s1, e12), VMUL(s2, e11));
    const VF q1 = VSUB(VMUL(s2, e10), VMUL(s0, e12));
    const VF q2 = VSUB(VMUL(s0, e11), VMUL(s1, e10));
    const VF u = VMUL(VADD(VADD(VMUL(s0, p0), VMUL(s1, p1)), VMUL(s2, p2)), inv);
    const VF v = VMUL(VADD(VADD(VMUL(d0, q0), VMUL(d1, q1)), VMUL(d2, q2)), inv);
    const VF t = VMUL(VADD(VADD(VMUL(e20, q0), VMUL(e21, q1)), VMUL(e22, q2)), inv);
    const VF zero = VSET1(0.0f);
    const uint32_t ok = nonzero & VGE(u, zero) & VGE(v, zero) & VLE(VADD(u, v), VSET1(1.0f)) &
                        VLE(VLD(L->tmin), t) & VLT(t, VLD(L->best));
    VST(L->ht, t);
    VST(L->hu, u);
    VST(L->hv, v);
    VST(L->hdet, det);
    return ok;
}

/* The node a lane pops next, fetched into the cache while the other lanes work: random rays' nodes are rarely
 * cached, and a lane would otherwise wait for each of them in turn. */
static inline void PN(prefetch)(const rto__tracer *tr, const rto__lane *s)
{
    if (s->btop) {
        const uint32_t ref = s->bstack[s->btop - 1].ref;
        if (ref & RTO_BVH_LEAF_BIT)
            __builtin_prefetch(&s->blas->order[ref & ~RTO_BVH_LEAF_BIT]);
        else
            __builtin_prefetch(&s->blas->nodes[ref]);
        return;
    }
    if (!s->ttop || s->done)
        return;
    const uint32_t ref = s->tstack[s->ttop - 1].ref;
    const rto_accel_tlas *tl = tr->tlas;
    if (tl->kind == RTO_TLAS_KARRAS) {
        if (!(ref & RTO_BVH_LEAF_BIT))
            __builtin_prefetch(&tl->karras_nodes[ref]);
    } else if (ref < tl->n_padded - 1) { /* its two children, 64 bytes from an odd index: two lines */
        __builtin_prefetch(&tl->sweep_nodes[2 * (size_t)ref + 1]);
        __builtin_prefetch(&tl->sweep_nodes[2 * (size_t)ref + 2]);
    }
}

static void PN(trace)(const rto__tracer *tr, const rto_wf_ray *rays, size_t begin, size_t end, rto_hit_record *hits,
                      rto_trace_counters *counters, void *scratch)
{
    PN(lanes) *L = scratch;
    rto__trace_entry *stacks = (rto__trace_entry *)(L + 1);
    memset(L, 0, sizeof *L);
    for (uint32_t l = 0; l < W; l++) {
        L->s[l].tstack = stacks + (size_t)l * 2 * tr->stack_cap;
        L->s[l].bstack = L->s[l].tstack + tr->stack_cap;
    }
    size_t next = begin;
    uint32_t live = (uint32_t)((1ull << W) - 1);
    while (live) {
        uint32_t box = 0, tri = 0;
        for (uint32_t m = live; m; m &= m - 1) {
            const uint32_t l = (uint32_t)__builtin_ctz(m);
            const int k = PN(step)(tr, L, l, rays, &next, end, hits, counters);
            if (k == LANE_BOX)
                box |= 1u << l;
            else if (k == LANE_TRIANGLE)
                tri |= 1u << l;
            else
                live &= ~(1u << l);
        }
        if (box) {
            uint32_t hr;
            const uint32_t hl = PN(box_pair)(L, &hr);
            for (uint32_t m = box; m; m &= m - 1) {
                const uint32_t l = (uint32_t)__builtin_ctz(m);
                rto__lane_push(&L->s[l], (hl >> l) & 1, L->tl[l], (hr >> l) & 1, L->tr[l]);
                PN(prefetch)(tr, &L->s[l]);
            }
        }
        if (tri) {
            const uint32_t ok = PN(triangle)(L);
            for (uint32_t m = tri; m; m &= m - 1) {
                const uint32_t l = (uint32_t)__builtin_ctz(m);
                const rto_tri_hit h = {L->ht[l], L->hu[l], L->hv[l], L->hdet[l]};
                if (rto__lane_take(&L->s[l], (ok >> l) & 1, &h))
                    L->best[l] = h.t;
                PN(prefetch)(tr, &L->s[l]);
            }
        }
    }
}

static const rto__trace_lanes PN(kernel) = {PN(scratch_size), PN(trace)};
