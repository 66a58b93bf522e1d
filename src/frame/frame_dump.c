/* check-frame's input (check_frame_internal.h): the expected frame bundle and the GPU's dump read and checked
 * for shape. */
#include "check_frame_internal.h"
#include "core/tolerance.h"
#include "io/io_internal.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Limits of what a frame bundle can describe: what rto_frame_render accepts (2^26 pixels, maxDepth 64). */
#define FRAME_MAX_PIXELS (UINT64_C(1) << 26)
#define FRAME_MAX_DEPTH 64u

/* ---------------------------------------------------------------------------------------------------------------- */
/* Small helpers                                                                                                    */

char *rto__fc_join(const char *dir, const char *name)
{
    const size_t n = strlen(dir) + strlen(name) + 2;
    char *p = malloc(n);
    if (p)
        snprintf(p, n, "%s/%s", dir, name);
    return p;
}

void rto__fc_list_add(char *buf, size_t cap, const char *item)
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

const char *rto__fc_file_name(rto_bundle_file f, uint32_t d, char name[RTO_BUNDLE_FILE_NAME_MAX])
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

rto_status rto__fc_bad_expected(fcheck *c, const char *file, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    const rto_status s = bad_file(c, "expected bundle", c->desc->expected_dir, file, fmt, ap);
    va_end(ap);
    return s;
}

rto_status rto__fc_bad_gpu(fcheck *c, const char *file, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    const rto_status s = bad_file(c, "GPU dump", c->desc->gpu_dir, file, fmt, ap);
    va_end(ap);
    return s;
}

/* Whether the bundle keeps a file: listed in its manifest (a listed file that is gone is a damaged bundle, refused
 * when read). */
int rto__fc_exp_has(fcheck *c, const char *name) { return rto__bundle_lists(c->b, name); }

/* Loads a bundle file (sha256 checked) and requires exactly want's dtype and shape. */
rto_status rto__fc_exp_load(fcheck *c, const char *name, const rto_npy_desc *want, rto_npy *out)
{
    memset(out, 0, sizeof *out);
    if (!rto__fc_exp_has(c, name))
        return rto__fc_bad_expected(c, name, "not listed in its manifest.json");
    rto_msg m = {{0}};
    rto_status s = rto_bundle_read_name(c->b, name, out, &m);
    if (s)
        return rto__fail(c->msg, s, "expected bundle %s: %s: %s", c->desc->expected_dir, name, m.text);
    if (!rto_npy_desc_equal(&out->desc, want)) {
        char have[160], need[160];
        return rto__fc_bad_expected(c, name, "holds %s; expected %s", rto_npy_desc_text(&out->desc, NULL, have, sizeof have),
                                    rto_npy_desc_text(want, NULL, need, sizeof need));
    }
    return RTO_OK;
}

