/* The raymarch bundle (DESIGN.md §12.4): the rm_* arrays, image.png, the splat arrays a GPU needs to run the march
 * alone (fluid_params.npy, volume_f16.npy, occupancy.npy), and the manifest's statistics; and the reader of a splat
 * (or raymarch) bundle's volume. */
#include "fluid/raymarch_internal.h"
#include "internal.h"
#include "io/bundle_in.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const camera_keys[13] = {"px", "py", "pz", "tx", "ty", "tz", "ux", "uy", "uz", "fov_y", "aspect",
                                            "znear", "zfar"};

static rto_status add(rto_bundle *b, rto_bundle_file f, const rto_npy_desc *d, const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    return rto_bundle_add_npy(b, rto__bundle_name(f, 0, name), rto_bundle_file_role(f), NULL, d, data, msg);
}

static rto_status add_png(rto_bundle *b, const float *image, uint32_t w, uint32_t h, rto_msg *msg)
{
    const size_t n = (size_t)w * h * 4;
    uint8_t *px = malloc(n);
    if (!px)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the image");
    for (size_t k = 0; k < n; k++) {
        const float v = image[k];
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
    rto_status s = rto_bundle_add_image(b, rto__bundle_name(RTO_FILE_IMAGE, 0, name),
                                        rto_bundle_file_role(RTO_FILE_IMAGE), &im, msg);
    free(px);
    return s;
}

rto_status rto_raymarch_bundle_write(const char *outdir, const char *request, const char *srcdir, const rto_splat *vol,
                                     const rto_raymarch *r, rto_msg *msg)
{
    if (!outdir || !vol || !r || !r->image)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch bundle: missing argument");
    const uint32_t W = r->params.width, H = r->params.height;
    const rto_fluid_params *fp = &vol->params;
    rto_bundle *b;
    rto_status s = rto_bundle_begin(outdir, "raymarch", &b, msg);
    if (s)
        return s;
    if (request) {
        /* The record hashes the three source arrays the volume was read from (rto_raymarch_volume_load). */
        static const rto_bundle_file src_files[3] = {RTO_FILE_FLUID_PARAMS, RTO_FILE_FLUID_VOLUME_F16,
                                                     RTO_FILE_FLUID_OCCUPANCY};
        char paths[3][4096];
        const char *src[3];
        size_t n = 0;
        for (size_t i = 0; srcdir && i < 3 && !s; i++) {
            char name[RTO_BUNDLE_FILE_NAME_MAX];
            s = rto_bundle_file_name(src_files[i], 0, name, sizeof name);
            if (!s && snprintf(paths[i], sizeof paths[i], "%s/%s", srcdir, name) >= (int)sizeof paths[i])
                s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch bundle: %s: path too long", srcdir);
            src[n++] = paths[i];
        }
        if (!s)
            s = rto_bundle_set_request(b, request, src, n, msg);
    }
    rto_npy_desc d;
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F32, 1, 64, 0, 0);
        s = add(b, RTO_FILE_RM_PARAMS, &d, &r->uniforms, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F32, 3, H, W, 4);
        s = add(b, RTO_FILE_RM_IMAGE, &d, r->image, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_IMAGE_WALL, &d, r->image_wall, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_U32, 2, H, W, 0);
        s = add(b, RTO_FILE_RM_CROSSING, &d, r->crossing, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_STEPS, &d, r->steps, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_STEPS_SKIP, &d, r->steps_skip, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F32, 2, H, W, 0);
        s = add(b, RTO_FILE_RM_CROSSING_T, &d, r->crossing_t, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_TOLERANCE, &d, r->tolerance, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_TOLERANCE_WALL, &d, r->tolerance_wall, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F32, 3, H, W, 3);
        s = add(b, RTO_FILE_RM_NORMAL_CENTRAL, &d, r->normal_central, msg);
        if (!s)
            s = add(b, RTO_FILE_RM_NORMAL_FORWARD, &d, r->normal_forward, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_U8, 2, H, W, 0);
        s = add(b, RTO_FILE_RM_CERTAIN, &d, r->certain, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F32, 1, 16, 0, 0);
        s = add(b, RTO_FILE_FLUID_PARAMS, &d, &vol->uniforms, msg);
    }
    if (!s) {
        d = rto_npy_desc_array(RTO_DTYPE_F16, 3, fp->res[2], fp->res[1], fp->res[0]);
        s = add(b, RTO_FILE_FLUID_VOLUME_F16, &d, vol->volume_f16, msg);
    }
    if (!s && vol->occupancy) {
        d = rto_npy_desc_array(RTO_DTYPE_U32, 1, vol->occupancy_words, 0, 0);
        s = add(b, RTO_FILE_FLUID_OCCUPANCY, &d, vol->occupancy, msg);
    }
    if (!s)
        s = add_png(b, r->image, W, H, msg);
    const rto_raymarch_stats *st = &r->stats;
    const double np = st->pixels ? (double)st->pixels : 1.0;
    if (!s) {
        rto_bundle_set_int(b, "params", "width", W);
        rto_bundle_set_int(b, "params", "height", H);
        rto_bundle_set_real(b, "params", "step_size", r->params.step_size);
        rto_bundle_set_real(b, "params", "light_step_size", r->params.light_step_size);
        rto_bundle_set_real(b, "params", "density_offset", r->params.density_offset);
        rto_bundle_set_real(b, "params", "density_multiplier", r->params.density_multiplier);
        rto_bundle_set_int(b, "params", "num_refractions", r->params.num_refractions);
        rto_bundle_set_int(b, "params", "jitter_seed", r->params.jitter_seed);
        rto_bundle_set_real(b, "params", "jitter_scale", r->params.jitter_scale);
        rto_bundle_set_int(b, "params", "skip", st->skip_enabled);
        const rto_camera *cam = &r->params.camera;
        const float cv[13] = {cam->position.x, cam->position.y, cam->position.z, cam->target.x, cam->target.y,
                              cam->target.z, cam->up.x, cam->up.y, cam->up.z, cam->fov_y, cam->aspect, cam->znear,
                              cam->zfar};
        for (int k = 0; k < 13; k++)
            rto_bundle_set_real(b, "camera", camera_keys[k], cv[k]);
        rto_bundle_set_int(b, "params", "envelope", r->params.envelope);
        rto_bundle_set_int(b, "params", "occupancy_levels", vol->occupancy_levels);
        for (uint32_t l = 0; l < vol->occupancy_levels && l < 12; l++) {
            char key[32];
            snprintf(key, sizeof key, "level_offset_%u", l);
            rto_bundle_set_int(b, "params", key, (int64_t)vol->level_offset[l]);
            snprintf(key, sizeof key, "level_res_%u", l);
            rto_bundle_set_int(b, "params", key, vol->level_res[l]);
        }
        rto_bundle_set_int(b, "stats", "pixels", (int64_t)st->pixels);
        rto_bundle_set_int(b, "stats", "crossings", (int64_t)st->crossings);
        rto_bundle_set_int(b, "stats", "certain", (int64_t)st->certain);
        rto_bundle_set_int(b, "stats", "uncertain", (int64_t)st->uncertain);
        rto_bundle_set_int(b, "stats", "wall_pixels", (int64_t)st->wall_pixels);
        rto_bundle_set_real(b, "stats", "steps_mean", (double)st->steps_total / np);
        rto_bundle_set_int(b, "stats", "steps_max", st->steps_max);
        rto_bundle_set_real(b, "stats", "steps_skip_mean", (double)st->steps_skip_total / np);
        rto_bundle_set_int(b, "stats", "steps_skip_max", st->steps_skip_max);
        rto_bundle_set_real(b, "stats", "steps_reduction",
                            st->steps_total ? 1.0 - (double)st->steps_skip_total / (double)st->steps_total : 0.0);
        rto_bundle_set_int(b, "stats", "skipped_samples", (int64_t)st->skipped_samples);
        rto_bundle_set_int(b, "stats", "differing_pixels", (int64_t)st->differing_pixels);
        rto_bundle_set_int(b, "stats", "differing_crossings", (int64_t)st->differing_crossings);
        rto_bundle_set_real(b, "stats", "normal_angle_mean_deg", st->normal_angle_mean);
        s = rto_bundle_set_real(b, "stats", "normal_angle_max_deg", st->normal_angle_max);
    }
    if (!s)
        return rto_bundle_commit(b, msg);
    rto_bundle_abort(b);
    return s;
}

