/* TLAS sweep tree and Karras trees against independent references (a top-down radix split computed bit by bit,
 * brute-force unions, qsort), the acceleration-structure object against the step-by-step pipeline with the canonical
 * network, empty meshes, and mutation tests for the tree validators. */
#include "testutil.h"
#include "bvh/bvh_internal.h" /* rto__karras_build_scalar, the kept per-node builder */

#include <math.h>
#include <unistd.h>

/* Boxes of half-size h around the centroids of a centroid distribution. */
static rto_aabb *make_boxes(const char *dist, size_t n, float h, uint32_t seed)
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

static int64_t where_of(const rto_report *r, const char *name)
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

static const size_t sizes[] = {0, 1, 2, 3, 4095, 4096, 4097, 65536};

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

/* ------------------------------------------------------------------------------------------------------------------ */
/* Trees of real scenes: every fixture, rtstress:1..40, instances:DIST:N                                               */

/* The TLAS statistics the accel computed in its stages, against the public functions over the reference tree. */
static void expect_stats(const rto_bvh_stats *got, rto_bvh_stats want, const char *spec)
{
    if (got->depth != want.depth || got->leaves != want.leaves || memcmp(&got->sah, &want.sah, sizeof want.sah))
        fail_msg("%s: TLAS stats depth %u leaves %u sah %.17g, the reference's %u %u %.17g", spec, got->depth,
                 got->leaves, got->sah, want.depth, want.leaves, want.sah);
}

/* The pipeline written out step by step with the canonical bitonic network, as the builds ran it before they sorted
 * with rto_fast_radix_sort: the accel must give the same bytes (§4: real keys are unique). */
static void reference_tlas(const rto_scene *sc, rto_tlas_kind kind, const rto_accel_tlas *t, const char *spec)
{
    const size_t n = sc->instance_count, np = rto_next_pow2(n);
    rto_aabb *boxes = malloc((n ? n : 1) * sizeof *boxes);
    rto_vec3 *c = malloc((n ? n : 1) * sizeof *c);
    uint32_t *keys = malloc((n ? n : 1) * 4), *sorted = malloc((np ? np : 1) * 4);
    for (size_t i = 0; i < n; i++) {
        boxes[i] = rto_instance_aabb(sc, (uint32_t)i);
        c[i] = rto_aabb_centroid(&boxes[i]);
    }
    assert_int_equal(rto_tlas_keys(c, n, keys, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U32, keys, n, sorted, NULL, NULL, NULL), RTO_OK);
    assert_int_equal(t->instance_count, n);
    assert_int_equal(t->key_count, n);
    assert_int_equal(t->n_padded, np);
    if (memcmp(t->instance_aabbs, boxes, n * sizeof *boxes) || memcmp(t->keys, keys, n * 4) ||
        memcmp(t->sorted_keys, sorted, np * 4))
        fail_msg("%s: TLAS boxes or keys differ from the step-by-step pipeline", spec);
    if (kind == RTO_TLAS_SWEEP) {
        rto_tlas_node *nodes = malloc(rto_tlas_sweep_node_count(n) * sizeof *nodes);
        assert_int_equal(rto_tlas_build_sweep(sorted, n, boxes, nodes, NULL), RTO_OK);
        assert_int_equal(t->node_count, rto_tlas_sweep_node_count(n));
        assert_null(t->karras_nodes);
        if (memcmp(t->sweep_nodes, nodes, t->node_count * sizeof *nodes))
            fail_msg("%s: sweep TLAS differs from the step-by-step pipeline", spec);
        expect_stats(&t->stats, rto_tlas_stats(nodes, n), spec);
        free(nodes);
    } else {
        rto_bvh_node *nodes = malloc((n ? n : 1) * sizeof *nodes);
        assert_int_equal(rto__karras_build_scalar(RTO_KEY_U32, sorted, n, boxes, nodes, NULL), RTO_OK);
        assert_int_equal(t->node_count, n >= 2 ? n - 1 : 0);
        assert_null(t->sweep_nodes);
        if (memcmp(t->karras_nodes, nodes, t->node_count * sizeof *nodes))
            fail_msg("%s: Karras TLAS differs from the step-by-step pipeline", spec);
        const rto_aabb root = rto_scene_aabb(sc); /* the union of the instances' world boxes */
        expect_stats(&t->stats, rto_karras_stats(nodes, n, &root), spec);
        free(nodes);
    }
    free(boxes);
    free(c);
    free(keys);
    free(sorted);
}