/* Whether the dump holds a file of that name (a dangling link counts: reading it then fails). */
int rto__fc_gpu_has(fcheck *c, const char *name)
{
    char *path = rto__fc_join(c->desc->gpu_dir, name);
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
    char *path = rto__fc_join(c->desc->gpu_dir, name);
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

rto_status rto__fc_gpu_load(fcheck *c, const char *name, rto_npy *out, int *present)
{
    memset(out, 0, sizeof *out);
    return gpu_read(c, name, read_npy, out, present);
}

/* A dump's image: its header first; its pixels only when its size is the frame's, decoding no more than that size
 * needs (a 16384 x 16384 image.png of a few kilobytes is refused from its header, not decoded into gigabytes). A
 * header-only image (pixels NULL) comes back when the size differs: the callers name the size and read no pixel. */
rto_status rto__fc_gpu_image(fcheck *c, const char *name, rto_image *out, int *present)
{
    memset(out, 0, sizeof *out);
    rto_status s = gpu_read(c, name, probe_image, out, present);
    if (s || !*present || out->width != c->w || out->height != c->h)
        return s;
    const size_t budget = (size_t)c->pixels * out->channels * (out->type == RTO_PIXEL_U8 ? 1 : sizeof(float));
    char *path = rto__fc_join(c->desc->gpu_dir, name);
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
void rto__fc_not_dumped(fcheck *c, const char *name)
{
    c->files_not_dumped++;
    rto__fc_list_add(c->not_dumped, sizeof c->not_dumped, name);
}

void rto__fc_skipped(fcheck *c, const char *name, const char *why)
{
    char item[RTO_BUNDLE_FILE_NAME_MAX + 48];
    snprintf(item, sizeof item, "%s (%s)", name, why);
    rto__fc_list_add(c->skipped, sizeof c->skipped, item);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The bundle                                                                                                       */

static rto_status manifest_uint(fcheck *c, const char *key, uint64_t lo, uint64_t hi, uint64_t *out)
{
    int64_t v = -1;
    if (!rto_bundle_get_int(c->b, "frame", key, &v) || v < 0 || (uint64_t)v < lo || (uint64_t)v > hi)
        return rto__fc_bad_expected(c, "manifest.json", "frame.%s is missing or outside %" PRIu64 " .. %" PRIu64, key,
                                    lo, hi);
    *out = (uint64_t)v;
    return RTO_OK;
}

rto_status rto__fc_read_manifest(fcheck *c)
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
        return rto__fc_bad_expected(c, "manifest.json", "a frame of %" PRIu64 " x %" PRIu64 " pixels is larger than "
                                    "2^26", w, h);
    if ((s = manifest_uint(c, "max_depth", 1, FRAME_MAX_DEPTH, &d)) ||
        (s = manifest_uint(c, "capacity", 2 * w * h, 2 * w * h, &cap)) ||
        (s = manifest_uint(c, "payload_size", 0, RTO_PAYLOAD_MAX, &ps)))
        return s;
    if (ps % 4)
        return rto__fc_bad_expected(c, "manifest.json", "frame.payload_size %" PRIu64 " is not a multiple of 4", ps);
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
        return rto__fc_bad_expected(c, "manifest.json",
                                    "frame.scene_kind is missing or neither \"mesh\" nor \"stage2\"");
    const char *program = rto_bundle_get_str(c->b, "program", "name");
    c->accum_abs =
        program && !strcmp(program, "triangle") && !c->stage2 ? RTO__TOL_ACCUM_ABS_BARY : RTO__TOL_ACCUM_ABS;
    return RTO_OK;
}

static double max_abs(double m, float v) { return isfinite(v) && fabs((double)v) > m ? fabs((double)v) : m; }

/* M, the scale of the ray-origin tolerance: the largest magnitude of the camera position and the scene bounds (the
 * stage2 scene's ground slab reaches 10 from the origin). */
rto_status rto__fc_read_scale(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto_npy cam = {0}, boxes = {0};
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_CAMERA, 1);
    rto_status s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_CAMERA, 0, name), &want, &cam);
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
            return rto__fc_bad_expected(c, "manifest.json", "counts.instances is missing or outside 0 .. %u",
                                        RTO_TLAS_MAX_INSTANCES);
        want = rto_layout_desc(RTO_LAYOUT_AABB, (uint64_t)n);
        if ((s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_INSTANCE_AABBS, 0, name), &want, &boxes)))
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
rto_status rto__fc_read_frame_arrays(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const uint64_t q = (uint64_t)c->depth + 1;
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_U32, 1, q, 0, 0);
    rto_status s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_EMIT_COUNTS, 0, name), &d, &c->e_emit);
    if (s)
        return s;
    d = rto_npy_desc_array(RTO_DTYPE_U32, 2, q, 3, 0);
    if ((s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_INDIRECT_ARGS, 0, name), &d, &c->e_ind)))
        return s;
    d = rto_layout_desc(RTO_LAYOUT_FRAME_COUNTERS, q);
    if ((s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_FRAME_COUNTERS, 0, name), &d, &c->e_cnt)))
        return s;
    d = rto_npy_desc_array(RTO_DTYPE_U8, 2, c->h, c->w, 0);
    if ((s = rto__fc_exp_load(c, rto__fc_file_name(RTO_FILE_NOT_COMPARABLE, 0, name), &d, &c->e_nc)))
        return s;
    c->emit = c->e_emit.data;
    c->ind = c->e_ind.data;
    c->cnt = c->e_cnt.data;
    for (uint32_t k = 0; k < q; k++) {
        const rto_frame_counters *fc = &c->cnt[k];
        const uint32_t queued = (uint64_t)fc->emitted < c->cap ? fc->emitted : (uint32_t)c->cap;
        if (fc->emitted != c->emit[k])
            return rto__fc_bad_expected(c, rto__fc_file_name(RTO_FILE_FRAME_COUNTERS, 0, name),
                                        "queue %" PRIu32 ": emitted %" PRIu32 ", but emit_counts.npy says %" PRIu32, k,
                                        fc->emitted, c->emit[k]);
        if (fc->queued != queued || fc->dropped != fc->emitted - queued)
            return rto__fc_bad_expected(c, name, "queue %" PRIu32 ": queued %" PRIu32 " and dropped %" PRIu32 " do not "
                                        "follow from emitted %" PRIu32 " and the capacity %" PRIu64, k, fc->queued,
                                        fc->dropped, fc->emitted, c->cap);
        if (fc->traced != (k < c->depth ? queued : 0) || (uint64_t)fc->hits + fc->misses != fc->traced)
            return rto__fc_bad_expected(c, name, "queue %" PRIu32 ": traced %" PRIu32 ", hits %" PRIu32 " and misses "
                                        "%" PRIu32 " do not follow from queued %" PRIu32, k, fc->traced, fc->hits,
                                        fc->misses, queued);
        const uint32_t *a = &c->ind[3 * k];
        if (a[0] != ceil64(queued) || a[1] != 1 || a[2] != 1)
            return rto__fc_bad_expected(c, rto__fc_file_name(RTO_FILE_INDIRECT_ARGS, 0, name),
                                        "queue %" PRIu32 ": [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] is not "
                                        "[ceil(%" PRIu32 " / 64), 1, 1]", k, a[0], a[1], a[2], queued);
        if (fc->dropped && c->drop_queue == NONE32)
            c->drop_queue = k;
    }
    const uint8_t *nc = c->e_nc.data;
    for (uint64_t p = 0; p < c->pixels; p++)
        if (nc[p] & ~(RTO_PIXEL_CONFLICT | RTO_PIXEL_DROPPED))
            return rto__fc_bad_expected(c, rto__fc_file_name(RTO_FILE_NOT_COMPARABLE, 0, name),
                                        "pixel %" PRIu64 " holds 0x%02x; only RTO_PIXEL_CONFLICT (1) and "
                                        "RTO_PIXEL_DROPPED (2) are defined", p, nc[p]);
    c->mask = rto__alloc(c->pixels, 1);
    if (!c->mask)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(c->mask, nc, c->pixels);
    return RTO_OK;
}

