/* The visibility buffer's bundle (DESIGN.md §8, §11): what a GPU harness of seed 004 uploads (the build bundle's
 * files, the scene's geometry, the camera block, each mesh's base colour, the material pass's parameters) and what
 * its visibility and material passes must write (the G-buffer planes, the edge mask, the image), with each sample's
 * admissible set; and the reader, which checks every array like a GPU dump before check-vbuffer uses it. */
#include "internal.h"
#include "io/bundle_in.h"
#include "raster/raster_internal.h"
#include "raster/texture_sample.h"

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

/* The texture mesh m's material samples for unlit (the scene's index), or -1: none, or a mesh without UVs. */
static int32_t scene_mesh_texture(const rto_scene *sc, uint32_t m)
{
    const int32_t mat = sc->meshes[m].material;
    if (mat < 0 || (uint32_t)mat >= sc->material_count || !sc->meshes[m].uvs)
        return -1;
    const int32_t t = sc->materials[mat].base_color_texture;
    return t >= 0 && (uint32_t)t < sc->texture_count ? t : -1;
}

/* unlit's inputs (§11.5): which texture each mesh samples (the bundle's numbering: the textures some mesh samples, in
 * order of first use), those meshes' UVs and each texture's sizes and mip chain as binary16 (what a GPU uploads). */
static rto_status write_textures(const rto_scene *sc, rto_bundle *b, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const uint32_t nm = sc->mesh_count;
    int32_t *mesh_tex = malloc((size_t)(nm ? nm : 1) * sizeof *mesh_tex);
    int32_t *bundle_of = malloc((size_t)(sc->texture_count ? sc->texture_count : 1) * sizeof *bundle_of);
    uint32_t *scene_of = malloc((size_t)(sc->texture_count ? sc->texture_count : 1) * sizeof *scene_of);
    uint32_t *sizes = malloc((size_t)(sc->texture_count ? sc->texture_count : 1) * 3 * sizeof *sizes);
    rto_status s = mesh_tex && bundle_of && scene_of && sizes ? RTO_OK
                                                             : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    uint32_t used = 0;
    for (uint32_t t = 0; !s && t < sc->texture_count; t++)
        bundle_of[t] = -1;
    for (uint32_t m = 0; !s && m < nm; m++) {
        const int32_t t = scene_mesh_texture(sc, m);
        if (t >= 0 && bundle_of[t] < 0) {
            scene_of[used] = (uint32_t)t;
            bundle_of[t] = (int32_t)used++;
        }
        mesh_tex[m] = t >= 0 ? bundle_of[t] : -1;
    }
    rto_npy_desc nd = rto_npy_desc_array(RTO_DTYPE_I32, 1, nm, 0, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_MESH_TEXTURES, &nd, mesh_tex, msg);
    for (uint32_t m = 0; !s && m < nm; m++) {
        if (mesh_tex[m] < 0)
            continue;
        nd = rto_npy_desc_array(RTO_DTYPE_F32, 2, sc->meshes[m].vertex_count, 2, 0);
        s = rto_bundle_add_npy(b, rto__bundle_name(RTO_FILE_MESH_UVS, m, name), rto_bundle_file_role(RTO_FILE_MESH_UVS),
                               NULL, &nd, sc->meshes[m].uvs, msg);
    }
    for (uint32_t t = 0; !s && t < used; t++) {
        rto__vb_mips mips;
        s = rto__vb_mips_make(&sc->textures[scene_of[t]], &mips, msg);
        if (s)
            break;
        sizes[3 * t] = mips.width[0];
        sizes[3 * t + 1] = mips.height[0];
        sizes[3 * t + 2] = mips.levels;
        uint16_t *h = malloc(4 * mips.texels * sizeof *h);
        if (!h)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        for (size_t i = 0; !s && i < 4 * mips.texels; i++)
            h[i] = rto_f16_from_f32(mips.rgba[i]); /* exact: the chain holds binary16 values */
        nd = rto_npy_desc_array(RTO_DTYPE_F16, 2, mips.texels, 4, 0);
        if (!s)
            s = rto_bundle_add_npy(b, rto__bundle_name(RTO_FILE_VB_TEXTURE, t, name),
                                   rto_bundle_file_role(RTO_FILE_VB_TEXTURE), NULL, &nd, h, msg);
        free(h);
        rto__vb_mips_free(&mips);
    }
    nd = rto_npy_desc_array(RTO_DTYPE_U32, 2, used, 3, 0);
    if (!s)
        s = add(b, RTO_FILE_VB_TEXTURES, &nd, sizes, msg);
    free(mesh_tex);
    free(bundle_of);
    free(scene_of);
    free(sizes);
    return s;
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
    if (!s && d->material->material == RTO_VB_UNLIT)
        s = write_textures(sc, b, msg);
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
    rto_npy mesh_textures; /* unlit: vb_mesh_textures.npy */
    rto_npy *uvs;          /* unlit: mesh_M_uvs.npy of the meshes that sample a texture (one slot a mesh) */
    rto_texture *textures; /* unlit: each texture's level 0 as RGBA8 */
    uint32_t texture_count;
};

