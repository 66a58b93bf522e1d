/* Acceleration-structure benchmark: the oracle's build (rto_accel_build: boxes, keys, radix sort, trees, statistics),
 * with one thread and with every hardware thread, beside Embree's two builders on the same geometry in the same
 * process, median of RUNS runs each; each Embree row's ratio is against the oracle with the same thread count:
 *   - LOW: Embree's Morton builder, the closest relative of an LBVH. Embree picks it only when both the scene
 *     (rtcSetSceneBuildQuality, which selects the two-level builder) and the geometry (rtcSetGeometryBuildQuality,
 *     which selects Morton for that geometry) ask for RTC_BUILD_QUALITY_LOW;
 *   - MEDIUM: its default binned-SAH builder;
 * each on a device with "threads=1" and on one with the default thread count (every hardware thread), one device
 * alive at a time (all the one-thread rows first, then all the all-thread rows; runs interleaved within each), and
 * every timed build after a 20 ms pause (settle), so that neither side's idle threads are still spinning.
 * Cases: the BLAS of every mesh of the bunny and of 2CylinderEngine (one Embree scene per mesh, as the oracle builds
 * one BLAS per mesh; vertex and index buffers are filled before the clock starts, as the oracle's scene is loaded
 * before it), and the TLAS of instances:uniform:65536, where Embree's timed region includes creating the 65,536
 * instance geometries, as the oracle's includes its instance-box pass (the commit alone is printed beside it), and,
 * as a second Embree TLAS, one user geometry of 65,536 boxes whose bounds callback transforms the instanced mesh's
 * box as the oracle's instance-box pass does (no geometry object per instance). The oracle's timed region is the whole
 * rto_accel_build, so the BLAS cases include its TLAS over the scene's few instances, and the TLAS case the one
 * 12-triangle BLAS of the box.
 * Usage: bench_bvh [--json] [bunny.gltf] [2CylinderEngine.glb]. RTO_BENCH_EMBREE_CONFIG is appended to both
 * devices' config (e.g. "verbose=2" prints the builder Embree picked). Devices and mesh scenes are made by oracle/embree.c, as
 * crosscheck makes them. */
#define _GNU_SOURCE
#include "bench_util.h"
#include "embree.h"
#include "rtoracle.h"

#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_bvh: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

/* The Embree configurations, in print order. */
typedef struct econf {
    const char *name;
    emb_quality q;
    int dev; /* 0: threads=1, 1: default thread count */
} econf;

static const econf confs[] = {
    {"embree LOW (Morton)", EMB_QUALITY_LOW, 0},
    {"embree LOW (Morton)", EMB_QUALITY_LOW, 1},
    {"embree MEDIUM (SAH)", EMB_QUALITY_MEDIUM, 0},
    {"embree MEDIUM (SAH)", EMB_QUALITY_MEDIUM, 1},
};
#define NCONF (sizeof confs / sizeof confs[0])

static emb_device *devices[2];
static int hw_threads;

/* Embree errors arrive through the device's callback (oracle/embree.c): stop with the message. */
static void check(emb_device *d, const char *what)
{
    rto_msg msg = {{0}};
    if (emb_device_check(d, what, &msg))
        die(what, &msg);
}

static emb_device *new_device(uint32_t threads)
{
    rto_msg msg = {{0}};
    emb_device *d = NULL;
    if (emb_device_create(threads, getenv("RTO_BENCH_EMBREE_CONFIG"), &d, &msg))
        die("Embree device", &msg);
    return d;
}

/* Device d (0: threads=1, 1: every thread), the only one alive while its rows are measured: Embree runs every
 * device's builds in a task arena of the largest thread count among the devices alive (its getMaxNumThreads), so
 * with both alive, the threads=1 device would build on every thread. */
static void open_device(int d) { devices[d] = new_device(d ? 0u : 1u); }

static void close_device(int d)
{
    emb_device_destroy(devices[d]);
    devices[d] = NULL;
}

/* The oracle: the whole build the command and the tracer run, on one thread (dev 0) or every thread (dev 1).
 * Returns seconds. */
static double oracle_build(const rto_scene *s, int dev)
{
    rto_msg msg = {{0}};
    rto_accel *acc = NULL;
    rto_accel_desc d = {RTO_TLAS_SWEEP, dev ? 0u : 1u};
    settle();
    double t0 = now();
    if (rto_accel_build(s, &d, &acc, &msg))
        die("rto_accel_build", &msg);
    double t = now() - t0;
    rto_accel_destroy(acc);
    return t;
}

