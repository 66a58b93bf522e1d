/* TLAS sweep tree and Karras trees against independent references (a top-down radix split computed bit by bit,
 * brute-force unions, qsort), mutation tests for the tree validators, and the tolerance model of DESIGN.md §9 (the
 * transform bound, empty instances, leaf order); main(). One executable (unit.bvh) with test_bvh_accel.c (the
 * acceleration-structure object: trees of real scenes, threads, empty meshes, the accel API contract). */
#include "test_bvh.h"
#include "bvh/bvh_internal.h" /* rto__karras_build_scalar, the kept per-node builder */

#include <math.h>

/* Boxes of half-size h around the centroids of a centroid distribution. */
rto_aabb *make_boxes(const char *dist, size_t n, float h, uint32_t seed)
{
    rto_vec3 *c = malloc((n ? n : 1) * sizeof *c);
    rto_aabb *b = malloc((n ? n : 1) * sizeof *b);
    assert_int_equal(rto_centroids_generate(dist, seed, n, c, NULL), RTO_OK);
    for (size_t i = 0; i < n; i++) {
        float s = h * (1.0f + rto_unit(seed + 1, (uint32_t)i)); /* varied sizes */
        b[i].min = (rto_vec3){c[i].x - s, c[i].y - s, c[i].z - s};
        b[i].max = (rto_vec3){c[i].x + s, c[i].y + s, c[i].z + s};
    }
    free(c);
    return b;
}

int64_t where_of(const rto_report *r, const char *name)
{
    int64_t v;
    return rto_report_where(r, name, &v) ? v : -1;
}

/* The validators through their description structs; an unusable-input status fails the test. */
static rto_bvh_check_desc check_desc(const void *g, size_t count, const void *exp, const rto_aabb *boxes, size_t n,
                                     const double *tol)
{
    rto_bvh_check_desc d;
    memset(&d, 0, sizeof d);
    d.nodes = g;
    d.node_count = count;
    d.expected = exp;
    d.prim_boxes = boxes;
    d.prim_count = n;
    d.leaf_tolerance = tol;
    return d;
}

static rto_status tlas_check(const rto_tlas_node *g, size_t count, const rto_tlas_node *exp, const rto_aabb *boxes,
                             size_t n, const double *tol, rto_report *r)
{
    rto_bvh_check_desc d = check_desc(g, count, exp, boxes, n, tol);
    rto_msg msg = {{0}};
    rto_status s = rto_tlas_check(&d, r, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH)
        fail_msg("rto_tlas_check: %s", msg.text);
    return s;
}

static rto_status karras_check(const rto_bvh_node *g, size_t count, const rto_bvh_node *exp, const uint32_t *prims,
                               const rto_aabb *boxes, size_t n, const double *tol, rto_report *r)
{
    rto_bvh_check_desc d = check_desc(g, count, exp, boxes, n, tol);
    d.leaf_prims = prims;
    d.leaf_count = n;
    rto_msg msg = {{0}};
    rto_status s = rto_karras_check(&d, r, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH)
        fail_msg("rto_karras_check: %s", msg.text);
    return s;
}

typedef struct sweep {
    size_t n, np, count;
    uint32_t *keys, *sorted;
    rto_tlas_node *nodes;
    rto_aabb *boxes;
} sweep;

static void sweep_make(sweep *s, const char *dist, size_t n)
{
    s->n = n;
    s->np = rto_next_pow2(n);
    s->count = rto_tlas_sweep_node_count(n);
    s->boxes = make_boxes(dist, n, 1e-4f, 3);
    s->keys = malloc((n ? n : 1) * 4);
    s->sorted = malloc((s->np ? s->np : 1) * 4);
    s->nodes = malloc(s->count * sizeof *s->nodes);
    rto_msg msg = {{0}};
    size_t m = 0;
    if (rto_tlas_keys_from_boxes(s->boxes, n, s->keys, &m, &msg) ||
        rto_fast_radix_sort(RTO_KEY_U32, s->keys, n, s->sorted, &msg) ||
        rto_tlas_build_sweep(s->sorted, n, s->boxes, s->nodes, &msg))
        fail_msg("sweep %s n=%zu: %s", dist, n, msg.text);
    assert_int_equal(m, n); /* no empty box */
}

static void sweep_free(sweep *s)
{
    free(s->keys);
    free(s->sorted);
    free(s->nodes);
    free(s->boxes);
}

/* Sweep invariants written out here, independent of rto_tlas_check. */
static void test_sweep_tree_invariants(void **state)
{
    (void)state;
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
            sweep s;
            sweep_make(&s, di->name, sizes[z]);
            uint64_t *e = tu_qsorted(RTO_KEY_U32, s.keys, s.n);
            unsigned char *seen = calloc(s.n + 1, 1);
            assert_int_equal(s.count, s.n ? 2 * s.np - 1 : 1);
            for (size_t j = 0; j < s.np; j++) {
                const rto_tlas_node *t = &s.nodes[s.np - 1 + j];
                if (j < s.n) {
                    assert_int_equal(t->item, e[j] & 0xFFFF); /* leaf j is sorted position j */
                    assert_false(seen[t->item]);
                    seen[t->item] = 1;
                    assert_true(t->min[0] == s.boxes[t->item].min.x && t->max[2] == s.boxes[t->item].max.z);
                } else {
                    assert_int_equal(t->item, RTO_TLAS_EMPTY);
                    assert_true(isinf(t->min[0]) && t->min[0] > 0 && isinf(t->max[1]) && t->max[1] < 0);
                }
            }
            for (size_t i = 0; s.np && i < s.np - 1; i++) {
                const rto_tlas_node *t = &s.nodes[i];
                /* brute force: the union over the leaves below node i */
                size_t lo = i, hi = i;
                while (lo < s.np - 1) {
                    lo = 2 * lo + 1;
                    hi = 2 * hi + 2;
                }
                float mn = INFINITY, mx = -INFINITY;
                int any = 0;
                for (size_t l = lo; l <= hi; l++) {
                    mn = fminf(mn, s.nodes[l].min[1]);
                    mx = fmaxf(mx, s.nodes[l].max[1]);
                    any |= s.nodes[l].item != RTO_TLAS_EMPTY;
                }
                assert_true(t->min[1] == mn && t->max[1] == mx);
                assert_int_equal(t->item, any ? RTO_TLAS_INTERNAL : RTO_TLAS_EMPTY);
            }
            rto_report r;
            assert_int_equal(tlas_check(s.nodes, s.count, NULL, s.boxes, s.n, NULL, &r), RTO_OK);
            assert_int_equal(tlas_check(s.nodes, s.count, s.nodes, s.boxes, s.n, NULL, &r), RTO_OK);
            free(e);
            free(seen);
            sweep_free(&s);
        }
    }
}

