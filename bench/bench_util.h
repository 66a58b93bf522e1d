/* Timing helpers shared by the benchmarks: a monotonic clock, the median of RUNS samples, the machine's load, and
 * the machine-readable output every benchmark gives with --json. */
#ifndef RTO_BENCH_UTIL_H
#define RTO_BENCH_UTIL_H

#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define RUNS 7

/* The peak RSS (KiB) of work(spec, which) run once in a child process of its own (fork; getrusage's ru_maxrss of the
 * child), so that one measurement's memory does not raise the next one's; -1 when the child fails. */
static inline long bench_child_peak_kib(void (*work)(const char *spec, int which), const char *spec, int which)
{
    fflush(stdout);
    const pid_t pid = fork();
    if (pid == 0) {
        work(spec, which);
        _exit(0);
    }
    int status = 0;
    struct rusage ru;
    if (pid < 0 || wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
        return -1;
    return ru.ru_maxrss;
}

static inline double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A pause before a timed build, so that both sides start from idle threads: the oracle's pool and Embree's TBB
 * workers spin for a while after a job, and a spinning pool of one builder would slow the other's build when runs are
 * interleaved (on 16 cores, Embree's Morton builder ran 3-4x slower right after an oracle build). */
static inline void settle(void)
{
    const struct timespec t = {0, 20 * 1000 * 1000};
    nanosleep(&t, NULL);
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

/* --json: the tables go to stderr and stdout carries one JSON document (bench_finish):
 *   {"benchmark": NAME, "runs": RUNS, "rows": [ROW...], "detail": ...}
 * ROW = {"group", "case", "reference", "threads", "oracle_ms", "reference_ms", "ratio"}, one per figure the
 * benchmark compares: ratio = time(oracle) / time(reference) on the same work in the same process (> 1: the oracle is
 * slower). scripts/bench-plot draws the rows. */
static int bench_json_fd = -1;
static json_t *bench_rows;

/* Takes --json out of argv (the other arguments stay for the benchmark); with it, stdout is redirected to stderr
 * until bench_finish. Returns 1 with --json. */
static inline int bench_init(int *argc, char **argv)
{
    int json = 0, k = 1;
    for (int i = 1; i < *argc; i++) {
        if (!strcmp(argv[i], "--json"))
            json = 1;
        else
            argv[k++] = argv[i];
    }
    *argc = k;
    argv[k] = NULL;
    bench_rows = json_array();
    if (json) {
        fflush(stdout);
        bench_json_fd = dup(1);
        if (bench_json_fd < 0 || dup2(2, 1) < 0 || !bench_rows) {
            perror("bench: --json");
            exit(2);
        }
    }
    return json;
}

/* One compared figure (see above); threads 0 means every hardware thread. */
static inline void bench_row(const char *group, const char *kase, const char *reference, int threads,
                             double oracle_s, double reference_s)
{
    json_t *row = json_pack("{s:s, s:s, s:s, s:i, s:f, s:f, s:f}", "group", group, "case", kase, "reference",
                            reference, "threads", threads, "oracle_ms", oracle_s * 1e3, "reference_ms",
                            reference_s * 1e3, "ratio", oracle_s / reference_s);
    if (!row || json_array_append_new(bench_rows, row)) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
}

/* With --json, writes the document (runs: the samples per median; detail: the benchmark's own figures, or NULL;
 * stolen) to the real stdout. */
static inline void bench_finish(const char *name, int runs, json_t *detail)
{
    if (bench_json_fd < 0) {
        json_decref(detail);
        json_decref(bench_rows);
        return;
    }
    fflush(stdout);
    json_t *root = json_pack("{s:s, s:i, s:o, s:o}", "benchmark", name, "runs", runs, "rows", bench_rows, "detail",
                             detail ? detail : json_null());
    char *text = root ? json_dumps(root, JSON_INDENT(2) | JSON_PRESERVE_ORDER) : NULL;
    FILE *out = fdopen(bench_json_fd, "w");
    if (!text || !out || fprintf(out, "%s\n", text) < 0 || fclose(out)) {
        fprintf(stderr, "bench: --json: could not write the document\n");
        exit(1);
    }
    free(text);
    json_decref(root);
}

#endif
