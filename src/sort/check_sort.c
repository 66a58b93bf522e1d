/* The sort validator (DESIGN.md §4): a GPU's sorted buffer is correct iff it is sorted, is a permutation of the
 * input, and (for key/value sorts that promise it) is stable. Each failed property is diagnosed as one fault class
 * with the first bad slot, so a report reads "lost-key at slot 4090" rather than "arrays differ". The expected
 * final order comes from the C library's qsort, independent of the oracle's own sorts; only checkpoint passes are
 * compared with the oracle, because they are defined by its schedule. */
#include "report_internal.h"
#include "sort_internal.h"

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

/* The first index of e[0..n) (sorted) whose key is >= v (upper = 0) or > v (upper = 1). */
static size_t bound_of(const uint64_t *e, size_t n, uint64_t v, int upper)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (e[mid] < v || (upper && e[mid] == v))
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Count of v in the sorted array e[0..n): two binary searches, so that a dump of many equal keys costs O(log n) per
 * look-up, not O(n). */
static size_t count_of(const uint64_t *e, size_t n, uint64_t v)
{
    return bound_of(e, n, v, 1) - bound_of(e, n, v, 0);
}

static int hexw(rto_key_format f) { return f == RTO_KEY_U32 ? 8 : 16; }

static rto_value key_value(rto_key_format f, uint64_t k)
{
    return f == RTO_KEY_U32 ? rto__val_hex32((uint32_t)k) : rto__val_hex64(k);
}

/* A row of the table: keys compare as bit patterns (diff = xor), carried values as indices (diff = actual -
 * expected). */
static void add_diff(rto_report *r, rto_key_format f, int values, size_t slot, uint64_t expected, uint64_t actual)
{
    rto_report_row *row = rto__report_row_add(r, slot, "");
    if (!row)
        return;
    if (values) {
        row->expected = rto__val_uint(expected);
        row->actual = rto__val_uint(actual);
        row->diff = rto__val_int((int64_t)(actual - expected));
    } else {
        row->expected = key_value(f, expected);
        row->actual = key_value(f, actual);
        row->diff = key_value(f, expected ^ actual);
    }
}

/* The first fault found in priority order becomes the primary one (its table compares keys, or source indices for
 * value and stability faults); later ones only fail their check. */
static int claim(rto_report *r, rto_fault f, const char *check, int values)
{
    rto__report_mark(r, check, RTO_CHECK_FAILED);
    if (!rto__report_claim(r, (int)f, rto_fault_name(f)))
        return 0;
    rto__report_table(r, values ? "source indices" : "keys", "slot");
    return 1;
}

