/* Validation of a GPU's dump of a whole wavefront frame (DESIGN.md §7, §9; docs/frame.md "The GPU dump layout").
 *
 * A frame is a chain: GENERATE fills queue 0, PREP turns each queue's emit counter into indirect dispatch arguments,
 * TRACE writes one hit per queued ray, SHADE reads the hits, accumulates colour and fills the next queue, RESOLVE
 * turns accum into the image. A wrong buffer spoils everything downstream of it, so a report that said "the image
 * differs" would send the reader hunting through five kernels. The dump is therefore compared buffer by buffer in
 * that order, and the primary fault is the first stage (and bounce) that diverges; later divergences are listed, as
 * they are usually its consequences.
 *
 * What a GPU may legitimately do differently decides each rule: it appends rays with atomics, so a queue is a
 * multiset keyed by (pixel, kind, payloadSlot) and hits and payloads travel with their ray, not with a position; it
 * may fuse multiply-adds, so floats compare within the §9 tolerances; it races when two rays accumulate into one
 * pixel in one SHADE pass, and it drops arbitrary rays at capacity, so such pixels (and the queues from a dropping
 * one on) cannot be compared at all and are reported as not comparable instead of failing. */
#include "report_internal.h"
#include "core/json.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

const char *rto_frame_fault_name(rto_frame_fault f)
{
    switch (f) {
    case RTO_FRAME_OK: return "none";
    case RTO_FRAME_COUNTS: return "emit-count";
    case RTO_FRAME_INDIRECT: return "indirect-args";
    case RTO_FRAME_QUEUE: return "queue";
    case RTO_FRAME_PAYLOAD: return "payload";
    case RTO_FRAME_HITS: return "hits";
    case RTO_FRAME_ACCUM: return "accum";
    case RTO_FRAME_IMAGE: return "image";
    }
    return "unknown";
}

const char *rto_frame_artifact_name(uint32_t artifact)
{
    switch (artifact) {
    case RTO_FRAME_ARTIFACT_ACCUM_DIFF: return "check-frame.accum_diff.exr";
    case RTO_FRAME_ARTIFACT_IMAGE_DIFF: return "check-frame.image_diff.png";
    case RTO_FRAME_ARTIFACT_LISTING: return "check-frame.diffs.json";
    default: return NULL;
    }
}

/* Limits of what a frame bundle can describe: what rto_frame_render accepts (2^26 pixels, maxDepth 64). */
#define FRAME_MAX_PIXELS (UINT64_C(1) << 26)
#define FRAME_MAX_DEPTH 64u
#define NONE32 UINT32_MAX

/* Tolerances (docs/frame.md "The GPU dump layout"). Ray floats: §9's relative 1e-5 of hit t, carried to the
 * quantities a SHADE pass derives from a hit. Accum: §9. Image: §9, the percentage configurable. */
#define RAY_REL 1e-5
#define ACCUM_REL 1e-4
#define ACCUM_ABS 1e-6
/* The absolute part of the accum rule for a program whose colours are barycentrics (the built-in `triangle`, whose
 * red is (1 - u) - v): the barycentric rule of the hit records, twice, since a GPU's u and v may each differ by 1e-4
 * (§9). */
#define ACCUM_ABS_BARY 2e-4
#define IMAGE_STEP 1
#define IMAGE_PERCENT_DEFAULT 0.1
/* Payload words are compared as binary32 only where both read as plausible floats: 0, or a magnitude of at least
 * 2^-64. An integer below 2^28 (a pixel, a slot, a count) reads as a denormal or a float under 2^-64, so it is
 * compared bit for bit and never passes as "close". */
#define PAYLOAD_FLOAT_MIN 5.42101086242752217e-20 /* 2^-64 */

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
    double accum_abs; /* ACCUM_ABS, or ACCUM_ABS_BARY for `triangle` */
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
    rto_npy inst;
    rto_npy *mesh_npy;
    rto_mesh *meshes;
    uint32_t nmeshes, capmeshes;
    rto_instance *instances;
    uint32_t ninst;
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

/* ---------------------------------------------------------------------------------------------------------------- */
/* Small helpers                                                                                                    */

static char *join(const char *dir, const char *name)
{
    const size_t n = strlen(dir) + strlen(name) + 2;
    char *p = malloc(n);
    if (p)
        snprintf(p, n, "%s/%s", dir, name);
    return p;
}

static void list_add(char *buf, size_t cap, const char *item)
{
    const size_t used = strlen(buf);
    if (used + 4 >= cap)
        return;
    if (used && !strcmp(buf + used - 3, "..."))
        return;
    int n = snprintf(buf + used, cap - used, "%s%s", used ? ", " : "", item);
    if (n < 0 || (size_t)n >= cap - used) /* cut: end the list visibly */
        snprintf(buf + (used > cap - 4 ? cap - 4 : used), 4, "...");
}

static const char *file_name(rto_bundle_file f, uint32_t d, char name[RTO_BUNDLE_FILE_NAME_MAX])
{
    if (rto_bundle_file_name(f, d, name, RTO_BUNDLE_FILE_NAME_MAX))
        snprintf(name, RTO_BUNDLE_FILE_NAME_MAX, "(file %d)", (int)f); /* unreachable: every name fits */
    return name;
}

/* A one-line fault of an input file: "<where> <dir>: <file>: <text>". */
static rto_status bad_file(fcheck *c, const char *where, const char *dir, const char *file, const char *fmt,
                           va_list ap)
{
    char text[360];
    vsnprintf(text, sizeof text, fmt, ap);
    return rto__fail(c->msg, RTO_ERR_PARSE, "%s %s: %s: %s", where, dir, file, text);
}

static rto_status bad_expected(fcheck *c, const char *file, const char *fmt, ...) RTO_PRINTF(3, 4);
static rto_status bad_expected(fcheck *c, const char *file, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    const rto_status s = bad_file(c, "expected bundle", c->desc->expected_dir, file, fmt, ap);
    va_end(ap);
    return s;
}

static rto_status bad_gpu(fcheck *c, const char *file, const char *fmt, ...) RTO_PRINTF(3, 4);
static rto_status bad_gpu(fcheck *c, const char *file, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    const rto_status s = bad_file(c, "GPU dump", c->desc->gpu_dir, file, fmt, ap);
    va_end(ap);
    return s;
}

static int same_desc(const rto_npy_desc *have, const rto_npy_desc *want)
{
    if (have->dtype != want->dtype || have->ndim != want->ndim)
        return 0;
    for (uint32_t i = 0; i < want->ndim && i < RTO_NPY_MAX_DIMS; i++)
        if (have->shape[i] != want->shape[i])
            return 0;
    if (want->dtype != RTO_DTYPE_STRUCT)
        return 1;
    if (have->nfields != want->nfields)
        return 0;
    for (uint32_t i = 0; i < want->nfields && i < RTO_NPY_MAX_FIELDS; i++) {
        const rto_npy_field *a = &have->fields[i], *b = &want->fields[i];
        if (a->type != b->type || a->count != b->count || a->offset != b->offset || strcmp(a->name, b->name))
            return 0;
    }
    return 1;
}

/* "dtype <u4, shape (3, 3)" or "64-byte records, shape (12,)": what an array holds, for messages. */
static const char *describe(const rto_npy_desc *d, char *buf, size_t cap)
{
    char descr[256];
    int used;
    if (d->dtype == RTO_DTYPE_STRUCT)
        used = snprintf(buf, cap, "%zu-byte records, shape (", rto_npy_itemsize(d));
    else
        used = snprintf(buf, cap, "dtype %s, shape (", rto_npy_descr(d, descr, sizeof descr) ? "?" : descr);
    for (uint32_t i = 0; used >= 0 && (size_t)used < cap && i < d->ndim && i < RTO_NPY_MAX_DIMS; i++)
        used += snprintf(buf + used, cap - (size_t)used, "%s%llu%s", i ? " " : "", (unsigned long long)d->shape[i],
                         d->ndim == 1 || i + 1 < d->ndim ? "," : "");
    if (used >= 0 && (size_t)used < cap)
        snprintf(buf + used, cap - (size_t)used, ")");
    return buf;
}

/* Whether the bundle keeps a file: listed in its manifest (a listed file that is gone is a damaged bundle, refused
 * when read). */
static int exp_has(fcheck *c, const char *name) { return rto__bundle_lists(c->b, name); }

/* Loads a bundle file (sha256 checked) and requires exactly want's dtype and shape. */
static rto_status exp_load(fcheck *c, const char *name, const rto_npy_desc *want, rto_npy *out)
{
    memset(out, 0, sizeof *out);
    if (!exp_has(c, name))
        return bad_expected(c, name, "not listed in its manifest.json");
    rto_msg m = {{0}};
    rto_status s = rto_bundle_read_name(c->b, name, out, &m);
    if (s)
        return rto__fail(c->msg, s, "expected bundle %s: %s: %s", c->desc->expected_dir, name, m.text);
    if (!same_desc(&out->desc, want)) {
        char have[160], need[160];
        return bad_expected(c, name, "holds %s; expected %s", describe(&out->desc, have, sizeof have),
                            describe(want, need, sizeof need));
    }
    return RTO_OK;
}

/* Whether the dump holds a file of that name (a dangling link counts: reading it then fails). */
static int gpu_has(fcheck *c, const char *name)
{
    char *path = join(c->desc->gpu_dir, name);
    struct stat st;
    const int has = path && lstat(path, &st) == 0;
    free(path);
    return has;
}

static rto_status read_npy(const char *path, void *out, rto_msg *m) { return rto_npy_read(path, out, m); }
static rto_status probe_image(const char *path, void *out, rto_msg *m) { return rto_image_probe(path, out, m); }

/* Reads a file of the dump with read into out; *present 0 when the dump has none (not dumped, not a fault). */
static rto_status gpu_read(fcheck *c, const char *name, rto_status (*read)(const char *, void *, rto_msg *), void *out,
                           int *present)
{
    *present = 0;
    char *path = join(c->desc->gpu_dir, name);
    if (!path)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    struct stat st;
    if (lstat(path, &st) != 0) {
        const int e = errno;
        free(path);
        if (e == ENOENT)
            return RTO_OK;
        return rto__fail(c->msg, RTO_ERR_IO, "GPU dump %s: %s: %s", c->desc->gpu_dir, name, strerror(e));
    }
    rto_msg m = {{0}};
    rto_status s = read(path, out, &m);
    free(path);
    if (s)
        return rto__fail(c->msg, s, "GPU dump %s: %s: %s", c->desc->gpu_dir, name, m.text);
    *present = 1;
    return RTO_OK;
}

static rto_status gpu_load(fcheck *c, const char *name, rto_npy *out, int *present)
{
    memset(out, 0, sizeof *out);
    return gpu_read(c, name, read_npy, out, present);
}

/* A dump's image: its header first; its pixels only when its size is the frame's, decoding no more than that size
 * needs (a 16384 x 16384 image.png of a few kilobytes is refused from its header, not decoded into gigabytes). A
 * header-only image (pixels NULL) comes back when the size differs: the callers name the size and read no pixel. */
static rto_status gpu_image(fcheck *c, const char *name, rto_image *out, int *present)
{
    memset(out, 0, sizeof *out);
    rto_status s = gpu_read(c, name, probe_image, out, present);
    if (s || !*present || out->width != c->w || out->height != c->h)
        return s;
    const size_t budget = (size_t)c->pixels * out->channels * (out->type == RTO_PIXEL_U8 ? 1 : sizeof(float));
    char *path = join(c->desc->gpu_dir, name);
    if (!path)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_msg m = {{0}};
    s = rto_image_read_budget(path, budget, out, &m);
    free(path);
    if (s)
        return rto__fail(c->msg, s, "GPU dump %s: %s: %s", c->desc->gpu_dir, name, m.text);
    return RTO_OK;
}

/* The note for a file the dump lacks, unless the bundle lacks it too (then nothing was expected of the GPU). */
static void not_dumped(fcheck *c, const char *name)
{
    c->files_not_dumped++;
    list_add(c->not_dumped, sizeof c->not_dumped, name);
}

