/* The visibility buffer's bundle (DESIGN.md §8, §11): what a GPU harness of seed 004 uploads (the build bundle's
 * files, the scene's geometry, the camera block, each mesh's base colour, the material pass's parameters) and what
 * its visibility and material passes must write (the G-buffer planes, the edge mask, the image), with each sample's
 * admissible set; and the reader, which checks every array like a GPU dump before check-vbuffer uses it. */
#include "internal.h"
#include "io/bundle_in.h"
#include "raster/raster_internal.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const material_names[] = {"normals", "lambert", "unlit"};

int rto_vb_material_parse(const char *name, rto_vb_material *out)
{
    for (int m = 0; name && m < 3; m++)
        if (strcmp(name, material_names[m]) == 0) {
            *out = (rto_vb_material)m;
            return 1;
        }
    return 0;
}

const char *rto_vb_material_name(rto_vb_material material)
{
    return (unsigned)material < 3 ? material_names[material] : NULL;
}

/* An array of up to four dimensions (rto_npy_desc_array takes three). */
static rto_npy_desc array4(rto_dtype t, uint32_t ndim, uint64_t d0, uint64_t d1, uint64_t d2, uint64_t d3)
{
    rto_npy_desc d = rto_npy_desc_array(t, ndim < 3 ? ndim : 3, d0, d1, d2);
    if (ndim == 4) {
        d.ndim = 4;
        d.shape[3] = d3;
    }
    return d;
}

static rto_status add(rto_bundle *b, rto_bundle_file f, const rto_npy_desc *d, const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    return rto_bundle_add_npy(b, rto__bundle_name(f, 0, name), rto_bundle_file_role(f), NULL, d, data, msg);
}

rto_status rto_vbuffer_bundle_write(const rto_vbuffer_bundle_desc *d, rto_bundle *b, rto_msg *msg)
{
    if (!d || !b || !d->accel || !d->vbuffer || !d->material || !d->material_name || !d->mask || !d->image)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "incomplete vbuffer bundle description");
    const rto_scene *sc = rto_accel_scene(d->accel);
    const rto_vbuffer *vb = d->vbuffer;
    const rto_vbuffer_planes *p = &vb->planes;
    const uint64_t H = p->height, W = p->width, S = p->samples, n = H * W * S;
    float *colors = malloc((size_t)(sc->mesh_count ? sc->mesh_count : 1) * 4 * sizeof *colors);
    if (!colors)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        const int32_t mat = sc->meshes[m].material;
        for (int a = 0; a < 4; a++)
            colors[4 * m + a] = mat >= 0 && (uint32_t)mat < sc->material_count ? sc->materials[mat].base_color[a] : 1.0f;
    }
    rto_status s = rto_bvh_bundle_write(d->accel, b, msg);
    if (!s)
        s = rto_scene_bundle_write(sc, b, msg);
    rto_npy_desc nd = rto_npy_desc_array(RTO_DTYPE_F32, 1, 36, 0, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_CAMERA, &nd, &vb->camera, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_F32, 2, sc->mesh_count, 4, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_BASE_COLORS, &nd, colors, msg);
    free(colors);
    nd = array4(RTO_DTYPE_U16, 4, H, W, S, 4);
    if (!s)
        s = add(b, RTO_FILE_VB_VISIBILITY, &nd, p->visibility, msg);
    nd = array4(RTO_DTYPE_F16, 4, H, W, S, 2);
    if (!s)
        s = add(b, RTO_FILE_VB_BARYCENTRIC, &nd, p->barycentric, msg);
    nd = array4(RTO_DTYPE_F16, 4, H, W, S, 4);
    if (!s)
        s = add(b, RTO_FILE_VB_NORMAL, &nd, p->normal, msg);
    if (!s)
        s = add(b, RTO_FILE_VB_DERIVATIVES, &nd, p->derivatives, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_F32, 3, H, W, S);
    if (!s)
        s = add(b, RTO_FILE_VB_DEPTH, &nd, p->depth, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_U32, 3, H, W, S);
    if (!s)
        s = add(b, RTO_FILE_VB_DEPTH_UNORM24, &nd, p->depth_unorm24, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_U32, 1, n + 1, 0, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_ADMISSIBLE_OFFSETS, &nd, vb->admissible_offset, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_U32, 2, vb->admissible_offset[n], 2, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_ADMISSIBLE, &nd, vb->admissible, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_U8, 2, H, W, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_EDGE_MASK, &nd, d->mask, msg);
    nd = rto_npy_desc_array(RTO_DTYPE_F16, 3, H, W, 4);
    if (!s)
        s = add(b, RTO_FILE_VB_IMAGE, &nd, d->image, msg);
    if (s)
        return s;
    const rto_vbuffer_material_desc *m = d->material;
    const rto_vbuffer_stats *st = &vb->stats;
    rto_bundle_set_int(b, "vbuffer", "width", (int64_t)W);
    rto_bundle_set_int(b, "vbuffer", "height", (int64_t)H);
    rto_bundle_set_int(b, "vbuffer", "samples", (int64_t)S);
    if (m->material == RTO_VB_PLUGIN) {
        rto_bundle_set_str(b, "vbuffer", "material", "plugin");
        rto_bundle_set_str(b, "vbuffer", "material_plugin", d->material_name);
    } else {
        rto_bundle_set_str(b, "vbuffer", "material", d->material_name);
    }
    rto_bundle_set_real(b, "vbuffer", "threshold_normal", (double)m->thresholds.normal);
    rto_bundle_set_real(b, "vbuffer", "threshold_depth", (double)m->thresholds.depth);
    rto_bundle_set_real(b, "vbuffer", "threshold_sample_depth", (double)m->thresholds.sample_depth);
    rto_bundle_set_real(b, "vbuffer", "sun_x", (double)m->sun[0]);
    rto_bundle_set_real(b, "vbuffer", "sun_y", (double)m->sun[1]);
    rto_bundle_set_real(b, "vbuffer", "sun_z", (double)m->sun[2]);
    rto_bundle_set_real(b, "vbuffer", "ambient", (double)m->ambient);
    uint64_t edges = 0;
    for (uint64_t k = 0; k < H * W; k++)
        edges += d->mask[k] != 0;
    rto_bundle_set_int(b, "vbuffer", "edge_pixels", (int64_t)edges);
    rto_bundle_set_int(b, "admissible", "samples", (int64_t)st->samples);
    rto_bundle_set_int(b, "admissible", "covered", (int64_t)st->covered);
    rto_bundle_set_int(b, "admissible", "certain", (int64_t)st->certain);
    rto_bundle_set_int(b, "admissible", "uncertain", (int64_t)st->uncertain);
    rto_bundle_set_int(b, "admissible", "max_set", (int64_t)st->max_set);
    static const char *const sizes[5] = {"sets_of_1", "sets_of_2", "sets_of_3", "sets_of_4", "sets_of_5_or_more"};
    for (int k = 0; k < 5; k++)
        rto_bundle_set_int(b, "admissible", sizes[k], (int64_t)st->set_sizes[k]);
    rto_bundle_set_int(b, "admissible", "clipped_triangles", (int64_t)st->clipped_triangles);
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Reading                                                                                                          */

