/* rtoracle crosscheck's table: one row per ray class, the unexplained rays in full; text or JSON
 * (crosscheck_run.h). */
#include "crosscheck_run.h"

#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static double rate(const row *w) { return w->rays ? 100.0 * (double)w->count[XC_AGREE] / (double)w->rays : NAN; }

static void row_total(const run *r, row *t)
{
    memset(t, 0, sizeof *t);
    for (size_t i = 0; i < r->nrows; i++) {
        const row *w = &r->rows[i];
        t->rays += w->rays;
        t->oracle_hits += w->oracle_hits;
        for (int c = 0; c < XC_CLASS_COUNT; c++)
            t->count[c] += w->count[c];
        if (w->max_rel_dt > t->max_rel_dt)
            t->max_rel_dt = w->max_rel_dt;
    }
}

static void row_name(const row *w, char *buf, size_t cap)
{
    if (w->other)
        snprintf(buf, cap, "other kinds");
    else
        xc_kind_name(w->kind, buf, cap);
}

static void print_hit(const char *who, const rto_hit_record *h)
{
    if (h->miss_flag)
        printf("    %-7s miss (t %.9g)\n", who, (double)h->t);
    else if (h->prim_id == UINT32_MAX)
        printf("    %-7s hit (occluded; no triangle named)\n", who);
    else
        printf("    %-7s triangle %u of instance %u at t %.9g, bary (%.9g, %.9g)\n", who, h->prim_id, h->instance_id,
               (double)h->t, (double)h->bary[0], (double)h->bary[1]);
}

/* A class's column: its name's width, at least 6 (the agree column holds up to 9 digits). */
static int class_width(int c)
{
    const int n = (int)strlen(xc_class_name((xc_class)c));
    return c == XC_AGREE ? 9 : n > 6 ? n : 6;
}

void xc_print_text(const run *r, const char *scene_name, const char *mode)
{
    uint64_t tris = 0;
    for (uint32_t i = 0; i < r->scene->instance_count; i++)
        tris += r->scene->meshes[r->scene->instances[i].blas].triangle_count;
    const uint32_t threads = r->E->thread_count(r->threads);
    printf("crosscheck %s: %u instance%s, %llu triangle%s; Embree %s %s (build quality %s), %u thread%s\n",
           scene_name, r->scene->instance_count, r->scene->instance_count == 1 ? "" : "s", (unsigned long long)tris,
           tris == 1 ? "" : "s", r->E->version, mode,
           r->E->quality_name(EMB_QUALITY_DEFAULT), threads, threads == 1 ? "" : "s");
    printf("%-12s %9s %9s", "rays", "count", "hits");
    for (int c = 0; c < XC_CLASS_COUNT; c++)
        printf(" %*s", class_width(c), xc_class_name((xc_class)c));
    printf(" %9s %11s\n", "agree %", "max rel dt");
    row t;
    row_total(r, &t);
    for (size_t i = 0; i <= r->nrows; i++) {
        const row *w = i < r->nrows ? &r->rows[i] : &t;
        char name[32];
        if (i < r->nrows)
            row_name(w, name, sizeof name);
        else
            snprintf(name, sizeof name, "total");
        char pct[16];
        if (w->rays)
            snprintf(pct, sizeof pct, "%.3f", rate(w));
        else
            snprintf(pct, sizeof pct, "-");
        printf("%-12s %9llu %9llu", name, (unsigned long long)w->rays, (unsigned long long)w->oracle_hits);
        for (int c = 0; c < XC_CLASS_COUNT; c++)
            printf(" %*llu", class_width(c), (unsigned long long)w->count[c]);
        printf(" %9s %11.3g\n", pct, w->max_rel_dt);
    }
    printf("hits: the oracle's; agree %%: agreeing rays / rays; max rel dt: largest |dt| / max(1, |t|) among agreeing "
           "hits (tolerance %g)\n", XC_T_REL);
    if (!r->unexplained) {
        printf("PASS: no unexplained disagreement\n");
        return;
    }
    printf("FAIL: %llu unexplained disagreement%s; the first %zu:\n", (unsigned long long)r->unexplained,
           r->unexplained == 1 ? "" : "s", r->ndetails);
    for (size_t i = 0; i < r->ndetails; i++) {
        const detail *d = &r->details[i];
        const rto_wf_ray *y = &d->ray;
        printf("  %s ray %zu: origin (%.9g, %.9g, %.9g) dir (%.9g, %.9g, %.9g) tMin %.9g tMax %.9g flags 0x%x "
               "cullMask 0x%02x\n", d->set, d->index, (double)y->origin[0], (double)y->origin[1],
               (double)y->origin[2], (double)y->dir[0], (double)y->dir[1], (double)y->dir[2], (double)y->t_min,
               (double)y->t_max, y->flags, y->cull_mask);
        print_hit("oracle", &d->oracle);
        print_hit("embree", &d->embree);
        printf("    why     %s\n", d->res.why);
    }
}

