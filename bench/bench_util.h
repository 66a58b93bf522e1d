/* Timing helpers shared by the benchmarks: a monotonic clock and the median of RUNS samples. */
#ifndef RTO_BENCH_UTIL_H
#define RTO_BENCH_UTIL_H

#include <stdlib.h>
#include <time.h>

#define RUNS 7

static inline double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Sorts t (RUNS samples) and returns its median. */
static inline double median(double *t)
{
    qsort(t, RUNS, sizeof *t, cmp_double);
    return t[RUNS / 2];
}

#endif
