/* One group kernel of the packed path (trace/packed.c includes this once per instruction set, after its own types and
 * helpers and trace/vec_ops.h). Before it: PN(x) (a prefixed name), VI_ADD(v, m, k) (k added in the lanes of bit
 * mask m) and LANES_IN(m) (the bits set in m).
 *
 * W neighbouring rays walk a tree together: each node is fetched once for the group and its two child boxes tested
 * for every ray of it as two vector computations of rto__slab's operations, lane by lane, and each triangle as one of
 * rto__triangle_intersect's. Every ray still takes its own walk, node for node: the group visits a node with the mask
 * of the rays whose walk visits it then. Where some rays that hit both children take the left first and others the
 * right, the group goes first to the side more of them take first (left on a tie), then to the other side, then back
 * to the first side for the rays that take it second, each of those entries holding every ray's own entry t and
 * checked against that ray's own best t when popped, as the ray's own pop would be. A ray masked off while the group
 * walks elsewhere keeps its best t, so its checks fall as they would alone; its counters count only the nodes,
 * boxes and triangles of its own walk. Where neighbouring rays are alike (primary and shadow rays) the group's walk
 * is little more than each ray's, and the fetches and tests are shared. */

/* A group's stack entry: a node, the rays it is for, and each one's entry t. */
typedef struct PN(entry) {
    uint32_t ref, mask;
    float t[W];
} PN(entry);

/* The group's rays in one space, lane by lane (lanes not in the walk hold what their results are masked off from). */
typedef struct PN(ray) {
    VF o[3], d[3], inv[3], t_min;
} PN(ray);

typedef struct PN(group) {
    VF best;              /* each ray's best t (from bestf) */
    VI visits, boxes, tris; /* counted by the walk, added to each ray's own when its counters are stored */
    float bestf[W];
    uint32_t alive;       /* rays not finished by a first hit */
    PN(entry) *tstack, *bstack;
    pray st[W];
} PN(group);

static size_t PN(scratch_size)(size_t stack_cap)
{
    return 2 * (2 * stack_cap) * sizeof(PN(entry)); /* a TLAS and a BLAS stack: at most 2 entries per level */
}

/* A box (its min at mn[0], mn[stride], mn[2 * stride], its max likewise at mx) against every lane: rto__slab's
 * operations, as slab_pair's lanes; the lanes that hit it, their entry t in *t. */
static inline uint32_t PN(slab)(const float *mn, const float *mx, int stride, const PN(ray) *r, VF best, VF *t)
{
    VF lo[3], hi[3];
#pragma GCC unroll 3
    for (int a = 0; a < 3; a++) {
        const VF t0 = VMUL(VSUB(VSET1(mn[stride * a]), r->o[a]), r->inv[a]);
        const VF t1 = VMUL(VSUB(VSET1(mx[stride * a]), r->o[a]), r->inv[a]);
        lo[a] = VMIN(t0, t1);
        hi[a] = VMAX(t0, t1);
    }
    const VF near = VMAX(VMAX(VMAX(lo[0], lo[1]), lo[2]), r->t_min);
    const VF far = VMIN(VMIN(VMIN(hi[0], hi[1]), hi[2]), best);
    *t = near;
    return VLE(near, far);
}

/* A node's child box c (0 left, 1 right). */
static inline uint32_t PN(child)(const packed_node *n, int c, const PN(ray) *r, VF best, VF *t)
{
    return PN(slab)(&n->box[c], &n->box[2 + c], 4, r, best, t);
}

/* rto__ray_inv_dir's operations, lane by lane: |d| < 1e-20 becomes +-1e-20 by d < 0 (a zero of either sign +1e-20). */
static inline VF PN(inv_dir)(VF d)
{
    const VF tiny = VSET1(1e-20f);
    return VDIV(VSET1(1.0f), VSEL_LT(VABS(d), tiny, VSEL_LT(d, VZERO(), VSET1(-1e-20f), tiny), d));
}

/* The triangle against the lanes act: rto__triangle_intersect's operations lane by lane (the edges, the same for every
 * lane, once), then each hit lane's culling and record as triangle()'s. Inlined: the walk's vectors stay put. */