static void reference_blas(const rto_mesh *mesh, const rto_accel_blas *b, const char *spec)
{
    const size_t t = mesh->triangle_count, tp = rto_next_pow2(t);
    uint64_t *bk = malloc((t ? t : 1) * 8), *bs = malloc((tp ? tp : 1) * 8);
    rto_aabb *tb = malloc((t ? t : 1) * sizeof *tb);
    rto_bvh_node *bn = malloc((t ? t : 1) * sizeof *bn);
    uint32_t *order = malloc((t ? t : 1) * 4);
    for (size_t i = 0; i < t; i++)
        tb[i] = rto_mesh_triangle_aabb(mesh, (uint32_t)i);
    assert_int_equal(rto_mesh_keys(mesh, bk, NULL), RTO_OK);
    assert_int_equal(rto_bitonic_sort(RTO_KEY_U64, bk, t, bs, NULL, NULL, NULL), RTO_OK);
    for (size_t j = 0; j < t; j++)
        order[j] = (uint32_t)bs[j]; /* the low word of a BLAS key is the triangle */
    assert_int_equal(rto__karras_build_scalar(RTO_KEY_U64, bs, t, tb, bn, NULL), RTO_OK);
    assert_int_equal(b->triangle_count, t);
    assert_int_equal(b->node_count, t >= 2 ? t - 1 : 0);
    rto_aabb bounds = rto_mesh_aabb(mesh); /* the accel takes it as the union of the triangle boxes */
    if (memcmp(&b->bounds, &bounds, sizeof bounds))
        fail_msg("%s BLAS %u: bounds differ from rto_mesh_aabb", spec, b->mesh);
    if (memcmp(b->sorted_keys, bs, t * 8) || memcmp(b->order, order, t * 4) || memcmp(b->prim_aabbs, tb, t * sizeof *tb) ||
        memcmp(b->nodes, bn, b->node_count * sizeof *bn))
        fail_msg("%s BLAS %u: differs from the step-by-step pipeline", spec, b->mesh);
    /* statistics as rto_karras_stats computes them from the finished tree (a walk from the root for the depth) */
    const rto_bvh_stats st = rto_karras_stats(bn, t, &bounds);
    if (b->stats.depth != st.depth || b->stats.leaves != st.leaves || memcmp(&b->stats.sah, &st.sah, sizeof st.sah))
        fail_msg("%s BLAS %u: stats depth %u sah %.17g, rto_karras_stats %u %.17g", spec, b->mesh, b->stats.depth,
                 b->stats.sah, st.depth, st.sah);
    free(bk);
    free(bs);
    free(tb);
    free(bn);
    free(order);
}

/* Builds both accels of a scene (sweep and Karras TLAS) and checks them: the same bytes as the step-by-step
 * pipeline with the canonical network, each instance / triangle in exactly one leaf (counted here), and the
 * validators' structure checks through rto_accel_check. */
static void check_scene_trees(const char *spec)
{
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(spec, &sc, &msg))
        fail_msg("%s: %s", spec, msg.text);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        if (rto_accel_build(sc, &desc, &acc, &msg))
            fail_msg("%s: %s", spec, msg.text);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        reference_tlas(sc, desc.tlas, t, spec);
        const size_t n = t->instance_count, np = t->n_padded;
        unsigned char *seen = calloc(n ? n : 1, 1);
        if (desc.tlas == RTO_TLAS_SWEEP) {
            for (size_t j = 0; j < np; j++) {
                uint32_t it = t->sweep_nodes[np - 1 + j].item;
                if (j < n) {
                    assert_true(it < n && !seen[it]);
                    seen[it] = 1;
                } else {
                    assert_int_equal(it, RTO_TLAS_EMPTY);
                }
            }
        }
        assert_int_equal(rto_accel_blas_count(acc), sc->mesh_count);
        for (uint32_t m = 0; m < sc->mesh_count; m++)
            reference_blas(&sc->meshes[m], rto_accel_get_blas(acc, m), spec);
        assert_null(rto_accel_get_blas(acc, sc->mesh_count));
        rto_report r;
        if (rto_accel_check(acc, &r, &msg) != RTO_OK)
            fail_msg("%s %s: %s", spec, kind ? "karras" : "sweep", msg.text);
        free(seen);
        rto_accel_destroy(acc);
    }
    rto_scene_destroy(sc);
}

static void test_procedural_scene_trees(void **state)
{
    (void)state;
    char spec[64];
    /* Under the sanitizer: every scene up to 8 objects, then every fourth up to the largest. */
    for (int n = 1; n <= 40; n += TU_SANITIZED && n >= 8 ? 4 : 1) {
        snprintf(spec, sizeof spec, "rtstress:%d", n);
        check_scene_trees(spec);
    }
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof sizes / sizeof sizes[0]; z++) {
            snprintf(spec, sizeof spec, "instances:%s:%zu", di->name, sizes[z]);
            check_scene_trees(spec);
        }
    }
    check_scene_trees("triangle");
}

static void test_fixture_trees(void **state)
{
    (void)state;
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    const char *files[] = {"Box/glTF/Box.gltf", "SimpleMeshes/glTF/SimpleMeshes.gltf", "Duck/glTF/Duck.gltf",
                           "CornellBox-nvpro-glTF/cornellBox.gltf", "StanfordBunny/bunny.gltf",
                           "Suzanne/glTF/Suzanne.gltf", "WaterBottle/glTF/WaterBottle.gltf"};
    char path[1024];
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", fix, files[i]);
        check_scene_trees(path);
    }
}

/* The same bytes with any thread count (DESIGN.md §2): every array and statistic of every tree, built with 1 thread
 * and with several (big meshes split among the team, small ones one per worker). */
/* Field by field: the struct has padding. */
static int same_stats(const rto_bvh_stats *a, const rto_bvh_stats *b)
{
    return a->depth == b->depth && a->leaves == b->leaves && !memcmp(&a->sah, &b->sah, sizeof a->sah);
}

