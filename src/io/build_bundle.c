/* A build bundle (DESIGN.md §8) from an accel: every array through the accel's views, in the GPU layouts of
 * layouts.c, under the file names and roles named there, with the counts and tree statistics in the manifest. The
 * order of files and manifest fields is part of the output bytes: keep it. */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>

static rto_status manifest_fail(rto_msg *msg)
{
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "cannot add a field to the manifest (out of memory, or text that "
                    "is not UTF-8)");
}

static rto_status add(rto_bundle *b, rto_bundle_file f, uint32_t mesh, const char *layout, const rto_npy_desc *d,
                      const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    if (rto_bundle_file_name(f, mesh, name, sizeof name))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no name for bundle file %d", (int)f);
    return rto_bundle_add_npy(b, name, rto_bundle_file_role(f), layout, d, data, msg);
}

static rto_status add_layout(rto_bundle *b, rto_bundle_file f, uint32_t mesh, rto_layout l, size_t n,
                             const void *data, rto_msg *msg)
{
    rto_npy_desc d = rto_layout_desc(l, n);
    return add(b, f, mesh, rto_layout_name(l), &d, data, msg);
}

static rto_status add_keys(rto_bundle *b, rto_bundle_file f, uint32_t mesh, rto_key_format kf, size_t n,
                           const void *data, rto_msg *msg)
{
    rto_npy_desc d = rto_npy_desc_keys(kf, n);
    return add(b, f, mesh, NULL, &d, data, msg);
}

static rto_status write_tlas(const rto_accel_tlas *t, const rto_scene *sc, rto_bundle *b, rto_msg *msg)
{
    rto_instance_record *rec = rto__alloc(sc->instance_count, sizeof *rec);
    if (!rec)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < sc->instance_count; i++)
        rec[i] = rto_instance_record_make(&sc->instances[i]);
    rto_status s = add_layout(b, RTO_FILE_INSTANCES, 0, RTO_LAYOUT_INSTANCE, sc->instance_count, rec, msg);
    free(rec);
    if (!s)
        s = add_layout(b, RTO_FILE_INSTANCE_AABBS, 0, RTO_LAYOUT_AABB, t->instance_count, t->instance_aabbs, msg);
    if (!s)
        s = add_keys(b, RTO_FILE_TLAS_KEYS, 0, RTO_KEY_U32, t->key_count, t->keys, msg);
    if (!s)
        s = add_keys(b, RTO_FILE_TLAS_SORTED_KEYS, 0, RTO_KEY_U32, t->n_padded, t->sorted_keys, msg);
    if (!s && t->kind == RTO_TLAS_SWEEP)
        s = add_layout(b, RTO_FILE_TLAS_NODES, 0, RTO_LAYOUT_TLAS_NODE, t->node_count, t->sweep_nodes, msg);
    else if (!s)
        s = add_layout(b, RTO_FILE_TLAS_NODES, 0, RTO_LAYOUT_BLAS_NODE, t->node_count, t->karras_nodes, msg);
    if (s)
        return s;
    int bad = 0;
    bad |= rto_bundle_set_str(b, "params", "tlas", t->kind == RTO_TLAS_SWEEP ? "sweep" : "karras");
    bad |= rto_bundle_set_int(b, "tlas", "instances", t->instance_count);
    /* Only scenes with empty instances carry the keyed count, so every other manifest keeps its bytes. */
    if (t->key_count != t->instance_count)
        bad |= rto_bundle_set_int(b, "tlas", "keyed_instances", t->key_count);
    bad |= rto_bundle_set_int(b, "tlas", "n_padded", t->n_padded);
    bad |= rto_bundle_set_int(b, "tlas", "nodes", (int64_t)t->node_count);
    bad |= rto_bundle_set_int(b, "tlas", "depth", t->stats.depth);
    bad |= rto_bundle_set_real(b, "tlas", "sah_cost", t->stats.sah);
    return bad ? manifest_fail(msg) : RTO_OK;
}

static rto_status write_blas(const rto_accel_blas *bl, const rto_mesh *mesh, rto_bundle *b, rto_msg *msg)
{
    const uint32_t m = bl->mesh;
    rto_status s = add_keys(b, RTO_FILE_BLAS_SORTED_KEYS, m, RTO_KEY_U64, bl->triangle_count, bl->sorted_keys, msg);
    if (!s) {
        rto_npy_desc od = rto_npy_desc_array(RTO_DTYPE_U32, 1, bl->triangle_count, 0, 0);
        s = add(b, RTO_FILE_BLAS_ORDER, m, NULL, &od, bl->order, msg);
    }
    if (!s)
        s = add_layout(b, RTO_FILE_BLAS_NODES, m, RTO_LAYOUT_BLAS_NODE, bl->node_count, bl->nodes, msg);
    if (!s)
        s = add_layout(b, RTO_FILE_BLAS_PRIM_AABBS, m, RTO_LAYOUT_AABB, bl->triangle_count, bl->prim_aabbs, msg);
    if (s)
        return s;
    char section[32];
    snprintf(section, sizeof section, "blas_%u", m);
    int bad = 0;
    bad |= rto_bundle_set_str(b, section, "mesh", mesh->name);
    bad |= rto_bundle_set_int(b, section, "triangles", bl->triangle_count);
    bad |= rto_bundle_set_int(b, section, "nodes", (int64_t)bl->node_count);
    bad |= rto_bundle_set_int(b, section, "depth", bl->stats.depth);
    bad |= rto_bundle_set_real(b, section, "sah_cost", bl->stats.sah);
    return bad ? manifest_fail(msg) : RTO_OK;
}

rto_status rto_accel_write_bundle(const rto_accel *accel, rto_bundle *b, rto_msg *msg)
{
    const rto_scene *sc = rto_accel_scene(accel);
    if (!sc || !b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL accel or bundle");
    uint64_t triangles = 0, blas_nodes = 0;
    int bad = 0;
    for (uint32_t i = 0; i < sc->instance_count; i++)
        triangles += sc->meshes[sc->instances[i].blas].triangle_count;
    bad |= rto_bundle_set_str(b, "", "scene", sc->source);
    bad |= rto_bundle_set_int(b, "counts", "meshes", sc->mesh_count);
    bad |= rto_bundle_set_int(b, "counts", "instances", sc->instance_count);
    bad |= rto_bundle_set_int(b, "counts", "instanced_triangles", (int64_t)triangles);
    rto_status s = bad ? manifest_fail(msg) : write_tlas(rto_accel_get_tlas(accel), sc, b, msg);
    for (uint32_t m = 0; !s && m < rto_accel_blas_count(accel); m++) {
        const rto_accel_blas *bl = rto_accel_get_blas(accel, m);
        s = write_blas(bl, &sc->meshes[m], b, msg);
        blas_nodes += bl->node_count;
    }
    if (!s && rto_bundle_set_int(b, "counts", "blas_nodes", (int64_t)blas_nodes))
        s = manifest_fail(msg);
    return s;
}
