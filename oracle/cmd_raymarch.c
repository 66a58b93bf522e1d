/* rtoracle raymarch: the reference raymarch of seed 003 (DESIGN.md §12.4-§12.5.1) over a splat bundle's volume, with
 * and without empty-space skipping (verified identical on every run), into a bundle a GPU harness runs alone. */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static const char raymarch_usage[] =
    "usage: rtoracle raymarch SPLATDIR [--width W --height H] [--camera auto|EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY]\n"
    "                         [--step S] [--light-step S] [--offset D] [--multiplier M] [--refractions N]\n"
    "                         [--seed N] [--jitter J] [--no-skip] [--no-envelope] [--threads N] [--force] -o OUTDIR\n\n"
    "SPLATDIR is a splat bundle (rtoracle splat) or a raymarch bundle: its fluid_params.npy, volume_f16.npy and\n"
    "occupancy.npy are read. The march (DESIGN.md §12.4): fixed steps t_k = max(t0, 0) + jitter + k * step from\n"
    "the pixel's Stage-2 camera ray, trilinear density minus the offset, central-difference normals (forward ones\n"
    "written beside them), shadow transmittance towards the sun, up to N refraction bounces, a checkered floor and\n"
    "a sky. The march is run twice, without and with empty-space skipping over the occupancy grid (offset > 0);\n"
    "the two must give the same image bytes and crossings, or the command exits 1. The envelope (§12.5.1) marks the\n"
    "pixels whose every decision is certain and their image tolerance. Writes a bundle (atomically): rm_params.npy,\n"
    "rm_image.npy, image.png, rm_crossing.npy, rm_crossing_t.npy, rm_normal_central.npy, rm_normal_forward.npy,\n"
    "rm_steps.npy, rm_steps_skip.npy, rm_certain.npy, rm_tolerance.npy, rm_image_wall.npy,\n"
    "rm_tolerance_wall.npy (a wall event's other admissible outcome), fluid_params.npy, volume_f16.npy,\n"
    "occupancy.npy and manifest.json (steps with and without skipping, the reduction, differing pixels).\n";

