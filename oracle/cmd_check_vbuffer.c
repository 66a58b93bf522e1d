/* rtoracle check-vbuffer: validates a GPU's visibility buffer (the G-buffer planes its visibility pass wrote, and the
 * edge mask and image of its material pass) against a vbuffer bundle by DESIGN.md §11.6: each sample's ID within its
 * admissible set, the attributes within the intervals the admissible choices give for the triangle the GPU chose, the
 * mask against the classifier on the GPU's own planes, the image against the material pass on the GPU's own planes
 * and mask. The bundle is checked like a GPU dump first and must be what this rtoracle computes for its scene and
 * camera (a hand-edited plane is refused, never trusted). */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char check_vbuffer_usage[] =
    "usage: rtoracle check-vbuffer --expected OUTDIR --gpu DUMPDIR [--f16-rounding any|nearest] [--json]\n"
    "                              [--material LIB.so] [--no-artifacts] [--threads N]\n\n"
    "Compares what a GPU's visibility and material passes wrote (DUMPDIR) with the vbuffer bundle written by\n"
    "`rtoracle vbuffer`. DUMPDIR holds the bundle's file names, each optional but vb_visibility.npy:\n"
    "  vb_visibility.npy   u16 or u32 (H, W, S, 4)     vb_barycentric.npy  f16 or u16 (H, W, S, 2)\n"
    "  vb_normal.npy       f16 or u16 (H, W, S, 4)     vb_derivatives.npy  f16 or u16 (H, W, S, 4)\n"
    "  vb_depth.npy        f32 (H, W, S)               vb_edge_mask.npy    u8 or u32 (H, W), 0 or 1\n"
    "  vb_image.npy        f16 or u16 (H, W, 4)\n"
    "(f16 planes as their bit patterns are fine; any array may also be flat). Rules (DESIGN.md §11.6): a\n"
    "sample's triangle must be in its admissible set (every triangle a device with 4 to 8 sub-pixel bits may\n"
    "write there; exact where the set has one member); its barycentrics, derivatives and depth within the\n"
    "intervals those choices give for the triangle the GPU chose, rounded outward to binary16; depth as binary32\n"
    "or as unorm24; the normal within 2 binary16 ulps of that triangle's face normal. Over whole planes: a constant\n"
    "depth offset, and with --f16-rounding nearest binary16 rounded toward zero (Vulkan leaves the rounding of\n"
    "float conversions to the device, so by default either is accepted). The edge mask must equal the classifier\n"
    "run on the GPU's own planes (a pixel within 2^-10 of a threshold may go either way); the image the material\n"
    "pass run on the GPU's planes and mask, within 2 binary16 ulps + 2^-12. A bundle written with a material\n"
    "plugin needs the same plugin (--material LIB.so, its name checked) to shade the GPU's planes.\n";

static const char check_vbuffer_epilog[] =
    "Fault classes, in the order they are reported: coverage, id, barycentric, normal, derivative, depth,\n"
    "f16-rounding, edge-mask, shading. Exit status: 0 valid, 1 a fault was found, 2 bad usage or input\n"
    "(including a bundle that is not what this rtoracle computes for its scene and camera).\n";

enum { P_VIS, P_BARY, P_NORMAL, P_DERIV, P_DEPTH, P_MASK, P_IMAGE, P_N };
static const struct {
    rto_bundle_file file;
    const char *plane;
    uint32_t channels; /* per sample (per pixel for the mask and image) */
    int per_pixel, f32;
} planes[P_N] = {
    [P_VIS] = {RTO_FILE_VB_VISIBILITY, "visibility", 4, 0, 0},
    [P_BARY] = {RTO_FILE_VB_BARYCENTRIC, "barycentric", 2, 0, 0},
    [P_NORMAL] = {RTO_FILE_VB_NORMAL, "normal", 4, 0, 0},
    [P_DERIV] = {RTO_FILE_VB_DERIVATIVES, "derivatives", 4, 0, 0},
    [P_DEPTH] = {RTO_FILE_VB_DEPTH, "depth", 1, 0, 1},
    [P_MASK] = {RTO_FILE_VB_EDGE_MASK, "edge-mask", 1, 1, 0},
    [P_IMAGE] = {RTO_FILE_VB_IMAGE, "image", 4, 1, 0},
};

/* Reads plane k of the dump into out (16-bit words, or floats for depth, or bytes for the mask): the dtypes the usage
 * lists, shaped as the bundle's plane or flat. Returns 0 when the file is absent, 1 when read, -1 after one line. */