/* Top-down reference for the binary radix tree: split [lo, hi] at the highest bit where keys lo and hi differ
 * (the (key, index) pair when keys repeat). Internal node numbering follows Karras: the range [lo, hi] belongs to
 * node lo or hi, whichever is its split-side end; the root is 0. */
static int highest_diff(uint64_t a, uint64_t b, uint32_t ia, uint32_t ib, int width)
{
    for (int bit = width - 1; bit >= 0; bit--)
        if (((a >> bit) & 1) != ((b >> bit) & 1))
            return bit + 32; /* key bits rank above index bits */
    for (int bit = 31; bit >= 0; bit--)
        if (((ia >> bit) & 1u) != ((ib >> bit) & 1u))
            return bit;
    return -1;
}

static int bit_of(uint64_t key, uint32_t idx, int pos) { return pos >= 32 ? (int)((key >> (pos - 32)) & 1) : (int)((idx >> pos) & 1u); }

static void reference_tree(rto_key_format f, const void *keys, uint32_t lo, uint32_t hi, uint32_t node,
                           rto_bvh_node *out)
{
    int width = f == RTO_KEY_U32 ? 32 : 64;
    int pos = highest_diff(tu_get(f, keys, lo), tu_get(f, keys, hi), lo, hi, width);
    uint32_t gamma = lo;
    while (gamma + 1 <= hi && bit_of(tu_get(f, keys, gamma + 1), gamma + 1, pos) == 0)
        gamma++;
    out[node].left = gamma == lo ? (RTO_BVH_LEAF_BIT | gamma) : gamma;
    out[node].right = gamma + 1 == hi ? (RTO_BVH_LEAF_BIT | (gamma + 1)) : gamma + 1;
    if (gamma != lo)
        reference_tree(f, keys, lo, gamma, gamma, out);
    if (gamma + 1 != hi)
        reference_tree(f, keys, gamma + 1, hi, gamma + 1, out);
}

static void expect_bvh(rto_status s, const rto_report *r, rto_bvh_fault f, int64_t node, const char *what);

static void check_karras(rto_key_format f, const void *sorted, size_t n, const rto_aabb *boxes, const char *what)
{
    rto_bvh_node *nodes = malloc((n ? n : 1) * sizeof *nodes), *ref = calloc(n ? n : 1, sizeof *ref);
    rto_bvh_node *scalar = malloc((n ? n : 1) * sizeof *scalar);
    rto_msg msg = {{0}};
    if (rto_karras_build(f, sorted, n, boxes, nodes, &msg))
        fail_msg("%s: %s", what, msg.text);
    /* every byte (links, parents, boxes, padding) as the kept per-node builder writes it */
    if (rto__karras_build_scalar(f, sorted, n, boxes, scalar, &msg))
        fail_msg("%s: scalar: %s", what, msg.text);
    for (size_t i = 0; i + 1 < n; i++)
        if (memcmp(&nodes[i], &scalar[i], sizeof *nodes))
            fail_msg("%s n=%zu: node %zu differs from the per-node builder's", what, n, i);
    free(scalar);
    if (n >= 2) {
        reference_tree(f, sorted, 0, (uint32_t)n - 1, 0, ref);
        for (size_t i = 0; i + 1 < n; i++)
            if (nodes[i].left != ref[i].left || nodes[i].right != ref[i].right)
                fail_msg("%s n=%zu: node %zu children %08x %08x, reference %08x %08x", what, n, i, nodes[i].left,
                         nodes[i].right, ref[i].left, ref[i].right);
    }
    uint32_t *prims = malloc((n ? n : 1) * 4);
    for (size_t j = 0; j < n; j++)
        prims[j] = rto_key_prim(f, tu_get(f, sorted, j));
    /* keys that repeat their primitive index (the duplicates case) give a leaf order that is no permutation,
     * which the validator must name; every other tree passes */
    int perm = 1;
    unsigned char *seen = calloc(n ? n : 1, 1);
    for (size_t j = 0; j < n; j++) {
        perm &= prims[j] < n && !seen[prims[j]];
        if (prims[j] < n)
            seen[prims[j]] = 1;
    }
    free(seen);
    rto_report r;
    rto_status s = karras_check(nodes, n >= 2 ? n - 1 : 0, nodes, prims, boxes, n, NULL, &r);
    if (perm && s != RTO_OK)
        fail_msg("%s n=%zu: self-check: %s", what, n, r.summary);
    if (!perm)
        expect_bvh(s, &r, RTO_BVH_ITEM, -1, what);
    free(nodes);
    free(ref);
    free(prims);
}

