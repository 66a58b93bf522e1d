/* The splat bundle (DESIGN.md §12): what a GPU harness of seed 003 uploads (the uniform block, the particles) and
 * what its splat passes must leave (the u32 volume, the resolved binary16 volume, the occupancy grid), with the
 * overflow list; and the reader, which checks every array like a GPU dump and requires each to be what this rtoracle
 * computes from the bundle's own particles and parameters (a hand-edited volume is refused, never trusted). */
#include "fluid/fluid_internal.h"
#include "internal.h"
#include "io/bundle_in.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static rto_status add(rto_bundle *b, rto_bundle_file f, const rto_npy_desc *d, const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    return rto_bundle_add_npy(b, rto__bundle_name(f, 0, name), rto_bundle_file_role(f), NULL, d, data, msg);
}

rto_status rto_splat_bundle_write(const rto_splat *s, const float *pos, uint64_t count, rto_bundle *b, rto_msg *msg)
{
    if (!s || !b || (!pos && count) || !s->volume_u32)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "incomplete splat bundle description");
    const rto_fluid_params *p = &s->params;
    const uint64_t nx = p->res[0], ny = p->res[1], nz = p->res[2];
    static const float none[3] = {0.0f, 0.0f, 0.0f};
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_F32, 1, 16, 0, 0);
    rto_status st = add(b, RTO_FILE_FLUID_PARAMS, &d, &s->uniforms, msg);
    d = rto_npy_desc_array(RTO_DTYPE_F32, 2, count, 3, 0);
    if (!st)
        st = add(b, RTO_FILE_FLUID_PARTICLES, &d, count ? pos : none, msg);
    d = rto_npy_desc_array(RTO_DTYPE_U32, 3, nz, ny, nx);
    if (!st)
        st = add(b, RTO_FILE_FLUID_VOLUME_U32, &d, s->volume_u32, msg);
    d = rto_npy_desc_array(RTO_DTYPE_F16, 3, nz, ny, nx);
    if (!st)
        st = add(b, RTO_FILE_FLUID_VOLUME_F16, &d, s->volume_f16, msg);
    d = rto_npy_desc_array(RTO_DTYPE_U32, 1, s->occupancy_words, 0, 0);
    if (!st)
        st = add(b, RTO_FILE_FLUID_OCCUPANCY, &d, s->occupancy, msg);
    d = rto_npy_desc_array(RTO_DTYPE_U64, 2, s->overflow_count, 2, 0);
    if (!st && s->overflow_count)
        st = add(b, RTO_FILE_FLUID_OVERFLOW, &d, s->overflow, msg);
    if (st)
        return st;
    static const char *const mins[3] = {"bounds_min_x", "bounds_min_y", "bounds_min_z"};
    static const char *const maxs[3] = {"bounds_max_x", "bounds_max_y", "bounds_max_z"};
    static const char *const res[3] = {"res_x", "res_y", "res_z"};
    for (int a = 0; a < 3; a++) {
        rto_bundle_set_real(b, "fluid", mins[a], (double)rto__v3get(&p->bounds.min, a));
        rto_bundle_set_real(b, "fluid", maxs[a], (double)rto__v3get(&p->bounds.max, a));
        rto_bundle_set_int(b, "fluid", res[a], (int64_t)p->res[a]);
    }
    rto_bundle_set_real(b, "fluid", "radius", (double)p->radius);
    rto_bundle_set_real(b, "fluid", "scale", (double)p->scale);
    rto_bundle_set_real(b, "fluid", "kernel_factor", (double)s->uniforms.kernel_factor);
    rto_bundle_set_int(b, "fluid", "particles", (int64_t)count);
    rto_bundle_set_int(b, "occupancy", "cells", (int64_t)p->occupancy);
    rto_bundle_set_int(b, "occupancy", "levels", (int64_t)s->occupancy_levels);
    rto_bundle_set_int(b, "occupancy", "words", (int64_t)s->occupancy_words);
    for (uint32_t l = 0; l < s->occupancy_levels; l++) {
        char key[32];
        snprintf(key, sizeof key, "level_%" PRIu32 "_offset", l);
        rto_bundle_set_int(b, "occupancy", key, (int64_t)s->level_offset[l]);
        snprintf(key, sizeof key, "level_%" PRIu32 "_res", l);
        rto_bundle_set_int(b, "occupancy", key, (int64_t)s->level_res[l]);
    }
    const rto_splat_stats *t = &s->stats;
    rto_bundle_set_int(b, "splat", "contributions", (int64_t)t->contributions);
    rto_bundle_set_int(b, "splat", "uncertain", (int64_t)t->uncertain);
    rto_bundle_set_int(b, "splat", "voxels_nonzero", (int64_t)t->voxels_nonzero);
    rto_bundle_set_int(b, "splat", "overflow_voxels", (int64_t)t->overflow_voxels);
    if (t->overflow_voxels)
        rto_bundle_set_int(b, "splat", "first_overflow", (int64_t)t->first_overflow);
    rto_bundle_set_int(b, "splat", "max_sum", (int64_t)t->max_sum); /* below 2^56: 2^24 particles of 2^32 */
    rto_bundle_set_int(b, "splat", "occupied_cells", (int64_t)t->occupied_cells);
    return RTO_OK;
}