static int load_plane(const char *dir, int k, uint32_t w, uint32_t h, uint32_t s, void **out)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX], path[4096];
    rto_bundle_file_name(planes[k].file, 0, name, sizeof name);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (access(path, F_OK) != 0)
        return 0;
    rto_msg msg = {{0}};
    rto_npy a = {0};
    if (rto_npy_read(path, &a, &msg)) {
        cli_fail("check-vbuffer", "--gpu %s: %s", dir, msg.text);
        return -1;
    }
    const uint64_t n = (uint64_t)w * h * (planes[k].per_pixel ? 1 : s) * planes[k].channels;
    /* The plane's shape (H, W[, S][, C]) with its axes of size 1 dropped must be the array's with its axes of size 1
     * dropped, or the array flat: a (W, H, ...) dump of the right size is refused, not compared pixel by pixel. */
    const uint64_t want[4] = {h, w, planes[k].per_pixel ? 1 : s, planes[k].channels};
    uint64_t ws[4], as[RTO_NPY_MAX_DIMS], elems = 1;
    uint32_t nw = 0, na = 0;
    for (int d = 0; d < 4; d++)
        if (want[d] != 1)
            ws[nw++] = want[d];
    for (uint32_t d = 0; d < a.desc.ndim; d++) {
        elems *= a.desc.shape[d];
        if (a.desc.shape[d] != 1)
            as[na++] = a.desc.shape[d];
    }
    int same_shape = na <= 1 || na == nw;
    for (uint32_t d = 0; same_shape && na > 1 && d < na; d++)
        same_shape = as[d] == ws[d];
    const rto_dtype t = a.desc.dtype;
    const int ok_type = planes[k].f32 ? t == RTO_DTYPE_F32
                        : k == P_MASK ? (t == RTO_DTYPE_U8 || t == RTO_DTYPE_U32)
                        : k == P_VIS  ? (t == RTO_DTYPE_U16 || t == RTO_DTYPE_U32)
                                      : (t == RTO_DTYPE_F16 || t == RTO_DTYPE_U16);
    if (!ok_type || elems != n || !same_shape) {
        cli_fail("check-vbuffer", "--gpu %s: %s: expected %" PRIu64 " values of %s (%ux%u%s x %u), found %s", dir, name,
                 n, planes[k].f32 ? "float32" : k == P_MASK ? "uint8 or uint32" : k == P_VIS ? "uint16 or uint32"
                                                                                           : "float16 or uint16",
                 w, h, planes[k].per_pixel ? "" : s == 4 ? " x 4 samples" : " x 1 sample", planes[k].channels,
                 rto_npy_desc_text(&a.desc, NULL, (char[160]){0}, 160));
        rto_npy_free(&a);
        return -1;
    }
    if (t == RTO_DTYPE_U8) { /* the mask: 0 or 1 */
        const uint8_t *m = a.data;
        for (uint64_t i = 0; i < n; i++)
            if (m[i] > 1) {
                cli_fail("check-vbuffer", "--gpu %s: %s: pixel %" PRIu64 " holds %u; the mask is 0 or 1", dir, name, i,
                         m[i]);
                rto_npy_free(&a);
                return -1;
            }
    }
    if (t == RTO_DTYPE_U32) { /* 32-bit words holding 16-bit values (or mask bytes), as a storage buffer gives them */
        const uint32_t *src = a.data;
        const size_t size = k == P_MASK ? 1 : 2;
        unsigned char *dst = malloc(n * size);
        for (uint64_t i = 0; dst && i < n; i++) {
            if (src[i] > (k == P_MASK ? 1u : 0xffffu)) {
                cli_fail("check-vbuffer", "--gpu %s: %s: value %" PRIu64 " is %" PRIu32 ", outside %s", dir, name, i,
                         src[i], k == P_MASK ? "0 .. 1" : "16 bits");
                free(dst);
                rto_npy_free(&a);
                return -1;
            }
            if (size == 1)
                dst[i] = (unsigned char)src[i];
            else
                ((uint16_t *)(void *)dst)[i] = (uint16_t)src[i];
        }
        rto_npy_free(&a);
        if (!dst) {
            cli_fail("check-vbuffer", "out of memory reading %s", name);
            return -1;
        }
        *out = dst;
        return 1;
    }
    *out = a.data; /* the array's buffer, owned from here on */
    return 1;
}

