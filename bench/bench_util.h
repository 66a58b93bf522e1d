/* Timing helpers shared by the benchmarks: a monotonic clock, the median of RUNS samples and the machine's load. */
#ifndef RTO_BENCH_UTIL_H
#define RTO_BENCH_UTIL_H

#include <stdio.h>
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

/* The load average around a run: figures taken on a busy machine are marked as such by it. */
static inline void print_load(const char *when)
{
    FILE *f = fopen("/proc/loadavg", "r");
    char line[128] = "?\n";
    if (f) {
        if (!fgets(line, sizeof line, f))
            snprintf(line, sizeof line, "?\n");
        fclose(f);
    }
    printf("load average %s: %s", when, line);
}

#endif
