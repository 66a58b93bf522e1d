/* A scene's geometry as a GPU uploads it, to and from a bundle (DESIGN.md §8): mesh_M_positions.npy and
 * mesh_M_indices.npy per mesh, with the build bundle's instances.npy. Read back once, validated once, for every check
 * that intersects the bundle's triangles (check-hits, check-frame). */
#include "io/bundle_in.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

rto_status rto_scene_bundle_write(const rto_scene *sc, rto_bundle *b, rto_msg *msg)
{
    if (!sc || !b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene or bundle");
    rto_status s = RTO_OK;
    for (uint32_t m = 0; m < sc->mesh_count && !s; m++) {
        const rto_mesh *mesh = &sc->meshes[m];
        char name[RTO_BUNDLE_FILE_NAME_MAX];
        rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_F32, 2, mesh->vertex_count, 3, 0);
        s = rto_bundle_add_npy(b, rto__bundle_name(RTO_FILE_MESH_POSITIONS, m, name),
                               rto_bundle_file_role(RTO_FILE_MESH_POSITIONS), NULL, &d, mesh->positions, msg);
        d = rto_npy_desc_array(RTO_DTYPE_U32, 2, mesh->triangle_count, 3, 0);
        if (!s)
            s = rto_bundle_add_npy(b, rto__bundle_name(RTO_FILE_MESH_INDICES, m, name),
                                   rto_bundle_file_role(RTO_FILE_MESH_INDICES), NULL, &d, mesh->indices, msg);
    }
    return s;
}

struct rto_scene_bundle_data {
    rto_npy inst;
    rto_npy *mesh_npy; /* 2 per mesh: positions, indices */
    rto_mesh *meshes;
    uint32_t mesh_count, mesh_cap;
    rto_instance *instances;
};

void rto_scene_bundle_free(rto_scene_bundle *sb)
{
    if (!sb)
        return;
    struct rto_scene_bundle_data *d = sb->data;
    if (d) {
        rto_npy_free(&d->inst);
        for (uint32_t m = 0; m < d->mesh_count; m++) {
            rto_npy_free(&d->mesh_npy[2 * m]);
            rto_npy_free(&d->mesh_npy[2 * m + 1]);
        }
        free(d->mesh_npy);
        free(d->meshes);
        free(d->instances);
        free(d);
    }
    memset(sb, 0, sizeof *sb);
}

/* mesh_M_positions.npy (f32 (V, 3), finite) and mesh_M_indices.npy (u32 (T, 3), T = the manifest's blas_M.triangles,
 * every index < V). The mesh array grows as files are found, so a manifest claiming millions of meshes costs nothing
 * before its first missing file. */
