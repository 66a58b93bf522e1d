/* One bounce of check-frame (check_frame_internal.h): its emit counter and FrameCounters, its indirect args, its
 * queue, and the payloads and hit records that travel with the queue's rays. */
#include "check_frame_internal.h"
#include "core/tolerance.h"
#include "../trace/trace_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Payload words are compared as binary32 only where both read as plausible floats: 0, or a magnitude of at least
 * 2^-64. An integer below 2^28 (a pixel, a slot, a count) reads as a denormal or a float under 2^-64, so it is
 * compared bit for bit and never passes as "close". */
#define PAYLOAD_FLOAT_MIN 5.42101086242752217e-20 /* 2^-64 */

/* ---------------------------------------------------------------------------------------------------------------- */
/* Counts and indirect args                                                                                         */

typedef struct count_diff {
    const char *field;
    uint32_t e, a;
} count_diff;

/* Reports the differing counters of queue d (f: which stage they belong to). */
static void counts_fault(fcheck *c, rto_frame_fault f, uint32_t d, const count_diff *x, uint32_t nx, const char *what)
{
    if (!nx || !rto__fc_claim(c, f, d))
        return;
    for (uint32_t k = 0; k < nx; k++)
        rto__fc_uint_row(c, d, x[k].field, x[k].e, x[k].a);
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
    if (!rto__fc_claim(c, f, d))
        return 0;
    rto__fc_uint_row(c, d, what, (uint64_t)c->depth + 1, n);
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

void rto__fc_step_counts(fcheck *c, uint32_t d)
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
    snprintf(what, sizeof what, "the emit counter of queue %" PRIu32 ", filled by %s", d, rto__fc_filled_by(d));
    counts_fault(c, RTO_FRAME_COUNTS, d, x, nx, what);
}

void rto__fc_step_indirect(fcheck *c, uint32_t d)
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
    if (!rto__fc_claim(c, RTO_FRAME_INDIRECT, d))
        return;
    static const char *const names[3] = {"workgroups.x", "workgroups.y", "workgroups.z"};
    for (int k = 0; k < 3; k++)
        if (a[k] != e[k])
            rto__fc_uint_row(c, d, names[k], e[k], a[k]);
    rto__report_summary(c->r, "indirect-args: PREP of queue %" PRIu32 ": [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] in the "
                       "GPU's dump, the oracle's [%" PRIu32 ", %" PRIu32 ", %" PRIu32 "] = [ceil(%" PRIu32
                       " / 64), 1, 1]", d, a[0], a[1], a[2], e[0], e[1], e[2], c->cnt[d].queued);
}

