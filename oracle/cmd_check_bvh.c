/* rtoracle check-bvh: validates a GPU-built TLAS or BLAS node array against a build bundle — exactly (items and
 * links equal to the oracle's) or, with --structure-only, for validity against the primitives alone; boxes by the
 * rules of DESIGN.md §9 either way. Every array read from the bundle is first checked like a GPU dump: dtype, shape
 * and value ranges as the manifest and the other arrays imply, so a hand-edited bundle is refused, never trusted. */
#include "cli.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char check_bvh_usage[] =
    "usage: rtoracle check-bvh --expected OUTDIR --gpu nodes.npy [--blas M] [--structure-only]\n"
    "                          [--gpu-order order.npy] [--json] [--no-artifacts]\n\n"
    "Compares a GPU-built node array with the bundle written by `rtoracle build`: the TLAS by default, the\n"
    "BLAS of mesh M with --blas M. The dump may be the structured TlasNode / BlasNode records, a (count,\n"
    "words) array or the raw buffer as flat uint32/float32 words.\n"
    "Modes (the report names the one used):\n"
    "  exact           items, links and parents equal to the oracle's (the default)\n"
    "  structure-only  any valid tree over the same primitives: links in range, no cycle or shared node,\n"
    "                  every primitive in exactly one leaf (--structure-only, or implied by --gpu-order)\n"
    "Boxes, in both modes (DESIGN.md §9), checked bottom-up so a fault is named where it starts: TLAS leaf\n"
    "boxes within 8*2^-24*(|m0*x|+|m1*y|+|m2*z|+|t|) per world coordinate of the instance's transformed\n"
    "box, triangle boxes exact, every internal box the exact union of the dump's own children, EMPTY boxes\n"
    "(+inf, -inf).\n"
    "--gpu-order order.npy gives the GPU's own leaf order of a Karras tree (uint32 primitive per sorted\n"
    "leaf; it must be a permutation); the tree then differs from the oracle's, so it implies\n"
    "--structure-only. Without it the leaf order is the oracle's.\n";

static const char check_bvh_epilog[] =
    "Fault classes: size, cycle, shared-node, bad-link, dropped-leaf, item, swapped-children, topology,\n"
    "parent, empty, box. Exit status: 0 valid, 1 a fault was found, 2 bad usage or input (including a\n"
    "bundle whose arrays disagree with its manifest).\n";

/* What check-bvh reads from a build bundle, each array validated before use. */
typedef struct build_arrays {
    cli_bundle in; /* the bundle, for cli_bundle_* */
    int64_t meshes;
    rto_npy nodes, boxes, order, keys, inst; /* the oracle's tree, primitive boxes, BLAS leaf order, TLAS sorted keys,
                                              * instance records */
    uint32_t *prims;                         /* primitive of each sorted leaf (Karras layouts) */
    size_t prim_count, leaves, node_count;
    double *tol; /* TLAS: 3 leaf-box tolerances per instance */
} build_arrays;

static void arrays_free(build_arrays *a)
{
    rto_npy_free(&a->nodes);
    rto_npy_free(&a->boxes);
    rto_npy_free(&a->order);
    rto_npy_free(&a->keys);
    rto_npy_free(&a->inst);
    free(a->prims);
    free(a->tol);
}

/* Exactly (+inf, -inf) on every axis: the one empty box a bundle holds (rto_aabb_is_empty accepts any min > max). */
static int box_empty(const rto_aabb *b)
{
    const rto_aabb e = rto_aabb_empty();
    return rto_aabb_equal(b, &e);
}

/* Every box finite with min <= max, or (where allowed) the empty box (+inf, -inf). */
static int check_boxes(const build_arrays *a, const char *name, const rto_aabb *boxes, size_t n, int allow_empty)
{
    for (size_t i = 0; i < n; i++)
        if (!rto_aabb_is_finite(&boxes[i]) && !(allow_empty && box_empty(&boxes[i])))
            return cli_bundle_refuse(&a->in, name, "box %zu is neither finite with min <= max%s", i,
                                     allow_empty ? " nor the empty box (+inf, -inf)" : "");
    return EXIT_PASS;
}

