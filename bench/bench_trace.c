/* Trace benchmark: the oracle's ordered traversal (rto_trace) beside Embree 3 on the same rays in the same process.
 *
 * Table 1: Mrays/s for primary, shadow and random rays on the Stanford bunny, 2CylinderEngine and rtstress:16 at
 * 1920x1080 (random: 1920 * 1080 rays; shadow: one per primary hit), with 1 thread and with all threads:
 *   - the oracle: rto_trace with rto_trace_desc.threads 1, or 0 (one thread per online CPU), on each of its paths
 *     the CPU has (RTO_TRACE_ISA = scalar, sse2, avx2, avx512: the scalar reference, the packed path, 8 or 16 ray
 *     lanes); every path's records are compared with the scalar path's after the runs, and the ratios use the path
 *     rto_trace takes by default (sse2, the packed path; its copy of the trees is made by an untimed first call);
 *     on a CPU with AVX-512 the packed path again with RTO_TRACE_GROUPS=8 ("sse2 groups8", g8): what it runs on a
 *     CPU with AVX2 and without AVX-512 (groups of 8 rays instead of 16), so one machine gives both figures;
 *   - Embree: rtcIntersect1 per ray (rtcOccluded1 for the TERMINATE_ON_FIRST_HIT shadow rays) through the scene
 *     mirror of oracle/embree.c (one RTCScene per mesh, one instance geometry per instance, as crosscheck builds
 *     it). 1 thread: a device with "threads=1", traced in the calling thread. All threads: a device with Embree's
 *     default thread count, traced by emb_trace's own pthreads over the same static partition rto_trace uses
 *     ([k n / T, (k + 1) n / T)), so both sides get identical slices of work.
 *   Embree is built with RTC_BUILD_QUALITY_HIGH (SAH with spatial splits, its fastest structure to trace) and its
 *   default, non-robust intersection; a second column gives Embree with RTC_SCENE_FLAG_ROBUST, the mode crosscheck
 *   compares against (same build quality), and a third its stream API (rtcIntersect1M / rtcOccluded1M on streams
 *   of 256 rays), timed with the coherent and the incoherent context flag and shown at the faster of the two.
 * Table 2: the oracle's trace time for rtstress:N, N = 8, 16, 24, 32, 40 (512 to 64,000 instances), primary rays at
 *   1920x1080, 1 thread and all threads, relative to N = 8, with the sweep TLAS (the default) and a Karras TLAS: the
 *   sweep tree's leaves follow the sorted keys in a complete binary tree, so its subtrees match Morton cells only
 *   when the instance count is a power of two and fills the grid (N = 8, 16, 32); the Karras tree splits where the
 *   keys' bits change.
 * The timed region is the tracing call alone: scenes, trees, Embree mirrors and rays are made before the clock starts,
 * and the hit records are allocated once. Each figure is the median of RUNS runs, every side interleaved.
 * oracle/embree is time(oracle) / time(Embree): > 1 means the oracle is slower. Hits of both sides are counted
 * outside the clock and printed, so a reader sees both traced the same rays to the same surfaces.
 * Usage: bench_trace [--width W] [--height H] [--json] [--stress-only | --table1-only] [bunny.gltf]
 *                    [2CylinderEngine.glb]. */
#define _GNU_SOURCE
#include "bench_util.h"
#include "embree.h"
#include "rtoracle.h"

#include <jansson.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t width = 1920, height = 1080;
static int hw_threads;
static emb_device *devices[2]; /* 0: threads=1, 1: all */
static json_t *jrows, *jstress;

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_trace: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

typedef struct rayset {
    rto_ray_set set;
    rto_wf_ray *rays;
    size_t n;
} rayset;

