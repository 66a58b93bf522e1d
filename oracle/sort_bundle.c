/* The sort bundle: input keys, the oracle's sorted keys and permutation, and its checkpoints (bitonic passes or
 * radix intermediates), with a manifest a GPU harness reads (DESIGN.md §4, §8). Shared by `sort` and `suite`. */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

/* Checkpoints larger than this are refused rather than attempted: a bundle is read back whole by harnesses. */
#define CHECKPOINT_BYTES_MAX (UINT64_C(4) << 30)

static rto_status add_common(rto_bundle *b, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                             const key_origin *o, rto_msg *msg)
{
    char buf[160];
    if (o->case_id)
        rto_bundle_set_str(b, "", "case", o->case_id);
    rto_bundle_set_str(b, "input", "file", "keys.npy");
    rto_bundle_set_int(b, "input", "n", (int64_t)n);
    rto_bundle_set_str(b, "input", "format", f == RTO_KEY_U32 ? "u32" : "u64");
    if (o->dist) {
        rto_bundle_set_str(b, "input", "dist", o->dist);
        rto_bundle_set_int(b, "input", "seed", o->seed);
    }
    if (o->file) {
        const char *base = strrchr(o->file, '/');
        rto_bundle_set_str(b, "input", "source", base ? base + 1 : o->file);
    }
    size_t np = rto_next_pow2(n);
    rto_bundle_set_str(b, "params", "algo", p->algo == RTO_SORT_BITONIC ? "bitonic" : "radix");
    rto_bundle_set_int(b, "params", "n_padded", (int64_t)np);
    snprintf(buf, sizeof buf, "0x%" PRIx64, rto_key_sentinel(f));
    rto_bundle_set_str(b, "params", "sentinel", buf);
    if (p->algo == RTO_SORT_BITONIC) {
        rto_bundle_set_int(b, "params", "passes", rto_bitonic_pass_count(np));
    } else {
        rto_bundle_set_int(b, "params", "passes", rto_radix_pass_count(f, p->radix_bits));
        rto_bundle_set_int(b, "params", "radix_bits", p->radix_bits);
        rto_bundle_set_int(b, "params", "tile", p->tile);
        rto_bundle_set_int(b, "params", "tiles", (int64_t)rto_radix_tile_count(n, p->tile));
    }
    rto_bundle_set_str(b, "params", "checkpoints", p->checkpoints ? "yes" : "no");
    rto_npy_desc kd = rto_npy_desc_keys(f, n);
    return rto_bundle_add_npy(b, "keys.npy", "input-keys", NULL, &kd, keys, msg);
}

static rto_status add_result(rto_bundle *b, rto_key_format f, size_t n, const void *sorted, const uint32_t *perm,
                             rto_msg *msg)
{
    rto_npy_desc kd = rto_npy_desc_keys(f, n), pd = rto_npy_desc_array(RTO_DTYPE_U32, 1, n, 0, 0);
    rto_status s = rto_bundle_add_npy(b, "sorted.npy", "sorted-keys", NULL, &kd, sorted, msg);
    return s ? s : rto_bundle_add_npy(b, "perm.npy", "permutation", NULL, &pd, perm, msg);
}

static rto_status write_bitonic(rto_bundle *b, rto_key_format f, const void *keys, size_t n, bool checkpoints,
                                rto_msg *msg)
{
    const size_t np = rto_next_pow2(n), ksz = rto_key_size(f);
    const uint32_t passes = rto_bitonic_pass_count(np);
    if (checkpoints && (uint64_t)passes * np * ksz > CHECKPOINT_BYTES_MAX)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT,
                        "checkpoints for n = %zu would take %.1f GiB (%" PRIu32 " passes of %zu keys); limit 4 GiB", n,
                        (double)passes * (double)np * (double)ksz / (double)(1u << 30), passes, np);
    void *sorted = cli_alloc(np, ksz), *ck = checkpoints ? cli_alloc((size_t)passes * np, ksz) : NULL;
    uint32_t *perm = cli_alloc(np, sizeof *perm);
    uint32_t *table = cli_alloc(passes, 2 * sizeof *table);
    rto_status s = RTO_OK;
    if (!sorted || !perm || !table || (checkpoints && !ck))
        s = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    if (!s)
        s = rto_bitonic_sort(f, keys, n, sorted, perm, ck, msg);
    if (!s)
        s = add_result(b, f, n, sorted, perm, msg);
    if (!s && checkpoints) {
        rto_npy_desc cd = rto_npy_desc_array(f == RTO_KEY_U32 ? RTO_DTYPE_U32 : RTO_DTYPE_U64, 2, passes, np, 0);
        s = rto_bundle_add_npy(b, "passes.npy", "bitonic-passes", NULL, &cd, ck, msg);
        rto_npy_desc td = rto_npy_desc_array(RTO_DTYPE_NONE, 1, passes, 0, 0);
        td.dtype = RTO_DTYPE_STRUCT;
        td.nfields = 2;
        td.fields[0] = (rto_npy_field){"k", RTO_DTYPE_U32, 1, 0};
        td.fields[1] = (rto_npy_field){"j", RTO_DTYPE_U32, 1, 4};
        for (uint32_t i = 0; i < passes; i++)
            rto_bitonic_pass_kj(i, &table[2 * i], &table[2 * i + 1]);
        if (!s)
            s = rto_bundle_add_npy(b, "pass_table.npy", "bitonic-pass-table", "BitonicPass", &td, table, msg);
    }
    free(sorted);
    free(ck);
    free(perm);
    free(table);
    return s;
}

