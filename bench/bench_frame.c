/* Frame benchmark: a full `sun-shadow` frame (maxDepth 2: primary rays, then shadow rays) at 1920x1080 with every
 * stage kept, as `rtoracle render SCENE --program sun-shadow --stages all` makes a full dump (bench/golden.py times
 * render's default, the lean golden), for the Stanford bunny, the Cornell box,
 * 2CylinderEngine and rtstress:16, beside Embree tracing the same primary + shadow rays.
 *
 * Each scene runs in two child processes (fork), so neither memory peak nor allocator state carries from one scene
 * or one measurement to the next:
 *   - golden: load, build, one frame with all (allowed) threads and every stage kept (RTO_FRAME_KEEP_ALL), then the
 *     bundle `rtoracle render` writes (the build bundle, the mesh geometry and the frame's files) into a temporary
 *     directory, which is measured (bytes, files) and removed. Peak RSS is getrusage's ru_maxrss of that child, after
 *     the frame and after the write.
 *   - timing: RUNS frames with one thread and with all threads (rto_frame_desc.threads 1 and the CPUs this process
 *     may run on, so `taskset -c 0,1` measures 2 cores), interleaved with Embree tracing the frame's own queue 0
 *     (primary) and queue 1 (shadow) rays: one device with "threads=1" traced in the calling thread, one with
 *     "threads=N" for the same N traced by emb_trace's static partition over N threads (as bench_trace). Embree
 *     runs its fastest mode, build quality HIGH (SAH with spatial splits) without RTC_SCENE_FLAG_ROBUST; shadow rays
 *     (TERMINATE_ON_FIRST_HIT) go through rtcOccluded1.
 *     Same work in both timed regions: the frame's TRACE stage allocates its hit records and traces the queue of
 *     each bounce; Embree's timed region allocates a hit array for the same rays the same way and traces them (the array is
 *     freed after the clock stops, as the frame's are freed after the frame). Stage times are rto_frame.seconds,
 *     the total is the wall time of rto_frame_render; every figure is the median of RUNS runs.
 * Ratios are time(oracle) / time(Embree): "trace/emb" compares the TRACE stage with Embree on the same rays,
 * "frame/emb" the whole frame. The camera is the scene's first camera, else the framing of its bounds (as `render`).
 * The timing child also renders each frame with no stage kept (rto_frame_desc.keep 0: counters, image and mask only,
 * what `--stages none` writes), and times Embree a second time into a hit array written before ("emb warm": tracing
 * alone, without the page faults of new memory, which dominate on some virtual machines; the header prints what a
 * first touch costs on this one).
 * Usage: bench_frame [--json] [--width W] [--height H] [--runs N (5 .. 7)] [--no-golden] [bunny.gltf] [cornellBox.gltf]
 *        [2CylinderEngine.glb] (rtstress:16 is always added; --no-golden skips the bundle and RSS child). */
#define _GNU_SOURCE
#include "bench_util.h"
#include "core/internal.h" /* rto__alloc_large: the frame's allocation of hit records */
#include "embree.h"
#include "rtoracle.h"

#include <dirent.h>
#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static uint32_t width = 1920, height = 1080;
static int runs = RUNS;
static int hw_threads;
static int no_golden;

/* What a scene's children report to the parent through a pipe. */
typedef struct golden_result {
    int ok;
    char camera[64];
    uint32_t instances;
    uint64_t triangles, rays[3]; /* per queue */
    uint64_t bundle_bytes, bundle_files;
    double render_s, write_s;
    long rss_after_render_kb, rss_peak_kb;
} golden_result;

typedef struct timing_result {
    int ok;
    uint64_t primary, shadow;
    double stage[2][RTO_FRAME_STAGE_COUNT]; /* [0: 1 thread, 1: all][stage], medians */
    double total[2], lean[2], embree[2], embree_warm[2];
} timing_result;

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_frame: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

static long rss_kb(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss; /* kilobytes on Linux */
}

