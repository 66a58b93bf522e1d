/* A build bundle (DESIGN.md §8) from an accel: every array through the accel's views, in the GPU layouts of
 * layouts.c, under the file names and roles named there, with the counts and tree statistics in the manifest. The
 * order of files and manifest fields is part of the output bytes: keep it. And one tree of it read back for a check,
 * every array validated like a GPU dump first: a hand-edited bundle is refused, never trusted. */
#include "core/aabb.h"
#include "io/bundle_in.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>

#include <stdio.h>
#include <stdlib.h>

static rto_status manifest_fail(rto_msg *msg)
{
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "cannot add a field to the manifest (out of memory, or text that "
                    "is not UTF-8)");
}

static rto_status add(rto_bundle *b, rto_bundle_file f, uint32_t mesh, const char *layout, const rto_npy_desc *d,
                      const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    if (rto_bundle_file_name(f, mesh, name, sizeof name))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no name for bundle file %d", (int)f);
    return rto_bundle_add_npy(b, name, rto_bundle_file_role(f), layout, d, data, msg);
}

static rto_status add_layout(rto_bundle *b, rto_bundle_file f, uint32_t mesh, rto_layout l, size_t n,
                             const void *data, rto_msg *msg)
{
    rto_npy_desc d = rto_layout_desc(l, n);
    return add(b, f, mesh, rto_layout_name(l), &d, data, msg);
}

static rto_status add_keys(rto_bundle *b, rto_bundle_file f, uint32_t mesh, rto_key_format kf, size_t n,
                           const void *data, rto_msg *msg)
{
    rto_npy_desc d = rto_npy_desc_keys(kf, n);
    return add(b, f, mesh, NULL, &d, data, msg);
}

static rto_status write_tlas(const rto_accel_tlas *t, const rto_scene *sc, rto_bundle *b, rto_msg *msg)
{
    rto_instance_record *rec = rto__alloc(sc->instance_count, sizeof *rec);
    if (!rec)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < sc->instance_count; i++)
        rec[i] = rto_instance_record_make(&sc->instances[i]);
    rto_status s = add_layout(b, RTO_FILE_INSTANCES, 0, RTO_LAYOUT_INSTANCE, sc->instance_count, rec, msg);
    free(rec);
    if (!s)
        s = add_layout(b, RTO_FILE_INSTANCE_AABBS, 0, RTO_LAYOUT_AABB, t->instance_count, t->instance_aabbs, msg);
    if (!s)
        s = add_keys(b, RTO_FILE_TLAS_KEYS, 0, RTO_KEY_U32, t->key_count, t->keys, msg);
    if (!s)
        s = add_keys(b, RTO_FILE_TLAS_SORTED_KEYS, 0, RTO_KEY_U32, t->n_padded, t->sorted_keys, msg);
    if (!s && t->kind == RTO_TLAS_SWEEP)
        s = add_layout(b, RTO_FILE_TLAS_NODES, 0, RTO_LAYOUT_TLAS_NODE, t->node_count, t->sweep_nodes, msg);
    else if (!s)
        s = add_layout(b, RTO_FILE_TLAS_NODES, 0, RTO_LAYOUT_BLAS_NODE, t->node_count, t->karras_nodes, msg);
    if (s)
        return s;
    int bad = 0;
    bad |= rto_bundle_set_str(b, "params", "tlas", t->kind == RTO_TLAS_SWEEP ? "sweep" : "karras");
    bad |= rto_bundle_set_int(b, "tlas", "instances", t->instance_count);
    /* Only scenes with empty instances carry the keyed count, so every other manifest keeps its bytes. */
    if (t->key_count != t->instance_count)
        bad |= rto_bundle_set_int(b, "tlas", "keyed_instances", t->key_count);
    bad |= rto_bundle_set_int(b, "tlas", "n_padded", t->n_padded);
    bad |= rto_bundle_set_int(b, "tlas", "nodes", (int64_t)t->node_count);
    bad |= rto_bundle_set_int(b, "tlas", "depth", t->stats.depth);
    bad |= rto_bundle_set_real(b, "tlas", "sah_cost", t->stats.sah);
    return bad ? manifest_fail(msg) : RTO_OK;
}

