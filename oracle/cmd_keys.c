/* rtoracle keys: sort inputs of a named distribution (DESIGN.md §3). */
#include "cli.h"

#include <getopt.h>
#include <stdlib.h>
#include <string.h>

static void keys_help(FILE *to)
{
    fprintf(to,
            "usage: rtoracle keys --dist NAME --n N [--seed S] [--format u32|u64] -o keys.npy\n"
            "       rtoracle keys --list\n\n"
            "Writes N keys of distribution NAME as a 1-D .npy array (uint32 or uint64, default u32).\n"
            "Centroid distributions give Morton keys of generated centroids: TLAS keys (morton15 << 16 | index,\n"
            "N <= 65536) for u32, BLAS keys (morton30 << 32 | index) for u64. Raw distributions give keys directly.\n"
            "Every key is a pure function of (dist, format, seed, index) through the shared PRNG (DESIGN.md §3).\n\n"
            "options:\n"
            "  --dist NAME      a distribution (see --list)\n"
            "  --n N            number of keys (0 .. 2^28)\n"
            "  --seed S         PRNG seed, default 1\n"
            "  --format F       u32 (default) or u64\n"
            "  -o, --output P   output .npy path (written atomically)\n"
            "  --list           list distributions and size classes\n");
}

static void list_dists(void)
{
    printf("centroid distributions (Morton keys of generated centroids):\n");
    for (size_t i = 0; i < rto_dist_count(); i++)
        if (rto_dist_at(i)->kind == RTO_DIST_CENTROID)
            printf("  %-20s %s\n", rto_dist_at(i)->name, rto_dist_at(i)->summary);
    printf("raw key distributions:\n");
    for (size_t i = 0; i < rto_dist_count(); i++)
        if (rto_dist_at(i)->kind == RTO_DIST_RAW)
            printf("  %-20s %s\n", rto_dist_at(i)->name, rto_dist_at(i)->summary);
    printf("size classes:\n");
    const char *classes[] = {"tiny", "tile", "pow2", "large"};
    for (size_t c = 0; c < 4; c++) {
        size_t sizes[RTO_SIZE_CLASS_MAX], count = 0;
        rto_size_class(classes[c], sizes, &count, NULL);
        printf("  %-6s", classes[c]);
        for (size_t i = 0; i < count; i++)
            printf(" %zu", sizes[i]);
        printf("\n");
    }
}

int cmd_keys(int argc, char **argv)
{
    static const struct option opts[] = {{"dist", required_argument, 0, 'd'},   {"n", required_argument, 0, 'n'},
                                         {"seed", required_argument, 0, 's'},   {"format", required_argument, 0, 'f'},
                                         {"output", required_argument, 0, 'o'}, {"list", no_argument, 0, 'l'},
                                         {"help", no_argument, 0, 'h'},         {0, 0, 0, 0}};
    const char *dist = NULL, *out = NULL;
    uint64_t n = 0, seed = 1;
    bool have_n = false;
    rto_key_format f = RTO_KEY_U32;
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1;) {
        switch (c) {
        case 'd': dist = optarg; break;
        case 'n':
            if (!cli_parse_u64(optarg, RTO_MAX_KEYS, &n))
                return cli_fail("keys", "--n '%s': expected an integer 0 .. %llu", optarg,
                                (unsigned long long)RTO_MAX_KEYS);
            have_n = true;
            break;
        case 's':
            if (!cli_parse_u64(optarg, UINT32_MAX, &seed))
                return cli_fail("keys", "--seed '%s': expected an integer 0 .. 4294967295", optarg);
            break;
        case 'f':
            if (!cli_parse_format(optarg, &f))
                return cli_fail("keys", "--format '%s': expected u32 or u64", optarg);
            break;
        case 'o': out = optarg; break;
        case 'l': list_dists(); return EXIT_PASS;
        case 'h': keys_help(stdout); return EXIT_PASS;
        default: keys_help(stderr); return cli_fail("keys", "unknown or incomplete option '%s'", argv[optind - 1]);
        }
    }
    if (optind < argc)
        return cli_fail("keys", "unexpected argument '%s'", argv[optind]);
    if (!dist || !have_n || !out)
        return cli_fail("keys", "--dist, --n and -o are required (rtoracle keys --help)");
    if (!rto_dist_find(dist))
        return cli_fail("keys", "unknown distribution '%s' (rtoracle keys --list)", dist);
    void *keys = malloc(n ? n * rto_key_size(f) : 1);
    if (!keys)
        return cli_fail("keys", "out of memory for %llu keys", (unsigned long long)n);
    rto_msg msg = {{0}};
    rto_status s = rto_keys_generate(dist, f, (uint32_t)seed, (size_t)n, keys, &msg);
    if (!s) {
        rto_npy_desc desc = rto_npy_desc_keys(f, n);
        s = rto_npy_write(out, &desc, keys, &msg);
    }
    free(keys);
    return cli_status("keys", s, &msg);
}
