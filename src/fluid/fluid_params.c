/* The fluid stage's parameters (DESIGN.md §12.1): the seed's defaults, the uniform block the splat kernels read
 * (each value rounded once from binary64) and the particle generators (lattices with seeded jitter, deterministic). */
#include "fluid/fluid_internal.h"
#include "internal.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FLUID_PI 3.14159265358979323846
#define FLUID_PARTICLES_MAX (UINT64_C(1) << 24)
#define FLUID_VOXELS_MAX (UINT64_C(1) << 27)

void rto_fluid_params_default(rto_fluid_params *p)
{
    if (!p)
        return;
    memset(p, 0, sizeof *p);
    for (int a = 0; a < 3; a++) {
        *rto__v3ptr(&p->bounds.min, a) = -1.0f;
        *rto__v3ptr(&p->bounds.max, a) = 1.0f;
        p->res[a] = 64;
    }
    p->radius = 0.05f;
    p->scale = 1000.0f;
    p->occupancy = 32;
}

rto_status rto_fluid_uniforms_make(const rto_fluid_params *p, rto_fluid_uniforms *u, rto_msg *msg)
{
    if (!p || !u)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL fluid parameters");
    memset(u, 0, sizeof *u);
    static const char axis[3] = {'x', 'y', 'z'};
    for (int a = 0; a < 3; a++) {
        const float lo = rto__v3get(&p->bounds.min, a), hi = rto__v3get(&p->bounds.max, a);
        if (!isfinite(lo) || !isfinite(hi) || !(hi > lo))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "bounds %c: [%g, %g] (finite, max > min)", axis[a],
                             (double)lo, (double)hi);
    }
    uint64_t voxels = 1;
    for (int a = 0; a < 3; a++) {
        if (p->res[a] < 1 || p->res[a] > 1024)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "resolution %c: %" PRIu32 " (1 to 1024)", axis[a],
                             p->res[a]);
        voxels *= p->res[a];
    }
    if (voxels > FLUID_VOXELS_MAX)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%" PRIu32 "x%" PRIu32 "x%" PRIu32 " voxels: more than 2^27",
                         p->res[0], p->res[1], p->res[2]);
    if (!isfinite(p->radius) || !(p->radius > 0.0f))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "radius %g: finite and > 0", (double)p->radius);
    if (!isfinite(p->scale) || !(p->scale > 0.0f) || p->scale > 16777216.0f)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "scale %g: finite, > 0 and at most 2^24", (double)p->scale);
    if (p->occupancy < 1 || p->occupancy > 1024)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "occupancy %" PRIu32 " cells per axis (1 to 1024)",
                         p->occupancy);
    const double h = (double)p->radius;
    const double S = 15.0 / (2.0 * FLUID_PI * h * h * h * h * h);
    if (!(S <= 3.0e38) || !((float)S > 0.0f))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "radius %g: the kernel factor 15 / (2 pi h^5) = %g is not a "
                         "finite non-zero binary32", h, S);
    /* The occupancy grid's margin h 2^-12 must cover the model's distance error at r = h (§12.3): a radius
     * below what the bounds' binary32 precision resolves is refused. */
    double umax = 0.0;
    for (int a = 0; a < 3; a++) {
        const double m = fabs((double)rto__v3get(&p->bounds.min, a)), M = fabs((double)rto__v3get(&p->bounds.max, a));
        int e;
        frexp((m > M ? m : M) + m, &e);
        const double ua = ldexp(1.0, e - 24);
        umax = ua > umax ? ua : umax;
    }
    const double hmin = 1.7320508075688773 * umax / (0x1p-12 - 0x1p-19);
    if (h < hmin)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "radius %g: below %g, what the bounds' binary32 precision "
                         "resolves (DESIGN.md §12.3)", h, hmin);
    for (int a = 0; a < 3; a++) {
        const double vs =
            ((double)rto__v3get(&p->bounds.max, a) - (double)rto__v3get(&p->bounds.min, a)) / (double)p->res[a];
        if (!(vs <= 3.0e38) || !((float)vs > 0.0f))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "bounds %c: voxel size %g is not a finite non-zero "
                             "binary32", axis[a], vs);
        u->bounds_min[a] = rto__v3get(&p->bounds.min, a);
        u->bounds_max[a] = rto__v3get(&p->bounds.max, a);
        u->voxel_size[a] = (float)vs;
        u->res[a] = (float)p->res[a];
    }
    u->radius = p->radius;
    u->kernel_factor = (float)S;
    u->scale = p->scale;
    u->occupancy = (float)p->occupancy;
    return RTO_OK;
}

