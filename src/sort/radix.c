/* LSD radix sort reference (DESIGN.md §4): the tiled histogram -> exclusive prefix -> per-tile base -> stable scatter
 * scheme a GPU radix sort runs per digit, with every intermediate exposed so a GPU dump can be compared stage by
 * stage. This is the sort whose scatter race corrupted the TLAS in seeds/001; the reference makes such a race show
 * up as the first pass, tile and digit where a GPU's histogram, base or scatter differs. */
#include "sort_internal.h"

#include <stdlib.h>
#include <string.h>

uint32_t rto_radix_pass_count(rto_key_format f, uint32_t bits)
{
    if (bits != 4 && bits != 8)
        return 0;
    return (uint32_t)(rto_key_size(f) * 8 / bits);
}

size_t rto_radix_tile_count(size_t n, uint32_t tile) { return tile ? (n + tile - 1) / tile : 0; }

rto_status rto_radix_sort(rto_key_format f, const void *keys, size_t n, uint32_t bits, uint32_t tile, void *sorted,
                          uint32_t *perm, const rto_radix_trace *trace, rto_msg *msg)
{
    rto_status st = rto__sort_args_check(f, keys, n, sorted, msg);
    if (st)
        return st;
    if (bits != 4 && bits != 8)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "radix digit width %u: must be 4 or 8", bits);
    if (tile == 0)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "tile size must be at least 1");

    const uint32_t radix = UINT32_C(1) << bits, passes = rto_radix_pass_count(f, bits);
    const size_t tiles = rto_radix_tile_count(n, tile), ksz = rto_key_size(f);
    uint64_t *cur = rto__alloc(n, sizeof *cur), *nxt = rto__alloc(n, sizeof *nxt);
    uint32_t *ci = rto__alloc(n, sizeof *ci), *ni = rto__alloc(n, sizeof *ni);
    uint32_t *hist = rto__alloc((size_t)radix, sizeof *hist), *total = rto__alloc(radix, sizeof *total);
    uint32_t *base = rto__alloc(tiles, (size_t)radix * sizeof *base);
    rto_status s = RTO_OK;
    if (!cur || !nxt || !ci || !ni || !hist || !total || !base) {
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory sorting %zu keys", n);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        cur[i] = rto__key_get(f, keys, i);
        ci[i] = (uint32_t)i;
    }
    for (uint32_t p = 0; p < passes; p++) {
        const uint32_t shift = p * bits;
        const uint64_t mask = radix - 1;
        /* Totals per digit, then the exclusive prefix: the first output slot of each digit. */
        memset(total, 0, radix * sizeof *total);
        for (size_t i = 0; i < n; i++)
            total[(cur[i] >> shift) & mask]++;
        uint32_t prefix_run = 0;
        uint32_t *prefix = trace && trace->prefix ? trace->prefix + (size_t)p * radix : NULL;
        /* base[t][d] starts as prefix[d] and accumulates the earlier tiles' counts. */
        for (uint32_t d = 0; d < radix; d++) {
            if (prefix)
                prefix[d] = prefix_run;
            if (tiles)
                base[d] = prefix_run;
            prefix_run += total[d];
        }
        for (size_t t = 0; t < tiles; t++) {
            size_t lo = t * tile, hi = lo + tile < n ? lo + tile : n;
            memset(hist, 0, radix * sizeof *hist);
            for (size_t i = lo; i < hi; i++)
                hist[(cur[i] >> shift) & mask]++;
            uint32_t *tb = base + t * radix;
            if (t + 1 < tiles)
                for (uint32_t d = 0; d < radix; d++)
                    tb[radix + d] = tb[d] + hist[d];
            if (trace && trace->hist)
                memcpy(trace->hist + ((size_t)p * tiles + t) * radix, hist, radix * sizeof *hist);
            if (trace && trace->base)
                memcpy(trace->base + ((size_t)p * tiles + t) * radix, tb, radix * sizeof *tb);
            /* Stable scatter: keys of one digit keep their order inside the tile, tiles keep theirs. */
            for (size_t i = lo; i < hi; i++) {
                uint32_t d = (uint32_t)((cur[i] >> shift) & mask);
                uint32_t dst = tb[d]++;
                nxt[dst] = cur[i];
                ni[dst] = ci[i];
            }
        }
        uint64_t *tk = cur;
        cur = nxt;
        nxt = tk;
        uint32_t *ti = ci;
        ci = ni;
        ni = ti;
        if (trace && trace->scatter) {
            unsigned char *dst = (unsigned char *)trace->scatter + (size_t)p * n * ksz;
            for (size_t i = 0; i < n; i++)
                rto__key_put(f, dst, i, cur[i]);
        }
        if (trace && trace->perm)
            memcpy(trace->perm + (size_t)p * n, ci, n * sizeof *ci);
    }
    for (size_t i = 0; i < n; i++)
        rto__key_put(f, sorted, i, cur[i]);
    if (perm)
        memcpy(perm, ci, n * sizeof *ci);
done:
    free(cur);
    free(nxt);
    free(ci);
    free(ni);
    free(hist);
    free(total);
    free(base);
    return s;
}
