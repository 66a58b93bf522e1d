/* Private pieces of check-frame (rto_frame_check, DESIGN.md §9) shared by its files: the state of one check and what
 * each file provides to the others. Not installed; not exported.
 *
 *   check_frame.c   the driver: fault and artefact names, claiming faults and filling the report, the check itself
 *   frame_dump.c    reading the expected bundle and the GPU's dump (manifest, frame-wide arrays, scene, files)
 *   queue_match.c   a bounce's queue against the oracle's as multisets keyed by (pixel, kind, payloadSlot)
 *   bounce_check.c  one bounce: its counters, indirect args, queue, payloads and hits
 *   pixel_check.c   accum and image: pixel comparisons, statistics and the diff artefacts */
#ifndef RTO_FRAME_CHECK_INTERNAL_H
#define RTO_FRAME_CHECK_INTERNAL_H

#include "../core/report_internal.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#define NONE32 UINT32_MAX

/* A local bit of the not-comparable mask: a pixel with a ray in the first queue that dropped rays (on a GPU, which
 * of that queue's rays are kept is arbitrary, so any of their pixels may end up differently). */
#define MASK_DROP_QUEUE 0x80u

/* How many failing pixels the listing artefact holds per comparison. */
#define LIST_MAX 64
#define LATER_MAX 8

typedef struct pixel_diff {
    uint32_t x, y;
    float e[4], a[4];
} pixel_diff;

/* One accum or image comparison, for the report and the listing artefact. */
typedef struct pixel_stats {
    int run, failed;
    char file[RTO_BUNDLE_FILE_NAME_MAX];
    uint32_t channels;
    uint64_t compared, excluded, over;
    double max_diff;
    uint32_t max_x, max_y, max_c;
    uint32_t nlist;
    pixel_diff list[LIST_MAX];
    int have_oiio;
    rto_image_compare_result oiio;
    /* what the diff image is made from (kept only while the comparison failed) */
    rto_image expected, actual;
} pixel_stats;

typedef struct later_fault {
    rto_frame_fault f;
    int64_t bounce;
} later_fault;

typedef struct fcheck {
    const rto_frame_check_desc *desc;
    rto_report *r;
    rto_msg *msg;
    rto_bundle_reader *b;
    uint32_t w, h, depth, words; /* width, height, maxDepth, payload words */
    uint64_t cap, pixels;        /* queue capacity 2 W H, W H */
    int stage2;
    double accum_abs; /* the accum rule's absolute part: RTO__TOL_ACCUM_ABS (RTO__TOL_ACCUM_ABS_BARY: `triangle`) */
    double scale; /* M: the largest magnitude of the scene bounds and the camera position */
    double fail_percent;
    /* the bundle's frame-wide arrays */
    rto_npy e_emit, e_ind, e_cnt, e_nc;
    const uint32_t *emit;
    const uint32_t *ind;
    const rto_frame_counters *cnt;
    uint8_t *mask; /* W H: RTO_PIXEL_* | MASK_DROP_QUEUE */
    /* the dump's frame-wide arrays */
    rto_npy g_emit, g_ind, g_cnt;
    int have_g_emit, have_g_ind, have_g_cnt;
    size_t g_emit_n, g_ind_n, g_cnt_n;
    /* the scene, loaded when hits are compared (mesh scenes) */
    int scene_loaded;
    rto_scene_bundle scene;
    /* bookkeeping */
    uint32_t drop_queue; /* the first queue with drops, NONE32 if none */
    uint64_t files_compared, files_not_dumped, rays_compared;
    char not_dumped[200];
    char skipped[200];      /* dumped files that could not be compared, and why */
    char drop_skipped[160]; /* dumped queue files past a queue that dropped rays */
    later_fault later[LATER_MAX];
    uint32_t nlater;
    pixel_stats accum, image;
    int payloads_run, hits_run;
    uint32_t artifacts;
} fcheck;

/* The pairing of a bounce's queue (queue_match.c). */
typedef enum qkind { Q_DIFFERS = 0, Q_MISSING = 1, Q_EXTRA = 2, Q_DUPLICATE = 3 } qkind;

