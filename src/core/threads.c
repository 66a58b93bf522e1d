/* Static partitioning for the parallel stages (DESIGN.md §2): n items are split into `threads` contiguous ranges of
 * (almost) equal size, one per thread, fixed before any work starts. Each item's output depends only on that item,
 * so the bytes written do not depend on the thread count or on scheduling. */
#include "internal.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
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

/* A team: one set of threads for a whole multi-stage job, with barriers between the stages, so a build starts its
 * threads once instead of once per stage. Workers are numbered in creation order, and only after every thread has
 * been asked for is their number fixed: a thread that could not be created leaves no gap, the others share its
 * work. The partitions stay static (each worker derives its ranges from its number and the team size alone). */
struct rto__team {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    uint32_t size;       /* workers, fixed before any runs */
    uint32_t waiting;    /* workers at the current barrier */
    uint64_t generation; /* barriers passed */
    int started;         /* size is final */
    rto_team_fn fn;
    void *ctx;
};

typedef struct team_member {
    rto__team *team;
    uint32_t worker;
} team_member;

static void *team_main(void *arg)
{
    team_member *m = arg;
    rto__team *t = m->team;
    pthread_mutex_lock(&t->lock);
    while (!t->started)
        pthread_cond_wait(&t->cond, &t->lock);
    pthread_mutex_unlock(&t->lock);
    t->fn(t->ctx, t, m->worker, t->size);
    return NULL;
}

void rto__team_sync(rto__team *t)
{
    if (!t || t->size < 2)
        return;
    pthread_mutex_lock(&t->lock);
    uint64_t gen = t->generation;
    if (++t->waiting == t->size) {
        t->waiting = 0;
        t->generation++;
        pthread_cond_broadcast(&t->cond);
    } else {
        while (gen == t->generation)
            pthread_cond_wait(&t->cond, &t->lock);
    }
    pthread_mutex_unlock(&t->lock);
}

void rto__team_run(uint32_t threads, rto_team_fn fn, void *ctx)
{
    uint32_t want = rto__thread_count(threads);
    if (want < 2) {
        fn(ctx, NULL, 0, 1);
        return;
    }
    rto__team t;
    memset(&t, 0, sizeof t);
    t.fn = fn;
    t.ctx = ctx;
    if (pthread_mutex_init(&t.lock, NULL)) {
        fn(ctx, NULL, 0, 1);
        return;
    }
    if (pthread_cond_init(&t.cond, NULL)) {
        pthread_mutex_destroy(&t.lock);
        fn(ctx, NULL, 0, 1);
        return;
    }
    team_member members[RTO_THREADS_MAX];
    pthread_t ids[RTO_THREADS_MAX];
    uint32_t made = 1; /* worker 0 is the caller */
    for (uint32_t w = 1; w < want; w++) {
        members[made] = (team_member){&t, made};
        if (pthread_create(&ids[made], NULL, team_main, &members[made]) == 0)
            made++;
    }
    pthread_mutex_lock(&t.lock);
    t.size = made;
    t.started = 1;
    pthread_cond_broadcast(&t.cond);
    pthread_mutex_unlock(&t.lock);
    fn(ctx, made > 1 ? &t : NULL, 0, made);
    for (uint32_t w = 1; w < made; w++)
        pthread_join(ids[w], NULL);
    pthread_cond_destroy(&t.cond);
    pthread_mutex_destroy(&t.lock);
}