/* Compares the GPU's checkpoint passes with the oracle's; records the first divergent pass. */
static rto_status check_passes(const rto_sort_check_desc *d, rto_report *r, rto_msg *msg)
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
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "radix checkpoints need --radix-bits 4|8 and a tile >= 1");
    }
    rto__report_mark(r, "passes", RTO_CHECK_PASSED);
    rto__report_fact(r, "passes", passes);
    if (d->gpu_pass_count != passes || d->gpu_pass_len != len) {
        if (claim(r, RTO_FAULT_SIZE, "passes", 0))
            rto__report_summary(r,
                               "size: the checkpoint dump holds %" PRIu32 " passes of %zu keys; the %s oracle has "
                               "%" PRIu32 " passes of %zu",
                               d->gpu_pass_count, d->gpu_pass_len, d->algo == RTO_SORT_BITONIC ? "bitonic" : "radix",
                               passes, len);
        return RTO_OK;
    }
    if (passes == 0 || len == 0)
        return RTO_OK;
    unsigned char *expect = rto__alloc((size_t)passes * len, ksz);
    if (!expect)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %" PRIu32 " checkpoint passes", passes);
    rto_status s;
    if (d->algo == RTO_SORT_BITONIC) {
        void *sorted = rto__alloc(np, ksz);
        s = sorted ? rto_bitonic_sort(f, d->input, d->n, sorted, NULL, expect, msg)
                   : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        free(sorted);
    } else {
        void *sorted = rto__alloc(d->n, ksz);
        rto_radix_trace tr = {NULL, NULL, NULL, expect, NULL};
        s = sorted ? rto_radix_sort(f, d->input, d->n, d->radix_bits, d->radix_tile, sorted, NULL, &tr, msg)
                   : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        free(sorted);
    }
    if (s) {
        free(expect);
        return s;
    }
    const unsigned char *gpu = d->gpu_passes;
    for (uint32_t p = 0; p < passes; p++) {
        const unsigned char *e = expect + (size_t)p * len * ksz, *g = gpu + (size_t)p * len * ksz;
        if (memcmp(e, g, len * ksz) == 0)
            continue;
        uint32_t k = p * d->radix_bits, j = 0;
        if (d->algo == RTO_SORT_BITONIC)
            rto_bitonic_pass_kj(p, &k, &j);
        size_t first = SIZE_MAX;
        int own = claim(r, RTO_FAULT_PASS, "passes", 0);
        for (size_t i = 0; i < len; i++) {
            uint64_t ev = rto__key_get(f, e, i), gv = rto__key_get(f, g, i);
            if (ev == gv)
                continue;
            if (first == SIZE_MAX)
                first = i;
            if (own)
                add_diff(r, f, 0, i, ev, gv);
        }
        if (own) {
            rto__report_at(r, "pass", p);
            if (d->algo == RTO_SORT_BITONIC) {
                rto__report_at(r, "k", k);
                rto__report_at(r, "j", j);
                rto__report_at(r, "slot", (int64_t)first);
                rto__report_at(r, "partner", (int64_t)(first ^ (size_t)j));
                rto__report_summary(r,
                                   "pass: checkpoint pass %" PRIu32 " (k=%" PRIu32 ", j=%" PRIu32
                                   ") is the first to diverge, at slot %zu (compare-exchange partner %zu): expected "
                                   "0x%0*" PRIx64 ", got 0x%0*" PRIx64,
                                   p, k, j, first, first ^ (size_t)j, hexw(f), rto__key_get(f, e, first), hexw(f),
                                   rto__key_get(f, g, first));
            } else {
                rto__report_at(r, "digit_bit", k);
                rto__report_at(r, "slot", (int64_t)first);
                rto__report_at(r, "tile", (int64_t)(first / d->radix_tile));
                rto__report_summary(r,
                                   "pass: radix pass %" PRIu32 " (digit bits %" PRIu32 "..%" PRIu32
                                   ") is the first to diverge, at slot %zu (tile %zu): expected 0x%0*" PRIx64
                                   ", got 0x%0*" PRIx64,
                                   p, k, k + d->radix_bits - 1, first, first / d->radix_tile, hexw(f),
                                   rto__key_get(f, e, first), hexw(f), rto__key_get(f, g, first));
            }
        } else {
            /* Another fault is primary; keep where the checkpoints diverge in the summary's tail. */
            if (d->algo == RTO_SORT_BITONIC)
                rto__report_append(r, "; checkpoints first diverge at pass %" PRIu32 " (k=%" PRIu32 ", j=%" PRIu32
                                  ") slot %zu", p, k, j, first);
            else
                rto__report_append(r, "; checkpoints first diverge at radix pass %" PRIu32 " (digit bits %" PRIu32
                                  "..%" PRIu32 ") slot %zu", p, k, k + d->radix_bits - 1, first);
        }
        break;
    }
    free(expect);
    return RTO_OK;
}

static const char *const check_names[] = {"sorted", "permutation", "tail", "values", "stable", "passes"};

/* A multiset hash: the sum (mod 2^64) of a bijective mix of every key, equal for any two orders of the same keys.
 * The mix is splitmix64's finaliser, so that keys differing in a few bits change the sum everywhere. */
static uint64_t multiset_hash(rto_key_format f, const void *keys, size_t n)
{
    uint64_t h = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t z = rto__key_get(f, keys, i);
        z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
        h += z ^ (z >> 31);
    }
    return h;
}

/* Whether keys[0..n) ascend. */
static int ascending(rto_key_format f, const void *keys, size_t n)
{
    if (f == RTO_KEY_U32) {
        const uint32_t *k = keys;
        uint32_t bad = 0;
        for (size_t i = 1; i < n; i++)
            bad |= k[i - 1] > k[i];
        return !bad;
    }
    const uint64_t *k = keys;
    uint32_t bad = 0;
    for (size_t i = 1; i < n; i++)
        bad |= k[i - 1] > k[i];
    return !bad;
}

/* Whether slots [from, to) of the dump all hold the sentinel. */
static int all_sentinel(rto_key_format f, const void *keys, size_t from, size_t to)
{
    uint64_t and_all = ~UINT64_C(0);
    for (size_t i = from; i < to; i++)
        and_all &= rto__key_get(f, keys, i);
    return from >= to || and_all == rto_key_sentinel(f);
}

/* The n keys widened to 64 bits and sorted. The reference sorts with the C library's qsort; the fast path with
 * rto_fast_radix_sort (a sorted array is unique, so both give the same bytes; tests/test_check_sort.c holds them
 * to each other). */