rto_status rto_raymarch_volume_load(const char *dir, rto_splat *out, rto_msg *msg)
{
    if (!dir || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: missing argument");
    memset(out, 0, sizeof *out);
    rto_bundle_reader *r;
    rto_status s = rto_bundle_open(dir, &r, msg);
    if (s)
        return s;
    rto_npy par, vol, occ;
    memset(&par, 0, sizeof par);
    memset(&vol, 0, sizeof vol);
    memset(&occ, 0, sizeof occ);
    s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_FLUID_PARAMS), &par, msg);
    if (!s)
        s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_FLUID_VOLUME_F16), &vol, msg);
    if (!s)
        s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_FLUID_OCCUPANCY), &occ, msg);
    rto_bundle_close(r);
    if (!s && (par.desc.dtype != RTO_DTYPE_F32 || par.desc.ndim != 1 || par.desc.shape[0] != 16))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: fluid_params.npy is not f32 (16,)", dir);
    rto_fluid_uniforms u;
    if (!s) {
        memcpy(&u, par.data, sizeof u);
        for (int a = 0; a < 3; a++)
            if (!(u.res[a] >= 1.0f && u.res[a] <= 1024.0f && u.res[a] == floorf(u.res[a])) ||
                !(u.bounds_max[a] > u.bounds_min[a]) || !(fabsf(u.bounds_min[a]) < 1e30f) ||
                !(fabsf(u.bounds_max[a]) < 1e30f) || !(u.voxel_size[a] > 0.0f && u.voxel_size[a] < 1e30f))
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: fluid_params.npy: bad bounds, resolution or voxel size", dir);
        if (!s && !(u.occupancy >= 1.0f && u.occupancy <= 1024.0f && u.occupancy == floorf(u.occupancy)))
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: fluid_params.npy: occupancy outside 1..1024", dir);
    }
    if (!s && (vol.desc.dtype != RTO_DTYPE_F16 || vol.desc.ndim != 3 || vol.desc.shape[0] != (uint64_t)u.res[2] ||
               vol.desc.shape[1] != (uint64_t)u.res[1] || vol.desc.shape[2] != (uint64_t)u.res[0]))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: volume_f16.npy is not f16 (%g, %g, %g)", dir, (double)u.res[2],
                      (double)u.res[1], (double)u.res[0]);
    if (!s) {
        out->occupancy_levels = rto__rm_levels((uint32_t)u.occupancy, out->level_offset, out->level_res,
                                               &out->occupancy_words);
        if (occ.desc.dtype != RTO_DTYPE_U32 || occ.desc.ndim != 1 || occ.desc.shape[0] != out->occupancy_words)
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: occupancy.npy is not u32 (%llu,)", dir,
                          (unsigned long long)out->occupancy_words);
    }
    if (!s) {
        out->uniforms = u;
        out->params.bounds.min.x = u.bounds_min[0];
        out->params.bounds.min.y = u.bounds_min[1];
        out->params.bounds.min.z = u.bounds_min[2];
        out->params.bounds.max.x = u.bounds_max[0];
        out->params.bounds.max.y = u.bounds_max[1];
        out->params.bounds.max.z = u.bounds_max[2];
        for (int a = 0; a < 3; a++)
            out->params.res[a] = (uint32_t)u.res[a];
        out->params.radius = u.radius;
        out->params.scale = u.scale;
        out->params.occupancy = (uint32_t)u.occupancy;
        out->volume_f16 = vol.data;
        out->occupancy = occ.data;
        vol.data = NULL;
        occ.data = NULL;
    }
    rto_npy_free(&par);
    rto_npy_free(&vol);
    rto_npy_free(&occ);
    if (s)
        memset(out, 0, sizeof *out);
    return s;
}