static inline __attribute__((always_inline)) void PN(triangle)(PN(group) *g, const packed_tri *tri, const PN(ray) *r,
                                                               uint32_t act, uint32_t inst)
{
    float e1[3], e2[3];
    rto__sub3(&tri->v[3], &tri->v[0], e1);
    rto__sub3(&tri->v[6], &tri->v[0], e2);
    VF E1[3], E2[3], p[3], s[3], q[3];
    for (int a = 0; a < 3; a++) {
        E1[a] = VSET1(e1[a]);
        E2[a] = VSET1(e2[a]);
        s[a] = VSUB(r->o[a], VSET1(tri->v[a]));
    }
#define CROSS(x, y, out)                                                                                             \
    do {                                                                                                             \
        out[0] = VSUB(VMUL(x[1], y[2]), VMUL(x[2], y[1]));                                                          \
        out[1] = VSUB(VMUL(x[2], y[0]), VMUL(x[0], y[2]));                                                          \
        out[2] = VSUB(VMUL(x[0], y[1]), VMUL(x[1], y[0]));                                                          \
    } while (0)
#define DOT(x, y) VADD(VADD(VMUL(x[0], y[0]), VMUL(x[1], y[1])), VMUL(x[2], y[2]))
    CROSS(r->d, E2, p);
    const VF det = DOT(E1, p), inv = VDIV(VSET1(1.0f), det);
    CROSS(s, E1, q);
    const VF u = VMUL(DOT(s, p), inv), v = VMUL(DOT(r->d, q), inv), t = VMUL(DOT(E2, q), inv);
#undef CROSS
#undef DOT
    const VF zero = VZERO();
    g->tris = VI_ADD(g->tris, act, 1);
    uint32_t hit = act & VNEQ(det, zero) & VGE(u, zero) & VGE(v, zero) & VLE(VADD(u, v), VSET1(1.0f)) &
                   VLE(r->t_min, t) & VLT(t, g->best);
    if (!hit)
        return;
    float ht[W], hu[W], hv[W], hd[W];
    VSTU(ht, t);
    VSTU(hu, u);
    VSTU(hv, v);
    VSTU(hd, det);
    while (hit) {
        const int l = __builtin_ctz(hit);
        hit &= hit - 1;
        pray *st = &g->st[l];
        if (rto__triangle_culled(st->ray->flags, hd[l]))
            continue;
        g->bestf[l] = ht[l];
        st->h = (rto_tri_hit){ht[l], hu[l], hv[l], hd[l]};
        st->inst_hit = inst;
        st->prim_hit = tri->prim;
        st->found = 1;
        if (st->ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) {
            st->done = 1;
            g->alive &= ~(1u << l);
        }
    }
    g->best = VLDU(g->bestf);
}

static inline void PN(push)(PN(entry) *stack, size_t *top, uint32_t ref, uint32_t mask, VF t)
{
    PN(entry) *e = &stack[(*top)++];
    e->ref = ref;
    e->mask = mask;
    VSTU(e->t, t);
}

/* A node's hit children for the lanes in the walk (hl, hr: the lanes that hit each): *cur and *act the child visited
 * now and its lanes, the rest pushed (see above); 0 when no lane hit either. */
static inline int PN(descend)(const packed_node *n, uint32_t hl, uint32_t hr, VF tl, VF tr, PN(entry) *stack,
                              size_t *top, uint32_t *cur, uint32_t *act)
{
    if (!hr || !hl) {
        *cur = n->child[!hl];
        *act = hl | hr;
        return *act != 0;
    }
    const uint32_t both = hl & hr, lfirst = both & VLE(tl, tr), rfirst = both & ~lfirst;
    if (LANES_IN(rfirst) > LANES_IN(lfirst)) {
        if (lfirst)
            PN(push)(stack, top, n->child[1], lfirst, tr);
        PN(push)(stack, top, n->child[0], hl, tl);
        *cur = n->child[1];
        *act = hr & ~lfirst;
    } else {
        if (rfirst)
            PN(push)(stack, top, n->child[0], rfirst, tl);
        PN(push)(stack, top, n->child[1], hr, tr);
        *cur = n->child[0];
        *act = hl & ~rfirst;
    }
    return 1;
}