static rto_status sorted_wide(rto_key_format f, const void *keys, size_t n, int reference, uint64_t *out,
                              rto_msg *msg)
{
    if (reference) {
        for (size_t i = 0; i < n; i++)
            out[i] = rto__key_get(f, keys, i);
        qsort(out, n, sizeof *out, cmp_u64);
        return RTO_OK;
    }
    uint64_t *wide = rto__alloc_large(n, sizeof *wide);
    if (!wide)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking %zu keys", n);
    for (size_t i = 0; i < n; i++)
        wide[i] = rto__key_get(f, keys, i);
    rto_status s = rto_fast_radix_sort(RTO_KEY_U64, wide, n, out, msg);
    free(wide);
    return s;
}

/* The stable reference of the values checks: (key, source index) in key order, ties by index; padding p carries
 * n + p. Only its indices appear in a report (the expected column of value and stability faults). */
static keyed *stable_reference(const rto_sort_check_desc *d)
{
    const size_t n = d->n, gn = d->gpu_n;
    keyed *stable = rto__alloc(gn, sizeof *stable);
    if (!stable)
        return NULL;
    for (size_t i = 0; i < gn; i++) {
        stable[i].key = i < n ? rto__key_get(d->format, d->input, i) : rto_key_sentinel(d->format);
        stable[i].index = (uint32_t)i;
    }
    qsort(stable, gn, sizeof *stable, cmp_keyed);
    return stable;
}

/* The validator. The keys' verdict comes first from a direct comparison of the dump with the sorted input (the
 * caller's expected_keys, once shown to be the input in ascending order, in one pass over memory; or, with the input
 * alone, rto__sort_match: the input sorted bucket by bucket by an MSD radix partition and each bucket compared with
 * its slots, in about two passes, on d->threads workers): equal real range and a sentinel tail is a pass. Only when
 * they differ does the full analysis run (the input sorted by rto_fast_radix_sort, multiset merge of the sorted dump
 * against it, order, tail), single-threaded, which names the fault and its first bad slot; it is the only path of the
 * reference (reference = 1: qsort, no comparison), which the tests hold the fast path to report for report. The
 * thread count thus changes neither the verdict nor a byte of the report. */
static rto_status sort_check(const rto_sort_check_desc *d, rto_report *r, rto_msg *msg, int reference)
{
    if (!d || !r)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL descriptor or report");
    rto__report_begin(r, "check-sort");
    for (size_t i = 0; i < sizeof check_names / sizeof check_names[0]; i++)
        rto__report_add_check(r, check_names[i]);
    rto__report_table(r, "keys", "slot");
    snprintf(r->tolerance, sizeof r->tolerance, "exact: keys, carried values and checkpoint passes compare bit for "
             "bit (DESIGN.md §9)");
    const rto_key_format f = d->format;
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    if ((uint64_t)d->n > RTO_MAX_KEYS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu keys", d->n,
                        (unsigned long long)RTO_MAX_KEYS);
    if ((d->n && !d->input) || (d->gpu_n && !d->gpu_keys) || (d->gpu_pass_count && !d->gpu_passes))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL input, GPU keys or GPU passes");
    const size_t n = d->n, np = rto_next_pow2(n), gn = d->gpu_n, ksz = rto_key_size(f);
    /* The expected array decides a pass on its own, so it must be the input sorted: ascending, and the same multiset
     * (by hash: a wrong array is refused unless its hash collides, and a right one is never refused). */
    if (d->expected_keys && !reference && n &&
        (!ascending(f, d->expected_keys, n) ||
         multiset_hash(f, d->expected_keys, n) != multiset_hash(f, d->input, n)))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "the expected keys are not the input keys in ascending order");
    const uint64_t sentinel = rto_key_sentinel(f);
    const int w = hexw(f);
    snprintf(r->context, sizeof r->context, "%zu keys (%s), GPU dump of %zu slots (n_padded %zu)", n,
             f == RTO_KEY_U32 ? "u32" : "u64", gn, np);
    rto__report_fact(r, "n", (int64_t)n);
    rto__report_fact(r, "n_padded", (int64_t)np);
    rto__report_fact(r, "gpu_n", (int64_t)gn);

    if (gn != n && gn != np) {
        claim(r, RTO_FAULT_SIZE, "permutation", 0);
        rto__report_at(r, "slot", (int64_t)(gn < n ? gn : n));
        rto__report_summary(r, "size: the GPU dump holds %zu keys; expected n = %zu or n_padded = %zu", gn, n, np);
        return RTO_ERR_MISMATCH;
    }

    uint64_t *e = NULL, *gs = NULL;
    void *own_sorted = NULL;
    keyed *stable = NULL;
    unsigned char *seen = NULL;
    rto_status status = RTO_OK;