enum { A_CAMERA, A_COLORS, A_VIS, A_BARY, A_NORMAL, A_DERIV, A_DEPTH, A_U24, A_OFFSETS, A_ADM, A_MASK, A_IMAGE, A_N };

struct rto_vbuffer_bundle_data {
    rto_npy arrays[A_N];
    rto_mesh *meshes;
    rto_material *materials;
};

static rto_status read_real(const rto__bundle_in *in, const char *key, float *out)
{
    double v = 0.0;
    if (!rto_bundle_get_real(in->r, "vbuffer", key, &v) || !isfinite(v) || fabs(v) > 1e30)
        return rto__bundle_refuse(in, "manifest.json", "vbuffer.%s is missing or not a finite number", key);
    *out = (float)v;
    return RTO_OK;
}

/* Every visibility ID background or an existing triangle of an existing instance. */
static rto_status check_ids(const rto__bundle_in *in, const rto_vbuffer_geometry *g, const uint32_t *pairs, size_t n,
                            const char *file)
{
    for (size_t k = 0; k < n; k++) {
        const uint32_t inst = pairs[2 * k], prim = pairs[2 * k + 1];
        if (inst == RTO_VB_BACKGROUND && prim == RTO_VB_BACKGROUND)
            continue;
        if (inst >= g->instance_count || prim >= g->meshes[g->instances[inst].blas].triangle_count)
            return rto__bundle_refuse(in, file, "entry %zu names triangle %" PRIu32 " of instance %" PRIu32
                                      ", which the scene does not have", k, prim, inst);
    }
    return RTO_OK;
}

