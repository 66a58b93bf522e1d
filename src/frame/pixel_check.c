/* check-frame's pixels (check_frame_internal.h): accum and the 8-bit image against the bundle's, pixel by pixel
 * under DESIGN.md §9, their statistics, and the artefacts written for a failed comparison (diff images, listing). */
#include "check_frame_internal.h"
#include "core/tolerance.h"
#include "core/json.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The image rule (docs/frame.md "The GPU dump layout"; DESIGN.md §9): +-1 per channel, a configurable percentage of
 * the compared pixels allowed over it. */
#define IMAGE_STEP 1

/* ---------------------------------------------------------------------------------------------------------------- */
/* Accum and image                                                                                                  */

static const char channel_names[4][2] = {"r", "g", "b", "a"};

/* §9's accum rule for one channel with the frame's absolute part: within 1e-4 |e| + 1e-6 (+ 2e-4 for `triangle`);
 * infinities must match, NaN matches only NaN. */
static int accum_close(const fcheck *c, float e, float a) { return rto__tol_accum_close(e, a, c->accum_abs); }

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
    if (!rto__fc_claim(c, f, -1))
        return;
    rto__fc_uint_row(c, 0, "width", c->w, gw);
    rto__fc_uint_row(c, 0, "height", c->h, gh);
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
    if (!rto__fc_claim(c, RTO_FRAME_ACCUM, -1))
        return;
    const pixel_diff *f = &ps->list[0];
    rto__fc_at_pixel(c, f->y * c->w + f->x);
    uint32_t k0 = 0;
    while (k0 + 1 < ch && accum_close(c, f->e[k0], f->a[k0]))
        k0++;
    c->r->tolerance_bound = rto__tol_accum(f->e[k0], c->accum_abs);
    for (uint32_t i = 0; i < ps->nlist && c->r->nrows < RTO_REPORT_MAX_ROWS; i++)
        for (uint32_t k = 0; k < ch; k++) {
            const pixel_diff *x = &ps->list[i];
            if (!accum_close(c, x->e[k], x->a[k]))
                rto__fc_add_row(c, (uint64_t)x->y * c->w + x->x, channel_names[k], rto__val_f32(x->e[k]),
                                rto__val_f32(x->a[k]), rto__val_f64((double)x->a[k] - (double)x->e[k]),
                                rto__val_f64(rto__tol_accum(x->e[k], c->accum_abs)));
        }
    rto__report_summary(c->r, "accum: %s: pixel %" PRIu32 " (x %" PRIu32 ", y %" PRIu32 ") channel %s is %.9g, the "
                       "oracle's %.9g (|diff| %.3g > %.3g); %" PRIu64 " of %" PRIu64 " compared pixels outside 1e-4 "
                       "relative + %g", file, f->y * c->w + f->x, f->x, f->y, channel_names[k0], (double)f->a[k0],
                       (double)f->e[k0], fabs((double)f->a[k0] - (double)f->e[k0]),
                       rto__tol_accum(f->e[k0], c->accum_abs), ps->over, ps->compared, c->accum_abs);
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