#define G(i) rto__key_get(f, d->gpu_keys, (i))
    rto__report_mark(r, "sorted", RTO_CHECK_PASSED);
    rto__report_mark(r, "permutation", RTO_CHECK_PASSED);

    /* The fast verdict: the real range equals the sorted input bit for bit (compared with expected_keys, or matched
     * bucket by bucket as rto__sort_match sorts the input), the tail is sentinels. */
    const void *expect = reference ? NULL : d->expected_keys;
    int keys_equal = 0;
    if (!reference) {
        int match = 1;
        if (expect)
            match = n == 0 || memcmp(d->gpu_keys, expect, n * ksz) == 0;
        else if ((match = rto__sort_match(f, d->input, n, d->gpu_keys, NULL, d->threads)) < 0) {
            status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking %zu keys", n);
            goto done;
        }
        keys_equal = match && all_sentinel(f, d->gpu_keys, n, gn);
    }
    if (!reference && !keys_equal && !expect && n) { /* the full analysis needs the sorted input */
        own_sorted = rto__alloc_large(n, ksz);
        if (!own_sorted) {
            status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking %zu keys", n);
            goto done;
        }
        if ((status = rto_fast_radix_sort(f, d->input, n, own_sorted, msg)))
            goto done;
        expect = own_sorted;
    }
    if (keys_equal) {
        if (gn > n)
            rto__report_mark(r, "tail", RTO_CHECK_PASSED);
        goto values;
    }

    e = rto__alloc_large(n, sizeof *e);
    gs = rto__alloc_large(n, sizeof *gs);
    if (!e || !gs) {
        status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking %zu keys", n);
        goto done;
    }
    if (expect) {
        for (size_t i = 0; i < n; i++)
            e[i] = rto__key_get(f, expect, i);
    } else if ((status = sorted_wide(f, d->input, n, reference, e, msg))) {
        goto done;
    }
    if ((status = sorted_wide(f, d->gpu_keys, n, reference, gs, msg)))
        goto done;

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
        rto_fault fault = extra_sentinels ? RTO_FAULT_LOST : extra_foreign ? RTO_FAULT_CORRUPT : RTO_FAULT_DUPLICATE;
        size_t slot = first_diff;
        if (fault == RTO_FAULT_CORRUPT)
            for (size_t i = 0; i < n; i++)
                if (!count_of(e, n, G(i))) {
                    slot = i;
                    break;
                }
        claim(r, fault, "permutation", 0);
        rto__report_at(r, "slot", (int64_t)slot);
        if (fault == RTO_FAULT_LOST) {
            rto__report_summary(r,
                               "lost-key: %zu input key(s) missing from the sorted range (first 0x%0*" PRIx64
                               ") and %" PRIu64 " extra sentinel(s) in their place; first bad slot %zu",
                               nmissing, w, first_missing, extra_sentinels, slot);
        } else if (fault == RTO_FAULT_CORRUPT) {
            uint64_t x = G(slot) ^ e[slot];
            int bits = 0;
            for (uint64_t t = x; t; t &= t - 1)
                bits++;
            rto__report_summary(r,
                               "corrupt-key: slot %zu holds 0x%0*" PRIx64 ", which is not in the input; expected "
                               "0x%0*" PRIx64 " (%d bit%s differ)",
                               slot, w, G(slot), w, e[slot], bits, bits == 1 ? "" : "s");
        } else {
            rto__report_summary(r,
                               "duplicate-key: key 0x%0*" PRIx64 " appears %zu time(s), the input has it %zu time(s); "
                               "0x%0*" PRIx64 " is missing; first bad slot %zu",
                               w, first_extra, count_of(gs, n, first_extra), count_of(e, n, first_extra), w,
                               first_missing, slot);
        }
        for (size_t i = 0; i < n; i++)
            if (G(i) != e[i])
                add_diff(r, f, 0, i, e[i], G(i));
    }
    for (size_t i = 0; i + 1 < n; i++) {
        if (G(i) > G(i + 1)) {
            if (claim(r, RTO_FAULT_ORDER, "sorted", 0)) {
                rto__report_at(r, "slot", (int64_t)i);
                rto__report_summary(r,
                                   "order: a permutation of the input but not sorted: slot %zu holds 0x%0*" PRIx64
                                   " > slot %zu 0x%0*" PRIx64,
                                   i, w, G(i), i + 1, w, G(i + 1));
                for (size_t s = 0; s < n; s++)
                    if (G(s) != e[s])
                        add_diff(r, f, 0, s, e[s], G(s));
            }
            break;
        }
    }
    if (gn > n) {
        rto__report_mark(r, "tail", RTO_CHECK_PASSED);
        for (size_t i = n; i < gn; i++) {
            if (G(i) == sentinel)
                continue;
            if (claim(r, RTO_FAULT_TAIL, "tail", 0)) {
                rto__report_at(r, "slot", (int64_t)i);
                rto__report_summary(r, "tail: padded slot %zu (of %zu) holds 0x%0*" PRIx64 " instead of the sentinel", i,
                                   gn, w, G(i));
                for (size_t s = i; s < gn; s++)
                    if (G(s) != sentinel)
                        add_diff(r, f, 0, s, sentinel, G(s));
            }
            break;
        }
    }