/* Frame-wide arrays longer than the frame: the GPU ran more queues than maxDepth + 1. */
void rto__fc_step_extra_queues(fcheck *c)
{
    const size_t q = (size_t)c->depth + 1;
    if (c->have_g_emit && c->g_emit_n > q && rto__fc_claim(c, RTO_FRAME_COUNTS, (int64_t)q)) {
        rto__fc_uint_row(c, q, "emit_counts entries", q, c->g_emit_n);
        rto__report_summary(c->r, "emit-count: the GPU's emit_counts.npy has %zu entries; the frame has %zu queues "
                           "(maxDepth %" PRIu32 " + 1)", c->g_emit_n, q, c->depth);
    }
    if (c->have_g_cnt && c->g_cnt_n > q && rto__fc_claim(c, RTO_FRAME_COUNTS, (int64_t)q)) {
        rto__fc_uint_row(c, q, "frame_counters rows", q, c->g_cnt_n);
        rto__report_summary(c->r, "emit-count: the GPU's frame_counters.npy has %zu rows; the frame has %zu queues",
                           c->g_cnt_n, q);
    }
    if (c->have_g_ind && c->g_ind_n > q && rto__fc_claim(c, RTO_FRAME_INDIRECT, (int64_t)q)) {
        rto__fc_uint_row(c, q, "indirect_args rows", q, c->g_ind_n);
        rto__report_summary(c->r, "indirect-args: the GPU's indirect_args.npy has %zu rows; the frame has %zu queues",
                           c->g_ind_n, q);
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Payloads                                                                                                         */

static int payload_float(uint32_t w)
{
    float f;
    memcpy(&f, &w, 4);
    return isfinite(f) && (f == 0.0f || fabs((double)f) >= PAYLOAD_FLOAT_MIN);
}

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
    return rto__tol_accum_close(fe, fa, RTO__TOL_ACCUM_ABS); /* payload floats carry colour on its way to accum */
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
    rto__fc_file_name(RTO_FILE_BOUNCE_PAYLOADS, d, name);
    if (!c->words)
        return; /* the program carries no payload */
    rto_npy e = {0}, g = {0};
    if (!rto__fc_gpu_bounce_file(c, name, rg, &g, st))
        goto out;
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_U32, 2, n, c->words, 0);
    if ((*st = rto__fc_exp_load(c, name, &want, &e)))
        goto out;
    const rto_npy_desc *gd = &g.desc;
    if ((gd->dtype != RTO_DTYPE_U32 && gd->dtype != RTO_DTYPE_F32) ||
        !((gd->ndim == 2 && gd->shape[1] == c->words) || (gd->ndim == 1 && gd->shape[0] % c->words == 0))) {
        *st = rto__fc_bad_gpu(c, name, "holds %s; expected dtype <u4 or <f4, shape (rays, %" PRIu32 ") or flat",
                      rto_npy_desc_text(gd, NULL, have, sizeof have), c->words);
        goto out;
    }
    c->files_compared++;
    c->payloads_run = 1;
    const size_t rows = (size_t)(gd->ndim == 2 ? gd->shape[0] : gd->shape[0] / c->words);
    /* one row per dumped ray in the dump's order, or the whole store (capacity rows) indexed by payloadSlot */
    const int by_slot = rows == c->cap;
    if (!by_slot && rows != m) {
        if (rto__fc_claim(c, RTO_FRAME_PAYLOAD, d)) {
            rto__fc_uint_row(c, 0, "payload rows", m, rows);
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
    if (!wrong || !rto__fc_claim(c, RTO_FRAME_PAYLOAD, d))
        goto out;
    rto__fc_at_ray(c, ro, q->gpu_of, first);
    char key[128];
    rto__fc_key_text(c, &ro[first], key, sizeof key);
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
                rto__fc_add_row(c, i, field, rto__val_f32(fe), rto__val_f32(fa), rto__val_f64((double)fa - (double)fe),
                                rto__val_f64(rto__tol_accum(fe, RTO__TOL_ACCUM_ABS)));
            else
                rto__fc_add_row(c, i, field, rto__val_hex32(x[k]), rto__val_hex32(a[k]), rto__val_hex32(x[k] ^ a[k]),
                                rto__val_none());
        }
    }
out:
    rto_npy_free(&e);
    rto_npy_free(&g);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hits                                                                                                             */

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

void rto__fc_step_hit_counters(fcheck *c, uint32_t d)
{
    static const cnt_field fields[] = {CNT_FIELD(traced), CNT_FIELD(hits), CNT_FIELD(misses)};
    pass_counters(c, d, RTO_FRAME_HITS, "TRACE", fields, 3);
}

void rto__fc_step_shade_counters(fcheck *c, uint32_t d)
{
    static const cnt_field fields[] = {CNT_FIELD(shaded), CNT_FIELD(accumulates)};
    pass_counters(c, d, RTO_FRAME_COUNTS, "SHADE", fields, 2);
}

/* Each GPU record is judged with the ray the GPU traced (§9's model holds a record to its own ray; how far the GPU's
 * ray may be from the oracle's is the queue step's rule): where the paired GPU ray differs from the oracle's, the
 * expected record is the oracle's arithmetic on the GPU's ray, brute force (a conforming implementation of §6 too).
 * Fills hrays and hexp (n each) from the oracle's rays ro and records eh. */
static rto_status gpu_ray_records(fcheck *c, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, const qresult *q,
                                  const rto_hit_record *eh, rto_wf_ray *hrays, rto_hit_record *hexp)
{
    size_t *redo = rto__alloc(n, sizeof *redo);
    if (!redo)
        return rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_msg mm = {{0}};
    rto_status s = RTO_OK;
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
        const rto_scene view = {.meshes = (rto_mesh *)c->scene.meshes, .mesh_count = c->scene.mesh_count,
                                .instances = (rto_instance *)c->scene.instances,
                                .instance_count = c->scene.instance_count};
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
        }
    }
    free(redo);
    return s;
}

