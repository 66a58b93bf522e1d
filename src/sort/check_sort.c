/* The sort validator (DESIGN.md §4): a GPU's sorted buffer is correct iff it is sorted, is a permutation of the
 * input, and (for key/value sorts that promise it) is stable. Each failed property is diagnosed as one fault class
 * with the first bad slot, so a report reads "lost-key at slot 4090" rather than "arrays differ". The expected
 * final order comes from the C library's qsort, independent of the oracle's own sorts; only checkpoint passes are
 * compared with the oracle, because they are defined by its schedule. */
#include "internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *rto_fault_name(rto_fault f)
{
    switch (f) {
    case RTO_FAULT_NONE: return "none";
    case RTO_FAULT_SIZE: return "size";
    case RTO_FAULT_LOST: return "lost-key";
    case RTO_FAULT_CORRUPT: return "corrupt-key";
    case RTO_FAULT_DUPLICATE: return "duplicate-key";
    case RTO_FAULT_ORDER: return "order";
    case RTO_FAULT_TAIL: return "tail";
    case RTO_FAULT_VALUE: return "value";
    case RTO_FAULT_STABILITY: return "stability";
    case RTO_FAULT_PASS: return "pass";
    }
    return "unknown";
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

typedef struct keyed {
    uint64_t key;
    uint32_t index;
} keyed;

static int cmp_keyed(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key)
        return (x->key > y->key) - (x->key < y->key);
    return (x->index > y->index) - (x->index < y->index);
}

/* Count of v in the sorted array e[0..n). */
static size_t count_of(const uint64_t *e, size_t n, uint64_t v)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (e[mid] < v)
            lo = mid + 1;
        else
            hi = mid;
    }
    size_t c = 0;
    while (lo + c < n && e[lo + c] == v)
        c++;
    return c;
}

static int hexw(rto_key_format f) { return f == RTO_KEY_U32 ? 8 : 16; }

static void add_diff(rto_sort_report *r, size_t slot, uint64_t expected, uint64_t actual)
{
    if (r->ndiffs < RTO_SORT_MAX_DIFFS) {
        r->diffs[r->ndiffs].slot = slot;
        r->diffs[r->ndiffs].expected = expected;
        r->diffs[r->ndiffs].actual = actual;
        r->ndiffs++;
    }
}

/* The first fault found in priority order becomes the primary one; later ones only set their failed bit. */
static int claim(rto_sort_report *r, rto_fault f, uint32_t bit, size_t slot)
{
    r->failed |= bit;
    if (r->fault != RTO_FAULT_NONE)
        return 0;
    r->fault = f;
    r->first_slot = slot;
    r->ndiffs = 0;
    return 1;
}