static rto_status read_arrays(const rto__bundle_in *in, rto_vbuffer_bundle *vb, struct rto_vbuffer_bundle_data *a,
                              uint64_t H, uint64_t W, uint64_t S)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const uint64_t n = H * W * S;
    const struct {
        rto_bundle_file f;
        rto_npy_desc d;
    } files[A_N] = {
        [A_CAMERA] = {RTO_FILE_VB_CAMERA, rto_npy_desc_array(RTO_DTYPE_F32, 1, 36, 0, 0)},
        [A_COLORS] = {RTO_FILE_VB_BASE_COLORS, rto_npy_desc_array(RTO_DTYPE_F32, 2, vb->geometry.mesh_count, 4, 0)},
        [A_VIS] = {RTO_FILE_VB_VISIBILITY, array4(RTO_DTYPE_U16, 4, H, W, S, 4)},
        [A_BARY] = {RTO_FILE_VB_BARYCENTRIC, array4(RTO_DTYPE_F16, 4, H, W, S, 2)},
        [A_NORMAL] = {RTO_FILE_VB_NORMAL, array4(RTO_DTYPE_F16, 4, H, W, S, 4)},
        [A_DERIV] = {RTO_FILE_VB_DERIVATIVES, array4(RTO_DTYPE_F16, 4, H, W, S, 4)},
        [A_DEPTH] = {RTO_FILE_VB_DEPTH, rto_npy_desc_array(RTO_DTYPE_F32, 3, H, W, S)},
        [A_U24] = {RTO_FILE_VB_DEPTH_UNORM24, rto_npy_desc_array(RTO_DTYPE_U32, 3, H, W, S)},
        [A_OFFSETS] = {RTO_FILE_VB_ADMISSIBLE_OFFSETS, rto_npy_desc_array(RTO_DTYPE_U32, 1, n + 1, 0, 0)},
        [A_ADM] = {RTO_FILE_VB_ADMISSIBLE, rto_npy_desc_array(RTO_DTYPE_U32, 2, UINT64_MAX, 2, 0)},
        [A_MASK] = {RTO_FILE_VB_EDGE_MASK, rto_npy_desc_array(RTO_DTYPE_U8, 2, H, W, 0)},
        [A_IMAGE] = {RTO_FILE_VB_IMAGE, rto_npy_desc_array(RTO_DTYPE_F16, 3, H, W, 4)},
    };
    for (int k = 0; k < A_N; k++) {
        rto_status s = rto__bundle_load(in, rto__bundle_name(files[k].f, 0, name), &files[k].d, NULL, &a->arrays[k]);
        if (s)
            return s;
    }
    if (!rto__all_finite(a->arrays[A_CAMERA].data, 36))
        return rto__bundle_refuse(in, "vb_camera.npy", "a matrix element is not finite");
    if (!rto__all_finite(a->arrays[A_COLORS].data, 4 * (size_t)vb->geometry.mesh_count))
        return rto__bundle_refuse(in, "vb_base_colors.npy", "a base colour is not finite");
    const float *depth = a->arrays[A_DEPTH].data;
    for (uint64_t k = 0; k < n; k++)
        if (!(depth[k] >= 0.0f && depth[k] <= 1.0f))
            return rto__bundle_refuse(in, "vb_depth.npy", "sample %" PRIu64 " holds %g, outside [0, 1]", k,
                                      (double)depth[k]);
    const uint32_t *off = a->arrays[A_OFFSETS].data;
    const uint64_t rows = a->arrays[A_ADM].desc.shape[0];
    if (off[0] != 0 || off[n] != rows)
        return rto__bundle_refuse(in, "vb_admissible_offsets.npy", "offsets run from %" PRIu32 " to %" PRIu32
                                  " over %" PRIu64 " admissible entries", off[0], off[n], rows);
    for (uint64_t k = 0; k < n; k++)
        if (off[k + 1] <= off[k])
            return rto__bundle_refuse(in, "vb_admissible_offsets.npy", "sample %" PRIu64 " has an empty set", k);
    rto_status s = check_ids(in, &vb->geometry, a->arrays[A_ADM].data, (size_t)rows, "vb_admissible.npy");
    const uint16_t *vis = a->arrays[A_VIS].data;
    uint32_t pair[2];
    for (uint64_t k = 0; !s && k < n; k++) {
        pair[0] = (uint32_t)vis[4 * k + 2] | (uint32_t)vis[4 * k + 3] << 16;
        pair[1] = (uint32_t)vis[4 * k] | (uint32_t)vis[4 * k + 1] << 16;
        s = check_ids(in, &vb->geometry, pair, 1, "vb_visibility.npy");
    }
    const uint8_t *mask = a->arrays[A_MASK].data;
    for (uint64_t k = 0; !s && k < H * W; k++)
        if (mask[k] > 1)
            s = rto__bundle_refuse(in, "vb_edge_mask.npy", "pixel %" PRIu64 " holds %u; the mask is 0 or 1", k,
                                   mask[k]);
    return s;
}