static rto_status write_blas(const rto_accel_blas *bl, const rto_mesh *mesh, rto_bundle *b, rto_msg *msg)
{
    const uint32_t m = bl->mesh;
    rto_status s = add_keys(b, RTO_FILE_BLAS_SORTED_KEYS, m, RTO_KEY_U64, bl->triangle_count, bl->sorted_keys, msg);
    if (!s) {
        rto_npy_desc od = rto_npy_desc_array(RTO_DTYPE_U32, 1, bl->triangle_count, 0, 0);
        s = add(b, RTO_FILE_BLAS_ORDER, m, NULL, &od, bl->order, msg);
    }
    if (!s)
        s = add_layout(b, RTO_FILE_BLAS_NODES, m, RTO_LAYOUT_BLAS_NODE, bl->node_count, bl->nodes, msg);
    if (!s)
        s = add_layout(b, RTO_FILE_BLAS_PRIM_AABBS, m, RTO_LAYOUT_AABB, bl->triangle_count, bl->prim_aabbs, msg);
    if (s)
        return s;
    char section[32];
    snprintf(section, sizeof section, "blas_%u", m);
    int bad = 0;
    bad |= rto_bundle_set_str(b, section, "mesh", mesh->name);
    bad |= rto_bundle_set_int(b, section, "triangles", bl->triangle_count);
    bad |= rto_bundle_set_int(b, section, "nodes", (int64_t)bl->node_count);
    bad |= rto_bundle_set_int(b, section, "depth", bl->stats.depth);
    bad |= rto_bundle_set_real(b, section, "sah_cost", bl->stats.sah);
    return bad ? manifest_fail(msg) : RTO_OK;
}

rto_status rto_bvh_bundle_write(const rto_accel *accel, rto_bundle *b, rto_msg *msg)
{
    const rto_scene *sc = rto_accel_scene(accel);
    if (!sc || !b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel or bundle");
    uint64_t triangles = 0, blas_nodes = 0;
    int bad = 0;
    for (uint32_t i = 0; i < sc->instance_count; i++)
        triangles += sc->meshes[sc->instances[i].blas].triangle_count;
    bad |= rto_bundle_set_str(b, "", "scene", sc->source);
    bad |= rto_bundle_set_int(b, "counts", "meshes", sc->mesh_count);
    bad |= rto_bundle_set_int(b, "counts", "instances", sc->instance_count);
    bad |= rto_bundle_set_int(b, "counts", "instanced_triangles", (int64_t)triangles);
    rto_status s = bad ? manifest_fail(msg) : write_tlas(rto_accel_get_tlas(accel), sc, b, msg);
    for (uint32_t m = 0; !s && m < rto_accel_blas_count(accel); m++) {
        const rto_accel_blas *bl = rto_accel_get_blas(accel, m);
        s = write_blas(bl, &sc->meshes[m], b, msg);
        blas_nodes += bl->node_count;
    }
    if (!s && rto_bundle_set_int(b, "counts", "blas_nodes", (int64_t)blas_nodes))
        s = manifest_fail(msg);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Reading one tree back (check-bvh)                                                                                */

/* What a tree's check reads from a build bundle, each array validated before use. */
struct rto_bvh_bundle_data {
    rto__bundle_in in;
    int64_t meshes;
    rto_npy nodes, boxes, order, keys, inst; /* the oracle's tree, primitive boxes, BLAS leaf order, TLAS sorted keys,
                                              * instance records */
    uint32_t *prims;                         /* primitive of each sorted leaf (Karras layouts) */
    size_t prim_count, leaves, node_count;
    double *tol; /* TLAS: 3 leaf-box tolerances per instance */
};

static void arrays_free(struct rto_bvh_bundle_data *a)
{
    rto_npy_free(&a->nodes);
    rto_npy_free(&a->boxes);
    rto_npy_free(&a->order);
    rto_npy_free(&a->keys);
    rto_npy_free(&a->inst);
    free(a->prims);
    free(a->tol);
}

/* Every box finite with min <= max, or (where allowed) exactly the empty box (+inf, -inf), the one empty box a bundle
 * holds: after this, rto_aabb_is_empty tells the two apart. */
static rto_status check_boxes(const struct rto_bvh_bundle_data *a, const char *name, const rto_aabb *boxes, size_t n,
                              int allow_empty)
{
    const rto_aabb empty = rto_aabb_empty();
    for (size_t i = 0; i < n; i++)
        if (!rto_aabb_is_finite(&boxes[i]) && !(allow_empty && rto_aabb_equal(&boxes[i], &empty)))
            return rto__bundle_refuse(&a->in, name, "box %zu is neither finite with min <= max%s", i,
                                     allow_empty ? " nor the empty box (+inf, -inf)" : "");
    return RTO_OK;
}

/* blas_M_prim_aabbs.npy: one finite box per triangle the manifest counts (none for an empty mesh). */
static rto_status load_prim_boxes(const struct rto_bvh_bundle_data *a, uint32_t m, rto_npy *out, size_t *triangles)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], section[32];
    rto__bundle_name(RTO_FILE_BLAS_PRIM_AABBS, m, name);
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    rto_status rc = rto__bundle_count(&a->in, section, "triangles", UINT32_MAX, triangles);
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_AABB, *triangles);
    if (!rc)
        rc = rto__bundle_load(&a->in, name, &want, rto_layout_name(RTO_LAYOUT_AABB), out);
    return rc ? rc : check_boxes(a, name, out->data, *triangles, 0);
}