/* The bundle's stored planes must be what rto_vbuffer_make computes for its geometry and camera. */
static const char *bundle_differs(const rto_vbuffer_bundle *vb, const rto_vbuffer *re)
{
    const rto_vbuffer_planes *a = &vb->planes, *b = &re->planes;
    const size_t n = (size_t)a->width * a->height * a->samples;
    if (memcmp(a->visibility, b->visibility, 8 * n))
        return "vb_visibility.npy";
    if (memcmp(a->barycentric, b->barycentric, 4 * n))
        return "vb_barycentric.npy";
    if (memcmp(a->normal, b->normal, 8 * n))
        return "vb_normal.npy";
    if (memcmp(a->derivatives, b->derivatives, 8 * n))
        return "vb_derivatives.npy";
    if (memcmp(a->depth, b->depth, 4 * n) || memcmp(a->depth_unorm24, b->depth_unorm24, 4 * n))
        return "vb_depth.npy";
    if (memcmp(vb->admissible_offset, re->admissible_offset, 4 * (n + 1)) ||
        memcmp(vb->admissible, re->admissible, 8 * (size_t)re->admissible_offset[n]))
        return "vb_admissible.npy";
    return NULL;
}

static void fill_report(rto_report *r, const rto_vbuffer_check_result *res, const rto_vbuffer_bundle *vb)
{
    memset(r, 0, sizeof *r);
    snprintf(r->validator, sizeof r->validator, "check-vbuffer");
    snprintf(r->what, sizeof r->what, "%ux%u x%u %.64s", vb->planes.width, vb->planes.height, vb->planes.samples,
             vb->material.material == RTO_VB_PLUGIN ? vb->plugin_name : vb->material_name);
    snprintf(r->context, sizeof r->context, "%" PRIu64 " samples compared, %" PRIu64
             " with another admissible triangle than the reference's", res->compared, res->other_admissible);
    r->code = (int)res->fault;
    snprintf(r->fault, sizeof r->fault, "%s", res->fault ? rto_vb_fault_name(res->fault) : "none");
    if (res->fault) {
        snprintf(r->faults_seen[0], sizeof r->faults_seen[0], "%s", rto_vb_fault_name(res->fault));
        r->nfaults_seen = 1;
    }
    for (int k = 0; k < P_N; k++) {
        rto_report_check *c = &r->checks[r->nchecks++];
        snprintf(c->name, sizeof c->name, "%s", planes[k].plane);
        c->state = !(res->planes_checked >> k & 1u) ? RTO_CHECK_NOT_RUN
                   : res->fault && res->plane && strcmp(res->plane, planes[k].plane) == 0 ? RTO_CHECK_FAILED
                                                                                           : RTO_CHECK_PASSED;
    }
    if (res->fault) {
        const char *names[3] = {"x", "y", "sample"};
        const int64_t v[3] = {res->x, res->y, res->sample};
        for (int k = 0; k < 3; k++) {
            snprintf(r->where[k].name, sizeof r->where[k].name, "%s", names[k]);
            r->where[k].value = v[k];
        }
        r->nwhere = 3;
    }
    const char *fnames[6] = {"samples", "compared", "other_admissible", "mask_gpu_only", "mask_oracle_only",
                             "mask_either"};
    const int64_t fv[6] = {(int64_t)vb->planes.width * vb->planes.height * vb->planes.samples, (int64_t)res->compared,
                           (int64_t)res->other_admissible, (int64_t)res->mask_gpu_only, (int64_t)res->mask_oracle_only,
                           (int64_t)res->mask_either};
    for (int k = 0; k < 6; k++) {
        snprintf(r->facts[k].name, sizeof r->facts[k].name, "%s", fnames[k]);
        r->facts[k].value = fv[k];
    }
    r->nfacts = 6;
    snprintf(r->tolerance, sizeof r->tolerance, "admissible sets and intervals of DESIGN.md §11.3, §11.6");
    if (res->fault)
        snprintf(r->summary, sizeof r->summary, "%s: %.480s", rto_vb_fault_name(res->fault), res->what);
    else
        snprintf(r->summary, sizeof r->summary, "ok: %" PRIu64 " samples within their admissible sets and intervals",
                 res->compared);
}

