/* rtoracle check-hits: validates a GPU's hit records against a trace bundle (rtoracle trace) by the rules of
 * DESIGN.md §9: IDs, customIndex, hitGroup, missFlag and objToWorld exact, t and barycentrics within tolerance, and
 * another primitive than the oracle's accepted only as a tie (its own re-intersection gives the oracle's t). The
 * bundle's geometry is what the claimed primitives are intersected with, so rto_trace_bundle_read checks every array
 * of it like a GPU dump first: a hand-edited bundle is refused with one line, never trusted. */
#include "cli.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char check_hits_usage[] =
    "usage: rtoracle check-hits --expected OUTDIR --gpu hits.npy [--json] [--no-artifacts]\n\n"
    "Compares a GPU's hit records (one 96-byte HitRecord per ray, in ray order) with the trace bundle written\n"
    "by `rtoracle trace`. The dump may be the structured HitRecord records, a (count, 24) uint32/float32\n"
    "array or the raw buffer as flat uint32/float32 words.\n"
    "Rules (DESIGN.md §9's conformance model: every binary32 operation of §6 correctly rounded, any a*b + c\n"
    "fused or not, division and reciprocal within 2.5 ulp): a record equal to the oracle's passes; otherwise\n"
    "a hit must name a primitive that a conforming implementation may hit, with t and the barycentrics inside\n"
    "the intervals the model gives for it (computed per ray, in binary64 with outward rounding), customIndex,\n"
    "hitGroup and objToWorld exactly its instance's (the column padding is ignored), and no primitive that\n"
    "every conforming implementation reaches and hits may lie before it. A miss must be the miss record (t =\n"
    "the ray's tMax, IDs 0xFFFFFFFF, bary and objToWorld 0), and no primitive may be certainly reached and\n"
    "hit. Each accepted difference is named by the freedom that explains it: arithmetic (the same primitive,\n"
    "other rounding), tie (another primitive at a t the model cannot tell apart), edge (hit or miss is not\n"
    "certain: a vertex, an edge, a ray nearly parallel to the plane), box (certainly hit, not certainly\n"
    "reached), t-range (t within rounding of tMin or tMax), first-hit (a TERMINATE_ON_FIRST_HIT ray ending\n"
    "on another hit: only hit / miss and the claim's t are defined).\n";

static const char check_hits_epilog[] =
    "Fault classes, in priority order: size, miss-flag, instance, prim, t, bary, custom-index, hit-group,\n"
    "transform. The report names the highest-priority fault of the first wrong ray and lists every class\n"
    "seen. Exit status: 0 valid (differences the model allows included), 1 a fault was found, 2 bad usage or\n"
    "input (including a bundle whose arrays disagree with its manifest).\n";

int cmd_check_hits(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL;
    bool json = false, no_artifacts = false;
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "OUTDIR", "the trace bundle (rtoracle trace)"),
        OPT_PATH("gpu", 0, &gpu, "hits.npy", "the GPU's hit records, one per ray of the bundle"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "do not write the report next to the GPU dump"),
        OPT_END,
    };
    const opt_command cmd = {"check-hits", check_hits_usage, check_hits_epilog, opts, 0, 0, NULL};
    opt_args args;
    int parsed = opts_parse(&cmd, argc, argv, &args);
    if (parsed >= 0)
        return parsed;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((parsed = opts_require(&cmd, &args, required)))
        return parsed;

    rto_msg msg = {{0}};
    rto_trace_bundle tb;
    memset(&tb, 0, sizeof tb);
    rto_npy g = {0};
    int rc = EXIT_PASS;
    /* the GPU's dump first: a wrong file there is the likelier mistake, and it is cheap to read */
    size_t gpu_count = 0;
    if (rto_npy_read(gpu, &g, &msg) || rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &g, &gpu_count, &msg)) {
        rc = cli_fail("check-hits", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    if (rto_trace_bundle_read(expected, &tb, &msg)) {
        rc = cli_fail("check-hits", "--expected %s", msg.text);
        goto out;
    }
    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = tb.rays;
    d.ray_count = tb.count;
    d.expected = tb.hits;
    d.gpu = g.data;
    d.gpu_count = gpu_count;
    d.instances = tb.scene.instances;
    d.instance_count = tb.scene.instance_count;
    d.meshes = tb.scene.meshes;
    d.mesh_count = tb.scene.mesh_count;
    rto_report r;
    rto_status s = rto_hits_check(&d, &r, &msg);
    if (s == RTO_ERR_INVALID_ARGUMENT) {
        /* the bundle's own records or geometry disagree: refused as input, as any other bundle array */
        char hname[RTO_BUNDLE_FILE_NAME_MAX];
        rto_bundle_file_name(RTO_FILE_HITS, 0, hname, sizeof hname);
        rc = cli_fail("check-hits", "--expected %s: %s: %s", expected, hname, msg.text);
        goto out;
    }
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-hits", s, &msg);
        goto out;
    }
    if (tb.width && tb.height)
        snprintf(r.what, sizeof r.what, "%.50s rays %" PRIu32 "x%" PRIu32, tb.ray_set, tb.width, tb.height);
    else
        snprintf(r.what, sizeof r.what, "%.80s rays", tb.ray_set);
    rc = cli_report("check-hits", &r, json, !no_artifacts, gpu);
out:
    rto_npy_free(&g);
    rto_trace_bundle_free(&tb);
    return rc;
}
