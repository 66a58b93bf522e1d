/* rtoracle check-bvh: validates a GPU-built TLAS or BLAS node array against a build bundle — exactly (items and
 * links equal to the oracle's) or, with --structure-only, for validity against the primitives alone; boxes by the
 * rules of DESIGN.md §9 either way. The bundle is read by rto_bvh_bundle_read, which refuses a hand-edited one. */
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
    rto_bvh_bundle bb;
    rto_npy g = {0}, order = {0};
    int rc = EXIT_PASS;
    rto_status rs = rto_bvh_bundle_read(expected, blas, &bb, &msg);
    if (rs) {
        rc = cli_fail("check-bvh", "--expected %s", msg.text);
        goto out;
    }
    if (bb.sweep && order_path) {
        rc = cli_fail("check-bvh", "--gpu-order applies to Karras trees (a BLAS, or a TLAS built with --tlas karras); "
                                   "a sweep TLAS's leaf order is its items");
        goto out;
    }
    const rto_layout lk = bb.sweep ? RTO_LAYOUT_TLAS_NODE : RTO_LAYOUT_BLAS_NODE;
    size_t count = 0;
    if (rto_npy_read(gpu, &g, &msg) || rto_layout_accept(lk, &g, &count, &msg)) {
        rc = cli_fail("check-bvh", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    rto_bvh_check_desc d;
    memset(&d, 0, sizeof d);
    d.nodes = g.data;
    d.node_count = count;
    d.expected = structure_only || order_path ? NULL : bb.nodes;
    d.prim_boxes = bb.prim_boxes;
    d.prim_count = bb.prim_count;
    d.leaf_tolerance = bb.leaf_tolerance;
    d.leaf_prims = bb.leaf_prims;
    d.leaf_count = bb.leaf_count;
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
    rto_status s = bb.sweep ? rto_tlas_check(&d, &r, &msg) : rto_karras_check(&d, &r, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-bvh", s, &msg);
        goto out;
    }
    if (blas >= 0)
        snprintf(r.what, sizeof r.what, "BLAS %lld", (long long)blas);
    else
        snprintf(r.what, sizeof r.what, "TLAS (%s)", bb.tlas_mode);
    if (order_path) {
        size_t used = strlen(r.context);
        snprintf(r.context + used, sizeof r.context - used, "; leaf order from --gpu-order%s",
                 structure_only ? "" : ", which implies --structure-only");
    }
    rc = cli_report("check-bvh", &r, json, artifacts, gpu);
out:
    rto_npy_free(&g);
    rto_npy_free(&order);
    rto_bvh_bundle_free(&bb);
    return rc;
}