/* The scene a hit is re-intersected with (rto_hits_check): instances and mesh geometry, as check-hits reads them.
 * Read once, on the first bounce whose hits are compared. */
rto_status rto__fc_load_scene(fcheck *c)
{
    if (c->scene_loaded)
        return RTO_OK;
    c->scene_loaded = 1;
    rto_msg m = {{0}};
    /* the one scene reader (rto_scene_bundle_read), whose "DIR: FILE: what" is named as the expected bundle's */
    rto_status s = rto_scene_bundle_read(c->desc->expected_dir, &c->scene, &m);
    return s ? rto__fail(c->msg, s, "expected bundle %s", m.text) : RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The dump's frame-wide arrays                                                                                     */

rto_status rto__fc_read_gpu_arrays(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], have[160];
    rto_status s = rto__fc_gpu_load(c, rto__fc_file_name(RTO_FILE_EMIT_COUNTS, 0, name), &c->g_emit, &c->have_g_emit);
    if (s)
        return s;
    if (c->have_g_emit) {
        const rto_npy_desc *d = &c->g_emit.desc;
        if (d->dtype != RTO_DTYPE_U32 || d->ndim != 1)
            return rto__fc_bad_gpu(c, name, "holds %s; expected dtype <u4, shape (maxDepth + 1,)",
                                   rto_npy_desc_text(d, NULL, have, sizeof have));
        c->g_emit_n = (size_t)d->shape[0];
    } else {
        rto__fc_not_dumped(c, name);
    }
    if ((s = rto__fc_gpu_load(c, rto__fc_file_name(RTO_FILE_INDIRECT_ARGS, 0, name), &c->g_ind, &c->have_g_ind)))
        return s;
    if (c->have_g_ind) {
        /* (queues, 3) as written, or the raw buffer of 3 words per queue */
        const rto_npy_desc *d = &c->g_ind.desc;
        const int shape_ok = (d->ndim == 2 && d->shape[1] == 3) || (d->ndim == 1 && d->shape[0] % 3 == 0);
        if (d->dtype != RTO_DTYPE_U32 || !shape_ok)
            return rto__fc_bad_gpu(c, name, "holds %s; expected dtype <u4, shape (maxDepth + 1, 3) or "
                                   "(3 * (maxDepth + 1),)", rto_npy_desc_text(d, NULL, have, sizeof have));
        c->g_ind_n = (size_t)(d->ndim == 2 ? d->shape[0] : d->shape[0] / 3);
    } else {
        rto__fc_not_dumped(c, name);
    }
    if ((s = rto__fc_gpu_load(c, rto__fc_file_name(RTO_FILE_FRAME_COUNTERS, 0, name), &c->g_cnt, &c->have_g_cnt)))
        return s;
    if (c->have_g_cnt) {
        rto_msg m = {{0}};
        if (rto_layout_accept(RTO_LAYOUT_FRAME_COUNTERS, &c->g_cnt, &c->g_cnt_n, &m))
            return rto__fc_bad_gpu(c, name, "%s", m.text);
    }
    /* frame_counters.npy is optional for a GPU (its emit counter is in emit_counts.npy): never "not dumped" */
    return RTO_OK;
}

