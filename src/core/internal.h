/* Private helpers every stage of the library shares: printf-style checking, failure messages, allocation, key
 * access, min / max, and static thread partitioning. A stage's own helpers live in its private header
 * (sort/sort_internal.h, keys/keys_internal.h, bvh/bvh_internal.h, trace/trace_internal.h, io/io_internal.h, ...).
 * Not installed; never included by users. */
#ifndef RTO_INTERNAL_H
#define RTO_INTERNAL_H

#include "rtoracle.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>

/* Everything declared below stays inside librtoracle.so: not part of the public API, not exported. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#if defined(__GNUC__)
#define RTO_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define RTO_PRINTF(a, b)
#endif

/* Code between RTO__TARGET_BEGIN("avx2") (or another target string) and RTO__TARGET_END is compiled for that
 * instruction set, function by function, while the library itself targets baseline x86-64: the SIMD paths that run
 * only where the CPU has them (sort/bitonic_simd.c, trace/lanes.c). clang ignores GCC's target pragma; its own
 * attribute pragma gives every function in between the same target. */
#define RTO__PRAGMA(x) _Pragma(#x)
#if defined(__clang__)
#define RTO__TARGET_BEGIN(isa) RTO__PRAGMA(clang attribute push(__attribute__((target(isa))), apply_to = function))
#define RTO__TARGET_END RTO__PRAGMA(clang attribute pop)
#else
#define RTO__TARGET_BEGIN(isa) RTO__PRAGMA(GCC push_options) RTO__PRAGMA(GCC target(isa))
#define RTO__TARGET_END RTO__PRAGMA(GCC pop_options)
#endif

/** The library's name for rto_msg_set (public): writes a one-line reason into m (if non-NULL) and returns s. */
#define rto__fail rto_msg_set

/** A user's plugin opened (frame/plugin.c; program and material plugins): path must be a regular file, named as such
 * (a bare name is not looked up on the library path), dlopen'ed RTLD_NOW | RTLD_LOCAL, and its entry symbol found.
 * On success *handle and *entry are set; otherwise one line "PATH: why" and RTO_ERR_IO / RTO_ERR_UNSUPPORTED
 * (`what` names the kind of plugin in the message when the symbol is missing). */
rto_status rto__plugin_open(const char *path, const char *symbol, const char *what, void **handle, void **entry,
                            rto_msg *msg);

/** Key i of a u32 or u64 key array, widened to 64 bits. */
static inline uint64_t rto__key_get(rto_key_format f, const void *keys, size_t i)
{
    return f == RTO_KEY_U32 ? ((const uint32_t *)keys)[i] : ((const uint64_t *)keys)[i];
}

static inline void rto__key_put(rto_key_format f, void *keys, size_t i, uint64_t v)
{
    if (f == RTO_KEY_U32)
        ((uint32_t *)keys)[i] = (uint32_t)v;
    else
        ((uint64_t *)keys)[i] = v;
}

/* min / max with a fixed choice between +0 and -0 (the second operand when equal), so that unions are the same bytes
 * whether the compiler inlines minss or calls fminf. */
static inline float rto__minf(float a, float b) { return a < b ? a : b; }
static inline float rto__maxf(float a, float b) { return a > b ? a : b; }

/** Whether this CPU runs AVX2, and AVX-512 F, BW, DQ and VL (core/cpu.c): the SIMD paths chosen at run time. 0 on
 * other architectures. */
int rto__cpu_avx2(void);
int rto__cpu_avx512(void);
/** The path environment variable env names (name(i), lowest <= i < count), or -1 (unset, or another value). */
int rto__isa_named(const char *env, const char *(*name)(int), int lowest, int count);
/** The path a dispatcher runs when asked for none: paths lowest .. count - 1 are ordered from the reference (always
 * supported) to the widest; the best supported one up to cap, or up to the path environment variable env names
 * (rto__isa_named). */
int rto__isa_resolve(const char *env, const char *(*name)(int), int (*supported)(int), int lowest, int count, int cap);

/* Static thread partitioning (core/threads.c, DESIGN.md §2). */

/** Most threads a parallel stage starts. */
#define RTO_THREADS_MAX 256u
/** Work on items [begin, end) by worker `worker` (0 .. threads - 1; worker 0 runs in the calling thread). */
typedef void (*rto_range_fn)(void *ctx, uint32_t worker, size_t begin, size_t end);
/** requested, or the number of online CPUs for 0; at most RTO_THREADS_MAX. */
uint32_t rto__thread_count(uint32_t requested);
/** Splits n items into rto__thread_count(threads) contiguous ranges of equal size (+-1) (at most n) and runs fn on
 * each, range r as worker r, on a team (rto__team_run); returns when all are done. A team smaller than the ranges
 * (threads that could not be created) runs several ranges per worker: the same ranges, the same results. */
void rto__parallel_ranges(size_t n, uint32_t threads, rto_range_fn fn, void *ctx);
/** A team of threads for a job of several stages (core/threads.c): fn runs once on every worker, which meet at
 * rto__team_sync between stages. team is NULL when the team has one worker (then syncs do nothing). */
typedef struct rto__team rto__team;
typedef void (*rto_team_fn)(void *ctx, rto__team *team, uint32_t worker, uint32_t workers);
/** Runs fn on rto__thread_count(threads) workers (fewer if threads cannot be created; worker 0 is the caller) and
 * returns when all are done. */
void rto__team_run(uint32_t threads, rto_team_fn fn, void *ctx);
/** Barrier: returns when every worker of the team has called it (as many times). Memory written before it by one
 * worker is visible after it to all. */
void rto__team_sync(rto__team *team);
/** Item range [begin, end) of worker w of t over n items: [w n / t, (w + 1) n / t). */
static inline void rto__part(size_t n, uint32_t w, uint32_t t, size_t *begin, size_t *end)
{
    *begin = (size_t)((uint64_t)n * w / t);
    *end = (size_t)((uint64_t)n * (w + 1) / t);
}

/* Allocation (core/status.c). */

/** malloc of count * size bytes with an overflow check; count 0 gives a 1-byte block so NULL always means failure. */
void *rto__alloc(size_t count, size_t size);
/** rto__alloc for big buffers (frames): from 4 MiB up aligned to 2 MiB and advised as transparent huge pages, which
 * makes their first touch several times cheaper. Release with free(). */
void *rto__alloc_large(size_t count, size_t size);
/** rto__alloc aligned to a cache line (64 bytes), for arrays of 64-byte tree nodes that a traversal reads one node
 * at a time: each node then costs one line, not two. Release with free(). */
void *rto__alloc_lines(size_t count, size_t size);

/** What a reader derives from an accel's trees and keeps with it (bvh/accel.c; one slot per accel: the tracer's packed
 * copy, trace/packed.c): make(accel) runs once, on the first call, under the accel's lock (concurrent callers wait
 * for it); release frees it with the accel. NULL when make returned NULL (out of memory), then and on every later
 * call. With make NULL, only looks: what was made, or NULL. */
void *rto__accel_derived(const rto_accel *accel, void *(*make)(const rto_accel *), void (*release)(void *));
/** Adds n to the rays the tracer was given on this accel so far (it chooses a path by them) and returns the sum. */
uint64_t rto__accel_rays_traced(const rto_accel *accel, uint64_t n);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