/* The median of the first `runs` samples (bench_util's median takes exactly RUNS). */
static double median_n(double *t)
{
    qsort(t, (size_t)runs, sizeof *t, cmp_double);
    return runs % 2 ? t[runs / 2] : 0.5 * (t[runs / 2 - 1] + t[runs / 2]);
}

typedef struct loaded {
    rto_scene *scene;
    rto_accel *accel;
    rto_camera camera;
} loaded;

static int load(const char *spec, loaded *l)
{
    rto_msg msg = {{0}};
    memset(l, 0, sizeof *l);
    if (rto_scene_load(spec, &l->scene, &msg)) {
        fprintf(stderr, "bench_frame: skipping %s: %s\n", spec, msg.text);
        return 0;
    }
    if (rto_accel_build(l->scene, NULL, &l->accel, &msg))
        die(spec, &msg);
    if (l->scene->camera_count) {
        l->camera = l->scene->cameras[0];
    } else {
        const rto_aabb b = rto_scene_aabb(l->scene);
        l->camera = rto_camera_frame(&b, (float)width / (float)height);
        snprintf(l->camera.name, sizeof l->camera.name, "auto");
    }
    return 1;
}

static void unload(loaded *l)
{
    rto_accel_destroy(l->accel);
    rto_scene_destroy(l->scene);
}

static rto_frame *frame_run(const loaded *l, uint32_t threads, uint32_t keep, double *wall)
{
    rto_frame_desc d;
    memset(&d, 0, sizeof d);
    d.program = rto_program_builtin("sun-shadow");
    d.scene_kind = RTO_FRAME_SCENE_MESH;
    d.accel = l->accel;
    d.width = width;
    d.height = height;
    d.max_depth = 2;
    d.camera = &l->camera;
    d.keep = keep;
    d.threads = threads;
    rto_frame *f = NULL;
    rto_msg msg = {{0}};
    const double t0 = now();
    if (rto_frame_render(&d, &f, &msg))
        die("rto_frame_render", &msg);
    *wall = now() - t0;
    return f;
}

/* Sums the sizes of the regular files in dir, then removes them and dir (a bundle is one flat directory). */
static void measure_and_remove(const char *dir, uint64_t *bytes, uint64_t *files)
{
    *bytes = *files = 0;
    DIR *dp = opendir(dir);
    if (!dp)
        return;
    struct dirent *e;
    char path[8192];
    while ((e = readdir(dp))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        const int len = snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (len < 0 || (size_t)len >= sizeof path)
            continue;
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISREG(st.st_mode)) {
            *bytes += (uint64_t)st.st_size;
            (*files)++;
            unlink(path);
        }
    }
    closedir(dp);
    rmdir(dir);
}

/* The files `rtoracle render` writes for a mesh scene: build bundle, mesh geometry, then the frame's. */
static void write_golden(const loaded *l, const rto_frame *f, const char *outdir)
{
    rto_msg msg = {{0}};
    rto_bundle *b = NULL;
    rto_status s = rto_bundle_begin(outdir, "frame", &b, &msg);
    if (!s)
        s = rto_bvh_bundle_write(l->accel, b, &msg);
    for (uint32_t m = 0; !s && m < l->scene->mesh_count; m++) {
        const rto_mesh *mesh = &l->scene->meshes[m];
        char name[RTO_BUNDLE_FILE_NAME_MAX];
        rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_F32, 2, mesh->vertex_count, 3, 0);
        s = rto_bundle_file_name(RTO_FILE_MESH_POSITIONS, m, name, sizeof name);
        if (!s)
            s = rto_bundle_add_npy(b, name, rto_bundle_file_role(RTO_FILE_MESH_POSITIONS), NULL, &d, mesh->positions,
                                   &msg);
        d = rto_npy_desc_array(RTO_DTYPE_U32, 2, mesh->triangle_count, 3, 0);
        if (!s)
            s = rto_bundle_file_name(RTO_FILE_MESH_INDICES, m, name, sizeof name);
        if (!s)
            s = rto_bundle_add_npy(b, name, rto_bundle_file_role(RTO_FILE_MESH_INDICES), NULL, &d, mesh->indices,
                                   &msg);
    }
    if (!s)
        s = rto_frame_bundle_write(f, 1, b, &msg);
    if (!s)
        s = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    if (s)
        die("writing the bundle", &msg);
}

