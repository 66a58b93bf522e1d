/* rtoracle suite sort: the distribution x size x format x algorithm matrix as bundles, the set a GPU harness runs
 * (DESIGN.md §3, §4). One suite directory holds a manifest listing every case and one sort bundle per case. */
#include "cli.h"

#include <getopt.h>
#include <stdlib.h>
#include <string.h>

static void suite_help(FILE *to)
{
    fprintf(to,
            "usage: rtoracle suite sort [--sizes LIST] [--dists LIST] [--formats LIST] [--algos LIST] [--seed S]\n"
            "                           [--radix-bits 4|8] [--tile T] [--checkpoint-max N] -o DIR\n\n"
            "Writes one sort bundle per case into DIR/<algo>-<fmt>-<dist>-n<N>/ and DIR/manifest.json listing\n"
            "them with case ids such as sort:bitonic:fmt=u32:dist=clustered:n=4097. Written atomically.\n"
            "Combinations that do not exist are skipped (digit-4..7 need u64; centroid distributions give TLAS\n"
            "keys of at most 65536 instances in u32).\n\n"
            "options (LIST = comma-separated):\n"
            "  --sizes LIST         size classes (tiny, tile, pow2, large, all) and/or numbers; default all\n"
            "  --dists LIST         distribution names, or all / centroid / raw; default all\n"
            "  --formats LIST       u32, u64; default u32,u64\n"
            "  --algos LIST         bitonic, radix; default bitonic,radix\n"
            "  --seed S             PRNG seed, default 1\n"
            "  --radix-bits B       4 or 8, default 8;  --tile T   radix tile, default 256\n"
            "  --checkpoint-max N   write bitonic passes / radix intermediates when n_padded <= N (default 1024,\n"
            "                       0 for none)\n"
            "  -o, --output DIR     output directory\n");
}

#define MAX_ITEMS 256

