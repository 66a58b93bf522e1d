/* check-sort's fast verdict (DESIGN.md §4): whether the input keys, once sorted, equal the GPU's dump bit for bit,
 * found without writing the sorted input out and comparing it afterwards. An MSD radix partition does it in about
 * two passes over memory where an LSD sort of 64-bit keys takes six:
 *   - the keys are counted and scattered once by their top digit; bucket d then holds exactly the keys of slots
 *     [start_d, start_d + count_d) of the sorted array;
 *   - each bucket is partitioned again by its next digit, in cache, until every bucket holds a few keys; an insertion
 *     sort then orders the range (O(keys) when no bucket is long) and it is compared with its slots of the dump.
 * The digit of a slot range comes from the dump's first and last key of that range: if the dump is right, every key
 * of the range shares their common prefix, and the digit is the bits just below it. Every key is checked to share that
 * prefix; a key that does not, or a run that differs from its slots, gives the verdict "differs" (the caller then
 * analyses the dump in full). A wrong dump can only choose poor digits, never pass: the buckets are in key order
 * because every key of a range shares the bits above its digit, so the runs, concatenated, are the sorted input.
 * With no dump the same partition sorts into an output array instead (the digits then come from the keys' own
 * differing bits): what the tests hold to qsort.
 * For a team (rto__team_run), the top digit's counting and scattering split the input into static ranges, one per
 * worker, and each worker then takes the buckets whose first slot falls in its range; the verdict is the AND of the
 * workers', the same for every thread count. */
#include "sort_internal.h"

#include <stdlib.h>
#include <string.h>

#define MAX_BITS 11u                 /* widest digit: 2048 counters, within L1 */
#define ROOT_BITS 16u                /* widest top digit of a small input on one thread */
#define LEAF 24u                     /* runs this short are insertion-sorted */
#define FEW 16u                      /* buckets of at most this many keys: their whole range is insertion-sorted */
#define LOCAL_KEYS 4096u             /* a top bucket up to this size is partitioned in the worker's own scratch */
#define PATH_COUNTERS (6u << MAX_BITS) /* counters along one path of nested digits (widths add up to <= 64 bits) */


/* The top digit's width: alone and below RTO__SORT_MATCH_TEAM_FROM keys, up to ROOT_BITS (the keys and counters
 * stay in L2, and one digit leaves buckets of about two keys); for a team, or more keys, digit_bits. */
static uint32_t digit_bits(size_t m);
static uint32_t root_bits(size_t n, uint32_t workers)
{
    const uint32_t b = rto__bitlen64((uint64_t)n);
    if (workers > 1 || n >= RTO__SORT_MATCH_TEAM_FROM)
        return digit_bits(n);
    return b - 1 > ROOT_BITS ? ROOT_BITS : b - 1;
}

/* Digit width for m keys: about one key per two buckets, at most MAX_BITS. */
static uint32_t digit_bits(size_t m)
{
    const uint32_t b = rto__bitlen64((uint64_t)m);
    return b <= 2 ? 1u : b > MAX_BITS ? MAX_BITS : b;
}

typedef struct worker {
    const void *want; /* the dump's n keys, or NULL: sort into out */
    void *out;
    void *local;       /* LOCAL_KEYS keys */
    uint32_t *counts;  /* PATH_COUNTERS, used as a stack along the path */
    uint32_t used;
    int state; /* 0 equal so far, 1 differs, -1 out of memory */
} worker;

typedef struct match {
    rto_key_format f;
    const void *keys, *want;
    void *out;
    size_t n;
    void *a;         /* n keys: the top buckets */
    uint32_t *hist;  /* [worker][1 << MAX_BITS] */
    uint64_t *diff;  /* [worker]: sorting, the keys' differing bits */
    int *state;      /* [worker]: the top level's checks, read by every worker after a sync */
    int *verdict;    /* [worker]: the final state (apart from state: a worker may finish while others still read it) */
} match;