values:
    if (d->gpu_values) {
        /* Each value must name a distinct source slot holding its key; the stable reference (made only for a
         * report's table) is (key, source index) ordered by qsort; padding p carries n + p. A dump of n slots may hold
         * such padding values too: where real keys equal the sentinel, a padding sentinel can overtake them in the
         * network (docs/sort.md), so every value below n_padded names a source. */
        seen = calloc(np ? np : 1, 1);
        if (!seen) {
            status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking values");
            goto done;
        }
        rto__report_mark(r, "values", RTO_CHECK_PASSED);
        for (size_t i = 0; i < gn; i++) {
            /* The source keys are read in the dump's order, all over the input: ask for them ahead of use. */
            if (i + 16 < gn && d->gpu_values[i + 16] < n)
                __builtin_prefetch((const unsigned char *)d->input + (size_t)d->gpu_values[i + 16] * ksz);
            uint32_t v = d->gpu_values[i];
            uint64_t src = v < n ? rto__key_get(f, d->input, v) : sentinel;
            const char *why = NULL;
            if ((size_t)v >= np)
                why = "is out of range";
            else if (seen[v])
                why = "appears twice";
            else if (src != G(i))
                why = "names a source slot holding a different key";
            if (v < np)
                seen[v] = 1;
            if (!why)
                continue;
            if (claim(r, RTO_FAULT_VALUE, "values", 1)) {
                if (!(stable = stable_reference(d))) {
                    status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking values");
                    goto done;
                }
                rto__report_at(r, "slot", (int64_t)i);
                rto__report_summary(r, "value: slot %zu carries source index %" PRIu32 ", which %s (key 0x%0*" PRIx64
                                   ")", i, v, why, w, G(i));
                add_diff(r, f, 1, i, stable[i].index, v);
            }
            break;
        }
        if (d->require_stable) {
            rto__report_mark(r, "stable", RTO_CHECK_PASSED);
            for (size_t i = 0; i + 1 < gn; i++) {
                if (G(i) != G(i + 1) || d->gpu_values[i] < d->gpu_values[i + 1])
                    continue;
                if (claim(r, RTO_FAULT_STABILITY, "stable", 1)) {
                    if (!stable && !(stable = stable_reference(d))) {
                        status = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory checking values");
                        goto done;
                    }
                    rto__report_at(r, "slot", (int64_t)i);
                    rto__report_summary(r,
                                       "stability: slots %zu and %zu hold equal keys 0x%0*" PRIx64
                                       " with source indices %" PRIu32 " then %" PRIu32 " (input order reversed)",
                                       i, i + 1, w, G(i), d->gpu_values[i], d->gpu_values[i + 1]);
                    for (size_t s = 0; s < gn; s++)
                        if (d->gpu_values[s] != stable[s].index)
                            add_diff(r, f, 1, s, stable[s].index, d->gpu_values[s]);
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
    if (r->code == RTO_FAULT_NONE)
        rto__report_summary(r, "ok: %zu keys sorted, a permutation of the input%s%s", n,
                           rto_report_check_state(r, "stable") == RTO_CHECK_PASSED ? ", stable" : "",
                           rto_report_check_state(r, "passes") == RTO_CHECK_PASSED ? ", every checkpoint pass equal"
                                                                                    : "");
    status = r->code == RTO_FAULT_NONE ? RTO_OK : RTO_ERR_MISMATCH;
done:
    free(own_sorted);
    free(e);
    free(gs);
    free(stable);
    free(seen);
    return status;
}

rto_status rto_sort_check(const rto_sort_check_desc *d, rto_report *r, rto_msg *msg)
{
    return sort_check(d, r, msg, 0);
}

rto_status rto__sort_check_reference(const rto_sort_check_desc *d, rto_report *r, rto_msg *msg)
{
    return sort_check(d, r, msg, 1);
}