static rto_status write_radix(rto_bundle *b, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                              rto_msg *msg)
{
    const size_t ksz = rto_key_size(f), tiles = rto_radix_tile_count(n, p->tile);
    const uint32_t passes = rto_radix_pass_count(f, p->radix_bits), radix = UINT32_C(1) << p->radix_bits;
    if (!passes || !p->tile)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "radix needs --radix-bits 4 or 8 and --tile >= 1");
    if (p->checkpoints && (uint64_t)passes * (tiles * radix * 8 + n * (ksz + 4)) > CHECKPOINT_BYTES_MAX)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "radix intermediates for n = %zu would exceed 4 GiB", n);
    void *sorted = cli_alloc(n, ksz);
    uint32_t *perm = cli_alloc(n, sizeof *perm);
    rto_radix_trace tr = {NULL, NULL, NULL, NULL, NULL};
    if (p->checkpoints) {
        tr.hist = cli_alloc((size_t)passes * tiles, radix * sizeof *tr.hist);
        tr.prefix = cli_alloc(passes, radix * sizeof *tr.prefix);
        tr.base = cli_alloc((size_t)passes * tiles, radix * sizeof *tr.base);
        tr.scatter = cli_alloc((size_t)passes * n, ksz);
        tr.perm = cli_alloc((size_t)passes * n, sizeof *tr.perm);
    }
    rto_status s = RTO_OK;
    if (!sorted || !perm || (p->checkpoints && (!tr.hist || !tr.prefix || !tr.base || !tr.scatter || !tr.perm)))
        s = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    if (!s)
        s = rto_radix_sort(f, keys, n, p->radix_bits, p->tile, sorted, perm, p->checkpoints ? &tr : NULL, msg);
    if (!s)
        s = add_result(b, f, n, sorted, perm, msg);
    if (!s && p->checkpoints) {
        rto_npy_desc hd = rto_npy_desc_array(RTO_DTYPE_U32, 3, passes, tiles, radix);
        rto_npy_desc pd = rto_npy_desc_array(RTO_DTYPE_U32, 2, passes, radix, 0);
        rto_npy_desc sd = rto_npy_desc_array(f == RTO_KEY_U32 ? RTO_DTYPE_U32 : RTO_DTYPE_U64, 2, passes, n, 0);
        rto_npy_desc qd = rto_npy_desc_array(RTO_DTYPE_U32, 2, passes, n, 0);
        s = rto_bundle_add_npy(b, "radix_hist.npy", "radix-tile-histograms", NULL, &hd, tr.hist, msg);
        if (!s)
            s = rto_bundle_add_npy(b, "radix_prefix.npy", "radix-digit-prefix", NULL, &pd, tr.prefix, msg);
        if (!s)
            s = rto_bundle_add_npy(b, "radix_base.npy", "radix-tile-bases", NULL, &hd, tr.base, msg);
        if (!s)
            s = rto_bundle_add_npy(b, "radix_scatter.npy", "radix-passes", NULL, &sd, tr.scatter, msg);
        if (!s)
            s = rto_bundle_add_npy(b, "radix_perm.npy", "radix-pass-permutations", NULL, &qd, tr.perm, msg);
    }
    free(sorted);
    free(perm);
    free(tr.hist);
    free(tr.prefix);
    free(tr.base);
    free(tr.scatter);
    free(tr.perm);
    return s;
}

rto_status sort_bundle_write(const char *outdir, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                             const key_origin *origin, rto_bundle_share *share, rto_msg *msg)
{
    rto_bundle *b = NULL;
    rto_status s = rto_bundle_begin(outdir, "sort", &b, msg);
    if (s)
        return s;
    rto_bundle_set_share(b, share);
    if (origin->request) {
        const char *src[1] = {origin->file};
        s = rto_bundle_set_request(b, origin->request, src, origin->file ? 1 : 0, msg);
    }
    if (!s)
        s = add_common(b, f, keys, n, p, origin, msg);
    if (!s)
        s = p->algo == RTO_SORT_BITONIC ? write_bitonic(b, f, keys, n, p->checkpoints, msg)
                                        : write_radix(b, f, keys, n, p, msg);
    if (s) {
        rto_bundle_abort(b);
        return s;
    }
    return rto_bundle_commit(b, msg);
}