/* A point at fraction (fx, fy, fz) of the box, in binary64 then rounded once. */
static void at_fraction(const rto_fluid_params *p, double fx, double fy, double fz, float *out)
{
    const double f[3] = {fx, fy, fz};
    for (int a = 0; a < 3; a++) {
        const double lo = rto__v3get(&p->bounds.min, a), ext = (double)rto__v3get(&p->bounds.max, a) - lo;
        out[a] = (float)(lo + f[a] * ext);
    }
}

/* n particles on a jittered lattice filling the fractional box [f0, f1] (per axis): the lattice spacing makes at
 * least n points, which are taken in order (x fastest); each is moved by up to a quarter spacing (rto_unit). */
static void block(const rto_fluid_params *p, const double f0[3], const double f1[3], uint64_t n, uint32_t seed,
                  float *out)
{
    double ext[3], vol = 1.0;
    for (int a = 0; a < 3; a++) {
        ext[a] = f1[a] - f0[a];
        vol *= ext[a];
    }
    double sp = cbrt(vol / (double)n);
    uint64_t cnt[3];
    for (;;) {
        for (int a = 0; a < 3; a++) {
            cnt[a] = (uint64_t)(ext[a] / sp);
            if (cnt[a] < 1)
                cnt[a] = 1;
        }
        if (cnt[0] * cnt[1] * cnt[2] >= n)
            break;
        sp *= 0.97;
    }
    for (uint64_t i = 0; i < n; i++) {
        const uint64_t ix = i % cnt[0], iy = (i / cnt[0]) % cnt[1], iz = i / (cnt[0] * cnt[1]);
        const uint64_t id[3] = {ix, iy, iz};
        double f[3];
        for (int a = 0; a < 3; a++) {
            const double step = ext[a] / (double)cnt[a];
            const double j = ((double)rto_unit(seed, (uint32_t)(3 * i + (uint64_t)a)) - 0.5) * 0.5 * step;
            f[a] = f0[a] + ((double)id[a] + 0.5) * step + j;
        }
        at_fraction(p, f[0], f[1], f[2], out + 3 * i);
    }
}

/* n droplets uniform in the ball of centre c and radius rad (fractions of the box), by rejection on rto_unit. */
static void ball(const rto_fluid_params *p, const double c[3], double rad, uint64_t n, uint32_t seed, float *out)
{
    uint32_t k = 0;
    for (uint64_t i = 0; i < n; i++) {
        double d[3];
        do {
            for (int a = 0; a < 3; a++)
                d[a] = 2.0 * (double)rto_unit(seed, k++) - 1.0;
        } while (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1.0);
        at_fraction(p, c[0] + rad * d[0], c[1] + rad * d[1], c[2] + rad * d[2], out + 3 * i);
    }
}

/* "lattice": the bounds' 8 corners and 6 face centres, then voxel corners bmin + f32(i) * vs and voxel centres (as
 * the splat computes them) at a stride of about a quarter of the resolution, and points on the faces. */
