/* rtoracle keys: sort inputs of a named distribution (DESIGN.md §3). */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char keys_usage[] =
    "usage: rtoracle keys --dist NAME --n N [--seed S] [--format u32|u64] [--memory-budget MiB] -o keys.npy\n"
    "       rtoracle keys --list\n\n"
    "Writes N keys of distribution NAME as a 1-D .npy array (uint32 or uint64, default u32).\n"
    "Centroid distributions give Morton keys of generated centroids: TLAS keys (morton15 << 16 | index,\n"
    "N <= 65536) for u32, BLAS keys (morton30 << 32 | index) for u64. Raw distributions give keys directly.\n"
    "Every key is a pure function of (dist, format, seed, index) through the shared PRNG (DESIGN.md §3).\n"
    "Memory: the keys (4 or 8 bytes each), twice that for sorted and reversed (the C library's sort buffer); a\n"
    "request over the budget (--memory-budget; default half the memory this process may use) is refused at once.\n"
    "Numbers are decimal (a leading zero is still decimal: 010 is ten) or hexadecimal with 0x.\n";

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
    const char *dist = NULL, *out = NULL;
    uint64_t n = 0, budget_mb = 0;
    uint32_t seed = 1;
    rto_key_format f = RTO_KEY_U32;
    bool list = false;
    const opt_spec opts[] = {
        OPT_STRING("dist", &dist, "NAME", "a distribution (see --list)"),
        OPT_UINT("n", &n, 0, RTO_MAX_KEYS, "N", "number of keys", NULL),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "S", "PRNG seed", "1"),
        OPT_ENUM("format", &f, cli_format_names, "F", "key format", "u32"),
        OPT_PATH("output", 'o', &out, "P", "output .npy path (written atomically)"),
        OPT_UINT("memory-budget", &budget_mb, 0, CLI_MEMORY_BUDGET_MAX_MB, "MiB", CLI_MEMORY_BUDGET_HELP, "0"),
        OPT_FLAG("list", &list, "list distributions and size classes"),
        OPT_END,
    };
    const opt_command cmd = {"keys", keys_usage, NULL, opts, 0, 0, NULL};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    if (list) {
        list_dists();
        return EXIT_PASS;
    }
    static const char *const required[] = {"dist", "n", "output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    if (!rto_dist_find(dist))
        return cli_fail("keys", "unknown distribution '%s' (rtoracle keys --list)", dist);
    char what[96];
    snprintf(what, sizeof what, "%llu %s keys of '%s'", (unsigned long long)n, f == RTO_KEY_U32 ? "u32" : "u64", dist);
    if (!cli_within_budget("keys", n * rto_key_size(f) + rto_keys_memory_bound(dist, f, (size_t)n), budget_mb, what))
        return EXIT_BAD_INPUT;
    void *keys = malloc(n ? n * rto_key_size(f) : 1);
    if (!keys)
        return cli_fail("keys", "out of memory for %llu keys", (unsigned long long)n);
    rto_msg msg = {{0}};
    rto_status s = rto_keys_generate(dist, f, seed, (size_t)n, keys, &msg);
    if (!s) {
        rto_npy_desc desc = rto_npy_desc_keys(f, n);
        s = rto_npy_write(out, &desc, keys, &msg);
    }
    free(keys);
    return cli_status("keys", s, &msg);
}
