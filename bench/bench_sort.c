/* Sort oracle benchmarks: the bitonic network, the radix reference and check-sort, each beside the C library's
 * qsort on the same keys in the same process, as a ratio (median of RUNS runs). Absolute times drift on a shared
 * machine; the ratio is the figure to compare. Embree has no sort, so qsort is the yardstick here. */
#include "rtoracle.h"
#include "bench_util.h"

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

typedef enum { WORK_QSORT, WORK_BITONIC, WORK_RADIX, WORK_CHECK } work;

typedef struct job {
    rto_key_format f;
    size_t n;
    const void *keys;
    void *scratch;   /* n_padded keys */
    uint32_t *perm;  /* n_padded */
    const void *sorted; /* a correct sorted output, for check-sort */
} job;

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
        job j = {cases[c].f, n, keys, scratch, perm, sorted};
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
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("peak RSS %.1f MiB; median of %d runs each; qsort sorts a copy of the same keys\n",
           (double)ru.ru_maxrss / 1024.0, RUNS);
    return 0;
}