static void skipped(fcheck *c, const char *name, const char *why)
{
    char item[RTO_BUNDLE_FILE_NAME_MAX + 48];
    snprintf(item, sizeof item, "%s (%s)", name, why);
    list_add(c->skipped, sizeof c->skipped, item);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Faults                                                                                                           */

static const char *check_of(rto_frame_fault f)
{
    switch (f) {
    case RTO_FRAME_COUNTS: return "counts";
    case RTO_FRAME_INDIRECT: return "indirect";
    case RTO_FRAME_QUEUE: return "queues";
    case RTO_FRAME_PAYLOAD: return "payloads";
    case RTO_FRAME_HITS: return "hits";
    case RTO_FRAME_ACCUM: return "accum";
    case RTO_FRAME_IMAGE: return "image";
    case RTO_FRAME_OK: break;
    }
    return "";
}

static const char *const check_names[] = {"counts", "indirect", "queues", "payloads", "hits", "accum", "image"};

/* Records fault f at a bounce (-1: a frame-wide buffer). Returns 1 for the primary fault (the first in pipeline
 * order, as the stages are compared in that order): the caller then fills location, summary and rows. A later fault
 * is listed by class and bounce for the summary. */
static int claim(fcheck *c, rto_frame_fault f, int64_t bounce)
{
    rto__report_mark(c->r, check_of(f), RTO_CHECK_FAILED);
    if (rto__report_claim(c->r, (int)f, rto_frame_fault_name(f))) {
        if (bounce >= 0)
            rto__report_at(c->r, "bounce", bounce);
        static const char *const titles[][2] = {
            {"", ""},
            {"counters", "queue"},
            {"indirect args", "queue"},
            {"key counts and ray fields", "ray"},
            {"payload words", "ray"},
            {"hit records", "ray"},
            {"accum channels", "pixel"},
            {"image channels", "pixel"},
        };
        rto__report_table(c->r, titles[f][0], titles[f][1]);
        return 1;
    }
    for (uint32_t i = 0; i < c->nlater; i++)
        if (c->later[i].f == f && c->later[i].bounce == bounce)
            return 0;
    if (c->nlater < LATER_MAX)
        c->later[c->nlater++] = (later_fault){f, bounce};
    return 0;
}

static void add_row(fcheck *c, uint64_t index, const char *field, rto_value e, rto_value a, rto_value d, rto_value t)
{
    rto_report_row *row = rto__report_row_add(c->r, index, field);
    if (!row)
        return;
    row->expected = e;
    row->actual = a;
    row->diff = d;
    row->tolerance = t;
}

static void uint_row(fcheck *c, uint64_t index, const char *field, uint64_t e, uint64_t a)
{
    add_row(c, index, field, rto__val_uint(e), rto__val_uint(a), rto__val_int((int64_t)a - (int64_t)e), rto__val_none());
}

/* The pixel of a ray as location fields: pixel, and x / y when it lies in the image. */
static void at_pixel(fcheck *c, uint32_t pixel)
{
    rto__report_at(c->r, "pixel", pixel);
    if (pixel < c->pixels) {
        rto__report_at(c->r, "x", pixel % c->w);
        rto__report_at(c->r, "y", pixel / c->w);
    }
}

/* Oracle ray i of a queue and its GPU partner as location fields: ray, gpu_ray, pixel (x, y) and slot. */
static void at_ray(fcheck *c, const rto_wf_ray *ro, const uint32_t *gpu_of, size_t i)
{
    rto__report_at(c->r, "ray", (int64_t)i);
    rto__report_at(c->r, "gpu_ray", gpu_of[i]);
    at_pixel(c, ro[i].pixel);
    rto__report_at(c->r, "slot", ro[i].payload_slot);
}

/* Where a ray of queue d came from, for sentences. */
static const char *filled_by(uint32_t d) { return d == 0 ? "GENERATE" : "the SHADE pass of the bounce before"; }

/* ---------------------------------------------------------------------------------------------------------------- */
/* The bundle                                                                                                       */

static rto_status manifest_uint(fcheck *c, const char *key, uint64_t lo, uint64_t hi, uint64_t *out)
{
    int64_t v = -1;
    if (!rto_bundle_get_int(c->b, "frame", key, &v) || v < 0 || (uint64_t)v < lo || (uint64_t)v > hi)
        return bad_expected(c, "manifest.json", "frame.%s is missing or outside %" PRIu64 " .. %" PRIu64, key, lo,
                            hi);
    *out = (uint64_t)v;
    return RTO_OK;
}

static rto_status read_manifest(fcheck *c)
{
    const char *kind = rto_bundle_get_str(c->b, "", "kind");
    if (!kind || strcmp(kind, "frame"))
        return rto__fail(c->msg, RTO_ERR_INVALID_ARGUMENT, "expected bundle %s is a%s %s bundle, not a frame bundle "
                        "(rtoracle render)", c->desc->expected_dir, kind && strchr("aeiou", kind[0]) ? "n" : "",
                        kind ? kind : "(kind-less)");
    uint64_t w = 0, h = 0, d = 0, cap = 0, ps = 0;
    rto_status s;
    if ((s = manifest_uint(c, "width", 1, FRAME_MAX_PIXELS, &w)) ||
        (s = manifest_uint(c, "height", 1, FRAME_MAX_PIXELS, &h)))
        return s;
    if (w * h > FRAME_MAX_PIXELS)
        return bad_expected(c, "manifest.json", "a frame of %" PRIu64 " x %" PRIu64 " pixels is larger than 2^26", w,
                            h);
    if ((s = manifest_uint(c, "max_depth", 1, FRAME_MAX_DEPTH, &d)) ||
        (s = manifest_uint(c, "capacity", 2 * w * h, 2 * w * h, &cap)) ||
        (s = manifest_uint(c, "payload_size", 0, RTO_PAYLOAD_MAX, &ps)))
        return s;
    if (ps % 4)
        return bad_expected(c, "manifest.json", "frame.payload_size %" PRIu64 " is not a multiple of 4", ps);
    c->w = (uint32_t)w;
    c->h = (uint32_t)h;
    c->depth = (uint32_t)d;
    c->cap = cap;
    c->pixels = w * h;
    c->words = (uint32_t)(ps / 4);
    const char *sk = rto_bundle_get_str(c->b, "frame", "scene_kind");
    int64_t ski = -1;
    if (sk && !strcmp(sk, "stage2"))
        c->stage2 = 1;
    else if (sk && !strcmp(sk, "mesh"))
        c->stage2 = 0;
    else if (!sk && rto_bundle_get_int(c->b, "frame", "scene_kind", &ski) && (ski == 0 || ski == 1))
        c->stage2 = ski == 1;
    else
        return bad_expected(c, "manifest.json", "frame.scene_kind is missing or neither \"mesh\" nor \"stage2\"");
    const char *program = rto_bundle_get_str(c->b, "program", "name");
    c->accum_abs = program && !strcmp(program, "triangle") && !c->stage2 ? ACCUM_ABS_BARY : ACCUM_ABS;
    return RTO_OK;
}

static double max_abs(double m, float v) { return isfinite(v) && fabs((double)v) > m ? fabs((double)v) : m; }

/* M, the scale of the ray-origin tolerance: the largest magnitude of the camera position and the scene bounds (the
 * stage2 scene's ground slab reaches 10 from the origin). */
static rto_status read_scale(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto_npy cam = {0}, boxes = {0};
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_CAMERA, 1);
    rto_status s = exp_load(c, file_name(RTO_FILE_CAMERA, 0, name), &want, &cam);
    if (s)
        return s;
    rto_camera_uniforms u;
    memcpy(&u, cam.data, sizeof u);
    rto_npy_free(&cam);
    double m = 1.0;
    for (int k = 0; k < 3; k++)
        m = max_abs(m, u.position[k]);
    if (c->stage2) {
        m = m > 10.0 ? m : 10.0;
    } else {
        int64_t n = -1;
        if (!rto_bundle_get_int(c->b, "counts", "instances", &n) || n < 0 || n > (int64_t)RTO_TLAS_MAX_INSTANCES)
            return bad_expected(c, "manifest.json", "counts.instances is missing or outside 0 .. %u",
                                RTO_TLAS_MAX_INSTANCES);
        want = rto_layout_desc(RTO_LAYOUT_AABB, (uint64_t)n);
        if ((s = exp_load(c, file_name(RTO_FILE_INSTANCE_AABBS, 0, name), &want, &boxes)))
            return s;
        const float *v = boxes.data;
        for (size_t k = 0; k < 6 * (size_t)n; k++)
            m = max_abs(m, v[k]);
        rto_npy_free(&boxes);
    }
    c->scale = m;
    return RTO_OK;
}

static uint32_t ceil64(uint32_t n) { return n / 64 + (n % 64 != 0); }

/* The frame-wide arrays every frame bundle has, and their agreement with each other: what the dump is compared with
 * must itself be right, so an edited bundle is refused rather than blamed on the GPU. */
static rto_status read_frame_arrays(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const uint64_t q = (uint64_t)c->depth + 1;
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_U32, 1, q, 0, 0);
    rto_status s = exp_load(c, file_name(RTO_FILE_EMIT_COUNTS, 0, name), &d, &c->e_emit);
    if (s)
        return s;
    d = rto_npy_desc_array(RTO_DTYPE_U32, 2, q, 3, 0);
    if ((s = exp_load(c, file_name(RTO_FILE_INDIRECT_ARGS, 0, name), &d, &c->e_ind)))
        return s;
    d = rto_layout_desc(RTO_LAYOUT_FRAME_COUNTERS, q);
    if ((s = exp_load(c, file_name(RTO_FILE_FRAME_COUNTERS, 0, name), &d, &c->e_cnt)))
        return s;
    d = rto_npy_desc_array(RTO_DTYPE_U8, 2, c->h, c->w, 0);
    if ((s = exp_load(c, file_name(RTO_FILE_NOT_COMPARABLE, 0, name), &d, &c->e_nc)))
        return s;
    c->emit = c->e_emit.data;
    c->ind = c->e_ind.data;
    c->cnt = c->e_cnt.data;
    for (uint32_t k = 0; k < q; k++) {
        const rto_frame_counters *fc = &c->cnt[k];
        const uint32_t queued = (uint64_t)fc->emitted < c->cap ? fc->emitted : (uint32_t)c->cap;
        if (fc->emitted != c->emit[k])
            return bad_expected(c, file_name(RTO_FILE_FRAME_COUNTERS, 0, name),
                                "queue %" PRIu32 ": emitted %" PRIu32 ", but emit_counts.npy says %" PRIu32, k,
                                fc->emitted, c->emit[k]);
        if (fc->queued != queued || fc->dropped != fc->emitted - queued)
            return bad_expected(c, name, "queue %" PRIu32 ": queued %" PRIu32 " and dropped %" PRIu32 " do not follow "
                                "from emitted %" PRIu32 " and the capacity %" PRIu64, k, fc->queued, fc->dropped,
                                fc->emitted, c->cap);
        if (fc->traced != (k < c->depth ? queued : 0) || (uint64_t)fc->hits + fc->misses != fc->traced)
            return bad_expected(c, name, "queue %" PRIu32 ": traced %" PRIu32 ", hits %" PRIu32 " and misses %" PRIu32
                                " do not follow from queued %" PRIu32, k, fc->traced, fc->hits, fc->misses, queued);
        const uint32_t *a = &c->ind[3 * k];
        if (a[0] != ceil64(queued) || a[1] != 1 || a[2] != 1)
            return bad_expected(c, file_name(RTO_FILE_INDIRECT_ARGS, 0, name),
                                "queue %" PRIu32 ": [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] is not [ceil(%" PRIu32
                                " / 64), 1, 1]", k, a[0], a[1], a[2], queued);
        if (fc->dropped && c->drop_queue == NONE32)
            c->drop_queue = k;
    }
    const uint8_t *nc = c->e_nc.data;
    for (uint64_t p = 0; p < c->pixels; p++)
        if (nc[p] & ~(RTO_PIXEL_CONFLICT | RTO_PIXEL_DROPPED))
            return bad_expected(c, file_name(RTO_FILE_NOT_COMPARABLE, 0, name),
                                "pixel %" PRIu64 " holds 0x%02x; only RTO_PIXEL_CONFLICT (1) and RTO_PIXEL_DROPPED (2) "
                                "are defined", p, nc[p]);
    c->mask = rto__alloc(c->pixels, 1);
    if (!c->mask)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(c->mask, nc, c->pixels);
    return RTO_OK;
}

/* The scene a hit is re-intersected with (rto_hits_check): instances and mesh geometry, as check-hits reads them.
 * Read once, on the first bounce whose hits are compared. */
