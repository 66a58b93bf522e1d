/* rtoracle sort: one input file through the bitonic or radix oracle into a bundle. */
#include "cli.h"

#include <stdlib.h>

static const char sort_usage[] =
    "usage: rtoracle sort keys.npy [--algo bitonic|radix] [--radix-bits 4|8] [--tile T] [--checkpoints]\n"
    "                     [--force] -o OUTDIR\n\n"
    "Sorts a 1-D uint32/uint64 .npy with the canonical bitonic network (padded with the sentinel to the next\n"
    "power of two) or the LSD radix reference, and writes a bundle (written atomically):\n"
    "  keys.npy          the input                       sorted.npy  the n sorted keys\n"
    "  perm.npy          source index of each sorted slot (bitonic: padding p carries n + p)\n"
    "  passes.npy        --checkpoints, bitonic: the n_padded buffer after every (k, j) pass\n"
    "  pass_table.npy    --checkpoints, bitonic: (k, j) of each pass\n"
    "  radix_*.npy       radix: per-pass tile histograms, digit prefix, tile bases, scattered keys and\n"
    "                    indices (always written for --algo radix)\n"
    "  manifest.json     roles, dtypes, shapes and sha256 of every file\n"
    "An OUTDIR that already holds this very bundle (same keys file content, options and rtoracle build, no file\n"
    "changed since) is left as it is, in one line; --force writes it again.\n";

int cmd_sort(int argc, char **argv)
{
    sort_params p = {RTO_SORT_BITONIC, 8, 256, false};
    const char *out = NULL;
    bool force = false;
    const opt_spec opts[] = {
        OPT_ENUM("algo", &p.algo, cli_algo_names, "A", "sorting algorithm", "bitonic"),
        OPT_CHOICE("radix-bits", &p.radix_bits, cli_radix_bits_names, "B", "radix digit width", "8"),
        OPT_UINT("tile", &p.tile, 1, CLI_TILE_MAX, "T", "radix tile size in keys (the GPU workgroup's keys)", "256"),
        OPT_FLAG("checkpoints", &p.checkpoints, "write bitonic passes (radix intermediates are always written)"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"sort", sort_usage, NULL, opts, 1, 1, "one input keys.npy"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    const char *in = args.arg[0];
    static const char *const not_inputs[] = {"output", "force", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("sort", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }
    rto_msg msg = {{0}};
    rto_npy npy = {0};
    rto_key_format f;
    size_t n;
    rto_status s = rto_npy_read(in, &npy, &msg);
    if (!s)
        s = rto_npy_as_keys(&npy, &f, &n, &msg);
    if (s) {
        rto_npy_free(&npy);
        free(request);
        return cli_fail("sort", "%s: %s", in, msg.text);
    }
    if (p.algo == RTO_SORT_RADIX)
        p.checkpoints = true;
    key_origin origin = {NULL, NULL, 0, in, request};
    s = sort_bundle_write(out, f, npy.data, n, &p, &origin, NULL, &msg);
    rto_npy_free(&npy);
    free(request);
    return cli_status("sort", s, &msg);
}