static rto_status load_mesh(const rto__bundle_in *in, struct rto_scene_bundle_data *a, uint32_t m)
{
    if (m == a->mesh_cap) {
        const uint32_t cap = a->mesh_cap ? 2 * a->mesh_cap : 16;
        rto_mesh *meshes = realloc(a->meshes, (size_t)cap * sizeof *meshes);
        if (meshes)
            a->meshes = meshes;
        rto_npy *npy = realloc(a->mesh_npy, 2 * (size_t)cap * sizeof *npy);
        if (npy)
            a->mesh_npy = npy;
        if (!meshes || !npy)
            return rto__fail(in->msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", in->dir);
        a->mesh_cap = cap;
    }
    rto_npy *pos = &a->mesh_npy[2 * m], *idx = &a->mesh_npy[2 * m + 1];
    memset(pos, 0, sizeof *pos);
    memset(idx, 0, sizeof *idx);
    a->mesh_count = m + 1; /* owned from here on: freed with the others */
    char section[32], pname[RTO_BUNDLE_FILE_NAME_MAX], iname[RTO_BUNDLE_FILE_NAME_MAX];
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    size_t t = 0;
    rto_status s = rto__bundle_count(in, section, "triangles", UINT32_MAX, &t);
    if (s)
        return s;
    rto__bundle_name(RTO_FILE_MESH_POSITIONS, m, pname);
    rto__bundle_name(RTO_FILE_MESH_INDICES, m, iname);
    rto_npy_desc pd = rto_npy_desc_array(RTO_DTYPE_F32, 2, UINT64_MAX, 3, 0);
    rto_npy_desc id = rto_npy_desc_array(RTO_DTYPE_U32, 2, t, 3, 0);
    if ((s = rto__bundle_load(in, pname, &pd, NULL, pos)) || (s = rto__bundle_load(in, iname, &id, NULL, idx)))
        return s;
    const uint64_t v = pos->desc.shape[0];
    if (v > UINT32_MAX)
        return rto__bundle_refuse(in, pname, "%" PRIu64 " vertices: more than a mesh can index", v);
    if (!rto__all_finite(pos->data, 3 * (size_t)v))
        return rto__bundle_refuse(in, pname, "a vertex position is not finite");
    const uint32_t *ix = idx->data;
    for (size_t k = 0; k < 3 * t; k++)
        if (ix[k] >= v)
            return rto__bundle_refuse(in, iname,
                                      "triangle %zu names vertex %" PRIu32 "; the mesh has %" PRIu64 " vertices (%s)",
                                      k / 3, ix[k], v, pname);
    rto_mesh *mesh = &a->meshes[m];
    memset(mesh, 0, sizeof *mesh);
    snprintf(mesh->name, sizeof mesh->name, "mesh %" PRIu32, m);
    mesh->vertex_count = (uint32_t)v;
    mesh->positions = pos->data;
    mesh->triangle_count = (uint32_t)t;
    mesh->indices = idx->data;
    mesh->material = -1;
    return RTO_OK;
}

/* instances.npy: each record's BLAS exists, both transforms are finite, customIndex and mask within their bits. */
static rto_status load_instances(const rto__bundle_in *in, struct rto_scene_bundle_data *a, size_t n)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_name(RTO_FILE_INSTANCES, 0, name);
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_INSTANCE, n);
    rto_status s = rto__bundle_load(in, name, &want, rto_layout_name(RTO_LAYOUT_INSTANCE), &a->inst);
    if (s)
        return s;
    a->instances = rto__alloc(n, sizeof *a->instances);
    if (!a->instances)
        return rto__fail(in->msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory", in->dir);
    for (size_t i = 0; i < n; i++) {
        rto_instance_record rec; /* the array's records are this struct's bytes (rto_layout_desc) */
        memcpy(&rec, (const unsigned char *)a->inst.data + i * sizeof rec, sizeof rec);
        if (rec.blas >= a->mesh_count)
            return rto__bundle_refuse(in, name, "instance %zu names BLAS %" PRIu32 "; the bundle has %" PRIu32 " meshes",
                                      i, rec.blas, a->mesh_count);
        if (!rto__all_finite(&rec.obj_to_world[0][0], 12) || !rto__all_finite(&rec.world_to_obj[0][0], 12))
            return rto__bundle_refuse(in, name, "a transform of instance %zu is not finite", i);
        if (rec.custom_index > RTO_INSTANCE_CUSTOM_INDEX_MASK || rec.mask > 0xFFu)
            return rto__bundle_refuse(in, name,
                                      "instance %zu has customIndex 0x%" PRIx32 " or mask 0x%" PRIx32
                                      " outside their 24 / 8 bits",
                                      i, rec.custom_index, rec.mask);
        a->instances[i] = rto_instance_from_record(&rec);
    }
    return RTO_OK;
}

rto_status rto_scene_bundle_read(const char *dir, rto_scene_bundle *sb, rto_msg *msg)
{
    if (!sb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene bundle");
    memset(sb, 0, sizeof *sb);
    struct rto_scene_bundle_data *a = calloc(1, sizeof *a);
    if (!a)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    sb->data = a;
    rto__bundle_in in;
    size_t meshes = 0, instances = 0;
    rto_status s = rto__bundle_in_open(&in, dir, NULL, NULL, msg);
    if (!s && !(s = rto__bundle_count(&in, "counts", "meshes", UINT32_MAX, &meshes)))
        s = rto__bundle_count(&in, "counts", "instances", RTO_TLAS_MAX_INSTANCES, &instances);
    for (uint32_t m = 0; !s && m < meshes; m++)
        s = load_mesh(&in, a, m);
    if (!s)
        s = load_instances(&in, a, instances);
    rto__bundle_in_close(&in);
    if (s) {
        rto_scene_bundle_free(sb);
        return s;
    }
    sb->meshes = a->meshes;
    sb->mesh_count = a->mesh_count;
    sb->instances = a->instances;
    sb->instance_count = (uint32_t)instances;
    return RTO_OK;
}