static rto_status load_scene(fcheck *c)
{
    if (c->scene_loaded)
        return RTO_OK;
    c->scene_loaded = 1;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    int64_t meshes = -1, instances = -1;
    if (!rto_bundle_get_int(c->b, "counts", "meshes", &meshes) || meshes < 0 || meshes > (int64_t)UINT32_MAX ||
        !rto_bundle_get_int(c->b, "counts", "instances", &instances) || instances < 0 ||
        instances > (int64_t)RTO_TLAS_MAX_INSTANCES)
        return bad_expected(c, "manifest.json", "counts.meshes or counts.instances is missing or out of range");
    for (uint32_t m = 0; m < (uint32_t)meshes; m++) {
        /* grown as files are found: a manifest claiming millions of meshes costs nothing before the first missing */
        if (m == c->capmeshes) {
            const uint32_t cap = c->capmeshes ? 2 * c->capmeshes : 16;
            rto_mesh *mm = realloc(c->meshes, (size_t)cap * sizeof *mm);
            if (mm)
                c->meshes = mm;
            rto_npy *np = realloc(c->mesh_npy, 2 * (size_t)cap * sizeof *np);
            if (np)
                c->mesh_npy = np;
            if (!mm || !np)
                return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
            c->capmeshes = cap;
        }
        rto_npy *pos = &c->mesh_npy[2 * m], *idx = &c->mesh_npy[2 * m + 1];
        memset(pos, 0, sizeof *pos);
        memset(idx, 0, sizeof *idx);
        c->nmeshes = m + 1;
        char section[32], pname[RTO_BUNDLE_FILE_NAME_MAX];
        snprintf(section, sizeof section, "blas_%" PRIu32, m);
        int64_t t = -1;
        if (!rto_bundle_get_int(c->b, section, "triangles", &t) || t < 0 || t > (int64_t)UINT32_MAX)
            return bad_expected(c, "manifest.json", "%s.triangles is missing or out of range", section);
        file_name(RTO_FILE_MESH_POSITIONS, m, pname);
        if (!exp_has(c, pname))
            return bad_expected(c, pname, "not listed in its manifest.json");
        rto_msg mm = {{0}};
        rto_status s = rto_bundle_read_name(c->b, pname, pos, &mm);
        if (s)
            return rto__fail(c->msg, s, "expected bundle %s: %s: %s", c->desc->expected_dir, pname, mm.text);
        rto_npy_desc pd = rto_npy_desc_array(RTO_DTYPE_F32, 2, pos->desc.ndim == 2 ? pos->desc.shape[0] : 0, 3, 0);
        if (!same_desc(&pos->desc, &pd) || pos->desc.shape[0] > UINT32_MAX) {
            char have[160];
            return bad_expected(c, pname, "holds %s; expected dtype <f4, shape (N, 3)",
                                describe(&pos->desc, have, sizeof have));
        }
        rto_npy_desc id = rto_npy_desc_array(RTO_DTYPE_U32, 2, (uint64_t)t, 3, 0);
        if ((s = exp_load(c, file_name(RTO_FILE_MESH_INDICES, m, name), &id, idx)))
            return s;
        const float *pv = pos->data;
        for (size_t k = 0; k < 3 * (size_t)pos->desc.shape[0]; k++)
            if (!isfinite(pv[k]))
                return bad_expected(c, pname, "a vertex position is not finite");
        rto_mesh *mesh = &c->meshes[m];
        memset(mesh, 0, sizeof *mesh);
        snprintf(mesh->name, sizeof mesh->name, "mesh %" PRIu32, m);
        mesh->vertex_count = (uint32_t)pos->desc.shape[0];
        mesh->positions = pos->data;
        mesh->triangle_count = (uint32_t)t;
        mesh->indices = idx->data;
        mesh->material = -1;
    }
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_INSTANCE, (uint64_t)instances);
    rto_status s = exp_load(c, file_name(RTO_FILE_INSTANCES, 0, name), &want, &c->inst);
    if (s)
        return s;
    c->instances = rto__alloc((size_t)instances, sizeof *c->instances);
    if (!c->instances)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t i = 0; i < (size_t)instances; i++) {
        rto_instance_record rec;
        memcpy(&rec, (const unsigned char *)c->inst.data + i * sizeof rec, sizeof rec);
        if (rec.blas >= c->nmeshes)
            return bad_expected(c, name, "instance %zu names BLAS %" PRIu32 "; the bundle has %" PRIu32 " meshes", i,
                                rec.blas, c->nmeshes);
        for (int k = 0; k < 12; k++)
            if (!isfinite((&rec.obj_to_world[0][0])[k]) || !isfinite((&rec.world_to_obj[0][0])[k]))
                return bad_expected(c, name, "a transform of instance %zu is not finite", i);
        c->instances[i] = rto_instance_from_record(&rec);
    }
    c->ninst = (uint32_t)instances;
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The dump's frame-wide arrays                                                                                     */

static rto_status read_gpu_arrays(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], have[160];
    rto_status s = gpu_load(c, file_name(RTO_FILE_EMIT_COUNTS, 0, name), &c->g_emit, &c->have_g_emit);
    if (s)
        return s;
    if (c->have_g_emit) {
        const rto_npy_desc *d = &c->g_emit.desc;
        if (d->dtype != RTO_DTYPE_U32 || d->ndim != 1)
            return bad_gpu(c, name, "holds %s; expected dtype <u4, shape (maxDepth + 1,)",
                           describe(d, have, sizeof have));
        c->g_emit_n = (size_t)d->shape[0];
    } else {
        not_dumped(c, name);
    }
    if ((s = gpu_load(c, file_name(RTO_FILE_INDIRECT_ARGS, 0, name), &c->g_ind, &c->have_g_ind)))
        return s;
    if (c->have_g_ind) {
        /* (queues, 3) as written, or the raw buffer of 3 words per queue */
        const rto_npy_desc *d = &c->g_ind.desc;
        const int shape_ok = (d->ndim == 2 && d->shape[1] == 3) || (d->ndim == 1 && d->shape[0] % 3 == 0);
        if (d->dtype != RTO_DTYPE_U32 || !shape_ok)
            return bad_gpu(c, name, "holds %s; expected dtype <u4, shape (maxDepth + 1, 3) or (3 * (maxDepth + 1),)",
                           describe(d, have, sizeof have));
        c->g_ind_n = (size_t)(d->ndim == 2 ? d->shape[0] : d->shape[0] / 3);
    } else {
        not_dumped(c, name);
    }
    if ((s = gpu_load(c, file_name(RTO_FILE_FRAME_COUNTERS, 0, name), &c->g_cnt, &c->have_g_cnt)))
        return s;
    if (c->have_g_cnt) {
        rto_msg m = {{0}};
        if (rto_layout_accept(RTO_LAYOUT_FRAME_COUNTERS, &c->g_cnt, &c->g_cnt_n, &m))
            return bad_gpu(c, name, "%s", m.text);
    }
    /* frame_counters.npy is optional for a GPU (its emit counter is in emit_counts.npy): never "not dumped" */
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Counts and indirect args                                                                                         */

typedef struct count_diff {
    const char *field;
    uint32_t e, a;
} count_diff;

/* Reports the differing counters of queue d (f: which stage they belong to). */
static void counts_fault(fcheck *c, rto_frame_fault f, uint32_t d, const count_diff *x, uint32_t nx, const char *what)
{
    if (!nx || !claim(c, f, d))
        return;
    for (uint32_t k = 0; k < nx; k++)
        uint_row(c, d, x[k].field, x[k].e, x[k].a);
    rto__report_summary(c->r, "%s: queue %" PRIu32 ": %s %" PRIu32 " in the GPU's dump, %" PRIu32
                       " in the oracle's (%s)", rto_frame_fault_name(f), d, x[0].field, x[0].a, x[0].e, what);
    if (c->drop_queue != NONE32 && d > c->drop_queue)
        rto__report_append(c->r, " [queue %" PRIu32 " dropped rays; on a GPU the rays kept there, and so the counts "
                          "after it, may differ]", c->drop_queue);
}

/* A frame-wide array of the dump that ends before queue d: claims fault f with its length n (what: the row
 * field, unit: what its entries count). Returns whether f was claimed. */
static int short_array(fcheck *c, rto_frame_fault f, uint32_t d, const char *what, const char *file, size_t n,
                       const char *unit)
{
    if (!claim(c, f, d))
        return 0;
    uint_row(c, d, what, (uint64_t)c->depth + 1, n);
    rto__report_summary(c->r, "%s: queue %" PRIu32 ": the GPU's %s ends after %zu %s; the frame has %" PRIu32,
                       rto_frame_fault_name(f), d, file, n, unit, c->depth + 1);
    return 1;
}

/* A FrameCounters field of the dump, row d. */
static uint32_t gcnt(const fcheck *c, uint32_t d, size_t offset)
{
    uint32_t v;
    memcpy(&v, (const unsigned char *)c->g_cnt.data + (size_t)d * sizeof(rto_frame_counters) + offset, sizeof v);
    return v;
}

#define CNT_FIELD(f) {#f, offsetof(rto_frame_counters, f)}
typedef struct cnt_field {
    const char *name;
    size_t offset;
} cnt_field;

/* Compares FrameCounters fields of row d; the differing ones go into x. */
static uint32_t compare_counters(const fcheck *c, uint32_t d, const cnt_field *fields, size_t nf, count_diff *x,
                                 uint32_t nx)
{
    for (size_t k = 0; k < nf && c->have_g_cnt && d < c->g_cnt_n; k++) {
        uint32_t e;
        memcpy(&e, (const unsigned char *)&c->cnt[d] + fields[k].offset, sizeof e);
        const uint32_t a = gcnt(c, d, fields[k].offset);
        if (a != e)
            x[nx++] = (count_diff){fields[k].name, e, a};
    }
    return nx;
}

static void step_counts(fcheck *c, uint32_t d)
{
    count_diff x[8];
    uint32_t nx = 0;
    if (c->have_g_emit) {
        if (d < c->g_emit_n) {
            const uint32_t a = ((const uint32_t *)c->g_emit.data)[d];
            if (a != c->emit[d])
                x[nx++] = (count_diff){"emit_counts", c->emit[d], a};
        } else if (short_array(c, RTO_FRAME_COUNTS, d, "emit_counts entries", "emit_counts.npy", c->g_emit_n,
                               "queue(s)")) {
            return;
        }
    }
    static const cnt_field emit_fields[] = {CNT_FIELD(emitted), CNT_FIELD(queued), CNT_FIELD(dropped),
                                            CNT_FIELD(refused)};
    if (c->have_g_cnt && d >= c->g_cnt_n) {
        short_array(c, RTO_FRAME_COUNTS, d, "frame_counters rows", "frame_counters.npy", c->g_cnt_n, "row(s)");
        return;
    }
    /* the emit counter itself, then the FrameCounters fields that follow from it */
    nx = compare_counters(c, d, emit_fields, 4, x, nx);
    char what[96];
    snprintf(what, sizeof what, "the emit counter of queue %" PRIu32 ", filled by %s", d, filled_by(d));
    counts_fault(c, RTO_FRAME_COUNTS, d, x, nx, what);
}

static void step_indirect(fcheck *c, uint32_t d)
{
    if (!c->have_g_ind)
        return;
    const uint32_t *e = &c->ind[3 * d];
    if (d >= c->g_ind_n) {
        short_array(c, RTO_FRAME_INDIRECT, d, "indirect_args rows", "indirect_args.npy", c->g_ind_n, "queue(s)");
        return;
    }
    const uint32_t *a = (const uint32_t *)c->g_ind.data + 3 * (size_t)d;
    if (a[0] == e[0] && a[1] == e[1] && a[2] == e[2])
        return;
    if (!claim(c, RTO_FRAME_INDIRECT, d))
        return;
    static const char *const names[3] = {"workgroups.x", "workgroups.y", "workgroups.z"};
    for (int k = 0; k < 3; k++)
        if (a[k] != e[k])
            uint_row(c, d, names[k], e[k], a[k]);
    rto__report_summary(c->r, "indirect-args: PREP of queue %" PRIu32 ": [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] in the "
                       "GPU's dump, the oracle's [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] = [ceil(%" PRIu32
                       " / 64), 1, 1]", d, a[0], a[1], a[2], e[0], e[1], e[2], c->cnt[d].queued);
}