/* Compares the GPU's checkpoint passes with the oracle's; fills the pass fields of r. */
static rto_status check_passes(const rto_sort_check_desc *d, rto_sort_report *r, rto_msg *msg)
{
    const rto_key_format f = d->format;
    const size_t ksz = rto_key_size(f), np = rto_next_pow2(d->n);
    uint32_t passes;
    size_t len;
    if (d->algo == RTO_SORT_BITONIC) {
        passes = rto_bitonic_pass_count(np);
        len = np;
    } else {
        passes = rto_radix_pass_count(f, d->radix_bits);
        len = d->n;
        if (!passes || d->radix_tile == 0)
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "radix checkpoints need --radix-bits 4|8 and a tile >= 1");
    }
    r->checked |= RTO_CHECK_PASSES;
    if (d->gpu_pass_count != passes || d->gpu_pass_len != len) {
        if (claim(r, RTO_FAULT_SIZE, RTO_CHECK_PASSES, 0))
            snprintf(r->summary, sizeof r->summary,
                     "size: the checkpoint dump holds %" PRIu32 " passes of %zu keys; the %s oracle has %" PRIu32
                     " passes of %zu",
                     d->gpu_pass_count, d->gpu_pass_len, d->algo == RTO_SORT_BITONIC ? "bitonic" : "radix", passes,
                     len);
        return RTO_OK;
    }
    if (passes == 0 || len == 0)
        return RTO_OK;
    unsigned char *expect = rto_alloc((size_t)passes * len, ksz);
    if (!expect)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %" PRIu32 " checkpoint passes", passes);
    rto_status s;
    if (d->algo == RTO_SORT_BITONIC) {
        void *sorted = rto_alloc(np, ksz);
        s = sorted ? rto_bitonic_sort(f, d->input, d->n, sorted, NULL, expect, msg)
                   : rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        free(sorted);
    } else {
        void *sorted = rto_alloc(d->n, ksz);
        rto_radix_trace tr = {NULL, NULL, NULL, expect, NULL};
        s = sorted ? rto_radix_sort(f, d->input, d->n, d->radix_bits, d->radix_tile, sorted, NULL, &tr, msg)
                   : rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        free(sorted);
    }
    if (s) {
        free(expect);
        return s;
    }
    const unsigned char *gpu = d->gpu_passes;
    for (uint32_t p = 0; p < passes && r->pass < 0; p++) {
        const unsigned char *e = expect + (size_t)p * len * ksz, *g = gpu + (size_t)p * len * ksz;
        if (memcmp(e, g, len * ksz) == 0)
            continue;
        r->pass = p;
        if (d->algo == RTO_SORT_BITONIC)
            rto_bitonic_pass_kj(p, &r->pass_k, &r->pass_j);
        else {
            r->pass_k = p * d->radix_bits;
            r->pass_j = 0;
        }
        size_t first = SIZE_MAX;
        int own = claim(r, RTO_FAULT_PASS, RTO_CHECK_PASSES, 0);
        for (size_t i = 0; i < len; i++) {
            uint64_t ev = rto_key_get(f, e, i), gv = rto_key_get(f, g, i);
            if (ev == gv)
                continue;
            if (first == SIZE_MAX)
                first = i;
            if (own)
                add_diff(r, i, ev, gv);
        }
        if (own) {
            r->first_slot = first;
            if (d->algo == RTO_SORT_BITONIC)
                snprintf(r->summary, sizeof r->summary,
                         "pass: checkpoint pass %" PRIu32 " (k=%" PRIu32 ", j=%" PRIu32
                         ") is the first to diverge, at slot %zu (compare-exchange partner %zu): expected 0x%0*" PRIx64
                         ", got 0x%0*" PRIx64,
                         p, r->pass_k, r->pass_j, first, first ^ (size_t)r->pass_j, hexw(f), rto_key_get(f, e, first),
                         hexw(f), rto_key_get(f, g, first));
            else
                snprintf(r->summary, sizeof r->summary,
                         "pass: radix pass %" PRIu32 " (digit bits %" PRIu32 "..%" PRIu32
                         ") is the first to diverge, at slot %zu (tile %zu): expected 0x%0*" PRIx64 ", got 0x%0*" PRIx64,
                         p, r->pass_k, r->pass_k + d->radix_bits - 1, first, first / d->radix_tile, hexw(f),
                         rto_key_get(f, e, first), hexw(f), rto_key_get(f, g, first));
        } else {
            /* Another fault is primary; keep the slot of the divergence in the summary's tail. */
            size_t used = strlen(r->summary);
            snprintf(r->summary + used, sizeof r->summary - used,
                     "; checkpoints first diverge at pass %" PRIu32 " (k=%" PRIu32 ", j=%" PRIu32 ") slot %zu", p,
                     r->pass_k, r->pass_j, first);
        }
    }
    free(expect);
    return RTO_OK;
}