static void expect_same_accel(const rto_accel *x, const rto_accel *y, const char *spec, uint32_t threads)
{
    const rto_accel_tlas *a = rto_accel_get_tlas(x), *b = rto_accel_get_tlas(y);
    if (a->kind != b->kind || a->instance_count != b->instance_count || a->key_count != b->key_count ||
        a->n_padded != b->n_padded || a->node_count != b->node_count ||
        memcmp(a->instance_aabbs, b->instance_aabbs, a->instance_count * sizeof(rto_aabb)) ||
        memcmp(a->keys, b->keys, a->key_count * 4u) || memcmp(a->sorted_keys, b->sorted_keys, a->n_padded * 4u) ||
        (a->sweep_nodes && memcmp(a->sweep_nodes, b->sweep_nodes, a->node_count * sizeof(rto_tlas_node))) ||
        (a->karras_nodes && memcmp(a->karras_nodes, b->karras_nodes, a->node_count * sizeof(rto_bvh_node))) ||
        !same_stats(&a->stats, &b->stats))
        fail_msg("%s: the TLAS with %u threads differs from the one with 1", spec, threads);
    assert_int_equal(rto_accel_blas_count(x), rto_accel_blas_count(y));
    for (uint32_t m = 0; m < rto_accel_blas_count(x); m++) {
        const rto_accel_blas *p = rto_accel_get_blas(x, m), *q = rto_accel_get_blas(y, m);
        const size_t t = p->triangle_count;
        if (p->triangle_count != q->triangle_count || p->node_count != q->node_count ||
            memcmp(&p->bounds, &q->bounds, sizeof p->bounds) || memcmp(p->sorted_keys, q->sorted_keys, t * 8) ||
            memcmp(p->order, q->order, t * 4) || memcmp(p->prim_aabbs, q->prim_aabbs, t * sizeof(rto_aabb)) ||
            memcmp(p->nodes, q->nodes, p->node_count * sizeof(rto_bvh_node)) ||
            !same_stats(&p->stats, &q->stats))
            fail_msg("%s: BLAS %u with %u threads differs from the one with 1", spec, m, threads);
    }
}

static void check_threads(const rto_scene *sc, const char *spec)
{
    static const uint32_t threads[] = {2, 3, 8, 33};
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc one = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 1};
        rto_accel *ref = NULL;
        rto_msg msg = {{0}};
        if (rto_accel_build(sc, &one, &ref, &msg))
            fail_msg("%s: %s", spec, msg.text);
        for (size_t i = 0; i < sizeof threads / sizeof threads[0]; i++) {
            rto_accel_desc d = one;
            d.threads = threads[i];
            rto_accel *acc = NULL;
            if (rto_accel_build(sc, &d, &acc, &msg))
                fail_msg("%s, %u threads: %s", spec, threads[i], msg.text);
            expect_same_accel(ref, acc, spec, threads[i]);
            rto_accel_destroy(acc);
        }
        rto_accel_destroy(ref);
    }
}

static void check_threads_spec(const char *spec)
{
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(spec, &sc, &msg))
        fail_msg("%s: %s", spec, msg.text);
    check_threads(sc, spec);
    rto_scene_destroy(sc);
}

static void test_accel_bytes_do_not_depend_on_threads(void **state)
{
    (void)state;
    char path[1024];
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    snprintf(path, sizeof path, "%s/StanfordBunny/bunny.gltf", fix); /* one big mesh: built by the whole team */
    check_threads_spec(path);
    const char *models = getenv("RTO_ASSIMP_MODELS"); /* 34 meshes: one worker each */
    if (models) {
        snprintf(path, sizeof path, "%s/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", models);
        if (access(path, R_OK) == 0)
            check_threads_spec(path);
    }
    check_threads_spec("rtstress:4");
    check_threads_spec("instances:clustered:4097");
    check_threads_spec("instances:uniform:65536");
    check_threads_spec("triangle"); /* one triangle */
    /* an empty mesh beside a non-empty one, its instances unkeyed; and a scene with nothing at all */
    rto_scene empty;
    memset(&empty, 0, sizeof empty);
    check_threads(&empty, "no meshes");
    rto_mesh none;
    memset(&none, 0, sizeof none);
    snprintf(none.name, sizeof none.name, "empty");
    none.material = -1;
    rto_instance inst;
    memset(&inst, 0, sizeof inst);
    const double m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&inst, m, NULL), RTO_OK);
    inst.mask = 0xFF;
    empty.meshes = &none;
    empty.mesh_count = 1;
    empty.instances = &inst;
    empty.instance_count = 1;
    check_threads(&empty, "one empty mesh");
}

/* The Karras builder's subtrees (several workers) on key sets of every distribution, duplicates included: the same
 * bytes as the kept per-node builder. */