rto_status rto_raymarch_bundle_read(const char *dir, uint32_t threads, rto_splat *vol, rto_raymarch *ref, rto_msg *msg)
{
    if (!dir || !vol || !ref)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "raymarch: missing argument");
    memset(ref, 0, sizeof *ref);
    rto_status s = rto_raymarch_volume_load(dir, vol, msg);
    if (s)
        return s;
    rto_bundle_reader *r;
    if ((s = rto_bundle_open(dir, &r, msg))) {
        rto_splat_free(vol);
        return s;
    }
    rto_npy par, img, cr;
    memset(&par, 0, sizeof par);
    memset(&img, 0, sizeof img);
    memset(&cr, 0, sizeof cr);
    s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_RM_PARAMS), &par, msg);
    if (!s)
        s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_RM_IMAGE), &img, msg);
    if (!s)
        s = rto_bundle_read_role(r, rto_bundle_file_role(RTO_FILE_RM_CROSSING), &cr, msg);
    rto_raymarch_params p;
    rto_raymarch_params_default(vol, &p);
    float cv[13];
    for (int k = 0; !s && k < 13; k++) {
        double v;
        if (!rto_bundle_get_real(r, "camera", camera_keys[k], &v) || !(fabs(v) < 3e38))
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: camera.%s missing or not finite", dir,
                          camera_keys[k]);
        else
            cv[k] = (float)v;
    }
    int64_t env = 1;
    if (!s && !rto_bundle_get_int(r, "params", "envelope", &env))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: params.envelope missing", dir);
    rto_bundle_close(r);
    if (!s && (par.desc.dtype != RTO_DTYPE_F32 || par.desc.ndim != 1 || par.desc.shape[0] != 64))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: rm_params.npy is not f32 (64,)", dir);
    if (!s) {
        rto_raymarch_uniforms u;
        memcpy(&u, par.data, sizeof u);
        if (!(u.width >= 1 && u.width <= 16384 && u.height >= 1 && u.height <= 16384 &&
              u.num_refractions >= 0 && u.num_refractions <= 16 && u.width == floorf(u.width) &&
              u.height == floorf(u.height) && u.num_refractions == floorf(u.num_refractions)))
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: rm_params.npy: width, height or numRefractions out of range", dir);
        else {
            p.width = (uint32_t)u.width;
            p.height = (uint32_t)u.height;
            p.camera.position = (rto_vec3){cv[0], cv[1], cv[2]};
            p.camera.target = (rto_vec3){cv[3], cv[4], cv[5]};
            p.camera.up = (rto_vec3){cv[6], cv[7], cv[8]};
            p.camera.fov_y = cv[9];
            p.camera.aspect = cv[10];
            p.camera.znear = cv[11];
            p.camera.zfar = cv[12];
            p.step_size = u.step_size;
            p.light_step_size = u.light_step_size;
            p.density_offset = u.density_offset;
            p.density_multiplier = u.density_multiplier;
            memcpy(p.extinction, u.extinction, sizeof p.extinction);
            memcpy(p.sun_dir, u.sun_dir, sizeof p.sun_dir);
            p.ior = u.ior;
            p.num_refractions = (uint32_t)u.num_refractions;
            p.floor_height = u.floor_height;
            p.jitter_scale = u.jitter_scale;
            p.jitter_seed = u.jitter_seed;
            p.skip = u.skip != 0.0f;
            p.envelope = env != 0;
            p.threads = threads;
            s = rto_raymarch_make(vol, &p, ref, msg);
        }
    }
    if (!s && memcmp(&ref->uniforms, par.data, sizeof ref->uniforms))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: rm_params.npy is not what its parameters give", dir);
    const size_t n = (size_t)p.width * p.height;
    if (!s && (img.desc.dtype != RTO_DTYPE_F32 || img.nbytes != n * 4 * sizeof(float) ||
               memcmp(img.data, ref->image, img.nbytes)))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: rm_image.npy is not the raymarch of its volume and parameters", dir);
    if (!s && (cr.desc.dtype != RTO_DTYPE_U32 || cr.nbytes != n * sizeof(uint32_t) ||
               memcmp(cr.data, ref->crossing, cr.nbytes)))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: rm_crossing.npy is not the raymarch of its volume and parameters", dir);
    rto_npy_free(&par);
    rto_npy_free(&img);
    rto_npy_free(&cr);
    if (s) {
        rto_raymarch_free(ref);
        rto_splat_free(vol);
    }
    return s;
}