typedef struct qfinding {
    qkind kind;
    uint32_t o, g; /* oracle / GPU ray (NONE32 where there is none) */
    uint32_t count_o, count_g; /* how often the key occurs on each side */
    int field; /* Q_DIFFERS: the first differing field */
} qfinding;

typedef struct qresult {
    uint32_t *gpu_of;   /* per oracle ray: its GPU ray (fields within tolerance), NONE32 if none */
    size_t counts[4];   /* findings per qkind */
    size_t paired;
    uint32_t nfind;
    qfinding find[RTO_REPORT_MAX_ROWS]; /* the first findings, in key order */
} qresult;

/* ---------------------------------------------------------------------------------------------------------------- */
/* The report (check_frame.c)                                                                                        */

/** Records fault f at a bounce (-1: a frame-wide buffer). Returns 1 for the primary fault (the first in pipeline
 * order, as the stages are compared in that order): the caller then fills location, summary and rows. A later fault
 * is listed by class and bounce for the summary. */
int rto__fc_claim(fcheck *c, rto_frame_fault f, int64_t bounce);
/** A row of the report's table. */
void rto__fc_add_row(fcheck *c, uint64_t index, const char *field, rto_value e, rto_value a, rto_value d, rto_value t);
/** A row of two unsigned values and their signed difference. */
void rto__fc_uint_row(fcheck *c, uint64_t index, const char *field, uint64_t e, uint64_t a);
/** The pixel of a ray as location fields: pixel, and x / y when it lies in the image. */
void rto__fc_at_pixel(fcheck *c, uint32_t pixel);
/** Oracle ray i of a queue and its GPU partner as location fields: ray, gpu_ray, pixel (x, y) and slot. */
void rto__fc_at_ray(fcheck *c, const rto_wf_ray *ro, const uint32_t *gpu_of, size_t i);
/** Where a ray of queue d came from, for sentences. */
const char *rto__fc_filled_by(uint32_t d);

/* ---------------------------------------------------------------------------------------------------------------- */
/* The bundle and the dump (frame_dump.c)                                                                            */

/** dir/name, malloc'ed (NULL when out of memory). */
char *rto__fc_join(const char *dir, const char *name);
/** Appends item to a comma-separated list of capacity cap, ending it with "..." when it is full. */
void rto__fc_list_add(char *buf, size_t cap, const char *item);
/** The name of bundle file f of bounce d, written into name. */
const char *rto__fc_file_name(rto_bundle_file f, uint32_t d, char name[RTO_BUNDLE_FILE_NAME_MAX]);
/** A fault of a file of the expected bundle: "expected bundle <dir>: <file>: <text>" (RTO_ERR_PARSE). */
rto_status rto__fc_bad_expected(fcheck *c, const char *file, const char *fmt, ...) RTO_PRINTF(3, 4);
/** A fault of a file of the GPU's dump: "GPU dump <dir>: <file>: <text>" (RTO_ERR_PARSE). */
rto_status rto__fc_bad_gpu(fcheck *c, const char *file, const char *fmt, ...) RTO_PRINTF(3, 4);
/** Whether the bundle keeps a file: listed in its manifest. */
int rto__fc_exp_has(fcheck *c, const char *name);
/** Loads a bundle file (sha256 checked) and requires exactly want's dtype and shape. */
rto_status rto__fc_exp_load(fcheck *c, const char *name, const rto_npy_desc *want, rto_npy *out);
/** Whether the dump holds a file of that name (a dangling link counts: reading it then fails). */
int rto__fc_gpu_has(fcheck *c, const char *name);
/** Reads an array of the dump; *present 0 when the dump has none (not dumped, not a fault). */
rto_status rto__fc_gpu_load(fcheck *c, const char *name, rto_npy *out, int *present);
/** Reads an image of the dump: its pixels only when its size is the frame's (else a header-only image). */
rto_status rto__fc_gpu_image(fcheck *c, const char *name, rto_image *out, int *present);
/** Notes a file the dump lacks. */
void rto__fc_not_dumped(fcheck *c, const char *name);
/** Notes a dumped file that could not be compared, and why. */
void rto__fc_skipped(fcheck *c, const char *name, const char *why);
/** The manifest's kind, frame size, depth, capacity, payload size, scene kind and program. */
rto_status rto__fc_read_manifest(fcheck *c);
/** The bundle's frame-wide arrays and their agreement with each other; the not-comparable mask. */
rto_status rto__fc_read_frame_arrays(fcheck *c);
/** M, the scale of the ray-origin tolerance. */
rto_status rto__fc_read_scale(fcheck *c);
/** Marks the pixels a dropping queue makes incomparable (MASK_DROP_QUEUE). */
rto_status rto__fc_mark_drop_pixels(fcheck *c);
/** The dump's frame-wide arrays (emit counts, indirect args, frame counters), those it has. */
rto_status rto__fc_read_gpu_arrays(fcheck *c);
/** The scene a hit is re-intersected with: instances and mesh geometry, read once. */
rto_status rto__fc_load_scene(fcheck *c);
/** Opens the expected frame bundle and reads its manifest and frame-wide arrays, each checked against the others: the
 * frame bundle's reader (rto_frame_bundle_read) and the first step of rto_frame_check. */