/* The parameters of a uniform block: integral resolution and occupancy, the rest as written. */
static bool params_of(const rto_fluid_uniforms *u, rto_fluid_params *p)
{
    memset(p, 0, sizeof *p);
    for (int a = 0; a < 3; a++) {
        if (!(u->res[a] >= 1.0f && u->res[a] <= 1024.0f) || u->res[a] != floorf(u->res[a]))
            return false;
        *rto__v3ptr(&p->bounds.min, a) = u->bounds_min[a];
        *rto__v3ptr(&p->bounds.max, a) = u->bounds_max[a];
        p->res[a] = (uint32_t)u->res[a];
    }
    if (!(u->occupancy >= 1.0f && u->occupancy <= 1024.0f) || u->occupancy != floorf(u->occupancy))
        return false;
    p->occupancy = (uint32_t)u->occupancy;
    p->radius = u->radius;
    p->scale = u->scale;
    return true;
}

/* The first word where a file differs from the recomputed array, refused; RTO_OK when equal. */
static rto_status same(const rto__bundle_in *in, const char *file, const void *got, const void *want, size_t n,
                       size_t width)
{
    if (memcmp(got, want, n * width) == 0)
        return RTO_OK;
    for (size_t i = 0; i < n; i++)
        if (memcmp((const char *)got + i * width, (const char *)want + i * width, width))
            return rto__bundle_refuse(in, file, "element %zu is not what the splat of the bundle's particles gives "
                                      "(a tampered bundle?)", i);
    return RTO_OK;
}