static void test_karras_team_matches_scalar(void **state)
{
    (void)state;
    const size_t ns[] = {2, 3, 1000, 4097, 30000};
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *di = rto_dist_at(d);
        if (di->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t z = 0; z < sizeof ns / sizeof ns[0]; z++) {
            const size_t n = ns[z];
            rto_aabb *boxes = make_boxes(di->name, n, 1e-4f, 9);
            rto_vec3 *c = malloc(n * sizeof *c);
            uint64_t *keys = malloc(n * 8), *sorted = malloc(n * 8);
            for (size_t i = 0; i < n; i++)
                c[i] = rto_aabb_centroid(&boxes[i]);
            assert_int_equal(rto_blas_keys(c, n, keys, NULL), RTO_OK);
            assert_int_equal(rto_fast_radix_sort(RTO_KEY_U64, keys, n, sorted, NULL), RTO_OK);
            /* and the same keys with their index dropped: duplicates fall back to the index prefix */
            for (int dup = 0; dup < 2; dup++) {
                if (dup)
                    for (size_t i = 0; i < n; i++)
                        sorted[i] &= ~(uint64_t)0xFFFFFFFFu;
                rto_bvh_node *want = malloc(n * sizeof *want), *got = malloc(n * sizeof *got);
                assert_int_equal(rto__karras_build_scalar(RTO_KEY_U64, sorted, n, boxes, want, NULL), RTO_OK);
                const rto_bvh_stats st = rto_karras_stats(want, n, &boxes[0]);
                for (uint32_t workers = 1; workers <= 16; workers *= 2) {
                    memset(got, 0xA5, n * sizeof *got);
                    rto__karras k;
                    memset(&k, 0, sizeof k);
                    k.f = RTO_KEY_U64;
                    k.keys = sorted;
                    k.n = n;
                    k.boxes = boxes;
                    k.nodes = got;
                    assert_int_equal(rto__karras_plan(&k, workers, NULL), RTO_OK);
                    for (uint32_t w = workers; w-- > 0;) /* any order: the workers share nothing they write */
                        rto__karras_run(&k, w, workers);
                    rto__karras_finish(&k);
                    if (memcmp(got, want, (n - 1) * sizeof *got))
                        fail_msg("%s n=%zu dup=%d workers=%u: nodes differ from the per-node builder's", di->name, n,
                                 dup, workers);
                    if (k.depth != st.depth)
                        fail_msg("%s n=%zu dup=%d workers=%u: depth %u, rto_karras_stats %u", di->name, n, dup,
                                 workers, k.depth, st.depth);
                    rto__karras_free(&k);
                }
                free(want);
                free(got);
            }
            free(boxes);
            free(c);
            free(keys);
            free(sorted);
        }
    }
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* Empty meshes (DESIGN.md §5): an empty BLAS, and no TLAS key or leaf for its instances                              */

/* A scene assembled by hand: mesh 0 a unit quad (two triangles), mesh 1 empty; instances of mesh (i % 2) translated
 * by offsets[i]. The arrays are static: the scene is never passed to rto_scene_destroy. */
typedef struct hand_scene {
    rto_scene sc;
    rto_mesh meshes[2];
    rto_instance inst[8];
} hand_scene;

static float quad_pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};
static float empty_pos[] = {7, 7, 7};

static void hand_scene_make(hand_scene *h, const uint32_t *blas, const float (*offsets)[3], uint32_t n)
{
    memset(h, 0, sizeof *h);
    snprintf(h->sc.source, sizeof h->sc.source, "hand-made");
    snprintf(h->meshes[0].name, sizeof h->meshes[0].name, "quad");
    h->meshes[0].vertex_count = 4;
    h->meshes[0].positions = quad_pos;
    h->meshes[0].triangle_count = 2;
    h->meshes[0].indices = quad_idx;
    h->meshes[0].material = -1;
    snprintf(h->meshes[1].name, sizeof h->meshes[1].name, "empty");
    h->meshes[1].vertex_count = 1; /* vertices but no triangle, as a glTF primitive with no indices left */
    h->meshes[1].positions = empty_pos;
    h->meshes[1].material = -1;
    for (uint32_t i = 0; i < n; i++) {
        const double m[3][4] = {{1, 0, 0, offsets[i][0]}, {0, 1, 0, offsets[i][1]}, {0, 0, 1, offsets[i][2]}};
        assert_int_equal(rto_instance_set_transform(&h->inst[i], m, NULL), RTO_OK);
        h->inst[i].blas = blas[i];
        h->inst[i].mask = 0xFF;
    }
    h->sc.meshes = h->meshes;
    h->sc.mesh_count = 2;
    h->sc.instances = h->inst;
    h->sc.instance_count = n;
}

