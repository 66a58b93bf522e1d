/* The visibility pass of seed 004 (DESIGN.md §11) at 1920x1080 with 4x MSAA, beside the reference tracer on the same
 * number of primary rays (the scene at 3840x2160, one ray a pixel: a ray per sample of the vbuffer):
 *
 *   - time: rto_vbuffer_make (rasterization at every admissible precision, the planes, the admissible sets) against
 *     rto_trace of those rays, interleaved, median of RUNS runs each, 1 thread and every hardware thread; ratio =
 *     time(vbuffer) / time(trace);
 *   - peak RSS: each of the two made once in a child process of its own (fork), getrusage's ru_maxrss after it,
 *     scene and trees included.
 *
 *   bench_vbuffer [--json] BUNNY.gltf           (and rtstress:16)
 */
#include "bench_util.h"
#include "rtoracle.h"

#include <stdint.h>
#include <sys/resource.h>
#include <sys/wait.h>

enum { W = 1920, H = 1080, S = 4 };

typedef struct loaded {
    rto_scene *scene;
    rto_accel *accel;
    rto_camera camera;
    rto_vbuffer_camera vcam;
} loaded;

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_vbuffer: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

static void load(const char *spec, loaded *l)
{
    rto_msg msg = {{0}};
    memset(l, 0, sizeof *l);
    if (rto_scene_load(spec, &l->scene, &msg) || rto_accel_build(l->scene, NULL, &l->accel, &msg))
        die(spec, &msg);
    const rto_aabb b = rto_scene_aabb(l->scene);
    l->camera = rto_camera_frame(&b, (float)W / (float)H);
    if (rto_vbuffer_camera_make(&l->camera, W, H, &l->vcam, &msg))
        die(spec, &msg);
}

static double vbuffer_once(const loaded *l, uint32_t threads)
{
    rto_msg msg = {{0}};
    const rto_vbuffer_geometry g = {l->scene->meshes, l->scene->mesh_count, l->scene->instances,
                                    l->scene->instance_count};
    const rto_vbuffer_desc d = {W, H, S, threads};
    rto_vbuffer vb;
    const double t0 = now();
    if (rto_vbuffer_make(&g, &l->vcam, &d, &vb, &msg))
        die("vbuffer", &msg);
    const double t = now() - t0;
    rto_vbuffer_free(&vb);
    return t;
}

/* W H S primary rays: the scene at (2W) x (2H), the vbuffer's camera. */
static rto_wf_ray *make_rays(const loaded *l, size_t *n)
{
    rto_msg msg = {{0}};
    rto_rays_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.set = RTO_RAYS_PRIMARY;
    rd.width = 2 * W;
    rd.height = 2 * H;
    rd.camera = &l->camera;
    const size_t cap = rto_rays_capacity(&rd);
    rto_wf_ray *rays = malloc(cap * sizeof *rays);
    rto_camera_uniforms cu;
    if (!rays || rto_rays_generate(l->accel, &rd, rays, cap, n, &cu, &msg))
        die("rays", &msg);
    return rays;
}

static double trace_once(const loaded *l, const rto_wf_ray *rays, size_t n, rto_hit_record *hits, uint32_t threads)
{
    rto_msg msg = {{0}};
    const rto_trace_desc td = {threads};
    const double t0 = now();
    if (rto_trace(l->accel, rays, n, &td, hits, NULL, &msg))
        die("trace", &msg);
    return now() - t0;
}

/* What a peak-RSS child does (bench_child_peak_kib): loads spec and makes the vbuffer (which 0) or traces the rays
 * (1), all threads. */
static void rss_work(const char *spec, int which)
{
    loaded l;
    load(spec, &l);
    if (which == 0) {
        vbuffer_once(&l, 0);
    } else {
        size_t n = 0;
        rto_wf_ray *rays = make_rays(&l, &n);
        rto_hit_record *hits = malloc(n * sizeof *hits);
        if (!hits)
            _exit(1);
        trace_once(&l, rays, n, hits, 0);
    }
}

int main(int argc, char **argv)
{
    const int json = bench_init(&argc, argv);
    (void)json;
    if (argc != 2) {
        fprintf(stderr, "usage: bench_vbuffer [--json] BUNNY.gltf\n");
        return 2;
    }
    const char *scenes[2] = {argv[1], "rtstress:16"};
    const char *names[2] = {"bunny", "rtstress:16"};
    json_t *detail = json_array();
    print_load("before");
    printf("1920x1080, 4x MSAA (8,294,400 samples) against rto_trace of 8,294,400 primary rays (3840x2160);\n"
           "median of %d runs each, interleaved; ratio = vbuffer / trace\n\n", RUNS);
    printf("%-12s %-8s %12s %12s %8s %14s %14s\n", "scene", "threads", "vbuffer ms", "trace ms", "ratio",
           "vbuffer RSS MB", "trace RSS MB");
    for (int s = 0; s < 2; s++) {
        const long rss_vb = bench_child_peak_kib(rss_work, scenes[s], 0),
                   rss_tr = bench_child_peak_kib(rss_work, scenes[s], 1);
        loaded l;
        load(scenes[s], &l);
        size_t n = 0;
        rto_wf_ray *rays = make_rays(&l, &n);
        rto_hit_record *hits = malloc(n * sizeof *hits);
        if (!hits)
            die("hits", NULL);
        double tv[2][RUNS], tt[2][RUNS];
        for (int r = 0; r < RUNS; r++)
            for (int t = 0; t < 2; t++) {
                settle();
                tv[t][r] = vbuffer_once(&l, t == 0 ? 1 : 0);
                settle();
                tt[t][r] = trace_once(&l, rays, n, hits, t == 0 ? 1 : 0);
            }
        for (int t = 0; t < 2; t++) {
            const double mv = median(tv[t]), mt = median(tt[t]);
            printf("%-12s %-8s %12.1f %12.1f %8.2f %14.1f %14.1f\n", names[s], t == 0 ? "1" : "all", mv * 1e3,
                   mt * 1e3, mv / mt, rss_vb / 1024.0, rss_tr / 1024.0);
            bench_row("vbuffer-1080p-4x", names[s], "rto_trace", t == 0 ? 1 : 0, mv, mt);
            json_array_append_new(detail, json_pack("{s:s, s:i, s:f, s:f, s:I, s:I}", "scene", names[s], "threads",
                                                    t == 0 ? 1 : 0, "vbuffer_ms", mv * 1e3, "trace_ms", mt * 1e3,
                                                    "vbuffer_rss_kib", (json_int_t)rss_vb, "trace_rss_kib",
                                                    (json_int_t)rss_tr));
        }
        free(rays);
        free(hits);
        rto_accel_destroy(l.accel);
        rto_scene_destroy(l.scene);
    }
    print_load("after");
    bench_finish("vbuffer", RUNS, detail);
    return 0;
}