/* The bundle's own tree must pass the validator as a GPU's would (exactly, no tolerance): what a GPU dump is
 * compared with is then known to be a tree over these primitives. */
static rto_status self_check(const struct rto_bvh_bundle_data *a, const char *name, int sweep)
{
    rto_bvh_check_desc d;
    memset(&d, 0, sizeof d);
    d.nodes = a->nodes.data;
    d.node_count = a->node_count;
    d.prim_boxes = a->boxes.data;
    d.prim_count = a->prim_count;
    d.leaf_prims = a->prims;
    d.leaf_count = a->leaves;
    rto_report r;
    rto_msg msg = {{0}};
    rto_status s = sweep ? rto_tlas_check(&d, &r, &msg) : rto_karras_check(&d, &r, &msg);
    if (s == RTO_ERR_MISMATCH)
        return rto__bundle_refuse(&a->in, name, "not a valid tree over the bundle's primitives: %s", r.summary);
    if (s)
        return rto__bundle_refuse(&a->in, name, "%s", msg.text);
    return RTO_OK;
}

static rto_status load_blas(struct rto_bvh_bundle_data *a, uint32_t m)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], section[32];
    size_t t = 0, nodes = 0;
    rto_status rc = load_prim_boxes(a, m, &a->boxes, &t);
    if (rc)
        return rc;
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    if ((rc = rto__bundle_count(&a->in, section, "nodes", UINT32_MAX, &nodes)))
        return rc;
    if (nodes != (t >= 2 ? t - 1 : 0))
        return rto__bundle_refuse(&a->in, "manifest.json", "%s.nodes is %zu; a Karras tree over %zu triangles has %zu",
                                 section, nodes, t, t >= 2 ? t - 1 : 0);
    /* the leaf order: a permutation of the triangles */
    rto__bundle_name(RTO_FILE_BLAS_ORDER, m, name);
    rto_npy_desc od = rto_npy_desc_array(RTO_DTYPE_U32, 1, t, 0, 0);
    if ((rc = rto__bundle_load(&a->in, name, &od, NULL, &a->order)))
        return rc;
    const uint32_t *order = a->order.data;
    unsigned char *seen = calloc(t ? t : 1, 1);
    if (!seen)
        return rto__fail(a->in.msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", a->in.dir);
    for (size_t j = 0; j < t && !rc; j++) {
        if (order[j] >= t)
            rc = rto__bundle_refuse(&a->in, name, "entry %zu names triangle %" PRIu32 " of %zu", j, order[j], t);
        else if (seen[order[j]]++)
            rc = rto__bundle_refuse(&a->in, name,
                                   "triangle %" PRIu32 " appears twice (again at entry %zu): not a permutation",
                                   order[j], j);
    }
    free(seen);
    if (rc)
        return rc;
    a->prims = malloc((t ? t : 1) * sizeof *a->prims);
    if (!a->prims)
        return rto__fail(a->in.msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", a->in.dir);
    if (t)
        memcpy(a->prims, order, t * sizeof *order);
    a->prim_count = a->leaves = t;
    a->node_count = nodes;
    rto__bundle_name(RTO_FILE_BLAS_NODES, m, name);
    rto_npy_desc nd = rto_layout_desc(RTO_LAYOUT_BLAS_NODE, nodes);
    if ((rc = rto__bundle_load(&a->in, name, &nd, rto_layout_name(RTO_LAYOUT_BLAS_NODE), &a->nodes)))
        return rc;
    return self_check(a, name, 0);
}


/* instances.npy and instance_aabbs.npy: each instance's BLAS exists, its transform is finite, and its world box is
 * its BLAS's object box (the union of the triangle boxes; empty for an empty mesh) through that transform, as
 * rto_aabb_transform computes it for the build; the §9 leaf tolerance follows. */
static rto_status load_instances(struct rto_bvh_bundle_data *a, size_t n)
{
    char inst_name[RTO_BUNDLE_FILE_NAME_MAX], box_name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_name(RTO_FILE_INSTANCES, 0, inst_name);
    rto__bundle_name(RTO_FILE_INSTANCE_AABBS, 0, box_name);
    rto_npy_desc id = rto_layout_desc(RTO_LAYOUT_INSTANCE, n), bd = rto_layout_desc(RTO_LAYOUT_AABB, n);
    rto_status rc = rto__bundle_load(&a->in, inst_name, &id, rto_layout_name(RTO_LAYOUT_INSTANCE), &a->inst);
    if (!rc)
        rc = rto__bundle_load(&a->in, box_name, &bd, rto_layout_name(RTO_LAYOUT_AABB), &a->boxes);
    if (!rc)
        rc = check_boxes(a, box_name, a->boxes.data, n, 1);
    if (rc)
        return rc;
    rto_mat34 *xf = malloc((n ? n : 1) * sizeof *xf);
    uint32_t *blas = malloc((n ? n : 1) * sizeof *blas);
    rto_aabb *obj = calloc(a->meshes ? (size_t)a->meshes : 1, sizeof *obj);
    unsigned char *have = calloc(a->meshes ? (size_t)a->meshes : 1, 1);
    a->tol = malloc((n ? n : 1) * 3 * sizeof *a->tol);
    if (!xf || !blas || !obj || !have || !a->tol)
        rc = rto__fail(a->in.msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", a->in.dir);
    for (size_t i = 0; !rc && i < n; i++) {
        rto_instance_record rec; /* the array's records are this struct's bytes (rto_layout_desc) */
        memcpy(&rec, (const unsigned char *)a->inst.data + i * sizeof rec, sizeof rec);
        memcpy(xf[i].m, rec.obj_to_world, sizeof xf[i].m);
        blas[i] = rec.blas;
        if ((int64_t)blas[i] >= a->meshes)
            rc = rto__bundle_refuse(&a->in, inst_name,
                                   "instance %zu names BLAS %" PRIu32 "; the bundle has %" PRId64 " meshes", i, blas[i],
                                   a->meshes);
        for (int k = 0; !rc && k < 12; k++)
            if (!isfinite(xf[i].m[k / 4][k % 4]))
                rc = rto__bundle_refuse(&a->in, inst_name, "objToWorld of instance %zu is not finite", i);
    }
    /* each referenced BLAS's object box: the union of its triangle boxes */
    for (size_t i = 0; !rc && i < n; i++) {
        const uint32_t m = blas[i];
        if (have[m])
            continue;
        rto_npy pb = {0};
        size_t t = 0;
        rc = load_prim_boxes(a, m, &pb, &t);
        rto_aabb u = rto_aabb_empty();
        const rto_aabb *tb = pb.data;
        for (size_t k = 0; !rc && k < t; k++) { /* finite boxes with min <= max (check_boxes) */
            rto__aabb_grow(&u, tb[k].min);
            rto__aabb_grow(&u, tb[k].max);
        }
        rto_npy_free(&pb);
        obj[m] = u;
        have[m] = 1;
    }
    const rto_aabb *wb = a->boxes.data;
    for (size_t i = 0; !rc && i < n; i++) {
        rto_aabb w = rto_aabb_transform(&xf[i], &obj[blas[i]]);
        if (!rto_aabb_equal(&w, &wb[i])) /* as numbers: +0 == -0 */
            rc = rto__bundle_refuse(&a->in, box_name,
                                   "the box of instance %zu is not the box of BLAS %" PRIu32
                                   " through its objToWorld (instances.npy)",
                                   i, blas[i]);
        else
            rto_transform_box_tolerance(&xf[i], &obj[blas[i]], &a->tol[3 * i]);
    }
    free(xf);
    free(blas);
    free(obj);
    free(have);
    return rc;
}

/* tlas_sorted_keys.npy of a Karras TLAS: the keys of the instances with a leaf, ascending, each naming one such
 * instance in its low 16 bits, then sentinels up to n_padded. */
static rto_status load_sorted_keys(struct rto_bvh_bundle_data *a, size_t np)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_name(RTO_FILE_TLAS_SORTED_KEYS, 0, name);
    rto_npy_desc kd = rto_npy_desc_keys(RTO_KEY_U32, np);
    rto_status rc = rto__bundle_load(&a->in, name, &kd, NULL, &a->keys);
    if (rc)
        return rc;
    const uint32_t *k = a->keys.data;
    const rto_aabb *boxes = a->boxes.data;
    unsigned char *seen = calloc(a->prim_count ? a->prim_count : 1, 1);
    a->prims = malloc((a->leaves ? a->leaves : 1) * sizeof *a->prims);
    if (!seen || !a->prims)
        rc = rto__fail(a->in.msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", a->in.dir);
    for (size_t j = 0; !rc && j < np; j++) {
        const uint32_t p = rto_key_prim(RTO_KEY_U32, k[j]);
        if (j >= a->leaves) {
            if (k[j] != RTO_SENTINEL_U32)
                rc = rto__bundle_refuse(&a->in, name,
                                       "slot %zu holds 0x%08" PRIx32 "; the %zu slots after the %zu keyed instances "
                                       "must be the sentinel",
                                       j, k[j], np - a->leaves, a->leaves);
        } else if (k[j] & 0x80000000u) {
            rc = rto__bundle_refuse(&a->in, name, "key %zu is 0x%08" PRIx32 ": a TLAS key's top bit is 0", j, k[j]);
        } else if (j && k[j] <= k[j - 1]) {
            rc = rto__bundle_refuse(&a->in, name,
                                   "key %zu (0x%08" PRIx32 ") does not ascend from key %zu (0x%08" PRIx32 ")", j, k[j],
                                   j - 1, k[j - 1]);
        } else if (p >= a->prim_count || rto_aabb_is_empty(&boxes[p])) {
            rc = rto__bundle_refuse(&a->in, name, "key %zu (0x%08" PRIx32 ") names instance %" PRIu32 ", %s", j, k[j], p,
                                   p >= a->prim_count ? "which does not exist" : "whose BLAS is empty (it has no key)");
        } else if (seen[p]++) {
            rc = rto__bundle_refuse(&a->in, name, "key %zu (0x%08" PRIx32 ") names instance %" PRIu32 " a second time",
                                   j, k[j], p);
        } else {
            a->prims[j] = p;
        }
    }
    free(seen);
    return rc;
}

static rto_status load_tlas(struct rto_bvh_bundle_data *a, int sweep)
{
    size_t n = 0, np = 0, nodes = 0;
    rto_status rc = rto__bundle_count(&a->in, "counts", "instances", RTO_TLAS_MAX_INSTANCES, &n);
    if (!rc)
        rc = load_instances(a, n);
    if (rc)
        return rc;
    const rto_aabb *boxes = a->boxes.data;
    size_t keyed = 0, tlas_n = 0, tlas_keyed = 0;
    for (size_t i = 0; i < n; i++)
        keyed += !rto_aabb_is_empty(&boxes[i]);
    a->prim_count = n;
    a->leaves = keyed;
    const size_t want = sweep ? rto_tlas_sweep_node_count(keyed) : (keyed >= 2 ? keyed - 1 : 0);
    if ((rc = rto__bundle_count(&a->in, "tlas", "instances", RTO_TLAS_MAX_INSTANCES, &tlas_n)) ||
        (rc = rto__bundle_count(&a->in, "tlas", "n_padded", (uint64_t)1 << 17, &np)) ||
        (rc = rto__bundle_count(&a->in, "tlas", "nodes", (uint64_t)1 << 18, &nodes)))
        return rc;
    if (tlas_n != n)
        return rto__bundle_refuse(&a->in, "manifest.json", "tlas.instances is %zu; counts.instances is %zu", tlas_n, n);
    /* The manifest states the keyed count when instances of an empty BLAS make it differ (rtoracle build writes it
     * only then, so older bundles keep their bytes): absent, every instance must have a leaf. */
    int64_t stated = -1;
    if (!rto_bundle_get_int(a->in.r, "tlas", "keyed_instances", &stated)) {
        if (keyed != n)
            return rto__bundle_refuse(&a->in, "manifest.json",
                                     "tlas.keyed_instances is missing; %zu of the %zu instances have a "
                                     "non-empty box",
                                     keyed, n);
    } else if ((rc = rto__bundle_count(&a->in, "tlas", "keyed_instances", n, &tlas_keyed))) {
        return rc;
    } else if (tlas_keyed != keyed) {
        return rto__bundle_refuse(&a->in, "manifest.json",
                                 "tlas.keyed_instances is %zu; %zu of the %zu instances have a non-empty box",
                                 tlas_keyed, keyed, n);
    }
    if (np != rto_next_pow2(keyed))
        return rto__bundle_refuse(&a->in, "manifest.json",
                                 "tlas.n_padded is %zu; %zu instances have a leaf (next power of two %zu)", np, keyed,
                                 rto_next_pow2(keyed));
    if (nodes != want)
        return rto__bundle_refuse(&a->in, "manifest.json", "tlas.nodes is %zu; a %s TLAS over %zu leaves has %zu", nodes,
                                 sweep ? "sweep" : "Karras", keyed, want);
    a->node_count = nodes;
    const rto_layout lk = sweep ? RTO_LAYOUT_TLAS_NODE : RTO_LAYOUT_BLAS_NODE;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_name(RTO_FILE_TLAS_NODES, 0, name);
    rto_npy_desc nd = rto_layout_desc(lk, nodes);
    if ((rc = rto__bundle_load(&a->in, name, &nd, rto_layout_name(lk), &a->nodes)))
        return rc;
    if (!sweep && (rc = load_sorted_keys(a, np)))
        return rc;
    return self_check(a, name, sweep);
}

void rto_bvh_bundle_free(rto_bvh_bundle *bb)
{
    if (!bb)
        return;
    if (bb->data) {
        arrays_free(bb->data);
        free(bb->data);
    }
    memset(bb, 0, sizeof *bb);
}

rto_status rto_bvh_bundle_read(const char *dir, int64_t blas, rto_bvh_bundle *bb, rto_msg *msg)
{
    if (!bb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bvh bundle");
    memset(bb, 0, sizeof *bb);
    struct rto_bvh_bundle_data *a = calloc(1, sizeof *a);
    if (!a)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    bb->data = a;
    rto_status s = rto__bundle_in_open(&a->in, dir, NULL, NULL, msg);
    const char *kind = s ? NULL : rto_bundle_get_str(a->in.r, "", "kind");
    const char *mode = s ? NULL : rto_bundle_get_str(a->in.r, "params", "tlas");
    if (!s && (!kind || strcmp(kind, "build") || !mode ||
               (strcmp(mode, "sweep") && strcmp(mode, "karras"))))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s is not a build bundle (rtoracle build)", dir);
    size_t meshes = 0;
    if (!s)
        s = rto__bundle_count(&a->in, "counts", "meshes", UINT32_MAX, &meshes);
    a->meshes = (int64_t)meshes;
    if (!s && blas >= a->meshes)
        s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s: no BLAS %lld: the scene has %lld meshes", dir,
                      (long long)blas, (long long)a->meshes);
    const int sweep = !s && blas < 0 && !strcmp(mode, "sweep");
    if (!s)
        s = blas >= 0 ? load_blas(a, (uint32_t)blas) : load_tlas(a, sweep);
    if (!s)
        snprintf(bb->tlas_mode, sizeof bb->tlas_mode, "%s", mode);
    rto__bundle_in_close(&a->in);
    if (s) {
        rto_bvh_bundle_free(bb);
        return s;
    }
    bb->blas = blas < 0 ? -1 : blas;
    bb->sweep = sweep;
    bb->mesh_count = (uint32_t)meshes;
    bb->nodes = a->nodes.data;
    bb->node_count = a->node_count;
    bb->prim_boxes = a->boxes.data;
    bb->prim_count = a->prim_count;
    bb->leaf_tolerance = blas < 0 ? a->tol : NULL;
    bb->leaf_prims = a->prims;
    bb->leaf_count = a->leaves;
    return RTO_OK;
}
