/* Static partitioning for the parallel stages (DESIGN.md §2): n items are split into `threads` contiguous ranges of
 * (almost) equal size, one per thread, fixed before any work starts. Each item's output depends only on that item,
 * so the bytes written do not depend on the thread count or on scheduling. */
#include "internal.h"

#include <pthread.h>
#include <stdlib.h>
#include <unistd.h>

uint32_t rto__thread_count(uint32_t requested)
{
    if (requested)
        return requested > RTO_THREADS_MAX ? RTO_THREADS_MAX : requested;
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    if (online < 1)
        return 1;
    return online > (long)RTO_THREADS_MAX ? RTO_THREADS_MAX : (uint32_t)online;
}

typedef struct range_job {
    rto_range_fn fn;
    void *ctx;
    size_t begin, end;
    uint32_t worker;
} range_job;

static void *run_range(void *arg)
{
    range_job *j = arg;
    j->fn(j->ctx, j->worker, j->begin, j->end);
    return NULL;
}

void rto__parallel_ranges(size_t n, uint32_t threads, rto_range_fn fn, void *ctx)
{
    uint32_t t = rto__thread_count(threads);
    /* No thread for less than one item each: small calls stay in the caller's thread. */
    if ((size_t)t > n)
        t = n ? (uint32_t)n : 1;
    range_job jobs[RTO_THREADS_MAX];
    pthread_t ids[RTO_THREADS_MAX];
    int started[RTO_THREADS_MAX] = {0};
    for (uint32_t w = 0; w < t; w++) {
        /* Range w is [w n / t, (w + 1) n / t): computed without overflow for n < 2^58. */
        jobs[w] = (range_job){fn, ctx, (size_t)((uint64_t)n * w / t), (size_t)((uint64_t)n * (w + 1) / t), w};
    }
    for (uint32_t w = 1; w < t; w++)
        started[w] = pthread_create(&ids[w], NULL, run_range, &jobs[w]) == 0;
    run_range(&jobs[0]);
    /* A thread that could not be started runs its range here instead: the same items, the same results. */
    for (uint32_t w = 1; w < t; w++) {
        if (started[w])
            pthread_join(ids[w], NULL);
        else
            run_range(&jobs[w]);
    }
}
