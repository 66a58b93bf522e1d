/* The sort bundle: input keys, the oracle's sorted keys and permutation, and its checkpoints (bitonic passes or
 * radix intermediates), with a manifest a GPU harness reads (DESIGN.md §4, §8); and the same bundle read back for
 * check-sort, every array checked against the manifest first. */
#include "io/bundle_in.h"
#include "sort_internal.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

/* Checkpoints larger than this are refused rather than attempted: a bundle is read back whole by harnesses. */
#define CHECKPOINT_BYTES_MAX (UINT64_C(4) << 30)

static rto_status add_common(rto_bundle *b, const rto_sort_bundle_desc *p, rto_msg *msg)
{
    const rto_key_format f = p->format;
    const size_t n = p->n;
    char buf[160];
    if (p->case_id)
        rto_bundle_set_str(b, "", "case", p->case_id);
    rto_bundle_set_str(b, "input", "file", "keys.npy");
    rto_bundle_set_int(b, "input", "n", (int64_t)n);
    rto_bundle_set_str(b, "input", "format", f == RTO_KEY_U32 ? "u32" : "u64");
    if (p->dist) {
        rto_bundle_set_str(b, "input", "dist", p->dist);
        rto_bundle_set_int(b, "input", "seed", p->seed);
    }
    if (p->source) {
        const char *base = strrchr(p->source, '/');
        rto_bundle_set_str(b, "input", "source", base ? base + 1 : p->source);
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
        rto_bundle_set_int(b, "params", "tile", p->radix_tile);
        rto_bundle_set_int(b, "params", "tiles", (int64_t)rto_radix_tile_count(n, p->radix_tile));
    }
    rto_bundle_set_str(b, "params", "checkpoints", p->checkpoints ? "yes" : "no");
    rto_npy_desc kd = rto_npy_desc_keys(f, n);
    return rto_bundle_add_npy(b, "keys.npy", "input-keys", NULL, &kd, p->keys, msg);
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
    void *sorted = rto__alloc(np, ksz), *ck = checkpoints ? rto__alloc((size_t)passes * np, ksz) : NULL;
    uint32_t *perm = rto__alloc(np, sizeof *perm);
    uint32_t *table = rto__alloc(passes, 2 * sizeof *table);
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

static rto_status write_radix(rto_bundle *b, rto_key_format f, const void *keys, size_t n,
                              const rto_sort_bundle_desc *p, rto_msg *msg)
{
    const size_t ksz = rto_key_size(f), tiles = rto_radix_tile_count(n, p->radix_tile);
    const uint32_t passes = rto_radix_pass_count(f, p->radix_bits), radix = UINT32_C(1) << p->radix_bits;
    if (!passes || !p->radix_tile)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "radix needs --radix-bits 4 or 8 and --tile >= 1");
    if (p->checkpoints && (uint64_t)passes * (tiles * radix * 8 + n * (ksz + 4)) > CHECKPOINT_BYTES_MAX)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "radix intermediates for n = %zu would exceed 4 GiB", n);
    void *sorted = rto__alloc(n, ksz);
    uint32_t *perm = rto__alloc(n, sizeof *perm);
    rto_radix_trace tr = {NULL, NULL, NULL, NULL, NULL};
    if (p->checkpoints) {
        tr.hist = rto__alloc((size_t)passes * tiles, radix * sizeof *tr.hist);
        tr.prefix = rto__alloc(passes, radix * sizeof *tr.prefix);
        tr.base = rto__alloc((size_t)passes * tiles, radix * sizeof *tr.base);
        tr.scatter = rto__alloc((size_t)passes * n, ksz);
        tr.perm = rto__alloc((size_t)passes * n, sizeof *tr.perm);
    }
    rto_status s = RTO_OK;
    if (!sorted || !perm || (p->checkpoints && (!tr.hist || !tr.prefix || !tr.base || !tr.scatter || !tr.perm)))
        s = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
    if (!s)
        s = rto_radix_sort(f, keys, n, p->radix_bits, p->radix_tile, sorted, perm, p->checkpoints ? &tr : NULL, msg);
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

