/* rtoracle crosscheck: one run's rays through the oracle and Embree, each disagreement classified and tallied per
 * ray class (crosscheck_run.h). */
#include "crosscheck_run.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

const char *xc_kind_name(uint32_t kind, char *buf, size_t cap)
{
    const char *n = kind < RTO_RAY_SET_COUNT ? rto_ray_set_name((rto_ray_set)kind) : NULL;
    if (n)
        snprintf(buf, cap, "%s", n);
    else
        snprintf(buf, cap, "kind %u", kind);
    return buf;
}

static row *row_for(run *r, uint32_t kind)
{
    for (size_t i = 0; i < r->nrows; i++)
        if (!r->rows[i].other && r->rows[i].kind == kind)
            return &r->rows[i];
    if (r->nrows < XC_MAX_ROWS - 1) {
        row *w = &r->rows[r->nrows++];
        memset(w, 0, sizeof *w);
        w->kind = kind;
        return w;
    }
    /* the last row gathers every further kind */
    row *w = &r->rows[XC_MAX_ROWS - 1];
    if (r->nrows < XC_MAX_ROWS) {
        memset(w, 0, sizeof *w);
        w->other = true;
        r->nrows = XC_MAX_ROWS;
    }
    return w;
}

static rto_status ensure_mirror(run *r, emb_scene **m, bool robust, rto_msg *msg)
{
    if (*m)
        return RTO_OK;
    emb_scene_desc desc = {EMB_QUALITY_DEFAULT, robust, r->culling};
    return r->E->scene_create(r->dev, r->scene, &desc, m, msg);
}

/* Compares and classifies n rays already traced by both sides. */
static rto_status compare(run *r, const char *set, const rto_wf_ray *rays, size_t n, const rto_hit_record *oh,
                          const rto_hit_record *eh, rto_msg *msg)
{
    for (size_t i = 0; i < n; i++) {
        const rto_wf_ray *ray = &rays[i];
        row *w = row_for(r, ray->kind);
        w->rays++;
        w->oracle_hits += oh[i].miss_flag == 0;
        double rel;
        if (xc_agree(ray, &oh[i], &eh[i], &rel)) {
            w->count[XC_AGREE]++;
            if (rel > w->max_rel_dt)
                w->max_rel_dt = rel;
            continue;
        }
        /* A disagreement: what else the classes need. Embree's occlusion names no triangle: ask for its closest
         * hit. Against Embree default, ask Embree robust too. */
        rto_hit_record closest, robust;
        bool have_closest = false;
        if ((ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) && eh[i].miss_flag == 0) {
            r->E->trace_closest(r->mirror, ray, &closest);
            have_closest = true;
        }
        rto_status st;
        if (!r->robust_mode) {
            if ((st = ensure_mirror(r, &r->robust, true, msg)) ||
                (st = r->E->trace(r->robust, r->dev, ray, 1, 1, &robust, msg)))
                return st;
        }
        xc_input in = {r->scene, ray, &oh[i], &eh[i], have_closest ? &closest : NULL, r->robust_mode ? NULL : &robust,
                       NULL, &r->model};
        xc_result res;
        xc_classify(&in, &res);
        w->count[res.cls]++;
        if (res.cls == XC_UNEXPLAINED) {
            r->unexplained++;
            if (r->ndetails < XC_DETAIL) {
                detail *d = &r->details[r->ndetails++];
                snprintf(d->set, sizeof d->set, "%s", set);
                d->index = i;
                d->ray = *ray;
                d->oracle = oh[i];
                d->embree = eh[i];
                d->res = res;
            }
        }
    }
    return RTO_OK;
}

/* Traces n rays both ways and compares them. */
static rto_status trace_both(run *r, const char *set, const rto_wf_ray *rays, size_t n, rto_msg *msg)
{
    rto_hit_record *oh = cli_alloc(n, sizeof *oh), *eh = cli_alloc(n, sizeof *eh);
    rto_status st = RTO_OK;
    if (!oh || !eh)
        st = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu hit records", n);
    rto_trace_desc td = {r->threads};
    if (!st)
        st = rto_trace(r->accel, rays, n, &td, oh, NULL, msg);
    if (!st)
        st = ensure_mirror(r, &r->mirror, r->robust_mode, msg);
    if (!st)
        st = r->E->trace(r->mirror, r->dev, rays, n, r->threads, eh, msg);
    if (!st)
        st = compare(r, set, rays, n, oh, eh, msg);
    free(oh);
    free(eh);
    return st;
}

/* ---- output --------------------------------------------------------------------------------------------------- */

bool xc_parse_sets(const char *text, rto_ray_set *sets, size_t *n)
{
    *n = 0;
    const char *p = text;
    while (1) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        char name[32];
        rto_ray_set s;
        if (len == 0 || len >= sizeof name)
            return false;
        memcpy(name, p, len);
        name[len] = 0;
        if (!rto_ray_set_parse(name, &s))
            return false;
        bool dup = false;
        for (size_t i = 0; i < *n; i++)
            dup |= sets[i] == s;
        if (!dup)
            sets[(*n)++] = s;
        if (!comma)
            return true;
        p = comma + 1;
    }
}

int xc_run_file(run *r, const char *path, rto_msg *msg)
{
    rto_wf_ray *rays = NULL;
    size_t count = 0;
    if (rto_rays_read(path, XC_MAX_RAYS, &rays, &count, msg))
        return cli_fail("crosscheck", "--rays %s", msg->text);
    for (size_t i = 0; i < count; i++)
        r->culling |= (rays[i].flags & (RTO_RAY_FLAG_CULL_BACK_FACING | RTO_RAY_FLAG_CULL_FRONT_FACING)) != 0;
    const char *base = strrchr(path, '/');
    rto_status st = trace_both(r, base ? base + 1 : path, rays, count, msg);
    free(rays);
    return st ? cli_status("crosscheck", st, msg) : EXIT_PASS;
}

int xc_run_sets(run *r, const rto_ray_set *sets, size_t nsets, uint32_t seed, uint32_t width, uint32_t height,
                    uint32_t count, rto_msg *msg)
{
    for (size_t k = 0; k < nsets; k++) {
        rto_rays_desc d;
        memset(&d, 0, sizeof d);
        d.set = sets[k];
        d.seed = seed;
        d.width = width;
        d.height = height;
        d.count = count;
        d.threads = r->threads;
        size_t cap = rto_rays_capacity(&d), n = 0;
        rto_wf_ray *rays = cli_alloc(cap, sizeof *rays);
        if (!rays)
            return cli_fail("crosscheck", "out of memory for %zu rays", cap);
        rto_status st = rto_rays_generate(r->accel, &d, rays, cap, &n, NULL, msg);
        if (!st)
            st = trace_both(r, rto_ray_set_name(sets[k]), rays, n, msg);
        free(rays);
        if (st)
            return cli_status("crosscheck", st, msg);
    }
    return EXIT_PASS;
}