rto_status rto_splat_bundle_read(const char *dir, uint32_t threads, rto_splat_bundle *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL splat bundle");
    memset(out, 0, sizeof *out);
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_in in;
    rto_npy a[6];
    memset(a, 0, sizeof a);
    rto_status s = rto__bundle_in_open(&in, dir, "splat", "splat", msg);
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_F32, 1, 16, 0, 0);
    if (!s)
        s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_PARAMS, 0, name), &want, NULL, &a[0]);
    rto_fluid_uniforms u, u2;
    rto_fluid_params p;
    if (!s) {
        memcpy(&u, a[0].data, sizeof u);
        rto_msg pm = {{0}};
        if (!params_of(&u, &p))
            s = rto__bundle_refuse(&in, name, "the resolution or occupancy is not an integer from 1 to 1024");
        else if (rto_fluid_uniforms_make(&p, &u2, &pm))
            s = rto__bundle_refuse(&in, name, "%s", pm.text);
        else if (memcmp(&u, &u2, sizeof u))
            s = rto__bundle_refuse(&in, name, "the voxel size or kernel factor is not what the bounds and radius give");
    }
    want = rto_npy_desc_array(RTO_DTYPE_F32, 2, UINT64_MAX, 3, 0);
    if (!s)
        s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_PARTICLES, 0, name), &want, NULL, &a[1]);
    if (!s && a[1].desc.shape[0] > (UINT64_C(1) << 24))
        s = rto__bundle_refuse(&in, name, "%" PRIu64 " particles (at most 2^24)", a[1].desc.shape[0]);
    const uint64_t count = s ? 0 : a[1].desc.shape[0];
    if (!s && !rto__all_finite(a[1].data, (size_t)count * 3))
        s = rto__bundle_refuse(&in, name, "a particle coordinate is not finite");
    /* the volumes' files first: the recomputation allocates what they hold, never more than the bundle has */
    const size_t nv = (size_t)p.res[0] * p.res[1] * p.res[2];
    want = rto_npy_desc_array(RTO_DTYPE_U32, 3, p.res[2], p.res[1], p.res[0]);
    if (!s)
        s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_VOLUME_U32, 0, name), &want, NULL, &a[2]);
    want = rto_npy_desc_array(RTO_DTYPE_F16, 3, p.res[2], p.res[1], p.res[0]);
    if (!s)
        s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_VOLUME_F16, 0, name), &want, NULL, &a[3]);
    if (!s) {
        rto_msg sm = {{0}};
        rto_status e = rto_splat_make(&p, a[1].data, count, threads, &out->splat, &sm);
        if (e == RTO_ERR_OUT_OF_MEMORY)
            s = rto__fail(msg, e, "%s", sm.text);
        else if (e)
            s = rto__bundle_refuse(&in, rto__bundle_name(RTO_FILE_FLUID_PARTICLES, 0, name), "%s", sm.text);
    }
    const rto_splat *sp = &out->splat;
    if (!s)
        s = same(&in, rto__bundle_name(RTO_FILE_FLUID_VOLUME_U32, 0, name), a[2].data, sp->volume_u32, nv, 4);
    if (!s)
        s = same(&in, rto__bundle_name(RTO_FILE_FLUID_VOLUME_F16, 0, name), a[3].data, sp->volume_f16, nv, 2);
    want = rto_npy_desc_array(RTO_DTYPE_U32, 1, sp->occupancy_words, 0, 0);
    if (!s && !(s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_OCCUPANCY, 0, name), &want, NULL, &a[4])))
        s = same(&in, name, a[4].data, sp->occupancy, (size_t)sp->occupancy_words, 4);
    want = rto_npy_desc_array(RTO_DTYPE_U64, 2, sp->overflow_count, 2, 0);
    if (!s && sp->overflow_count &&
        !(s = rto__bundle_load(&in, rto__bundle_name(RTO_FILE_FLUID_OVERFLOW, 0, name), &want, NULL, &a[5])))
        s = same(&in, name, a[5].data, sp->overflow, (size_t)sp->overflow_count * 2, 8);
    rto__bundle_in_close(&in);
    for (int k = 0; k < 6; k++)
        if (k != 1)
            rto_npy_free(&a[k]);
    if (s) {
        rto_npy_free(&a[1]);
        rto_splat_free(&out->splat);
        memset(out, 0, sizeof *out);
        return s;
    }
    out->count = count;
    out->particles = malloc((size_t)(count ? count : 1) * 3 * sizeof *out->particles);
    if (!out->particles) {
        rto_npy_free(&a[1]);
        rto_splat_free(&out->splat);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (count)
        memcpy(out->particles, a[1].data, (size_t)count * 3 * sizeof *out->particles);
    rto_npy_free(&a[1]);
    return RTO_OK;
}

void rto_splat_bundle_free(rto_splat_bundle *b)
{
    if (!b)
        return;
    free(b->particles);
    rto_splat_free(&b->splat);
    memset(b, 0, sizeof *b);
}