/* The next entry with a ray still in it whose best t its box starts within: *cur and *act; 0 when none is left. */
static inline int PN(pop)(const PN(group) *g, PN(entry) *stack, size_t *top, uint32_t *cur, uint32_t *act)
{
    while (*top) {
        const PN(entry) *e = &stack[--*top];
        uint32_t m = e->mask & g->alive;
        if (m)
            m &= VNGT(VLDU(e->t), g->best);
        if (!m)
            continue;
        *cur = e->ref;
        *act = m;
        return 1;
    }
    return 0;
}

/* The group's ray in instance in's object space: rto__ray_to_object's and rto__ray_inv_dir's operations, lane by
 * lane. */
static inline PN(ray) PN(to_object)(const rto_instance *in, const PN(ray) *w)
{
    const float(*m)[4] = in->world_to_obj.m;
    PN(ray) r;
    for (int a = 0; a < 3; a++) {
        const VF m0 = VSET1(m[a][0]), m1 = VSET1(m[a][1]), m2 = VSET1(m[a][2]);
        r.o[a] = VADD(VADD(VADD(VMUL(m0, w->o[0]), VMUL(m1, w->o[1])), VMUL(m2, w->o[2])), VSET1(m[a][3]));
        r.d[a] = VADD(VADD(VMUL(m0, w->d[0]), VMUL(m1, w->d[1])), VMUL(m2, w->d[2]));
        r.inv[a] = PN(inv_dir)(r.d[a]);
    }
    r.t_min = w->t_min;
    return r;
}

/* The lanes act reaching instance inst (the group's world ray w): those whose mask meets the instance's enter its
 * BLAS, as blas_enter's ray does, and walk it together. */
static void PN(blas)(const rto__tracer *tr, const packed_accel *pa, PN(group) *g, uint32_t inst, uint32_t act,
                     const PN(ray) *w)
{
    const rto_instance *in = &tr->scene->instances[inst];
    uint32_t enter = 0;
    for (uint32_t m = act; m; m &= m - 1) {
        const int l = __builtin_ctz(m);
        if (in->mask & g->st[l].ray->cull_mask) {
            enter |= 1u << l;
            g->st[l].c.instance_entries++;
        }
    }
    if (!enter)
        return;
    const PN(ray) r = PN(to_object)(in, w);
    const packed_tree *pt = &pa->blas[in->blas];
    if (pt->root & RTO_BVH_LEAF_BIT) { /* no internal node: straight to the triangle */
        PN(triangle)(g, &pt->slots[pt->root & ~RTO_BVH_LEAF_BIT].tri, &r, enter, inst);
        return;
    }
    const packed_slot *slots = pt->slots;
    PN(entry) *stack = g->bstack;
    size_t top = 0;
    uint32_t cur = pt->root;
    act = enter;
    VI visits = g->visits, boxes = g->boxes; /* in registers through the walk, not g's memory */
    for (;;) {
        visits = VI_ADD(visits, act, 1);
        if (cur & RTO_BVH_LEAF_BIT) {
            PN(triangle)(g, &slots[cur & ~RTO_BVH_LEAF_BIT].tri, &r, act, inst);
        } else {
            const packed_node *n = &slots[cur].node;
            VF tl, tr2;
            boxes = VI_ADD(boxes, act, 2);
            const uint32_t hl = PN(child)(n, 0, &r, g->best, &tl) & act;
            const uint32_t hr = PN(child)(n, 1, &r, g->best, &tr2) & act;
            if (PN(descend)(n, hl, hr, tl, tr2, stack, &top, &cur, &act))
                continue;
        }
        if (!PN(pop)(g, stack, &top, &cur, &act))
            break;
    }
    g->visits = visits;
    g->boxes = boxes;
}

/* The TLAS walk: PN(blas)'s loop with absent children and instance leaves. The node test is written out in each loop
 * rather than shared: a shared helper (children present as an argument) took 8-12 % more time on shadow rays. */