static rayset make_rays(const rto_accel *acc, rto_ray_set set)
{
    rto_rays_desc d;
    memset(&d, 0, sizeof d);
    d.set = set;
    d.seed = 1;
    d.width = width;
    d.height = height;
    d.count = (size_t)width * height;
    rayset r = {set, NULL, 0};
    size_t cap = rto_rays_capacity(&d);
    r.rays = malloc((cap ? cap : 1) * sizeof *r.rays);
    rto_msg msg = {{0}};
    if (!r.rays || rto_rays_generate(acc, &d, r.rays, cap, &r.n, NULL, &msg))
        die("rto_rays_generate", &msg);
    return r;
}

/* What Table 1 times on each ray set: the oracle's paths (RTO_TRACE_ISA set to each in turn; one the CPU lacks is
 * skipped) and Embree's calls. */
typedef struct side {
    const char *name;
    const char *isa; /* an oracle path, or NULL for Embree */
    emb_api api;
    int robust;
    const char *groups; /* RTO_TRACE_GROUPS for the oracle's path, or NULL */
} side;
enum {
    SIDE_SCALAR,
    SIDE_SSE2,
    SIDE_SSE2_G8,
    SIDE_AVX2,
    SIDE_AVX512,
    SIDE_EMBREE,
    SIDE_ROBUST,
    SIDE_STREAM,
    SIDE_STREAM_COHERENT,
    SIDES
};
static const side sides[SIDES] = {
    {"scalar", "scalar", EMB_API_SINGLE, 0, NULL},
    {"sse2", "sse2", EMB_API_SINGLE, 0, NULL},
    {"sse2 groups8", "sse2", EMB_API_SINGLE, 0, "8"}, /* what the packed path runs on a CPU without AVX-512 */
    {"avx2", "avx2", EMB_API_SINGLE, 0, NULL},
    {"avx512", "avx512", EMB_API_SINGLE, 0, NULL},
    {"embree", NULL, EMB_API_SINGLE, 0, NULL},
    {"embree robust", NULL, EMB_API_SINGLE, 1, NULL},
    {"embree stream", NULL, EMB_API_STREAM, 0, NULL},
    {"embree stream coherent", NULL, EMB_API_STREAM_COHERENT, 0, NULL},
};
static int side_ok[SIDES];
static int default_side; /* the path rto_trace takes without RTO_TRACE_ISA */

static double time_side(int k, const rto_accel *acc, emb_scene *const e[2], emb_device *d, const rayset *r,
                        uint32_t threads, rto_hit_record *hits)
{
    rto_msg msg = {{0}};
    const side *sd = &sides[k];
    if ((sd->isa && setenv("RTO_TRACE_ISA", sd->isa, 1)) || (sd->groups && setenv("RTO_TRACE_GROUPS", sd->groups, 1)))
        die("setenv", NULL);
    rto_trace_desc td = {threads};
    const double t0 = now();
    if (sd->isa ? rto_trace(acc, r->rays, r->n, &td, hits, NULL, &msg) != RTO_OK
                : emb_trace_api(e[sd->robust], d, r->rays, r->n, threads, sd->api, hits, &msg) != RTO_OK)
        die(sd->name, &msg);
    const double t = now() - t0;
    unsetenv("RTO_TRACE_ISA");
    unsetenv("RTO_TRACE_GROUPS");
    return t;
}

static size_t count_hits(const rto_hit_record *h, size_t n)
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        k += h[i].miss_flag == 0;
    return k;
}