rto_status rto_sort_check(const rto_sort_check_desc *d, rto_sort_report *r, rto_msg *msg)
{
    if (!d || !r)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL descriptor or report");
    memset(r, 0, sizeof *r);
    r->fault = RTO_FAULT_NONE;
    r->first_slot = SIZE_MAX;
    r->pass = -1;
    const rto_key_format f = d->format;
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    if ((uint64_t)d->n > RTO_MAX_KEYS)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu keys", d->n,
                        (unsigned long long)RTO_MAX_KEYS);
    if ((d->n && !d->input) || (d->gpu_n && !d->gpu_keys) || (d->gpu_pass_count && !d->gpu_passes))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL input, GPU keys or GPU passes");
    const size_t n = d->n, np = rto_next_pow2(n), gn = d->gpu_n;
    const uint64_t sentinel = rto_key_sentinel(f);
    const int w = hexw(f);

    if (gn != n && gn != np) {
        claim(r, RTO_FAULT_SIZE, RTO_CHECK_PERMUTATION, gn < n ? gn : n);
        snprintf(r->summary, sizeof r->summary,
                 "size: the GPU dump holds %zu keys; expected n = %zu or n_padded = %zu", gn, n, np);
        return RTO_ERR_MISMATCH;
    }

    uint64_t *e = rto_alloc(n, sizeof *e), *gs = rto_alloc(n, sizeof *gs);
    keyed *stable = NULL;
    unsigned char *seen = NULL;
    rto_status status = RTO_OK;
    if (!e || !gs) {
        status = rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking %zu keys", n);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        e[i] = rto_key_get(f, d->input, i);
        gs[i] = rto_key_get(f, d->gpu_keys, i);
    }
    qsort(e, n, sizeof *e, cmp_u64);
    qsort(gs, n, sizeof *gs, cmp_u64);