rto_status rto__fc_step_accum(fcheck *c)
{
    char nname[RTO_BUNDLE_FILE_NAME_MAX], xname[RTO_BUNDLE_FILE_NAME_MAX], have[160];
    rto__fc_file_name(RTO_FILE_ACCUM, 0, nname);
    rto__fc_file_name(RTO_FILE_ACCUM_EXR, 0, xname);
    const int expected = rto__fc_exp_has(c, nname);
    rto_npy e = {0}, g = {0};
    rto_image gi = {0};
    int have_npy = 0, have_exr = 0;
    rto_status s = rto__fc_gpu_load(c, nname, &g, &have_npy);
    if (!s)
        s = rto__fc_gpu_image(c, xname, &gi, &have_exr);
    if (s)
        goto out;
    if (!have_npy && !have_exr) {
        if (expected)
            rto__fc_not_dumped(c, "accum.npy / accum.exr");
        goto out;
    }
    if (!expected) {
        rto__fc_skipped(c, have_npy ? nname : xname, "not kept by the bundle");
        goto out;
    }
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_F32, 3, c->h, c->w, 4);
    if ((s = rto__fc_exp_load(c, nname, &want, &e)))
        goto out;
    const float *ef = e.data;
    for (int src = 0; src < 2; src++) {
        const float *a = NULL;
        uint32_t ch = 0, gw = 0, gh = 0;
        const char *file = src ? xname : nname;
        if (src == 0 && have_npy) {
            const rto_npy_desc *d = &g.desc;
            if (d->dtype != RTO_DTYPE_F32 || d->ndim != 3 || (d->shape[2] != 3 && d->shape[2] != 4)) {
                s = rto__fc_bad_gpu(c, nname, "holds %s; expected dtype <f4, shape (height, width, 4) or "
                                    "(height, width, 3)", rto_npy_desc_text(d, NULL, have, sizeof have));
                goto out;
            }
            a = g.data;
            gh = d->shape[0] > UINT32_MAX ? UINT32_MAX : (uint32_t)d->shape[0];
            gw = d->shape[1] > UINT32_MAX ? UINT32_MAX : (uint32_t)d->shape[1];
            ch = (uint32_t)d->shape[2];
        } else if (src == 1 && have_exr) {
            if (gi.type != RTO_PIXEL_F32 || (gi.channels != 3 && gi.channels != 4)) {
                s = rto__fc_bad_gpu(c, xname, "is a %" PRIu32 "-channel %s image; expected RGBA or RGB float (linear "
                                    "accum)", gi.channels, gi.type == RTO_PIXEL_U8 ? "8-bit" : "float");
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

rto_status rto__fc_step_image(fcheck *c)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__fc_file_name(RTO_FILE_IMAGE, 0, name);
    const int expected = rto__fc_exp_has(c, name);
    rto_image e = {0}, g = {0};
    int present = 0;
    rto_status s = rto__fc_gpu_image(c, name, &g, &present);
    if (s || !present) {
        if (!s && expected)
            rto__fc_not_dumped(c, name);
        return s;
    }
    if (!expected) {
        rto__fc_skipped(c, name, "not kept by the bundle");
        goto out;
    }
    rto_msg m = {{0}};
    if ((s = rto_bundle_read_image(c->b, name, &e, &m))) {
        s = rto__fail(c->msg, s, "expected bundle %s: %s: %s", c->desc->expected_dir, name, m.text);
        goto out;
    }
    if (e.type != RTO_PIXEL_U8 || e.channels != 4 || e.width != c->w || e.height != c->h) {
        s = rto__fc_bad_expected(c, name, "is a %" PRIu32 " x %" PRIu32 " image of %" PRIu32 " %s channels; expected "
                                 "%" PRIu32 " x %" PRIu32 " RGBA 8-bit", e.width, e.height, e.channels,
                                 e.type == RTO_PIXEL_U8 ? "8-bit" : "float", c->w, c->h);
        goto out;
    }
    if (g.type != RTO_PIXEL_U8 || (g.channels != 3 && g.channels != 4)) {
        s = rto__fc_bad_gpu(c, name, "is a %" PRIu32 "-channel %s image; expected RGBA or RGB, 8 bits per channel",
                            g.channels, g.type == RTO_PIXEL_U8 ? "8-bit" : "non-8-bit");
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
    if (rto__fc_claim(c, RTO_FRAME_IMAGE, -1)) {
        const uint32_t p = (uint32_t)first;
        rto__fc_at_pixel(c, p);
        for (uint32_t i = 0; i < ps->nlist && c->r->nrows < RTO_REPORT_MAX_ROWS; i++) {
            const pixel_diff *f = &ps->list[i];
            for (uint32_t k = 0; k < ch; k++)
                if (fabsf(f->a[k] - f->e[k]) > IMAGE_STEP)
                    rto__fc_add_row(c, (uint64_t)f->y * c->w + f->x, channel_names[k], rto__val_uint((uint64_t)f->e[k]),
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
    char *path = rto__fc_join(c->desc->artifact_dir, rto_frame_artifact_name(bit));
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

rto_status rto__fc_write_artifacts(fcheck *c)
{
    if (!c->desc->artifact_dir || (!c->accum.failed && !c->image.failed))
        return RTO_OK;
    rto_status s;
    if (c->accum.failed && c->accum.expected.pixels && (s = write_diff(c, &c->accum, RTO_FRAME_ARTIFACT_ACCUM_DIFF, 1)))
        return s;
    if (c->image.failed && c->image.expected.pixels &&
        (s = write_diff(c, &c->image, RTO_FRAME_ARTIFACT_IMAGE_DIFF, 16)))
        return s;
    char *path = rto__fc_join(c->desc->artifact_dir, rto_frame_artifact_name(RTO_FRAME_ARTIFACT_LISTING));
    if (!path)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    s = write_listing(c, path);
    free(path);
    if (!s)
        c->artifacts |= RTO_FRAME_ARTIFACT_LISTING;
    return s;
}