static void PN(tlas)(const rto__tracer *tr, const packed_accel *pa, PN(group) *g, uint32_t act, uint32_t cur,
                     const PN(ray) *r)
{
    const packed_tree *pt = &pa->tlas;
    PN(entry) *stack = g->tstack;
    size_t top = 0;
    VI visits = g->visits, boxes = g->boxes;
    for (;;) {
        visits = VI_ADD(visits, act, 1);
        if (cur & RTO_BVH_LEAF_BIT) {
            g->visits = visits;
            g->boxes = boxes;
            PN(blas)(tr, pa, g, cur & ~RTO_BVH_LEAF_BIT, act, r);
            visits = g->visits;
            boxes = g->boxes;
        } else {
            const packed_node *n = &pt->slots[cur].node;
            VF tl = VZERO(), tr2 = VZERO();
            boxes = VI_ADD(boxes, act, (int)n->tests);
            const uint32_t hl = (n->present & 1) ? PN(child)(n, 0, r, g->best, &tl) & act : 0;
            const uint32_t hr = (n->present & 2) ? PN(child)(n, 1, r, g->best, &tr2) & act : 0;
            if (PN(descend)(n, hl, hr, tl, tr2, stack, &top, &cur, &act))
                continue;
        }
        if (!PN(pop)(g, stack, &top, &cur, &act))
            break;
    }
    g->visits = visits;
    g->boxes = boxes;
}

/* Rays [begin, end) W at a time: each starts as tlas_start starts it, lane by lane (where the TLAS is a Karras tree
 * of one instance, each ray is traced alone, as tlas_start does), and the rays with a walk ahead walk the TLAS
 * together. */
static void PN(trace)(const rto__tracer *tr, const packed_accel *pa, const rto_wf_ray *rays, size_t begin, size_t end,
                      rto_hit_record *hits, rto_trace_counters *counters, void *scratch)
{
    const packed_tree *pt = &pa->tlas;
    const int alone = !pt->empty && !pt->root_box && (pt->root & RTO_BVH_LEAF_BIT);
    PN(group) g;
    g.tstack = scratch;
    g.bstack = g.tstack + 2 * tr->stack_cap;
    for (int l = 0; l < W; l++) { /* a ray traced alone (trace_blas) uses the scalar stacks, in the same scratch */
        g.st[l].tstack = scratch;
        g.st[l].bstack = g.st[l].tstack + tr->stack_cap;
    }
    for (size_t i = begin; i < end; i += W) {
        const size_t k = end - i < W ? end - i : W;
        const uint32_t lanes = (uint32_t)((1u << k) - 1);
        float v[2][3][W], tmin[W];
        memset(v, 0, sizeof v);
        memset(tmin, 0, sizeof tmin);
        memset(g.bestf, 0, sizeof g.bestf);
        for (size_t l = 0; l < k; l++) {
            const rto_wf_ray *ray = &rays[i + l];
            ray_reset(&g.st[l], ray);
            if (alone) {
                float winv[3];
                uint32_t cur;
                rto__ray_inv_dir(ray->dir, winv);
                tlas_start(tr, pa, &g.st[l], winv, &cur);
            }
            g.bestf[l] = ray->t_max;
            tmin[l] = ray->t_min;
            for (int a = 0; a < 3; a++) {
                v[0][a][l] = ray->origin[a];
                v[1][a][l] = ray->dir[a];
            }
        }
        g.visits = g.boxes = g.tris = VI_ZERO();
        uint32_t act = pt->empty || alone ? 0 : lanes;
        if (act) {
            PN(ray) r;
            for (int a = 0; a < 3; a++) {
                r.o[a] = VLDU(v[0][a]);
                r.d[a] = VLDU(v[1][a]);
                r.inv[a] = PN(inv_dir)(r.d[a]);
            }
            r.t_min = VLDU(tmin);
            g.best = VLDU(g.bestf);
            if (pt->root_box) { /* the sweep tree's root box is tested like any node */
                VF t;
                g.boxes = VI_ADD(g.boxes, act, 1);
                act &= PN(slab)(pt->box, pt->box + 3, 1, &r, g.best, &t);
            }
            g.alive = act;
            if (act)
                PN(tlas)(tr, pa, &g, act, pt->root, &r);
        }
        uint32_t visits[W], boxes[W], tris[W];
        VI_STU(visits, g.visits);
        VI_STU(boxes, g.boxes);
        VI_STU(tris, g.tris);
        for (size_t l = 0; l < k; l++) {
            ray_record(tr, &g.st[l], i + l, hits);
            if (counters) /* the counts of the walk added to the ray's own (stored whole: no copy of fields) */
                _mm_storeu_si128((__m128i *)(void *)&counters[i + l],
                                 _mm_add_epi32(_mm_loadu_si128((const __m128i *)(const void *)&g.st[l].c),
                                               _mm_setr_epi32((int)visits[l], (int)boxes[l], (int)tris[l], 0)));
        }
    }
}
