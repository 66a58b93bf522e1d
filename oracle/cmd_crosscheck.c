/* rtoracle crosscheck: the same rays through the oracle (rto_trace) and Intel Embree 3 (oracle/embree.c), compared
 * ray by ray, every disagreement classified (src/trace/crosscheck.h: tie, coplanar, crossing, t-rounding, robust-only,
 * surface-start, grazing, sliver, unexplained),
 * one summary row per ray class. An unexplained disagreement is a bug in one of the two tracers until shown
 * otherwise: exit status 1. */
#include "crosscheck_run.h"

#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char crosscheck_usage[] =
    "usage: rtoracle crosscheck SCENE [--rays SETS|FILE.npy] [--count N] [--width W --height H] [--seed S]\n"
    "                           [--embree robust|default] [--threads N] [--json]\n\n"
    "Traces rays through the oracle (ordered traversal, DESIGN.md §6) and through Embree 3 mirroring the\n"
    "scene (one Embree scene per BLAS, one instance geometry per instance), and compares every ray: they\n"
    "agree when both miss, or both hit the same (instance, primitive) with |dt| <= 1e-5 max(1, |t|)\n"
    "(TERMINATE_ON_FIRST_HIT rays: when both hit or both miss). Each disagreement gets the first class\n"
    "that fits:\n"
    "  tie          different triangles at the same t (within 1e-5) that share a vertex (index, or world\n"
    "               position within 1e-6 relative)\n"
    "  coplanar     different triangles at the same t lying in one plane and overlapping at the hit\n"
    "  crossing     different triangles at the same t, not in one plane, both containing the hit point\n"
    "               (they touch or cross there)\n"
    "  t-rounding   the same triangle, t apart by more than 1e-5, both t in the interval DESIGN.md §9's\n"
    "               conformance model gives a conforming implementation, or the two hit points within\n"
    "               1e-5 (relative to the coordinates) of each other across its plane\n"
    "  robust-only  (--embree default) Embree robust agrees with the oracle where default did not\n"
    "  surface-start  the hit one side missed lies on a plane the ray starts on (its crossing within\n"
    "               rounding of tMin)\n"
    "  grazing      the hit one side missed is one the model says may be hit or missed (an edge or a box\n"
    "               within rounding), or lies within 1e-5 (relative to the coordinates, over |cos| of the\n"
    "               incidence angle) of an edge of its triangle, or the ray is within 1e-4 of parallel to\n"
    "               its plane\n"
    "  sliver       an ill-conditioned triangle: t, or the hit's distance to an edge, within 4 times the\n"
    "               spread the model allows §6's binary32 arithmetic there\n"
    "  unexplained  anything else (the first few are printed in full)\n"
    "SETS is a comma-separated list of generated sets (primary, shadow, random, grazing, axis; every set\n"
    "a pure function of the scene and the seed): primary and shadow use --width x --height, the others\n"
    "--count rays. FILE.npy is a WfRay array (rays.npy of a trace bundle); its rays are grouped by kind.\n"
    "docs/trace.md (\"crosscheck\") explains the classes and how to read the table.\n";

static const char crosscheck_epilog[] =
    "Exit status: 0 no unexplained disagreement, 1 at least one, 2 bad usage or input.\n";

int cmd_crosscheck(int argc, char **argv)
{
    const char *rays_arg = "primary,random,grazing,axis,shadow";
    uint32_t count = 65536, width = 320, height = 240, seed = 1, threads = 0;
    unsigned robust = 1;
    bool json = false;
    static const opt_name modes[] = {{"robust", 1}, {"default", 0}, {NULL, 0}};
    const opt_spec opts[] = {
        OPT_STRING("rays", &rays_arg, "SETS|FILE.npy",
                   "generated sets (primary, shadow, random, grazing, axis; default all) or a WfRay .npy file"),
        OPT_UINT("count", &count, 1, XC_MAX_RAYS, "N", "rays of each random, grazing and axis set", "65536"),
        OPT_UINT("width", &width, 1, 16384, "W", "image width of primary and shadow rays", "320"),
        OPT_UINT("height", &height, 1, 16384, "H", "image height of primary and shadow rays", "240"),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "S", "PRNG seed of the generated sets", "1"),
        OPT_ENUM("embree", &robust, modes, "MODE",
                 "Embree's mode: robust (RTC_SCENE_FLAG_ROBUST, watertight) or default (its fast path)", "robust"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads for both tracers (0: one per online CPU)", "0"),
        OPT_FLAG("json", &json, "print the table as JSON"),
        OPT_END,
    };
    const opt_command cmd = {"crosscheck", crosscheck_usage, crosscheck_epilog, opts, 1, 1, "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    if ((uint64_t)width * height > XC_MAX_RAYS)
        return cli_fail("crosscheck", "--width %u --height %u: %llu rays, at most %llu", width, height,
                        (unsigned long long)width * height, (unsigned long long)XC_MAX_RAYS);
    rto_ray_set sets[RTO_RAY_SET_COUNT];
    size_t nsets = 0;
    const bool file = strlen(rays_arg) >= 4 && !strcmp(rays_arg + strlen(rays_arg) - 4, ".npy");
    if (!file && !xc_parse_sets(rays_arg, sets, &nsets))
        return cli_fail("crosscheck", "--rays %s: expected a comma-separated list of primary, shadow, random, grazing, "
                        "axis, or a .npy ray file", rays_arg);

    const char *spec = args.arg[0];
    rto_msg msg = {{0}};
    const emb_module *E = emb_module_load(&msg);
    if (!E)
        return cli_fail("crosscheck", "%s", msg.text);
    rto_scene *sc = NULL;
    if (rto_scene_load(spec, &sc, &msg))
        return cli_fail("crosscheck", "%s", msg.text);
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle crosscheck: warning: %s\n", sc->warnings[w]);
    run r;
    memset(&r, 0, sizeof r);
    r.E = E;
    r.scene = sc;
    r.robust_mode = robust != 0;
    r.threads = threads;
    rto_accel *acc = NULL;
    rto_status st = rto_accel_build(sc, NULL, &acc, &msg);
    if (!st)
        st = cf_scene_init(&r.model, sc, &msg);
    if (!st)
        st = E->device_create(threads, NULL, &r.dev, &msg);
    if (st) {
        rc = cli_status("crosscheck", st, &msg);
        goto out;
    }
    r.accel = acc;
    rc = file ? xc_run_file(&r, rays_arg, &msg) : xc_run_sets(&r, sets, nsets, seed, width, height, count, &msg);
    if (rc == EXIT_PASS) {
        const char *mode = r.robust_mode ? "robust" : "default";
        rc = json ? xc_print_json(&r, spec, mode) : (xc_print_text(&r, spec, mode), EXIT_PASS);
        if (rc == EXIT_PASS && r.unexplained)
            rc = EXIT_MISMATCH;
    }
out:
    E->scene_destroy(r.mirror);
    E->scene_destroy(r.robust);
    E->device_destroy(r.dev);
    cf_scene_free(&r.model);
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
    return rc;
}
