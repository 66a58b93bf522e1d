/* rtoracle sort: one input file through the bitonic or radix oracle into a bundle. */
#include "cli.h"

#include <getopt.h>
#include <stdlib.h>

static void sort_help(FILE *to)
{
    fprintf(to,
            "usage: rtoracle sort keys.npy [--algo bitonic|radix] [--radix-bits 4|8] [--tile T] [--checkpoints]\n"
            "                     -o OUTDIR\n\n"
            "Sorts a 1-D uint32/uint64 .npy with the canonical bitonic network (padded with the sentinel to the next\n"
            "power of two) or the LSD radix reference, and writes a bundle (written atomically):\n"
            "  keys.npy          the input                       sorted.npy  the n sorted keys\n"
            "  perm.npy          source index of each sorted slot (bitonic: padding p carries n + p)\n"
            "  passes.npy        --checkpoints, bitonic: the n_padded buffer after every (k, j) pass\n"
            "  pass_table.npy    --checkpoints, bitonic: (k, j) of each pass\n"
            "  radix_*.npy       radix: per-pass tile histograms, digit prefix, tile bases, scattered keys and\n"
            "                    indices (always written for --algo radix)\n"
            "  manifest.json     roles, dtypes, shapes and sha256 of every file\n\n"
            "options:\n"
            "  --algo A          bitonic (default) or radix\n"
            "  --radix-bits B    radix digit width, 4 or 8 (default 8)\n"
            "  --tile T          radix tile size in keys (the GPU workgroup's keys), default 256\n"
            "  --checkpoints     write bitonic passes (radix intermediates are always written)\n"
            "  -o, --output DIR  output bundle directory\n");
}

int cmd_sort(int argc, char **argv)
{
    static const struct option opts[] = {{"algo", required_argument, 0, 'a'},   {"radix-bits", required_argument, 0, 'b'},
                                         {"tile", required_argument, 0, 't'},   {"checkpoints", no_argument, 0, 'c'},
                                         {"output", required_argument, 0, 'o'}, {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    sort_params p = {RTO_SORT_BITONIC, 8, 256, false};
    const char *out = NULL;
    uint64_t v;
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1;) {
        switch (c) {
        case 'a':
            if (!cli_parse_algo(optarg, &p.algo))
                return cli_fail("sort", "--algo '%s': expected bitonic or radix", optarg);
            break;
        case 'b':
            if (!cli_parse_u64(optarg, 8, &v) || (v != 4 && v != 8))
                return cli_fail("sort", "--radix-bits '%s': expected 4 or 8", optarg);
            p.radix_bits = (uint32_t)v;
            break;
        case 't':
            if (!cli_parse_u64(optarg, 1u << 24, &v) || v == 0)
                return cli_fail("sort", "--tile '%s': expected 1 .. 16777216", optarg);
            p.tile = (uint32_t)v;
            break;
        case 'c': p.checkpoints = true; break;
        case 'o': out = optarg; break;
        case 'h': sort_help(stdout); return EXIT_PASS;
        default: sort_help(stderr); return cli_fail("sort", "unknown or incomplete option '%s'", argv[optind - 1]);
        }
    }
    if (optind + 1 != argc)
        return cli_fail("sort", "expected exactly one input keys.npy (rtoracle sort --help)");
    if (!out)
        return cli_fail("sort", "-o OUTDIR is required");
    const char *in = argv[optind];
    rto_msg msg = {{0}};
    rto_npy npy = {0};
    rto_key_format f;
    size_t n;
    rto_status s = rto_npy_read(in, &npy, &msg);
    if (!s)
        s = rto_npy_as_keys(&npy, &f, &n, &msg);
    if (s) {
        rto_npy_free(&npy);
        return cli_fail("sort", "%s: %s", in, msg.text);
    }
    if (p.algo == RTO_SORT_RADIX)
        p.checkpoints = true;
    key_origin origin = {NULL, NULL, 0, in};
    s = sort_bundle_write(out, f, npy.data, n, &p, &origin, &msg);
    rto_npy_free(&npy);
    return cli_status("sort", s, &msg);
}
