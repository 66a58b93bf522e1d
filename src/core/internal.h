/* Private helpers shared by the library's stages. Not installed; never included by users. */
#ifndef RTO_INTERNAL_H
#define RTO_INTERNAL_H

#include "rtoracle.h"

#include <signal.h>
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

/** The library's name for rto_msg_set (public): writes a one-line reason into m (if non-NULL) and returns s. */
#define rto__fail rto_msg_set

/** The checks every sort entry point makes of its common arguments: a known format, n within RTO_MAX_KEYS, and
 * non-NULL arrays when n > 0. */
static inline rto_status rto__sort_args_check(rto_key_format f, const void *keys, size_t n, const void *sorted,
                                             rto_msg *msg)
{
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    if ((uint64_t)n > RTO_MAX_KEYS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu keys", n,
                        (unsigned long long)RTO_MAX_KEYS);
    if (n && (!keys || !sorted))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL keys or output");
    return RTO_OK;
}

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

/** Surface area of a box given as min / max triples, in binary64; 0 for an empty box (SAH statistics). */
static inline double rto__box_area(const float *mn, const float *mx)
{
    double d[3];
    for (int a = 0; a < 3; a++) {
        d[a] = (double)mx[a] - (double)mn[a];
        if (!(d[a] >= 0))
            return 0;
    }
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/** TLAS keys whose index field is index[i] (the instance a centroid belongs to) instead of i: the keys of a subset
 * of instances, quantised over that subset's bounds. index == NULL means index[i] = i (rto_tlas_keys). */
rto_status rto__tlas_keys_indexed(const rto_vec3 *centroids, const uint32_t *index, size_t n, uint32_t *keys,
                                 rto_msg *msg);

/** The self-intersection offset of secondary rays (shadow rays, rto_frame_env.ray_offset): 1e-4 max(1, M), M the
 * largest finite magnitude among the bounds' coordinates and the camera position (trace/ray.c). */
float rto__ray_offset(const rto_aabb *bounds, const rto_camera_uniforms *u);

/** Bits needed to write v: 0 for 0, else 1 + the index of its highest set bit. */
static inline uint32_t rto__bitlen64(uint64_t v) { return v ? 64u - (uint32_t)__builtin_clzll(v) : 0u; }

/** Spreads the low 10 bits of v so that bit b lands on bit 3b (keys/morton.c's Morton codes). */
static inline uint32_t rto__spread3(uint32_t v)
{
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

/* BLAS keys in parts (keys/box_keys.c), for a team: each worker takes a static range of triangles. */

/** What one range of triangles contributes to the mesh: the union of its boxes in triangle order (rto__minf /
 * rto__maxf: the later operand kept when equal), the bounds of its centroids (the earlier kept, as rto_blas_keys),
 * and whether a centroid is not finite. Parts combine in range order with rto__key_part_merge. */
typedef struct rto__key_part {
    rto_aabb u;
    float lo[3], hi[3];
    int bad;
} rto__key_part;
void rto__key_part_init(rto__key_part *p);
void rto__key_part_merge(rto__key_part *into, const rto__key_part *p);
/** Boxes of triangles [begin, end) of a mesh (rto_mesh_triangle_aabb) into boxes[begin..end), their centroids into
 * cent[axis][begin..end), and their part. */
void rto__blas_boxes_part(const rto_mesh *mesh, size_t begin, size_t end, rto_aabb *boxes, float *const cent[3],
                          rto__key_part *part);
/** The mesh's centroid bounds are usable for keys (every centroid finite, spans within binary32). */
int rto__key_bounds_ok(const rto__key_part *all, size_t n);
/** BLAS keys [begin, end) (rto_blas_keys' bytes) from the centroids and the whole mesh's part. */
void rto__blas_keys_part(float *const cent[3], size_t begin, size_t end, const rto__key_part *all,
                         uint64_t *keys);
/** World boxes of instances [begin, end): rto_aabb_transform of their BLAS's bounds; with the part of the non-empty
 * ones (their union and centroid bounds) and their number (*keyed). */
void rto__instance_boxes_part(const rto_instance *inst, const rto_aabb *blas_bounds, size_t begin, size_t end,
                              rto_aabb *boxes, rto__key_part *part, size_t *keyed);
/** TLAS key of centroid c (rto__tlas_keys_indexed's bytes), with centroid bounds lo / hi. */
uint32_t rto__tlas_key(rto_vec3 c, const float lo[3], const float hi[3], uint32_t index);
/** TLAS keys of the non-empty boxes among [begin, end) (rto_tlas_keys_from_boxes' bytes), written from keys[first] on,
 * with the bounds of all the keyed centroids (merged parts of rto__instance_boxes_part). */
void rto__tlas_keys_part(const rto_aabb *boxes, size_t begin, size_t end, const rto__key_part *all, size_t first,
                         uint32_t *keys);
/** The sweep TLAS (rto_tlas_build_sweep's bytes) in parts: leaves [begin, end) of n_padded over n sorted keys, then
 * each level's internal nodes [begin, end) (node indices), children's level first. */
void rto__tlas_sweep_leaves(const uint32_t *sorted_keys, size_t n, size_t np, const rto_aabb *boxes,
                            rto_tlas_node *nodes, size_t begin, size_t end);
void rto__tlas_sweep_nodes(rto_tlas_node *nodes, size_t begin, size_t end);

/** rto_fast_radix_sort for a team (sort/fast_radix.c): the same bytes. Scratch the caller provides for up to W workers:
 * hist rto__radix_team_hist_words(W) u32, first W * 2048 u32, diff W u64, ordered W bytes; tmp n keys. in and out must
 * not overlap. Every worker calls it; it returns after a sync, with out sorted. */
typedef struct rto__team rto__team;
typedef struct rto__radix_team {
    rto_key_format f;
    const void *in;
    size_t n;
    void *out, *tmp;
    uint32_t *hist, *first;
    uint64_t *diff;
    uint8_t *ordered;
} rto__radix_team;
size_t rto__radix_team_hist_words(uint32_t workers);
void rto__radix_team_sort(rto__radix_team *r, rto__team *team, uint32_t worker, uint32_t workers);

/** check-sort's fast verdict (sort/sort_match.c): 1 when keys[0..n) in ascending order equal want[0..n) bit for bit,
 * 0 when they differ, -1 when out of memory. With want NULL it sorts keys into out instead (n keys, apart from keys)
 * and returns 1 or -1: the same partition, which the tests hold to qsort. threads: 0 = one per online CPU, used from
 * RTO__SORT_MATCH_TEAM_FROM keys on; the answer does not depend on it. */
#define RTO__SORT_MATCH_TEAM_FROM ((size_t)1 << 17)
int rto__sort_match(rto_key_format f, const void *keys, size_t n, const void *want, void *out, uint32_t threads);

/* The Karras builder in stages (bvh/karras.c), for a team: plan (one worker), run (every worker, between syncs),
 * finish (one worker). rto_karras_build runs them with one worker. */
typedef struct rto__karras_job {
    uint32_t lo, hi;   /* leaves of the subtree */
    uint32_t root;     /* its root node */
    uint32_t parent;   /* the root's parent */
    uint32_t height;   /* out */
} rto__karras_job;
typedef struct rto__karras_top {
    uint32_t node;
    int64_t slot[2]; /* per child: -1 leaf, j >= 0 job j, -2 - t top node t */
    uint32_t height;
} rto__karras_top;
typedef struct rto__karras {
    rto_key_format f;
    const void *keys;        /* sorted */
    size_t n;
    const rto_aabb *boxes;   /* by primitive */
    rto_bvh_node *nodes;     /* n - 1 */
    double *areas;           /* NULL, or n - 1: each node's SAH term (rto__karras_stats_depth) */
    /* filled by plan */
    uint32_t workers;
    rto__karras_job *jobs;
    size_t job_count;
    rto__karras_top *tops;
    size_t top_count;
    uint32_t depth;          /* by finish: the deepest leaf's depth */
} rto__karras;
rto_status rto__karras_plan(rto__karras *k, uint32_t workers, rto_msg *msg);
void rto__karras_run(rto__karras *k, uint32_t worker, uint32_t workers);
void rto__karras_finish(rto__karras *k);
void rto__karras_free(rto__karras *k);
/** The per-node Karras procedure for every node, then boxes bottom-up: the reference the fast builder is tested on. */
rto_status rto__karras_build_scalar(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                                   rto_bvh_node *nodes, rto_msg *msg);
/** rto_karras_stats with the depth given (the builder's) and, unless NULL, the node terms (rto__karras.areas). */
rto_bvh_stats rto__karras_stats_depth(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box, uint32_t depth,
                                      const double *areas);

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

/* Atomic output (io/atomic.c). */

/** Creates `target.tmp.PID-XXXXXX` (a directory with mode 0777, or a file with 0666 whose descriptor goes to *fd; the
 * umask applies) and lists it for rto_temporaries_remove. *tmp is malloc'ed. */
rto_status rto__tmp_create(const char *target, bool is_dir, char **tmp, int *fd, rto_msg *msg);
/** Takes a temporary off the list (after it was renamed into place or removed). */
void rto__tmp_forget(const char *tmp);
/** Blocks SIGINT, SIGTERM and SIGHUP in the calling thread while a temporary is created, renamed or removed. */
void rto__signals_hold(sigset_t *old);
void rto__signals_release(const sigset_t *old);
/**
 * Where output to path may go (*where, malloc'ed): path itself when absent (its directory must exist) or a regular
 * file / directory (is_dir); the real path for a symbolic link or "." / ".."; path written through in place
 * (*in_place) for a character device or FIFO when allow_special. Everything else is refused.
 */
rto_status rto__output_target(const char *path, bool is_dir, bool allow_special, char **where, bool *in_place,
                             rto_msg *msg);

/** A file being written atomically: fp writes to tmp, which rto__atomic_close renames to path. */
typedef struct rto_atomic_file {
    FILE *fp;
    char *path;
    char *tmp; /* NULL when written in place */
    bool in_place;
} rto_atomic_file;
rto_status rto__atomic_open(rto_atomic_file *f, const char *path, bool allow_special, rto_msg *msg);
/** Flushes, closes and renames into place; on any failure the temporary is removed. */
rto_status rto__atomic_close(rto_atomic_file *f, rto_msg *msg);
/** Closes and removes the temporary (a failed write). */
void rto__atomic_discard(rto_atomic_file *f);

/* Bundle entries that are not .npy arrays (io/bundle.c owns manifest.json; io/image.c writes and reads images). */

/** Writes name (a plain file name) into the bundle's temporary directory with write(path, image) and lists it like an
 * array: name, role, sha256 of the file written, and "image": {width, height, channels, type ("u8" / "f32")}. A
 * failure, the writer's included, is kept for rto_bundle_commit. */
rto_status rto__bundle_add_image(rto_bundle *b, const char *name, const char *role, const rto_image *image,
                                 rto_status (*write)(const char *path, const rto_image *image, rto_msg *msg),
                                 rto_msg *msg);
/** The path (malloc'ed, in *path) of the file the manifest lists as name, once its sha256 matches the manifest's. */
/** dir + "/" + name in new memory (NULL when out of memory); the caller frees it. */
char *rto__path_join(const char *dir, const char *name);
rto_status rto__bundle_checked_path(rto_bundle_reader *r, const char *name, char **path, rto_msg *msg);

/* Up-to-date bundles (io/stamp.c). */

/** The stamp text's head for a request and its source files (malloc'ed in *out), hashing each source now. *out stays
 * NULL (and RTO_OK is returned) when the bundle cannot be stamped: no build identity, or source names that do not
 * fit the record; such a bundle is simply rewritten by every run. */
rto_status rto__stamp_head(const char *request, const char *const *sources, size_t count, char **out, rto_msg *msg);
/** Stamps a finished bundle directory (manifest.json written) with head plus the digest of its files; a file system
 * without user extended attributes leaves it unstamped. head NULL: nothing. */
void rto__stamp_write(const char *dir, const char *head);
/** An 8-bit image of 1 to 4 channels as PNG file bytes (io/png_write.c, libpng; malloc'ed in *bytes). */
rto_status rto__png_encode(const rto_image *im, unsigned char **bytes, size_t *len, rto_msg *msg);
/** The image module file rtoracle would load (scene/image_module_load.c), or NULL when there is none. */
const char *rto__image_module_path(void);
/** The places a module loaded on demand is searched, in order (scene/image_module_load.c): $ENV_NAME, FILE beside the
 * running executable, <exe dir>/../RELATIVE (the install layout, so a copied install uses its own module), then the
 * build tree's and the configured install path. Returns how many (at most RTO_MODULE_PATHS); rel holds the two
 * executable-relative paths. */
#define RTO_MODULE_PATHS 5
size_t rto__module_paths(const char *env_name, const char *file, const char *relative, const char *build,
                         const char *install, const char *paths[RTO_MODULE_PATHS], char rel[2][4096]);
/** Writes an .npy file that does not exist yet (O_EXCL; inside a bundle's temporary directory, which is itself what
 * is made atomic) and, unless hex is NULL, its SHA-256, hashed from memory while writing: no second read of the file.
 * Never opens an existing file for writing. */
rto_status rto__npy_write_hashed(const char *path, const rto_npy_desc *desc, const void *data, char hex[65],
                                 rto_msg *msg);
/** The SHA-256 and size of the .npy file rto__npy_write_hashed would write for desc and data, from memory (the same
 * preamble, built by the same code); name is only for messages. */
rto_status rto__npy_hash(const char *name, const rto_npy_desc *desc, const void *data, char hex[65],
                         uint64_t *file_bytes, rto_msg *msg);

/* Input files. */

/**
 * Opens path for reading only if it is a regular file (a symbolic link is followed): a FIFO, a directory or a device
 * (/dev/zero) is refused at once, without blocking in open() and without a byte read, so no input can hang the
 * command or make it read without end. *size gets the file's size. NULL with *status set and msg written on refusal.
 */
FILE *rto__open_regular(const char *path, uint64_t *size, rto_status *status, rto_msg *msg);

/** 1 when the manifest of a bundle opened for reading lists a file of that name (on disk or not), else 0: how a
 * reader tells a file the writer did not keep from one that was removed. */
int rto__bundle_lists(rto_bundle_reader *r, const char *name);

/** rto_sort_check without its fast path: the dump and the input both sorted by the C library's qsort and analysed in
 * full, expected_keys ignored. The reference the tests hold rto_sort_check to, report for report. */
rto_status rto__sort_check_reference(const rto_sort_check_desc *desc, rto_report *report, rto_msg *msg);

/** malloc of count * size bytes with an overflow check; count 0 gives a 1-byte block so NULL always means failure. */
void *rto__alloc(size_t count, size_t size);
/** rto__alloc for big buffers (frames): from 4 MiB up aligned to 2 MiB and advised as transparent huge pages, which
 * makes their first touch several times cheaper. Release with free(). */
void *rto__alloc_large(size_t count, size_t size);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