static golden_result child_golden(const char *spec)
{
    golden_result g;
    memset(&g, 0, sizeof g);
    loaded l;
    if (!load(spec, &l))
        return g;
    snprintf(g.camera, sizeof g.camera, "%s", l.camera.name);
    g.instances = l.scene->instance_count;
    for (uint32_t i = 0; i < l.scene->instance_count; i++)
        g.triangles += l.scene->meshes[l.scene->instances[i].blas].triangle_count;
    rto_frame *f = frame_run(&l, (uint32_t)hw_threads, RTO_FRAME_KEEP_ALL, &g.render_s);
    g.rss_after_render_kb = rss_kb();
    for (uint32_t d = 0; d < 3 && d <= f->max_depth; d++)
        g.rays[d] = f->counters[d].queued;
    const char *tmp = getenv("TMPDIR");
    char parent[4096], outdir[4200];
    snprintf(parent, sizeof parent, "%s/bench_frame.XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(parent)) {
        fprintf(stderr, "bench_frame: mkdtemp %s: %s\n", parent, strerror(errno));
        exit(1);
    }
    snprintf(outdir, sizeof outdir, "%s/golden", parent);
    const double t0 = now();
    write_golden(&l, f, outdir);
    g.write_s = now() - t0;
    g.rss_peak_kb = rss_kb();
    measure_and_remove(outdir, &g.bundle_bytes, &g.bundle_files);
    rmdir(parent);
    rto_frame_destroy(f);
    unload(&l);
    g.ok = 1;
    return g;
}

/* Embree on the rays: into a fresh hit array, allocated in the timed region exactly as the frame's TRACE allocates
 * its hit records (rto__alloc_large: 2 MiB-aligned and advised as transparent huge pages, so both sides pay the same
 * first touch) (warm == NULL), or into warm, an array already written once (tracing alone). */
static double time_embree(const emb_scene *e, emb_device *dev, const rto_wf_ray *rays, size_t n, uint32_t threads,
                          rto_hit_record *warm)
{
    rto_msg msg = {{0}};
    const double t0 = now();
    rto_hit_record *hits = warm ? warm : rto__alloc_large(n, sizeof *hits);
    if (!hits || emb_trace(e, dev, rays, n, threads, hits, &msg))
        die("emb_trace", &msg);
    const double t = now() - t0;
    if (!warm)
        free(hits);
    return t;
}

