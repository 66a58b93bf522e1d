/* rtoracle check-bvh: validates a GPU-built TLAS or BLAS node array against a build bundle — exactly (topology and
 * items) with DESIGN.md §9 box tolerances, or, with --structure-only, for validity against the scene alone. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char check_bvh_usage[] =
    "usage: rtoracle check-bvh --expected OUTDIR --gpu nodes.npy [--blas M] [--structure-only]\n"
    "                          [--gpu-order order.npy] [--json] [--no-artifacts]\n\n"
    "Compares a GPU-built node array with the bundle written by `rtoracle build`: the TLAS by default, the\n"
    "BLAS of mesh M with --blas M. The dump may be the structured TlasNode / BlasNode records, a (count,\n"
    "words) array or the raw buffer as flat uint32/float32 words.\n"
    "Exact mode: items, links and parents must equal the oracle's; internal boxes must be the exact union\n"
    "of their children; leaf boxes within 4 ulp for TLAS instances (transformed boxes) and exact for\n"
    "triangles. --structure-only accepts a tree built differently: links in range, no cycle or shared node,\n"
    "every primitive in exactly one leaf, boxes as above against the scene's boxes. For Karras layouts the\n"
    "leaf order is the oracle's sorted keys unless --gpu-order gives the GPU's (primitive per sorted leaf).\n";

static const char check_bvh_epilog[] =
    "Fault classes: size, cycle, shared-node, bad-link, dropped-leaf, item, swapped-children, topology,\n"
    "parent, empty, box. Exit status: 0 valid, 1 a fault was found, 2 bad usage or input.\n";

static int load_bundle_file(rto_bundle_reader *b, const char *name, rto_npy *out, const char *dir)
{
    rto_msg msg = {{0}};
    if (rto_bundle_read_name(b, name, out, &msg))
        return cli_fail("check-bvh", "--expected %s: %s", dir, msg.text);
    return EXIT_PASS;
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
    rto_bundle_reader *b = NULL;
    rto_npy g = {0}, exp = {0}, boxes = {0}, order = {0}, keys = {0};
    int rc = EXIT_PASS;
    if (rto_bundle_open(expected, &b, &msg)) {
        rc = cli_fail("check-bvh", "--expected: %s", msg.text);
        goto out;
    }
    const char *kind = rto_bundle_get_str(b, "", "kind"), *tlas_mode = rto_bundle_get_str(b, "params", "tlas");
    if (!kind || strcmp(kind, "build") || !tlas_mode) {
        rc = cli_fail("check-bvh", "--expected %s is not a build bundle (rtoracle build)", expected);
        goto out;
    }
    int64_t meshes = 0;
    rto_bundle_get_int(b, "counts", "meshes", &meshes);
    if (blas >= meshes) {
        rc = cli_fail("check-bvh", "--blas %lld: the scene has %lld meshes", (long long)blas, (long long)meshes);
        goto out;
    }
    const int sweep = blas < 0 && !strcmp(tlas_mode, "sweep");
    const rto_layout lk = sweep ? RTO_LAYOUT_TLAS_NODE : RTO_LAYOUT_BLAS_NODE;
    char name[RTO_BUNDLE_FILE_NAME_MAX], what[64];
    if (blas >= 0)
        snprintf(what, sizeof what, "BLAS %lld", (long long)blas);
    else
        snprintf(what, sizeof what, "TLAS (%s)", tlas_mode);
    if (rto_npy_read(gpu, &g, &msg)) {
        rc = cli_fail("check-bvh", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    size_t count = 0;
    if (rto_layout_accept(lk, &g, &count, &msg)) {
        rc = cli_fail("check-bvh", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    /* expected nodes and primitive boxes */
    rto_bundle_file_name(blas < 0 ? RTO_FILE_TLAS_NODES : RTO_FILE_BLAS_NODES, (uint32_t)blas, name, sizeof name);
    if ((rc = load_bundle_file(b, name, &exp, expected)))
        goto out;
    rto_bundle_file_name(blas < 0 ? RTO_FILE_INSTANCE_AABBS : RTO_FILE_BLAS_PRIM_AABBS, (uint32_t)blas, name,
                         sizeof name);
    if ((rc = load_bundle_file(b, name, &boxes, expected)))
        goto out;
    const size_t n = (size_t)boxes.desc.shape[0], exp_count = (size_t)exp.desc.shape[0];
    rto_bvh_report r;
    rto_status s;
    if (sweep) {
        s = rto_tlas_check(g.data, count, structure_only ? NULL : exp.data, boxes.data, n, &r, &msg);
    } else {
        uint32_t *prims = NULL;
        if (order_path) {
            if (rto_npy_read(order_path, &order, &msg) || order.desc.dtype != RTO_DTYPE_U32 || order.desc.ndim != 1 ||
                order.desc.shape[0] != n) {
                rc = cli_fail("check-bvh", "--gpu-order %s: expected %zu uint32 primitive indices%s%s", order_path, n,
                              msg.text[0] ? ": " : "", msg.text);
                goto out;
            }
            prims = order.data;
            for (size_t j = 0; j < n; j++)
                if (prims[j] >= n) {
                    rc = cli_fail("check-bvh", "--gpu-order %s: entry %zu names primitive %u of %zu", order_path, j,
                                  prims[j], n);
                    goto out;
                }
        } else if (blas >= 0) {
            rto_bundle_file_name(RTO_FILE_BLAS_ORDER, (uint32_t)blas, name, sizeof name);
            if ((rc = load_bundle_file(b, name, &order, expected)))
                goto out;
            prims = order.data;
        } else {
            rto_bundle_file_name(RTO_FILE_TLAS_SORTED_KEYS, 0, name, sizeof name);
            if ((rc = load_bundle_file(b, name, &keys, expected)))
                goto out;
            prims = malloc((n ? n : 1) * sizeof *prims);
            if (!prims) {
                rc = cli_fail("check-bvh", "out of memory");
                goto out;
            }
            for (size_t j = 0; j < n; j++)
                prims[j] = rto_key_prim(RTO_KEY_U32, ((const uint32_t *)keys.data)[j]);
        }
        const int exact = !structure_only && !order_path;
        s = rto_karras_check(g.data, count, exact && count == exp_count ? exp.data : NULL, prims, boxes.data, n,
                             blas < 0 ? RTO_TLAS_LEAF_ULPS : 0, &r, &msg);
        if (prims != order.data)
            free(prims);
    }
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-bvh", s, &msg);
        goto out;
    }
    json_t *j = json_object();
    json_object_set_new(j, "command", json_string("check-bvh"));
    json_object_set_new(j, "tree", json_string(what));
    json_object_set_new(j, "mode", json_string(structure_only || order_path ? "structure-only" : "exact"));
    json_object_set_new(j, "result", json_string(s == RTO_OK ? "pass" : "fail"));
    json_object_set_new(j, "fault", json_string(rto_bvh_fault_name(r.fault)));
    json_object_set_new(j, "node", r.node >= 0 ? json_integer(r.node) : json_null());
    json_object_set_new(j, "leaf", r.leaf >= 0 ? json_integer(r.leaf) : json_null());
    json_t *all = json_array();
    for (int f = 1; f <= RTO_BVH_BOX; f++)
        if (r.faults & (1u << f))
            json_array_append_new(all, json_string(rto_bvh_fault_name((rto_bvh_fault)f)));
    json_object_set_new(j, "faults", all);
    json_object_set_new(j, "nodes", json_integer((json_int_t)count));
    json_object_set_new(j, "message", json_string(s == RTO_OK ? "ok" : r.summary));
    if (json) {
        json_dumpf(j, stdout, JSON_INDENT(2));
        fputc('\n', stdout);
    } else if (s == RTO_OK) {
        printf("check-bvh %s: PASS %zu nodes over %zu primitives (%s)\n", what, count, n,
               structure_only || order_path ? "valid structure" : "equal to the oracle within tolerance");
    } else {
        printf("check-bvh %s: FAIL %s\n", what, r.summary);
        printf("  fault classes seen:");
        for (int f = 1; f <= RTO_BVH_BOX; f++)
            if (r.faults & (1u << f))
                printf(" %s", rto_bvh_fault_name((rto_bvh_fault)f));
        printf("\n");
    }
    int wrote = s == RTO_ERR_MISMATCH && artifacts ? cli_write_report(gpu, "check-bvh", j) : EXIT_PASS;
    json_decref(j);
    rc = wrote != EXIT_PASS ? wrote : s == RTO_OK ? EXIT_PASS : EXIT_MISMATCH;
out:
    rto_npy_free(&g);
    rto_npy_free(&exp);
    rto_npy_free(&boxes);
    rto_npy_free(&order);
    rto_npy_free(&keys);
    rto_bundle_close(b);
    return rc;
}
