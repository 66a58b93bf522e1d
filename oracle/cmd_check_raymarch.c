/* rtoracle check-raymarch: a GPU's raymarch dump against a raymarch bundle (DESIGN.md §12.7). */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static const char check_raymarch_usage[] =
    "usage: rtoracle check-raymarch --expected RMDIR --gpu DUMPDIR [--threads N]\n\n"
    "RMDIR is a raymarch bundle (rtoracle raymarch); it is recomputed from its volume and parameters (a bundle\n"
    "that differs is refused). DUMPDIR holds image.npy (f32 (H, W, 4)) and crossing.npy (u32 (H, W), 0xFFFFFFFF for\n"
    "none), and optionally steps.npy, steps_skip.npy (u32 (H, W): primary-march steps without and with skipping) and\n"
    "crossing_noskip.npy (the same GPU's crossings without skipping). Faults: shape, skip (a skipping GPU's crossing\n"
    "differs from its own non-skipping one, or it took fewer steps than the reference's lossless skipping at a\n"
    "certain pixel), crossing (the first crossing's step outside the admissible set), image (a certain pixel beyond\n"
    "its tolerance, and beyond its wall event's other outcome where it has one: DESIGN.md §12.5.1). The first wrong\n"
    "pixel is named with expected and GPU values.\n";

/* Reads DIR/name: NULL data when absent and optional; 1 = bad (line printed), 0 = fine. 2 = shape fault. */
static int read_plane(const char *dir, const char *name, int optional, rto_dtype t, uint32_t ch, uint32_t W,
                      uint32_t H, rto_npy *out, char *shape_note, size_t cap)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    memset(out, 0, sizeof *out);
    FILE *f = fopen(path, "rb");
    if (!f) {
        if (optional)
            return 0;
        cli_fail("check-raymarch", "%s: missing", path);
        return 1;
    }
    fclose(f);
    rto_msg m = {{0}};
    if (rto_npy_read(path, out, &m)) {
        cli_fail("check-raymarch", "%s", m.text);
        return 1;
    }
    const int ok = out->desc.dtype == t && out->desc.ndim == (ch ? 3u : 2u) && out->desc.shape[0] == H &&
                   out->desc.shape[1] == W && (!ch || out->desc.shape[2] == ch);
    if (out->desc.dtype != t) {
        cli_fail("check-raymarch", "%s: dtype %s, expected %s", path, out->desc.dtype == RTO_DTYPE_F32 ? "<f4" : "other",
                 t == RTO_DTYPE_F32 ? "<f4" : "<u4");
        rto_npy_free(out);
        return 1;
    }
    if (!ok) {
        snprintf(shape_note, cap, "%s has shape (%llu, %llu%s), the bundle's image is %ux%u", name,
                 (unsigned long long)out->desc.shape[0], (unsigned long long)out->desc.shape[1],
                 ch ? ", ..." : "", W, H);
        rto_npy_free(out);
        return 2;
    }
    return 0;
}

int cmd_check_raymarch(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL;
    uint64_t threads = 0;
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "RMDIR", "the raymarch bundle"),
        OPT_PATH("gpu", 0, &gpu, "DUMPDIR", "the GPU's dump directory"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads for the recomputation (0: one per CPU)", "0"),
        OPT_END,
    };
    const opt_command cmd = {"check-raymarch", check_raymarch_usage,
                             "exit status: 0 pass, 1 a fault found, 2 bad usage or input\n", opts, 0, 0, NULL};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    rto_msg msg = {{0}};
    rto_splat vol;
    rto_raymarch ref;
    rto_status s = rto_raymarch_bundle_read(expected, (uint32_t)threads, &vol, &ref, &msg);
    if (s)
        return cli_status("check-raymarch", s, &msg);
    const uint32_t W = ref.params.width, H = ref.params.height;
    rto_npy img, cr, st, sk, cn;
    memset(&img, 0, sizeof img);
    memset(&cr, 0, sizeof cr);
    memset(&st, 0, sizeof st);
    memset(&sk, 0, sizeof sk);
    memset(&cn, 0, sizeof cn);
    char note[256] = "";
    int bad = 0, shape = 0, r;
    r = read_plane(gpu, "image.npy", 0, RTO_DTYPE_F32, 4, W, H, &img, note, sizeof note);
    bad |= r == 1, shape |= r == 2;
    r = bad ? 0 : read_plane(gpu, "crossing.npy", 0, RTO_DTYPE_U32, 0, W, H, &cr, note, sizeof note);
    bad |= r == 1, shape |= r == 2;
    r = bad ? 0 : read_plane(gpu, "steps.npy", 1, RTO_DTYPE_U32, 0, W, H, &st, note, sizeof note);
    bad |= r == 1, shape |= r == 2;
    r = bad ? 0 : read_plane(gpu, "steps_skip.npy", 1, RTO_DTYPE_U32, 0, W, H, &sk, note, sizeof note);
    bad |= r == 1, shape |= r == 2;
    r = bad ? 0 : read_plane(gpu, "crossing_noskip.npy", 1, RTO_DTYPE_U32, 0, W, H, &cn, note, sizeof note);
    bad |= r == 1, shape |= r == 2;
    int status = EXIT_PASS;
    if (bad) {
        status = EXIT_BAD_INPUT;
    } else if (shape) {
        printf("check-raymarch: FAIL shape: %s\n", note);
        status = EXIT_MISMATCH;
    } else {
        rto_raymarch_dump d = {W, H, img.data, cr.data, cn.data, st.data, sk.data};
        rto_raymarch_check_result res;
        s = rto_raymarch_check(&ref, &d, &res, &msg);
        if (s) {
            status = cli_status("check-raymarch", s, &msg);
        } else if (res.fault[0]) {
            printf("check-raymarch: FAIL %s at pixel (%u, %u): %s\n", res.fault, res.x, res.y, res.detail);
            printf("  %" PRIu64 " faulty pixels (crossing %" PRIu64 ", skip %" PRIu64 ", image %" PRIu64 "); %" PRIu64
                   " pixels compared, %" PRIu64 " uncertain (image not compared)\n",
                   res.faults, res.crossing_faults, res.skip_faults, res.image_faults, res.compared, res.uncertain);
            status = EXIT_MISMATCH;
        } else {
            printf("check-raymarch: PASS %ux%u: %" PRIu64 " pixels compared (largest deviation %.3f of the "
                   "tolerance), %" PRIu64 " uncertain (image not compared), every crossing admissible%s\n",
                   W, H, res.compared, res.max_excess, res.uncertain,
                   sk.data ? ", skipping lossless" : "");
        }
    }
    rto_npy_free(&img);
    rto_npy_free(&cr);
    rto_npy_free(&st);
    rto_npy_free(&sk);
    rto_npy_free(&cn);
    rto_raymarch_free(&ref);
    rto_splat_free(&vol);
    return status;
}