static timing_result child_timing(const char *spec)
{
    timing_result r;
    memset(&r, 0, sizeof r);
    loaded l;
    if (!load(spec, &l))
        return r;
    /* The rays Embree traces: the frame's own primary and shadow queues. */
    double wall;
    rto_frame *f = frame_run(&l, (uint32_t)hw_threads, RTO_FRAME_KEEP_RAYS, &wall);
    r.primary = f->queues[0].count;
    r.shadow = f->queues[1].count;
    const size_t n = r.primary + r.shadow;
    rto_wf_ray *rays = malloc(n * sizeof *rays);
    if (!rays)
        die("out of memory", NULL);
    memcpy(rays, f->queues[0].rays, r.primary * sizeof *rays);
    memcpy(rays + r.primary, f->queues[1].rays, r.shadow * sizeof *rays);
    rto_frame_destroy(f);
    rto_msg msg = {{0}};
    emb_device *dev[2];
    emb_scene *es[2];
    if (emb_device_create(1, NULL, &dev[0], &msg) || emb_device_create((uint32_t)hw_threads, NULL, &dev[1], &msg))
        die("Embree device", &msg);
    for (int d = 0; d < 2; d++) {
        emb_scene_desc desc = {EMB_QUALITY_HIGH, false, false};
        if (emb_scene_create(dev[d], l.scene, &desc, &es[d], &msg))
            die("emb_scene_create", &msg);
    }
    rto_hit_record *warm = malloc(n * sizeof *warm);
    if (!warm)
        die("out of memory", NULL);
    memset(warm, 0, n * sizeof *warm);
    double st[2][RTO_FRAME_STAGE_COUNT][RUNS], tot[2][RUNS], lean[2][RUNS], emb[2][RUNS], embw[2][RUNS];
    for (int run = 0; run < runs; run++)
        for (int d = 0; d < 2; d++) {
            const uint32_t threads = d ? (uint32_t)hw_threads : 1u;
            f = frame_run(&l, threads, RTO_FRAME_KEEP_ALL, &tot[d][run]);
            for (int s = 0; s < RTO_FRAME_STAGE_COUNT; s++)
                st[d][s][run] = f->seconds[s];
            rto_frame_destroy(f);
            rto_frame_destroy(frame_run(&l, threads, 0, &lean[d][run]));
            emb[d][run] = time_embree(es[d], dev[d], rays, n, threads, NULL);
            embw[d][run] = time_embree(es[d], dev[d], rays, n, threads, warm);
        }
    free(warm);
    for (int d = 0; d < 2; d++) {
        for (int s = 0; s < RTO_FRAME_STAGE_COUNT; s++)
            r.stage[d][s] = median_n(st[d][s]);
        r.total[d] = median_n(tot[d]);
        r.lean[d] = median_n(lean[d]);
        r.embree[d] = median_n(emb[d]);
        r.embree_warm[d] = median_n(embw[d]);
        emb_scene_destroy(es[d]);
        emb_device_destroy(dev[d]);
    }
    free(rays);
    unload(&l);
    r.ok = 1;
    return r;
}

