/* rtoracle crosscheck: the same rays through the oracle (rto_trace) and Intel Embree 3 (oracle/embree.c), compared
 * ray by ray, every disagreement classified (src/trace/crosscheck.h: tie, coplanar, crossing, t-rounding, robust-only,
 * surface-start, grazing, sliver, unexplained),
 * one summary row per ray class. An unexplained disagreement is a bug in one of the two tracers until shown
 * otherwise: exit status 1. */
#include "cli.h"
#include "trace/crosscheck.h"
#include "embree_module.h"

#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char crosscheck_usage[] =
    "usage: rtoracle crosscheck SCENE [--rays SETS|FILE.npy] [--count N] [--width W --height H] [--seed S]\n"
    "                           [--embree robust|default] [--threads N] [--json]\n\n"
    "Traces rays through the oracle (ordered traversal, DESIGN.md §6) and through Embree 3 mirroring the\n"
    "scene (one Embree scene per BLAS, one instance geometry per instance), and compares every ray: they\n"
    "agree when both miss, or both hit the same (instance, primitive) with |dt| <= 1e-5 max(1, |t|)\n"
    "(TERMINATE_ON_FIRST_HIT rays: when both hit or both miss). Each disagreement gets the first class\n"
    "that fits:\n"
    "  tie          different triangles at the same t (within 1e-5) that share a vertex (index, or world\n"
    "               position within 1e-6 relative)\n"
    "  coplanar     different triangles at the same t lying in one plane and overlapping at the hit\n"
    "  crossing     different triangles at the same t, not in one plane, both containing the hit point\n"
    "               (they touch or cross there)\n"
    "  t-rounding   the same triangle, t apart by more than 1e-5, both t in the interval DESIGN.md §9's\n"
    "               conformance model gives a conforming implementation, or the two hit points within\n"
    "               1e-5 (relative to the coordinates) of each other across its plane\n"
    "  robust-only  (--embree default) Embree robust agrees with the oracle where default did not\n"
    "  surface-start  the hit one side missed lies on a plane the ray starts on (its crossing within\n"
    "               rounding of tMin)\n"
    "  grazing      the hit one side missed is one the model says may be hit or missed (an edge or a box\n"
    "               within rounding), or lies within 1e-5 (relative to the coordinates, over |cos| of the\n"
    "               incidence angle) of an edge of its triangle, or the ray is within 1e-4 of parallel to\n"
    "               its plane\n"
    "  sliver       an ill-conditioned triangle: t, or the hit's distance to an edge, within 4 times the\n"
    "               spread the model allows §6's binary32 arithmetic there\n"
    "  unexplained  anything else (the first few are printed in full)\n"
    "SETS is a comma-separated list of generated sets (primary, shadow, random, grazing, axis; every set\n"
    "a pure function of the scene and the seed): primary and shadow use --width x --height, the others\n"
    "--count rays. FILE.npy is a WfRay array (rays.npy of a trace bundle); its rays are grouped by kind.\n"
    "docs/trace.md (\"crosscheck\") explains the classes and how to read the table.\n";

static const char crosscheck_epilog[] =
    "Exit status: 0 no unexplained disagreement, 1 at least one, 2 bad usage or input.\n";

/* Rays one run may trace (each costs 64 bytes of ray and two 96-byte records). */
#define XC_MAX_RAYS (UINT64_C(1) << 24)
/* Unexplained rays printed in full. */
#define XC_DETAIL 5
/* Ray kinds given their own row; a file's rays of further kinds share the last. */
#define XC_MAX_ROWS 16

typedef struct row {
    uint32_t kind;
    bool other; /* the row of every kind beyond XC_MAX_ROWS - 1 */
    uint64_t rays, oracle_hits, count[XC_CLASS_COUNT];
    double max_rel_dt;
} row;

typedef struct detail {
    char set[24];
    size_t index;
    rto_wf_ray ray;
    rto_hit_record oracle, embree;
    xc_result res;
} detail;

typedef struct run {
    const emb_module *E; /* Embree, loaded on demand (embree_module.h) */
    const rto_scene *scene;
    const rto_accel *accel;
    emb_device *dev;
    emb_scene *mirror, *robust; /* robust: only for --embree default, made on the first disagreement */
    cf_scene model;             /* the conformance model's view of the scene (DESIGN.md §9) */
    bool robust_mode, culling;
    uint32_t threads;
    row rows[XC_MAX_ROWS];
    size_t nrows;
    detail details[XC_DETAIL];
    size_t ndetails;
    uint64_t unexplained;
} run;

static const char *kind_name(uint32_t kind, char *buf, size_t cap)
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
        kind_name(w->kind, buf, cap);
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

static void print_text(const run *r, const char *scene_name, const char *mode)
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

static int print_json(const run *r, const char *scene_name, const char *mode)
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

/* ---- the command ---------------------------------------------------------------------------------------------- */

static bool ends_with(const char *s, const char *tail)
{
    size_t a = strlen(s), b = strlen(tail);
    return a >= b && !strcmp(s + a - b, tail);
}

/* --rays: the generated sets in the order given (duplicates dropped), or false for a bad name. */
static bool parse_sets(const char *text, rto_ray_set *sets, size_t *n)
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