static void bench_scene(const char *spec, const char *label)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_accel *acc = NULL;
    if (rto_scene_load(spec, &s, &msg)) {
        fprintf(stderr, "bench_trace: skipping %s: %s\n", spec, msg.text);
        return;
    }
    if (rto_accel_build(s, NULL, &acc, &msg))
        die(spec, &msg);
    /* [device][0: fast, 1: robust] */
    emb_scene *e[2][2];
    for (int d = 0; d < 2; d++)
        for (int rb = 0; rb < 2; rb++) {
            emb_scene_desc desc = {EMB_QUALITY_HIGH, rb == 1, false};
            if (emb_scene_create(devices[d], s, &desc, &e[d][rb], &msg))
                die("emb_scene_create", &msg);
        }
    const rto_ray_set sets[3] = {RTO_RAYS_PRIMARY, RTO_RAYS_SHADOW, RTO_RAYS_RANDOM};
    for (int k = 0; k < 3; k++) {
        rayset r = make_rays(acc, sets[k]);
        const size_t bytes = (r.n ? r.n : 1) * sizeof(rto_hit_record);
        rto_hit_record *h[SIDES];
        for (int i = 0; i < SIDES; i++)
            if (!(h[i] = malloc(bytes)))
                die("out of memory", NULL);
        for (int d = 0; d < 2; d++) {
            const uint32_t threads = d ? 0 : 1;
            double t[SIDES][RUNS], m[SIDES] = {0};
            /* Untimed: the first rto_trace of an accel makes the packed copy of its trees, as Embree's commit is made
             * before the clock (one ray is enough) */
            const rayset first = {r.set, r.rays, r.n ? 1 : 0};
            time_side(SIDE_SSE2, acc, e[d], devices[d], &first, threads, h[SIDE_SSE2]);
            for (int run = 0; run < RUNS; run++)
                for (int i = 0; i < SIDES; i++)
                    if (side_ok[i])
                        t[i][run] = time_side(i, acc, e[d], devices[d], &r, threads, h[i]);
            for (int i = 0; i < SIDES; i++)
                if (side_ok[i]) {
                    m[i] = median(t[i]);
                    /* every oracle path writes the scalar tracer's bytes (unit.trace_lanes holds them to it too) */
                    if (sides[i].isa && memcmp(h[i], h[SIDE_SCALAR], r.n * sizeof *h[i]))
                        die(sides[i].name, &(rto_msg){{"records differ from the scalar path's"}});
                }
            /* Embree's stream API at its faster context flag: the fairer reference */
            const int st = m[SIDE_STREAM_COHERENT] < m[SIDE_STREAM] ? SIDE_STREAM_COHERENT : SIDE_STREAM;
            const double n = (double)r.n, mo = m[default_side];
            char th[16], kase[96];
            snprintf(th, sizeof th, d ? "all(%d)" : "1", hw_threads);
            printf("%-16s %-7s %7s %8zu %8zu %8zu |", label, rto_ray_set_name(sets[k]), th, r.n,
                   count_hits(h[SIDE_SCALAR], r.n), count_hits(h[SIDE_EMBREE], r.n));
            for (int i = 0; i < SIDES; i++) {
                if (i == SIDE_STREAM_COHERENT)
                    continue;
                if (side_ok[i])
                    printf(" %7.2f", n / m[i == SIDE_STREAM ? st : i] * 1e-6);
                else
                    printf(" %7s", "-");
            }
            printf(" | %6.2f %6.2f %6.2f", mo / m[SIDE_EMBREE], mo / m[SIDE_ROBUST], mo / m[st]);
            if (side_ok[SIDE_SSE2_G8])
                printf(" %6.2f", m[SIDE_SSE2_G8] / m[SIDE_EMBREE]);
            printf("\n");
            snprintf(kase, sizeof kase, "%s %s", label, rto_ray_set_name(sets[k]));
            json_t *ms = json_object();
            for (int i = 0; i < SIDES; i++) {
                if (!side_ok[i])
                    continue;
                json_object_set_new(ms, sides[i].name, json_real(m[i] * 1e3));
                if (sides[i].isa) { /* each oracle path against rtcIntersect1 */
                    char group[32];
                    snprintf(group, sizeof group, "trace %s", sides[i].name);
                    bench_row(group, kase, "embree", d ? 0 : 1, m[i], m[SIDE_EMBREE]);
                }
            }
            char group[32];
            snprintf(group, sizeof group, "trace %s", sides[default_side].name);
            bench_row(group, kase, "embree robust", d ? 0 : 1, mo, m[SIDE_ROBUST]);
            bench_row(group, kase, sides[st].name, d ? 0 : 1, mo, m[st]);
            json_array_append_new(jrows, json_pack("{s:s, s:s, s:i, s:I, s:I, s:I, s:s, s:o}", "scene", label, "rays",
                rto_ray_set_name(sets[k]), "threads", d ? hw_threads : 1, "count", (json_int_t)r.n, "oracle_hits",
                (json_int_t)count_hits(h[SIDE_SCALAR], r.n), "embree_hits",
                (json_int_t)count_hits(h[SIDE_EMBREE], r.n), "default_path", sides[default_side].name, "ms", ms));
            fflush(stdout);
        }
        for (int i = 0; i < SIDES; i++)
            free(h[i]);
        free(r.rays);
    }
    for (int d = 0; d < 2; d++)
        for (int rb = 0; rb < 2; rb++)
            emb_scene_destroy(e[d][rb]);
    rto_accel_destroy(acc);
    rto_scene_destroy(s);
}