/* Runs fn(spec) in a child and copies its result (size bytes) back through a pipe. */
static int in_child(void (*fn)(const char *, void *), const char *spec, void *out, size_t size)
{
    int fd[2];
    if (pipe(fd))
        return 0;
    fflush(stdout);
    fflush(stderr);
    const pid_t pid = fork();
    if (pid < 0)
        return 0;
    if (pid == 0) {
        close(fd[0]);
        char *buf = calloc(1, size);
        if (!buf)
            _exit(1);
        fn(spec, buf);
        size_t off = 0;
        while (off < size) {
            const ssize_t w = write(fd[1], buf + off, size - off);
            if (w <= 0)
                _exit(1);
            off += (size_t)w;
        }
        _exit(0);
    }
    close(fd[1]);
    size_t off = 0;
    while (off < size) {
        const ssize_t rd = read(fd[0], (char *)out + off, size - off);
        if (rd <= 0)
            break;
        off += (size_t)rd;
    }
    close(fd[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    return off == size && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

static void golden_fn(const char *spec, void *out) { *(golden_result *)out = child_golden(spec); }
static void timing_fn(const char *spec, void *out) { *(timing_result *)out = child_timing(spec); }

/* --json's detail: one object per scene with the figures docs/frame.md's table shows (bench/frame_table.py). */
static json_t *detail_scenes;

static void bench_scene(const char *spec, const char *label)
{
    golden_result g;
    timing_result t;
    memset(&g, 0, sizeof g);
    memset(&t, 0, sizeof t);
    if ((!no_golden && (!in_child(golden_fn, spec, &g, sizeof g) || !g.ok)) ||
        !in_child(timing_fn, spec, &t, sizeof t) || !t.ok) {
        printf("%-19s failed or skipped (see stderr)\n", label);
        return;
    }
    for (int d = 0; d < 2; d++) {
        char th[16];
        snprintf(th, sizeof th, d ? "all(%d)" : "1", hw_threads);
        const double *s = t.stage[d];
        printf("%-19s %-7s %8llu %8llu %7.1f %7.1f %8.1f %8.1f %7.1f %8.1f %8.1f %8.1f %8.1f %6.2f %6.2f %6.2f\n",
               label, th, (unsigned long long)t.primary, (unsigned long long)t.shadow, s[RTO_STAGE_GENERATE] * 1e3,
               s[RTO_STAGE_PREP] * 1e3, s[RTO_STAGE_TRACE] * 1e3, s[RTO_STAGE_SHADE] * 1e3,
               s[RTO_STAGE_RESOLVE] * 1e3, t.total[d] * 1e3, t.lean[d] * 1e3, t.embree[d] * 1e3,
               t.embree_warm[d] * 1e3, s[RTO_STAGE_TRACE] / t.embree[d], t.total[d] / t.embree[d],
               t.lean[d] / t.embree[d]);
        char kase[96];
        snprintf(kase, sizeof kase, "%s TRACE stage", label);
        bench_row("frame", kase, "embree (primary + shadow rays)", d ? 0 : 1, s[RTO_STAGE_TRACE], t.embree[d]);
        snprintf(kase, sizeof kase, "%s whole frame", label);
        bench_row("frame", kase, "embree (primary + shadow rays)", d ? 0 : 1, t.total[d], t.embree[d]);
    }
    const double mb = 1.0 / (1024.0 * 1024.0);
    const double bytes_mb = (double)g.bundle_bytes * mb, rss_mb = (double)g.rss_peak_kb / 1024.0;
    json_t *sc = json_pack("{s:s, s:I, s:I, s:i}", "scene", label, "primary_rays", (json_int_t)t.primary,
                           "shadow_rays", (json_int_t)t.shadow, "threads_all", hw_threads);
    for (int d = 0; d < 2 && sc; d++) {
        const double *st = t.stage[d];
        json_object_set_new(sc, d ? "all_threads" : "one_thread",
                            json_pack("{s:f, s:f, s:f, s:f, s:f, s:f, s:f, s:f}", "total_s", t.total[d], "no_stage_kept_s",
                                      t.lean[d], "generate_ms", st[RTO_STAGE_GENERATE] * 1e3, "trace_ms",
                                      st[RTO_STAGE_TRACE] * 1e3, "shade_ms", st[RTO_STAGE_SHADE] * 1e3, "resolve_ms",
                                      st[RTO_STAGE_RESOLVE] * 1e3, "embree_ms", t.embree[d] * 1e3,
                                      "trace_over_embree", st[RTO_STAGE_TRACE] / t.embree[d]));
    }
    if (sc && !no_golden)
        json_object_set_new(sc, "golden", json_pack("{s:f, s:I, s:f, s:f}", "bundle_mib", bytes_mb, "files",
                                                     (json_int_t)g.bundle_files, "write_s", g.write_s,
                                                     "peak_rss_mib", rss_mb));
    if (!sc || json_array_append_new(detail_scenes, sc)) {
        fprintf(stderr, "bench_frame: out of memory\n");
        exit(1);
    }
    if (!no_golden)
        printf("%-19s golden: camera '%s', %u instances, %llu triangles; queues %llu / %llu / %llu rays; render %.2f "
               "s, bundle %.1f MiB in %llu files written in %.2f s; peak RSS %.1f MiB after the frame, %.1f MiB after "
               "the write\n", label, g.camera, g.instances, (unsigned long long)g.triangles,
               (unsigned long long)g.rays[0], (unsigned long long)g.rays[1], (unsigned long long)g.rays[2], g.render_s,
               bytes_mb, (unsigned long long)g.bundle_files, g.write_s, (double)g.rss_after_render_kb / 1024.0,
               rss_mb);
    const double best = t.total[1] < t.total[0] ? t.total[1] : t.total[0];
    const double best_lean = t.lean[1] < t.lean[0] ? t.lean[1] : t.lean[0];
    printf("SUMMARY %s: %ux%u sun-shadow frame, every stage kept: %.2f s on %d threads (%.2f s on 1); no stage kept: "
           "%.2f s (%.2f s on 1); TRACE %.2fx Embree's time (%.2fx on 1 thread)", label, width, height, t.total[1],
           hw_threads, t.total[0], t.lean[1], t.lean[0], t.stage[1][RTO_STAGE_TRACE] / t.embree[1],
           t.stage[0][RTO_STAGE_TRACE] / t.embree[0]);
    if (!no_golden)
        printf("; golden bundle %.0f MiB, peak RSS %.0f MiB = %.2fx the bytes written", bytes_mb, rss_mb,
               rss_mb / bytes_mb);
    printf("; goals: < 1 s %s (every stage) / %s (none)", best < 1.0 ? "met" : "not met",
           best_lean < 1.0 ? "met" : "not met");
    if (!no_golden)
        printf(", RSS < 2x bytes %s", rss_mb < 2.0 * bytes_mb ? "met" : "not met");
    printf("\n");
    fflush(stdout);
}

/* Milliseconds to touch each 4 KiB page of a fresh 256 MiB block once: what the first write to a new buffer costs on
 * this machine (a frame at 1080p writes about a GiB of new memory). */
static double first_touch_ms_per_gib(void)
{
    const size_t n = (size_t)256 << 20;
    volatile char *p = malloc(n);
    if (!p)
        return 0.0;
    const double t0 = now();
    for (size_t i = 0; i < n; i += 4096)
        p[i] = (char)i;
    const double t = now() - t0;
    free((void *)p);
    return t * 1e3 * 4.0;
}

static uint32_t arg_u32(const char *text, unsigned long lo, unsigned long hi)
{
    char *end;
    unsigned long v = strtoul(text, &end, 10);
    if (*end || v < lo || v > hi) {
        fprintf(stderr, "bench_frame: bad number '%s' (%lu .. %lu)\n", text, lo, hi);
        exit(2);
    }
    return (uint32_t)v;
}

int main(int argc, char **argv)
{
    const char *scenes[8];
    int nscenes = 0;
    bench_init(&argc, argv);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--width") && i + 1 < argc)
            width = arg_u32(argv[++i], 1, 8192);
        else if (!strcmp(argv[i], "--height") && i + 1 < argc)
            height = arg_u32(argv[++i], 1, 8192);
        else if (!strcmp(argv[i], "--no-golden"))
            no_golden = 1;
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = (int)arg_u32(argv[++i], 5, RUNS);
        else if (nscenes < 7)
            scenes[nscenes++] = argv[i];
    }
    scenes[nscenes++] = "rtstress:16";
    cpu_set_t set;
    hw_threads = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
    print_load("before");
    printf("sun-shadow frames at %ux%u, maxDepth 2; median of %d runs; Embree %d.%d.%d (build quality high, not "
           "robust) on the frame's primary + shadow rays; x/emb = time(oracle) / time(Embree with a fresh hit array); "
           "first touch of new memory here: %.0f ms per GiB\n", width, height, runs, RTC_VERSION_MAJOR,
           RTC_VERSION_MINOR, RTC_VERSION_PATCH, first_touch_ms_per_gib());
    printf("%-19s %-7s %8s %8s %7s %7s %8s %8s %7s %8s %8s %8s %8s %6s %6s %6s\n", "scene", "threads", "primary",
           "shadow", "gen", "prep", "trace", "shade", "resolve", "total", "no-keep", "embree", "emb warm", "trace/",
           "frame/", "nokeep");
    printf("%-19s %-7s %8s %8s %7s %7s %8s %8s %7s %8s %8s %8s %8s %6s %6s %6s\n", "", "", "rays", "rays", "ms", "ms",
           "ms", "ms", "ms", "ms", "total ms", "ms", "ms", "emb", "emb", "/emb");
    detail_scenes = json_array();
    for (int i = 0; i < nscenes; i++) {
        const char *base = strrchr(scenes[i], '/');
        bench_scene(scenes[i], base ? base + 1 : scenes[i]);
    }
    print_load("after");
    bench_finish("frame", runs, json_pack("{s:i, s:i, s:o}", "width", width, "height", height, "scenes",
                                          detail_scenes));
    return 0;
}