/* blas_M_prim_aabbs.npy: one finite box per triangle the manifest counts (none for an empty mesh). */
static int load_prim_boxes(const build_arrays *a, uint32_t m, rto_npy *out, size_t *triangles)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], section[32];
    cli_bundle_file_name(RTO_FILE_BLAS_PRIM_AABBS, m, name);
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    int rc = cli_bundle_count(&a->in, section, "triangles", UINT32_MAX, triangles);
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_AABB, *triangles);
    if (!rc)
        rc = cli_bundle_load(&a->in, name, &want, rto_layout_name(RTO_LAYOUT_AABB), out);
    return rc ? rc : check_boxes(a, name, out->data, *triangles, 0);
}

/* The bundle's own tree must pass the validator as a GPU's would (exactly, no tolerance): what a GPU dump is
 * compared with is then known to be a tree over these primitives. */
static int self_check(const build_arrays *a, const char *name, int sweep)
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
        return cli_bundle_refuse(&a->in, name, "not a valid tree over the bundle's primitives: %s", r.summary);
    if (s)
        return cli_bundle_refuse(&a->in, name, "%s", msg.text);
    return EXIT_PASS;
}

static int load_blas(build_arrays *a, uint32_t m)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], section[32];
    size_t t = 0, nodes = 0;
    int rc = load_prim_boxes(a, m, &a->boxes, &t);
    if (rc)
        return rc;
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    if ((rc = cli_bundle_count(&a->in, section, "nodes", UINT32_MAX, &nodes)))
        return rc;
    if (nodes != (t >= 2 ? t - 1 : 0))
        return cli_bundle_refuse(&a->in, "manifest.json", "%s.nodes is %zu; a Karras tree over %zu triangles has %zu",
                                 section, nodes, t, t >= 2 ? t - 1 : 0);
    /* the leaf order: a permutation of the triangles */
    cli_bundle_file_name(RTO_FILE_BLAS_ORDER, m, name);
    rto_npy_desc od = rto_npy_desc_array(RTO_DTYPE_U32, 1, t, 0, 0);
    if ((rc = cli_bundle_load(&a->in, name, &od, NULL, &a->order)))
        return rc;
    const uint32_t *order = a->order.data;
    unsigned char *seen = calloc(t ? t : 1, 1);
    if (!seen)
        return cli_fail("check-bvh", "out of memory");
    for (size_t j = 0; j < t && !rc; j++) {
        if (order[j] >= t)
            rc = cli_bundle_refuse(&a->in, name, "entry %zu names triangle %" PRIu32 " of %zu", j, order[j], t);
        else if (seen[order[j]]++)
            rc = cli_bundle_refuse(&a->in, name,
                                   "triangle %" PRIu32 " appears twice (again at entry %zu): not a permutation",
                                   order[j], j);
    }
    free(seen);
    if (rc)
        return rc;
    a->prims = malloc((t ? t : 1) * sizeof *a->prims);
    if (!a->prims)
        return cli_fail("check-bvh", "out of memory");
    if (t)
        memcpy(a->prims, order, t * sizeof *order);
    a->prim_count = a->leaves = t;
    a->node_count = nodes;
    cli_bundle_file_name(RTO_FILE_BLAS_NODES, m, name);
    rto_npy_desc nd = rto_layout_desc(RTO_LAYOUT_BLAS_NODE, nodes);
    if ((rc = cli_bundle_load(&a->in, name, &nd, rto_layout_name(RTO_LAYOUT_BLAS_NODE), &a->nodes)))
        return rc;
    return self_check(a, name, 0);
}


/* instances.npy and instance_aabbs.npy: each instance's BLAS exists, its transform is finite, and its world box is
 * its BLAS's object box (the union of the triangle boxes; empty for an empty mesh) through that transform, as
 * rto_aabb_transform computes it for the build; the §9 leaf tolerance follows. */