static json_t *jreal(double v) { return isfinite(v) ? json_real(v) : json_null(); }

static json_t *jrow(const row *w, const char *name)
{
    json_t *o = json_object();
    json_object_set_new(o, "rays", cli_json_text(name));
    json_object_set_new(o, "count", json_integer((json_int_t)w->rays));
    json_object_set_new(o, "hits", json_integer((json_int_t)w->oracle_hits));
    for (int c = 0; c < XC_CLASS_COUNT; c++)
        json_object_set_new(o, xc_class_name((xc_class)c), json_integer((json_int_t)w->count[c]));
    json_object_set_new(o, "agreement_percent", jreal(rate(w)));
    json_object_set_new(o, "max_rel_dt", json_real(w->max_rel_dt));
    return o;
}

static json_t *jhit(const rto_hit_record *h)
{
    json_t *o = json_object();
    json_object_set_new(o, "hit", json_boolean(h->miss_flag == 0));
    json_object_set_new(o, "t", jreal(h->t));
    if (h->miss_flag == 0 && h->prim_id != UINT32_MAX) {
        json_object_set_new(o, "instance", json_integer(h->instance_id));
        json_object_set_new(o, "prim", json_integer(h->prim_id));
        json_object_set_new(o, "bary", json_pack("[ff]", (double)h->bary[0], (double)h->bary[1]));
    }
    return o;
}

int xc_print_json(const run *r, const char *scene_name, const char *mode)
{
    json_t *root = json_object();
    json_object_set_new(root, "command", json_string("crosscheck"));
    json_object_set_new(root, "scene", cli_json_text(scene_name));
    json_t *e = json_object();
    json_object_set_new(e, "version", json_string(r->E->version));
    json_object_set_new(e, "mode", json_string(mode));
    json_object_set_new(e, "build_quality", json_string(r->E->quality_name(EMB_QUALITY_DEFAULT)));
    json_object_set_new(root, "embree", e);
    json_object_set_new(root, "threads", json_integer(r->E->thread_count(r->threads)));
    json_t *tol = json_object();
    json_object_set_new(tol, "t_rel", json_real(XC_T_REL));
    json_object_set_new(tol, "shared_vertex_rel", json_real(XC_SHARED_REL));
    json_object_set_new(tol, "coplanar_rel", json_real(XC_PLANE_REL));
    json_object_set_new(tol, "edge_rel", json_real(XC_EDGE_REL));
    json_object_set_new(tol, "parallel_cos", json_real(XC_PARALLEL_COS));
    json_object_set_new(root, "tolerances", tol);
    json_t *rows = json_array();
    for (size_t i = 0; i < r->nrows; i++) {
        char name[32];
        row_name(&r->rows[i], name, sizeof name);
        json_array_append_new(rows, jrow(&r->rows[i], name));
    }
    json_object_set_new(root, "classes", rows);
    row t;
    row_total(r, &t);
    json_object_set_new(root, "total", jrow(&t, "total"));
    json_t *un = json_array();
    for (size_t i = 0; i < r->ndetails; i++) {
        const detail *d = &r->details[i];
        json_t *o = json_object();
        json_object_set_new(o, "set", json_string(d->set));
        json_object_set_new(o, "index", json_integer((json_int_t)d->index));
        json_object_set_new(o, "origin", json_pack("[fff]", (double)d->ray.origin[0], (double)d->ray.origin[1],
                                                   (double)d->ray.origin[2]));
        json_object_set_new(o, "dir", json_pack("[fff]", (double)d->ray.dir[0], (double)d->ray.dir[1],
                                                (double)d->ray.dir[2]));
        json_object_set_new(o, "t_min", jreal(d->ray.t_min));
        json_object_set_new(o, "t_max", jreal(d->ray.t_max));
        json_object_set_new(o, "flags", json_integer(d->ray.flags));
        json_object_set_new(o, "cull_mask", json_integer(d->ray.cull_mask));
        json_object_set_new(o, "oracle", jhit(&d->oracle));
        json_object_set_new(o, "embree", jhit(&d->embree));
        json_object_set_new(o, "why", cli_json_text(d->res.why));
        json_array_append_new(un, o);
    }
    json_object_set_new(root, "unexplained_total", json_integer((json_int_t)r->unexplained));
    json_object_set_new(root, "unexplained", un);
    json_object_set_new(root, "result", json_string(r->unexplained ? "fail" : "pass"));
    char *text = json_dumps(root, JSON_INDENT(2) | JSON_PRESERVE_ORDER | JSON_REAL_PRECISION(9));
    json_decref(root);
    if (!text)
        return cli_fail("crosscheck", "out of memory for the JSON output");
    printf("%s\n", text);
    free(text);
    return EXIT_PASS;
}