/* Frame-wide arrays longer than the frame: the GPU ran more queues than maxDepth + 1. */
static void step_extra_queues(fcheck *c)
{
    const size_t q = (size_t)c->depth + 1;
    if (c->have_g_emit && c->g_emit_n > q && claim(c, RTO_FRAME_COUNTS, (int64_t)q)) {
        uint_row(c, q, "emit_counts entries", q, c->g_emit_n);
        rto__report_summary(c->r, "emit-count: the GPU's emit_counts.npy has %zu entries; the frame has %zu queues "
                           "(maxDepth %" PRIu32 " + 1)", c->g_emit_n, q, c->depth);
    }
    if (c->have_g_cnt && c->g_cnt_n > q && claim(c, RTO_FRAME_COUNTS, (int64_t)q)) {
        uint_row(c, q, "frame_counters rows", q, c->g_cnt_n);
        rto__report_summary(c->r, "emit-count: the GPU's frame_counters.npy has %zu rows; the frame has %zu queues",
                           c->g_cnt_n, q);
    }
    if (c->have_g_ind && c->g_ind_n > q && claim(c, RTO_FRAME_INDIRECT, (int64_t)q)) {
        uint_row(c, q, "indirect_args rows", q, c->g_ind_n);
        rto__report_summary(c->r, "indirect-args: the GPU's indirect_args.npy has %zu rows; the frame has %zu queues",
                           c->g_ind_n, q);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Queues: multisets keyed by (pixel, kind, payloadSlot)                                                            */

typedef struct rkey {
    uint32_t pixel, kind, slot, index;
} rkey;

static int rkey_cmp(const void *pa, const void *pb)
{
    const rkey *a = pa, *b = pb;
    if (a->pixel != b->pixel)
        return a->pixel < b->pixel ? -1 : 1;
    if (a->kind != b->kind)
        return a->kind < b->kind ? -1 : 1;
    if (a->slot != b->slot)
        return a->slot < b->slot ? -1 : 1;
    return a->index < b->index ? -1 : a->index > b->index;
}

static int same_key(const rkey *a, const rkey *b)
{
    return a->pixel == b->pixel && a->kind == b->kind && a->slot == b->slot;
}

static rkey *keys_of(const rto_wf_ray *rays, size_t n)
{
    rkey *k = rto__alloc(n, sizeof *k);
    if (!k)
        return NULL;
    for (size_t i = 0; i < n; i++)
        k[i] = (rkey){rays[i].pixel, rays[i].kind, rays[i].payload_slot, (uint32_t)i};
    qsort(k, n, sizeof *k, rkey_cmp);
    return k;
}

/* The tolerance of float field f (0 .. 7: origin.xyz, tMin, dir.xyz, tMax) of a ray whose value is e. An origin is
 * a hit point o + t d, off by |dt| |d| when t is off by §9's 1e-5 max(1, |t|); a t inside the scene is at most the
 * distance across it from the camera, under 4 M. Directions and t bounds are relative, as §9's t. */
static double ray_tolerance(const fcheck *c, int f, float e)
{
    const double a = fabs((double)e);
    if (f < 3) {
        const double m = 4.0 * c->scale;
        return RAY_REL * (a > m ? a : m);
    }
    return RAY_REL * (a > 1.0 ? a : 1.0);
}

static int float_close(float e, float a, double tol)
{
    uint32_t be, ba;
    memcpy(&be, &e, 4);
    memcpy(&ba, &a, 4);
    return be == ba || (isfinite(e) && isfinite(a) && fabs((double)a - (double)e) <= tol);
}

static const char *const ray_float_names[8] = {"origin.x", "origin.y", "origin.z", "tMin",
                                                "dir.x",    "dir.y",    "dir.z",    "tMax"};
static const char *const ray_int_names[7] = {"pixel", "flags", "cullMask", "missIndex", "sbtOffset", "payloadSlot",
                                              "kind"};

/* The first field (0 .. 7 floats, 8 .. 14 integers) in which two rays differ beyond tolerance, or -1. */
static int ray_diff(const fcheck *c, const rto_wf_ray *e, const rto_wf_ray *a)
{
    const float *ef = e->origin, *af = a->origin; /* 8 floats: origin, tMin, dir, tMax */
    for (int f = 0; f < 8; f++)
        if (!float_close(ef[f], af[f], ray_tolerance(c, f, ef[f])))
            return f;
    const uint32_t *ei = &e->pixel, *ai = &a->pixel;
    for (int f = 0; f < 7; f++)
        if (ei[f] != ai[f])
            return 8 + f;
    return -1;
}

static void ray_field_row(fcheck *c, uint64_t index, const rto_wf_ray *e, const rto_wf_ray *a, int f)
{
    if (f < 8) {
        const float ev = (&e->origin[0])[f], av = (&a->origin[0])[f];
        add_row(c, index, ray_float_names[f], rto__val_f32(ev), rto__val_f32(av),
                rto__val_f64((double)av - (double)ev), rto__val_f64(ray_tolerance(c, f, ev)));
    } else {
        const uint32_t ev = (&e->pixel)[f - 8], av = (&a->pixel)[f - 8];
        if (f == 9) /* flags: a bit pattern */
            add_row(c, index, ray_int_names[f - 8], rto__val_hex32(ev), rto__val_hex32(av), rto__val_hex32(ev ^ av),
                    rto__val_none());
        else
            uint_row(c, index, ray_int_names[f - 8], ev, av);
    }
}

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

static void qfind(qresult *q, qfinding f)
{
    q->counts[f.kind]++;
    if (q->nfind < RTO_REPORT_MAX_ROWS)
        q->find[q->nfind++] = f;
}

/* Pairs the rays of one key. A key normally has one ray on each side; when a pixel emits several rays of one kind
 * from different invocations, rays of equal fields are paired first, so a permutation among them is no fault. Past
 * a bound on the work (a dump with one key repeated a million times), rays are paired in order. */
static void match_group(const fcheck *c, const rto_wf_ray *ro, const rkey *ko, size_t a, const rto_wf_ray *rg,
                        const rkey *kg, size_t b, uint8_t *used_o, uint8_t *used_g, qresult *q)
{
    memset(used_o, 0, a);
    memset(used_g, 0, b);
    if ((uint64_t)a * b <= 65536) {
        for (size_t i = 0; i < a; i++)
            for (size_t j = 0; j < b; j++)
                if (!used_g[j] && ray_diff(c, &ro[ko[i].index], &rg[kg[j].index]) < 0) {
                    used_o[i] = used_g[j] = 1;
                    q->gpu_of[ko[i].index] = kg[j].index;
                    q->paired++;
                    break;
                }
    } else {
        for (size_t i = 0; i < a && i < b; i++)
            if (ray_diff(c, &ro[ko[i].index], &rg[kg[i].index]) < 0) {
                used_o[i] = used_g[i] = 1;
                q->gpu_of[ko[i].index] = kg[i].index;
                q->paired++;
            }
    }
    /* what is left: pairs whose fields differ, then rays one side lacks */
    size_t i = 0, j = 0;
    for (;;) {
        while (i < a && used_o[i])
            i++;
        while (j < b && used_g[j])
            j++;
        if (i >= a || j >= b)
            break;
        qfind(q, (qfinding){Q_DIFFERS, ko[i].index, kg[j].index, (uint32_t)a, (uint32_t)b,
                            ray_diff(c, &ro[ko[i].index], &rg[kg[j].index])});
        used_o[i] = used_g[j] = 1;
    }
    for (; i < a; i++)
        if (!used_o[i])
            qfind(q, (qfinding){Q_MISSING, ko[i].index, NONE32, (uint32_t)a, (uint32_t)b, -1});
    for (; j < b; j++)
        if (!used_g[j])
            qfind(q, (qfinding){a ? Q_DUPLICATE : Q_EXTRA, a ? ko[0].index : NONE32, kg[j].index, (uint32_t)a,
                                (uint32_t)b, -1});
}

static rto_status match_queue(fcheck *c, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m, qresult *q)
{
    memset(q, 0, sizeof *q);
    q->gpu_of = rto__alloc(n, sizeof *q->gpu_of);
    rkey *ko = keys_of(ro, n), *kg = keys_of(rg, m);
    uint8_t *used = rto__alloc(n + m, 1);
    if (!q->gpu_of || !ko || !kg || !used) {
        free(ko);
        free(kg);
        free(used);
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory comparing a queue of %zu rays", n);
    }
    for (size_t i = 0; i < n; i++)
        q->gpu_of[i] = NONE32;
    size_t i = 0, j = 0;
    while (i < n || j < m) {
        /* the next key in order, and its group on each side */
        const rkey *k = i < n && (j >= m || rkey_cmp(&ko[i], &kg[j]) <= 0 || same_key(&ko[i], &kg[j])) ? &ko[i]
                                                                                                       : &kg[j];
        size_t a = 0, b = 0;
        while (i + a < n && same_key(&ko[i + a], k))
            a++;
        while (j + b < m && same_key(&kg[j + b], k))
            b++;
        match_group(c, ro, ko + i, a, rg, kg + j, b, used, used + a, q);
        i += a;
        j += b;
    }
    free(ko);
    free(kg);
    free(used);
    return RTO_OK;
}

static void key_text(const fcheck *c, const rto_wf_ray *r, char *buf, size_t cap)
{
    if (r->pixel < c->pixels)
        snprintf(buf, cap, "pixel %" PRIu32 " (x %" PRIu32 ", y %" PRIu32 "), kind %" PRIu32 ", payloadSlot %" PRIu32,
                 r->pixel, r->pixel % c->w, r->pixel / c->w, r->kind, r->payload_slot);
    else
        snprintf(buf, cap, "pixel %" PRIu32 " (outside the image), kind %" PRIu32 ", payloadSlot %" PRIu32, r->pixel,
                 r->kind, r->payload_slot);
}

static void queue_fault(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                        const qresult *q)
{
    const size_t total = q->counts[0] + q->counts[1] + q->counts[2] + q->counts[3];
    if (!total || !claim(c, RTO_FRAME_QUEUE, d))
        return;
    const qfinding *f = &q->find[0];
    const rto_wf_ray *r = f->o != NONE32 ? &ro[f->o] : &rg[f->g];
    char key[128];
    key_text(c, r, key, sizeof key);
    if (f->o != NONE32)
        rto__report_at(c->r, "ray", f->o);
    if (f->g != NONE32)
        rto__report_at(c->r, "gpu_ray", f->g);
    at_pixel(c, r->pixel);
    rto__report_at(c->r, "slot", r->payload_slot);
    rto__report_at(c->r, "kind", r->kind);
    switch (f->kind) {
    case Q_MISSING:
        rto__report_summary(c->r, "queue: bounce %" PRIu32 ": ray %" PRIu32 " of the oracle's queue (%s) is missing "
                           "from the GPU's queue", d, f->o, key);
        break;
    case Q_EXTRA:
        rto__report_summary(c->r, "queue: bounce %" PRIu32 ": the GPU's ray %" PRIu32 " (%s) is not in the oracle's "
                           "queue", d, f->g, key);
        break;
    case Q_DUPLICATE:
        rto__report_summary(c->r, "queue: bounce %" PRIu32 ": the key (%s) appears %" PRIu32 " times in the GPU's "
                           "queue, %" PRIu32 " in the oracle's (its ray %" PRIu32 ")", d, key, f->count_g, f->count_o,
                           f->o);
        break;
    case Q_DIFFERS: {
        const rto_wf_ray *e = &ro[f->o], *a = &rg[f->g];
        if (f->field < 8) {
            const float ev = (&e->origin[0])[f->field], av = (&a->origin[0])[f->field];
            const double tol = ray_tolerance(c, f->field, ev);
            c->r->tolerance_bound = tol;
            rto__report_summary(c->r, "queue: bounce %" PRIu32 ": ray %" PRIu32 " (%s) differs: %s is %.9g in the GPU's "
                               "ray %" PRIu32 ", %.9g in the oracle's (|diff| %.3g > %.3g)", d, f->o, key,
                               ray_float_names[f->field], (double)av, f->g, (double)ev,
                               fabs((double)av - (double)ev), tol);
        } else {
            rto__report_summary(c->r, "queue: bounce %" PRIu32 ": ray %" PRIu32 " (%s) differs: %s is %" PRIu32
                               " in the GPU's ray %" PRIu32 ", %" PRIu32 " in the oracle's", d, f->o, key,
                               ray_int_names[f->field - 8], (&a->pixel)[f->field - 8], f->g,
                               (&e->pixel)[f->field - 8]);
        }
        break;
    }
    }
    rto__report_append(c->r, "; %zu missing, %zu extra, %zu duplicated, %zu differing (oracle %zu rays, GPU %zu), "
                      "filled by %s", q->counts[Q_MISSING], q->counts[Q_EXTRA], q->counts[Q_DUPLICATE],
                      q->counts[Q_DIFFERS], n, m, filled_by(d));
    for (uint32_t k = 0; k < q->nfind; k++) {
        const qfinding *x = &q->find[k];
        switch (x->kind) {
        case Q_MISSING: uint_row(c, x->o, "missing (key count)", x->count_o, x->count_g); break;
        case Q_EXTRA: uint_row(c, x->g, "extra (gpu ray index)", 0, x->count_g); break;
        case Q_DUPLICATE: uint_row(c, x->o, "duplicated (key count)", x->count_o, x->count_g); break;
        case Q_DIFFERS: {
            /* every differing field of the pair, not only the first */
            for (int fld = 0; fld < 15; fld++) {
                const rto_wf_ray *e = &ro[x->o], *a = &rg[x->g];
                int differs;
                if (fld < 8)
                    differs = !float_close((&e->origin[0])[fld], (&a->origin[0])[fld],
                                           ray_tolerance(c, fld, (&e->origin[0])[fld]));
                else
                    differs = (&e->pixel)[fld - 8] != (&a->pixel)[fld - 8];
                if (differs)
                    ray_field_row(c, x->o, e, a, fld);
            }
            break;
        }
        }
    }
}

/* The rays of a GPU queue dump: WfRay records or their words (rto_layout_accept). A dump of the whole buffer
 * (capacity records) is cut to the queue's length n. */
static rto_status gpu_rays(fcheck *c, const char *name, const rto_npy *g, size_t n, size_t *m)
{
    rto_msg mm = {{0}};
    if (rto_layout_accept(RTO_LAYOUT_WF_RAY, g, m, &mm))
        return bad_gpu(c, name, "%s", mm.text);
    if (*m == c->cap && n < c->cap)
        *m = n;
    return RTO_OK;
}

/* The queue's length on the GPU: min(its emit counter, capacity) when dumped, else the oracle's. */
static size_t gpu_queue_len(const fcheck *c, uint32_t d)
{
    if (c->have_g_emit && d < c->g_emit_n) {
        const uint32_t e = ((const uint32_t *)c->g_emit.data)[d];
        return (uint64_t)e < c->cap ? e : (size_t)c->cap;
    }
    return c->cnt[d].queued;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Payloads                                                                                                         */

static int payload_float(uint32_t w)
{
    float f;
    memcpy(&f, &w, 4);
    return isfinite(f) && (f == 0.0f || fabs((double)f) >= PAYLOAD_FLOAT_MIN);
}

/* §9's accum rule with absolute part abs (ACCUM_ABS, or the frame's accum_abs). Payload floats carry colour on its way
 * to accum, so they compare with it too. */
static double accum_tolerance(float e, double abs) { return ACCUM_REL * fabs((double)e) + abs; }

/* Whether two payload words agree: bit for bit, or as close binary32 values (see PAYLOAD_FLOAT_MIN). */
static int word_close(uint32_t e, uint32_t a)
{
    if (e == a)
        return 1;
    if (!payload_float(e) || !payload_float(a))
        return 0;
    float fe, fa;
    memcpy(&fe, &e, 4);
    memcpy(&fa, &a, 4);
    return fabs((double)fa - (double)fe) <= accum_tolerance(fe, ACCUM_ABS);
}

/* Reads the dump's file of a bounce that pairs with its rays (payloads, hits) into g. Returns 1 when there is
 * something to compare: the dump has the file, the bundle keeps it, and the dump's queue is there to pair it with;
 * otherwise notes why not (not dumped, skipped) and returns 0, with *s set on an error. */
static int gpu_bounce_file(fcheck *c, const char *name, const rto_wf_ray *rg, rto_npy *g, rto_status *s)
{
    const int expected = exp_has(c, name);
    int present = 0;
    if ((*s = gpu_load(c, name, g, &present)))
        return 0;
    if (!present) {
        if (expected)
            not_dumped(c, name);
        return 0;
    }
    if (!expected) {
        skipped(c, name, "not kept by the bundle");
        return 0;
    }
    if (!rg) {
        skipped(c, name, "no rays dumped to pair them with");
        return 0;
    }
    return 1;
}

/* The GPU's payload of oracle ray i: its partner's row, or the store's row at its payloadSlot; NULL for a ray
 * without a partner (a queue fault already) or a slot past the store (the ray itself then differs). */
static const uint32_t *payload_row(const fcheck *c, const qresult *q, const rto_wf_ray *rg, const uint32_t *gw,
                                   size_t rows, int by_slot, size_t i)
{
    const uint32_t g = q->gpu_of[i];
    if (g == NONE32)
        return NULL;
    const size_t row = by_slot ? (size_t)rg[g].payload_slot : (size_t)g;
    return row < rows ? gw + row * c->words : NULL;
}

static void step_payloads(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                          const qresult *q, rto_status *st)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], have[160];
    file_name(RTO_FILE_BOUNCE_PAYLOADS, d, name);
    if (!c->words)
        return; /* the program carries no payload */
    rto_npy e = {0}, g = {0};
    if (!gpu_bounce_file(c, name, rg, &g, st))
        goto out;
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_U32, 2, n, c->words, 0);
    if ((*st = exp_load(c, name, &want, &e)))
        goto out;
    const rto_npy_desc *gd = &g.desc;
    if ((gd->dtype != RTO_DTYPE_U32 && gd->dtype != RTO_DTYPE_F32) ||
        !((gd->ndim == 2 && gd->shape[1] == c->words) || (gd->ndim == 1 && gd->shape[0] % c->words == 0))) {
        *st = bad_gpu(c, name, "holds %s; expected dtype <u4 or <f4, shape (rays, %" PRIu32 ") or flat",
                      describe(gd, have, sizeof have), c->words);
        goto out;
    }
    c->files_compared++;
    c->payloads_run = 1;
    const size_t rows = (size_t)(gd->ndim == 2 ? gd->shape[0] : gd->shape[0] / c->words);
    /* one row per dumped ray in the dump's order, or the whole store (capacity rows) indexed by payloadSlot */
    const int by_slot = rows == c->cap;
    if (!by_slot && rows != m) {
        if (claim(c, RTO_FRAME_PAYLOAD, d)) {
            uint_row(c, 0, "payload rows", m, rows);
            rto__report_summary(c->r, "payload: bounce %" PRIu32 ": the GPU dumped %zu payload rows for its %zu rays "
                               "(or the store of %" PRIu64 " slots)", d, rows, m, c->cap);
        }
        goto out;
    }
    const uint32_t *ew = e.data, *gw = g.data;
    size_t wrong = 0, first = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        const uint32_t *a = payload_row(c, q, rg, gw, rows, by_slot, i), *x = ew + i * (size_t)c->words;
        int bad = 0;
        for (uint32_t k = 0; a && k < c->words; k++)
            bad |= !word_close(x[k], a[k]);
        if (bad && !wrong++)
            first = i;
    }
    if (!wrong || !claim(c, RTO_FRAME_PAYLOAD, d))
        goto out;
    at_ray(c, ro, q->gpu_of, first);
    char key[128];
    key_text(c, &ro[first], key, sizeof key);
    rto__report_summary(c->r, "payload: bounce %" PRIu32 ": the payload of ray %zu (%s) differs in the GPU's dump (%s);"
                       " %zu of %zu paired rays differ", d, first, key,
                       by_slot ? "its payload store, read at payloadSlot" : "the row of its ray", wrong, q->paired);
    for (size_t i = first; i < n && c->r->nrows < RTO_REPORT_MAX_ROWS; i++) {
        const uint32_t *a = payload_row(c, q, rg, gw, rows, by_slot, i), *x = ew + i * (size_t)c->words;
        for (uint32_t k = 0; a && k < c->words; k++) {
            if (word_close(x[k], a[k]))
                continue;
            char field[RTO_REPORT_NAME_MAX];
            snprintf(field, sizeof field, "word %" PRIu32, k);
            float fe, fa;
            memcpy(&fe, &x[k], 4);
            memcpy(&fa, &a[k], 4);
            if (payload_float(x[k]) && payload_float(a[k]))
                add_row(c, i, field, rto__val_f32(fe), rto__val_f32(fa), rto__val_f64((double)fa - (double)fe),
                        rto__val_f64(accum_tolerance(fe, ACCUM_ABS)));
            else
                add_row(c, i, field, rto__val_hex32(x[k]), rto__val_hex32(a[k]), rto__val_hex32(x[k] ^ a[k]),
                        rto__val_none());
        }
    }
