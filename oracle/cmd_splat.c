/* rtoracle splat: SPH particles splatted into a fixed-point density volume as seed 003's splat passes do (DESIGN.md
 * §12): the u32 volume the atomicAdds leave, its binary16 resolve and the occupancy grid with its mip chain, written
 * as a bundle a GPU harness uploads from and check-volume compares with. */
#include "cli.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char splat_usage[] =
    "usage: rtoracle splat (PARTICLES.npy | GENERATOR) [--resolution N|NX,NY,NZ] [--bounds X0,Y0,Z0,X1,Y1,Z1]\n"
    "                      [--radius H] [--scale S] [--occupancy O] [--threads N] [--force] -o OUTDIR\n\n"
    "PARTICLES.npy holds float32 positions, shape (N, 3), N at most 2^24, every coordinate finite. A GENERATOR is\n"
    "dambreak:N (a block in the lower-left third of the box), pool:N (a layer over the bottom quarter), splash:N\n"
    "(a pool and a ball of droplets above it), single (one particle in the centre) or lattice (particles on voxel\n"
    "corners, voxel centres and the bounds' faces and corners, where each rounding sits on a knife edge).\n"
    "The splat (DESIGN.md §12.2): for every voxel centre c within the smoothing radius h of a particle p, in\n"
    "binary32, u32((h - |c - p|)^2 * 15 / (2 pi h^5) * scale) truncated, summed exactly; the sum is stored mod 2^32\n"
    "as atomicAdd leaves it, and a voxel whose true sum passes 2^32 - 1 is listed (overflow.npy) with a warning on\n"
    "stderr (the bundle is still written, exit 0). The resolve: binary16 of f32(u) / scale. The occupancy grid\n"
    "(§12.3): O cells per axis, a cell set where a particle's radius dilated by one voxel meets it, then each coarser\n"
    "level (ceil(res / 2) cells per axis down to 1) the OR of its children; bit (z O + y) O + x of u32 words.\n"
    "Writes a bundle (atomically):\n"
    "  fluid_params.npy   f32 (16,): bounds_min, h, voxel_size, S, bounds_max, scale, res, occupancy\n"
    "  particles.npy      f32 (N, 3)\n"
    "  volume_u32.npy     u32 (NZ, NY, NX): the sums mod 2^32, x fastest\n"
    "  volume_f16.npy     f16 (NZ, NY, NX): the resolved density\n"
    "  occupancy.npy      u32 (words,): every level's bits, level 0 first\n"
    "  overflow.npy       u64 (K, 2): voxel index and true sum (only when some voxel overflows)\n"
    "  manifest.json      parameters, occupancy levels (offset, res), statistics\n"
    "The bytes do not depend on --threads or on the particles' order. An OUTDIR that already holds this very bundle\n"
    "is left as it is; --force writes it again.\n";

/* Most particles a file may hold. */
#define SPLAT_MAX_PARTICLES (UINT64_C(1) << 24)

/* Positions from a .npy: float32 (N, 3) only. EXIT_PASS, or EXIT_BAD_INPUT after one line. */
static int read_particles(const char *path, float **pos, uint64_t *count)
{
    rto_msg msg = {{0}};
    rto_npy a = {0};
    if (rto_npy_read(path, &a, &msg))
        return cli_fail("splat", "%s", msg.text);
    char desc[160];
    if (a.desc.dtype != RTO_DTYPE_F32 || a.desc.nfields || a.desc.ndim != 2 || a.desc.shape[1] != 3) {
        cli_fail("splat", "%s: expected float32 positions of shape (N, 3), found %s", path,
                 rto_npy_desc_text(&a.desc, NULL, desc, sizeof desc));
        rto_npy_free(&a);
        return EXIT_BAD_INPUT;
    }
    const uint64_t n = a.desc.shape[0];
    if (n > SPLAT_MAX_PARTICLES) {
        rto_npy_free(&a);
        return cli_fail("splat", "%s: %" PRIu64 " particles (at most 2^24)", path, n);
    }
    const float *f = a.data;
    for (uint64_t i = 0; i < 3 * n; i++)
        if (!isfinite(f[i])) {
            cli_fail("splat", "%s: particle %" PRIu64 " has a non-finite coordinate", path, i / 3);
            rto_npy_free(&a);
            return EXIT_BAD_INPUT;
        }
    float *copy = cli_alloc(n * 3, sizeof *copy);
    if (!copy) {
        rto_npy_free(&a);
        return cli_fail("splat", "out of memory for %" PRIu64 " particles", n);
    }
    if (n)
        memcpy(copy, f, (size_t)n * 3 * sizeof *copy);
    rto_npy_free(&a);
    *pos = copy;
    *count = n;
    return EXIT_PASS;
}