static int load_instances(build_arrays *a, size_t n)
{
    char inst_name[RTO_BUNDLE_FILE_NAME_MAX], box_name[RTO_BUNDLE_FILE_NAME_MAX];
    cli_bundle_file_name(RTO_FILE_INSTANCES, 0, inst_name);
    cli_bundle_file_name(RTO_FILE_INSTANCE_AABBS, 0, box_name);
    rto_npy_desc id = rto_layout_desc(RTO_LAYOUT_INSTANCE, n), bd = rto_layout_desc(RTO_LAYOUT_AABB, n);
    int rc = cli_bundle_load(&a->in, inst_name, &id, rto_layout_name(RTO_LAYOUT_INSTANCE), &a->inst);
    if (!rc)
        rc = cli_bundle_load(&a->in, box_name, &bd, rto_layout_name(RTO_LAYOUT_AABB), &a->boxes);
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
        rc = cli_fail("check-bvh", "out of memory");
    for (size_t i = 0; !rc && i < n; i++) {
        rto_instance_record rec; /* the array's records are this struct's bytes (rto_layout_desc) */
        memcpy(&rec, (const unsigned char *)a->inst.data + i * sizeof rec, sizeof rec);
        memcpy(xf[i].m, rec.obj_to_world, sizeof xf[i].m);
        blas[i] = rec.blas;
        if ((int64_t)blas[i] >= a->meshes)
            rc = cli_bundle_refuse(&a->in, inst_name,
                                   "instance %zu names BLAS %" PRIu32 "; the bundle has %" PRId64 " meshes", i, blas[i],
                                   a->meshes);
        for (int k = 0; !rc && k < 12; k++)
            if (!isfinite(xf[i].m[k / 4][k % 4]))
                rc = cli_bundle_refuse(&a->in, inst_name, "objToWorld of instance %zu is not finite", i);
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
        for (size_t k = 0; !rc && k < t; k++) {
            u.min.x = tb[k].min.x < u.min.x ? tb[k].min.x : u.min.x;
            u.min.y = tb[k].min.y < u.min.y ? tb[k].min.y : u.min.y;
            u.min.z = tb[k].min.z < u.min.z ? tb[k].min.z : u.min.z;
            u.max.x = tb[k].max.x > u.max.x ? tb[k].max.x : u.max.x;
            u.max.y = tb[k].max.y > u.max.y ? tb[k].max.y : u.max.y;
            u.max.z = tb[k].max.z > u.max.z ? tb[k].max.z : u.max.z;
        }
        rto_npy_free(&pb);
        obj[m] = u;
        have[m] = 1;
    }
    const rto_aabb *wb = a->boxes.data;
    for (size_t i = 0; !rc && i < n; i++) {
        rto_aabb w = rto_aabb_transform(&xf[i], &obj[blas[i]]);
        if (!rto_aabb_equal(&w, &wb[i])) /* as numbers: +0 == -0 */
            rc = cli_bundle_refuse(&a->in, box_name,
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
static int load_sorted_keys(build_arrays *a, size_t np)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    cli_bundle_file_name(RTO_FILE_TLAS_SORTED_KEYS, 0, name);
    rto_npy_desc kd = rto_npy_desc_keys(RTO_KEY_U32, np);
    int rc = cli_bundle_load(&a->in, name, &kd, NULL, &a->keys);
    if (rc)
        return rc;
    const uint32_t *k = a->keys.data;
    const rto_aabb *boxes = a->boxes.data;
    unsigned char *seen = calloc(a->prim_count ? a->prim_count : 1, 1);
    a->prims = malloc((a->leaves ? a->leaves : 1) * sizeof *a->prims);
    if (!seen || !a->prims)
        rc = cli_fail("check-bvh", "out of memory");
    for (size_t j = 0; !rc && j < np; j++) {
        const uint32_t p = rto_key_prim(RTO_KEY_U32, k[j]);
        if (j >= a->leaves) {
            if (k[j] != RTO_SENTINEL_U32)
                rc = cli_bundle_refuse(&a->in, name,
                                       "slot %zu holds 0x%08" PRIx32 "; the %zu slots after the %zu keyed instances "
                                       "must be the sentinel",
                                       j, k[j], np - a->leaves, a->leaves);
        } else if (k[j] & 0x80000000u) {
            rc = cli_bundle_refuse(&a->in, name, "key %zu is 0x%08" PRIx32 ": a TLAS key's top bit is 0", j, k[j]);
        } else if (j && k[j] <= k[j - 1]) {
            rc = cli_bundle_refuse(&a->in, name,
                                   "key %zu (0x%08" PRIx32 ") does not ascend from key %zu (0x%08" PRIx32 ")", j, k[j],
                                   j - 1, k[j - 1]);
        } else if (p >= a->prim_count || box_empty(&boxes[p])) {
            rc = cli_bundle_refuse(&a->in, name, "key %zu (0x%08" PRIx32 ") names instance %" PRIu32 ", %s", j, k[j], p,
                                   p >= a->prim_count ? "which does not exist" : "whose BLAS is empty (it has no key)");
        } else if (seen[p]++) {
            rc = cli_bundle_refuse(&a->in, name, "key %zu (0x%08" PRIx32 ") names instance %" PRIu32 " a second time",
                                   j, k[j], p);
        } else {
            a->prims[j] = p;
        }
    }
    free(seen);
    return rc;
}

static int load_tlas(build_arrays *a, int sweep)
{
    size_t n = 0, np = 0, nodes = 0;
    int rc = cli_bundle_count(&a->in, "counts", "instances", RTO_TLAS_MAX_INSTANCES, &n);
    if (!rc)
        rc = load_instances(a, n);
    if (rc)
        return rc;
    const rto_aabb *boxes = a->boxes.data;
    size_t keyed = 0, tlas_n = 0, tlas_keyed = 0;
    for (size_t i = 0; i < n; i++)
        keyed += !box_empty(&boxes[i]);
    a->prim_count = n;
    a->leaves = keyed;
    const size_t want = sweep ? rto_tlas_sweep_node_count(keyed) : (keyed >= 2 ? keyed - 1 : 0);
    if ((rc = cli_bundle_count(&a->in, "tlas", "instances", RTO_TLAS_MAX_INSTANCES, &tlas_n)) ||
        (rc = cli_bundle_count(&a->in, "tlas", "n_padded", (uint64_t)1 << 17, &np)) ||
        (rc = cli_bundle_count(&a->in, "tlas", "nodes", (uint64_t)1 << 18, &nodes)))
        return rc;
    if (tlas_n != n)
        return cli_bundle_refuse(&a->in, "manifest.json", "tlas.instances is %zu; counts.instances is %zu", tlas_n, n);
    /* The manifest states the keyed count when instances of an empty BLAS make it differ (rtoracle build writes it
     * only then, so older bundles keep their bytes): absent, every instance must have a leaf. */
    int64_t stated = -1;
    if (!rto_bundle_get_int(a->in.b, "tlas", "keyed_instances", &stated)) {
        if (keyed != n)
            return cli_bundle_refuse(&a->in, "manifest.json",
                                     "tlas.keyed_instances is missing; %zu of the %zu instances have a "
                                     "non-empty box",
                                     keyed, n);
    } else if ((rc = cli_bundle_count(&a->in, "tlas", "keyed_instances", n, &tlas_keyed))) {
        return rc;
    } else if (tlas_keyed != keyed) {
        return cli_bundle_refuse(&a->in, "manifest.json",
                                 "tlas.keyed_instances is %zu; %zu of the %zu instances have a non-empty box",
                                 tlas_keyed, keyed, n);
    }
    if (np != rto_next_pow2(keyed))
        return cli_bundle_refuse(&a->in, "manifest.json",
                                 "tlas.n_padded is %zu; %zu instances have a leaf (next power of two %zu)", np, keyed,
                                 rto_next_pow2(keyed));
    if (nodes != want)
        return cli_bundle_refuse(&a->in, "manifest.json", "tlas.nodes is %zu; a %s TLAS over %zu leaves has %zu", nodes,
                                 sweep ? "sweep" : "Karras", keyed, want);
    a->node_count = nodes;
    const rto_layout lk = sweep ? RTO_LAYOUT_TLAS_NODE : RTO_LAYOUT_BLAS_NODE;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    cli_bundle_file_name(RTO_FILE_TLAS_NODES, 0, name);
    rto_npy_desc nd = rto_layout_desc(lk, nodes);
    if ((rc = cli_bundle_load(&a->in, name, &nd, rto_layout_name(lk), &a->nodes)))
        return rc;
    if (!sweep && (rc = load_sorted_keys(a, np)))
        return rc;
    return self_check(a, name, sweep);
}

int cmd_check_bvh(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL, *order_path = NULL;
    bool structure_only = false, json = false, no_artifacts = false;
    uint32_t blas_index = 0;
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "OUTDIR", "the build bundle (rtoracle build)"),
        OPT_PATH("gpu", 0, &gpu, "nodes.npy", "the GPU's node array"),
        OPT_UINT("blas", &blas_index, 0, UINT32_MAX, "M", "check the BLAS of mesh M instead of the TLAS", NULL),
        OPT_FLAG("structure-only", &structure_only, "accept any valid tree over the same primitives"),
        OPT_PATH("gpu-order", 0, &order_path, "order.npy",
                 "the GPU's primitive per sorted leaf (Karras layouts; implies --structure-only)"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "do not write the report next to the GPU dump"),
        OPT_END,
    };
    const opt_command cmd = {"check-bvh", check_bvh_usage, check_bvh_epilog, opts, 0, 0, NULL};
    opt_args args;
    int parsed = opts_parse(&cmd, argc, argv, &args);
    if (parsed >= 0)
        return parsed;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((parsed = opts_require(&cmd, &args, required)))
        return parsed;
    const int64_t blas = opts_given(&cmd, &args, "blas") ? (int64_t)blas_index : -1;
    const bool artifacts = !no_artifacts;

    rto_msg msg = {{0}};
    build_arrays a;
    memset(&a, 0, sizeof a);
    a.in.cmd = "check-bvh";
    a.in.dir = expected;
    rto_npy g = {0}, order = {0};
    int rc = EXIT_PASS;
    if (rto_bundle_open(expected, &a.in.b, &msg)) {
        rc = cli_fail("check-bvh", "--expected: %s", msg.text);
        goto out;
    }
    const char *kind = rto_bundle_get_str(a.in.b, "", "kind"),
               *tlas_mode = rto_bundle_get_str(a.in.b, "params", "tlas");
    if (!kind || strcmp(kind, "build") || !tlas_mode || (strcmp(tlas_mode, "sweep") && strcmp(tlas_mode, "karras"))) {
        rc = cli_fail("check-bvh", "--expected %s is not a build bundle (rtoracle build)", expected);
        goto out;
    }
    size_t meshes = 0;
    if ((rc = cli_bundle_count(&a.in, "counts", "meshes", UINT32_MAX, &meshes)))
        goto out;
    a.meshes = (int64_t)meshes;
    if (blas >= a.meshes) {
        rc = cli_fail("check-bvh", "--blas %lld: the scene has %lld meshes", (long long)blas, (long long)a.meshes);
        goto out;
    }
    const int sweep = blas < 0 && !strcmp(tlas_mode, "sweep");
    if (sweep && order_path) {
        rc = cli_fail("check-bvh", "--gpu-order applies to Karras trees (a BLAS, or a TLAS built with --tlas karras); "
                                   "a sweep TLAS's leaf order is its items");
        goto out;
    }
    const rto_layout lk = sweep ? RTO_LAYOUT_TLAS_NODE : RTO_LAYOUT_BLAS_NODE;
    if (rto_npy_read(gpu, &g, &msg)) {
        rc = cli_fail("check-bvh", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    size_t count = 0;
    if (rto_layout_accept(lk, &g, &count, &msg)) {
        rc = cli_fail("check-bvh", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    if ((rc = blas >= 0 ? load_blas(&a, (uint32_t)blas) : load_tlas(&a, sweep)))
        goto out;
    rto_bvh_check_desc d;
    memset(&d, 0, sizeof d);
    d.nodes = g.data;
    d.node_count = count;
    d.expected = structure_only || order_path ? NULL : a.nodes.data;
    d.prim_boxes = a.boxes.data;
    d.prim_count = a.prim_count;
    d.leaf_tolerance = blas < 0 ? a.tol : NULL;
    d.leaf_prims = a.prims;
    d.leaf_count = a.leaves;
    if (order_path) {
        /* the GPU's leaf order is a GPU output: its shape is input, its values are checked by the validator */
        if (rto_npy_read(order_path, &order, &msg) || order.desc.dtype != RTO_DTYPE_U32 || order.desc.ndim != 1) {
            rc = cli_fail("check-bvh", "--gpu-order %s: expected a 1-D uint32 array (primitive per sorted leaf)%s%s",
                          order_path, msg.text[0] ? ": " : "", msg.text);
            goto out;
        }
        d.leaf_prims = order.data;
        d.leaf_count = (size_t)order.desc.shape[0];
    }
    rto_report r;
    rto_status s = sweep ? rto_tlas_check(&d, &r, &msg) : rto_karras_check(&d, &r, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-bvh", s, &msg);
        goto out;
    }
    if (blas >= 0)
        snprintf(r.what, sizeof r.what, "BLAS %lld", (long long)blas);
    else
        snprintf(r.what, sizeof r.what, "TLAS (%s)", tlas_mode);
    if (order_path) {
        size_t used = strlen(r.context);
        snprintf(r.context + used, sizeof r.context - used, "; leaf order from --gpu-order%s",
                 structure_only ? "" : ", which implies --structure-only");
    }
    rc = cli_report("check-bvh", &r, json, artifacts, gpu);
out:
    rto_npy_free(&g);
    rto_npy_free(&order);
    arrays_free(&a);
    rto_bundle_close(a.in.b);
    return rc;
}
