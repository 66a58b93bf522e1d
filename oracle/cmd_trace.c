/* rtoracle trace: a scene's rays traced by the reference (DESIGN.md §6) into a trace bundle: everything a GPU's TRACE
 * kernel reads (instances, trees, mesh geometry, rays, the camera block) and what it must write (one 96-byte hit
 * record per ray), plus per-ray traversal counters and their histograms in the manifest. The library builds the trees
 * (checked like `rtoracle build`), generates or loads the rays and traces them; the command chooses and writes. */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char trace_usage[] =
    "usage: rtoracle trace SCENE [--rays SET|FILE.npy] [--width W --height H] [--count N] [--seed S]\n"
    "                      [--camera scene|auto|N|EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY] [--light X,Y,Z]\n"
    "                      [--tlas sweep|karras] [--threads N] [--force] -o OUTDIR\n\n"
    "SCENE is a .gltf / .glb path or a procedural scene (see rtoracle info --help).\n"
    "Ray sets: primary (one camera ray per pixel), shadow (from each primary hit towards a distant light),\n"
    "random (inside the scene bounds), grazing (aimed at triangle edges and vertices), axis (axis-parallel and\n"
    "zero-component directions); or a .npy file of WfRay records (structured, (n, 16) words or flat).\n"
    "Camera: scene = the scene's first camera, else an automatic framing (the default); auto = the framing;\n"
    "N = the scene's camera N; or eye, target, up and the vertical field of view in degrees.\n"
    "Writes a bundle (atomically): the build bundle's files (rtoracle build --help), and\n"
    "  mesh_M_positions.npy     f32 (vertices, 3), mesh_M_indices.npy: u32 (triangles, 3), per mesh M\n"
    "  rays.npy                 WfRay records traced\n"
    "  hits.npy                 HitRecord, one per ray (96 bytes: t, instanceId, primId, hitGroup, bary,\n"
    "                           customIndex, missFlag, objToWorld as column-major mat4x3)\n"
    "  counters.npy             TraceCounters, one per ray: nodesVisited, boxTests, triangleTests,\n"
    "                           instanceEntries\n"
    "  camera.npy               CameraUniforms (144 bytes) for camera rays\n"
    "  manifest.json            ray set, camera, hit and miss counts, counter statistics and histograms\n"
    "The bytes do not depend on --threads.\n"
    "An OUTDIR that already holds this very bundle (same inputs, options and rtoracle build, no file changed\n"
    "since) is left as it is, in one line; --force writes it again.\n";

static const opt_name tlas_names[] = {{"sweep", 0}, {"karras", 1}, {NULL, 0}};

/* Most rays a command makes or reads: width * height or --count. */
#define TRACE_MAX_RAYS (UINT64_C(1) << 26)

