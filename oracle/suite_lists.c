/* The lists of rtoracle suite sort (--sizes, --dists) resolved into the cases' sizes and distributions. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* Appends d to dists unless already there: a distribution named twice is one case. */
static void add_dist(const rto_dist_info **dists, size_t *n, const rto_dist_info *d)
{
    for (size_t i = 0; i < *n; i++)
        if (dists[i] == d)
            return;
    if (*n < CLI_SUITE_DISTS_MAX)
        dists[(*n)++] = d;
}

int cli_suite_sizes(const opt_list *sizes_opt, size_t sizes[CLI_SUITE_SIZES_MAX], size_t *count)
{
    size_t nsizes = 0;
    static const char *const all[] = {"all"};
    const char *const *size_items = sizes_opt->count ? sizes_opt->item : all;
    size_t nsize_items = sizes_opt->count ? sizes_opt->count : 1;
    for (size_t i = 0; i < nsize_items; i++) {
        size_t cls[RTO_SIZE_CLASS_MAX], nc = 0;
        uint64_t num;
        rto_msg m = {{0}};
        if (opts_parse_uint(size_items[i], RTO_MAX_KEYS, &num)) {
            cls[0] = (size_t)num;
            nc = 1;
        } else if (rto_size_class(size_items[i], cls, &nc, &m)) {
            return cli_fail("suite", "--sizes %s: expected a size class (tiny, tile, pow2, large, all) or an integer "
                            "0 .. %llu", size_items[i], (unsigned long long)RTO_MAX_KEYS);
        }
        for (size_t k = 0; k < nc; k++) {
            int dup = 0;
            for (size_t q = 0; q < nsizes; q++)
                dup |= sizes[q] == cls[k];
            if (!dup && nsizes < CLI_SUITE_SIZES_MAX)
                sizes[nsizes++] = cls[k];
        }
    }
    qsort(sizes, nsizes, sizeof *sizes, cmp_size);
    *count = nsizes;
    return EXIT_PASS;
}

int cli_suite_dists(const opt_list *dists_opt, const rto_dist_info *dists[CLI_SUITE_DISTS_MAX], size_t *count)
{
    static const char *const all[] = {"all"};
    size_t ndists = 0;
    /* Distributions in the order first named; a group adds its members not named before. */
    const char *const *dist_items = dists_opt->count ? dists_opt->item : all;
    size_t ndist_items = dists_opt->count ? dists_opt->count : 1;
    for (size_t i = 0; i < ndist_items; i++) {
        const char *item = dist_items[i];
        int every = !strcmp(item, "all"), cen = !strcmp(item, "centroid"), raw = !strcmp(item, "raw");
        if (every || cen || raw) {
            for (size_t k = 0; k < rto_dist_count(); k++) {
                const rto_dist_info *di = rto_dist_at(k);
                if (every || (cen && di->kind == RTO_DIST_CENTROID) || (raw && di->kind == RTO_DIST_RAW))
                    add_dist(dists, &ndists, di);
            }
        } else if (rto_dist_find(item)) {
            add_dist(dists, &ndists, rto_dist_find(item));
        } else {
            return cli_fail("suite", "--dists %s: unknown distribution (rtoracle keys --list)", item);
        }
    }
    *count = ndists;
    return EXIT_PASS;
}