out:
    rto_npy_free(&e);
    rto_npy_free(&g);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hits                                                                                                             */

/* The stage2 scene has no triangles to re-intersect: its hits compare as IDs and missFlag exactly, t and bary within
 * §9, objToWorld exactly (the translation to a primitive's centre), with check-hits's fault names. Returns the fault
 * (RTO_HIT_OK when the records agree) and the first differing field as a row. */
typedef struct hit_diff {
    const char *field;
    rto_value e, a, d, tol;
} hit_diff;

static rto_hit_fault stage2_hit_diff(const rto_hit_record *e, const rto_hit_record *a, hit_diff *x)
{
    const struct {
        rto_hit_fault f;
        const char *field;
        uint32_t e, a;
    } ids[] = {
        {RTO_HIT_MISS_FLAG, "missFlag", e->miss_flag, a->miss_flag},
        {RTO_HIT_INSTANCE, "instanceId", e->instance_id, a->instance_id},
        {RTO_HIT_PRIM, "primId", e->prim_id, a->prim_id},
    };
    for (size_t k = 0; k < sizeof ids / sizeof ids[0]; k++)
        if (ids[k].e != ids[k].a) {
            *x = (hit_diff){ids[k].field, rto__val_hex32(ids[k].e), rto__val_hex32(ids[k].a),
                            rto__val_hex32(ids[k].e ^ ids[k].a), rto__val_none()};
            return ids[k].f;
        }
    const double tt = 1e-5 * (fabs((double)e->t) > 1.0 ? fabs((double)e->t) : 1.0);
    const struct {
        rto_hit_fault f;
        const char *field;
        float e, a;
        double tol;
    } floats[] = {
        {RTO_HIT_T, "t", e->t, a->t, tt},
        {RTO_HIT_BARY, "bary.u", e->bary[0], a->bary[0], 1e-4},
        {RTO_HIT_BARY, "bary.v", e->bary[1], a->bary[1], 1e-4},
    };
    for (size_t k = 0; k < sizeof floats / sizeof floats[0]; k++)
        if (!(fabs((double)floats[k].a - (double)floats[k].e) <= floats[k].tol)) {
            *x = (hit_diff){floats[k].field, rto__val_f32(floats[k].e), rto__val_f32(floats[k].a),
                            rto__val_f64((double)floats[k].a - (double)floats[k].e), rto__val_f64(floats[k].tol)};
            return floats[k].f;
        }
    const struct {
        rto_hit_fault f;
        const char *field;
        uint32_t e, a;
    } more[] = {
        {RTO_HIT_CUSTOM_INDEX, "customIndex", e->custom_index, a->custom_index},
        {RTO_HIT_HIT_GROUP, "hitGroup", e->hit_group, a->hit_group},
    };
    for (size_t k = 0; k < sizeof more / sizeof more[0]; k++)
        if (more[k].e != more[k].a) {
            *x = (hit_diff){more[k].field, rto__val_hex32(more[k].e), rto__val_hex32(more[k].a),
                            rto__val_hex32(more[k].e ^ more[k].a), rto__val_none()};
            return more[k].f;
        }
    static const char *const cells[4][3] = {{"objToWorld[0][0]", "objToWorld[0][1]", "objToWorld[0][2]"},
                                            {"objToWorld[1][0]", "objToWorld[1][1]", "objToWorld[1][2]"},
                                            {"objToWorld[2][0]", "objToWorld[2][1]", "objToWorld[2][2]"},
                                            {"objToWorld[3][0]", "objToWorld[3][1]", "objToWorld[3][2]"}};
    for (int col = 0; col < 4; col++)
        for (int row = 0; row < 3; row++)
            if (e->obj_to_world[col][row] != a->obj_to_world[col][row]) {
                *x = (hit_diff){cells[col][row], rto__val_f32(e->obj_to_world[col][row]),
                                rto__val_f32(a->obj_to_world[col][row]),
                                rto__val_f64((double)a->obj_to_world[col][row] - (double)e->obj_to_world[col][row]),
                                rto__val_none()};
                return RTO_HIT_TRANSFORM;
            }
    return RTO_HIT_OK;
}

static rto_status stage2_hits(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_hit_record *eh,
                              const rto_hit_record *gh, const qresult *q)
{
    size_t wrong = 0, first = SIZE_MAX;
    hit_diff x;
    for (size_t i = 0; i < n; i++) {
        if (q->gpu_of[i] == NONE32 || stage2_hit_diff(&eh[i], &gh[i], &x) == RTO_HIT_OK)
            continue;
        if (!wrong++)
            first = i;
    }
    if (!wrong || !claim(c, RTO_FRAME_HITS, d))
        return RTO_OK;
    const rto_hit_fault f = stage2_hit_diff(&eh[first], &gh[first], &x);
    at_ray(c, ro, q->gpu_of, first);
    c->r->tolerance_bound = x.tol.type == RTO_VALUE_NONE ? 0 : x.tol.v.f;
    rto__report_summary(c->r, "hits: bounce %" PRIu32 " (stage2 scene: IDs, missFlag, objToWorld exact, t and bary "
                       "within §9): %s: ray %zu: %s differs; %zu of %zu paired rays wrong", d, rto_hit_fault_name(f),
                       first, x.field, wrong, q->paired);
    for (size_t i = first; i < n && c->r->nrows < RTO_REPORT_MAX_ROWS; i++)
        if (q->gpu_of[i] != NONE32 && stage2_hit_diff(&eh[i], &gh[i], &x) != RTO_HIT_OK)
            add_row(c, i, x.field, x.e, x.a, x.d, x.tol);
    return RTO_OK;
}

/* The FrameCounters fields a pass of bounce d fills (at most 4), as fault f. */
static void pass_counters(fcheck *c, uint32_t d, rto_frame_fault f, const char *pass, const cnt_field *fields,
                          size_t nf)
{
    count_diff x[4];
    const uint32_t nx = compare_counters(c, d, fields, nf, x, 0);
    char what[96];
    snprintf(what, sizeof what, "FrameCounters of the %s pass of bounce %" PRIu32, pass, d);
    counts_fault(c, f, d, x, nx, what);
}

