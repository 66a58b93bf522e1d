/* rtoracle check-frame: compares a GPU's dump of a whole frame with the frame bundle `rtoracle render` wrote, stage
 * by stage in pipeline order, and names the first stage and bounce that diverges (rto_frame_check). The dump is a
 * directory holding any subset of the bundle's file names (docs/frame.md "The GPU dump layout"). */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char check_frame_usage[] =
    "usage: rtoracle check-frame --expected OUTDIR --gpu GPUDIR [--json] [--no-artifacts] [--artifacts DIR]\n"
    "                            [--image-fail-percent P]\n\n"
    "Compares a GPU's frame dump (a directory holding any of the frame bundle's file names: emit_counts.npy,\n"
    "indirect_args.npy, frame_counters.npy, bounce_D_rays.npy, bounce_D_payloads.npy, bounce_D_hits.npy,\n"
    "accum.npy or accum.exr, image.png) with the bundle written by `rtoracle render`, in pipeline order:\n"
    "per queue its emit count and counters, PREP's indirect args (exact), the queue as a multiset keyed by\n"
    "(pixel, kind, payloadSlot), the payloads and hits of matching rays (check-hits rules), then accum\n"
    "(1e-4 relative + 1e-6; + 2e-4 for `triangle`) and the 8-bit image (+-1 per channel, at most 0.1 %% of the pixels over).\n"
    "Pixels the bundle marks not comparable (conflicts, drops) are left out and counted; from a queue that\n"
    "dropped rays on, queues compare by their counts only. A file the dump lacks is reported as not dumped.\n"
    "On a fault the report (check-frame.json) and, for accum / image, a diff image and a listing of the\n"
    "first failing pixels are written into GPUDIR (or --artifacts DIR).\n";

static const char check_frame_epilog[] =
    "Fault classes, in pipeline order: emit-count, indirect-args, queue, payload, hits, accum, image. The\n"
    "report names the first divergence (with its bounce) and lists the later ones. Exit status: 0 the dump\n"
    "agrees, 1 a fault was found, 2 bad usage or input (a bundle whose files disagree with its manifest, an\n"
    "unreadable or mistyped dump file, a dump holding nothing to compare).\n";

int cmd_check_frame(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL, *artifact_dir = NULL;
    bool json = false, no_artifacts = false;
    rto_frame_check_desc d;
    memset(&d, 0, sizeof d);
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "OUTDIR", "the frame bundle (rtoracle render)"),
        OPT_PATH("gpu", 0, &gpu, "GPUDIR", "the directory of the GPU's dump"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "write no report or diff images"),
        OPT_PATH("artifacts", 0, &artifact_dir, "DIR", "write the report and diff images there (default: GPUDIR)"),
        OPT_REAL("image-fail-percent", &d.image_fail_percent, 100, "P",
                 "% of the compared pixels that may differ by more than +-1", "0.1"),
        OPT_END,
    };
    const opt_command cmd = {"check-frame", check_frame_usage, check_frame_epilog, opts, 0, 0, NULL};
    opt_args args;
    int parsed = opts_parse(&cmd, argc, argv, &args);
    if (parsed >= 0)
        return parsed;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((parsed = opts_require(&cmd, &args, required)))
        return parsed;
    d.expected_dir = expected;
    d.gpu_dir = gpu;
    d.image_fail_percent_set = opts_given(&cmd, &args, "image-fail-percent");
    d.artifact_dir = no_artifacts ? NULL : artifact_dir ? artifact_dir : gpu;

    rto_report r;
    rto_msg msg = {{0}};
    /* Artefacts go neither into a bundle nor over an input: --artifacts naming such a place is refused; the default
     * place, the GPU dump, when it is a bundle (a bundle checked against itself), gets none, with a note. */
    if (d.artifact_dir && rto_output_check(d.artifact_dir, 1, (const char *const[]){expected}, 1, &msg)) {
        if (artifact_dir)
            return cli_status("check-frame", RTO_ERR_INVALID_ARGUMENT, &msg);
        fprintf(stderr, "rtoracle check-frame: no artefacts written: %s\n", msg.text);
        d.artifact_dir = NULL;
        msg = (rto_msg){{0}};
    }
    uint32_t written = 0;
    rto_status s = rto_frame_check(&d, &r, &written, &msg);
    if (s != RTO_OK && s != RTO_ERR_MISMATCH)
        return cli_status("check-frame", s, &msg);
    for (uint32_t bit = 1; bit <= RTO_FRAME_ARTIFACT_LISTING; bit <<= 1)
        if (written & bit)
            fprintf(stderr, "rtoracle check-frame: %s written to %s/%s\n",
                    bit == RTO_FRAME_ARTIFACT_LISTING ? "diff listing" : "diff image", d.artifact_dir,
                    rto_frame_artifact_name(bit));
    char *path = NULL;
    if (d.artifact_dir) {
        const size_t len = strlen(d.artifact_dir) + sizeof "/check-frame.json";
        path = malloc(len);
        if (!path)
            return cli_fail("check-frame", "out of memory");
        snprintf(path, len, "%s/check-frame.json", d.artifact_dir);
    }
    const int rc = cli_report_at("check-frame", &r, json, path);
    free(path);
    return rc;
}