static void test_empty_mesh_builds_an_empty_blas(void **state)
{
    (void)state;
    /* instances 1 and 3 are of the empty mesh, and far away: were they keyed, the x and z quantisation would move */
    const uint32_t blas[] = {0, 1, 0, 1};
    const float off[][3] = {{0, 0, 0}, {50, 0, 50}, {0, 3, 0}, {-40, 9, 9}};
    hand_scene h;
    hand_scene_make(&h, blas, off, 4);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        rto_msg msg = {{0}};
        if (rto_accel_build(&h.sc, &desc, &acc, &msg))
            fail_msg("empty mesh scene: %s", msg.text);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        assert_int_equal(t->instance_count, 4);
        assert_int_equal(t->key_count, 2);
        assert_int_equal(t->n_padded, 2);
        /* Pinned: centroids (0.5, 0.5, 0) and (0.5, 3.5, 0); only y varies, so instance 2 gets q = (0, 31, 0) and
         * morton15 = 0x2492; the keys keep the real instance indices 0 and 2. */
        assert_int_equal(t->keys[0], 0x00000000u);
        assert_int_equal(t->keys[1], 0x24920002u);
        assert_int_equal(t->sorted_keys[0], 0x00000000u);
        assert_int_equal(t->sorted_keys[1], 0x24920002u);
        for (int i = 1; i < 4; i += 2) { /* the empty instances' world boxes are (+inf, -inf) */
            assert_true(rto_aabb_is_empty(&t->instance_aabbs[i]));
            assert_true(t->instance_aabbs[i].min.x == INFINITY && t->instance_aabbs[i].max.y == -INFINITY);
        }
        if (desc.tlas == RTO_TLAS_SWEEP) {
            assert_int_equal(t->node_count, 3);
            assert_int_equal(t->sweep_nodes[1].item, 0);
            assert_int_equal(t->sweep_nodes[2].item, 2);
            assert_int_equal(t->sweep_nodes[0].item, RTO_TLAS_INTERNAL);
            assert_true(t->sweep_nodes[0].min[1] == 0.0f && t->sweep_nodes[0].max[1] == 4.0f);
        } else {
            assert_int_equal(t->node_count, 1);
            assert_int_equal(t->karras_nodes[0].left, RTO_BVH_LEAF_BIT | 0u);
            assert_int_equal(t->karras_nodes[0].right, RTO_BVH_LEAF_BIT | 1u);
            assert_true(t->karras_nodes[0].rmin[1] == 3.0f && t->karras_nodes[0].rmax[1] == 4.0f);
        }
        assert_int_equal(t->stats.leaves, 2);
        const rto_accel_blas *e = rto_accel_get_blas(acc, 1);
        assert_non_null(e);
        assert_int_equal(e->mesh, 1);
        assert_int_equal(e->triangle_count, 0);
        assert_int_equal(e->node_count, 0);
        assert_int_equal(e->stats.depth, 0);
        assert_int_equal(rto_accel_get_blas(acc, 0)->node_count, 1);
        rto_report r;
        if (rto_accel_check(acc, &r, &msg))
            fail_msg("self-check: %s", msg.text);
        rto_accel_destroy(acc);
    }
    /* only empty instances: no key; the sweep TLAS is one EMPTY root, the Karras TLAS has no node */
    const uint32_t blas2[] = {1, 1};
    hand_scene_make(&h, blas2, off, 2);
    for (int kind = 0; kind < 2; kind++) {
        rto_accel_desc desc = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, 0};
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(&h.sc, &desc, &acc, NULL), RTO_OK);
        const rto_accel_tlas *t = rto_accel_get_tlas(acc);
        assert_int_equal(t->key_count, 0);
        assert_int_equal(t->n_padded, 0);
        assert_int_equal(t->node_count, kind ? 0u : 1u);
        if (!kind)
            assert_int_equal(t->sweep_nodes[0].item, RTO_TLAS_EMPTY);
        rto_report r;
        assert_int_equal(rto_accel_check(acc, &r, NULL), RTO_OK);
        rto_accel_destroy(acc);
    }
}

/* rto_tlas_keys_from_boxes against rto_tlas_keys (tested in test_keys) of the non-empty boxes alone: the same Morton
 * bits, with the real box index in the low 16 bits. */
static void test_tlas_keys_skip_empty_boxes(void **state)
{
    (void)state;
    for (uint32_t seed = 1; seed <= 20; seed++) {
        const size_t n = 1 + rto_rng(seed, 0) % 3000;
        rto_aabb *boxes = make_boxes("uniform", n, 1e-3f, seed);
        rto_vec3 *c = malloc(n * sizeof *c);
        uint32_t *index = malloc(n * 4), *keys = malloc(n * 4), *ref = malloc(n * 4);
        size_t m = 0;
        for (size_t i = 0; i < n; i++) {
            if (rto_rng(seed, (uint32_t)i + 1) % 4 == 0) { /* a quarter of the boxes are empty */
                boxes[i].min = (rto_vec3){INFINITY, INFINITY, INFINITY};
                boxes[i].max = (rto_vec3){-INFINITY, -INFINITY, -INFINITY};
                continue;
            }
            c[m] = rto_aabb_centroid(&boxes[i]);
            index[m++] = (uint32_t)i;
        }
        size_t got = SIZE_MAX;
        assert_int_equal(rto_tlas_keys_from_boxes(boxes, n, keys, &got, NULL), RTO_OK);
        assert_int_equal(got, m);
        assert_int_equal(rto_tlas_keys(c, m, ref, NULL), RTO_OK);
        for (size_t k = 0; k < m; k++)
            if (keys[k] != ((ref[k] & 0xFFFF0000u) | index[k]))
                fail_msg("seed %u: key %zu is %08x, want %08x", seed, k, keys[k], (ref[k] & 0xFFFF0000u) | index[k]);
        free(boxes);
        free(c);
        free(index);
        free(keys);
        free(ref);
    }
    /* an empty or NaN box through a transform stays the empty box */
    rto_mat34 xf = {{{1, 0, 0, 1}, {0, 1, 0, 2}, {0, 0, 1, 3}}};
    rto_aabb none = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    rto_aabb nan_box = {{NAN, 0, 0}, {1, 1, 1}};
    rto_aabb t1 = rto_aabb_transform(&xf, &none), t2 = rto_aabb_transform(&xf, &nan_box);
    assert_memory_equal(&t1, &none, sizeof none);
    assert_memory_equal(&t2, &none, sizeof none);
    /* a NaN bound is not empty: it is refused, naming the box */
    rto_aabb b[2] = {{{0, 0, 0}, {1, 1, 1}}, {{NAN, 0, 0}, {1, 1, 1}}};
    uint32_t k[2];
    size_t m = 9;
    rto_msg msg = {{0}};
    assert_int_equal(rto_tlas_keys_from_boxes(b, 2, k, &m, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "centroid 1"));
    assert_int_equal(m, 0);
}

/* ------------------------------------------------------------------------------------------------------------------ */
/* The accel API contract                                                                                              */