static void step_hit_counters(fcheck *c, uint32_t d)
{
    static const cnt_field fields[] = {CNT_FIELD(traced), CNT_FIELD(hits), CNT_FIELD(misses)};
    pass_counters(c, d, RTO_FRAME_HITS, "TRACE", fields, 3);
}

static void step_shade_counters(fcheck *c, uint32_t d)
{
    static const cnt_field fields[] = {CNT_FIELD(shaded), CNT_FIELD(accumulates)};
    pass_counters(c, d, RTO_FRAME_COUNTS, "SHADE", fields, 2);
}

static rto_status step_hits(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                            const qresult *q)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    file_name(RTO_FILE_BOUNCE_HITS, d, name);
    rto_npy e = {0}, g = {0};
    rto_hit_record *paired = NULL, *hexp = NULL;
    rto_wf_ray *hrays = NULL;
    size_t *redo = NULL;
    rto_status s = RTO_OK;
    if (!gpu_bounce_file(c, name, rg, &g, &s))
        goto out;
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, n);
    if ((s = exp_load(c, name, &want, &e)))
        goto out;
    size_t k = 0;
    rto_msg mm = {{0}};
    if (rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &g, &k, &mm)) {
        s = bad_gpu(c, name, "%s", mm.text);
        goto out;
    }
    if (k == c->cap && m < c->cap)
        k = m; /* the whole hit buffer: its first m records are this bounce's */
    c->files_compared++;
    c->hits_run = 1;
    if (k != m) {
        if (claim(c, RTO_FRAME_HITS, d)) {
            uint_row(c, 0, "hit records", m, k);
            rto__report_summary(c->r, "hits: bounce %" PRIu32 ": the GPU dumped %zu hit records for its %zu rays (one "
                               "per ray, in the order of its bounce_%" PRIu32 "_rays.npy)", d, k, m, d);
        }
        goto out;
    }
    /* The GPU's record of each oracle ray, found through the ray pairing; a ray without a partner (already a queue
     * fault) gets the oracle's own record, so that ray numbers stay the oracle's queue indices. */
    paired = rto__alloc(n, sizeof *paired);
    if (!paired) {
        s = rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        goto out;
    }
    const rto_hit_record *eh = e.data, *gh = g.data;
    for (size_t i = 0; i < n; i++)
        paired[i] = q->gpu_of[i] != NONE32 ? gh[q->gpu_of[i]] : eh[i];
    if (c->stage2) {
        s = stage2_hits(c, d, ro, n, eh, paired, q);
        goto out;
    }
    if ((s = load_scene(c)))
        goto out;
    /* Each GPU record is judged with the ray the GPU traced (§9's model holds a record to its own ray; how far the
     * GPU's ray may be from the oracle's is the queue step's rule): where the paired GPU ray differs from the
     * oracle's, the expected record is the oracle's arithmetic on the GPU's ray, brute force (a conforming
     * implementation of §6 too). */
    if (!(hrays = rto__alloc(n, sizeof *hrays)) || !(hexp = rto__alloc(n, sizeof *hexp)) ||
        !(redo = rto__alloc(n, sizeof *redo))) {
        s = rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        goto out;
    }
    size_t nredo = 0;
    for (size_t i = 0; i < n; i++) {
        hrays[i] = ro[i];
        hexp[i] = eh[i];
        if (q->gpu_of[i] != NONE32 && memcmp(&rg[q->gpu_of[i]], &ro[i], sizeof ro[i])) {
            hrays[i] = rg[q->gpu_of[i]];
            redo[nredo++] = i;
        }
    }
    if (nredo) {
        rto_wf_ray *rr = rto__alloc(nredo, sizeof *rr);
        rto_hit_record *rh = rto__alloc(nredo, sizeof *rh);
        const rto_scene view = {.meshes = c->meshes, .mesh_count = c->nmeshes, .instances = c->instances,
                                .instance_count = c->ninst};
        rto_status bs = rr && rh ? RTO_OK : rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        for (size_t x = 0; !bs && x < nredo; x++)
            rr[x] = hrays[redo[x]];
        if (!bs)
            bs = rto_trace_brute(&view, rr, nredo, NULL, rh, &mm);
        for (size_t x = 0; !bs && x < nredo; x++)
            hexp[redo[x]] = rh[x];
        free(rr);
        free(rh);
        if (bs == RTO_ERR_INVALID_ARGUMENT) {
            /* a GPU ray that cannot be traced (non-finite): the queue step names it; judge the oracle's ray */
            for (size_t x = 0; x < nredo; x++) {
                hrays[redo[x]] = ro[redo[x]];
                hexp[redo[x]] = eh[redo[x]];
            }
        } else if (bs) {
            s = rto__fail(c->msg, bs, "%s", mm.text);
            goto out;
        }
    }
    rto_hits_check_desc hd;
    memset(&hd, 0, sizeof hd);
    hd.rays = hrays;
    hd.ray_count = n;
    hd.expected = hexp;
    hd.gpu = paired;
    hd.gpu_count = n;
    hd.instances = c->instances;
    hd.instance_count = c->ninst;
    hd.meshes = c->meshes;
    hd.mesh_count = c->nmeshes;
    rto_report sub;
    const rto_status hs = rto_hits_check(&hd, &sub, &mm);
    if (hs == RTO_ERR_INVALID_ARGUMENT) {
        /* the bundle's own records or geometry disagree: refused as input, never blamed on the GPU */
        s = bad_expected(c, name, "%s", mm.text);
        goto out;
    }
    if (hs != RTO_OK && hs != RTO_ERR_MISMATCH) {
        s = rto__fail(c->msg, hs, "%s", mm.text);
        goto out;
    }
    if (hs == RTO_ERR_MISMATCH && claim(c, RTO_FRAME_HITS, d)) {
        int64_t ray = 0;
        rto_report_where(&sub, "ray", &ray);
        if (ray >= 0 && (size_t)ray < n)
            at_ray(c, ro, q->gpu_of, (size_t)ray);
        else
            rto__report_at(c->r, "ray", ray);
        for (uint32_t r = 0; r < sub.nrows && r < RTO_REPORT_MAX_ROWS; r++)
            add_row(c, sub.rows[r].index, sub.rows[r].field, sub.rows[r].expected, sub.rows[r].actual,
                    sub.rows[r].diff, sub.rows[r].tolerance);
        c->r->tolerance_bound = sub.tolerance_bound;
        rto__report_summary(c->r, "hits: bounce %" PRIu32 " (check-hits rules, ray = the oracle's queue index): %s", d,
                           sub.summary);
    }
out:
    free(paired);
    free(hrays);
    free(hexp);
    free(redo);
    rto_npy_free(&e);
    rto_npy_free(&g);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* One bounce                                                                                                       */

static rto_status step_queue(fcheck *c, uint32_t d)
{
    char rname[RTO_BUNDLE_FILE_NAME_MAX], pname[RTO_BUNDLE_FILE_NAME_MAX], hname[RTO_BUNDLE_FILE_NAME_MAX];
    file_name(RTO_FILE_BOUNCE_RAYS, d, rname);
    file_name(RTO_FILE_BOUNCE_PAYLOADS, d, pname);
    file_name(RTO_FILE_BOUNCE_HITS, d, hname);
    const int traced = d < c->depth;
    if (c->drop_queue != NONE32 && d >= c->drop_queue) {
        /* which rays a GPU keeps at capacity is arbitrary: from here on only the counts compare */
        const char *names[3] = {rname, c->words ? pname : NULL, traced ? hname : NULL};
        for (int k = 0; k < 3; k++)
            if (names[k] && gpu_has(c, names[k]))
                list_add(c->drop_skipped, sizeof c->drop_skipped, names[k]);
        return RTO_OK;
    }
    const int expected = exp_has(c, rname);
    rto_npy e = {0}, g = {0};
    int present = 0;
    rto_status s = gpu_load(c, rname, &g, &present);
    if (s)
        return s;
    const size_t n = c->cnt[d].queued;
    size_t m = 0;
    qresult q;
    memset(&q, 0, sizeof q);
    const rto_wf_ray *ro = NULL, *rg = NULL;
    if (!present) {
        if (expected)
            not_dumped(c, rname);
    } else if (!expected) {
        skipped(c, rname, "not kept by the bundle");
    } else {
        rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_WF_RAY, n);
        if ((s = exp_load(c, rname, &want, &e)) || (s = gpu_rays(c, rname, &g, gpu_queue_len(c, d), &m)))
            goto out;
        ro = e.data;
        rg = g.data;
        c->files_compared++;
        c->rays_compared += n;
        if ((s = match_queue(c, ro, n, rg, m, &q)))
            goto out;
        queue_fault(c, d, ro, n, rg, m, &q);
    }
    if (ro) {
        step_payloads(c, d, ro, n, rg, m, &q, &s);
        if (s)
            goto out;
        if (traced && (s = step_hits(c, d, ro, n, rg, m, &q)))
            goto out;
    } else {
        /* without both queues there is nothing to pair payloads and hits with */
        const char *names[2] = {c->words ? pname : NULL, traced ? hname : NULL};
        for (int k = 0; k < 2; k++) {
            if (!names[k])
                continue;
            if (gpu_has(c, names[k]))
                skipped(c, names[k], present ? "its queue is not in the bundle" : "no rays dumped to pair them with");
            else if (exp_has(c, names[k]))
                not_dumped(c, names[k]);
        }
    }
out:
    free(q.gpu_of);
    rto_npy_free(&e);
    rto_npy_free(&g);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Accum and image                                                                                                  */

static const char channel_names[4][2] = {"r", "g", "b", "a"};

/* Marks the pixels a dropping queue makes incomparable: every pixel with a ray in it (kept or dropped). Descendant
 * rays keep their pixel, so later queues add none. Without the queue's rays in the bundle, no pixel is safe. */
static rto_status mark_drop_pixels(fcheck *c)
{
    if (c->drop_queue == NONE32)
        return RTO_OK;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    file_name(RTO_FILE_BOUNCE_RAYS, c->drop_queue, name);
    if (!exp_has(c, name)) {
        for (uint64_t p = 0; p < c->pixels; p++)
            c->mask[p] |= MASK_DROP_QUEUE;
        return RTO_OK;
    }
    rto_npy e = {0};
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_WF_RAY, c->cnt[c->drop_queue].queued);
    rto_status s = exp_load(c, name, &want, &e);
    if (s)
        return s;
    const rto_wf_ray *r = e.data;
    for (size_t i = 0; i < (size_t)want.shape[0]; i++)
        if (r[i].pixel < c->pixels)
            c->mask[r[i].pixel] |= MASK_DROP_QUEUE;
    for (uint64_t p = 0; p < c->pixels; p++)
        if (c->mask[p] & RTO_PIXEL_DROPPED)
            c->mask[p] |= MASK_DROP_QUEUE;
    rto_npy_free(&e);
    return RTO_OK;
}

/* §9's accum rule for one channel: within 1e-4 |e| + 1e-6; infinities must match, NaN matches only NaN. */
static int accum_close(const fcheck *c, float e, float a)
{
    if (isnan(e) || isnan(a))
        return isnan(e) && isnan(a);
    if (isinf(e) || isinf(a))
        return e == a;
    return fabs((double)a - (double)e) <= accum_tolerance(e, c->accum_abs);
}

static void stats_note(pixel_stats *ps, uint32_t x, uint32_t y, const float *e, const float *a, uint32_t ch)
{
    if (ps->nlist >= LIST_MAX)
        return;
    pixel_diff *p = &ps->list[ps->nlist++];
    memset(p, 0, sizeof *p);
    p->x = x;
    p->y = y;
    for (uint32_t k = 0; k < ch; k++) {
        p->e[k] = e[k];
        p->a[k] = a[k];
    }
}

/* Starts the statistics of one accum or image comparison of file (ch channels). */
static void stats_begin(pixel_stats *ps, const char *file, uint32_t ch)
{
    memset(ps, 0, offsetof(pixel_stats, expected));
    ps->run = 1;
    snprintf(ps->file, sizeof ps->file, "%s", file);
    ps->channels = ch;
}

/* Keeps the largest difference seen: channel k of pixel p. */
static void stats_max(pixel_stats *ps, double diff, uint64_t p, uint32_t w, uint32_t k)
{
    if (diff > ps->max_diff) {
        ps->max_diff = diff;
        ps->max_x = (uint32_t)(p % w);
        ps->max_y = (uint32_t)(p / w);
        ps->max_c = k;
    }
}

/* A dumped accum or image of another size than the frame: fault f, with both sizes as rows. */
static void size_fault(fcheck *c, rto_frame_fault f, const char *file, uint32_t gw, uint32_t gh)
{
    if (!claim(c, f, -1))
        return;
    uint_row(c, 0, "width", c->w, gw);
    uint_row(c, 0, "height", c->h, gh);
    rto__report_summary(c->r, "%s: %s is %" PRIu32 " x %" PRIu32 "; the frame is %" PRIu32 " x %" PRIu32,
                       rto_frame_fault_name(f), file, gw, gh, c->w, c->h);
}