#define G(i) rto_key_get(f, d->gpu_keys, (i))
    r->checked |= RTO_CHECK_SORTED | RTO_CHECK_PERMUTATION;

    /* Multiset: merge the sorted GPU real range against the sorted input. */
    size_t nmissing = 0, nextra = 0;
    uint64_t first_missing = 0, first_extra = 0, extra_sentinels = 0;
    int extra_foreign = 0;
    for (size_t a = 0, b = 0; a < n || b < n;) {
        if (b >= n || (a < n && e[a] < gs[b])) {
            if (!nmissing++)
                first_missing = e[a];
            a++;
        } else if (a >= n || gs[b] < e[a]) {
            if (!nextra++)
                first_extra = gs[b];
            if (gs[b] == sentinel)
                extra_sentinels++;
            else if (!count_of(e, n, gs[b]))
                extra_foreign = 1;
            b++;
        } else {
            a++;
            b++;
        }
    }
    size_t first_diff = SIZE_MAX;
    for (size_t i = 0; i < n && first_diff == SIZE_MAX; i++)
        if (G(i) != e[i])
            first_diff = i;
    if (nextra) {
        rto_fault fault;
        size_t slot = first_diff;
        if (extra_sentinels) {
            fault = RTO_FAULT_LOST;
            snprintf(r->summary, sizeof r->summary,
                     "lost-key: %zu input key(s) missing from the sorted range (first 0x%0*" PRIx64
                     ") and %" PRIu64 " extra sentinel(s) in their place; first bad slot %zu",
                     nmissing, w, first_missing, extra_sentinels, slot);
        } else if (extra_foreign) {
            fault = RTO_FAULT_CORRUPT;
            for (size_t i = 0; i < n; i++)
                if (!count_of(e, n, G(i))) {
                    slot = i;
                    break;
                }
            uint64_t x = G(slot) ^ e[slot];
            int bits = 0;
            for (uint64_t t = x; t; t &= t - 1)
                bits++;
            snprintf(r->summary, sizeof r->summary,
                     "corrupt-key: slot %zu holds 0x%0*" PRIx64 ", which is not in the input; expected 0x%0*" PRIx64
                     " (%d bit%s differ)",
                     slot, w, G(slot), w, e[slot], bits, bits == 1 ? "" : "s");
        } else {
            fault = RTO_FAULT_DUPLICATE;
            snprintf(r->summary, sizeof r->summary,
                     "duplicate-key: key 0x%0*" PRIx64 " appears %zu time(s), the input has it %zu time(s); 0x%0*" PRIx64
                     " is missing; first bad slot %zu",
                     w, first_extra, count_of(gs, n, first_extra), count_of(e, n, first_extra), w, first_missing, slot);
        }
        claim(r, fault, RTO_CHECK_PERMUTATION, slot);
        for (size_t i = 0; i < n; i++)
            if (G(i) != e[i])
                add_diff(r, i, e[i], G(i));
    }
    for (size_t i = 0; i + 1 < n; i++) {
        if (G(i) > G(i + 1)) {
            if (claim(r, RTO_FAULT_ORDER, RTO_CHECK_SORTED, i)) {
                snprintf(r->summary, sizeof r->summary,
                         "order: a permutation of the input but not sorted: slot %zu holds 0x%0*" PRIx64
                         " > slot %zu 0x%0*" PRIx64,
                         i, w, G(i), i + 1, w, G(i + 1));
                for (size_t s = 0; s < n; s++)
                    if (G(s) != e[s])
                        add_diff(r, s, e[s], G(s));
            }
            break;
        }
    }
    if (gn > n) {
        r->checked |= RTO_CHECK_TAIL;
        for (size_t i = n; i < gn; i++) {
            if (G(i) == sentinel)
                continue;
            if (claim(r, RTO_FAULT_TAIL, RTO_CHECK_TAIL, i)) {
                snprintf(r->summary, sizeof r->summary,
                         "tail: padded slot %zu (of %zu) holds 0x%0*" PRIx64 " instead of the sentinel", i, gn, w,
                         G(i));
                for (size_t s = i; s < gn; s++)
                    if (G(s) != sentinel)
                        add_diff(r, s, sentinel, G(s));
            }
            break;
        }
    }

    if (d->gpu_values) {
        /* The stable reference: (key, source index) ordered by qsort; padding p carries n + p. */
        stable = rto_alloc(gn, sizeof *stable);
        seen = calloc(gn ? gn : 1, 1);
        if (!stable || !seen) {
            status = rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking values");
            goto done;
        }
        for (size_t i = 0; i < gn; i++) {
            stable[i].key = i < n ? rto_key_get(f, d->input, i) : sentinel;
            stable[i].index = (uint32_t)i;
        }
        qsort(stable, gn, sizeof *stable, cmp_keyed);
        r->checked |= RTO_CHECK_VALUES;
        for (size_t i = 0; i < gn; i++) {
            uint32_t v = d->gpu_values[i];
            uint64_t src = v < n ? rto_key_get(f, d->input, v) : sentinel;
            const char *why = NULL;
            if ((size_t)v >= gn)
                why = "is out of range";
            else if (seen[v])
                why = "appears twice";
            else if (src != G(i))
                why = "names a source slot holding a different key";
            if (v < gn)
                seen[v] = 1;
            if (!why)
                continue;
            if (claim(r, RTO_FAULT_VALUE, RTO_CHECK_VALUES, i)) {
                r->diffs_are_values = 1;
                snprintf(r->summary, sizeof r->summary,
                         "value: slot %zu carries source index %" PRIu32 ", which %s (key 0x%0*" PRIx64 ")", i, v, why,
                         w, G(i));
                add_diff(r, i, stable[i].index, v);
            }
            break;
        }
        if (d->require_stable) {
            r->checked |= RTO_CHECK_STABLE;
            for (size_t i = 0; i + 1 < gn; i++) {
                if (G(i) != G(i + 1) || d->gpu_values[i] < d->gpu_values[i + 1])
                    continue;
                if (claim(r, RTO_FAULT_STABILITY, RTO_CHECK_STABLE, i)) {
                    r->diffs_are_values = 1;
                    snprintf(r->summary, sizeof r->summary,
                             "stability: slots %zu and %zu hold equal keys 0x%0*" PRIx64
                             " with source indices %" PRIu32 " then %" PRIu32 " (input order reversed)",
                             i, i + 1, w, G(i), d->gpu_values[i], d->gpu_values[i + 1]);
                    for (size_t s = 0; s < gn; s++)
                        if (d->gpu_values[s] != stable[s].index)
                            add_diff(r, s, stable[s].index, d->gpu_values[s]);
                }
                break;
            }
        }
    }
#undef G

    if (d->gpu_passes) {
        status = check_passes(d, r, msg);
        if (status)
            goto done;
    }
    if (r->fault == RTO_FAULT_NONE)
        snprintf(r->summary, sizeof r->summary, "ok: %zu keys sorted, a permutation of the input%s%s", n,
                 (r->checked & RTO_CHECK_STABLE) ? ", stable" : "",
                 (r->checked & RTO_CHECK_PASSES) ? ", every checkpoint pass equal" : "");
    status = r->fault == RTO_FAULT_NONE ? RTO_OK : RTO_ERR_MISMATCH;
done:
    free(e);
    free(gs);
    free(stable);
    free(seen);
    return status;
}