static void test_accel_contract(void **state)
{
    (void)state;
    rto_accel_destroy(NULL);
    assert_null(rto_accel_get_tlas(NULL));
    assert_null(rto_accel_get_blas(NULL, 0));
    assert_null(rto_accel_scene(NULL));
    assert_int_equal(rto_accel_blas_count(NULL), 0);
    rto_accel *acc = (rto_accel *)&acc; /* must be reset to NULL on failure */
    rto_msg msg = {{0}};
    assert_int_equal(rto_accel_build(NULL, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_null(acc);
    rto_scene *sc = NULL;
    assert_int_equal(rto_scene_load("rtstress:3", &sc, &msg), RTO_OK);
    assert_int_equal(rto_accel_build(sc, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_accel_desc bad = {(rto_tlas_kind)7, 0};
    assert_int_equal(rto_accel_build(sc, &bad, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "TLAS kind"));
    /* NULL and a zero-initialised description both mean the sweep TLAS, with identical bytes */
    rto_accel *a = NULL, *z = NULL;
    rto_accel_desc zero;
    memset(&zero, 0, sizeof zero);
    assert_int_equal(rto_accel_build(sc, NULL, &a, &msg), RTO_OK);
    assert_int_equal(rto_accel_build(sc, &zero, &z, &msg), RTO_OK);
    const rto_accel_tlas *ta = rto_accel_get_tlas(a), *tz = rto_accel_get_tlas(z);
    assert_int_equal(ta->kind, RTO_TLAS_SWEEP);
    assert_int_equal(ta->node_count, tz->node_count);
    assert_memory_equal(ta->sweep_nodes, tz->sweep_nodes, ta->node_count * sizeof(rto_tlas_node));
    assert_ptr_equal(rto_accel_scene(a), sc);
    assert_int_equal(ta->node_count, 2 * 32 - 1); /* 27 instances, n_padded 32 */
    rto_accel_destroy(a);
    rto_accel_destroy(z);
    /* a scene assembled by hand is checked before anything is read through it */
    uint32_t saved = sc->meshes[0].indices[4];
    sc->meshes[0].indices[4] = sc->meshes[0].vertex_count;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "mesh 0"));
    sc->meshes[0].indices[4] = saved;
    sc->instances[5].blas = 3;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "instance 5"));
    assert_null(acc);
    rto_scene_destroy(sc);
}

/* Instances whose keys are refused (a non-finite centroid): every thread count refuses the build with the message of
 * the sequential key function over the same world boxes, which names the first such instance. */
static void test_accel_tlas_key_refusals(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load("instances:uniform:5000", &sc, &msg), RTO_OK);
    for (int fault = 0; fault < 2; fault++) {
        rto_mat34 saved[2] = {sc->instances[3001].obj_to_world, sc->instances[4998].obj_to_world};
        /* an infinite translation: a non-finite centroid in a middle worker's range, or two, the first and last */
        if (fault == 0) {
            sc->instances[3001].obj_to_world.m[1][3] = INFINITY;
        } else {
            sc->instances[4998].obj_to_world.m[0][3] = -INFINITY;
            sc->instances[3001].obj_to_world.m[2][3] = INFINITY;
        }
        /* the expected message: the sequential keys of the instances' world boxes */
        rto_aabb *boxes = calloc(sc->instance_count, sizeof *boxes);
        uint32_t *keys = calloc(sc->instance_count, sizeof *keys);
        assert_non_null(boxes);
        assert_non_null(keys);
        rto_aabb mesh = rto_mesh_aabb(&sc->meshes[0]);
        for (uint32_t i = 0; i < sc->instance_count; i++)
            boxes[i] = rto_aabb_transform(&sc->instances[i].obj_to_world, &mesh);
        size_t m = 0;
        rto_msg want = {{0}};
        assert_int_equal(rto_tlas_keys_from_boxes(boxes, sc->instance_count, keys, &m, &want),
                         RTO_ERR_INVALID_ARGUMENT);
        if (!strstr(want.text, "centroid 3001 has a non-finite coordinate"))
            fail_msg("fault %d: the sequential keys say \"%s\"", fault, want.text);
        static const uint32_t threads[] = {1, 2, 3, 8};
        for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
            rto_accel_desc d = {RTO_TLAS_SWEEP, threads[t]};
            rto_accel *acc = (rto_accel *)&acc;
            assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
            assert_null(acc);
            if (strcmp(msg.text, want.text) != 0)
                fail_msg("fault %d, %u threads: \"%s\", expected \"%s\"", fault, threads[t], msg.text, want.text);
        }
        free(boxes);
        free(keys);
        sc->instances[3001].obj_to_world = saved[0];
        sc->instances[4998].obj_to_world = saved[1];
    }
    rto_scene_destroy(sc);
}

/* A triangle naming a vertex the mesh does not have: the build checks indices in its own stages now (each worker its
 * range, before any box reads a vertex), and must still name the first one in mesh and index order, before any key
 * refusal, at every thread count; a team-built mesh (sphere:5, 20,480 triangles) and worker-built ones (rtstress). */
