/* rtoracle check-volume: validates a GPU's splat (the u32 volume its atomicAdds left, optionally the resolved binary16
 * volume and the occupancy grid) against a splat bundle by DESIGN.md §12.6. The bundle is checked first and must be
 * what this rtoracle computes from its own particles and parameters (a hand-edited volume is refused, never
 * trusted). */
#include "cli.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char check_volume_usage[] =
    "usage: rtoracle check-volume --expected SPLATDIR --gpu DUMPDIR [--f16-rounding any|nearest] [--json]\n"
    "                             [--threads N]\n\n"
    "Compares what a GPU's splat passes wrote (DUMPDIR) with the splat bundle written by `rtoracle splat`.\n"
    "DUMPDIR holds the bundle's file names:\n"
    "  volume_u32.npy   u32 (NZ, NY, NX) or flat: the atomic buffer after splat_particles (required)\n"
    "  volume_f16.npy   f16 or u16 (NZ, NY, NX), (NZ, NY, NX, 4) rgba or flat: the resolved texture (optional;\n"
    "                   with rgba, G and B must be 0 and A 1)\n"
    "  occupancy.npy    u32 (words,): every level of the occupancy grid, level 0 first (optional)\n"
    "Rules (DESIGN.md §12.2, §12.6): a voxel whose contributions are all certain must hold the reference sum\n"
    "exactly; any other within the admissible range of the conformance model (a conforming GPU's r within\n"
    "sqrt(3) ulp(c) + r 2^-19, k * scale within 2^-20, each truncated). A voxel whose true sum passes 2^32 - 1 is\n"
    "a fault whatever it holds. The f16 plane is checked against the GPU's own u32 values: f32(u) rounded either\n"
    "way, the division within 2.5 ulp, binary16 rounded to nearest even or (unless --f16-rounding nearest) toward\n"
    "zero. The occupancy grid must be lossless (every cell a non-zero voxel's trilinear reach meets is set) and\n"
    "each coarser level the OR of its children. The first wrong voxel is named with the particles that reach it.\n";

static const char check_volume_epilog[] =
    "Fault classes, in the order they are claimed: shape, overflow, radius (mass beyond every particle's radius,\n"
    "or none where every admissible sum is positive), contribution, resolve, resolve-rounding (--f16-rounding\n"
    "nearest), occupancy. Exit status: 0 valid, 1 a fault was found, 2 bad usage or input (including a bundle\n"
    "that is not what this rtoracle computes from its particles).\n";

enum { D_U32, D_F16, D_OCC, D_N };

/* Reads dump file k into *a (0 absent, 1 read, -1 after one line): u32 volume (NZ, NY, NX) or flat; f16 / u16
 * (NZ, NY, NX[, 4]) or flat; u32 occupancy (words,). A size other than the bundle's is left to the check (shape);
 * an array of the right size in another shape, or of another dtype, is refused. */
static int load(const char *dir, int k, const uint32_t n[3], rto_npy *a)
{
    static const char *const names[D_N] = {"volume_u32.npy", "volume_f16.npy", "occupancy.npy"};
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, names[k]);
    if (access(path, F_OK) != 0)
        return 0;
    rto_msg msg = {{0}};
    if (rto_npy_read(path, a, &msg)) {
        cli_fail("check-volume", "--gpu %s: %s", dir, msg.text);
        return -1;
    }
    const rto_dtype t = a->desc.dtype;
    const bool type_ok = !a->desc.nfields && (k == D_F16 ? t == RTO_DTYPE_F16 || t == RTO_DTYPE_U16 : t == RTO_DTYPE_U32);
    bool shape_ok = a->desc.ndim == 1;
    if (k == D_U32 || k == D_F16) {
        const uint32_t nd = a->desc.ndim;
        if ((nd == 3 || (k == D_F16 && nd == 4)) && a->desc.shape[0] == n[2] && a->desc.shape[1] == n[1] &&
            a->desc.shape[2] == n[0] && (nd == 3 || a->desc.shape[3] == 4))
            shape_ok = true;
        uint64_t elems = 1;
        for (uint32_t d = 0; d < nd; d++)
            elems *= a->desc.shape[d];
        const uint64_t nv = (uint64_t)n[0] * n[1] * n[2];
        if (!shape_ok && elems != nv && elems != 4 * nv)
            shape_ok = true; /* another size: the check's shape fault */
    }
    if (!type_ok || !shape_ok) {
        char desc[160];
        cli_fail("check-volume", "--gpu %s: %s: expected %s of shape %s, found %s", dir, names[k],
                 k == D_F16 ? "float16 or uint16" : "uint32",
                 k == D_U32 ? "(NZ, NY, NX) or flat" : k == D_F16 ? "(NZ, NY, NX), (NZ, NY, NX, 4) or flat" : "(words,)",
                 rto_npy_desc_text(&a->desc, NULL, desc, sizeof desc));
        rto_npy_free(a);
        return -1;
    }
    return 1;
}

int cmd_check_volume(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL;
    int rounding = 0;
    uint64_t threads = 0;
    bool json = false;
    static const opt_name rounding_names[] = {{"any", 0}, {"nearest", 1}, {NULL, 0}};
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "SPLATDIR", "the splat bundle (rtoracle splat)"),
        OPT_PATH("gpu", 0, &gpu, "DUMPDIR", "the GPU's dump directory"),
        OPT_ENUM("f16-rounding", &rounding, rounding_names, "R",
                 "binary16 stores the resolve may make: any (nearest or toward zero) or nearest", "any"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the report is the same", "0"),
        OPT_END,
    };
    const opt_command cmd = {"check-volume", check_volume_usage, check_volume_epilog, opts, 0, 0, NULL};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    rto_msg msg = {{0}};
    rto_splat_bundle sb;
    rto_status st = rto_splat_bundle_read(expected, (uint32_t)threads, &sb, &msg);
    if (st)
        return cli_fail("check-volume", "--expected %s", msg.text);
    rto_npy a[D_N];
    memset(a, 0, sizeof a);
    int got[D_N] = {0};
    for (int k = 0; k < D_N && rc == 0; k++) {
        got[k] = load(gpu, k, sb.splat.params.res, &a[k]);
        if (got[k] < 0)
            rc = EXIT_BAD_INPUT;
    }
    if (!rc && !got[D_U32])
        rc = cli_fail("check-volume", "--gpu %s: no volume_u32.npy (a missing directory?)", gpu);
    if (!rc) {
        rto_volume_dump d;
        memset(&d, 0, sizeof d);
        d.volume_u32 = a[D_U32].data;
        d.u32_count = a[D_U32].nbytes / 4;
        if (got[D_F16]) {
            d.volume_f16 = a[D_F16].data;
            d.f16_count = a[D_F16].nbytes / 2;
        }
        if (got[D_OCC]) {
            d.occupancy = a[D_OCC].data;
            d.occupancy_words = a[D_OCC].nbytes / 4;
        }
        rto_report *r = malloc(sizeof *r);
        st = r ? rto_volume_check(&sb.splat, sb.particles, sb.count, &d, rounding, (uint32_t)threads, r, &msg)
               : rto_msg_set(&msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        rc = st ? cli_status("check-volume", st, &msg) : cli_report_at("check-volume", r, json, NULL);
        free(r);
    }
    for (int k = 0; k < D_N; k++)
        rto_npy_free(&a[k]);
    rto_splat_bundle_free(&sb);
    return rc;
}