rto_status rto_sort_bundle_write(const rto_sort_bundle_desc *desc, rto_bundle *b, rto_msg *msg)
{
    if (!desc || !b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL sort bundle description or bundle");
    rto_status s = rto__sort_args_check(desc->format, desc->keys, desc->n, desc->keys, msg);
    if (!s && desc->algo != RTO_SORT_BITONIC && desc->algo != RTO_SORT_RADIX)
        s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown sort algorithm %d", (int)desc->algo);
    if (!s)
        s = add_common(b, desc, msg);
    if (!s)
        s = desc->algo == RTO_SORT_BITONIC ? write_bitonic(b, desc->format, desc->keys, desc->n, desc->checkpoints, msg)
                                           : write_radix(b, desc->format, desc->keys, desc->n, desc, msg);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Reading it back                                                                                                  */

void rto_sort_bundle_free(rto_sort_bundle *sb)
{
    if (!sb)
        return;
    rto_npy_free(&sb->keys);
    rto_npy_free(&sb->sorted);
    memset(sb, 0, sizeof *sb);
}

/* The input is read like a GPU dump: its dtype and shape must be what the manifest states (input.format, input.n),
 * and the padded size must follow from them, so nothing later indexes past what was read. */
static rto_status read_input(const rto__bundle_in *in, rto_sort_bundle *sb)
{
    const char *fmt = rto_bundle_get_str(in->r, "input", "format");
    const char *file = rto_bundle_get_str(in->r, "input", "file");
    int64_t n = -1, np = -1;
    char got[96];
    file = file ? file : "keys.npy";
    if (!fmt || (strcmp(fmt, "u32") && strcmp(fmt, "u64")))
        return rto__fail(in->msg, RTO_ERR_PARSE, "%s: manifest input.format is %s%s%s, not u32 or u64", in->dir,
                         fmt ? "'" : "", fmt ? fmt : "missing", fmt ? "'" : "");
    sb->format = strcmp(fmt, "u32") ? RTO_KEY_U64 : RTO_KEY_U32;
    if (!rto_bundle_get_int(in->r, "input", "n", &n) || n < 0 || (uint64_t)n > RTO_MAX_KEYS)
        return rto__fail(in->msg, RTO_ERR_PARSE, "%s: manifest input.n is missing or outside 0 .. %llu", in->dir,
                         (unsigned long long)RTO_MAX_KEYS);
    rto_msg why = {{0}};
    rto_status s = rto_bundle_read_role(in->r, "input-keys", &sb->keys, &why);
    if (s)
        return rto__fail(in->msg, s, "%s", why.text);
    rto_npy_desc want = rto_npy_desc_keys(sb->format, (uint64_t)n);
    if (!rto_npy_desc_equal(&sb->keys.desc, &want))
        return rto__fail(in->msg, RTO_ERR_PARSE, "%s: %s: holds %s; the manifest says %lld %s keys", in->dir, file,
                         rto_npy_desc_text(&sb->keys.desc, NULL, got, sizeof got), (long long)n, fmt);
    if (!rto_bundle_get_int(in->r, "params", "n_padded", &np) || (uint64_t)np != rto_next_pow2((size_t)n))
        return rto__fail(in->msg, RTO_ERR_PARSE,
                         "%s: manifest params.n_padded is %lld, not the next power of two of input.n %lld", in->dir,
                         (long long)np, (long long)n);
    sb->n = (size_t)n;
    sb->n_padded = (size_t)np;
    return RTO_OK;
}

/* params: the algorithm, a radix bundle's digit width and tile, and the pass count of that schedule. */
static rto_status read_params(const rto__bundle_in *in, rto_sort_bundle *sb)
{
    const char *algo = rto_bundle_get_str(in->r, "params", "algo");
    int64_t bits = 0, tile = 0, passes = -1;
    if (!algo || (strcmp(algo, "bitonic") && strcmp(algo, "radix")))
        return rto__fail(in->msg, RTO_ERR_PARSE, "%s: not a sort bundle (params.algo missing)", in->dir);
    sb->algo = strcmp(algo, "bitonic") ? RTO_SORT_RADIX : RTO_SORT_BITONIC;
    sb->radix_bits = 8;
    sb->radix_tile = 256;
    if (sb->algo == RTO_SORT_RADIX) {
        if (!rto_bundle_get_int(in->r, "params", "radix_bits", &bits) ||
            !rto_bundle_get_int(in->r, "params", "tile", &tile) || (bits != 4 && bits != 8) || tile < 1 ||
            tile > (1 << 24))
            return rto__fail(in->msg, RTO_ERR_PARSE, "%s: radix bundle without valid radix_bits / tile", in->dir);
        sb->radix_bits = (uint32_t)bits;
        sb->radix_tile = (uint32_t)tile;
    }
    const uint32_t want = sb->algo == RTO_SORT_BITONIC ? rto_bitonic_pass_count(sb->n_padded)
                                                        : rto_radix_pass_count(sb->format, sb->radix_bits);
    if (!rto_bundle_get_int(in->r, "params", "passes", &passes) || passes != (int64_t)want)
        return rto__fail(in->msg, RTO_ERR_PARSE, "%s: manifest params.passes is %lld; %s over %zu keys has %u",
                         in->dir, (long long)passes,
                         sb->algo == RTO_SORT_BITONIC ? "the bitonic network" : "the radix sort", sb->n, want);
    sb->passes = want;
    return RTO_OK;
}

rto_status rto_sort_bundle_read(const char *dir, rto_sort_bundle *sb, rto_msg *msg)
{
    if (!sb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL sort bundle");
    memset(sb, 0, sizeof *sb);
    rto__bundle_in in;
    rto_status s = rto__bundle_in_open(&in, dir, NULL, NULL, msg);
    if (!s)
        s = read_input(&in, sb);
    /* The bundle's sorted keys let a check compare a dump with them directly. A bundle without them is checked from
     * its input alone; one whose sorted.npy is listed but changed or malformed is refused. */
    if (!s) {
        rto_msg why = {{0}};
        rto_status ss = rto_bundle_read_role(in.r, "sorted-keys", &sb->sorted, &why);
        if (ss == RTO_OK) {
            rto_npy_desc want = rto_npy_desc_keys(sb->format, sb->n);
            char got[96];
            if (!rto_npy_desc_equal(&sb->sorted.desc, &want))
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: sorted.npy holds %s; the input holds %s", dir,
                              rto_npy_desc_text(&sb->sorted.desc, NULL, got, sizeof got),
                              sb->format == RTO_KEY_U32 ? "u32" : "u64");
        } else if (ss != RTO_ERR_IO) {
            s = rto__fail(msg, ss, "%s", why.text);
        }
    }
    if (!s) {
        const char *id = rto_bundle_get_str(in.r, "", "case");
        snprintf(sb->case_id, sizeof sb->case_id, "%s", id ? id : "");
        s = read_params(&in, sb);
    }
    rto__bundle_in_close(&in);
    if (s)
        rto_sort_bundle_free(sb);
    return s;
}
