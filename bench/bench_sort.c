/* Sort oracle benchmarks: the bitonic network, the radix reference and check-sort, each beside the C library's
 * qsort on the same keys in the same process, as a ratio (median of RUNS runs). Absolute times drift on a shared
 * machine; the ratio is the figure to compare. Embree has no sort, so qsort is the yardstick here.
 *
 * check-sort is timed on a correct dump (the case a CI loop meets) five ways: with only the input (matched inside by
 * an MSD radix partition) on one thread and on every hardware thread (rto_sort_check_desc.threads 1 and 0), with
 * expected_keys (a bundle's sorted.npy), with expected_keys and stable carried values, and the full analysis that
 * every call ran before the fast path (qsort of input and dump), as the before figure. Every check but "all threads"
 * runs on one thread.
 * `bench_sort WORD` runs only the oracles whose name contains WORD (e.g. check; "paths" runs only the table of
 * bitonic paths, each beside qsort and a plain LSD radix sort). --json: bench_util.h. */
#include "rtoracle.h"
#include "bench_util.h"
#include "sort/sort_internal.h" /* rto__sort_check_reference */
#include "sort/bitonic_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

typedef enum {
    WORK_QSORT,
    WORK_BITONIC,
    WORK_RADIX,
    WORK_CHECK_INPUT,
    WORK_CHECK_INPUT_ALL, /* the same with every hardware thread */
    WORK_CHECK_EXPECTED,
    WORK_CHECK_VALUES,
    WORK_CHECK_FULL,
    WORK_LSD,
    WORK_NET
} work;

typedef struct job {
    rto_key_format f;
    size_t n;
    const void *keys;
    void *scratch;   /* n_padded keys */
    uint32_t *perm;  /* n_padded */
    const void *sorted; /* a correct sorted output, for check-sort */
    const uint32_t *values; /* its stable source indices */
    void *tmp;              /* n keys: the plain radix sort's ping-pong buffer */
    int isa;                /* WORK_NET: rto__bitonic_isa, or -1 for the scalar reference */
    uint32_t threads;       /* WORK_NET: 0 = all CPUs */
} job;

/* A plain LSD radix sort (8-bit digits, every histogram counted in one read, ping-pong buffers, keys only): the
 * yardstick for "what the hardware allows" beside the network, written here so the library's sorts are not timed
 * against themselves. */
#define DEFINE_LSD(KEY, NAME)                                                                                          \
    static void lsd_##NAME(const KEY *in, size_t n, KEY *out, KEY *tmp)                                                \
    {                                                                                                                  \
        enum { D = sizeof(KEY) };                                                                                      \
        static uint32_t hist[D][256];                                                                                  \
        memset(hist, 0, sizeof hist);                                                                                  \
        for (size_t i = 0; i < n; i++)                                                                                 \
            for (int d = 0; d < D; d++)                                                                                \
                hist[d][(in[i] >> (8 * d)) & 0xFF]++;                                                                  \
        const KEY *src = in;                                                                                           \
        for (int d = 0; d < D; d++) {                                                                                  \
            KEY *dst = ((D - 1 - d) % 2 == 0) ? out : tmp;                                                             \
            uint32_t run = 0;                                                                                          \
            for (int b = 0; b < 256; b++) {                                                                            \
                uint32_t c = hist[d][b];                                                                               \
                hist[d][b] = run;                                                                                      \
                run += c;                                                                                              \
            }                                                                                                          \
            for (size_t i = 0; i < n; i++)                                                                             \
                dst[hist[d][(src[i] >> (8 * d)) & 0xFF]++] = src[i];                                                   \
            src = dst;                                                                                                 \
        }                                                                                                              \
    }
DEFINE_LSD(uint32_t, u32)
DEFINE_LSD(uint64_t, u64)