static void test_accel_index_refusals(void **state)
{
    (void)state;
    static const char *const specs[] = {"sphere:5", "rtstress:4"};
    static const uint32_t threads[] = {1, 2, 3, 8};
    for (size_t sp = 0; sp < sizeof specs / sizeof specs[0]; sp++) {
        rto_scene *sc = NULL;
        rto_msg msg = {{0}};
        assert_int_equal(rto_scene_load(specs[sp], &sc, &msg), RTO_OK);
        const uint32_t last = sc->mesh_count - 1;
        rto_mesh *me = &sc->meshes[last];
        assert_true(me->triangle_count >= 8);
        const size_t mid = 3 * (size_t)(me->triangle_count * 7 / 10) + 1, end = 3 * (size_t)me->triangle_count - 1;
        for (int fault = 0; fault < 3; fault++) {
            const uint32_t saved_mid = me->indices[mid], saved_end = me->indices[end];
            const float saved_pos = sc->meshes[0].positions[0];
            me->indices[mid] = me->vertex_count + (uint32_t)fault; /* just past the end, or further */
            if (fault >= 1)
                me->indices[end] = UINT32_MAX; /* a later one too: the first is named */
            if (fault == 2) {
                sc->meshes[0].positions[0] = INFINITY; /* a key refusal in the first mesh: the index is still named */
                const uint32_t bad_mid = me->indices[mid], bad_end = me->indices[end];
                me->indices[mid] = saved_mid;
                me->indices[end] = saved_end;
                rto_accel *alone = (rto_accel *)&alone;
                assert_int_equal(rto_accel_build(sc, NULL, &alone, &msg), RTO_ERR_INVALID_ARGUMENT); /* refused alone */
                assert_null(alone);
                assert_null(strstr(msg.text, "not below"));
                me->indices[mid] = bad_mid;
                me->indices[end] = bad_end;
            }
            char want[sizeof msg.text];
            snprintf(want, sizeof want, "mesh %u (%s): index %zu is %u, not below %u vertices", last, me->name, mid,
                     me->vertex_count + (uint32_t)fault, me->vertex_count);
            for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
                rto_accel_desc d = {RTO_TLAS_SWEEP, threads[t]};
                rto_accel *acc = (rto_accel *)&acc;
                assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
                assert_null(acc);
                if (strcmp(msg.text, want) != 0)
                    fail_msg("%s fault %d, %u threads: \"%s\", expected \"%s\"", specs[sp], fault, threads[t], msg.text,
                             want);
            }
            me->indices[mid] = saved_mid;
            me->indices[end] = saved_end;
            sc->meshes[0].positions[0] = saved_pos;
        }
        rto_accel *acc = NULL;
        assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK); /* restored: it builds */
        rto_accel_destroy(acc);
        rto_scene_destroy(sc);
    }
}

/* An instance naming a BLAS the scene does not have: checked by the build in the instance boxes' ranges now, and
 * still named first (before an index out of range or a key refusal), at every thread count, for both TLAS kinds. */
static void test_accel_instance_refusals(void **state)
{
    (void)state;
    static const uint32_t threads[] = {1, 2, 3, 8};
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load("instances:uniform:5000", &sc, &msg), RTO_OK);
    assert_int_equal(sc->mesh_count, 1);
    rto_mesh *me = &sc->meshes[0];
    for (int fault = 0; fault < 4; fault++) {
        const rto_instance saved[3] = {sc->instances[100], sc->instances[3001], sc->instances[4998]};
        const uint32_t saved_index = me->indices[1];
        sc->instances[3001].blas = 1 + (uint32_t)fault; /* in a middle worker's range */
        if (fault == 1)
            sc->instances[4998].blas = 7; /* a later one too: the first is named */
        if (fault == 2)
            me->indices[1] = me->vertex_count; /* an index out of range: the instance is still named first */
        if (fault == 3) {
            sc->instances[100].obj_to_world.m[0][3] = INFINITY; /* a TLAS key refusal, earlier in order */
            const uint32_t bad = sc->instances[3001].blas;
            sc->instances[3001].blas = 0;
            rto_accel *alone = (rto_accel *)&alone;
            assert_int_equal(rto_accel_build(sc, NULL, &alone, &msg), RTO_ERR_INVALID_ARGUMENT); /* refused alone */
            assert_null(alone);
            assert_null(strstr(msg.text, "names BLAS"));
            sc->instances[3001].blas = bad;
        }
        char want[sizeof msg.text];
        snprintf(want, sizeof want, "instance 3001 names BLAS %u of 1", 1 + (uint32_t)fault);
        for (int kind = 0; kind < 2; kind++)
            for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
                rto_accel_desc d = {kind ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, threads[t]};
                rto_accel *acc = (rto_accel *)&acc;
                assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
                assert_null(acc);
                if (strcmp(msg.text, want) != 0)
                    fail_msg("fault %d, kind %d, %u threads: \"%s\", expected \"%s\"", fault, kind, threads[t],
                             msg.text, want);
            }
        sc->instances[100] = saved[0];
        sc->instances[3001] = saved[1];
        sc->instances[4998] = saved[2];
        me->indices[1] = saved_index;
    }
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK); /* restored: it builds */
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
}

/* A mesh with NULL indices is refused before the build; what the sequential checks named before it still comes
 * first: a bad instance, then a bad index in an earlier mesh (but not in a later one). */