static uint64_t lattice(const rto_fluid_params *p, const rto_fluid_uniforms *u, float *out)
{
    uint64_t n = 0;
    for (int k = 0; k < 8; k++) {
        for (int a = 0; a < 3; a++)
            if (out)
                out[3 * n + (uint64_t)a] =
                    (k >> a) & 1 ? rto__v3get(&p->bounds.max, a) : rto__v3get(&p->bounds.min, a);
        n++;
    }
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++) {
            if (out) {
                at_fraction(p, 0.5, 0.5, 0.5, out + 3 * n);
                out[3 * n + (uint64_t)a] = side ? rto__v3get(&p->bounds.max, a) : rto__v3get(&p->bounds.min, a);
            }
            n++;
        }
    uint32_t stride[3];
    for (int a = 0; a < 3; a++)
        stride[a] = p->res[a] / 4 ? p->res[a] / 4 : 1;
    for (uint32_t z = 0; z <= p->res[2]; z += stride[2])
        for (uint32_t y = 0; y <= p->res[1]; y += stride[1])
            for (uint32_t x = 0; x <= p->res[0]; x += stride[0]) {
                const uint32_t id[3] = {x, y, z};
                if (out)
                    for (int a = 0; a < 3; a++) /* a voxel corner, the same binary32 steps as the centres */
                        out[3 * n + (uint64_t)a] = u->bounds_min[a] + (float)id[a] * u->voxel_size[a];
                n++;
                if (x < p->res[0] && y < p->res[1] && z < p->res[2]) {
                    if (out)
                        for (int a = 0; a < 3; a++)
                            out[3 * n + (uint64_t)a] = rto__fluid_centre(u, a, id[a]);
                    n++;
                }
            }
    return n;
}

rto_status rto_fluid_generate(const char *spec, const rto_fluid_params *p, float **pos, uint64_t *count, rto_msg *msg)
{
    if (!spec || !pos || !count)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL argument");
    *pos = NULL;
    *count = 0;
    rto_fluid_uniforms u;
    rto_status s = rto_fluid_uniforms_make(p, &u, msg);
    if (s)
        return s;
    static const char *const kinds[] = {"dambreak", "pool", "splash"};
    int kind = -1;
    uint64_t n = 0;
    if (strcmp(spec, "single") == 0) {
        kind = 3;
        n = 1;
    } else if (strcmp(spec, "lattice") == 0) {
        kind = 4;
        n = lattice(p, &u, NULL);
    } else {
        for (int k = 0; k < 3; k++) {
            const size_t len = strlen(kinds[k]);
            if (strncmp(spec, kinds[k], len) == 0 && spec[len] == ':') {
                const char *t = spec + len + 1;
                char *end = NULL;
                if (*t < '0' || *t > '9')
                    break;
                errno = 0;
                const unsigned long long v = strtoull(t, &end, 10);
                if (errno || *end || v < 1 || v > FLUID_PARTICLES_MAX)
                    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s: the particle count must be 1 to 2^24", spec);
                kind = k;
                n = v;
            }
        }
    }
    if (kind < 0)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s: not a generator (dambreak:N, pool:N, splash:N, single, "
                         "lattice)", spec);
    float *out = malloc((size_t)n * 3 * sizeof *out);
    if (!out)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %" PRIu64 " particles", n);
    if (kind == 0) {
        const double f0[3] = {0.02, 0.02, 0.02}, f1[3] = {0.35, 0.6, 0.98};
        block(p, f0, f1, n, 3001, out);
    } else if (kind == 1) {
        const double f0[3] = {0.02, 0.02, 0.02}, f1[3] = {0.98, 0.25, 0.98};
        block(p, f0, f1, n, 3002, out);
    } else if (kind == 2) {
        const uint64_t drops = n / 4, pool = n - drops;
        const double f0[3] = {0.02, 0.02, 0.02}, f1[3] = {0.98, 0.25, 0.98}, c[3] = {0.5, 0.65, 0.5};
        block(p, f0, f1, pool, 3003, out);
        ball(p, c, 0.15, drops, 3004, out + 3 * pool);
    } else if (kind == 3) {
        at_fraction(p, 0.5, 0.5, 0.5, out);
    } else {
        lattice(p, &u, out);
    }
    *pos = out;
    *count = n;
    return RTO_OK;
}
