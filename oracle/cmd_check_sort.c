/* rtoracle check-sort: validates a GPU's sorted buffer (and its checkpoint passes) against the input keys. */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static const char check_usage[] =
    "usage: rtoracle check-sort --input keys.npy --gpu gpu_sorted.npy [--gpu-values values.npy] [--stable]\n"
    "                           [--expected OUTDIR] [--gpu-passes passes.npy] [--algo bitonic|radix]\n"
    "                           [--radix-bits 4|8] [--tile T] [--threads N] [--json] [--no-artifacts]\n\n"
    "Checks that the GPU's buffer is sorted, is a permutation of the input and (with values) that every\n"
    "value names a source slot holding its key (padding element p carries n + p, which may appear in the\n"
    "first n slots where keys equal the sentinel) and, with --stable, that equal keys keep input order.\n"
    "The dump may hold n keys or all n_padded slots (then the tail must be sentinels). --gpu may also be\n"
    "a structured array with fields 'key' and 'value'. With --gpu-passes (shape passes x slots), names the\n"
    "first checkpoint pass (k, j) and slot where the GPU diverges from the oracle's schedule.\n"
    "--expected OUTDIR takes the input, algorithm, digit width and tile from a sort bundle (its input is\n"
    "verified by sha256); a radix bundle implies --stable when the dump carries values. The dump is compared\n"
    "with the bundle's sorted.npy directly (with --input alone, with the input as a radix partition sorts it,\n"
    "bucket by bucket in cache: --threads workers from 131072 keys), and analysed further only where it\n"
    "differs. The verdict and the report do not depend on --threads.\n";

static const char check_epilog[] =
    "Fault classes: size, lost-key, corrupt-key, duplicate-key, order, tail, value, stability, pass.\n"
    "Exit status: 0 all checks pass, 1 a fault was found, 2 bad usage or input.\n"
    "On a fault the JSON report is also written next to the GPU dump as <gpu>.check-sort.json\n"
    "(--no-artifacts skips it).\n";

typedef struct loaded {
    rto_npy input;
    rto_sort_bundle bundle;
    cli_sort_dump dump;
} loaded;

static void loaded_free(loaded *l)
{
    rto_sort_bundle_free(&l->bundle);
    rto_npy_free(&l->input);
    cli_sort_dump_free(&l->dump);
}

static int load(const char *path, rto_npy *out, const char *what)
{
    rto_msg msg = {{0}};
    if (rto_npy_read(path, out, &msg))
        return cli_fail("check-sort", "%s %s: %s", what, path, msg.text);
    return EXIT_PASS;
}

int cmd_check_sort(int argc, char **argv)
{
    const char *input = NULL, *gpu = NULL, *values = NULL, *expected = NULL, *passes = NULL;
    bool json = false, no_artifacts = false, stable = false, radix_bundle = false;
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.algo = RTO_SORT_BITONIC;
    d.radix_bits = 8;
    d.radix_tile = 256;
    const opt_spec opts[] = {
        OPT_PATH("input", 0, &input, "keys.npy", "the keys the GPU sorted"),
        OPT_PATH("gpu", 0, &gpu, "sorted.npy", "the GPU's sorted buffer (keys, or {key, value} records)"),
        OPT_PATH("gpu-values", 0, &values, "values.npy", "the values the GPU carried with the keys"),
        OPT_FLAG("stable", &stable, "require equal keys to keep input order (needs values)"),
        OPT_PATH("expected", 0, &expected, "OUTDIR", "a sort bundle: input, algorithm, digit width and tile"),
        OPT_PATH("gpu-passes", 0, &passes, "passes.npy", "the GPU's checkpoint passes (passes x slots)"),
        OPT_ENUM("algo", &d.algo, cli_algo_names, "A", "the algorithm the GPU ran", "bitonic"),
        OPT_CHOICE("radix-bits", &d.radix_bits, cli_radix_bits_names, "B", "radix digit width", "8"),
        OPT_UINT("tile", &d.radix_tile, 1, CLI_TILE_MAX, "T", "radix tile size in keys", "256"),
        OPT_UINT("threads", &d.threads, 0, 256, "N", "threads (0: one per CPU); the report is the same", "0"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "do not write the report next to the GPU dump"),
        OPT_END,
    };
    const opt_command cmd = {"check-sort", check_usage, check_epilog, opts, 0, 0, NULL};
    opt_args args;
    int parsed = opts_parse(&cmd, argc, argv, &args);
    if (parsed >= 0)
        return parsed;
    const bool artifacts = !no_artifacts, algo_given = opts_given(&cmd, &args, "algo");
    static const char *const required[] = {"gpu", NULL};
    if ((parsed = opts_require(&cmd, &args, required)))
        return parsed;
    if (!input && !expected)
        return cli_fail("check-sort", "one of --input / --expected is required (rtoracle check-sort --help)");

    loaded l;
    memset(&l, 0, sizeof l);
    rto_msg msg = {{0}};
    int rc = EXIT_PASS;
    const char *case_id = NULL;
    if (expected) {
        rto_sort_bundle *sb = &l.bundle;
        if (rto_sort_bundle_read(expected, sb, &msg)) {
            rc = cli_fail("check-sort", "--expected %s", msg.text);
            goto out;
        }
        if (input) {
            if ((rc = load(input, &l.input, "--input")))
                goto out;
            if (l.input.nbytes != sb->keys.nbytes || l.input.desc.dtype != sb->keys.desc.dtype ||
                (sb->keys.nbytes && memcmp(l.input.data, sb->keys.data, sb->keys.nbytes))) {
                rc = cli_fail("check-sort", "--input %s is not the input of bundle %s", input, expected);
                goto out;
            }
        }
        case_id = sb->case_id;
        if (algo_given)
            fprintf(stderr, "rtoracle check-sort: --algo ignored, the bundle says %s\n",
                    sb->algo == RTO_SORT_BITONIC ? "bitonic" : "radix");
        d.algo = sb->algo;
        d.radix_bits = sb->radix_bits;
        d.radix_tile = sb->radix_tile;
        radix_bundle = sb->algo == RTO_SORT_RADIX;
        d.expected_keys = sb->sorted.data;
    } else if ((rc = load(input, &l.input, "--input"))) {
        goto out;
    }
    const rto_npy *in = l.input.data || !expected ? &l.input : &l.bundle.keys;
    if (rto_npy_as_keys(in, &d.format, &d.n, &msg)) {
        rc = cli_fail("check-sort", "input: %s", msg.text);
        goto out;
    }
    d.input = in->data;
    if ((rc = cli_sort_dump_load(gpu, values, passes, &l.dump, &d)))
        goto out;
    /* An LSD radix sort is stable by construction: hold a GPU's key/value radix output to it. */
    if (radix_bundle && d.gpu_values)
        stable = true;
    if (stable && !d.gpu_values) {
        rc = cli_fail("check-sort", "stability needs the values the GPU carried: --gpu-values or a {key, value} dump");
        goto out;
    }
    d.require_stable = stable;

    rto_report r;
    rto_status s = rto_sort_check(&d, &r, &msg);
    if (s == RTO_ERR_INVALID_ARGUMENT && d.expected_keys && strstr(msg.text, "expected keys")) {
        rc = cli_fail("check-sort", "--expected %s: sorted.npy is not the bundle's input in ascending order", expected);
        goto out;
    }
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-sort", s, &msg);
        goto out;
    }
    snprintf(r.what, sizeof r.what, "%.*s", (int)sizeof r.what - 1, case_id ? case_id : "");
    rc = cli_report("check-sort", &r, json, artifacts, gpu);
out:
    loaded_free(&l);
    return rc;
}