/* The rays of a GPU queue dump: WfRay records or their words (rto_layout_accept). A dump of the whole buffer
 * (capacity records) is cut to the queue's length n. */
rto_status rto__fc_gpu_rays(fcheck *c, const char *name, const rto_npy *g, size_t n, size_t *m)
{
    rto_msg mm = {{0}};
    if (rto_layout_accept(RTO_LAYOUT_WF_RAY, g, m, &mm))
        return rto__fc_bad_gpu(c, name, "%s", mm.text);
    if (*m == c->cap && n < c->cap)
        *m = n;
    return RTO_OK;
}

/* The queue's length on the GPU: min(its emit counter, capacity) when dumped, else the oracle's. */
size_t rto__fc_gpu_queue_len(const fcheck *c, uint32_t d)
{
    if (c->have_g_emit && d < c->g_emit_n) {
        const uint32_t e = ((const uint32_t *)c->g_emit.data)[d];
        return (uint64_t)e < c->cap ? e : (size_t)c->cap;
    }
    return c->cnt[d].queued;
}

/* Reads the dump's file of a bounce that pairs with its rays (payloads, hits) into g. Returns 1 when there is
 * something to compare: the dump has the file, the bundle keeps it, and the dump's queue is there to pair it with;
 * otherwise notes why not (not dumped, skipped) and returns 0, with *s set on an error. */
