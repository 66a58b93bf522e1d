/* rtoracle render: one wavefront frame (DESIGN.md §7) of a scene and a program into a frame bundle: what every GPU
 * buffer of the frame should hold, bounce by bounce, and the image it should produce. */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const char render_usage[] =
    "usage: rtoracle render SCENE --program NAME|PLUGIN.so [--width W --height H] [--max-depth D]\n"
    "                       [--camera scene|auto|N|EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY] [--param NAME=V[,V..][:NAME=..]]\n"
    "                       [--stages LIST] [--tlas sweep|karras] [--threads N] [--memory-budget MiB]\n"
    "                       [--timings] -o OUTDIR\n\n"
    "SCENE is a .gltf / .glb path, a procedural scene (see rtoracle info --help), or stage2 (seed 002's two\n"
    "spheres, box and ground slab, traced analytically with the seed's own intersection code).\n"
    "Programs: triangle (barycentric colours), sun-shadow (ambient + a shadow ray towards the sun, Reinhard and\n"
    "gamma), normals (n * 0.5 + 0.5 and the sky gradient), or a plugin: a shared library exporting\n"
    "rto_program_entry_v1 (see docs/frame.md). --program list prints each program's parameters.\n"
    "Stages kept (--stages, comma-separated): rays, hits, trace-counters, payloads (per bounce), accum,\n"
    "accum-exr; or lean (the default: accum), all, none. The camera, counters, indirect args, image and\n"
    "not-comparable mask are always written: the lean golden is what a GPU harness compares of a frame.\n"
    "Writes a bundle (atomically): for mesh scenes the build bundle's files and mesh geometry, and\n"
    "  camera.npy                 CameraUniforms (144 bytes)\n"
    "  emit_counts.npy            u32 (D+1,): each queue's emit counter\n"
    "  indirect_args.npy          u32 (D+1, 3): PREP's [ceil(n/64), 1, 1]\n"
    "  frame_counters.npy         FrameCounters (D+1,): emitted, queued, dropped, refused, traced, hits,\n"
    "                             misses, shaded, accumulates, conflicts\n"
    "  bounce_D_rays.npy          WfRay: the queue traced at bounce D (and the last, untraced queue)\n"
    "  bounce_D_hits.npy          HitRecord, one per ray; bounce_D_trace_counters.npy TraceCounters\n"
    "  bounce_D_payloads.npy      u32 (rays, payload words)\n"
    "  accum.npy                  the linear accum buffer, f32 RGBA (H, W, 4); accum.exr the same as OpenEXR\n"
    "  image.png                  the resolved rgba8unorm image\n"
    "  not_comparable.npy         u8 (H, W): 1 = accumulate conflict, 2 = a ray dropped at capacity\n"
    "  manifest.json              scene, program and parameters, camera, counters (and with --timings the\n"
    "                             per-stage wall times)\n"
    "The bundle is byte-identical across runs and --threads; --timings adds wall-clock times, which are not.\n"
    "Memory: a frame may hold its queues at their capacity of 2 W H rays (64 bytes each, plus the payload) and\n"
    "every kept stage; the bound (DESIGN.md §7) is checked before the scene is loaded, and a frame over the budget\n"
    "(--memory-budget; default half the memory this process may use) is refused at once.\n"
    "An OUTDIR that already holds this very bundle (same inputs, options and rtoracle build, no file changed\n"
    "since) is left as it is, in one line; --force writes it again.\n";

/* Most pixels of a frame (the library's limit): 2^26. */
#define RENDER_MAX_PIXELS (UINT64_C(1) << 26)

static const opt_name tlas_names[] = {{"sweep", 0}, {"karras", 1}, {NULL, 0}};

