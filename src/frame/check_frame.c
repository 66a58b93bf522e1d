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
 * one on) cannot be compared at all and are reported as not comparable instead of failing.
 *
 * This file is the driver: the fault and artefact names, faults claimed into the report in pipeline order, and
 * rto_frame_check itself. The steps live beside it (check_frame_internal.h lists the files). */
#include "check_frame_internal.h"
#include "core/json.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define IMAGE_PERCENT_DEFAULT 0.1

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
int rto__fc_claim(fcheck *c, rto_frame_fault f, int64_t bounce)
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

void rto__fc_add_row(fcheck *c, uint64_t index, const char *field, rto_value e, rto_value a, rto_value d, rto_value t)
{
    rto_report_row *row = rto__report_row_add(c->r, index, field);
    if (!row)
        return;
    row->expected = e;
    row->actual = a;
    row->diff = d;
    row->tolerance = t;
}

void rto__fc_uint_row(fcheck *c, uint64_t index, const char *field, uint64_t e, uint64_t a)
{
    rto__fc_add_row(c, index, field, rto__val_uint(e), rto__val_uint(a), rto__val_int((int64_t)a - (int64_t)e),
                    rto__val_none());
}

/* The pixel of a ray as location fields: pixel, and x / y when it lies in the image. */
void rto__fc_at_pixel(fcheck *c, uint32_t pixel)
{
    rto__report_at(c->r, "pixel", pixel);
    if (pixel < c->pixels) {
        rto__report_at(c->r, "x", pixel % c->w);
        rto__report_at(c->r, "y", pixel / c->w);
    }
}

/* Oracle ray i of a queue and its GPU partner as location fields: ray, gpu_ray, pixel (x, y) and slot. */
void rto__fc_at_ray(fcheck *c, const rto_wf_ray *ro, const uint32_t *gpu_of, size_t i)
{
    rto__report_at(c->r, "ray", (int64_t)i);
    rto__report_at(c->r, "gpu_ray", gpu_of[i]);
    rto__fc_at_pixel(c, ro[i].pixel);
    rto__report_at(c->r, "slot", ro[i].payload_slot);
}

/* Where a ray of queue d came from, for sentences. */
const char *rto__fc_filled_by(uint32_t d) { return d == 0 ? "GENERATE" : "the SHADE pass of the bounce before"; }

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

void rto__fc_free(fcheck *c)
{
    rto_npy_free(&c->e_emit);
    rto_npy_free(&c->e_ind);
    rto_npy_free(&c->e_cnt);
    rto_npy_free(&c->e_nc);
    rto_npy_free(&c->g_emit);
    rto_npy_free(&c->g_ind);
    rto_npy_free(&c->g_cnt);
    rto_scene_bundle_free(&c->scene);
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
    rto_status s;
    if ((s = rto__fc_read_expected(&c)) || (s = rto__fc_read_scale(&c)) ||
        (s = rto__fc_mark_drop_pixels(&c)) || (s = rto__fc_read_gpu_arrays(&c)))
        goto out;
    c.files_compared += (uint64_t)c.have_g_emit + (uint64_t)c.have_g_ind + (uint64_t)c.have_g_cnt;
    for (uint32_t d = 0; d <= c.depth; d++) {
        rto__fc_step_counts(&c, d);
        rto__fc_step_indirect(&c, d);
        if ((s = rto__fc_step_queue(&c, d)))
            goto out;
        if (d < c.depth) {
            rto__fc_step_hit_counters(&c, d);
            rto__fc_step_shade_counters(&c, d);
        }
    }
    rto__fc_step_extra_queues(&c);
    if ((s = rto__fc_step_accum(&c)) || (s = rto__fc_step_image(&c)))
        goto out;
    if (!c.files_compared) {
        s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                     "GPU dump %s holds nothing to compare with the frame: none of its file names (emit_counts.npy, "
                     "indirect_args.npy, bounce_D_rays.npy, accum.npy, image.png, ...)%s%s", desc->gpu_dir,
                     c.skipped[0] ? " that the bundle keeps; not compared: " : "", c.skipped);
        goto out;
    }
    if ((s = rto__fc_write_artifacts(&c)))
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
    rto__fc_free(&c);
    return s;
}