/* The hit records of bounce d, paired through the queue's rays, judged by check-hits: with its conformance model on a
 * mesh scene (rto_hits_check), field by field on the stage2 scene, whose analytic primitives the model cannot
 * re-intersect (rto__hits_check_records: IDs, missFlag and objToWorld exact, t and bary within §9). */
static rto_status step_hits(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                            const qresult *q)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__fc_file_name(RTO_FILE_BOUNCE_HITS, d, name);
    rto_npy e = {0}, g = {0};
    rto_hit_record *paired = NULL, *hexp = NULL;
    rto_wf_ray *hrays = NULL;
    rto_status s = RTO_OK;
    if (!rto__fc_gpu_bounce_file(c, name, rg, &g, &s))
        goto out;
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, n);
    if ((s = rto__fc_exp_load(c, name, &want, &e)))
        goto out;
    size_t k = 0;
    rto_msg mm = {{0}};
    if (rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &g, &k, &mm)) {
        s = rto__fc_bad_gpu(c, name, "%s", mm.text);
        goto out;
    }
    if (k == c->cap && m < c->cap)
        k = m; /* the whole hit buffer: its first m records are this bounce's */
    c->files_compared++;
    c->hits_run = 1;
    if (k != m) {
        if (rto__fc_claim(c, RTO_FRAME_HITS, d)) {
            rto__fc_uint_row(c, 0, "hit records", m, k);
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
    rto_hits_check_desc hd;
    memset(&hd, 0, sizeof hd);
    hd.rays = ro;
    hd.ray_count = n;
    hd.expected = eh;
    hd.gpu = paired;
    hd.gpu_count = n;
    if (!c->stage2) {
        if ((s = rto__fc_load_scene(c)))
            goto out;
        if (!(hrays = rto__alloc(n, sizeof *hrays)) || !(hexp = rto__alloc(n, sizeof *hexp))) {
            s = rto__fail(c->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
            goto out;
        }
        if ((s = gpu_ray_records(c, ro, n, rg, q, eh, hrays, hexp)))
            goto out;
        hd.rays = hrays;
        hd.expected = hexp;
        hd.instances = c->scene.instances;
        hd.instance_count = c->scene.instance_count;
        hd.meshes = c->scene.meshes;
        hd.mesh_count = c->scene.mesh_count;
    }
    rto_report sub;
    const rto_status hs = c->stage2 ? rto__hits_check_records(&hd, &sub, &mm) : rto_hits_check(&hd, &sub, &mm);
    if (hs == RTO_ERR_INVALID_ARGUMENT) {
        /* the bundle's own records or geometry disagree: refused as input, never blamed on the GPU */
        s = rto__fc_bad_expected(c, name, "%s", mm.text);
        goto out;
    }
    if (hs != RTO_OK && hs != RTO_ERR_MISMATCH) {
        s = rto__fail(c->msg, hs, "%s", mm.text);
        goto out;
    }
    if (hs == RTO_ERR_MISMATCH && rto__fc_claim(c, RTO_FRAME_HITS, d)) {
        int64_t ray = 0;
        rto_report_where(&sub, "ray", &ray);
        if (ray >= 0 && (size_t)ray < n)
            rto__fc_at_ray(c, ro, q->gpu_of, (size_t)ray);
        else
            rto__report_at(c->r, "ray", ray);
        for (uint32_t r = 0; r < sub.nrows && r < RTO_REPORT_MAX_ROWS; r++)
            rto__fc_add_row(c, sub.rows[r].index, sub.rows[r].field, sub.rows[r].expected, sub.rows[r].actual,
                            sub.rows[r].diff, sub.rows[r].tolerance);
        c->r->tolerance_bound = sub.tolerance_bound;
        if (c->stage2)
            rto__report_summary(c->r, "hits: bounce %" PRIu32 " (stage2 scene: IDs, missFlag, objToWorld exact, t and "
                               "bary within §9): %s", d, sub.summary);
        else
            rto__report_summary(c->r, "hits: bounce %" PRIu32 " (check-hits rules, ray = the oracle's queue index): "
                               "%s", d, sub.summary);
    }
out:
    free(paired);
    free(hrays);
    free(hexp);
    rto_npy_free(&e);
    rto_npy_free(&g);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* One bounce                                                                                                       */

rto_status rto__fc_step_queue(fcheck *c, uint32_t d)
{
    char rname[RTO_BUNDLE_FILE_NAME_MAX], pname[RTO_BUNDLE_FILE_NAME_MAX], hname[RTO_BUNDLE_FILE_NAME_MAX];
    rto__fc_file_name(RTO_FILE_BOUNCE_RAYS, d, rname);
    rto__fc_file_name(RTO_FILE_BOUNCE_PAYLOADS, d, pname);
    rto__fc_file_name(RTO_FILE_BOUNCE_HITS, d, hname);
    const int traced = d < c->depth;
    if (c->drop_queue != NONE32 && d >= c->drop_queue) {
        /* which rays a GPU keeps at capacity is arbitrary: from here on only the counts compare */
        const char *names[3] = {rname, c->words ? pname : NULL, traced ? hname : NULL};
        for (int k = 0; k < 3; k++)
            if (names[k] && rto__fc_gpu_has(c, names[k]))
                rto__fc_list_add(c->drop_skipped, sizeof c->drop_skipped, names[k]);
        return RTO_OK;
    }
    const int expected = rto__fc_exp_has(c, rname);
    rto_npy e = {0}, g = {0};
    int present = 0;
    rto_status s = rto__fc_gpu_load(c, rname, &g, &present);
    if (s)
        return s;
    const size_t n = c->cnt[d].queued;
    size_t m = 0;
    qresult q;
    memset(&q, 0, sizeof q);
    const rto_wf_ray *ro = NULL, *rg = NULL;
    if (!present) {
        if (expected)
            rto__fc_not_dumped(c, rname);
    } else if (!expected) {
        rto__fc_skipped(c, rname, "not kept by the bundle");
    } else {
        rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_WF_RAY, n);
        if ((s = rto__fc_exp_load(c, rname, &want, &e)) ||
            (s = rto__fc_gpu_rays(c, rname, &g, rto__fc_gpu_queue_len(c, d), &m)))
            goto out;
        ro = e.data;
        rg = g.data;
        c->files_compared++;
        c->rays_compared += n;
        if ((s = rto__fc_match_queue(c, ro, n, rg, m, &q)))
            goto out;
        rto__fc_queue_fault(c, d, ro, n, rg, m, &q);
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
            if (rto__fc_gpu_has(c, names[k]))
                rto__fc_skipped(c, names[k],
                                present ? "its queue is not in the bundle" : "no rays dumped to pair them with");
            else if (rto__fc_exp_has(c, names[k]))
                rto__fc_not_dumped(c, names[k]);
        }
    }
out:
    free(q.gpu_of);
    rto_npy_free(&e);
    rto_npy_free(&g);
    return s;
}