static int run_file(run *r, const char *path, rto_msg *msg)
{
    rto_npy npy = {0};
    size_t count = 0;
    if (rto_npy_read(path, &npy, msg) || rto_layout_accept(RTO_LAYOUT_WF_RAY, &npy, &count, msg)) {
        rto_npy_free(&npy);
        return cli_fail("crosscheck", "--rays %s: %s", path, msg->text);
    }
    if (count > XC_MAX_RAYS) {
        rto_npy_free(&npy);
        return cli_fail("crosscheck", "--rays %s: %zu rays, at most %llu", path, count,
                        (unsigned long long)XC_MAX_RAYS);
    }
    const rto_wf_ray *rays = npy.data;
    for (size_t i = 0; i < count; i++)
        r->culling |= (rays[i].flags & (RTO_RAY_FLAG_CULL_BACK_FACING | RTO_RAY_FLAG_CULL_FRONT_FACING)) != 0;
    const char *base = strrchr(path, '/');
    rto_status st = trace_both(r, base ? base + 1 : path, rays, count, msg);
    rto_npy_free(&npy);
    return st ? cli_status("crosscheck", st, msg) : EXIT_PASS;
}

static int run_sets(run *r, const rto_ray_set *sets, size_t nsets, uint32_t seed, uint32_t width, uint32_t height,
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

int cmd_crosscheck(int argc, char **argv)
{
    const char *rays_arg = "primary,random,grazing,axis,shadow";
    uint32_t count = 65536, width = 320, height = 240, seed = 1, threads = 0;
    unsigned robust = 1;
    bool json = false;
    static const opt_name modes[] = {{"robust", 1}, {"default", 0}, {NULL, 0}};
    const opt_spec opts[] = {
        OPT_STRING("rays", &rays_arg, "SETS|FILE.npy",
                   "generated sets (primary, shadow, random, grazing, axis; default all) or a WfRay .npy file"),
        OPT_UINT("count", &count, 1, XC_MAX_RAYS, "N", "rays of each random, grazing and axis set", "65536"),
        OPT_UINT("width", &width, 1, 16384, "W", "image width of primary and shadow rays", "320"),
        OPT_UINT("height", &height, 1, 16384, "H", "image height of primary and shadow rays", "240"),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "S", "PRNG seed of the generated sets", "1"),
        OPT_ENUM("embree", &robust, modes, "MODE",
                 "Embree's mode: robust (RTC_SCENE_FLAG_ROBUST, watertight) or default (its fast path)", "robust"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads for both tracers (0: one per online CPU)", "0"),
        OPT_FLAG("json", &json, "print the table as JSON"),
        OPT_END,
    };
    const opt_command cmd = {"crosscheck", crosscheck_usage, crosscheck_epilog, opts, 1, 1, "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    if ((uint64_t)width * height > XC_MAX_RAYS)
        return cli_fail("crosscheck", "--width %u --height %u: %llu rays, at most %llu", width, height,
                        (unsigned long long)width * height, (unsigned long long)XC_MAX_RAYS);
    rto_ray_set sets[RTO_RAY_SET_COUNT];
    size_t nsets = 0;
    const bool file = ends_with(rays_arg, ".npy");
    if (!file && !parse_sets(rays_arg, sets, &nsets))
        return cli_fail("crosscheck", "--rays %s: expected a comma-separated list of primary, shadow, random, grazing, "
                        "axis, or a .npy ray file", rays_arg);

    const char *spec = args.arg[0];
    rto_msg msg = {{0}};
    const emb_module *E = emb_module_load(&msg);
    if (!E)
        return cli_fail("crosscheck", "%s", msg.text);
    rto_scene *sc = NULL;
    if (rto_scene_load(spec, &sc, &msg))
        return cli_fail("crosscheck", "%s", msg.text);
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle crosscheck: warning: %s\n", sc->warnings[w]);
    run r;
    memset(&r, 0, sizeof r);
    r.E = E;
    r.scene = sc;
    r.robust_mode = robust != 0;
    r.threads = threads;
    rto_accel *acc = NULL;
    rto_status st = rto_accel_build(sc, NULL, &acc, &msg);
    if (!st)
        st = cf_scene_init(&r.model, sc, &msg);
    if (!st)
        st = E->device_create(threads, NULL, &r.dev, &msg);
    if (st) {
        rc = cli_status("crosscheck", st, &msg);
        goto out;
    }
    r.accel = acc;
    rc = file ? run_file(&r, rays_arg, &msg) : run_sets(&r, sets, nsets, seed, width, height, count, &msg);
    if (rc == EXIT_PASS) {
        const char *mode = r.robust_mode ? "robust" : "default";
        rc = json ? print_json(&r, spec, mode) : (print_text(&r, spec, mode), EXIT_PASS);
        if (rc == EXIT_PASS && r.unexplained)
            rc = EXIT_MISMATCH;
    }
out:
    E->scene_destroy(r.mirror);
    E->scene_destroy(r.robust);
    E->device_destroy(r.dev);
    cf_scene_free(&r.model);
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
    return rc;
}