/* A number of the manifest's vbuffer section within [lo, hi] (what `rtoracle vbuffer` accepts for it). */
static rto_status read_real(const rto__bundle_in *in, const char *key, double lo, double hi, float *out)
{
    double v = 0.0;
    if (!rto_bundle_get_real(in->r, "vbuffer", key, &v) || !(v >= lo && v <= hi))
        return rto__bundle_refuse(in, "manifest.json", "vbuffer.%s is missing or outside [%g, %g]", key, lo, hi);
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

/* unlit's textures (write_textures): the mesh → texture table in range, each sampling mesh's UVs (V, 2) finite, each
 * texture's chain of the sizes vb_textures.npy gives, its level 0 the binary16 of an 8-bit value / 255 and every
 * level the box filter of the one before (rto__vb_mips_make on level 0 gives the file back bit for bit). The
 * meshes' uvs and one material each (base_color_texture) point into what this reads. */
static rto_status read_textures(const rto__bundle_in *in, rto_vbuffer_bundle *vb, struct rto_vbuffer_bundle_data *a)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const uint32_t nm = vb->geometry.mesh_count;
    rto_npy sizes;
    memset(&sizes, 0, sizeof sizes);
    rto_npy_desc want = rto_npy_desc_array(RTO_DTYPE_I32, 1, nm, 0, 0);
    rto_status s = rto__bundle_load(in, rto__bundle_name(RTO_FILE_VB_MESH_TEXTURES, 0, name), &want, NULL,
                                    &a->mesh_textures);
    want = rto_npy_desc_array(RTO_DTYPE_U32, 2, UINT64_MAX, 3, 0);
    if (!s)
        s = rto__bundle_load(in, rto__bundle_name(RTO_FILE_VB_TEXTURES, 0, name), &want, NULL, &sizes);
    if (s)
        return s;
    const uint64_t T = sizes.desc.shape[0];
    const uint32_t *sz = sizes.data;
    const int32_t *mt = a->mesh_textures.data;
    if (T > 65536)
        s = rto__bundle_refuse(in, "vb_textures.npy", "%" PRIu64 " textures (at most 65536)", T);
    for (uint32_t m = 0; !s && m < nm; m++)
        if (mt[m] < -1 || (mt[m] >= 0 && (uint64_t)mt[m] >= T))
            s = rto__bundle_refuse(in, "vb_mesh_textures.npy", "mesh %" PRIu32 " samples texture %" PRId32
                                   " of %" PRIu64, m, mt[m], T);
    for (uint64_t t = 0; !s && t < T; t++)
        if (sz[3 * t] == 0 || sz[3 * t + 1] == 0 || sz[3 * t] > 16384 || sz[3 * t + 1] > 16384 ||
            sz[3 * t + 2] != rto__vb_mip_levels(sz[3 * t], sz[3 * t + 1]))
            s = rto__bundle_refuse(in, "vb_textures.npy", "texture %" PRIu64 ": %" PRIu32 "x%" PRIu32 " with %" PRIu32
                                   " levels (sides 1 to 16384, floor(log2(max side)) + 1 levels)", t, sz[3 * t],
                                   sz[3 * t + 1], sz[3 * t + 2]);
    a->uvs = s ? NULL : calloc(nm ? nm : 1, sizeof *a->uvs);
    a->textures = s ? NULL : calloc(T ? T : 1, sizeof *a->textures);
    if (!s && (!a->uvs || !a->textures))
        s = rto__fail(in->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t m = 0; !s && m < nm; m++) {
        if (mt[m] < 0)
            continue;
        want = rto_npy_desc_array(RTO_DTYPE_F32, 2, a->meshes[m].vertex_count, 2, 0);
        s = rto__bundle_load(in, rto__bundle_name(RTO_FILE_MESH_UVS, m, name), &want, NULL, &a->uvs[m]);
        if (!s && !rto__all_finite(a->uvs[m].data, 2 * (size_t)a->meshes[m].vertex_count))
            s = rto__bundle_refuse(in, name, "a texture coordinate is not finite");
        if (!s)
            a->meshes[m].uvs = a->uvs[m].data;
    }
    for (uint64_t t = 0; !s && t < T; t++) {
        rto_texture *tx = &a->textures[t];
        tx->width = sz[3 * t];
        tx->height = sz[3 * t + 1];
        snprintf(tx->name, sizeof tx->name, "vb_texture_%" PRIu64, t);
        const size_t n0 = (size_t)tx->width * tx->height;
        size_t texels = 0;
        for (uint32_t l = 0; l < sz[3 * t + 2]; l++)
            texels += (size_t)(tx->width >> l ? tx->width >> l : 1) * (tx->height >> l ? tx->height >> l : 1);
        rto_npy lv;
        want = rto_npy_desc_array(RTO_DTYPE_F16, 2, texels, 4, 0);
        s = rto__bundle_load(in, rto__bundle_name(RTO_FILE_VB_TEXTURE, (uint32_t)t, name), &want, NULL, &lv);
        if (s)
            break;
        a->texture_count = (uint32_t)t + 1;
        const uint16_t *h = lv.data;
        tx->rgba = malloc(4 * n0);
        if (!tx->rgba)
            s = rto__fail(in->msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        for (size_t i = 0; !s && i < 4 * n0; i++) {
            const float v = rto_f16_to_f32(h[i]);
            const float q = v * 255.0f;
            const int byte = v >= 0.0f && v <= 1.0f ? (int)lrintf(q) : -1;
            if (byte < 0 || rto_f16_from_f32((float)byte / 255.0f) != h[i])
                s = rto__bundle_refuse(in, name, "level 0, texel %zu channel %zu holds %.9g (0x%04x), not the binary16 "
                                       "of an 8-bit value / 255", i / 4, i % 4, (double)v, h[i]);
            else
                tx->rgba[i] = (uint8_t)byte;
        }
        rto__vb_mips mips;
        if (!s && !(s = rto__vb_mips_make(tx, &mips, in->msg))) {
            for (size_t i = 4 * n0; !s && i < 4 * texels; i++)
                if (rto_f16_from_f32(mips.rgba[i]) != h[i]) {
                    uint32_t l = 0;
                    while (l + 1 < mips.levels && mips.offset[l + 1] <= i / 4)
                        l++;
                    s = rto__bundle_refuse(in, name, "level %" PRIu32 ", texel %zu channel %zu holds %.9g, but the 2x2 "
                                           "box filter of level %" PRIu32 " gives %.9g", l, i / 4 - mips.offset[l],
                                           i % 4, (double)rto_f16_to_f32(h[i]), l - 1, (double)mips.rgba[i]);
                }
            rto__vb_mips_free(&mips);
        }
        rto_npy_free(&lv);
    }
    rto_npy_free(&sizes);
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
    if (!s && !(s = read_real(&in, "threshold_normal", 0.0, 1.0, &m->thresholds.normal)) &&
        !(s = read_real(&in, "threshold_depth", 0.0, 1e30, &m->thresholds.depth)) &&
        !(s = read_real(&in, "threshold_sample_depth", 0.0, 1e30, &m->thresholds.sample_depth)) &&
        !(s = read_real(&in, "sun_x", -1e30, 1e30, &m->sun[0])) &&
        !(s = read_real(&in, "sun_y", -1e30, 1e30, &m->sun[1])) &&
        !(s = read_real(&in, "sun_z", -1e30, 1e30, &m->sun[2])))
        s = read_real(&in, "ambient", 0.0, 1.0, &m->ambient);
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
    if (!s && m->material == RTO_VB_UNLIT)
        s = read_textures(&in, vb, a);
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
        a->materials[k].base_color_texture = a->mesh_textures.data ? ((const int32_t *)a->mesh_textures.data)[k] : -1;
    }
    m->materials = a->materials;
    m->material_count = vb->geometry.mesh_count;
    m->textures = a->textures;
    m->texture_count = a->texture_count;
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
        rto_npy_free(&a->mesh_textures);
        for (uint32_t k = 0; a->uvs && k < vb->scene.mesh_count; k++)
            rto_npy_free(&a->uvs[k]);
        free(a->uvs);
        for (uint32_t t = 0; a->textures && t < a->texture_count; t++)
            free(a->textures[t].rgba);
        free(a->textures);
        free(a);
    }
    rto_scene_bundle_free(&vb->scene);
    memset(vb, 0, sizeof *vb);
}