rto_status rto_vbuffer_bundle_read(const char *dir, rto_vbuffer_bundle *vb, rto_msg *msg)
{
    if (!vb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL vbuffer bundle");
    memset(vb, 0, sizeof *vb);
    struct rto_vbuffer_bundle_data *a = calloc(1, sizeof *a);
    if (!a)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    vb->data = a;
    rto__bundle_in in;
    size_t W = 0, H = 0, S = 0;
    rto_status s = rto__bundle_in_open(&in, dir, "vbuffer", "vbuffer", msg);
    if (!s && !(s = rto__bundle_count(&in, "vbuffer", "width", 16384, &W)) &&
        !(s = rto__bundle_count(&in, "vbuffer", "height", 16384, &H)) &&
        !(s = rto__bundle_count(&in, "vbuffer", "samples", 4, &S)) && (W == 0 || H == 0 || (S != 1 && S != 4)))
        s = rto__bundle_refuse(&in, "manifest.json", "vbuffer %zux%zu with %zu samples: sizes from 1 and 1 or 4 samples",
                               W, H, S);
    rto_vbuffer_material_desc *m = &vb->material;
    const char *mname = s ? NULL : rto_bundle_get_str(in.r, "vbuffer", "material");
    if (!s && mname && strcmp(mname, "plugin") == 0) {
        const char *pname = rto_bundle_get_str(in.r, "vbuffer", "material_plugin");
        m->material = RTO_VB_PLUGIN;
        if (!pname || !*pname || strlen(pname) >= sizeof vb->plugin_name)
            s = rto__bundle_refuse(&in, "manifest.json", "vbuffer.material_plugin is missing or too long");
        else
            snprintf(vb->plugin_name, sizeof vb->plugin_name, "%s", pname);
    } else if (!s && !rto_vb_material_parse(mname, &m->material)) {
        s = rto__bundle_refuse(&in, "manifest.json", "vbuffer.material is not normals, lambert, unlit or plugin");
    }
    if (!s)
        snprintf(vb->material_name, sizeof vb->material_name, "%s", mname);
    if (!s && !(s = read_real(&in, "threshold_normal", &m->thresholds.normal)) &&
        !(s = read_real(&in, "threshold_depth", &m->thresholds.depth)) &&
        !(s = read_real(&in, "threshold_sample_depth", &m->thresholds.sample_depth)) &&
        !(s = read_real(&in, "sun_x", &m->sun[0])) && !(s = read_real(&in, "sun_y", &m->sun[1])) &&
        !(s = read_real(&in, "sun_z", &m->sun[2])))
        s = read_real(&in, "ambient", &m->ambient);
    if (!s)
        s = rto_scene_bundle_read(dir, &vb->scene, msg);
    if (!s) {
        const uint32_t nm = vb->scene.mesh_count;
        a->meshes = malloc((size_t)(nm ? nm : 1) * sizeof *a->meshes);
        a->materials = malloc((size_t)(nm ? nm : 1) * sizeof *a->materials);
        if (!a->meshes || !a->materials)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t k = 0; !s && k < nm; k++) {
            a->meshes[k] = vb->scene.meshes[k];
            a->meshes[k].material = (int32_t)k; /* each mesh its own base colour */
        }
        vb->geometry = (rto_vbuffer_geometry){a->meshes, nm, vb->scene.instances, vb->scene.instance_count};
    }
    if (!s)
        s = read_arrays(&in, vb, a, H, W, S);
    rto__bundle_in_close(&in);
    if (s) {
        rto_vbuffer_bundle_free(vb);
        return s;
    }
    memcpy(&vb->camera, a->arrays[A_CAMERA].data, sizeof vb->camera);
    const float *colors = a->arrays[A_COLORS].data;
    for (uint32_t k = 0; k < vb->geometry.mesh_count; k++) {
        memset(&a->materials[k], 0, sizeof a->materials[k]);
        memcpy(a->materials[k].base_color, colors + 4 * (size_t)k, 4 * sizeof *colors);
        a->materials[k].base_color_texture = -1;
    }
    m->materials = a->materials;
    m->material_count = vb->geometry.mesh_count;
    vb->planes = (rto_vbuffer_planes){(uint32_t)W,           (uint32_t)H,           (uint32_t)S,
                                      a->arrays[A_VIS].data, a->arrays[A_BARY].data, a->arrays[A_NORMAL].data,
                                      a->arrays[A_DERIV].data, a->arrays[A_DEPTH].data, a->arrays[A_U24].data};
    vb->admissible_offset = a->arrays[A_OFFSETS].data;
    vb->admissible = a->arrays[A_ADM].data;
    vb->mask = a->arrays[A_MASK].data;
    vb->image = a->arrays[A_IMAGE].data;
    return RTO_OK;
}

void rto_vbuffer_bundle_free(rto_vbuffer_bundle *vb)
{
    if (!vb)
        return;
    struct rto_vbuffer_bundle_data *a = vb->data;
    if (a) {
        for (int k = 0; k < A_N; k++)
            rto_npy_free(&a->arrays[k]);
        free(a->meshes);
        free(a->materials);
        free(a);
    }
    rto_scene_bundle_free(&vb->scene);
    memset(vb, 0, sizeof *vb);
}