int cmd_render(int argc, char **argv)
{
    const char *out = NULL, *program_arg = NULL, *camera_arg = NULL, *param_arg = NULL, *stages_arg = "lean";
    uint64_t width = 160, height = 90, depth = 0, threads = 0, budget_mb = 0, memory_mb = 0;
    unsigned karras = 0;
    bool timings = false, no_timings = false, force = false;
    const opt_spec opts[] = {
        OPT_STRING("program", &program_arg, "NAME", "triangle, sun-shadow, normals, a plugin .so, or list"),
        OPT_UINT("width", &width, 1, 65536, "W", "image width", "160"),
        OPT_UINT("height", &height, 1, 65536, "H", "image height", "90"),
        OPT_UINT("max-depth", &depth, 0, 64, "D", "bounces (0: the program's default)", "0"),
        OPT_STRING("camera", &camera_arg, "CAM", "scene, auto, a camera index, or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY"),
        OPT_STRING("param", &param_arg, "P", "program parameters NAME=V[,V..], several separated by ':'"),
        OPT_STRING("stages", &stages_arg, "LIST", "buffers to write: rays,hits,trace-counters,payloads,accum,"
                                                  "accum-exr, lean (default), all or none"),
        OPT_ENUM("tlas", &karras, tlas_names, "T", "TLAS layout", "sweep"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take", "256"),
        OPT_UINT("memory-budget", &memory_mb, 0, CLI_MEMORY_BUDGET_MAX_MB, "MiB", CLI_MEMORY_BUDGET_HELP, "0"),
        OPT_FLAG("timings", &timings, "put the per-stage wall times in the manifest (the bundle then differs run to run)"),
        OPT_FLAG("no-timings", &no_timings, "the default: no wall times (accepted for scripts written before)"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"render", render_usage, "exit status: 0 written, 2 bad usage or input\n", opts, 0, 1,
                             "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    if (program_arg && !strcmp(program_arg, "list")) {
        cli_list_programs();
        return EXIT_PASS;
    }
    static const char *const required[] = {"program", "output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    if (args.count != 1)
        return cli_fail("render", "expected one SCENE (rtoracle render --help)");
    if (width * height > RENDER_MAX_PIXELS)
        return cli_fail("render", "--width %llu --height %llu: more than %llu pixels", (unsigned long long)width,
                        (unsigned long long)height, (unsigned long long)RENDER_MAX_PIXELS);
    rto_msg msg = {{0}};
    uint32_t keep = 0;
    if (!rto_frame_keep_parse(stages_arg, &keep, &msg))
        return cli_fail("render", "--stages %s: %s", stages_arg, msg.text);
    rto_param_value params[RTO_PROGRAM_PARAMS_MAX];
    uint32_t nparams = 0;
    if (param_arg && !cli_parse_params(param_arg, params, &nparams))
        return EXIT_BAD_INPUT;
    const bool is_plugin =
        !rto_program_builtin(program_arg) && (strchr(program_arg, '/') || strstr(program_arg, ".so"));
    static const char *const not_inputs[] = {"output", "force", "threads", "memory-budget", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("render", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }

    rto_plugin *plugin = NULL;
    const rto_program *prog = cli_pick_program(program_arg, is_plugin, &plugin);
    if (!prog) {
        free(request);
        return EXIT_BAD_INPUT;
    }

    /* the frame's memory from its size, depth, payload and stages alone: refused before the scene is loaded */
    rto_frame_desc fd;
    memset(&fd, 0, sizeof fd);
    fd.program = prog;
    fd.width = (uint32_t)width;
    fd.height = (uint32_t)height;
    fd.max_depth = (uint32_t)depth;
    fd.keep = keep;
    if (!cli_frame_within_budget(&fd, memory_mb, stages_arg)) {
        rto_plugin_unload(plugin);
        free(request);
        return EXIT_BAD_INPUT;
    }

    const char *spec = args.arg[0];
    const bool stage2 = !strcmp(spec, "stage2");
    cli_traced_scene ts;
    memset(&ts, 0, sizeof ts);
    rto_status s = RTO_OK;
    if (!stage2 && (rc = cli_load_traced_scene("render", spec, budget_mb, camera_arg, (uint32_t)width,
                                               (uint32_t)height, karras, (uint32_t)threads, &ts))) {
        rto_plugin_unload(plugin);
        free(request);
        return rc;
    }
    rto_camera cam = ts.camera;
    if (stage2 && (rc = cli_stage2_camera("render", camera_arg, &cam))) {
        rto_plugin_unload(plugin);
        free(request);
        return rc;
    }

    cli_progress_bar bar = {isatty(STDERR_FILENO) == 1, 0, 0};
    fd.scene_kind = stage2 ? RTO_FRAME_SCENE_STAGE2 : RTO_FRAME_SCENE_MESH;
    fd.accel = ts.accel;
    fd.camera = &cam;
    fd.params = params;
    fd.param_count = nparams;
    fd.threads = (uint32_t)threads;
    fd.progress = cli_progress;
    fd.progress_arg = &bar;
    rto_frame *frame = NULL;
    const double t0 = cli_now();
    if (!s)
        s = rto_frame_render(&fd, &frame, &msg);
    if (bar.drawn)
        fputc('\n', stderr);
    if (!s)
        s = cli_frame_bundle(out, request, stage2 ? NULL : &ts, is_plugin ? program_arg : NULL, frame,
                             timings && !no_timings, &msg);
    if (!s)
        cli_frame_summary(spec, frame, cli_now() - t0, out);
    rto_frame_destroy(frame);
    cli_traced_scene_free(&ts);
    rto_plugin_unload(plugin);
    free(request);
    return cli_status("render", s, &msg);
}