static void test_karras_matches_top_down_reference(void **state)
{
    (void)state;
    const size_t ns[] = {0, 1, 2, 3, 4, 5, 17, 100, 4095, 4096, 4097};
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof ns / sizeof ns[0]; z++) {
            size_t n = ns[z];
            rto_aabb *boxes = make_boxes(di->name, n, 1e-4f, 9);
            /* BLAS keys (u64) and TLAS keys (u32) of the same boxes, sorted by the oracle's network */
            for (int fi = 0; fi < 2; fi++) {
                rto_key_format f = fi ? RTO_KEY_U64 : RTO_KEY_U32;
                rto_vec3 *c = malloc((n ? n : 1) * sizeof *c);
                for (size_t i = 0; i < n; i++)
                    c[i] = rto_aabb_centroid(&boxes[i]);
                void *keys = malloc((n ? n : 1) * 8), *sorted = malloc((rto_next_pow2(n) + 1) * 8);
                if (fi)
                    assert_int_equal(rto_blas_keys(c, n, keys, NULL), RTO_OK);
                else
                    assert_int_equal(rto_tlas_keys(c, n, keys, NULL), RTO_OK);
                assert_int_equal(rto_bitonic_sort(f, keys, n, sorted, NULL, NULL, NULL), RTO_OK);
                check_karras(f, sorted, n, boxes, di->name);
                free(c);
                free(keys);
                free(sorted);
            }
            free(boxes);
        }
    }
    /* duplicate keys exercise the index fallback of δ */
    uint64_t dup[64];
    rto_aabb boxes[64];
    for (int i = 0; i < 64; i++) {
        dup[i] = (uint64_t)(i / 16) << 40; /* four runs of equal keys; prim = low 32 bits = 0 */
        boxes[i].min = (rto_vec3){0, 0, 0};
        boxes[i].max = (rto_vec3){1, 1, 1};
    }
    check_karras(RTO_KEY_U64, dup, 64, boxes, "duplicates");
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Mutations: each caught and named                                                                                    */

/* The fault is caught, named (code and name) and located at node (node < 0: not checked). */
static void expect_bvh(rto_status s, const rto_report *r, rto_bvh_fault f, int64_t node, const char *what)
{
    if (s != RTO_ERR_MISMATCH || r->code != (int)f || strcmp(r->fault, rto_bvh_fault_name(f)) ||
        (node >= 0 && where_of(r, "node") != node))
        fail_msg("%s: got %s at node %lld (%s), want %s at node %lld", what, r->fault, (long long)where_of(r, "node"),
                 r->summary, rto_bvh_fault_name(f), (long long)node);
    assert_int_equal(strncmp(r->summary, rto_bvh_fault_name(f), strlen(rto_bvh_fault_name(f))), 0);
}

static void test_sweep_mutations(void **state)
{
    (void)state;
    sweep s;
    sweep_make(&s, "uniform", 3000);
    rto_tlas_node *g = malloc(s.count * sizeof *g);
    rto_report r;
    const size_t leaf0 = s.np - 1;
    for (int expected = 0; expected < 2; expected++) {
        const rto_tlas_node *exp = expected ? s.nodes : NULL;
        /* wrong leaf item */
        memcpy(g, s.nodes, s.count * sizeof *g);
        g[leaf0 + 10].item = g[leaf0 + 11].item;
        expect_bvh(tlas_check(g, s.count, exp, s.boxes, s.n, NULL, &r), &r, RTO_BVH_ITEM,
                   expected ? (int64_t)(leaf0 + 10) : -1, "sweep wrong item");
        /* dropped leaf */
        memcpy(g, s.nodes, s.count * sizeof *g);
        g[leaf0 + 20].item = RTO_TLAS_EMPTY;
        expect_bvh(tlas_check(g, s.count, exp, s.boxes, s.n, NULL, &r), &r, RTO_BVH_DROPPED_LEAF,
                   expected ? (int64_t)(leaf0 + 20) : -1, "sweep dropped leaf");
        /* an internal box shrunk by one ulp */
        memcpy(g, s.nodes, s.count * sizeof *g);
        g[5].max[1] = nextafterf(g[5].max[1], -INFINITY);
        expect_bvh(tlas_check(g, s.count, exp, s.boxes, s.n, NULL, &r), &r, RTO_BVH_BOX, 5, "sweep box 1 ulp");
        /* a leaf box one ulp off an exact leaf: named at the leaf, not at the ancestors whose unions it spoiled */
        memcpy(g, s.nodes, s.count * sizeof *g);
        g[leaf0 + 7].min[0] = nextafterf(g[leaf0 + 7].min[0], INFINITY);
        expect_bvh(tlas_check(g, s.count, exp, s.boxes, s.n, NULL, &r), &r, RTO_BVH_BOX, (int64_t)(leaf0 + 7),
                   "sweep leaf box 1 ulp");
        assert_int_equal(where_of(&r, "leaf"), 7);
        assert_int_equal(where_of(&r, "primitive"), g[leaf0 + 7].item);
        /* EMPTY item on a real internal node */
        memcpy(g, s.nodes, s.count * sizeof *g);
        g[1].item = RTO_TLAS_EMPTY;
        expect_bvh(tlas_check(g, s.count, exp, s.boxes, s.n, NULL, &r), &r, RTO_BVH_EMPTY, 1, "sweep empty");
    }
    /* swapped children: the subtrees under node 2 exchanged level by level */
    memcpy(g, s.nodes, s.count * sizeof *g);
    for (size_t a = 5, b = 6, w = 1; a < s.count; a = 2 * a + 1, b = 2 * b + 1, w *= 2)
        for (size_t k = 0; k < w; k++) {
            rto_tlas_node t = g[a + k];
            g[a + k] = g[b + k];
            g[b + k] = t;
        }
    expect_bvh(tlas_check(g, s.count, s.nodes, s.boxes, s.n, NULL, &r), &r, RTO_BVH_SWAPPED, 2, "sweep swapped");
    /* a structure-only check accepts the swap: still a valid tree over the same instances */
    assert_int_equal(tlas_check(g, s.count, NULL, s.boxes, s.n, NULL, &r), RTO_OK);
    assert_string_equal(r.mode, "structure-only");
    /* size */
    expect_bvh(tlas_check(s.nodes, s.count - 1, NULL, s.boxes, s.n, NULL, &r), &r, RTO_BVH_SIZE, -1, "sweep size");
    free(g);
    sweep_free(&s);
}