/* One Embree scene of one mesh, uncommitted (the commit is what is timed). */
static RTCScene embree_mesh_scene(emb_device *dev, const rto_mesh *m, emb_quality q)
{
    RTCScene sc = emb_mesh_scene_new(dev, m, q, false);
    check(dev, "mesh scene");
    if (!sc)
        die("mesh scene", NULL);
    return sc;
}

/* rtcCommitScene of one scene per mesh (empty meshes have no BLAS to build). Returns seconds. */
static double embree_blas(const rto_scene *s, const econf *c)
{
    double total = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        if (!s->meshes[m].triangle_count)
            continue;
        RTCScene sc = embree_mesh_scene(devices[c->dev], &s->meshes[m], c->q);
        settle();
        double t0 = now();
        rtcCommitScene(sc);
        total += now() - t0;
        check(devices[c->dev], "BLAS commit");
        rtcReleaseScene(sc);
    }
    return total;
}

/* Instance creation and rtcCommitScene of the top-level scene over a committed BLAS. Returns seconds, and the
 * commit's alone in *commit. */
static double embree_tlas(const rto_scene *s, RTCScene blas, const econf *c, double *commit)
{
    emb_device *dev = devices[c->dev];
    settle();
    double t0 = now();
    RTCScene top = rtcNewScene(emb_device_rtc(dev));
    rtcSetSceneBuildQuality(top, emb_quality_rtc(c->q));
    for (uint32_t i = 0; i < s->instance_count; i++)
        emb_instance_attach(dev, top, blas, &s->instances[i], i, c->q);
    double t1 = now();
    rtcCommitScene(top);
    double t = now() - t0;
    *commit = now() - t1;
    check(dev, "TLAS commit");
    rtcReleaseScene(top);
    return t;
}

typedef struct user_tlas {
    const rto_scene *scene;
    rto_aabb mesh_box; /* object-space box of the one instanced mesh */
} user_tlas;

/* Embree's bounds callback: the instance's world box, the mesh box through objToWorld as the oracle computes it. */
static void user_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const user_tlas *u = args->geometryUserPtr;
    rto_aabb w = rto_aabb_transform(&u->scene->instances[args->primID].obj_to_world, &u->mesh_box);
    args->bounds_o->lower_x = w.min.x;
    args->bounds_o->lower_y = w.min.y;
    args->bounds_o->lower_z = w.min.z;
    args->bounds_o->upper_x = w.max.x;
    args->bounds_o->upper_y = w.max.y;
    args->bounds_o->upper_z = w.max.z;
}