static void run(work w, const job *j)
{
    size_t ksz = rto_key_size(j->f);
    rto_status s = RTO_OK;
    switch (w) {
    case WORK_QSORT:
        memcpy(j->scratch, j->keys, j->n * ksz);
        qsort(j->scratch, j->n, ksz, j->f == RTO_KEY_U32 ? cmp_u32 : cmp_u64);
        break;
    case WORK_BITONIC: s = rto_bitonic_sort(j->f, j->keys, j->n, j->scratch, j->perm, NULL, NULL); break;
    case WORK_LSD:
        if (j->f == RTO_KEY_U32)
            lsd_u32(j->keys, j->n, j->scratch, j->tmp);
        else
            lsd_u64(j->keys, j->n, j->scratch, j->tmp);
        break;
    case WORK_NET:
        s = j->isa < 0 ? rto__bitonic_sort_scalar(j->f, j->keys, j->n, j->scratch, j->perm, NULL, NULL)
                       : rto__bitonic_sort_with(j->f, j->keys, j->n, j->scratch, j->perm, NULL,
                                                (rto__bitonic_isa)j->isa, j->threads, NULL);
        break;
    case WORK_RADIX: s = rto_radix_sort(j->f, j->keys, j->n, 8, 256, j->scratch, j->perm, NULL, NULL); break;
    case WORK_CHECK_INPUT:
    case WORK_CHECK_INPUT_ALL:
    case WORK_CHECK_EXPECTED:
    case WORK_CHECK_VALUES:
    case WORK_CHECK_FULL: {
        rto_sort_check_desc d;
        memset(&d, 0, sizeof d);
        d.format = j->f;
        d.input = j->keys;
        d.n = j->n;
        d.gpu_keys = j->sorted;
        d.gpu_n = j->n;
        d.threads = w == WORK_CHECK_INPUT_ALL ? 0 : 1;
        if (w == WORK_CHECK_EXPECTED || w == WORK_CHECK_VALUES)
            d.expected_keys = j->sorted;
        if (w == WORK_CHECK_VALUES) {
            d.gpu_values = j->values;
            d.require_stable = 1;
        }
        rto_report r;
        s = w == WORK_CHECK_FULL ? rto__sort_check_reference(&d, &r, NULL) : rto_sort_check(&d, &r, NULL);
        break;
    }
    }
    if (s != RTO_OK) {
        fprintf(stderr, "bench: work %d failed: %s\n", (int)w, rto_status_string(s));
        exit(1);
    }
}

static double median_seconds(work w, const job *j)
{
    double t[RUNS];
    for (int r = 0; r < RUNS; r++) {
        double t0 = now();
        run(w, j);
        t[r] = now() - t0;
    }
    return median(t);
}

/* The network's paths at the acceptance sizes: each path with 1 thread and all threads, beside qsort and the plain
 * radix sort on the same keys, timed in this process (medians of RUNS runs). ns/CE: time per compare-exchange of the
 * canonical schedule (n_padded / 2 per pass). */
static void bench_paths(void)
{
    static const struct {
        rto_key_format f;
        size_t n;
        const char *dist;
    } cases[] = {{RTO_KEY_U32, 65536, "uniform"}, {RTO_KEY_U64, 1u << 20, "random"}};
    printf("\n%-16s %-4s %8s %8s %11s %9s %10s %10s\n", "bitonic path", "fmt", "n", "threads", "median ms",
           "ns/CE", "/qsort", "/radix");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const size_t n = cases[c].n, np = rto_next_pow2(n), ksz = rto_key_size(cases[c].f);
        const double ces = (double)(np / 2) * rto_bitonic_pass_count(np);
        void *keys = malloc(n * ksz), *scratch = malloc(np * ksz), *tmp = malloc(n * ksz);
        uint32_t *perm = malloc(np * sizeof *perm);
        if (!keys || !scratch || !tmp || !perm || rto_keys_generate(cases[c].dist, cases[c].f, 1, n, keys, NULL))
            exit(1);
        job j = {cases[c].f, n, keys, scratch, perm, NULL, NULL, tmp, 0, 1};
        const double tq = median_seconds(WORK_QSORT, &j), tr = median_seconds(WORK_LSD, &j);
        const char *fmt = cases[c].f == RTO_KEY_U32 ? "u32" : "u64";
        printf("%-16s %-4s %8zu %8s %11.3f %9s %10s %10s\n", "qsort", fmt, n, "1", tq * 1e3, "-", "1.00x", "-");
        printf("%-16s %-4s %8zu %8s %11.3f %9s %10s %10s\n", "plain LSD radix", fmt, n, "1", tr * 1e3, "-", "-",
               "1.00x");
        for (int isa = -1; isa < RTO__BITONIC_ISA_COUNT; isa++) {
            if (isa == RTO__BITONIC_AUTO || (isa > 0 && !rto__bitonic_isa_supported((rto__bitonic_isa)isa)))
                continue;
            for (uint32_t t = 1; t <= 2; t++) {
                if (isa < 0 && t == 2)
                    continue; /* the reference has no threads */
                j.isa = isa;
                j.threads = t == 1 ? 1 : 0;
                const double tb = median_seconds(WORK_NET, &j);
                char threads[16];
                snprintf(threads, sizeof threads, "%s", t == 1 ? "1" : "all");
                const char *path = isa < 0 ? "scalar reference" : rto__bitonic_isa_name((rto__bitonic_isa)isa);
                printf("%-16s %-4s %8zu %8s %11.3f %9.3f %9.3fx %9.3fx\n", path, fmt, n, threads, tb * 1e3,
                       tb / ces * 1e9, tb / tq, tb / tr);
                char kase[64];
                snprintf(kase, sizeof kase, "bitonic %s %s n=%zu", path, fmt, n);
                bench_row("sort", kase, "qsort (1 thread)", (int)j.threads, tb, tq);
                bench_row("sort", kase, "plain LSD radix (1 thread)", (int)j.threads, tb, tr);
            }
        }
        free(keys);
        free(scratch);
        free(tmp);
        free(perm);
    }
}