rto_status rto__fc_read_expected(fcheck *c);
/** Frees everything a check (or a frame bundle read) holds. */
void rto__fc_free(fcheck *c);
/** Reads the dump's file of a bounce that pairs with its rays (payloads, hits) into g: 1 when there is something to
 * compare; otherwise notes why not and returns 0, with *s set on an error. */
int rto__fc_gpu_bounce_file(fcheck *c, const char *name, const rto_wf_ray *rg, rto_npy *g, rto_status *s);
/** The rays of a GPU queue dump (a dump of the whole buffer is cut to the queue's length n): *m of them. */
rto_status rto__fc_gpu_rays(fcheck *c, const char *name, const rto_npy *g, size_t n, size_t *m);
/** The queue's length on the GPU: min(its emit counter, capacity) when dumped, else the oracle's. */
size_t rto__fc_gpu_queue_len(const fcheck *c, uint32_t d);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Queues (queue_match.c)                                                                                            */

/** Pairs the oracle's n rays with the GPU's m as multisets keyed by (pixel, kind, payloadSlot). */
rto_status rto__fc_match_queue(fcheck *c, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m, qresult *q);
/** Claims and reports the queue fault of bounce d, if the pairing found any. */
void rto__fc_queue_fault(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                         const qresult *q);
/** A ray's key as text: "pixel P (x X, y Y), kind K, payloadSlot S". */
void rto__fc_key_text(const fcheck *c, const rto_wf_ray *r, char *buf, size_t cap);

/* ---------------------------------------------------------------------------------------------------------------- */
/* One bounce (bounce_check.c)                                                                                       */

/** Queue d's emit counter and the FrameCounters fields that follow from it. */
void rto__fc_step_counts(fcheck *c, uint32_t d);
/** Queue d's indirect dispatch arguments. */
void rto__fc_step_indirect(fcheck *c, uint32_t d);
/** Queue d's rays, then the payloads and hits paired with them. */
rto_status rto__fc_step_queue(fcheck *c, uint32_t d);
/** The FrameCounters fields of bounce d's TRACE pass. */
void rto__fc_step_hit_counters(fcheck *c, uint32_t d);
/** The FrameCounters fields of bounce d's SHADE pass. */
void rto__fc_step_shade_counters(fcheck *c, uint32_t d);
/** Frame-wide arrays longer than the frame: the GPU ran more queues than maxDepth + 1. */
void rto__fc_step_extra_queues(fcheck *c);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Accum and image (pixel_check.c)                                                                                   */

/** The accum (accum.npy, accum.exr) against the bundle's. */
rto_status rto__fc_step_accum(fcheck *c);
/** The 8-bit image against the bundle's. */
rto_status rto__fc_step_image(fcheck *c);
/** The diff images and the listing, for failed accum or image comparisons, when desc->artifact_dir is set. */
rto_status rto__fc_write_artifacts(fcheck *c);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