static double time_oracle(const rto_accel *acc, const rayset *r, uint32_t threads, rto_hit_record *hits)
{
    rto_msg msg = {{0}};
    rto_trace_desc td = {threads};
    double t0 = now();
    if (rto_trace(acc, r->rays, r->n, &td, hits, NULL, &msg))
        die("rto_trace", &msg);
    return now() - t0;
}

static void bench_stress(void)
{
    printf("\noracle trace cost for rtstress:N, primary rays at %ux%u (median of %d runs), with the sweep TLAS (the "
           "default) and a Karras TLAS\n", width, height, RUNS);
    printf("%-12s %-6s %9s %9s %9s | %10s %8s %7s | %10s %8s %7s\n", "scene", "tlas", "instances", "rays", "hits",
           "1 thr ms", "Mrays/s", "vs N=8", "all ms", "Mrays/s", "vs N=8");
    double base[2][2] = {{0, 0}, {0, 0}};
    for (uint32_t n = 8; n <= 40; n += 8) {
        char spec[32];
        snprintf(spec, sizeof spec, "rtstress:%u", n);
        rto_msg msg = {{0}};
        rto_scene *s = NULL;
        rto_accel *acc[2] = {NULL, NULL};
        const rto_accel_desc kinds[2] = {{RTO_TLAS_SWEEP, 0}, {RTO_TLAS_KARRAS, 0}};
        if (rto_scene_load(spec, &s, &msg) || rto_accel_build(s, &kinds[0], &acc[0], &msg) ||
            rto_accel_build(s, &kinds[1], &acc[1], &msg))
            die(spec, &msg);
        rayset r = make_rays(acc[0], RTO_RAYS_PRIMARY);
        rto_hit_record *h = malloc(r.n * sizeof *h);
        if (!h)
            die("out of memory", NULL);
        for (int k = 0; k < 2; k++) {
            double m[2];
            for (int d = 0; d < 2; d++) {
                double t[RUNS];
                for (int run = 0; run < RUNS; run++)
                    t[run] = time_oracle(acc[k], &r, d ? 0 : 1, h);
                m[d] = median(t);
                if (n == 8)
                    base[k][d] = m[d];
            }
            size_t hits = count_hits(h, r.n);
            const char *tl = k ? "karras" : "sweep";
            printf("%-12s %-6s %9u %9zu %9zu | %10.1f %8.2f %7.2f | %10.1f %8.2f %7.2f\n", spec, tl, s->instance_count,
                   r.n, hits, m[0] * 1e3, (double)r.n / m[0] * 1e-6, m[0] / base[k][0], m[1] * 1e3,
                   (double)r.n / m[1] * 1e-6, m[1] / base[k][1]);
            json_array_append_new(jstress, json_pack("{s:s, s:s, s:i, s:I, s:I, s:f, s:f, s:f, s:f}", "scene", spec,
                "tlas", tl, "instances", (int)s->instance_count, "rays", (json_int_t)r.n, "hits", (json_int_t)hits,
                "ms_1_thread", m[0] * 1e3, "ms_all_threads", m[1] * 1e3, "rel_1_thread", m[0] / base[k][0],
                "rel_all_threads", m[1] / base[k][1]));
            fflush(stdout);
        }
        free(h);
        free(r.rays);
        rto_accel_destroy(acc[0]);
        rto_accel_destroy(acc[1]);
        rto_scene_destroy(s);
    }
}

