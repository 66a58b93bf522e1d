/* check-frame's queues (check_frame_internal.h): a bounce's rays against the oracle's as multisets keyed by
 * (pixel, kind, payloadSlot), every field within DESIGN.md §9's ray tolerances. */
#include "check_frame_internal.h"
#include "core/tolerance.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* The tolerance of float field f (0 .. 7: origin.xyz, tMin, dir.xyz, tMax) of a ray whose value is e (docs/frame.md
 * "The GPU dump layout"): an origin by §9's origin rule, 1e-5 max(4 M, |o|) (a hit point o + t d, off by |dt| |d|
 * when t is off by the t rule; a t inside the scene is at most the distance across it from the camera, under 4 M);
 * directions and t bounds by the t rule itself, 1e-5 max(1, |v|). */
static double ray_tolerance(const fcheck *c, int f, float e)
{
    return f < 3 ? rto__tol_origin(e, c->scale) : rto__tol_t(e);
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
        rto__fc_add_row(c, index, ray_float_names[f], rto__val_f32(ev), rto__val_f32(av),
                        rto__val_f64((double)av - (double)ev), rto__val_f64(ray_tolerance(c, f, ev)));
    } else {
        const uint32_t ev = (&e->pixel)[f - 8], av = (&a->pixel)[f - 8];
        if (f == 9) /* flags: a bit pattern */
            rto__fc_add_row(c, index, ray_int_names[f - 8], rto__val_hex32(ev), rto__val_hex32(av),
                            rto__val_hex32(ev ^ av), rto__val_none());
        else
            rto__fc_uint_row(c, index, ray_int_names[f - 8], ev, av);
    }
}

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

rto_status rto__fc_match_queue(fcheck *c, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m, qresult *q)
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

void rto__fc_key_text(const fcheck *c, const rto_wf_ray *r, char *buf, size_t cap)
{
    if (r->pixel < c->pixels)
        snprintf(buf, cap, "pixel %" PRIu32 " (x %" PRIu32 ", y %" PRIu32 "), kind %" PRIu32 ", payloadSlot %" PRIu32,
                 r->pixel, r->pixel % c->w, r->pixel / c->w, r->kind, r->payload_slot);
    else
        snprintf(buf, cap, "pixel %" PRIu32 " (outside the image), kind %" PRIu32 ", payloadSlot %" PRIu32, r->pixel,
                 r->kind, r->payload_slot);
}

void rto__fc_queue_fault(fcheck *c, uint32_t d, const rto_wf_ray *ro, size_t n, const rto_wf_ray *rg, size_t m,
                         const qresult *q)
{
    const size_t total = q->counts[0] + q->counts[1] + q->counts[2] + q->counts[3];
    if (!total || !rto__fc_claim(c, RTO_FRAME_QUEUE, d))
        return;
    const qfinding *f = &q->find[0];
    const rto_wf_ray *r = f->o != NONE32 ? &ro[f->o] : &rg[f->g];
    char key[128];
    rto__fc_key_text(c, r, key, sizeof key);
    if (f->o != NONE32)
        rto__report_at(c->r, "ray", f->o);
    if (f->g != NONE32)
        rto__report_at(c->r, "gpu_ray", f->g);
    rto__fc_at_pixel(c, r->pixel);
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
                      q->counts[Q_DIFFERS], n, m, rto__fc_filled_by(d));
    for (uint32_t k = 0; k < q->nfind; k++) {
        const qfinding *x = &q->find[k];
        switch (x->kind) {
        case Q_MISSING: rto__fc_uint_row(c, x->o, "missing (key count)", x->count_o, x->count_g); break;
        case Q_EXTRA: rto__fc_uint_row(c, x->g, "extra (gpu ray index)", 0, x->count_g); break;
        case Q_DUPLICATE: rto__fc_uint_row(c, x->o, "duplicated (key count)", x->count_o, x->count_g); break;
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
