/* rtoracle vbuffer: a scene rasterized by the reference visibility pass of seed 004 (DESIGN.md §11) into a bundle:
 * what a GPU harness uploads (the build bundle's files, the geometry, the camera block, base colours) and what its
 * visibility and material passes must write (the G-buffer per sample, the edge mask, the image), with every sample's
 * admissible set. The library rasterizes, classifies and shades; the command chooses and writes. */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static const char vbuffer_usage[] =
    "usage: rtoracle vbuffer SCENE [--width W --height H] [--msaa 1|4] [--material normals|lambert|unlit|LIB.so]\n"
    "                        [--camera scene|auto|N|EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY] [--sun X,Y,Z] [--ambient A]\n"
    "                        [--threshold-normal T] [--threshold-depth T] [--threshold-sample-depth T]\n"
    "                        [--crosscheck] [--threads N] [--force] -o OUTDIR\n\n"
    "SCENE is a .gltf / .glb path or a procedural scene (see rtoracle info --help).\n"
    "The visibility pass: instanced triangles through the camera's view and projection (WebGPU clip space,\n"
    "depth 0..1, test 'less'), WebGPU's standard sample positions, the top-left rule at 8 sub-pixel bits; each\n"
    "sample's admissible set holds every triangle a device with 4 to 8 sub-pixel bits may write there. The\n"
    "material pass: the seed's edge classifier (thresholds below), interior pixels shaded once from sample 0,\n"
    "edge pixels per sample and averaged. DESIGN.md §11 states every rule. --material LIB.so shades with a\n"
    "material plugin: a user's material ported to C (rtoracle.h, \"Material plugins\"; examples/plugin/toon.c).\n"
    "Writes a bundle (atomically): the build bundle's files (rtoracle build --help), the scene's geometry\n"
    "(mesh_M_positions.npy, mesh_M_indices.npy), and\n"
    "  vb_camera.npy              f32 (36,): viewProj, the inverse projection (column-major), the eye, 0\n"
    "  vb_base_colors.npy         f32 (meshes, 4): each mesh's base colour\n"
    "  vb_visibility.npy          u16 (H, W, S, 4): primitive lo, hi, instance lo, hi; background 0xFFFF\n"
    "  vb_barycentric.npy         f16 (H, W, S, 2): (b1, b2) at the pixel centre, perspective-correct\n"
    "  vb_normal.npy              f16 (H, W, S, 4): octahedral face normal, tangent angle 0, handedness 1\n"
    "  vb_derivatives.npy         f16 (H, W, S, 4): dpdxFine (b1, b2), dpdyFine (b1, b2)\n"
    "  vb_depth.npy, vb_depth_unorm24.npy  f32 / u32 (H, W, S): depth, and as depth24plus stores it\n"
    "  vb_admissible_offsets.npy, vb_admissible.npy  each sample's admissible (instance, primitive) pairs\n"
    "  vb_edge_mask.npy           u8 (H, W): the classifier's edge pixels\n"
    "  vb_image.npy               f16 (H, W, 4): the material pass's RGBA16float image\n"
    "  image.png                  the image, clamped to [0, 1], 8 bits\n"
    "  manifest.json              size, samples, material, thresholds, the admissible-set statistics\n"
    "--crosscheck traces a primary ray through every sample position with the reference tracer and compares\n"
    "its closest hit with the sample's admissible set (agree, tie, near/far plane, an edge within 2^-5 pixel,\n"
    "which a rasterizer's snapping may move across the sample, an instance of mask 0, which rays never meet,\n"
    "or unexplained: exit 1).\n"
    "The bytes do not depend on --threads. An OUTDIR that already holds this very bundle is left as it is;\n"
    "--force writes it again.\n";

/* Most samples a bundle holds: 1920 x 1080 x 4 and room beyond (the planes take 36 bytes a sample). */
#define VBUFFER_MAX_SAMPLES (UINT64_C(1) << 25)