/* Compares an accum of ch channels (3 or 4) with the bundle's RGBA accum, pixel by pixel, and claims the fault. */
static void compare_accum(fcheck *c, const char *file, const float *e, const float *a, uint32_t ch)
{
    pixel_stats *ps = &c->accum;
    stats_begin(ps, file, ch);
    for (uint64_t p = 0; p < c->pixels; p++) {
        if (c->mask[p]) {
            ps->excluded++;
            continue;
        }
        ps->compared++;
        const float *ep = e + 4 * p, *ap = a + (size_t)ch * p;
        int over = 0;
        for (uint32_t k = 0; k < ch; k++) {
            stats_max(ps, fabs((double)ap[k] - (double)ep[k]), p, c->w, k);
            over |= !accum_close(c, ep[k], ap[k]);
        }
        if (over) {
            stats_note(ps, (uint32_t)(p % c->w), (uint32_t)(p / c->w), ep, ap, ch);
            ps->over++;
        }
    }
    if (!ps->over)
        return;
    ps->failed = 1;
    if (!claim(c, RTO_FRAME_ACCUM, -1))
        return;
    const pixel_diff *f = &ps->list[0];
    at_pixel(c, f->y * c->w + f->x);
    uint32_t k0 = 0;
    while (k0 + 1 < ch && accum_close(c, f->e[k0], f->a[k0]))
        k0++;
    c->r->tolerance_bound = accum_tolerance(f->e[k0], c->accum_abs);
    for (uint32_t i = 0; i < ps->nlist && c->r->nrows < RTO_REPORT_MAX_ROWS; i++)
        for (uint32_t k = 0; k < ch; k++) {
            const pixel_diff *x = &ps->list[i];
            if (!accum_close(c, x->e[k], x->a[k]))
                add_row(c, (uint64_t)x->y * c->w + x->x, channel_names[k], rto__val_f32(x->e[k]), rto__val_f32(x->a[k]),
                        rto__val_f64((double)x->a[k] - (double)x->e[k]),
                        rto__val_f64(accum_tolerance(x->e[k], c->accum_abs)));
        }
    rto__report_summary(c->r, "accum: %s: pixel %" PRIu32 " (x %" PRIu32 ", y %" PRIu32 ") channel %s is %.9g, the "
                       "oracle's %.9g (|diff| %.3g > %.3g); %" PRIu64 " of %" PRIu64 " compared pixels outside 1e-4 "
                       "relative + %g", file, f->y * c->w + f->x, f->x, f->y, channel_names[k0], (double)f->a[k0],
                       (double)f->e[k0], fabs((double)f->a[k0] - (double)f->e[k0]),
                       accum_tolerance(f->e[k0], c->accum_abs), ps->over, ps->compared, c->accum_abs);
}

static rto_status keep_images(pixel_stats *ps, uint32_t w, uint32_t h, uint32_t ch, rto_pixel_type t, const void *e,
                              size_t e_stride, const void *a, const uint8_t *mask, rto_msg *msg)
{
    /* the pair the diff image is made of: the expected image cut to the compared channels, and the actual one with
     * the pixels that are not comparable set to the expected values, so that they show no difference */
    const size_t vs = t == RTO_PIXEL_U8 ? 1 : 4, n = (size_t)w * h;
    void *pe = rto__alloc(n * ch, vs), *pa = rto__alloc(n * ch, vs);
    if (!pe || !pa) {
        free(pe);
        free(pa);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (size_t p = 0; p < n; p++) {
        memcpy((char *)pe + p * ch * vs, (const char *)e + p * e_stride * vs, ch * vs);
        memcpy((char *)pa + p * ch * vs, mask[p] ? (const char *)e + p * e_stride * vs : (const char *)a + p * ch * vs,
               ch * vs);
    }
    ps->expected = (rto_image){w, h, ch, t, pe};
    ps->actual = (rto_image){w, h, ch, t, pa};
    return RTO_OK;
}

static rto_status step_accum(fcheck *c)
{
    char nname[RTO_BUNDLE_FILE_NAME_MAX], xname[RTO_BUNDLE_FILE_NAME_MAX], have[160];
    file_name(RTO_FILE_ACCUM, 0, nname);
    file_name(RTO_FILE_ACCUM_EXR, 0, xname);
    const int expected = exp_has(c, nname);
    rto_npy e = {0}, g = {0};
    rto_image gi = {0};
    int have_npy = 0, have_exr = 0;
    rto_status s = gpu_load(c, nname, &g, &have_npy);
    if (!s)
        s = gpu_image(c, xname, &gi, &have_exr);
    if (s)
        goto out;
    if (!have_npy && !have_exr) {
        if (expected)
            not_dumped(c, "accum.npy / accum.exr");
        goto out;
    }
    if (!expected) {
        skipped(c, have_npy ? nname : xname, "not kept by the bundle");
        goto out;
    }
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_F32, 3, c->h, c->w, 4);
    if ((s = exp_load(c, nname, &want, &e)))
        goto out;
    const float *ef = e.data;
    for (int src = 0; src < 2; src++) {
        const float *a = NULL;
        uint32_t ch = 0, gw = 0, gh = 0;
        const char *file = src ? xname : nname;
        if (src == 0 && have_npy) {
            const rto_npy_desc *d = &g.desc;
            if (d->dtype != RTO_DTYPE_F32 || d->ndim != 3 || (d->shape[2] != 3 && d->shape[2] != 4)) {
                s = bad_gpu(c, nname, "holds %s; expected dtype <f4, shape (height, width, 4) or (height, width, 3)",
                            describe(d, have, sizeof have));
                goto out;
            }
            a = g.data;
            gh = d->shape[0] > UINT32_MAX ? UINT32_MAX : (uint32_t)d->shape[0];
            gw = d->shape[1] > UINT32_MAX ? UINT32_MAX : (uint32_t)d->shape[1];
            ch = (uint32_t)d->shape[2];
        } else if (src == 1 && have_exr) {
            if (gi.type != RTO_PIXEL_F32 || (gi.channels != 3 && gi.channels != 4)) {
                s = bad_gpu(c, xname, "is a %" PRIu32 "-channel %s image; expected RGBA or RGB float (linear accum)",
                            gi.channels, gi.type == RTO_PIXEL_U8 ? "8-bit" : "float");
                goto out;
            }
            a = gi.pixels;
            gw = gi.width;
            gh = gi.height;
            ch = gi.channels;
        } else {
            continue;
        }
        c->files_compared++;
        if (gw != c->w || gh != c->h) {
            c->accum.run = 1;
            c->accum.failed = 1;
            size_fault(c, RTO_FRAME_ACCUM, file, gw, gh);
            continue;
        }
        if (c->accum.failed)
            continue; /* accum.npy failed already: its .exr twin adds nothing */
        compare_accum(c, file, ef, a, ch);
        if (c->accum.failed && !c->accum.expected.pixels && c->desc->artifact_dir &&
            (s = keep_images(&c->accum, c->w, c->h, ch, RTO_PIXEL_F32, ef, 4, a, c->mask, c->msg)))
            goto out;
    }
out:
    rto_npy_free(&e);
    rto_npy_free(&g);
    rto_image_free(&gi);
    return s;
}