#define DEFINE_MATCH(KEY, NAME, BITS)                                                                                  \
    /* A sorted run of keys for slots [off, off + m): compared with the dump, or written out. */                    \
    static void emit_##NAME(worker *s, const KEY *k, size_t m, size_t off)                                             \
    {                                                                                                                  \
        if (m == 0)                                                                                                    \
            return;                                                                                                    \
        if (s->want) {                                                                                                 \
            if (memcmp(k, (const KEY *)s->want + off, m * sizeof *k))                                                  \
                s->state = 1;                                                                                          \
        } else {                                                                                                       \
            memcpy((KEY *)s->out + off, k, m * sizeof *k);                                                             \
        }                                                                                                              \
    }                                                                                                                  \
                                                                                                                       \
    static void small_sort_##NAME(KEY *k, size_t m)                                                                    \
    {                                                                                                                  \
        for (size_t i = 1; i < m; i++) {                                                                               \
            const KEY v = k[i];                                                                                        \
            size_t j = i;                                                                                              \
            for (; j > 0 && k[j - 1] > v; j--)                                                                         \
                k[j] = k[j - 1];                                                                                       \
            k[j] = v;                                                                                                  \
        }                                                                                                              \
    }                                                                                                                  \
                                                                                                                       \
    static void leaf_##NAME(worker *s, KEY *k, size_t m, size_t off)                                                   \
    {                                                                                                                  \
        small_sort_##NAME(k, m);                                                                                       \
        emit_##NAME(s, k, m, off);                                                                                     \
    }                                                                                                                  \
                                                                                                                       \
    /* The m keys of src (writable) belong in slots [off, off + m) and share every bit from `limit` up. spare: m     \
     * writable keys apart from src, or NULL (then the worker's scratch, or a new block for a big bucket). */         \
    static void node_##NAME(worker *s, KEY *src, size_t m, size_t off, KEY *spare, uint32_t limit)                    \
    {                                                                                                                  \
        if (s->state)                                                                                                  \
            return;                                                                                                    \
        if (m <= LEAF) {                                                                                               \
            leaf_##NAME(s, src, m, off);                                                                               \
            return;                                                                                                    \
        }                                                                                                              \
        KEY pre = src[0], span = 0;                                                                                    \
        if (s->want) {                                                                                                 \
            const KEY *w = s->want;                                                                                    \
            pre = w[off];                                                                                              \
            span = pre ^ w[off + m - 1];                                                                               \
        } else {                                                                                                       \
            for (size_t i = 1; i < m; i++)                                                                             \
                span |= src[i] ^ pre;                                                                                  \
        }                                                                                                              \
        uint32_t hi = rto__bitlen64(span);                                                                             \
        if (hi > limit)                                                                                                \
            hi = limit;                                                                                                \
        const KEY above = hi >= (BITS) ? 0 : (KEY)(~(KEY)0 << hi);                                                     \
        if (hi == 0) { /* one key value: every key must be pre */                                                     \
            KEY x = 0;                                                                                                 \
            for (size_t i = 0; i < m; i++)                                                                             \
                x |= src[i] ^ pre;                                                                                     \
            if (x)                                                                                                     \
                s->state = 1;                                                                                          \
            else                                                                                                       \
                emit_##NAME(s, src, m, off);                                                                           \
            return;                                                                                                    \
        }                                                                                                              \
        const uint32_t db = digit_bits(m), width = hi < db ? hi : db, shift = hi - width, radix = 1u << width;        \
        const KEY mask = (KEY)(radix - 1);                                                                             \
        uint32_t *end = s->counts + s->used;                                                                           \
        s->used += radix;                                                                                              \
        memset(end, 0, radix * sizeof *end);                                                                           \
        KEY outside = 0;                                                                                               \
        for (size_t i = 0; i < m; i++) {                                                                               \
            const KEY v = src[i];                                                                                      \
            outside |= (v ^ pre) & above;                                                                              \
            end[(v >> shift) & mask]++;                                                                                \
        }                                                                                                              \
        KEY *own = NULL;                                                                                               \
        if (outside) {                                                                                                 \
            s->state = 1;                                                                                              \
        } else if (!spare && m > LOCAL_KEYS && !(spare = own = rto__alloc_large(m, sizeof *src))) {                   \
            s->state = -1;                                                                                             \
        } else {                                                                                                       \
            if (!spare)                                                                                                \
                spare = s->local;                                                                                      \
            uint32_t run = 0, most = 0;                                                                                \
            for (uint32_t d = 0; d < radix; d++) { /* counts become first slots, then ends */                         \
                const uint32_t c = end[d];                                                                             \
                end[d] = run;                                                                                          \
                run += c;                                                                                              \
                most = c > most ? c : most;                                                                            \
            }                                                                                                          \
            for (size_t i = 0; i < m; i++)                                                                             \
                spare[end[(src[i] >> shift) & mask]++] = src[i];                                                       \
            if (most <= FEW) { /* every bucket a few keys: one insertion sort of the whole range, O(m) */            \
                leaf_##NAME(s, spare, m, off);                                                                         \
                free(own);                                                                                             \
                s->used -= radix;                                                                                      \
                return;                                                                                                \
            }                                                                                                          \
            /* Short buckets are sorted where they lie and compared (or written) in stretches; long ones recurse. */  \
            uint32_t begin = 0, stretch = 0;                                                                           \
            for (uint32_t d = 0; d < radix && !s->state; d++) {                                                        \
                const uint32_t c = end[d] - begin;                                                                     \
                if (c > LEAF) {                                                                                        \
                    emit_##NAME(s, spare + stretch, begin - stretch, off + stretch);                                   \
                    node_##NAME(s, spare + begin, c, off + begin, src + begin, shift);                                 \
                    stretch = end[d];                                                                                  \
                } else if (c > 1) {                                                                                    \
                    small_sort_##NAME(spare + begin, c);                                                               \
                }                                                                                                      \
                begin = end[d];                                                                                        \
            }                                                                                                          \
            if (!s->state)                                                                                             \
                emit_##NAME(s, spare + stretch, m - stretch, off + stretch);                                           \
            free(own);                                                                                                 \
        }                                                                                                              \
        s->used -= radix;                                                                                              \
    }                                                                                                                  \
                                                                                                                       \
    /* The top level, on every worker of the team. */                                                                 \
    static void root_##NAME(match *r, rto__team *team, worker *s, uint32_t w, uint32_t t)                              \
    {                                                                                                                  \
        const KEY *in = r->keys, *want = r->want;                                                                      \
        KEY *a = r->a;                                                                                                 \
        const size_t n = r->n;                                                                                         \
        size_t b, e;                                                                                                   \
        rto__part(n, w, t, &b, &e);                                                                                    \
        KEY pre = in[0], span = 0;                                                                                     \
        if (want) {                                                                                                    \
            pre = want[0];                                                                                             \
            span = pre ^ want[n - 1];                                                                                  \
        } else {                                                                                                       \
            for (size_t i = b; i < e; i++)                                                                             \
                span |= in[i] ^ pre;                                                                                   \
            r->diff[w] = span;                                                                                         \
            rto__team_sync(team);                                                                                      \
            for (uint32_t v = 0; v < t; v++)                                                                           \
                span |= (KEY)r->diff[v];                                                                               \
        }                                                                                                              \
        const uint32_t hi = rto__bitlen64(span);                                                                       \
        const KEY above = hi >= (BITS) ? 0 : (KEY)(~(KEY)0 << hi);                                                     \
        const uint32_t db = root_bits(n, t), width = hi < db ? hi : db, shift = hi - width, radix = 1u << width;      \
        const KEY mask = (KEY)(radix - 1);                                                                             \
        uint32_t *hist = r->hist + ((size_t)w << db);                                                                  \
        memset(hist, 0, radix * sizeof *hist);                                                                         \
        KEY outside = 0;                                                                                               \
        for (size_t i = b; i < e; i++) {                                                                               \
            const KEY v = in[i];                                                                                       \
            outside |= (v ^ pre) & above;                                                                              \
            hist[(v >> shift) & mask]++;                                                                               \
        }                                                                                                              \
        if (outside && !s->state)                                                                                      \
            s->state = 1;                                                                                              \
        r->state[w] = s->state;                                                                                        \
        rto__team_sync(team);                                                                                          \
        for (uint32_t v = 0; v < t; v++)                                                                               \
            if (r->state[v])                                                                                           \
                return; /* every worker sees the same states and stops here */                                        \
        if (hi == 0) { /* one key value: the range is sorted as it is */                                              \
            emit_##NAME(s, in + b, e - b, b);                                                                          \
            return;                                                                                                    \
        }                                                                                                              \
        /* This worker's first slot per digit: the keys of smaller digits and those of the same digit in lower       \
         * workers' ranges; ends[d], where bucket d ends. Alone, the counters become both in place. */              \
        uint32_t *first = hist, *ends = hist, run = 0, top = 0;                                                        \
        if (t == 1) {                                                                                                  \
            for (uint32_t d = 0; d < radix; d++) {                                                                     \
                const uint32_t c = hist[d];                                                                            \
                hist[d] = run;                                                                                         \
                run += c;                                                                                              \
                top = c > top ? c : top;                                                                               \
            }                                                                                                          \
        } else {                                                                                                       \
            first = s->counts;                                                                                         \
            ends = s->counts + (1u << MAX_BITS);                                                                       \
            for (uint32_t d = 0; d < radix; d++) {                                                                     \
                uint32_t before = 0, all = 0;                                                                          \
                for (uint32_t v = 0; v < t; v++) {                                                                     \
                    const uint32_t c = r->hist[((size_t)v << db) + d];                                                 \
                    before += v < w ? c : 0;                                                                           \
                    all += c;                                                                                          \
                }                                                                                                      \
                first[d] = run + before;                                                                               \
                run += all;                                                                                            \
                ends[d] = run;                                                                                         \
            }                                                                                                          \
        }                                                                                                              \
        for (size_t i = b; i < e; i++)                                                                                 \
            a[first[(in[i] >> shift) & mask]++] = in[i];                                                               \
        rto__team_sync(team);                                                                                          \
        if (t == 1 && top <= FEW) { /* alone, every bucket a few keys: one insertion sort of the whole array */       \
            leaf_##NAME(s, a, n, 0);                                                                                   \
            return;                                                                                                    \
        }                                                                                                              \
        /* Buckets by their first slot: those starting in [b, e) are this worker's, slots [s0, s1) together. */     \
        s->used = 2u << MAX_BITS;                                                                                      \
        size_t s0 = n, s1 = 0, most = 0;                                                                               \
        for (uint32_t d = 0; d < radix; d++) {                                                                         \
            const size_t from = d ? ends[d - 1] : 0, to = ends[d];                                                     \
            if (from >= b && from < e && to > from) {                                                                  \
                s0 = s0 < from ? s0 : from;                                                                            \
                s1 = to;                                                                                               \
                most = to - from > most ? to - from : most;                                                            \
            }                                                                                                          \
        }                                                                                                              \
        if (s1 <= s0)                                                                                                  \
            return;                                                                                                    \
        if (most <= FEW) { /* every bucket a few keys: one insertion sort of the whole range */                       \
            leaf_##NAME(s, a + s0, s1 - s0, s0);                                                                       \
            return;                                                                                                    \
        }                                                                                                              \
        size_t stretch = s0;                                                                                           \
        for (uint32_t d = 0; d < radix && !s->state; d++) {                                                            \
            const size_t from = d ? ends[d - 1] : 0, to = ends[d];                                                     \
            if (from < b || from >= e || to <= from)                                                                   \
                continue;                                                                                              \
            if (to - from > LEAF) {                                                                                    \
                emit_##NAME(s, a + stretch, from - stretch, stretch);                                                  \
                node_##NAME(s, a + from, to - from, from, NULL, shift);                                                \
                stretch = to;                                                                                          \
            } else if (to - from > 1) {                                                                                \
                small_sort_##NAME(a + from, to - from);                                                                \
            }                                                                                                          \
        }                                                                                                              \
        if (!s->state)                                                                                                 \
            emit_##NAME(s, a + stretch, s1 - stretch, stretch);                                                        \
    }