int cmd_trace(int argc, char **argv)
{
    const char *out = NULL, *rays_arg = "primary", *camera_arg = NULL, *light_arg = NULL;
    uint64_t width = 160, height = 120, count = 4096, seed = 1, threads = 0, budget_mb = 0;
    unsigned karras = 0;
    bool force = false;
    const opt_spec opts[] = {
        OPT_STRING("rays", &rays_arg, "SET", "primary, shadow, random, grazing, axis, or a WfRay .npy file"),
        OPT_UINT("width", &width, 1, 65536, "W", "image width (primary, shadow)", "160"),
        OPT_UINT("height", &height, 1, 65536, "H", "image height (primary, shadow)", "120"),
        OPT_UINT("count", &count, 1, TRACE_MAX_RAYS, "N", "rays of a random, grazing or axis set", "4096"),
        OPT_UINT("seed", &seed, 0, CLI_SEED_MAX, "S", "seed of the generated set", "1"),
        OPT_STRING("camera", &camera_arg, "CAM", "scene, auto, a camera index, or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY"),
        OPT_STRING("light", &light_arg, "X,Y,Z", "direction towards the light of shadow rays (default 0.3,1,0.2)"),
        OPT_ENUM("tlas", &karras, tlas_names, "T", "TLAS layout", "sweep"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take", "256"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"trace", trace_usage, "exit status: 0 written, 2 bad usage or input\n", opts, 1, 1,
                             "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    if ((uint64_t)width * height > TRACE_MAX_RAYS)
        return cli_fail("trace", "--width %llu --height %llu: more than %llu rays", (unsigned long long)width,
                        (unsigned long long)height, (unsigned long long)TRACE_MAX_RAYS);
    rto_ray_set set = RTO_RAYS_PRIMARY;
    const bool from_file = !rto_ray_set_parse(rays_arg, &set);
    if (from_file && !strstr(rays_arg, ".npy"))
        return cli_fail("trace", "--rays %s: expected primary, shadow, random, grazing, axis or a .npy ray file",
                        rays_arg);
    float light[3] = {0, 0, 0};
    if (light_arg && !cli_parse_floats(light_arg, light, 3))
        return cli_fail("trace", "--light %s: expected three numbers X,Y,Z", light_arg);
    static const char *const not_inputs[] = {"output", "force", "threads", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (cli_up_to_date("trace", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }

    cli_traced_scene ts;
    if ((rc = cli_load_traced_scene("trace", args.arg[0], budget_mb, camera_arg, (uint32_t)width, (uint32_t)height,
                                    karras, (uint32_t)threads, &ts))) {
        free(request);
        return rc;
    }
    const rto_scene *sc = ts.scene;
    const rto_accel *acc = ts.accel;
    const rto_camera cam = ts.camera;
    rto_msg msg = {{0}};
    rto_status s = RTO_OK;
    rto_wf_ray *rays = NULL;
    rto_hit_record *hits = NULL;
    rto_trace_counters *counters = NULL;
    rto_bundle *b = NULL;
    rto_camera_uniforms cu;
    memset(&cu, 0, sizeof cu);
    size_t n = 0;
    rto_rays_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.set = set;
    rd.seed = (uint32_t)seed;
    rd.width = (uint32_t)width;
    rd.height = (uint32_t)height;
    rd.camera = &cam;
    rd.count = (size_t)count;
    memcpy(rd.light_dir, light, sizeof light);
    rd.threads = (uint32_t)threads;
    if (!s && from_file) {
        s = rto_rays_read(rays_arg, TRACE_MAX_RAYS, &rays, &n, &msg);
    } else if (!s) {
        const size_t cap = rto_rays_capacity(&rd);
        rays = cli_alloc(cap, sizeof *rays);
        s = rays ? rto_rays_generate(acc, &rd, rays, cap, &n, &cu, &msg)
                 : rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", cap);
    }
    if (!s) {
        hits = cli_alloc(n, sizeof *hits);
        counters = cli_alloc(n, sizeof *counters);
        if (!hits || !counters)
            s = rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu hit records", n);
    }
    const rto_trace_desc td = {(uint32_t)threads};
    if (!s) {
        s = rto_trace(acc, rays, n, &td, hits, counters, &msg);
        /* A ray the tracer refuses came from the user's file: name it ("ray 4 has a non-finite origin" alone does not
         * say which file). */
        if (s && from_file)
            rto_msg_set(&msg, s, "%s: %s", rays_arg, msg.text);
    }
    if (!s)
        s = rto_bundle_begin(out, "trace", &b, &msg);
    if (!s)
        s = cli_set_request(b, request, sc, from_file ? rays_arg : NULL, &msg);
    const bool camera_rays = !from_file && (set == RTO_RAYS_PRIMARY || set == RTO_RAYS_SHADOW);
    char light_text[96];
    snprintf(light_text, sizeof light_text, "%.9g,%.9g,%.9g", (double)light[0], (double)light[1], (double)light[2]);
    const rto_trace_bundle_desc tbd = {acc, rays, n, hits, counters, from_file ? rays_arg : rto_ray_set_name(set),
                                       !from_file, (uint32_t)seed, camera_rays ? &cam : NULL, &cu,
                                       (uint32_t)width, (uint32_t)height,
                                       !from_file && set == RTO_RAYS_SHADOW ? (light_arg ? light_text : "default") : NULL};
    if (!s)
        s = rto_trace_bundle_write(&tbd, b, &msg);
    if (!s)
        s = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    if (!s) {
        char sum[64];
        printf("trace %s: %zu rays -> %s (%s)\n", args.arg[0], n, out, cli_dir_summary(out, sum, sizeof sum));
    }
    free(rays);
    free(hits);
    free(counters);
    free(request);
    cli_traced_scene_free(&ts);
    return cli_status("trace", s, &msg);
}