int cmd_splat(int argc, char **argv)
{
    const char *out = NULL, *res_arg = NULL, *bounds_arg = NULL;
    uint64_t occupancy = 32, threads = 0;
    double radius = 0.05, scale = 1000.0;
    bool force = false;
    const opt_spec opts[] = {
        OPT_STRING("resolution", &res_arg, "N|NX,NY,NZ", "voxels per axis, 1 to 1024 each (default 64)"),
        OPT_STRING("bounds", &bounds_arg, "X0,Y0,Z0,X1,Y1,Z1", "the volume's box (default -1,-1,-1,1,1,1)"),
        OPT_REAL("radius", &radius, 0.0, "H", "the smoothing radius h (> 0)", "0.05"),
        OPT_REAL("scale", &scale, 16777216.0, "S", "the fixed-point scale (> 0, at most 2^24)", "1000"),
        OPT_UINT("occupancy", &occupancy, 1, 1024, "O", "occupancy cells per axis", "32"),
        OPT_UINT("threads", &threads, 0, 256, "N", "threads (0: one per CPU); the output is the same", "0"),
        OPT_FLAG("force", &force, "write the bundle even when OUTDIR is up to date"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"splat", splat_usage, "exit status: 0 written (also with overflow: see the warning), 2 "
                             "bad usage or input\n", opts, 1, 1, "one PARTICLES.npy or GENERATOR"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    rto_fluid_params p;
    rto_fluid_params_default(&p);
    if (res_arg) {
        uint64_t r[3];
        char buf[64];
        const char *c1 = strchr(res_arg, ',');
        bool ok = strlen(res_arg) < sizeof buf;
        if (ok && !c1) {
            ok = opts_parse_uint(res_arg, 1024, &r[0]);
            r[1] = r[2] = r[0];
        } else if (ok) {
            snprintf(buf, sizeof buf, "%s", res_arg);
            char *a = buf, *b = strchr(a, ','), *c = b ? strchr(b + 1, ',') : NULL;
            ok = b && c && !strchr(c + 1, ',');
            if (ok) {
                *b = *c = 0;
                ok = opts_parse_uint(a, 1024, &r[0]) && opts_parse_uint(b + 1, 1024, &r[1]) &&
                     opts_parse_uint(c + 1, 1024, &r[2]);
            }
        }
        if (!ok || !r[0] || !r[1] || !r[2])
            return cli_fail("splat", "--resolution %s: expected N or NX,NY,NZ, each 1 to 1024", res_arg);
        for (int a = 0; a < 3; a++)
            p.res[a] = (uint32_t)r[a];
    }
    if (bounds_arg) {
        float b[6];
        if (!cli_parse_floats(bounds_arg, b, 6))
            return cli_fail("splat", "--bounds %s: expected six numbers X0,Y0,Z0,X1,Y1,Z1", bounds_arg);
        p.bounds.min = (rto_vec3){b[0], b[1], b[2]};
        p.bounds.max = (rto_vec3){b[3], b[4], b[5]};
    }
    p.radius = (float)radius;
    p.scale = (float)scale;
    p.occupancy = (uint32_t)occupancy;
    rto_msg msg = {{0}};
    rto_fluid_uniforms u;
    if (rto_fluid_uniforms_make(&p, &u, &msg))
        return cli_fail("splat", "%s", msg.text);
    static const char *const not_inputs[] = {"output", "force", "threads", NULL};
    char *request = opts_request(&cmd, &args, not_inputs);
    const char *src = args.arg[0];
    const size_t len = strlen(src);
    const bool is_file = len > 4 && strcmp(src + len - 4, ".npy") == 0;
    if (is_file) { /* the file's contents are an input too: no up-to-date shortcut without its hash */
        free(request);
        request = NULL;
    }
    if (cli_up_to_date("splat", out, request, force)) {
        free(request);
        return EXIT_PASS;
    }
    float *pos = NULL;
    uint64_t count = 0;
    if (is_file) {
        if ((rc = read_particles(src, &pos, &count)))
            return rc;
    } else if (rto_fluid_generate(src, &p, &pos, &count, &msg)) {
        free(request);
        return cli_fail("splat", "%s", msg.text);
    }
    rto_splat s;
    rto_bundle *b = NULL;
    rto_status st = rto_splat_make(&p, pos, count, (uint32_t)threads, &s, &msg);
    if (st) {
        free(pos);
        free(request);
        return cli_status("splat", st, &msg);
    }
    st = rto_bundle_begin(out, "splat", &b, &msg);
    if (!st)
        st = cli_set_request(b, request, NULL, NULL, &msg);
    if (!st)
        st = rto_splat_bundle_write(&s, pos, count, b, &msg);
    if (!st)
        st = rto_bundle_commit(b, &msg);
    else
        rto_bundle_abort(b);
    if (!st) {
        const rto_splat_stats *t = &s.stats;
        char sum[64];
        printf("splat %s: %" PRIu64 " particles into %" PRIu32 "x%" PRIu32 "x%" PRIu32 " voxels: %" PRIu64
               " contributions (%" PRIu64 " uncertain), %" PRIu64 " voxels non-zero, max sum %" PRIu64 ", %" PRIu64
               " of %" PRIu64 " occupancy cells set -> %s (%s)\n",
               src, count, p.res[0], p.res[1], p.res[2], t->contributions, t->uncertain, t->voxels_nonzero, t->max_sum,
               t->occupied_cells, (uint64_t)p.occupancy * p.occupancy * p.occupancy, out,
               cli_dir_summary(out, sum, sizeof sum));
        if (t->overflow_voxels) {
            const uint64_t v = s.overflow[0];
            fprintf(stderr, "rtoracle splat: warning: %" PRIu64 " voxel(s) overflow 32 bits; the first, (%" PRIu64
                    ", %" PRIu64 ", %" PRIu64 "), sums to %" PRIu64 " (overflow.npy lists them)\n",
                    t->overflow_voxels, v % p.res[0], v / p.res[0] % p.res[1], v / ((uint64_t)p.res[0] * p.res[1]),
                    s.overflow[1]);
        }
    }
    rto_splat_free(&s);
    free(pos);
    free(request);
    return cli_status("splat", st, &msg);
}
