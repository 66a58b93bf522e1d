/* Sort oracle benchmarks: the bitonic network, the radix reference and check-sort, each beside the C library's
 * qsort on the same keys in the same process, as a ratio (median of RUNS runs). Absolute times drift on a shared
 * machine; the ratio is the figure to compare. Embree has no sort, so qsort is the yardstick here. */
#include "rtoracle.h"
#include "bench_util.h"
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

typedef enum { WORK_QSORT, WORK_BITONIC, WORK_RADIX, WORK_CHECK, WORK_LSD, WORK_NET } work;

typedef struct job {
    rto_key_format f;
    size_t n;
    const void *keys;
    void *scratch;   /* n_padded keys */
    uint32_t *perm;  /* n_padded */
    const void *sorted; /* a correct sorted output, for check-sort */
    void *tmp;          /* n keys: the plain radix sort's ping-pong buffer */
    int isa;            /* WORK_NET: rto__bitonic_isa, or -1 for the scalar reference */
    uint32_t threads;   /* WORK_NET: 0 = all CPUs */
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
    case WORK_CHECK: {
        rto_sort_check_desc d;
        memset(&d, 0, sizeof d);
        d.format = j->f;
        d.input = j->keys;
        d.n = j->n;
        d.gpu_keys = j->sorted;
        d.gpu_n = j->n;
        rto_report r;
        s = rto_sort_check(&d, &r, NULL);
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
        job j = {cases[c].f, n, keys, scratch, perm, NULL, tmp, 0, 1};
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
                printf("%-16s %-4s %8zu %8s %11.3f %9.3f %9.3fx %9.3fx\n",
                       isa < 0 ? "scalar reference" : rto__bitonic_isa_name((rto__bitonic_isa)isa), fmt, n, threads,
                       tb * 1e3, tb / ces * 1e9, tb / tq, tb / tr);
            }
        }
        free(keys);
        free(scratch);
        free(tmp);
        free(perm);
    }
}

int main(void)
{
    static const struct {
        rto_key_format f;
        size_t n;
        const char *dist;
    } cases[] = {{RTO_KEY_U32, 16384, "uniform"}, {RTO_KEY_U32, 65536, "uniform"}, {RTO_KEY_U64, 1u << 20, "random"}};
    static const struct {
        work w;
        const char *name;
    } works[] = {{WORK_BITONIC, "bitonic"}, {WORK_RADIX, "radix-8/256"}, {WORK_CHECK, "check-sort"}};
    printf("%-12s %-4s %9s %11s %11s %10s %14s\n", "oracle", "fmt", "n", "median ms", "Mkeys/s", "qsort ms",
           "oracle/qsort");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const size_t n = cases[c].n, np = rto_next_pow2(n), ksz = rto_key_size(cases[c].f);
        void *keys = malloc(n * ksz), *scratch = malloc(np * ksz), *sorted = malloc(np * ksz);
        uint32_t *perm = malloc(np * sizeof *perm);
        if (!keys || !scratch || !sorted || !perm)
            return 1;
        if (rto_keys_generate(cases[c].dist, cases[c].f, 1, n, keys, NULL) != RTO_OK)
            return 1;
        memcpy(sorted, keys, n * ksz);
        qsort(sorted, n, ksz, cases[c].f == RTO_KEY_U32 ? cmp_u32 : cmp_u64);
        job j = {cases[c].f, n, keys, scratch, perm, sorted, NULL, 0, 0};
        for (size_t w = 0; w < sizeof works / sizeof works[0]; w++) {
            double tq = median_seconds(WORK_QSORT, &j), to = median_seconds(works[w].w, &j);
            printf("%-12s %-4s %9zu %11.3f %11.2f %10.3f %13.2fx\n", works[w].name,
                   cases[c].f == RTO_KEY_U32 ? "u32" : "u64", n, to * 1e3, (double)n / to * 1e-6, tq * 1e3, to / tq);
        }
        free(keys);
        free(scratch);
        free(sorted);
        free(perm);
    }
    bench_paths();
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("peak RSS %.1f MiB; median of %d runs each; qsort sorts a copy of the same keys\n",
           (double)ru.ru_maxrss / 1024.0, RUNS);
    return 0;
}