/* One user geometry of instance_count boxes and rtcCommitScene. Returns seconds. */
static double embree_user_tlas(const user_tlas *u, const econf *c)
{
    RTCDevice dev = emb_device_rtc(devices[c->dev]);
    settle();
    double t0 = now();
    RTCScene top = rtcNewScene(dev);
    rtcSetSceneBuildQuality(top, emb_quality_rtc(c->q));
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryBuildQuality(g, emb_quality_rtc(c->q));
    rtcSetGeometryUserPrimitiveCount(g, u->scene->instance_count);
    rtcSetGeometryUserData(g, (void *)(uintptr_t)u);
    rtcSetGeometryBoundsFunction(g, user_bounds, NULL);
    rtcCommitGeometry(g);
    rtcAttachGeometry(top, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(top);
    double t = now() - t0;
    check(devices[c->dev], "user-geometry TLAS commit");
    rtcReleaseScene(top);
    return t;
}

/* The oracle's rows (when label is not NULL; oracle[0] one thread, oracle[1] all), then one per Embree configuration
 * (suffix: "" or " user"; note: NULL or one per row), each also a --json row of case kase. */
static void print_rows(const char *label, const char *kase, uint64_t prims, const double *oracle,
                       const double *embree, const char *suffix, const double *note)
{
    for (int d = 0; label && d < 2; d++) {
        char threads[16];
        snprintf(threads, sizeof threads, d ? "all(%d)" : "1", hw_threads);
        char count[24];
        snprintf(count, sizeof count, "%llu", (unsigned long long)prims);
        printf("%-36s %8s  %-24s %7s %9.2f %9.2f %12s\n", d ? "" : label, d ? "" : count, "oracle rto_accel_build",
               threads, oracle[d] * 1e3, (double)prims / oracle[d] * 1e-6, "1.00");
    }
    for (size_t c = 0; c < NCONF; c++) {
        char name[64], extra[64] = "";
        snprintf(name, sizeof name, "%s%s", confs[c].name, suffix);
        if (note)
            snprintf(extra, sizeof extra, "  (commit alone %.2f ms)", note[c] * 1e3);
        char threads[16], ratio[16];
        if (confs[c].dev)
            snprintf(threads, sizeof threads, "all(%d)", hw_threads);
        else
            snprintf(threads, sizeof threads, "1");
        const double o = oracle[confs[c].dev];
        snprintf(ratio, sizeof ratio, "%.2f", o / embree[c]);
        printf("%-36s %8s  %-24s %7s %9.2f %9.2f %12s%s\n", "", "", name, threads, embree[c] * 1e3,
               (double)prims / embree[c] * 1e-6, ratio, extra);
        bench_row("bvh", kase, name, confs[c].dev ? 0 : 1, o, embree[c]);
    }
}

static void bench_blas(const char *path)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    if (rto_scene_load(path, &s, &msg)) {
        fprintf(stderr, "bench_bvh: skipping %s: %s\n", path, msg.text);
        return;
    }
    uint64_t tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        tris += s->meshes[m].triangle_count;
    double to[2][RUNS], te[NCONF][RUNS], me[NCONF];
    for (int d = 0; d < 2; d++) {
        open_device(d);
        for (int r = 0; r < RUNS; r++) {
            to[d][r] = oracle_build(s, d);
            for (size_t c = 0; c < NCONF; c++)
                if (confs[c].dev == d)
                    te[c][r] = embree_blas(s, &confs[c]);
        }
        close_device(d);
    }
    for (size_t c = 0; c < NCONF; c++)
        me[c] = median(te[c]);
    const char *base = strrchr(path, '/');
    char label[128];
    snprintf(label, sizeof label, "BLAS %s (%u meshes)", base ? base + 1 : path, s->mesh_count);
    const double mo[2] = {median(to[0]), median(to[1])};
    print_rows(label, label, tris, mo, me, "", NULL);
    rto_scene_destroy(s);
}

static void bench_tlas(const char *spec)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    if (rto_scene_load(spec, &s, &msg))
        die(spec, &msg);
    user_tlas u = {s, rto_mesh_aabb(&s->meshes[0])};
    double to[2][RUNS], te[NCONF][RUNS], tc[NCONF][RUNS], tu[NCONF][RUNS], me[NCONF], mc[NCONF], mu[NCONF];
    for (int d = 0; d < 2; d++) {
        open_device(d);
        RTCScene blas = embree_mesh_scene(devices[d], &s->meshes[0], EMB_QUALITY_MEDIUM);
        rtcCommitScene(blas);
        check(devices[d], "BLAS commit");
        for (int r = 0; r < RUNS; r++) {
            to[d][r] = oracle_build(s, d);
            for (size_t c = 0; c < NCONF; c++) {
                if (confs[c].dev != d)
                    continue;
                te[c][r] = embree_tlas(s, blas, &confs[c], &tc[c][r]);
                tu[c][r] = embree_user_tlas(&u, &confs[c]);
            }
        }
        rtcReleaseScene(blas);
        close_device(d);
    }
    for (size_t c = 0; c < NCONF; c++) {
        me[c] = median(te[c]);
        mc[c] = median(tc[c]);
        mu[c] = median(tu[c]);
    }
    char label[128];
    snprintf(label, sizeof label, "TLAS %s", spec);
    const double o[2] = {median(to[0]), median(to[1])};
    print_rows(label, label, s->instance_count, o, me, " inst", mc);
    print_rows(NULL, label, s->instance_count, o, mu, " user", NULL);
    rto_scene_destroy(s);
}

int main(int argc, char **argv)
{
    bench_init(&argc, argv);
    cpu_set_t set;
    hw_threads = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
    print_load("before");
    printf("%-36s %8s  %-24s %7s %9s %9s %12s\n", "case", "prims", "builder", "threads", "ms", "Mprims/s",
           "oracle/this");
    for (int i = 1; i < argc; i++)
        bench_blas(argv[i]);
    bench_tlas("instances:uniform:65536");
    printf("median of %d runs each, interleaved; Embree %d.%d.%d; oracle/this = time(oracle with the same thread "
           "count) / time(that builder), > 1 means the oracle is slower\n",
           RUNS, RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH);
    print_load("after");
    bench_finish("bvh", RUNS, NULL);
    return 0;
}
