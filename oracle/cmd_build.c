/* rtoracle build: a scene's acceleration structures in their GPU layouts (DESIGN.md §5). The library builds them
 * (rto_accel_build), checks every tree with the structural validators (rto_accel_check) and writes the bundle
 * (rto_bvh_bundle_write); the command only loads the scene and commits the bundle, and only if the self-check
 * passed. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char build_usage[] =
    "usage: rtoracle build SCENE [--tlas sweep|karras] [--texture-budget MB] [--threads N] [--force] -o OUTDIR\n\n"
    "SCENE is a .gltf / .glb path or a procedural scene: triangle, rtstress:N (1..40),\n"
    "instances:DIST:N (N boxes around the centroids of a centroid distribution, N <= 65536),\n"
    "sphere:L[:SEED] (a closed icosphere, L 0..7), random:SEED (rtoracle info --help lists them).\n"
    "Writes a bundle (atomically):\n"
    "  instances.npy            InstanceRecord: objToWorld, worldToObj (3x4 row-major), blas, customIndex,\n"
    "                           mask, sbtOffset, flags\n"
    "  instance_aabbs.npy       world AABB of every instance (Aabb)\n"
    "  tlas_keys.npy            TLAS keys in instance order (none for instances of an empty mesh);\n"
    "                           tlas_sorted_keys.npy: n_padded, sorted\n"
    "  tlas_nodes.npy           sweep: TlasNode heap (2 n_padded - 1); karras: BlasNode (n - 1)\n"
    "  blas_M_sorted_keys.npy   per mesh M: sorted BLAS keys (u64), blas_M_order.npy: triangle of each\n"
    "                           leaf, blas_M_nodes.npy: BlasNode (triangles - 1), blas_M_prim_aabbs.npy\n"
    "  manifest.json            counts, depth and SAH cost of every tree\n"
    "An OUTDIR that already holds this very bundle (same inputs, options and rtoracle build, no file changed\n"
    "since) is left as it is, in one line; --force writes it again. The bytes do not depend on --threads.\n";

/* --tlas: the sweep tree (the seeds' implicit heap) or a Karras tree. */
static const opt_name tlas_names[] = {{"sweep", 0}, {"karras", 1}, {NULL, 0}};

int cmd_build(int argc, char **argv)
{
    const char *out = NULL;
    unsigned karras = 0;
    uint64_t budget_mb = 0, threads = 0;
    bool force = false;
    const opt_spec opts[] = {
        OPT_ENUM("tlas", &karras, tlas_names, "T", "TLAS layout", "sweep, the seeds' implicit tree"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take", "256"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"build", build_usage, NULL, opts, 1, 1, "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    static const char *const not_inputs[] = {"output", "force", "threads", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("build", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }
    const char *scene = args.arg[0];
    rto_msg msg = {{0}};
    rto_scene *sc = NULL;
    rto_scene_load_desc load = {0};
    load.texture_budget_bytes = (size_t)(budget_mb << 20); /* 0 (not given): the default */
    rto_status s = rto_scene_load_ex(scene, &load, &sc, &msg);
    if (s) { /* the message names the scene file itself */
        free(request);
        return cli_fail("build", "%s", msg.text);
    }
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle build: warning: %s\n", sc->warnings[w]);
    rto_accel_desc desc = {karras ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, (uint32_t)threads};
    rto_accel *acc = NULL;
    s = rto_accel_build(sc, &desc, &acc, &msg);
    rto_report r;
    if (!s)
        s = rto_accel_check(acc, &r, &msg);
    rto_bundle *b = NULL;
    if (!s)
        s = rto_bundle_begin(out, "build", &b, &msg);
    if (!s)
        s = cli_set_request(b, request, sc, NULL, &msg);
    if (!s)
        s = rto_bvh_bundle_write(acc, b, &msg);
    if (!s)
        s = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    if (!s) {
        char sum[64];
        printf("build %s: %u instances, %u meshes -> %s (%s)\n", scene, sc->instance_count, sc->mesh_count, out,
               cli_dir_summary(out, sum, sizeof sum));
    }
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
    free(request);
    if (s == RTO_ERR_MISMATCH) /* the self-check failed: the oracle's own tree is wrong, nothing is written */
        return cli_fail("build", "internal self-check failed: %s", msg.text);
    return cli_status("build", s, &msg);
}