static uint32_t arg_u32(const char *text)
{
    char *end;
    unsigned long v = strtoul(text, &end, 10);
    if (*end || v == 0 || v > 16384) {
        fprintf(stderr, "bench_trace: bad size '%s'\n", text);
        exit(2);
    }
    return (uint32_t)v;
}

int main(int argc, char **argv)
{
    const char *scenes[8];
    int nscenes = 0;
    int stress_only = 0, table1_only = 0;
    bench_init(&argc, argv);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--width") && i + 1 < argc)
            width = arg_u32(argv[++i]);
        else if (!strcmp(argv[i], "--height") && i + 1 < argc)
            height = arg_u32(argv[++i]);
        else if (!strcmp(argv[i], "--stress-only"))
            stress_only = 1;
        else if (!strcmp(argv[i], "--table1-only"))
            table1_only = 1;
        else if (nscenes < 6)
            scenes[nscenes++] = argv[i];
    }
    cpu_set_t set;
    hw_threads = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
    rto_msg msg = {{0}};
    if (emb_device_create(1, NULL, &devices[0], &msg) || emb_device_create(0, NULL, &devices[1], &msg))
        die("Embree device", &msg);
    jrows = json_array();
    jstress = json_array();
    print_load("before");
    __builtin_cpu_init();
    for (int i = 0; i < SIDES; i++)
        side_ok[i] = 1;
    side_ok[SIDE_AVX2] = __builtin_cpu_supports("avx2");
    side_ok[SIDE_AVX512] = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
    side_ok[SIDE_SSE2_G8] = side_ok[SIDE_AVX512]; /* elsewhere the same as sse2 */
    /* rto_trace's default: the packed path (sse2) on x86-64, the only architecture this benchmark's paths exist on */
    default_side = SIDE_SSE2;
    printf("rays at %ux%u (random: %u rays; shadow: one per primary hit), median of %d runs, interleaved; Embree "
           "%d.%d.%d, build quality %s. Mrays/s of the oracle's paths (RTO_TRACE_ISA; rto_trace takes %s here) and "
           "of Embree: rtcIntersect1, robust, and rtcIntersect1M streams at their faster context flag; oracle/x = "
           "time(%s) / time(x); g8: sse2 with RTO_TRACE_GROUPS=8 (groups of 8, as without AVX-512; AVX-512 CPUs "
           "only)\n", width, height, width * height, RUNS, RTC_VERSION_MAJOR, RTC_VERSION_MINOR,
           RTC_VERSION_PATCH, emb_quality_name(EMB_QUALITY_HIGH), sides[default_side].name, sides[default_side].name);
    printf("%-16s %-7s %7s %8s %8s %8s | %7s %7s %7s %7s %7s %7s %7s %7s | %6s %6s %6s %6s\n", "scene", "rays",
           "threads", "count", "hits", "emb hits", "scalar", "sse2", "g8", "avx2", "avx512", "embree", "robust",
           "stream", "/emb", "/robust", "/stream", "g8/emb");
    for (int i = 0; i < nscenes && !stress_only; i++) {
        const char *base = strrchr(scenes[i], '/');
        bench_scene(scenes[i], base ? base + 1 : scenes[i]);
    }
    if (!stress_only)
        bench_scene("rtstress:16", "rtstress:16");
    if (!table1_only)
        bench_stress();
    print_load("after");
    bench_finish("trace", RUNS, json_pack("{s:i, s:i, s:i, s:o, s:o}", "width", (int)width, "height", (int)height,
                                    "threads", hw_threads, "rays", jrows, "rtstress", jstress));
    emb_device_destroy(devices[0]);
    emb_device_destroy(devices[1]);
    return 0;
}
