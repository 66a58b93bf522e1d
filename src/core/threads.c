/* Static partitioning for the parallel stages (DESIGN.md §2): n items are split into `threads` contiguous ranges of
 * (almost) equal size, one per thread, fixed before any work starts. Each item's output depends only on that item,
 * so the bytes written do not depend on the thread count or on scheduling. */
#include "internal.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
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

/* ---------------------------------------------------------------------------------------------------------------- */
/* Waiting: a thread that waits for a counter to move spins a little (a stage of a build lasts microseconds), then  */
/* sleeps on a condition variable. The counter moves by an atomic increment; the mover wakes sleepers only when     */
/* there are any. Both sides use sequentially consistent operations on the counter and the sleeper count, so either */
/* the sleeper sees the new value before it sleeps or the mover sees the sleeper and takes the lock to wake it.       */

typedef struct waitpoint {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    _Atomic uint32_t sleepers;
    _Atomic uint64_t value;
} waitpoint;

/* How long a waiting thread spins before it sleeps: a stage of a build lasts micro- to milliseconds, and waking a
 * sleeper costs a system call and, on a virtual machine whose idle cores halt, up to milliseconds before it runs. After
 * the first YIELD_AFTER_NS the spinning thread yields between checks: on a machine with more runnable threads than
 * cores, the thread it waits for may need this core.
 * Inside a job (barriers, the end of a job) a thread waits for team mates that are working, so it spins for up to
 * JOB_SPIN_NS: on the 16-core Xeon a sleeper took about 2 ms to run again, and with the old 2 ms budget at every
 * wait, one late worker made the others sleep at the next barrier, where they were late in turn: every barrier of a
 * 16-thread TLAS build cost 2 ms, and the median of 101 such builds was 10.4 ms instead of 2.2. Between jobs a pool
 * worker spins for IDLE_SPIN_NS only, then sleeps until the next job. */
#define JOB_SPIN_NS 20000000
#define IDLE_SPIN_NS 2000000
#define YIELD_AFTER_NS 50000
#define CHECK_EVERY 64

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

static inline void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

static void wp_init(waitpoint *p)
{
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->cond, NULL);
    atomic_store(&p->sleepers, 0);
}

/* Returns once p->value differs from old, spinning for up to spin_ns before it sleeps. */
static void wp_wait(waitpoint *p, uint64_t old, int64_t spin_ns)
{
    int64_t start = -1;
    for (uint32_t i = 0;; i++) {
        if (atomic_load_explicit(&p->value, memory_order_acquire) != old)
            return;
        if (i % CHECK_EVERY == 0) {
            const int64_t t = now_ns();
            if (start < 0) {
                start = t;
            } else if (t - start > spin_ns) {
                break;
            } else if (t - start > YIELD_AFTER_NS) {
                sched_yield();
                continue;
            }
        }
        cpu_relax();
    }
    pthread_mutex_lock(&p->lock);
    atomic_fetch_add(&p->sleepers, 1);
    while (atomic_load(&p->value) == old)
        pthread_cond_wait(&p->cond, &p->lock);
    atomic_fetch_sub(&p->sleepers, 1);
    pthread_mutex_unlock(&p->lock);
}

/* Moves p->value on (releasing every write made before) and wakes its sleepers. */
static void wp_advance(waitpoint *p)
{
    atomic_fetch_add(&p->value, 1);
    if (atomic_load(&p->sleepers)) {
        pthread_mutex_lock(&p->lock);
        pthread_cond_broadcast(&p->cond);
        pthread_mutex_unlock(&p->lock);
    }
}

/* A team: one set of threads for a whole multi-stage job, with barriers between the stages. Its workers come from  */
/* a pool started on first use and kept for the process, so a build pays for thread creation once per process, not */
/* once per call. Worker numbers are fixed before the job starts, and each worker derives its ranges from its       */
/* number and the team size alone: the partitions stay static. One job holds the pool at a time; a call that finds */
/* it busy (another thread's job, or a job inside a job) starts threads of its own for that call, as before.        */
struct rto__team {
    uint32_t size;               /* workers of the current job */
    _Atomic uint32_t waiting;    /* workers at the current barrier */
    waitpoint barrier;           /* value: barriers passed */
};

void rto__team_sync(rto__team *t)
{
    if (!t || t->size < 2)
        return;
    const uint64_t gen = atomic_load_explicit(&t->barrier.value, memory_order_acquire);
    if (atomic_fetch_add_explicit(&t->waiting, 1, memory_order_acq_rel) + 1 == t->size) {
        atomic_store_explicit(&t->waiting, 0, memory_order_relaxed);
        wp_advance(&t->barrier);
    } else {
        wp_wait(&t->barrier, gen, JOB_SPIN_NS);
    }
}

static struct pool {
    pthread_mutex_t busy; /* held by the job that has the pool */
    uint32_t made;        /* pool workers 1 .. made exist */
    waitpoint job;        /* value: jobs started */
    waitpoint done;       /* value: jobs whose pool workers have all returned */
    _Atomic uint32_t active; /* pool workers yet to answer the current job */
    rto__team team;
    rto_team_fn fn;
    void *ctx;
} pool = {.busy = PTHREAD_MUTEX_INITIALIZER};

static pthread_once_t pool_once = PTHREAD_ONCE_INIT;

static void pool_reset(void)
{
    pthread_mutex_init(&pool.busy, NULL);
    pool.made = 0;
    wp_init(&pool.job);
    wp_init(&pool.done);
    wp_init(&pool.team.barrier);
    atomic_store(&pool.team.waiting, 0);
    atomic_store(&pool.active, 0);
}

