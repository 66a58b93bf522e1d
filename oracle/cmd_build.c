/* rtoracle build: a scene's acceleration structures in their GPU layouts (DESIGN.md §5). The library builds them
 * (rto_accel_build), checks every tree with the structural validators (rto_accel_check) and writes the bundle
 * (rto_accel_write_bundle); the command only loads the scene and commits the bundle, and only if the self-check
 * passed. */
#include "cli.h"

#include <getopt.h>
#include <stdlib.h>
#include <string.h>

static void build_help(FILE *to)
{
    fprintf(to,
            "usage: rtoracle build SCENE [--tlas sweep|karras] -o OUTDIR\n\n"
            "SCENE is a .gltf / .glb path or a procedural scene: triangle, rtstress:N (1..40),\n"
            "instances:DIST:N (N boxes around the centroids of a centroid distribution, N <= 65536).\n"
            "Writes a bundle (atomically):\n"
            "  instances.npy            InstanceRecord: objToWorld, worldToObj (3x4 row-major), blas, customIndex,\n"
            "                           mask, sbtOffset, flags\n"
            "  instance_aabbs.npy       world AABB of every instance (Aabb)\n"
            "  tlas_keys.npy            TLAS keys in instance order (none for instances of an empty mesh);\n"
            "                           tlas_sorted_keys.npy: n_padded, sorted\n"
            "  tlas_nodes.npy           sweep: TlasNode heap (2 n_padded - 1); karras: BlasNode (n - 1)\n"
            "  blas_M_sorted_keys.npy   per mesh M: sorted BLAS keys (u64), blas_M_order.npy: triangle of each\n"
            "                           leaf, blas_M_nodes.npy: BlasNode (triangles - 1), blas_M_prim_aabbs.npy\n"
            "  manifest.json            counts, depth and SAH cost of every tree\n\n"
            "options:\n"
            "  --tlas sweep|karras  TLAS layout (default sweep, the seeds' implicit tree)\n"
            "  -o, --output DIR     output bundle directory\n");
}

int cmd_build(int argc, char **argv)
{
    static const struct option opts[] = {{"tlas", required_argument, 0, 't'}, {"output", required_argument, 0, 'o'},
                                         {"help", no_argument, 0, 'h'},       {0, 0, 0, 0}};
    const char *out = NULL;
    int karras = 0;
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1;) {
        switch (c) {
        case 't':
            if (!strcmp(optarg, "karras"))
                karras = 1;
            else if (strcmp(optarg, "sweep"))
                return cli_fail("build", "--tlas '%s': expected sweep or karras", optarg);
            break;
        case 'o': out = optarg; break;
        case 'h': build_help(stdout); return EXIT_PASS;
        default: build_help(stderr); return cli_fail("build", "unknown or incomplete option '%s'", argv[optind - 1]);
        }
    }
    if (optind + 1 != argc)
        return cli_fail("build", "expected exactly one SCENE (rtoracle build --help)");
    if (!out)
        return cli_fail("build", "-o OUTDIR is required");
    rto_msg msg = {{0}};
    rto_scene *sc = NULL;
    rto_status s = rto_scene_load(argv[optind], &sc, &msg);
    if (s)
        return cli_fail("build", "%s: %s", argv[optind], msg.text);
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle build: warning: %s\n", sc->warnings[w]);
    rto_accel_desc desc = {karras ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP};
    rto_accel *acc = NULL;
    s = rto_accel_build(sc, &desc, &acc, &msg);
    rto_bvh_report r;
    if (!s)
        s = rto_accel_check(acc, &r, &msg);
    rto_bundle *b = NULL;
    if (!s)
        s = rto_bundle_begin(out, "build", &b, &msg);
    if (!s)
        s = rto_accel_write_bundle(acc, b, &msg);
    if (!s)
        s = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
    if (s == RTO_ERR_MISMATCH) /* the self-check failed: the oracle's own tree is wrong, nothing is written */
        return cli_fail("build", "internal self-check failed: %s", msg.text);
    return cli_status("build", s, &msg);
}