/* Splits a comma-separated list in place. */
static size_t split(char *s, char **items)
{
    size_t n = 0;
    for (char *tok = strtok(s, ","); tok && n < MAX_ITEMS; tok = strtok(NULL, ","))
        items[n++] = tok;
    return n;
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

int cmd_suite(int argc, char **argv)
{
    static const struct option opts[] = {
        {"sizes", required_argument, 0, 'z'},  {"dists", required_argument, 0, 'd'},
        {"formats", required_argument, 0, 'f'}, {"algos", required_argument, 0, 'a'},
        {"seed", required_argument, 0, 's'},   {"radix-bits", required_argument, 0, 'b'},
        {"tile", required_argument, 0, 't'},   {"checkpoint-max", required_argument, 0, 'c'},
        {"output", required_argument, 0, 'o'}, {"help", no_argument, 0, 'h'},
        {0, 0, 0, 0}};
    if (argc < 2 || strcmp(argv[1], "sort") != 0) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            suite_help(stdout);
            return EXIT_PASS;
        }
        suite_help(stderr);
        return cli_fail("suite", "expected 'sort' (the only suite so far)");
    }
    argc--;
    argv++;
    char sizes_buf[1024] = "all", dists_buf[1024] = "all", formats_buf[64] = "u32,u64", algos_buf[64] = "bitonic,radix";
    const char *out = NULL;
    uint64_t seed = 1, v, checkpoint_max = 1024;
    sort_params base = {RTO_SORT_BITONIC, 8, 256, false};
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1;) {
        char *dst = NULL;
        size_t cap = 0;
        switch (c) {
        case 'z': dst = sizes_buf, cap = sizeof sizes_buf; break;
        case 'd': dst = dists_buf, cap = sizeof dists_buf; break;
        case 'f': dst = formats_buf, cap = sizeof formats_buf; break;
        case 'a': dst = algos_buf, cap = sizeof algos_buf; break;
        case 's':
            if (!cli_parse_u64(optarg, UINT32_MAX, &seed))
                return cli_fail("suite", "--seed '%s': expected 0 .. 4294967295", optarg);
            break;
        case 'b':
            if (!cli_parse_u64(optarg, 8, &v) || (v != 4 && v != 8))
                return cli_fail("suite", "--radix-bits '%s': expected 4 or 8", optarg);
            base.radix_bits = (uint32_t)v;
            break;
        case 't':
            if (!cli_parse_u64(optarg, 1u << 24, &v) || v == 0)
                return cli_fail("suite", "--tile '%s': expected 1 .. 16777216", optarg);
            base.tile = (uint32_t)v;
            break;
        case 'c':
            if (!cli_parse_u64(optarg, RTO_MAX_KEYS, &checkpoint_max))
                return cli_fail("suite", "--checkpoint-max '%s': expected 0 .. %llu", optarg,
                                (unsigned long long)RTO_MAX_KEYS);
            break;
        case 'o': out = optarg; break;
        case 'h': suite_help(stdout); return EXIT_PASS;
        default: suite_help(stderr); return cli_fail("suite", "unknown or incomplete option '%s'", argv[optind - 1]);
        }
        if (dst) {
            if (strlen(optarg) >= cap || !*optarg)
                return cli_fail("suite", "option list '%s' is empty or too long", optarg);
            strcpy(dst, optarg);
        }
    }
    if (optind < argc)
        return cli_fail("suite", "unexpected argument '%s'", argv[optind]);
    if (!out)
        return cli_fail("suite", "-o DIR is required");

    /* Sizes: classes and numbers, deduplicated and ascending. */
    char *items[MAX_ITEMS];
    size_t sizes[4 * RTO_SIZE_CLASS_MAX], nsizes = 0;
    size_t ni = split(sizes_buf, items);
    for (size_t i = 0; i < ni; i++) {
        size_t cls[RTO_SIZE_CLASS_MAX], nc = 0;
        uint64_t num;
        rto_msg m = {{0}};
        if (cli_parse_u64(items[i], RTO_MAX_KEYS, &num)) {
            cls[0] = (size_t)num;
            nc = 1;
        } else if (rto_size_class(items[i], cls, &nc, &m)) {
            return cli_fail("suite", "--sizes: '%s' is neither a number nor a size class (tiny, tile, pow2, large, all)",
                            items[i]);
        }
        for (size_t k = 0; k < nc; k++) {
            int dup = 0;
            for (size_t q = 0; q < nsizes; q++)
                dup |= sizes[q] == cls[k];
            if (!dup && nsizes < sizeof sizes / sizeof sizes[0])
                sizes[nsizes++] = cls[k];
        }
    }
    qsort(sizes, nsizes, sizeof *sizes, cmp_size);

    const rto_dist_info *dists[MAX_ITEMS];
    size_t ndists = 0;
    ni = split(dists_buf, items);
    for (size_t i = 0; i < ni; i++) {
        int all = !strcmp(items[i], "all"), cen = !strcmp(items[i], "centroid"), raw = !strcmp(items[i], "raw");
        if (all || cen || raw) {
            for (size_t k = 0; k < rto_dist_count() && ndists < MAX_ITEMS; k++) {
                const rto_dist_info *di = rto_dist_at(k);
                if (all || (cen && di->kind == RTO_DIST_CENTROID) || (raw && di->kind == RTO_DIST_RAW))
                    dists[ndists++] = di;
            }
        } else if (rto_dist_find(items[i])) {
            dists[ndists++] = rto_dist_find(items[i]);
        } else {
            return cli_fail("suite", "--dists: unknown distribution '%s' (rtoracle keys --list)", items[i]);
        }
    }
    rto_key_format formats[2];
    size_t nformats = 0;
    ni = split(formats_buf, items);
    for (size_t i = 0; i < ni; i++)
        if (nformats >= 2 || !cli_parse_format(items[i], &formats[nformats++]))
            return cli_fail("suite", "--formats: '%s' is not u32 or u64 (at most two)", items[i]);
    rto_sort_algo algos[2];
    size_t nalgos = 0;
    ni = split(algos_buf, items);
    for (size_t i = 0; i < ni; i++)
        if (nalgos >= 2 || !cli_parse_algo(items[i], &algos[nalgos++]))
            return cli_fail("suite", "--algos: '%s' is not bitonic or radix (at most two)", items[i]);

    rto_msg msg = {{0}};
    rto_bundle *suite = NULL;
    rto_status s = rto_bundle_begin(out, "suite", &suite, &msg);
    if (s)
        return cli_status("suite", s, &msg);
    rto_bundle_set_str(suite, "", "suite", "sort");
    rto_bundle_set_int(suite, "params", "seed", (int64_t)seed);
    rto_bundle_set_int(suite, "params", "radix_bits", base.radix_bits);
    rto_bundle_set_int(suite, "params", "tile", base.tile);
    rto_bundle_set_int(suite, "params", "checkpoint_max", (int64_t)checkpoint_max);
    size_t cases = 0, skipped = 0;
    void *keys = NULL;
    for (size_t a = 0; a < nalgos && !s; a++) {
        for (size_t fi = 0; fi < nformats && !s; fi++) {
            rto_key_format f = formats[fi];
            const char *fname = f == RTO_KEY_U32 ? "u32" : "u64";
            const char *aname = algos[a] == RTO_SORT_BITONIC ? "bitonic" : "radix";
            for (size_t di = 0; di < ndists && !s; di++) {
                const rto_dist_info *dist = dists[di];
                for (size_t zi = 0; zi < nsizes && !s; zi++) {
                    size_t n = sizes[zi];
                    if ((dist->u64_only && f == RTO_KEY_U32) ||
                        (dist->kind == RTO_DIST_CENTROID && f == RTO_KEY_U32 && n > RTO_TLAS_MAX_INSTANCES)) {
                        skipped++;
                        continue;
                    }
                    free(keys);
                    keys = rto_alloc(n, rto_key_size(f));
                    if (!keys) {
                        s = rto_fail(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu keys", n);
                        break;
                    }
                    s = rto_keys_generate(dist->name, f, (uint32_t)seed, n, keys, &msg);
                    char dir[256], id[256];
                    snprintf(dir, sizeof dir, "%s-%s-%s-n%zu", aname, fname, dist->name, n);
                    snprintf(id, sizeof id, "sort:%s:fmt=%s:dist=%s:n=%zu", aname, fname, dist->name, n);
                    size_t path_len = strlen(rto_bundle_tmpdir(suite)) + strlen(dir) + 2;
                    char *path = malloc(path_len);
                    if (!path) {
                        s = rto_fail(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
                        break;
                    }
                    snprintf(path, path_len, "%s/%s", rto_bundle_tmpdir(suite), dir);
                    sort_params p = base;
                    p.algo = algos[a];
                    p.checkpoints = n > 0 && rto_next_pow2(n) <= checkpoint_max;
                    key_origin origin = {id, dist->name, (uint32_t)seed, NULL};
                    if (!s)
                        s = sort_bundle_write(path, f, keys, n, &p, &origin, &msg);
                    free(path);
                    if (!s)
                        s = rto_bundle_add_case(suite, dir, id, &msg);
                    cases++;
                }
            }
        }
    }
    free(keys);
    if (s) {
        rto_bundle_abort(suite);
        return cli_status("suite", s, &msg);
    }
    rto_bundle_set_int(suite, "stats", "cases", (int64_t)cases);
    rto_bundle_set_int(suite, "stats", "skipped_combinations", (int64_t)skipped);
    s = rto_bundle_commit(suite, &msg);
    if (!s)
        printf("suite sort: %zu cases written to %s (%zu combinations skipped)\n", cases, out, skipped);
    return cli_status("suite", s, &msg);
}
