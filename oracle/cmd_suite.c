/* rtoracle suite sort: the distribution x size x format x algorithm matrix as bundles, the set a GPU harness runs
 * (DESIGN.md §3, §4). One suite directory holds a manifest listing every case and one sort bundle per case. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char suite_usage[] =
    "usage: rtoracle suite sort [--sizes LIST] [--dists LIST] [--formats LIST] [--algos LIST] [--seed S]\n"
    "                           [--radix-bits 4|8] [--tile T] [--checkpoint-max N] [--force] [--no-share]\n"
    "                           -o DIR\n\n"
    "Writes one sort bundle per case into DIR/<algo>-<fmt>-<dist>-n<N>/ and DIR/manifest.json listing\n"
    "them with case ids such as sort:bitonic:fmt=u32:dist=clustered:n=4097. Written atomically.\n"
    "Combinations that do not exist are skipped (digit-4..7 need u64; centroid distributions give TLAS\n"
    "keys of at most 65536 instances in u32).\n"
    "A LIST is comma-separated; a name given twice (or also through all / centroid / raw) makes one case.\n"
    "Sizes run in ascending order, the other lists in the order first given.\n"
    "A DIR that already holds this very suite (same options and rtoracle build, no file changed since) is left\n"
    "as it is, in one line; --force writes it again.\n"
    "An array identical to one an earlier case wrote (bitonic and radix cases of one input share keys.npy and\n"
    "sorted.npy) is a hard link to that file rather than a second copy; --no-share writes every file.\n";

int cmd_suite(int argc, char **argv)
{
    static opt_list sizes_opt, dists_opt, formats_opt, algos_opt;
    const char *out = NULL;
    uint32_t seed = 1;
    uint64_t checkpoint_max = 1024;
    sort_params base = {RTO_SORT_BITONIC, 8, 256, false};
    bool force = false, no_share = false;
    sizes_opt.count = dists_opt.count = formats_opt.count = algos_opt.count = 0;
    const opt_spec opts[] = {
        OPT_LIST("sizes", &sizes_opt, NULL, "size classes (tiny, tile, pow2, large, all) and/or numbers", "all"),
        OPT_LIST("dists", &dists_opt, NULL, "distribution names, or all / centroid / raw", "all"),
        OPT_LIST("formats", &formats_opt, cli_format_names, "key formats", "u32,u64"),
        OPT_LIST("algos", &algos_opt, cli_algo_names, "sorting algorithms", "bitonic,radix"),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "S", "PRNG seed", "1"),
        OPT_CHOICE("radix-bits", &base.radix_bits, cli_radix_bits_names, "B", "radix digit width", "8"),
        OPT_UINT("tile", &base.tile, 1, CLI_TILE_MAX, "T", "radix tile size in keys", "256"),
        OPT_UINT("checkpoint-max", &checkpoint_max, 0, RTO_MAX_KEYS, "N",
                 "write bitonic passes / radix intermediates for cases with n_padded <= N, none for 0", "1024"),
        OPT_FLAG("force", &force, "write the suite even when DIR is up to date"),
        OPT_FLAG("no-share", &no_share, "write every array, none as a hard link to an identical earlier one"),
        OPT_PATH("output", 'o', &out, "DIR", "output directory"),
        OPT_END,
    };
    const opt_command cmd = {"suite", suite_usage, NULL, opts, 1, 1, "a suite: sort"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    if (strcmp(args.arg[0], "sort") != 0)
        return cli_fail("suite", "unknown suite '%s': expected sort (the only suite so far)", args.arg[0]);
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;

    size_t sizes[CLI_SUITE_SIZES_MAX], nsizes = 0, ndists = 0;
    const rto_dist_info *dists[CLI_SUITE_DISTS_MAX];
    if ((rc = cli_suite_sizes(&sizes_opt, sizes, &nsizes)) || (rc = cli_suite_dists(&dists_opt, dists, &ndists)))
        return rc;
    rto_key_format formats[2] = {RTO_KEY_U32, RTO_KEY_U64};
    size_t nformats = formats_opt.count ? formats_opt.count : 2;
    for (size_t i = 0; i < formats_opt.count; i++)
        formats[i] = (rto_key_format)formats_opt.value[i];
    rto_sort_algo algos[2] = {RTO_SORT_BITONIC, RTO_SORT_RADIX};
    size_t nalgos = algos_opt.count ? algos_opt.count : 2;
    for (size_t i = 0; i < algos_opt.count; i++)
        algos[i] = (rto_sort_algo)algos_opt.value[i];

    /* --no-share changes how the files are stored, not what they hold. */
    static const char *const not_inputs[] = {"output", "force", "no-share", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("suite sort", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }
    rto_msg msg = {{0}};
    rto_bundle *suite = NULL;
    rto_bundle_share *share = NULL;
    rto_status s = rto_bundle_begin(out, "suite", &suite, &msg);
    if (!s && !no_share && !(share = rto_bundle_share_create()))
        s = rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    if (!s && request)
        s = rto_bundle_set_request(suite, request, NULL, 0, &msg);
    if (s) {
        rto_bundle_abort(suite);
        free(request);
        rto_bundle_share_destroy(share);
        return cli_status("suite", s, &msg);
    }
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
                    keys = cli_alloc(n, rto_key_size(f));
                    if (!keys) {
                        s = rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu keys", n);
                        break;
                    }
                    s = rto_keys_generate(dist->name, f, seed, n, keys, &msg);
                    char dir[256], id[256];
                    snprintf(dir, sizeof dir, "%s-%s-%s-n%zu", aname, fname, dist->name, n);
                    snprintf(id, sizeof id, "sort:%s:fmt=%s:dist=%s:n=%zu", aname, fname, dist->name, n);
                    size_t path_len = strlen(rto_bundle_tmpdir(suite)) + strlen(dir) + 2;
                    char *path = malloc(path_len);
                    if (!path) {
                        s = rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
                        break;
                    }
                    snprintf(path, path_len, "%s/%s", rto_bundle_tmpdir(suite), dir);
                    sort_params p = base;
                    p.algo = algos[a];
                    p.checkpoints = n > 0 && rto_next_pow2(n) <= checkpoint_max;
                    /* Each case is stamped too: the suite's record covers its cases' records. */
                    char *case_request = request ? malloc(strlen(request) + strlen(id) + 8) : NULL;
                    if (case_request)
                        sprintf(case_request, "%scase %s\n", request, id);
                    key_origin origin = {id, dist->name, seed, NULL, case_request};
                    if (!s)
                        s = sort_bundle_write(path, f, keys, n, &p, &origin, share, &msg);
                    free(path);
                    free(case_request);
                    if (!s)
                        s = rto_bundle_add_case(suite, dir, id, &msg);
                    cases++;
                }
            }
        }
    }
    free(keys);
    free(request);
    rto_bundle_share_destroy(share); /* the cases are committed: their files stay as they are */
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