/* A forked child has only the forking thread: it starts a pool of its own when it needs one. */
static void pool_init(void)
{
    pool_reset();
    pthread_atfork(NULL, NULL, pool_reset);
}

typedef struct pool_start {
    uint32_t worker;
    uint64_t seen; /* jobs started before this worker */
} pool_start;

static void *pool_main(void *arg)
{
    const uint32_t w = (uint32_t)((const pool_start *)arg)->worker;
    uint64_t seen = ((const pool_start *)arg)->seen;
    free(arg);
    for (;;) {
        wp_wait(&pool.job, seen, IDLE_SPIN_NS);
        /* Every pool worker answers every job, taking part or not, so the next job cannot start (and rewrite the
         * job's fields) before each worker has read this one's. */
        seen++;
        if (w < pool.team.size)
            pool.fn(pool.ctx, &pool.team, w, pool.team.size);
        if (atomic_fetch_sub(&pool.active, 1) == 1)
            wp_advance(&pool.done);
    }
    return NULL;
}

/* The pool's workers up to want - 1 (fewer if threads cannot be created); returns the team size. */
static uint32_t pool_grow(uint32_t want)
{
    pthread_attr_t attr;
    if (pthread_attr_init(&attr))
        return pool.made + 1 < want ? pool.made + 1 : want;
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    while (pool.made + 1 < want) {
        pool_start *st = malloc(sizeof *st);
        if (!st)
            break;
        st->worker = pool.made + 1;
        st->seen = atomic_load(&pool.job.value);
        pthread_t id;
        if (pthread_create(&id, &attr, pool_main, st)) {
            free(st);
            break;
        }
        pool.made++;
    }
    pthread_attr_destroy(&attr);
    return pool.made + 1 < want ? pool.made + 1 : want;
}

/* The team of a call that found the pool busy: threads of its own, joined at the end. */
typedef struct own_member {
    rto__team *team;
    rto_team_fn fn;
    void *ctx;
    uint32_t worker;
    waitpoint *go;
} own_member;

static void *own_main(void *arg)
{
    own_member *m = arg;
    wp_wait(m->go, 0, JOB_SPIN_NS);
    m->fn(m->ctx, m->team, m->worker, m->team->size);
    return NULL;
}

static void team_run_own(uint32_t want, rto_team_fn fn, void *ctx)
{
    rto__team t;
    memset(&t, 0, sizeof t);
    waitpoint go;
    memset(&go, 0, sizeof go);
    wp_init(&t.barrier);
    wp_init(&go);
    own_member members[RTO_THREADS_MAX];
    pthread_t ids[RTO_THREADS_MAX];
    uint32_t made = 1; /* worker 0 is the caller */
    for (uint32_t w = 1; w < want; w++) {
        members[made] = (own_member){&t, fn, ctx, made, &go};
        if (pthread_create(&ids[made], NULL, own_main, &members[made]) == 0)
            made++;
    }
    t.size = made; /* final before any worker reads it: they wait for go */
    wp_advance(&go);
    fn(ctx, made > 1 ? &t : NULL, 0, made);
    for (uint32_t w = 1; w < made; w++)
        pthread_join(ids[w], NULL);
    pthread_cond_destroy(&go.cond);
    pthread_mutex_destroy(&go.lock);
    pthread_cond_destroy(&t.barrier.cond);
    pthread_mutex_destroy(&t.barrier.lock);
}

void rto__team_run(uint32_t threads, rto_team_fn fn, void *ctx)
{
    const uint32_t want = rto__thread_count(threads);
    if (want < 2) {
        fn(ctx, NULL, 0, 1);
        return;
    }
    pthread_once(&pool_once, pool_init);
    if (pthread_mutex_trylock(&pool.busy)) {
        team_run_own(want, fn, ctx);
        return;
    }
    const uint32_t size = pool_grow(want);
    if (size < 2) {
        pthread_mutex_unlock(&pool.busy);
        fn(ctx, NULL, 0, 1);
        return;
    }
    /* The job's data first; starting it (an atomic increment) releases them to the workers. */
    pool.team.size = size;
    atomic_store(&pool.team.waiting, 0);
    pool.fn = fn;
    pool.ctx = ctx;
    atomic_store(&pool.active, pool.made);
    const uint64_t done = atomic_load(&pool.done.value);
    wp_advance(&pool.job);
    fn(ctx, &pool.team, 0, size);
    wp_wait(&pool.done, done, JOB_SPIN_NS);
    pthread_mutex_unlock(&pool.busy);
}

/* Ranges as a team job: worker w runs ranges w, w + size, ... of the t ranges fixed by the caller's request. */
typedef struct ranges_job {
    size_t n;
    uint32_t t;
    rto_range_fn fn;
    void *ctx;
} ranges_job;

static void run_ranges(void *arg, rto__team *team, uint32_t w, uint32_t size)
{
    (void)team;
    const ranges_job *j = arg;
    for (uint32_t r = w; r < j->t; r += size) {
        size_t b, e;
        rto__part(j->n, r, j->t, &b, &e);
        j->fn(j->ctx, r, b, e);
    }
}

void rto__parallel_ranges(size_t n, uint32_t threads, rto_range_fn fn, void *ctx)
{
    uint32_t t = rto__thread_count(threads);
    /* No thread for less than one item each: small calls stay in the caller's thread. */
    if ((size_t)t > n)
        t = n ? (uint32_t)n : 1;
    if (t < 2) {
        fn(ctx, 0, 0, n);
        return;
    }
    ranges_job j = {n, t, fn, ctx};
    rto__team_run(t, run_ranges, &j);
}