static void test_accel_null_mesh_precedence(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    const char *fix = getenv("RTO_FIXTURES");
    if (!fix)
        fail_msg("RTO_FIXTURES is not set (meson sets it to fixtures/)");
    char path[4096];
    snprintf(path, sizeof path, "%s/CornellBox-nvpro-glTF/cornellBox.gltf", fix);
    if (rto_scene_load(path, &sc, &msg))
        fail_msg("%s: %s", path, msg.text);
    assert_true(sc->mesh_count >= 2 && sc->instance_count >= 1);
    assert_true(sc->meshes[0].triangle_count >= 2 && sc->meshes[sc->mesh_count - 1].triangle_count >= 2);
    rto_mesh *first = &sc->meshes[0], *last = &sc->meshes[sc->mesh_count - 1];
    uint32_t *first_idx = first->indices, *last_idx = last->indices;
    const uint32_t saved_first = first_idx[4], saved_last = last_idx[4], saved_blas = sc->instances[0].blas;
    char want[sizeof msg.text];
    for (int fault = 0; fault < 3; fault++) {
        if (fault == 0) { /* a bad index in mesh 0, NULL indices in the last mesh: the index */
            first_idx[4] = first->vertex_count;
            last->indices = NULL;
            snprintf(want, sizeof want, "mesh 0 (%s): index 4 is %u, not below %u vertices", first->name,
                     first->vertex_count, first->vertex_count);
        } else if (fault == 1) { /* NULL indices in mesh 0, a bad index in the last mesh: the NULL */
            first->indices = NULL;
            last_idx[4] = last->vertex_count;
            snprintf(want, sizeof want, "mesh 0 (%s): NULL positions or indices", first->name);
        } else { /* a bad instance beside NULL indices: the instance */
            last->indices = NULL;
            sc->instances[0].blas = sc->mesh_count;
            snprintf(want, sizeof want, "instance 0 names BLAS %u of %u", sc->mesh_count, sc->mesh_count);
        }
        for (uint32_t threads = 1; threads <= 3; threads++) {
            rto_accel_desc d = {RTO_TLAS_SWEEP, threads};
            rto_accel *acc = (rto_accel *)&acc;
            assert_int_equal(rto_accel_build(sc, &d, &acc, &msg), RTO_ERR_INVALID_ARGUMENT);
            assert_null(acc);
            if (strcmp(msg.text, want) != 0)
                fail_msg("fault %d, %u threads: \"%s\", expected \"%s\"", fault, threads, msg.text, want);
        }
        first->indices = first_idx;
        last->indices = last_idx;
        first_idx[4] = saved_first;
        last_idx[4] = saved_last;
        sc->instances[0].blas = saved_blas;
    }
    rto_scene_destroy(sc);
}

/* rto_accel_check names the tree and the fault of a damaged accel. The views are const for readers; the test casts
 * that away on purpose to damage one tree at a time. */
static void test_accel_check_names_the_tree(void **state)
{
    (void)state;
    rto_scene *sc = NULL;
    rto_msg msg = {{0}};
    rto_report r;
    assert_int_equal(rto_scene_load("rtstress:4", &sc, &msg), RTO_OK);
    rto_accel *acc = NULL;
    assert_int_equal(rto_accel_build(sc, NULL, &acc, &msg), RTO_OK);
    const rto_accel_tlas *t = rto_accel_get_tlas(acc);
    rto_tlas_node *leaves = (rto_tlas_node *)(uintptr_t)(t->sweep_nodes + t->n_padded - 1);
    uint32_t item = leaves[3].item;
    leaves[3].item = leaves[4].item; /* an instance twice, another in no leaf */
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_string_equal(r.fault, "item");
    assert_non_null(strstr(msg.text, "the sweep TLAS: item"));
    leaves[3].item = item;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    rto_bvh_node *bn = (rto_bvh_node *)(uintptr_t)rto_accel_get_blas(acc, 0)->nodes;
    bn[2].lmax[1] = nextafterf(bn[2].lmax[1], INFINITY);
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_BOX);
    assert_int_equal(where_of(&r, "node"), 2);
    assert_string_equal(r.what, "BLAS 0");
    assert_non_null(strstr(msg.text, "the BLAS of mesh 0: box"));
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);

    /* with empty instances: a leaf that holds an instance of the empty mesh is caught */
    const uint32_t blas[] = {0, 1, 0, 0};
    const float off[][3] = {{0, 0, 0}, {50, 0, 50}, {0, 3, 0}, {4, 0, 0}};
    hand_scene h;
    hand_scene_make(&h, blas, off, 4);
    assert_int_equal(rto_accel_build(&h.sc, NULL, &acc, &msg), RTO_OK);
    t = rto_accel_get_tlas(acc);
    assert_int_equal(t->key_count, 3);
    leaves = (rto_tlas_node *)(uintptr_t)(t->sweep_nodes + t->n_padded - 1);
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    /* the EMPTY leaf given the empty instance, then a real instance's leaf given it instead */
    assert_int_equal(leaves[3].item, RTO_TLAS_EMPTY);
    leaves[3].item = 1;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_int_equal(where_of(&r, "node"), (int64_t)t->n_padded - 1 + 3);
    leaves[3].item = RTO_TLAS_EMPTY;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_OK);
    leaves[0].item = 1;
    assert_int_equal(rto_accel_check(acc, &r, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_BVH_ITEM);
    assert_int_equal(where_of(&r, "leaf"), 0);
    assert_int_equal(where_of(&r, "primitive"), 1); /* the real instance index: no renumbering */
    assert_int_equal(where_of(&r, "node"), (int64_t)t->n_padded - 1);
    assert_string_equal(r.what, "TLAS (sweep)");
    assert_non_null(strstr(msg.text, "the sweep TLAS: item"));
    rto_accel_destroy(acc);
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