DEFINE_MATCH(uint32_t, u32, 32u)
DEFINE_MATCH(uint64_t, u64, 64u)

static void match_team(void *ctx, rto__team *team, uint32_t w, uint32_t t)
{
    match *r = ctx;
    const size_t ksz = rto_key_size(r->f);
    worker s = {r->want, r->out, NULL, NULL, 0, 0};
    /* the scratch: LOCAL_KEYS keys, then the counters (the root's 2 x 2048 below the nodes' path) */
    unsigned char *mem = malloc(LOCAL_KEYS * ksz + ((2u << MAX_BITS) + PATH_COUNTERS) * sizeof(uint32_t));
    if (mem) {
        s.local = mem;
        s.counts = (uint32_t *)(mem + LOCAL_KEYS * ksz);
    } else {
        s.state = -1;
    }
    if (r->f == RTO_KEY_U32)
        root_u32(r, team, &s, w, t);
    else
        root_u64(r, team, &s, w, t);
    /* A worker that stopped early still reaches the syncs it owes: root returns only after the last one it shares
     * with the others, or before the first where every worker stops. */
    r->verdict[w] = s.state;
    free(mem);
}

int rto__sort_match(rto_key_format f, const void *keys, size_t n, const void *want, void *out, uint32_t threads)
{
    const size_t ksz = rto_key_size(f);
    if (n == 0)
        return 1;
    if (n <= LEAF) { /* one run, sorted in a copy */
        uint32_t c32[LEAF];
        uint64_t c64[LEAF];
        worker s = {want, out, NULL, NULL, 0, 0};
        if (f == RTO_KEY_U32) {
            memcpy(c32, keys, n * ksz);
            leaf_u32(&s, c32, n, 0);
        } else {
            memcpy(c64, keys, n * ksz);
            leaf_u64(&s, c64, n, 0);
        }
        return s.state ? 0 : 1;
    }
    uint32_t t = n >= RTO__SORT_MATCH_TEAM_FROM ? rto__thread_count(threads) : 1;
    match r = {f, keys, want, out, n, NULL, NULL, NULL, NULL, NULL};
    r.a = rto__alloc_large(n, ksz);
    r.hist = malloc(((size_t)t << root_bits(n, t)) * sizeof *r.hist);
    r.diff = malloc(t * sizeof *r.diff);
    r.state = calloc(t, sizeof *r.state);
    r.verdict = calloc(t, sizeof *r.verdict); /* 0 also for workers the team could not start */
    int result = -1;
    if (r.a && r.hist && r.diff && r.state && r.verdict) {
        if (t > 1)
            rto__team_run(t, match_team, &r);
        else
            match_team(&r, NULL, 0, 1);
        result = 1;
        for (uint32_t v = 0; v < t; v++)
            if (r.verdict[v] < 0)
                result = -1;
            else if (r.verdict[v] > 0 && result > 0)
                result = 0;
    }
    free(r.a);
    free(r.hist);
    free(r.diff);
    free(r.state);
    free(r.verdict);
    return result;
}