static int cmp_pair(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    if (x[0] != y[0])
        return (x[0] > y[0]) - (x[0] < y[0]);
    return (x[1] > y[1]) - (x[1] < y[1]);
}

int main(int argc, char **argv)
{
    bench_init(&argc, argv);
    const char *only = argc > 1 ? argv[1] : "";
    static const struct {
        rto_key_format f;
        size_t n;
        const char *dist;
    } cases[] = {{RTO_KEY_U32, 16384, "uniform"}, {RTO_KEY_U32, 65536, "uniform"}, {RTO_KEY_U64, 1u << 20, "random"}};
    static const struct {
        work w;
        const char *name;
    } works[] = {{WORK_BITONIC, "bitonic"},
                 {WORK_RADIX, "radix-8/256"},
                 {WORK_CHECK_INPUT, "check --input"},
                 {WORK_CHECK_INPUT_ALL, "check --input (all threads)"},
                 {WORK_CHECK_EXPECTED, "check --expected"},
                 {WORK_CHECK_VALUES, "check --expected +values,stable"},
                 {WORK_CHECK_FULL, "check full analysis (before)"}};
    print_load("before");
    printf("%-31s %-4s %9s %11s %11s %10s %14s\n", "oracle", "fmt", "n", "median ms", "Mkeys/s", "qsort ms",
           "oracle/qsort");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const size_t n = cases[c].n, np = rto_next_pow2(n), ksz = rto_key_size(cases[c].f);
        void *keys = malloc(n * ksz), *scratch = malloc(np * ksz), *sorted = malloc(np * ksz);
        uint32_t *perm = malloc(np * sizeof *perm), *values = malloc(n * sizeof *values);
        uint64_t *pairs = malloc(2 * n * sizeof *pairs);
        if (!keys || !scratch || !sorted || !perm || !values || !pairs)
            return 1;
        if (rto_keys_generate(cases[c].dist, cases[c].f, 1, n, keys, NULL) != RTO_OK)
            return 1;
        /* the correct key/value dump: (key, index) pairs by qsort, so equal keys keep input order */
        for (size_t i = 0; i < n; i++) {
            pairs[2 * i] = cases[c].f == RTO_KEY_U32 ? ((const uint32_t *)keys)[i] : ((const uint64_t *)keys)[i];
            pairs[2 * i + 1] = i;
        }
        qsort(pairs, n, 2 * sizeof *pairs, cmp_pair);
        for (size_t i = 0; i < n; i++) {
            if (cases[c].f == RTO_KEY_U32)
                ((uint32_t *)sorted)[i] = (uint32_t)pairs[2 * i];
            else
                ((uint64_t *)sorted)[i] = pairs[2 * i];
            values[i] = (uint32_t)pairs[2 * i + 1];
        }
        free(pairs);
        job j = {cases[c].f, n, keys, scratch, perm, sorted, values, NULL, 0, 0};
        for (size_t w = 0; w < sizeof works / sizeof works[0]; w++) {
            if (!strstr(works[w].name, only))
                continue;
            double tq = median_seconds(WORK_QSORT, &j), to = median_seconds(works[w].w, &j);
            const char *fmt = cases[c].f == RTO_KEY_U32 ? "u32" : "u64";
            printf("%-31s %-4s %9zu %11.3f %11.2f %10.3f %13.2fx\n", works[w].name, fmt, n, to * 1e3,
                   (double)n / to * 1e-6, tq * 1e3, to / tq);
            char kase[80];
            snprintf(kase, sizeof kase, "%s %s n=%zu", works[w].name, fmt, n);
            bench_row("sort", kase, works[w].w == WORK_CHECK_INPUT_ALL ? "qsort (1 thread)" : "qsort",
                      works[w].w == WORK_CHECK_INPUT_ALL ? 0 : 1, to, tq);
        }
        free(keys);
        free(scratch);
        free(sorted);
        free(perm);
        free(values);
    }
    if (strstr("bitonic paths", only))
        bench_paths();
    print_load("after");
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("peak RSS %.1f MiB; median of %d runs each; qsort sorts a copy of the same keys\n",
           (double)ru.ru_maxrss / 1024.0, RUNS);
    bench_finish("sort", RUNS, NULL);
    return 0;
}