/* image.png: the RGBA16float image clamped to [0, 1] and rounded to 8 bits. */
static rto_status add_png(rto_bundle *b, const uint16_t *image, uint32_t w, uint32_t h, rto_msg *msg)
{
    const size_t n = (size_t)w * h * 4;
    uint8_t *px = malloc(n);
    if (!px)
        return rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the image");
    for (size_t k = 0; k < n; k++) {
        const float v = rto_f16_to_f32(image[k]);
        px[k] = (uint8_t)(v > 0.0f ? (v < 1.0f ? v * 255.0f + 0.5f : 255.0f) : 0.0f);
    }
    rto_image im;
    memset(&im, 0, sizeof im);
    im.width = w;
    im.height = h;
    im.channels = 4;
    im.type = RTO_PIXEL_U8;
    im.pixels = px;
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto_bundle_file_name(RTO_FILE_IMAGE, 0, name, sizeof name);
    rto_status s = rto_bundle_add_image(b, name, rto_bundle_file_role(RTO_FILE_IMAGE), &im, msg);
    free(px);
    return s;
}

int cmd_vbuffer(int argc, char **argv)
{
    const char *out = NULL, *camera_arg = NULL, *sun_arg = NULL;
    uint64_t width = 160, height = 120, msaa = 4, threads = 0, budget_mb = 0;
    const char *material_arg = "normals";
    double ambient = 0.15, t_normal = 0.95, t_depth = 0.02, t_sample = 0.02;
    bool force = false, crosscheck = false;
    static const opt_name msaa_values[] = {{"1", 1}, {"4", 4}, {NULL, 0}};
    const opt_spec opts[] = {
        OPT_UINT("width", &width, 1, 16384, "W", "image width", "160"),
        OPT_UINT("height", &height, 1, 16384, "H", "image height", "120"),
        OPT_CHOICE("msaa", &msaa, msaa_values, "S", "samples a pixel (1 or 4)", "4"),
        OPT_STRING("material", &material_arg, "M",
                   "normals, lambert, unlit, or a material plugin (a .so exporting rto_material_entry_v1)"),
        OPT_STRING("camera", &camera_arg, "CAM", "scene, auto, a camera index, or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY"),
        OPT_STRING("sun", &sun_arg, "X,Y,Z", "lambert: direction towards the sun (default 0.3,1,0.2)"),
        OPT_REAL("ambient", &ambient, 1.0, "A", "lambert: the ambient term", "0.15"),
        OPT_REAL("threshold-normal", &t_normal, 1.0, "T", "edge where two normals' dot product is below T", "0.95"),
        OPT_REAL("threshold-depth", &t_depth, 0.0, "T", "edge where neighbours' view depths differ by more than T",
                 "0.02"),
        OPT_REAL("threshold-sample-depth", &t_sample, 0.0, "T", "edge where a pixel's samples' view depths span more",
                 "0.02"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take", "256"),
        OPT_FLAG("crosscheck", &crosscheck, "trace every sample's ray and compare with its admissible set"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"vbuffer", vbuffer_usage,
                             "exit status: 0 written, 1 --crosscheck found a sample it cannot explain, 2 bad usage or "
                             "input\n", opts, 1, 1,
                             "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    if (width * height * msaa > VBUFFER_MAX_SAMPLES)
        return cli_fail("vbuffer", "--width %" PRIu64 " --height %" PRIu64 " --msaa %" PRIu64
                        ": more than %" PRIu64 " samples", width, height, msaa, VBUFFER_MAX_SAMPLES);
    rto_vbuffer_material_desc md;
    memset(&md, 0, sizeof md);
    rto_material_plugin *plugin = NULL;
    if (!rto_vb_material_parse(material_arg, &md.material)) {
        if (!strchr(material_arg, '/') && !strstr(material_arg, ".so"))
            return cli_fail("vbuffer", "--material %s: expected normals, lambert, unlit or a plugin LIB.so",
                            material_arg);
        rto_msg pm = {{0}};
        if (rto_material_plugin_load(material_arg, &plugin, &pm))
            return cli_fail("vbuffer", "--material %s", pm.text);
        md.material = RTO_VB_PLUGIN;
        md.custom = rto_material_plugin_def(plugin);
    }
    md.thresholds = (rto_vb_thresholds){(float)t_normal, (float)t_depth, (float)t_sample};
    md.sun[0] = 0.3f;
    md.sun[1] = 1.0f;
    md.sun[2] = 0.2f;
    md.ambient = (float)ambient;
    if ((sun_arg && !cli_parse_floats(sun_arg, md.sun, 3)) ||
        (md.sun[0] == 0.0f && md.sun[1] == 0.0f && md.sun[2] == 0.0f)) {
        rto_material_plugin_unload(plugin);
        return cli_fail("vbuffer", "--sun %s: expected three numbers X,Y,Z, not all 0", sun_arg);
    }
    static const char *const not_inputs[] = {"output", "force", "threads", "crosscheck", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    if (!crosscheck && cli_up_to_date("vbuffer", out, request, force)) {
        free(request);
        rto_material_plugin_unload(plugin);
        return EXIT_PASS;
    }
    cli_traced_scene ts;
    if ((rc = cli_load_traced_scene("vbuffer", args.arg[0], budget_mb, camera_arg, (uint32_t)width, (uint32_t)height,
                                    0, (uint32_t)threads, &ts))) {
        free(request);
        rto_material_plugin_unload(plugin);
        return rc;
    }
    const rto_scene *sc = ts.scene;
    md.materials = sc->materials;
    md.material_count = sc->material_count;
    md.textures = sc->textures;
    md.texture_count = sc->texture_count;
    const rto_vbuffer_geometry g = {sc->meshes, sc->mesh_count, sc->instances, sc->instance_count};
    const rto_vbuffer_desc vd = {(uint32_t)width, (uint32_t)height, (uint32_t)msaa, (uint32_t)threads};
    rto_msg msg = {{0}};
    rto_vbuffer vb;
    memset(&vb, 0, sizeof vb);
    rto_vbuffer_camera cam;
    uint8_t *mask = cli_alloc(width * height, 1);
    uint16_t *image = cli_alloc(width * height * 4, sizeof *image);
    rto_bundle *b = NULL;
    rto_status s = mask && image ? RTO_OK : rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the image");
    if (!s)
        s = rto_vbuffer_camera_make(&ts.camera, (uint32_t)width, (uint32_t)height, &cam, &msg);
    if (!s)
        s = rto_vbuffer_make(&g, &cam, &vd, &vb, &msg);
    if (!s)
        s = rto_vbuffer_classify(&vb.planes, &vb.camera, &md.thresholds, mask, &msg);
    if (!s)
        s = rto_vbuffer_shade(&vb.planes, mask, &g, &md, image, &msg);
    if (!s)
        s = rto_bundle_begin(out, "vbuffer", &b, &msg);
    if (!s)
        s = cli_set_request(b, request, sc, plugin ? material_arg : NULL, &msg);
    const rto_vbuffer_bundle_desc bd = {ts.accel, &vb, &md, plugin ? md.custom->name : rto_vb_material_name(md.material),
                                        mask, image};
    if (!s)
        s = rto_vbuffer_bundle_write(&bd, b, &msg);
    if (!s)
        s = add_png(b, image, (uint32_t)width, (uint32_t)height, &msg);
    if (!s)
        s = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    if (!s) {
        const rto_vbuffer_stats *st = &vb.stats;
        char sum[64];
        printf("vbuffer %s: %" PRIu64 "x%" PRIu64 " x%" PRIu64 " samples, %" PRIu64 " covered; admissible sets: %" PRIu64
               " certain, %" PRIu64 " with 2 or more answers (largest %" PRIu32 ") -> %s (%s)\n",
               args.arg[0], width, height, msaa, st->covered, st->certain, st->uncertain, st->max_set, out,
               cli_dir_summary(out, sum, sizeof sum));
    }
    rto_vbuffer_crosscheck_result cx;
    if (!s && crosscheck && !(s = rto_vbuffer_crosscheck(&vb, ts.accel, &ts.camera, (uint32_t)threads, &cx, &msg))) {
        printf("crosscheck: %" PRIu64 " samples: %" PRIu64 " agree with the tracer, %" PRIu64 " ties, %" PRIu64
               " on the near or far plane, %" PRIu64 " within snapping of an edge, %" PRIu64
               " on a masked instance, %" PRIu64 " unexplained\n",
               cx.samples, cx.agree, cx.tie, cx.clip_plane, cx.snap, cx.masked, cx.unexplained);
        if (cx.unexplained)
            printf("  first unexplained: pixel (%" PRIu32 ", %" PRIu32 ") sample %" PRIu32 ": %s\n", cx.x, cx.y,
                   cx.sample, cx.first);
    }
    rto_vbuffer_free(&vb);
    free(mask);
    free(image);
    free(request);
    cli_traced_scene_free(&ts);
    rto_material_plugin_unload(plugin);
    if (!s && crosscheck && cx.unexplained)
        return EXIT_MISMATCH;
    return cli_status("vbuffer", s, &msg);
}
