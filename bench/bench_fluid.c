/* Seed 003's fluid volume and raymarch (DESIGN.md §12):
 *
 *   - splat: rto_splat_make of dambreak:100000 and dambreak:1000000 at 150^3 voxels (h = 0.05, the seed's occupancy
 *     32), median of N runs (default 5), 1 thread and every hardware thread;
 *   - raymarch: a 1920x1080 image of the 1M-particle volume, without skipping and with it (the skip_only pass: only
 *     the skipping march, as a skipping GPU runs it), envelope off (rm_certain / rm_tolerance are not needed to time
 *     the march; the admissible-crossing march of every pixel is included), median of N runs, 1 thread and all;
 *     mean primary-march steps per pixel of each;
 *   - peak RSS: each made once in a child process of its own (fork), getrusage's ru_maxrss after it.
 *
 *   bench_fluid [--json] [--runs N] [--quick]     (--quick: 10x fewer particles, 960x540, for a smoke run)
 */
#include "bench_util.h"
#include "rtoracle.h"

#include <stdint.h>
#include <sys/resource.h>
#include <sys/wait.h>

static int runs = 5;
static uint32_t W = 1920, H = 1080;

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_fluid: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

static double median_n(double *t, int n)
{
    qsort(t, (size_t)n, sizeof *t, cmp_double);
    return t[n / 2];
}

static void params_150(rto_fluid_params *fp)
{
    rto_fluid_params_default(fp);
    fp->res[0] = fp->res[1] = fp->res[2] = 150;
}

static float *particles(const char *spec, uint64_t *n)
{
    rto_fluid_params fp;
    params_150(&fp);
    float *pos = NULL;
    rto_msg msg = {{0}};
    if (rto_fluid_generate(spec, &fp, &pos, n, &msg))
        die(spec, &msg);
    return pos;
}

static double splat_once(const float *pos, uint64_t n, uint32_t threads, rto_splat *keep)
{
    rto_fluid_params fp;
    params_150(&fp);
    rto_splat s;
    rto_msg msg = {{0}};
    const double t0 = now();
    if (rto_splat_make(&fp, pos, n, threads, &s, &msg))
        die("splat", &msg);
    const double t = now() - t0;
    if (keep)
        *keep = s;
    else
        rto_splat_free(&s);
    return t;
}

static double march_once(const rto_splat *s, int skip, uint32_t threads, double *steps_mean)
{
    rto_raymarch_params p;
    rto_raymarch_params_default(s, &p);
    p.width = W;
    p.height = H;
    p.camera = rto_camera_frame(&s->params.bounds, (float)W / (float)H);
    p.envelope = 0;
    p.skip = skip;
    p.skip_only = skip;
    p.threads = threads;
    rto_raymarch r;
    rto_msg msg = {{0}};
    const double t0 = now();
    if (rto_raymarch_make(s, &p, &r, &msg))
        die("raymarch", &msg);
    const double t = now() - t0;
    if (steps_mean)
        *steps_mean = (double)r.stats.steps_total / (double)r.stats.pixels;
    rto_raymarch_free(&r);
    return t;
}

/* What a peak-RSS child does (bench_child_peak_kib): splats spec (which 0) or splats it and marches (1: without
 * skipping, 2: with). */
static void rss_work(const char *spec, int which)
{
    uint64_t n = 0;
    float *pos = particles(spec, &n);
    rto_splat s;
    splat_once(pos, n, 0, &s);
    free(pos);
    if (which)
        march_once(&s, which == 2, 0, NULL);
    rto_splat_free(&s);
}

int main(int argc, char **argv)
{
    bench_init(&argc, argv);
    int quick = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick"))
            quick = 1;
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc && atoi(argv[i + 1]) >= 1 && atoi(argv[i + 1]) <= 99)
            runs = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: bench_fluid [--json] [--runs N] [--quick]\n");
            return 2;
        }
    }
    const char *specs[2] = {"dambreak:100000", "dambreak:1000000"};
    if (quick) {
        specs[0] = "dambreak:10000";
        specs[1] = "dambreak:100000";
        W = 960;
        H = 540;
    }
    double *t = malloc((size_t)runs * sizeof *t);
    if (!t)
        die("out of memory", NULL);
    json_t *detail = json_array();
    print_load("before");
    printf("splat at 150^3 voxels (h 0.05, occupancy 32): median of %d runs\n\n", runs);
    printf("%-18s %-8s %12s %14s\n", "particles", "threads", "splat ms", "peak RSS MB");
    for (int s = 0; s < 2; s++) {
        uint64_t n = 0;
        float *pos = particles(specs[s], &n);
        const long rss = bench_child_peak_kib(rss_work, specs[s], 0);
        for (int th = 0; th < 2; th++) {
            for (int r = 0; r < runs; r++)
                t[r] = splat_once(pos, n, th == 0 ? 1 : 0, NULL);
            const double m = median_n(t, runs);
            printf("%-18s %-8s %12.1f %14.1f\n", specs[s], th == 0 ? "1" : "all", m * 1e3, rss / 1024.0);
            json_array_append_new(detail, json_pack("{s:s, s:s, s:i, s:f, s:I}", "stage", "splat", "case", specs[s],
                                                    "threads", th == 0 ? 1 : 0, "ms", m * 1e3, "rss_kib",
                                                    (json_int_t)rss));
        }
        free(pos);
    }
    printf("\nraymarch %ux%u of %s (envelope off): median of %d runs\n\n", W, H, specs[1], runs);
    printf("%-10s %-8s %12s %14s %14s\n", "skipping", "threads", "march ms", "steps/pixel", "peak RSS MB");
    {
        uint64_t n = 0;
        float *pos = particles(specs[1], &n);
        rto_splat s;
        splat_once(pos, n, 0, &s);
        free(pos);
        for (int skip = 0; skip < 2; skip++) {
            const long rss = bench_child_peak_kib(rss_work, specs[1], 1 + skip);
            for (int th = 0; th < 2; th++) {
                double steps = 0;
                for (int r = 0; r < runs; r++)
                    t[r] = march_once(&s, skip, th == 0 ? 1 : 0, &steps);
                const double m = median_n(t, runs);
                printf("%-10s %-8s %12.1f %14.2f %14.1f\n", skip ? "on" : "off", th == 0 ? "1" : "all", m * 1e3,
                       steps, rss / 1024.0);
                json_array_append_new(detail, json_pack("{s:s, s:i, s:i, s:f, s:f, s:I}", "stage", "raymarch", "skip",
                                                        skip, "threads", th == 0 ? 1 : 0, "ms", m * 1e3,
                                                        "steps_per_pixel", steps, "rss_kib", (json_int_t)rss));
            }
        }
        rto_splat_free(&s);
    }
    print_load("after");
    free(t);
    bench_finish("fluid", runs, detail);
    return 0;
}