int cmd_raymarch(int argc, char **argv)
{
    const char *out = NULL, *camera_arg = NULL;
    uint64_t width = 160, height = 120, threads = 0, refractions = 4, seed = 3;
    double step = 0, light_step = 0, offset = 100, multiplier = 0.01, jitter = 0.4;
    bool force = false, no_skip = false, no_envelope = false;
    const opt_spec opts[] = {
        OPT_UINT("width", &width, 1, 4096, "W", "image width", "160"),
        OPT_UINT("height", &height, 1, 4096, "H", "image height", "120"),
        OPT_STRING("camera", &camera_arg, "CAM", "auto (framing the bounds) or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY"),
        OPT_REAL("step", &step, 1000000, "S", "primary march step (0: half the smallest voxel)", "0"),
        OPT_REAL("light-step", &light_step, 1000000, "S", "light step; the shadow march steps twice it (0: 2 voxels)",
                 "0"),
        OPT_REAL("offset", &offset, 0, "D", "density offset (skipping needs > 0)", "100"),
        OPT_REAL("multiplier", &multiplier, 0, "M", "density multiplier (> 0)", "0.01"),
        OPT_UINT("refractions", &refractions, 0, 16, "N", "refraction bounces", "4"),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "N", "jitter seed", "3"),
        OPT_REAL("jitter", &jitter, 1.0, "J", "jitter as a fraction of the step (the seed's 0.4)", "0.4"),
        OPT_FLAG("no-skip", &no_skip, "no empty-space skipping pass"),
        OPT_FLAG("no-envelope", &no_envelope, "no envelope: rm_certain 0, rm_tolerance inf (faster)"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"raymarch", raymarch_usage,
                             "exit status: 0 written, 1 the skipping pass differs from the plain one, 2 bad usage or "
                             "input\n", opts, 1, 1, "one SPLATDIR"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    /* About 80 bytes a pixel of arrays: at most 2^22 pixels (4 Mpixel, ~340 MB). */
    if (width * height > (UINT64_C(1) << 22))
        return cli_fail("raymarch", "--width %" PRIu64 " --height %" PRIu64 ": more than 2^22 pixels", width, height);
    if (!(multiplier > 0))
        return cli_fail("raymarch", "--multiplier must be > 0");
    static const char *const not_inputs[] = {"output", "force", "threads", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("raymarch", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }
    rto_msg msg = {{0}};
    rto_splat vol;
    rto_status s = rto_raymarch_volume_load(args.arg[0], &vol, &msg);
    if (s) {
        free(request);
        return cli_status("raymarch", s, &msg);
    }
    rto_raymarch_params p;
    rto_raymarch_params_default(&vol, &p);
    p.width = (uint32_t)width;
    p.height = (uint32_t)height;
    p.camera = rto_camera_frame(&vol.params.bounds, (float)width / (float)height);
    if (camera_arg && strcmp(camera_arg, "auto") && !cli_camera_numbers(camera_arg, &p.camera)) {
        rto_splat_free(&vol);
        free(request);
        return cli_fail("raymarch", "--camera %s: expected auto or 10 numbers EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY",
                        camera_arg);
    }
    if (step > 0)
        p.step_size = (float)step;
    if (light_step > 0)
        p.light_step_size = (float)light_step;
    /* A step so small that one march of 512 samples covers less than a voxel is allowed; one whose samples would
     * not advance t in binary32 is not. */
    if (!(p.step_size >= 1e-6f) || !(p.light_step_size >= 1e-6f)) {
        rto_splat_free(&vol);
        free(request);
        return cli_fail("raymarch", "--step and --light-step must be at least 1e-6");
    }
    p.density_offset = (float)offset;
    p.density_multiplier = (float)multiplier;
    p.num_refractions = (uint32_t)refractions;
    p.jitter_seed = (uint32_t)seed;
    p.jitter_scale = (float)jitter;
    p.skip = !no_skip;
    p.envelope = !no_envelope;
    p.threads = (uint32_t)threads;
    rto_raymarch r;
    const double t0 = cli_now();
    s = rto_raymarch_make(&vol, &p, &r, &msg);
    const double secs = cli_now() - t0;
    if (!s)
        s = rto_raymarch_bundle_write(out, /* a skipping pass that differs is not recorded as up to date */
                                      r.stats.differing_pixels || r.stats.differing_crossings ? NULL : request,
                                      args.arg[0], &vol, &r, &msg);
    int status = cli_status("raymarch", s, &msg);
    if (!s) {
        const rto_raymarch_stats *st = &r.stats;
        char sum[64];
        const double np = (double)st->pixels;
        printf("raymarch %s: %" PRIu64 "x%" PRIu64 ", %" PRIu64 " crossings, steps per pixel %.2f (max %u) without "
               "skipping, %.2f (max %u) with (%s); %" PRIu64 " differing pixels, %" PRIu64 " differing crossings; %"
               PRIu64 " certain (%" PRIu64 " with a wall event's other outcome), %" PRIu64 " uncertain; normals "
               "central vs forward %.2f deg mean, %.2f max; %.2f s -> %s (%s)\n",
               args.arg[0], width, height, st->crossings, (double)st->steps_total / np, st->steps_max,
               (double)st->steps_skip_total / np, st->steps_skip_max, st->skip_enabled ? "skipping on" : "skipping off",
               st->differing_pixels, st->differing_crossings, st->certain, st->wall_pixels, st->uncertain,
               st->normal_angle_mean, st->normal_angle_max, secs, out, cli_dir_summary(out, sum, sizeof sum));
        if (st->differing_pixels || st->differing_crossings) {
            fprintf(stderr, "rtoracle raymarch: empty-space skipping changed %" PRIu64 " pixels and %" PRIu64
                    " crossings\n", st->differing_pixels, st->differing_crossings);
            status = EXIT_MISMATCH;
        }
    }
    rto_raymarch_free(&r);
    rto_splat_free(&vol);
    free(request);
    return status;
}