static void test_karras_mutations(void **state)
{
    (void)state;
    const size_t n = 2000;
    rto_aabb *boxes = make_boxes("clustered", n, 1e-4f, 4);
    rto_vec3 *c = malloc(n * sizeof *c);
    for (size_t i = 0; i < n; i++)
        c[i] = rto_aabb_centroid(&boxes[i]);
    uint64_t *keys = malloc(n * 8), *sorted = malloc(rto_next_pow2(n) * 8);
    assert_int_equal(rto_blas_keys(c, n, keys, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U64, keys, n, sorted, NULL, NULL, NULL), RTO_OK);
    rto_bvh_node *t = malloc((n - 1) * sizeof *t), *g = malloc((n - 1) * sizeof *g);
    assert_int_equal(rto_karras_build(RTO_KEY_U64, sorted, n, boxes, t, NULL), RTO_OK);
    uint32_t *prims = malloc(n * 4);
    for (size_t j = 0; j < n; j++)
        prims[j] = rto_key_prim(RTO_KEY_U64, sorted[j]);
    rto_report r;
    /* nodes with a leaf child and an internal child, for the leaf mutations */
    size_t mixed = SIZE_MAX, twoleaf = SIZE_MAX;
    for (size_t i = 1; i < n - 1; i++) {
        int ll = (t[i].left & RTO_BVH_LEAF_BIT) != 0, rl = (t[i].right & RTO_BVH_LEAF_BIT) != 0;
        if (ll && !rl && mixed == SIZE_MAX)
            mixed = i;
        if (ll && rl && twoleaf == SIZE_MAX)
            twoleaf = i;
    }
    assert_true(mixed != SIZE_MAX && twoleaf != SIZE_MAX);
#define RESET() memcpy(g, t, (n - 1) * sizeof *g)
#define CHECK(exp) karras_check(g, n - 1, (exp), prims, boxes, n, NULL, &r)
    assert_int_equal((RESET(), CHECK(t)), RTO_OK);
    for (int expected = 0; expected < 2; expected++) {
        const rto_bvh_node *exp = expected ? t : NULL;
        RESET(); /* wrong leaf item: the right leaf of a two-leaf node points at its left leaf */
        g[twoleaf].right = g[twoleaf].left;
        expect_bvh(CHECK(exp), &r, RTO_BVH_ITEM, (int64_t)twoleaf, "karras wrong item");
        RESET(); /* box shrunk by one ulp */
        g[mixed].rmin[2] = nextafterf(g[mixed].rmin[2], INFINITY);
        expect_bvh(CHECK(exp), &r, RTO_BVH_BOX, (int64_t)mixed, "karras box 1 ulp");
        RESET(); /* dropped leaf: the parent of a mixed node links straight to its internal child */
        {
            uint32_t p = t[mixed].parent, keep = t[mixed].right;
            int side = t[p].left == mixed ? 0 : 1;
            if (side)
                g[p].right = keep;
            else
                g[p].left = keep;
            g[keep].parent = p;
            expect_bvh(CHECK(exp), &r, RTO_BVH_DROPPED_LEAF, expected ? (int64_t)mixed : -1, "karras dropped leaf");
            assert_int_equal(where_of(&r, "leaf"), t[mixed].left & ~RTO_BVH_LEAF_BIT);
            assert_int_equal(where_of(&r, "primitive"), prims[t[mixed].left & ~RTO_BVH_LEAF_BIT]);
        }
        RESET(); /* cycle: a node links back to the root */
        g[mixed].right = 0;
        expect_bvh(CHECK(exp), &r, RTO_BVH_CYCLE, (int64_t)mixed, "karras cycle");
        RESET(); /* out-of-range link */
        g[mixed].right = (uint32_t)n + 5;
        expect_bvh(CHECK(exp), &r, RTO_BVH_BAD_LINK, (int64_t)mixed, "karras bad link");
        RESET(); /* parent link */
        g[t[mixed].right].parent = 0;
        expect_bvh(CHECK(exp), &r, RTO_BVH_PARENT, -1, "karras parent");
    }
    RESET(); /* swapped children: links and boxes exchanged */
    {
        rto_bvh_node *x = &g[mixed];
        uint32_t l = x->left;
        x->left = x->right;
        x->right = l;
        for (int a = 0; a < 3; a++) {
            float v = x->lmin[a];
            x->lmin[a] = x->rmin[a];
            x->rmin[a] = v;
            v = x->lmax[a];
            x->lmax[a] = x->rmax[a];
            x->rmax[a] = v;
        }
    }
    expect_bvh(CHECK(t), &r, RTO_BVH_SWAPPED, (int64_t)mixed, "karras swapped");
    assert_int_equal(CHECK(NULL), RTO_OK); /* still a valid tree without the oracle's order */
    /* A node cut off from the tree whose leaf link is out of range, while another leaf is linked twice (so no
     * dropped-leaf fault is claimed first) and no earlier node differs from the oracle's: exact mode compares the
     * cut-off node with the oracle's without reading the leaf order out of bounds, and names the out-of-range link
     * there. Karras nodes can have a parent of higher index: cut is one such, so the walk never range-checks it. */
    {
        size_t cut = SIZE_MAX, tw = SIZE_MAX;
        for (size_t i = 1; i < n - 1 && cut == SIZE_MAX; i++)
            if ((t[i].left & RTO_BVH_LEAF_BIT) && !(t[i].right & RTO_BVH_LEAF_BIT) && t[i].parent > i)
                cut = i;
        assert_true(cut != SIZE_MAX);
        for (size_t i = cut + 1; i < n - 1 && tw == SIZE_MAX; i++)
            if ((t[i].left & RTO_BVH_LEAF_BIT) && (t[i].right & RTO_BVH_LEAF_BIT) && t[cut].right != i)
                tw = i;
        assert_true(tw != SIZE_MAX);
        RESET();
        uint32_t p = t[cut].parent, keep = t[cut].right;
        assert_true(p > cut && keep > cut);
        if (t[p].left == cut)
            g[p].left = keep;
        else
            g[p].right = keep;
        g[keep].parent = p;
        g[tw].right = g[tw].left;
        g[cut].left = RTO_BVH_LEAF_BIT | (uint32_t)n; /* one past the leaf order */
        expect_bvh(CHECK(t), &r, RTO_BVH_BAD_LINK, (int64_t)cut, "karras unreachable node with a bad leaf link");
        assert_int_equal(rto_report_check_state(&r, "links"), RTO_CHECK_FAILED);
    }
#undef RESET
#undef CHECK
    free(boxes);
    free(c);
    free(keys);
    free(sorted);
    free(t);
    free(g);
    free(prims);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* DESIGN.md §9: TLAS leaves within the transform bound, internal boxes the exact union of the dump's own children  */

/* Instances of one object box far from its object-space origin, rotated and translated back near the world origin:
 * the transform rows cancel large terms, so the §9 bound is thousands of ulps of the small world coordinates. The
 * world boxes and the bound are computed here, from the formulas in DESIGN.md and docs/bvh.md, not by the library. */
typedef struct xscene {
    size_t n;
    rto_mat34 *m;
    rto_aabb obj, *world;
    double *tol;
} xscene;

static float row_eval(const float *r, float x, float y, float z) { return ((r[0] * x + r[1] * y) + r[2] * z) + r[3]; }

static void xscene_make(xscene *x, size_t n)
{
    x->n = n;
    x->m = malloc(n * sizeof *x->m);
    x->world = malloc(n * sizeof *x->world);
    x->tol = malloc(3 * n * sizeof *x->tol);
    x->obj = (rto_aabb){{999.0f, 1999.5f, -502.0f}, {1001.0f, 2000.5f, -498.0f}};
    const double c[3] = {1000, 2000, -500};
    for (size_t i = 0; i < n; i++) {
        double a = 0.37 * (double)i, ca = cos(a), sa = sin(a), R[3][3] = {{ca, -sa, 0}, {sa, ca, 0}, {0, 0, 1}};
        double off[3] = {(double)(i % 10), (double)(i / 10), 0.25 * (double)i};
        for (int r = 0; r < 3; r++) {
            double t = off[r];
            for (int k = 0; k < 3; k++) {
                x->m[i].m[r][k] = (float)R[r][k];
                t -= R[r][k] * c[k];
            }
            x->m[i].m[r][3] = (float)t;
        }
        rto_aabb w = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
        for (int k = 0; k < 8; k++) {
            float px = (k & 1) ? x->obj.max.x : x->obj.min.x, py = (k & 2) ? x->obj.max.y : x->obj.min.y,
                  pz = (k & 4) ? x->obj.max.z : x->obj.min.z;
            float q[3];
            for (int r = 0; r < 3; r++)
                q[r] = row_eval(x->m[i].m[r], px, py, pz);
            w.min.x = fminf(w.min.x, q[0]), w.min.y = fminf(w.min.y, q[1]), w.min.z = fminf(w.min.z, q[2]);
            w.max.x = fmaxf(w.max.x, q[0]), w.max.y = fmaxf(w.max.y, q[1]), w.max.z = fmaxf(w.max.z, q[2]);
        }
        x->world[i] = w;
        /* 8 * 2^-24 * max over the corners of |m0 x| + |m1 y| + |m2 z| + |t| */
        const float lo[3] = {x->obj.min.x, x->obj.min.y, x->obj.min.z},
                    hi[3] = {x->obj.max.x, x->obj.max.y, x->obj.max.z};
        for (int r = 0; r < 3; r++) {
            double worst = 0;
            for (int k = 0; k < 8; k++) {
                double sum = fabs((double)x->m[i].m[r][3]);
                for (int a2 = 0; a2 < 3; a2++)
                    sum += fabs((double)x->m[i].m[r][a2] * (double)(((k >> a2) & 1) ? hi[a2] : lo[a2]));
                worst = sum > worst ? sum : worst;
            }
            x->tol[3 * i + r] = 8.0 * ldexp(worst, -24);
        }
    }
}

static void xscene_free(xscene *x)
{
    free(x->m);
    free(x->world);
    free(x->tol);
}

/* The float farthest from e in direction dir (+1 / -1) that is still within tol of it. */
static float within(float e, double tol, int dir)
{
    float v = (float)((double)e + dir * tol);
    while (fabs((double)v - (double)e) > tol)
        v = nextafterf(v, dir > 0 ? -INFINITY : INFINITY);
    while (fabs((double)nextafterf(v, dir > 0 ? INFINITY : -INFINITY) - (double)e) <= tol)
        v = nextafterf(v, dir > 0 ? INFINITY : -INFINITY);
    return v;
}

static uint64_t ulp_distance(float a, float b)
{
    int32_t ia, ib;
    memcpy(&ia, &a, 4);
    memcpy(&ib, &b, 4);
    int64_t oa = ia < 0 ? -(int64_t)(ia & 0x7FFFFFFF) : ia, ob = ib < 0 ? -(int64_t)(ib & 0x7FFFFFFF) : ib;
    return (uint64_t)(oa > ob ? oa - ob : ob - oa);
}

/* The sorted TLAS keys of n instance boxes as a build makes them (rto_tlas_keys_from_boxes, then a sort): one per
 * non-empty box, which holds the real box index in its low 16 bits. Returns how many. */
static size_t tlas_sorted_keys(const rto_aabb *boxes, size_t n, uint32_t *keys, uint32_t *sorted)
{
    size_t m = 0;
    rto_msg msg = {{0}};
    if (rto_tlas_keys_from_boxes(boxes, n, keys, &m, &msg) || rto_fast_radix_sort(RTO_KEY_U32, keys, m, sorted, &msg))
        fail_msg("TLAS keys: %s", msg.text);
    return m;
}

/* Recomputes every sweep ancestor of node i as the union of its children (what a GPU does after its leaves). */
static void sweep_reunion(rto_tlas_node *g, size_t i)
{
    while (i > 0) {
        i = (i - 1) / 2;
        const rto_tlas_node *a = &g[2 * i + 1], *b = &g[2 * i + 2];
        for (int k = 0; k < 3; k++) {
            g[i].min[k] = a->min[k] < b->min[k] ? a->min[k] : b->min[k];
            g[i].max[k] = a->max[k] > b->max[k] ? a->max[k] : b->max[k];
        }
    }
}

static void test_sweep_tolerance_model(void **state)
{
    (void)state;
    xscene x;
    xscene_make(&x, 100);
    const size_t np = 128, count = 2 * np - 1, leaf0 = np - 1;
    uint32_t keys[100], sorted[128];
    rto_tlas_node *t = malloc(count * sizeof *t), *g = malloc(count * sizeof *g);
    assert_int_equal(tlas_sorted_keys(x.world, x.n, keys, sorted), x.n);
    assert_int_equal(rto_tlas_build_sweep(sorted, x.n, x.world, t, NULL), RTO_OK);
    rto_report r;
    assert_int_equal(tlas_check(t, count, t, x.world, x.n, x.tol, &r), RTO_OK);
    assert_int_equal(tlas_check(t, count, NULL, x.world, x.n, x.tol, &r), RTO_OK);
    for (int exact = 0; exact < 2; exact++) {
        const rto_tlas_node *exp = exact ? t : NULL;
        for (int side = 0; side < 2; side++) { /* max.x pushed up, min.y pushed down */
            const size_t L = leaf0 + 10, k = t[L].item;
            const int axis = side ? 1 : 0, dir = side ? -1 : 1;
            const float e = side ? t[L].min[axis] : t[L].max[axis];
            const float in = within(e, x.tol[3 * k + axis], dir), out = nextafterf(in, dir > 0 ? INFINITY : -INFINITY);
            /* the bound is what admits this leaf: far more than a fixed count of ulps */
            assert_true(ulp_distance(in, e) > 64);
            for (int reunion = 0; reunion < 2; reunion++) {
                /* within the bound: the leaf and its ancestors (the union of the dump's children) pass */
                memcpy(g, t, count * sizeof *g);
                *(side ? &g[L].min[axis] : &g[L].max[axis]) = in;
                sweep_reunion(g, L);
                if (tlas_check(g, count, exp, x.world, x.n, x.tol, &r) != RTO_OK)
                    fail_msg("leaf within the §9 bound (exact %d, side %d): %s", exact, side, r.summary);
                /* one float beyond it: a box fault at the leaf, whether or not the ancestors follow it */
                *(side ? &g[L].min[axis] : &g[L].max[axis]) = out;
                if (reunion)
                    sweep_reunion(g, L);
                expect_bvh(tlas_check(g, count, exp, x.world, x.n, x.tol, &r), &r, RTO_BVH_BOX, (int64_t)L,
                           "leaf just beyond the §9 bound");
                assert_int_equal(where_of(&r, "leaf"), 10);
                assert_int_equal(where_of(&r, "primitive"), (int64_t)k);
                assert_true(r.tolerance_bound == x.tol[3 * k + axis]);
                assert_true(r.nrows >= 1 && r.rows[0].tolerance.type == RTO_VALUE_F64);
                assert_string_equal(r.rows[0].field, side ? "min.y" : "max.x");
            }
        }
        /* an internal box one ulp off the union of the dump's children: box at that node */
        memcpy(g, t, count * sizeof *g);
        g[3].min[2] = nextafterf(g[3].min[2], -INFINITY);
        expect_bvh(tlas_check(g, count, exp, x.world, x.n, x.tol, &r), &r, RTO_BVH_BOX, 3, "internal box 1 ulp");
        /* an EMPTY leaf with a finite box: empty at that leaf, not box at its parent */
        for (int reunion = 0; reunion < 2; reunion++) {
            memcpy(g, t, count * sizeof *g);
            const size_t E = leaf0 + 100;
            assert_int_equal(g[E].item, RTO_TLAS_EMPTY);
            memcpy(g[E].min, &x.world[0].min, 12);
            memcpy(g[E].max, &x.world[0].max, 12);
            if (reunion)
                sweep_reunion(g, E);
            expect_bvh(tlas_check(g, count, exp, x.world, x.n, x.tol, &r), &r, RTO_BVH_EMPTY, (int64_t)E,
                       "EMPTY leaf with a finite box");
        }
        /* an EMPTY internal node (both children EMPTY) with a finite box: empty at that node */
        memcpy(g, t, count * sizeof *g);
        const size_t P = (leaf0 + 126 - 1) / 2;
        assert_int_equal(g[P].item, RTO_TLAS_EMPTY);
        memcpy(g[P].min, &x.world[0].min, 12);
        memcpy(g[P].max, &x.world[0].max, 12);
        expect_bvh(tlas_check(g, count, exp, x.world, x.n, x.tol, &r), &r, RTO_BVH_EMPTY, (int64_t)P,
                   "EMPTY internal node with a finite box");
    }
    free(t);
    free(g);
    xscene_free(&x);
}

static void test_karras_tolerance_model(void **state)
{
    (void)state;
    xscene x;
    xscene_make(&x, 100);
    const size_t n = 100;
    uint32_t keys[100], sorted[128], prims[100];
    rto_bvh_node *t = malloc((n - 1) * sizeof *t), *g = malloc((n - 1) * sizeof *g);
    assert_int_equal(tlas_sorted_keys(x.world, n, keys, sorted), n);
    assert_int_equal(rto_karras_build(RTO_KEY_U32, sorted, n, x.world, t, NULL), RTO_OK);
    for (size_t j = 0; j < n; j++)
        prims[j] = sorted[j] & 0xFFFFu;
    rto_report r;
    assert_int_equal(karras_check(t, n - 1, t, prims, x.world, n, x.tol, &r), RTO_OK);
    /* a node (not the root) with a leaf on its left */
    size_t i = 1;
    while (i < n - 1 && !(t[i].left & RTO_BVH_LEAF_BIT))
        i++;
    assert_true(i < n - 1);
    const uint32_t j = t[i].left & ~RTO_BVH_LEAF_BIT, k = prims[j], p = t[i].parent;
    const float e = t[i].lmax[2], in = within(e, x.tol[3 * k + 2], 1), out = nextafterf(in, INFINITY);
    for (int exact = 0; exact < 2; exact++) {
        memcpy(g, t, (n - 1) * sizeof *g);
        g[i].lmax[2] = in;
        /* the ancestors' child boxes follow the dump's own children: passes */
        float *pmax = t[p].left == i ? g[p].lmax : g[p].rmax;
        pmax[2] = fmaxf(pmax[2], in);
        /* and so on up to the root */
        for (uint32_t c = p; c != 0;) {
            uint32_t pp = g[c].parent;
            float *m = g[pp].left == c ? g[pp].lmax : g[pp].rmax;
            m[2] = fmaxf(g[c].lmax[2], g[c].rmax[2]);
            c = pp;
        }
        if (karras_check(g, n - 1, exact ? t : NULL, prims, x.world, n, x.tol, &r) != RTO_OK)
            fail_msg("Karras leaf within the §9 bound: %s", r.summary);
        /* one float beyond: box at the node holding the leaf, not at its parent */
        g[i].lmax[2] = out;
        expect_bvh(karras_check(g, n - 1, exact ? t : NULL, prims, x.world, n, x.tol, &r), &r, RTO_BVH_BOX,
                   (int64_t)i, "Karras leaf just beyond the §9 bound");
        assert_int_equal(where_of(&r, "leaf"), j);
        assert_int_equal(where_of(&r, "primitive"), k);
        assert_string_equal(r.rows[0].field, "lmax.z");
    }
    free(t);
    free(g);
    xscene_free(&x);
}

/* The shared decision on empty meshes: an instance with an empty world box has no leaf; the tree is built over the
 * others, whose keys keep the real instance index. */
static void test_empty_instances(void **state)
{
    (void)state;
    const size_t n = 40, np = 64, count = 2 * np - 1;
    rto_aabb *boxes = make_boxes("uniform", n, 1e-3f, 5);
    const rto_aabb empty = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    boxes[5] = boxes[17] = boxes[39] = empty;
    uint32_t keys[40], sorted[64];
    const size_t keyed = tlas_sorted_keys(boxes, n, keys, sorted);
    assert_int_equal(keyed, 37);
    rto_tlas_node *t = malloc(count * sizeof *t), *g = malloc(count * sizeof *g);
    assert_int_equal(rto_tlas_build_sweep(sorted, keyed, boxes, t, NULL), RTO_OK);
    rto_report r;
    assert_int_equal(tlas_check(t, count, t, boxes, n, NULL, &r), RTO_OK);
    assert_int_equal(tlas_check(t, count, NULL, boxes, n, NULL, &r), RTO_OK);
    /* a tree over all 40 (one leaf per instance) has the wrong size */
    expect_bvh(tlas_check(t, 2 * 64 - 2, NULL, boxes, n, NULL, &r), &r, RTO_BVH_SIZE, -1, "sweep size with empties");
    /* an EMPTY leaf given an empty instance: item at that leaf */
    for (int exact = 0; exact < 2; exact++) {
        memcpy(g, t, count * sizeof *g);
        const size_t L = np - 1 + 50;
        assert_int_equal(g[L].item, RTO_TLAS_EMPTY);
        g[L].item = 17;
        expect_bvh(tlas_check(g, count, exact ? t : NULL, boxes, n, NULL, &r), &r, RTO_BVH_ITEM, (int64_t)L,
                   "a leaf for an empty instance");
    }
    /* a real instance's leaf given an empty instance instead (the real one now in no leaf): item at that leaf,
     * where the fault starts, before the instance it pushed out (dropped-leaf, seen too) */
    for (int exact = 0; exact < 2; exact++) {
        memcpy(g, t, count * sizeof *g);
        const size_t L = np - 1 + 10;
        const uint32_t lost = g[L].item;
        assert_true(lost < n && lost != 5 && lost != 17 && lost != 39);
        g[L].item = 5;
        expect_bvh(tlas_check(g, count, exact ? t : NULL, boxes, n, NULL, &r), &r, RTO_BVH_ITEM, (int64_t)L,
                   "an empty instance in place of a real one");
        assert_int_equal(where_of(&r, "leaf"), 10);
        assert_int_equal(where_of(&r, "primitive"), 5);
        assert_non_null(strstr(r.summary, "an instance of an empty BLAS"));
        int dropped = 0;
        for (uint32_t k = 0; k < r.nfaults_seen; k++)
            dropped |= !strcmp(r.faults_seen[k], "dropped-leaf");
        assert_true(dropped);
    }
    free(t);
    free(g);
    free(boxes);
}

/* A GPU's own leaf order must be a permutation: a duplicated triangle (another in no leaf) is an item fault at the
 * leaf that holds the wrong one — the one whose box in the tree is not that triangle's box. */
static void test_leaf_order_permutation(void **state)
{
    (void)state;
    const size_t n = 500;
    rto_aabb *boxes = make_boxes("uniform", n, 1e-3f, 6);
    rto_vec3 *c = malloc(n * sizeof *c);
    for (size_t i = 0; i < n; i++)
        c[i] = rto_aabb_centroid(&boxes[i]);
    uint64_t *keys = malloc(n * 8), *sorted = malloc(512 * 8);
    assert_int_equal(rto_blas_keys(c, n, keys, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U64, keys, n, sorted, NULL, NULL, NULL), RTO_OK);
    rto_bvh_node *t = malloc((n - 1) * sizeof *t);
    assert_int_equal(rto_karras_build(RTO_KEY_U64, sorted, n, boxes, t, NULL), RTO_OK);
    uint32_t *prims = malloc(n * 4), *order = malloc(n * 4);
    for (size_t j = 0; j < n; j++)
        prims[j] = (uint32_t)sorted[j];
    /* the node linking each sorted leaf, found here */
    uint32_t *holder = malloc(n * 4);
    for (size_t i = 0; i + 1 < n; i++) {
        if (t[i].left & RTO_BVH_LEAF_BIT)
            holder[t[i].left & ~RTO_BVH_LEAF_BIT] = (uint32_t)i;
        if (t[i].right & RTO_BVH_LEAF_BIT)
            holder[t[i].right & ~RTO_BVH_LEAF_BIT] = (uint32_t)i;
    }
    rto_report r;
    const size_t a = 100, b = 300;
    for (int which = 0; which < 2; which++) {
        memcpy(order, prims, n * 4);
        size_t bad = which ? a : b; /* leaf `bad` takes the triangle of the other leaf */
        order[bad] = prims[which ? b : a];
        expect_bvh(karras_check(t, n - 1, NULL, order, boxes, n, NULL, &r), &r, RTO_BVH_ITEM, holder[bad],
                   "duplicated triangle in the leaf order");
        assert_int_equal(where_of(&r, "leaf"), (int64_t)bad);
        assert_int_equal(where_of(&r, "primitive"), order[bad]);
    }
    memcpy(order, prims, n * 4);
    order[7] = (uint32_t)n; /* no such triangle */
    expect_bvh(karras_check(t, n - 1, NULL, order, boxes, n, NULL, &r), &r, RTO_BVH_ITEM, holder[7],
               "out-of-range triangle in the leaf order");
    assert_int_equal(where_of(&r, "leaf"), 7);
    free(boxes);
    free(c);
    free(keys);
    free(sorted);
    free(t);
    free(prims);
    free(order);
    free(holder);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sweep_tree_invariants),
        cmocka_unit_test(test_karras_matches_top_down_reference),
        cmocka_unit_test(test_sweep_mutations),
        cmocka_unit_test(test_karras_mutations),
        cmocka_unit_test(test_sweep_tolerance_model),
        cmocka_unit_test(test_karras_tolerance_model),
        cmocka_unit_test(test_empty_instances),
        cmocka_unit_test(test_leaf_order_permutation),
        cmocka_unit_test(test_procedural_scene_trees),
        cmocka_unit_test(test_fixture_trees),
        cmocka_unit_test(test_accel_bytes_do_not_depend_on_threads),
        cmocka_unit_test(test_karras_team_matches_scalar),
        cmocka_unit_test(test_empty_mesh_builds_an_empty_blas),
        cmocka_unit_test(test_tlas_keys_skip_empty_boxes),
        cmocka_unit_test(test_accel_contract),
        cmocka_unit_test(test_accel_tlas_key_refusals),
        cmocka_unit_test(test_accel_index_refusals),
        cmocka_unit_test(test_accel_instance_refusals),
        cmocka_unit_test(test_accel_null_mesh_precedence),
        cmocka_unit_test(test_accel_check_names_the_tree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