int rto__fc_gpu_bounce_file(fcheck *c, const char *name, const rto_wf_ray *rg, rto_npy *g, rto_status *s)
{
    const int expected = rto__fc_exp_has(c, name);
    int present = 0;
    if ((*s = rto__fc_gpu_load(c, name, g, &present)))
        return 0;
    if (!present) {
        if (expected)
            rto__fc_not_dumped(c, name);
        return 0;
    }
    if (!expected) {
        rto__fc_skipped(c, name, "not kept by the bundle");
        return 0;
    }
    if (!rg) {
        rto__fc_skipped(c, name, "no rays dumped to pair them with");
        return 0;
    }
    return 1;
}

/* Marks the pixels a dropping queue makes incomparable: every pixel with a ray in it (kept or dropped). Descendant
 * rays keep their pixel, so later queues add none. Without the queue's rays in the bundle, no pixel is safe. */
rto_status rto__fc_mark_drop_pixels(fcheck *c)
{
    if (c->drop_queue == NONE32)
        return RTO_OK;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__fc_file_name(RTO_FILE_BOUNCE_RAYS, c->drop_queue, name);
    if (!rto__fc_exp_has(c, name)) {
        for (uint64_t p = 0; p < c->pixels; p++)
            c->mask[p] |= MASK_DROP_QUEUE;
        return RTO_OK;
    }
    rto_npy e = {0};
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_WF_RAY, c->cnt[c->drop_queue].queued);
    rto_status s = rto__fc_exp_load(c, name, &want, &e);
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

rto_status rto__fc_read_expected(fcheck *c)
{
    rto_msg m = {{0}};
    rto_status s = rto_bundle_open(c->desc->expected_dir, &c->b, &m);
    if (s)
        return rto__fail(c->msg, s, "expected bundle: %s", m.text);
    if ((s = rto__fc_read_manifest(c)) || (s = rto__fc_read_frame_arrays(c)))
        return s;
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The frame bundle read back (rto_frame_bundle_read): what check-frame reads first                                 */

struct rto_frame_bundle_data {
    fcheck c;
    rto_frame_check_desc desc;
};

void rto_frame_bundle_free(rto_frame_bundle *fb)
{
    if (!fb)
        return;
    if (fb->data) {
        rto__fc_free(&fb->data->c);
        free((char *)fb->data->desc.expected_dir);
        free(fb->data);
    }
    rto_scene_bundle_free(&fb->scene);
    memset(fb, 0, sizeof *fb);
}

rto_status rto_frame_bundle_read(const char *dir, rto_frame_bundle *fb, rto_msg *msg)
{
    if (!fb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL frame bundle");
    memset(fb, 0, sizeof *fb);
    if (!dir || !dir[0])
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no frame bundle given");
    struct rto_frame_bundle_data *a = calloc(1, sizeof *a);
    char *copy = strdup(dir);
    if (!a || !copy) {
        free(a);
        free(copy);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    fb->data = a;
    a->desc.expected_dir = copy;
    a->c.desc = &a->desc;
    a->c.msg = msg;
    a->c.drop_queue = NONE32;
    rto_status s = rto__fc_read_expected(&a->c);
    if (!s && !a->c.stage2)
        s = rto__fc_load_scene(&a->c);
    if (s) {
        rto_frame_bundle_free(fb);
        return s;
    }
    fcheck *c = &a->c;
    rto_bundle_close(c->b);
    c->b = NULL;
    fb->scene = c->scene; /* the bundle owns it from here */
    memset(&c->scene, 0, sizeof c->scene);
    fb->width = c->w;
    fb->height = c->h;
    fb->max_depth = c->depth;
    fb->payload_words = c->words;
    fb->stage2 = c->stage2;
    fb->emit_counts = c->emit;
    fb->indirect_args = c->ind;
    fb->frame_counters = c->cnt;
    fb->not_comparable = c->e_nc.data;
    return RTO_OK;
}