static rto_status step_image(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    file_name(RTO_FILE_IMAGE, 0, name);
    const int expected = exp_has(c, name);
    rto_image e = {0}, g = {0};
    int present = 0;
    rto_status s = gpu_image(c, name, &g, &present);
    if (s || !present) {
        if (!s && expected)
            not_dumped(c, name);
        return s;
    }
    if (!expected) {
        skipped(c, name, "not kept by the bundle");
        goto out;
    }
    rto_msg m = {{0}};
    if ((s = rto_bundle_read_image(c->b, name, &e, &m))) {
        s = rto__fail(c->msg, s, "expected bundle %s: %s: %s", c->desc->expected_dir, name, m.text);
        goto out;
    }
    if (e.type != RTO_PIXEL_U8 || e.channels != 4 || e.width != c->w || e.height != c->h) {
        s = bad_expected(c, name, "is a %" PRIu32 " x %" PRIu32 " image of %" PRIu32 " %s channels; expected %" PRIu32
                         " x %" PRIu32 " RGBA 8-bit", e.width, e.height, e.channels,
                         e.type == RTO_PIXEL_U8 ? "8-bit" : "float", c->w, c->h);
        goto out;
    }
    if (g.type != RTO_PIXEL_U8 || (g.channels != 3 && g.channels != 4)) {
        s = bad_gpu(c, name, "is a %" PRIu32 "-channel %s image; expected RGBA or RGB, 8 bits per channel", g.channels,
                    g.type == RTO_PIXEL_U8 ? "8-bit" : "non-8-bit");
        goto out;
    }
    c->files_compared++;
    pixel_stats *ps = &c->image;
    stats_begin(ps, name, g.channels);
    if (g.width != c->w || g.height != c->h) {
        ps->failed = 1;
        size_fault(c, RTO_FRAME_IMAGE, name, g.width, g.height);
        goto out;
    }
    const uint8_t *ep = e.pixels, *ap = g.pixels;
    const uint32_t ch = g.channels;
    int64_t first = -1;
    for (uint64_t p = 0; p < c->pixels; p++) {
        if (c->mask[p]) {
            ps->excluded++;
            continue;
        }
        ps->compared++;
        const uint8_t *x = ep + 4 * p, *y = ap + (size_t)ch * p;
        int over = 0;
        for (uint32_t k = 0; k < ch; k++) {
            const int diff = abs((int)y[k] - (int)x[k]);
            stats_max(ps, diff, p, c->w, k);
            over |= diff > IMAGE_STEP;
        }
        if (!over)
            continue;
        if (first < 0)
            first = (int64_t)p;
        float fe[4] = {0}, fa[4] = {0};
        for (uint32_t k = 0; k < ch; k++) {
            fe[k] = x[k];
            fa[k] = y[k];
        }
        stats_note(ps, (uint32_t)(p % c->w), (uint32_t)(p / c->w), fe, fa, ch);
        ps->over++;
    }
    const double allowed = c->fail_percent / 100.0 * (double)ps->compared;
    if (!((double)ps->over > allowed))
        goto out;
    ps->failed = 1;
    if (claim(c, RTO_FRAME_IMAGE, -1)) {
        const uint32_t p = (uint32_t)first;
        at_pixel(c, p);
        for (uint32_t i = 0; i < ps->nlist && c->r->nrows < RTO_REPORT_MAX_ROWS; i++) {
            const pixel_diff *f = &ps->list[i];
            for (uint32_t k = 0; k < ch; k++)
                if (fabsf(f->a[k] - f->e[k]) > IMAGE_STEP)
                    add_row(c, (uint64_t)f->y * c->w + f->x, channel_names[k], rto__val_uint((uint64_t)f->e[k]),
                            rto__val_uint((uint64_t)f->a[k]), rto__val_int((int64_t)f->a[k] - (int64_t)f->e[k]),
                            rto__val_uint(IMAGE_STEP));
        }
        c->r->tolerance_bound = IMAGE_STEP;
        const pixel_diff *f = &ps->list[0];
        rto__report_summary(c->r, "image: %" PRIu64 " of %" PRIu64 " compared pixels (%.3g %%) differ by more than +-1 "
                           "in a channel, over the %.3g %% allowed; the first: pixel %" PRIu32 " (x %" PRIu32
                           ", y %" PRIu32 "), rgba (%g, %g, %g, %g), the oracle's (%g, %g, %g, %g)", ps->over,
                           ps->compared, ps->compared ? 100.0 * (double)ps->over / (double)ps->compared : 0.0,
                           c->fail_percent, p, f->x, f->y, (double)f->a[0], (double)f->a[1], (double)f->a[2],
                           ch == 4 ? (double)f->a[3] : 255.0, (double)f->e[0], (double)f->e[1], (double)f->e[2],
                           (double)f->e[3]);
    }
    if (c->desc->artifact_dir)
        s = keep_images(ps, c->w, c->h, ch, RTO_PIXEL_U8, e.pixels, 4, g.pixels, c->mask, c->msg);
out:
    rto_image_free(&e);
    rto_image_free(&g);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Artefacts                                                                                                        */

static json_t *stats_json(const fcheck *c, const pixel_stats *ps, const char *rule, int *bad)
{
    json_t *o = json_object();
    if (!o) {
        *bad = 1;
        return NULL;
    }
    const struct {
        const char *k;
        json_t *v;
    } kv[] = {
        {"file", json_string(ps->file)},
        {"rule", json_string(rule)},
        {"width", json_integer(c->w)},
        {"height", json_integer(c->h)},
        {"channels", json_integer(ps->channels)},
        {"compared_pixels", json_integer((json_int_t)ps->compared)},
        {"not_comparable_pixels", json_integer((json_int_t)ps->excluded)},
        {"failing_pixels", json_integer((json_int_t)ps->over)},
        {"max_error", rto__json_real(ps->max_diff)},
        {"max_error_at", json_pack("[III]", (json_int_t)ps->max_x, (json_int_t)ps->max_y, (json_int_t)ps->max_c)},
        {"rms_error", ps->have_oiio ? rto__json_real(ps->oiio.rms_error) : json_null()},
        {"psnr", ps->have_oiio ? rto__json_real(ps->oiio.psnr) : json_null()},
    };
    for (size_t i = 0; i < sizeof kv / sizeof kv[0]; i++)
        if (!kv[i].v || json_object_set_new(o, kv[i].k, kv[i].v))
            *bad = 1;
    json_t *list = json_array();
    for (uint32_t i = 0; list && i < ps->nlist; i++) {
        const pixel_diff *p = &ps->list[i];
        json_t *e = json_array(), *a = json_array();
        for (uint32_t k = 0; e && a && k < ps->channels; k++)
            if (json_array_append_new(e, rto__json_real(p->e[k])) || json_array_append_new(a, rto__json_real(p->a[k])))
                *bad = 1;
        json_t *item = json_pack("{s:I, s:I, s:o, s:o}", "x", (json_int_t)p->x, "y", (json_int_t)p->y, "expected",
                                 e ? e : json_null(), "actual", a ? a : json_null());
        if (!item || json_array_append_new(list, item))
            *bad = 1;
    }
    if (!list || json_object_set_new(o, "first_failing", list))
        *bad = 1;
    return o;
}

static rto_status write_listing(fcheck *c, const char *path)
{
    int bad = 0;
    json_t *root = json_object();
    if (!root)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    char accum_rule[128];
    snprintf(accum_rule, sizeof accum_rule, "|actual - expected| <= 1e-4 |expected| + %g per channel (DESIGN.md §9)",
             c->accum_abs);
    if (c->accum.failed && json_object_set_new(root, "accum", stats_json(c, &c->accum, accum_rule, &bad)))
        bad = 1;
    if (c->image.failed) {
        char rule[128];
        snprintf(rule, sizeof rule, "+-1 per channel; at most %g %% of the compared pixels over (DESIGN.md §9)",
                 c->fail_percent);
        if (json_object_set_new(root, "image", stats_json(c, &c->image, rule, &bad)))
            bad = 1;
    }
    char *text = bad ? NULL : rto__json_text(root, JSON_INDENT(2) | JSON_REAL_PRECISION(9));
    json_decref(root);
    if (!text)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory writing %s", path);
    rto_msg m = {{0}};
    rto_status s = rto_file_write(path, text, strlen(text), &m);
    free(text);
    return s ? rto__fail(c->msg, s, "cannot write the diff listing: %s", m.text) : RTO_OK;
}

static rto_status write_diff(fcheck *c, pixel_stats *ps, uint32_t bit, double scale)
{
    char *path = join(c->desc->artifact_dir, rto_frame_artifact_name(bit));
    if (!path)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_image_compare_desc d;
    memset(&d, 0, sizeof d);
    d.fail = 1.0 / 255.0; /* thresholds only shape OpenImageIO's counts; the verdict is this validator's */
    d.warn = d.fail;
    d.diff_path = path;
    d.diff_scale = scale;
    rto_msg m = {{0}};
    rto_status s = rto_image_compare(&ps->expected, &ps->actual, &d, &ps->oiio, &m);
    free(path);
    if (s)
        return rto__fail(c->msg, s, "cannot write the diff image: %s", m.text);
    ps->have_oiio = 1;
    c->artifacts |= bit;
    return RTO_OK;
}

static rto_status write_artifacts(fcheck *c)
{
    if (!c->desc->artifact_dir || (!c->accum.failed && !c->image.failed))
        return RTO_OK;
    rto_status s;
    if (c->accum.failed && c->accum.expected.pixels && (s = write_diff(c, &c->accum, RTO_FRAME_ARTIFACT_ACCUM_DIFF, 1)))
        return s;
    if (c->image.failed && c->image.expected.pixels &&
        (s = write_diff(c, &c->image, RTO_FRAME_ARTIFACT_IMAGE_DIFF, 16)))
        return s;
    char *path = join(c->desc->artifact_dir, rto_frame_artifact_name(RTO_FRAME_ARTIFACT_LISTING));
    if (!path)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    s = write_listing(c, path);
    free(path);
    if (!s)
        c->artifacts |= RTO_FRAME_ARTIFACT_LISTING;
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The check                                                                                                        */

static void finish_report(fcheck *c)
{
    rto_report *r = c->r;
    uint64_t nc = 0, conflict = 0, dropped = 0;
    for (uint64_t p = 0; p < c->pixels; p++) {
        nc += c->mask[p] != 0;
        conflict += (c->mask[p] & RTO_PIXEL_CONFLICT) != 0;
        dropped += (c->mask[p] & (RTO_PIXEL_DROPPED | MASK_DROP_QUEUE)) != 0;
    }
    rto__report_fact(r, "width", c->w);
    rto__report_fact(r, "height", c->h);
    rto__report_fact(r, "files_compared", (int64_t)c->files_compared);
    rto__report_fact(r, "not_dumped", (int64_t)c->files_not_dumped);
    rto__report_fact(r, "not_comparable", (int64_t)nc);
    rto__report_fact(r, "rays_compared", (int64_t)c->rays_compared);
    rto__report_fact(r, "accum_over", (int64_t)c->accum.over);
    rto__report_fact(r, "image_over", (int64_t)c->image.over);
    if (r->code == RTO_FRAME_OK) {
        rto__report_summary(r, "ok: %" PRIu64 " file(s) of the GPU dump agree with the frame (%" PRIu64
                           " rays compared)", c->files_compared, c->rays_compared);
        if (c->image.run && c->image.over)
            rto__report_append(r, "; %" PRIu64 " image pixel(s) beyond +-1, within the %.3g %% allowed", c->image.over,
                              c->fail_percent);
    } else if (c->nlater) {
        rto__report_append(r, "; later:");
        for (uint32_t i = 0; i < c->nlater; i++) {
            if (c->later[i].bounce >= 0)
                rto__report_append(r, "%s %s at bounce %" PRId64, i ? "," : "", rto_frame_fault_name(c->later[i].f),
                                  c->later[i].bounce);
            else
                rto__report_append(r, "%s %s", i ? "," : "", rto_frame_fault_name(c->later[i].f));
        }
    }
    if (nc)
        rto__report_append(r, "; not comparable: %" PRIu64 " pixel(s) left out of accum and image (%" PRIu64
                          " conflict, %" PRIu64 " drop)", nc, conflict, dropped);
    if (c->drop_queue != NONE32)
        rto__report_append(r, "; queue %" PRIu32 " dropped %" PRIu32 " ray(s): it and later queues compared by counts "
                          "only%s%s%s", c->drop_queue, c->cnt[c->drop_queue].dropped,
                          c->drop_skipped[0] ? " (not compared: " : "", c->drop_skipped, c->drop_skipped[0] ? ")" : "");
    if (c->skipped[0])
        rto__report_append(r, "; not compared: %s", c->skipped);
    if (c->not_dumped[0])
        rto__report_append(r, "; not dumped: %s", c->not_dumped);
}

static void fcheck_free(fcheck *c)
{
    rto_npy_free(&c->e_emit);
    rto_npy_free(&c->e_ind);
    rto_npy_free(&c->e_cnt);
    rto_npy_free(&c->e_nc);
    rto_npy_free(&c->g_emit);
    rto_npy_free(&c->g_ind);
    rto_npy_free(&c->g_cnt);
    rto_npy_free(&c->inst);
    for (uint32_t m = 0; m < c->nmeshes; m++) {
        rto_npy_free(&c->mesh_npy[2 * m]);
        rto_npy_free(&c->mesh_npy[2 * m + 1]);
    }
    free(c->mesh_npy);
    free(c->meshes);
    free(c->instances);
    free(c->mask);
    free(c->accum.expected.pixels);
    free(c->accum.actual.pixels);
    free(c->image.expected.pixels);
    free(c->image.actual.pixels);
    rto_bundle_close(c->b);
}

rto_status rto_frame_check(const rto_frame_check_desc *desc, rto_report *report, uint32_t *artifacts, rto_msg *msg)
{
    if (artifacts)
        *artifacts = 0;
    if (!desc || !report)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL descriptor or report");
    rto__report_begin(report, "check-frame");
    for (size_t k = 0; k < sizeof check_names / sizeof check_names[0]; k++)
        rto__report_add_check(report, check_names[k]);
    if (!desc->expected_dir || !desc->expected_dir[0])
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no expected frame bundle given");
    if (!desc->gpu_dir || !desc->gpu_dir[0])
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no GPU dump directory given");
    const double pct = desc->image_fail_percent_set ? desc->image_fail_percent : IMAGE_PERCENT_DEFAULT;
    if (!(pct >= 0.0 && pct <= 100.0))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "the image failure percentage %g is outside 0 .. 100", pct);
    struct stat st;
    if (stat(desc->gpu_dir, &st) != 0)
        return rto__fail(msg, RTO_ERR_IO, "GPU dump %s: %s", desc->gpu_dir, strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return rto__fail(msg, RTO_ERR_IO, "GPU dump %s is not a directory (name the directory the dump's files are in)",
                        desc->gpu_dir);

    fcheck c;
    memset(&c, 0, sizeof c);
    c.desc = desc;
    c.r = report;
    c.msg = msg;
    c.drop_queue = NONE32;
    c.fail_percent = pct;
    snprintf(report->tolerance, sizeof report->tolerance,
             "counts, args, IDs exact; rays: origin 1e-5*max(4M,|o|), dir/tMin/tMax 1e-5*max(1,|v|); payload, accum "
             "1e-4 rel + 1e-6 (triangle: + 2e-4); hits as check-hits; image +-1, <= %g %% pixels (§9)", pct);
    rto_msg m = {{0}};
    rto_status s = rto_bundle_open(desc->expected_dir, &c.b, &m);
    if (s) {
        rto__fail(msg, s, "expected bundle: %s", m.text);
        goto out;
    }
    if ((s = read_manifest(&c)) || (s = read_frame_arrays(&c)) || (s = read_scale(&c)) ||
        (s = mark_drop_pixels(&c)) || (s = read_gpu_arrays(&c)))
        goto out;
    c.files_compared += (uint64_t)c.have_g_emit + (uint64_t)c.have_g_ind + (uint64_t)c.have_g_cnt;
    for (uint32_t d = 0; d <= c.depth; d++) {
        step_counts(&c, d);
        step_indirect(&c, d);
        if ((s = step_queue(&c, d)))
            goto out;
        if (d < c.depth) {
            step_hit_counters(&c, d);
            step_shade_counters(&c, d);
        }
    }
    step_extra_queues(&c);
    if ((s = step_accum(&c)) || (s = step_image(&c)))
        goto out;
    if (!c.files_compared) {
        s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                     "GPU dump %s holds nothing to compare with the frame: none of its file names (emit_counts.npy, "
                     "indirect_args.npy, bounce_D_rays.npy, accum.npy, image.png, ...)%s%s", desc->gpu_dir,
                     c.skipped[0] ? " that the bundle keeps; not compared: " : "", c.skipped);
        goto out;
    }
    if ((s = write_artifacts(&c)))
        goto out;
    /* the checks that ran and found nothing: passed (a failed one stays failed) */
    const int ran[7] = {c.have_g_emit || c.have_g_cnt, c.have_g_ind, c.rays_compared > 0, c.payloads_run,
                        c.hits_run, c.accum.run, c.image.run};
    for (size_t k = 0; k < 7; k++)
        if (ran[k])
            rto__report_mark(report, check_names[k], RTO_CHECK_PASSED);
    {
        const char *program = rto_bundle_get_str(c.b, "program", "name");
        const char *scene = rto_bundle_get_str(c.b, "", "scene");
        const char *slash = scene ? strrchr(scene, '/') : NULL;
        scene = slash && slash[1] ? slash + 1 : scene; /* a scene file by its name: the report's line stays short */
        snprintf(report->what, sizeof report->what, "%.40s %" PRIu32 "x%" PRIu32 "%s%.40s", program ? program : "?",
                 c.w, c.h, c.stage2 ? " stage2" : scene ? " " : "", c.stage2 ? "" : scene ? scene : "");
        snprintf(report->context, sizeof report->context,
                 "maxDepth %" PRIu32 " (%" PRIu32 " queues of capacity %" PRIu64 "), GPU dump: %" PRIu64
                 " file(s) compared, %" PRIu64 " not dumped", c.depth, c.depth + 1, c.cap, c.files_compared,
                 c.files_not_dumped);
    }
    finish_report(&c);
    if (artifacts)
        *artifacts = c.artifacts;
    s = report->code ? RTO_ERR_MISMATCH : RTO_OK;
out:
    fcheck_free(&c);
    return s;
}