int cmd_check_vbuffer(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL, *material_arg = NULL;
    bool json = false, no_artifacts = false;
    unsigned nearest = 0;
    static const opt_name rounding_names[] = {{"any", 0}, {"nearest", 1}, {NULL, 0}};
    uint64_t threads = 0;
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "OUTDIR", "the vbuffer bundle (rtoracle vbuffer)"),
        OPT_PATH("gpu", 0, &gpu, "DUMPDIR", "the GPU's planes, mask and image (vb_*.npy)"),
        OPT_ENUM("f16-rounding", &nearest, rounding_names, "R",
                 "binary16 stores: any (nearest or toward zero, as Vulkan allows) or nearest (even)", "any"),
        OPT_PATH("material", 0, &material_arg, "LIB.so", "the material plugin the bundle was written with"),
        OPT_UINT("threads", &threads, 0, 256, "N",
                 "threads recomputing the bundle (0: one per CPU; the check itself uses every CPU)", "0"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "do not write check-vbuffer.json into DUMPDIR"),
        OPT_END,
    };
    const opt_command cmd = {"check-vbuffer", check_vbuffer_usage, check_vbuffer_epilog, opts, 0, 0, NULL};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    rto_msg msg = {{0}};
    rto_vbuffer_bundle vb;
    rto_vbuffer re;
    memset(&re, 0, sizeof re);
    void *g[P_N] = {NULL};
    if (rto_vbuffer_bundle_read(expected, &vb, &msg))
        return cli_fail("check-vbuffer", "--expected %s", msg.text);
    const uint32_t W = vb.planes.width, H = vb.planes.height, S = vb.planes.samples;
    rc = EXIT_PASS;
    rto_material_plugin *plugin = NULL;
    if (vb.material.material == RTO_VB_PLUGIN) {
        rto_msg pm = {{0}};
        if (!material_arg)
            rc = cli_fail("check-vbuffer", "--expected %s: shaded with the material plugin '%s': pass it with "
                          "--material LIB.so", expected, vb.plugin_name);
        else if (rto_material_plugin_load(material_arg, &plugin, &pm))
            rc = cli_fail("check-vbuffer", "--material %s", pm.text);
        else if (strcmp(rto_material_plugin_def(plugin)->name, vb.plugin_name) != 0)
            rc = cli_fail("check-vbuffer", "--material %s: its material is '%s', the bundle's '%s'", material_arg,
                          rto_material_plugin_def(plugin)->name, vb.plugin_name);
        else
            vb.material.custom = rto_material_plugin_def(plugin);
    } else if (material_arg) {
        rc = cli_fail("check-vbuffer", "--material %s: the bundle's material is the built-in %s", material_arg,
                      vb.material_name);
    }
    for (int k = 0; k < P_N && rc == EXIT_PASS; k++) {
        const int got = load_plane(gpu, k, W, H, S, &g[k]);
        if (got < 0)
            rc = EXIT_BAD_INPUT;
        else if (got == 0 && k == P_VIS)
            rc = cli_fail("check-vbuffer", "--gpu %s: %s", gpu,
                          access(gpu, F_OK) ? "no such directory" : "no vb_visibility.npy: nothing to compare");
    }
    const rto_vbuffer_desc vd = {W, H, S, (uint32_t)threads};
    rto_status s = RTO_OK;
    if (rc == EXIT_PASS && (s = rto_vbuffer_make(&vb.geometry, &vb.camera, &vd, &re, &msg)))
        rc = cli_status("check-vbuffer", s, &msg);
    const char *differs = rc == EXIT_PASS ? bundle_differs(&vb, &re) : NULL;
    if (differs)
        rc = cli_fail("check-vbuffer", "--expected %s: %s: not what this rtoracle computes for the bundle's scene and "
                      "camera (written by another version, or edited)", expected, differs);
    if (rc == EXIT_PASS) {
        const rto_vbuffer_planes gp = {W, H, S, g[P_VIS], g[P_BARY], g[P_NORMAL], g[P_DERIV], g[P_DEPTH], NULL};
        const rto_vbuffer_check_desc cd = {&re, &vb.geometry, &gp, g[P_MASK], g[P_IMAGE], &vb.material,
                                           !nearest};
        rto_vbuffer_check_result res;
        if ((s = rto_vbuffer_check(&cd, &res, &msg))) {
            rc = cli_status("check-vbuffer", s, &msg);
        } else {
            rto_report r;
            fill_report(&r, &res, &vb);
            char path[4096];
            snprintf(path, sizeof path, "%s/check-vbuffer.json", gpu);
            rc = cli_report_at("check-vbuffer", &r, json, no_artifacts ? NULL : path);
        }
    }
    for (int k = 0; k < P_N; k++)
        free(g[k]);
    rto_vbuffer_free(&re);
    rto_vbuffer_bundle_free(&vb);
    rto_material_plugin_unload(plugin);
    return rc;
}
