/* rtoracle build: a scene's acceleration structures in their GPU layouts (DESIGN.md §5): instances, TLAS keys and
 * their bitonic sort, the TLAS (sweep tree or Karras), and one Karras BLAS per mesh with its triangle order. Every
 * tree passes the structural self-check before the bundle is committed. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char build_usage[] =
    "usage: rtoracle build SCENE [--tlas sweep|karras] [--texture-budget MB] -o OUTDIR\n\n"
    "SCENE is a .gltf / .glb path or a procedural scene: triangle, rtstress:N (1..40),\n"
    "instances:DIST:N (N boxes around the centroids of a centroid distribution, N <= 65536).\n"
    "Writes a bundle (atomically):\n"
    "  instances.npy            InstanceRecord: objToWorld, worldToObj (3x4 row-major), blas, customIndex,\n"
    "                           mask, sbtOffset, flags\n"
    "  instance_aabbs.npy       world AABB of every instance (Aabb)\n"
    "  tlas_keys.npy            TLAS keys in instance order; tlas_sorted_keys.npy: n_padded, sorted\n"
    "  tlas_nodes.npy           sweep: TlasNode heap (2 n_padded - 1); karras: BlasNode (n - 1)\n"
    "  blas_M_sorted_keys.npy   per mesh M: sorted BLAS keys (u64), blas_M_order.npy: triangle of each\n"
    "                           leaf, blas_M_nodes.npy: BlasNode (triangles - 1), blas_M_prim_aabbs.npy\n"
    "  manifest.json            counts, depth and SAH cost of every tree\n";

/* --tlas: the sweep tree (the seeds' implicit heap) or a Karras tree. */
static const opt_name tlas_names[] = {{"sweep", 0}, {"karras", 1}, {NULL, 0}};

static rto_status add_aabbs(rto_bundle *b, const char *name, const char *role, const rto_aabb *boxes, size_t n,
                            rto_msg *msg)
{
    rto_npy_desc d = layout_desc(LAYOUT_AABB, n);
    return rto_bundle_add_npy(b, name, role, layout_name(LAYOUT_AABB), &d, boxes, msg);
}

/* Instance records as the GPU reads them: 32 u32-sized words each. */
static rto_status add_instances(rto_bundle *b, const rto_scene *sc, rto_msg *msg)
{
    const size_t rec = layout_size(LAYOUT_INSTANCE);
    unsigned char *buf = calloc(sc->instance_count ? sc->instance_count : 1, rec);
    if (!buf)
        return cli_error(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < sc->instance_count; i++) {
        const rto_instance *in = &sc->instances[i];
        unsigned char *p = buf + i * rec;
        uint32_t w[5] = {in->blas, in->custom_index, in->mask, in->sbt_offset, in->flags};
        memcpy(p, in->obj_to_world.m, 48);
        memcpy(p + 48, in->world_to_obj.m, 48);
        memcpy(p + 96, w, sizeof w);
    }
    rto_npy_desc d = layout_desc(LAYOUT_INSTANCE, sc->instance_count);
    rto_status s = rto_bundle_add_npy(b, "instances.npy", "instances", layout_name(LAYOUT_INSTANCE), &d, buf, msg);
    free(buf);
    return s;
}

static rto_status self_check(rto_status s, const rto_bvh_report *r, const char *what, rto_msg *msg)
{
    if (s == RTO_ERR_MISMATCH)
        return cli_error(msg, RTO_ERR_UNSUPPORTED, "internal self-check of %s failed: %s", what, r->summary);
    return s;
}

static rto_status build_tlas(rto_bundle *b, const rto_scene *sc, int karras, rto_msg *msg)
{
    const size_t n = sc->instance_count, np = rto_next_pow2(n);
    if (n > RTO_TLAS_MAX_INSTANCES)
        return cli_error(msg, RTO_ERR_INVALID_ARGUMENT, "%zu instances: a TLAS key indexes at most %u", n,
                        RTO_TLAS_MAX_INSTANCES);
    rto_aabb *boxes = cli_alloc(n, sizeof *boxes);
    uint32_t *keys = cli_alloc(n, 4), *sorted = cli_alloc(np, 4), *prims = cli_alloc(n, 4);
    size_t count = karras ? (n >= 2 ? n - 1 : 0) : rto_tlas_sweep_node_count(n);
    void *nodes = cli_alloc(count, karras ? sizeof(rto_bvh_node) : sizeof(rto_tlas_node));
    rto_status s = RTO_OK;
    if (!boxes || !keys || !sorted || !prims || !nodes)
        s = cli_error(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t i = 0; !s && i < n; i++)
        boxes[i] = rto_instance_aabb(sc, (uint32_t)i);
    rto_bvh_report r;
    rto_bvh_stats st = {0, 0, 0};
    if (!s && !karras) {
        s = rto_tlas_build_sweep(boxes, n, keys, sorted, nodes, msg);
        if (!s)
            s = self_check(rto_tlas_check(nodes, count, NULL, boxes, n, &r, msg), &r, "the sweep TLAS", msg);
        st = rto_tlas_stats(nodes, n);
    } else if (!s) {
        s = rto_tlas_sorted_keys(boxes, n, keys, sorted, msg);
        if (!s)
            s = rto_karras_build(RTO_KEY_U32, sorted, n, boxes, nodes, msg);
        for (size_t j = 0; !s && j < n; j++)
            prims[j] = rto_key_prim(RTO_KEY_U32, sorted[j]);
        if (!s)
            s = self_check(rto_karras_check(nodes, count, NULL, prims, boxes, n, 0, &r, msg), &r, "the Karras TLAS",
                           msg);
        rto_aabb root = rto_scene_aabb(sc);
        st = rto_karras_stats(nodes, n, &root);
    }
    if (!s)
        s = add_instances(b, sc, msg);
    if (!s)
        s = add_aabbs(b, "instance_aabbs.npy", "instance-aabbs", boxes, n, msg);
    if (!s) {
        rto_npy_desc kd = rto_npy_desc_keys(RTO_KEY_U32, n), sd = rto_npy_desc_keys(RTO_KEY_U32, np);
        s = rto_bundle_add_npy(b, "tlas_keys.npy", "tlas-keys", NULL, &kd, keys, msg);
        if (!s)
            s = rto_bundle_add_npy(b, "tlas_sorted_keys.npy", "tlas-sorted-keys", NULL, &sd, sorted, msg);
    }
    if (!s) {
        layout_kind k = karras ? LAYOUT_BVH_NODE : LAYOUT_TLAS_NODE;
        rto_npy_desc nd = layout_desc(k, count);
        s = rto_bundle_add_npy(b, "tlas_nodes.npy", "tlas-nodes", layout_name(k), &nd, nodes, msg);
    }
    if (!s) {
        rto_bundle_set_str(b, "params", "tlas", karras ? "karras" : "sweep");
        rto_bundle_set_int(b, "tlas", "instances", (int64_t)n);
        rto_bundle_set_int(b, "tlas", "n_padded", (int64_t)np);
        rto_bundle_set_int(b, "tlas", "nodes", (int64_t)count);
        rto_bundle_set_int(b, "tlas", "depth", st.depth);
        rto_bundle_set_real(b, "tlas", "sah_cost", st.sah);
    }
    free(boxes);
    free(keys);
    free(sorted);
    free(prims);
    free(nodes);
    return s;
}

static rto_status build_blas(rto_bundle *b, const rto_scene *sc, uint32_t m, uint64_t *total_nodes, rto_msg *msg)
{
    const rto_mesh *mesh = &sc->meshes[m];
    const size_t n = mesh->triangle_count, np = rto_next_pow2(n), count = n >= 2 ? n - 1 : 0;
    uint64_t *keys = cli_alloc(n, 8), *sorted = cli_alloc(np, 8);
    uint32_t *order = cli_alloc(n, 4);
    rto_aabb *boxes = cli_alloc(n, sizeof *boxes);
    rto_bvh_node *nodes = cli_alloc(count, sizeof *nodes);
    rto_status s = RTO_OK;
    if (!keys || !sorted || !order || !boxes || !nodes)
        s = cli_error(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t t = 0; !s && t < n; t++)
        boxes[t] = rto_mesh_triangle_aabb(mesh, (uint32_t)t);
    if (!s)
        s = rto_mesh_keys(mesh, keys, msg);
    if (!s)
        s = rto_bitonic_sort(RTO_KEY_U64, keys, n, sorted, NULL, NULL, msg);
    for (size_t j = 0; !s && j < n; j++)
        order[j] = rto_key_prim(RTO_KEY_U64, sorted[j]);
    if (!s)
        s = rto_karras_build(RTO_KEY_U64, sorted, n, boxes, nodes, msg);
    rto_bvh_report r;
    char what[96], name[96], section[32];
    snprintf(what, sizeof what, "the BLAS of mesh %u", m);
    if (!s)
        s = self_check(rto_karras_check(nodes, count, NULL, order, boxes, n, 0, &r, msg), &r, what, msg);
    if (!s) {
        rto_npy_desc kd = rto_npy_desc_keys(RTO_KEY_U64, n), od = rto_npy_desc_array(RTO_DTYPE_U32, 1, n, 0, 0);
        rto_npy_desc nd = layout_desc(LAYOUT_BVH_NODE, count);
        snprintf(name, sizeof name, "blas_%u_sorted_keys.npy", m);
        s = rto_bundle_add_npy(b, name, "blas-sorted-keys", NULL, &kd, sorted, msg);
        snprintf(name, sizeof name, "blas_%u_order.npy", m);
        if (!s)
            s = rto_bundle_add_npy(b, name, "blas-order", NULL, &od, order, msg);
        snprintf(name, sizeof name, "blas_%u_nodes.npy", m);
        if (!s)
            s = rto_bundle_add_npy(b, name, "blas-nodes", layout_name(LAYOUT_BVH_NODE), &nd, nodes, msg);
        snprintf(name, sizeof name, "blas_%u_prim_aabbs.npy", m);
        if (!s)
            s = add_aabbs(b, name, "blas-prim-aabbs", boxes, n, msg);
    }
    if (!s) {
        rto_aabb root = rto_mesh_aabb(mesh);
        rto_bvh_stats st = rto_karras_stats(nodes, n, &root);
        snprintf(section, sizeof section, "blas_%u", m);
        rto_bundle_set_str(b, section, "mesh", mesh->name);
        rto_bundle_set_int(b, section, "triangles", (int64_t)n);
        rto_bundle_set_int(b, section, "nodes", (int64_t)count);
        rto_bundle_set_int(b, section, "depth", st.depth);
        rto_bundle_set_real(b, section, "sah_cost", st.sah);
        *total_nodes += count;
    }
    free(keys);
    free(sorted);
    free(order);
    free(boxes);
    free(nodes);
    return s;
}

int cmd_build(int argc, char **argv)
{
    const char *out = NULL;
    unsigned karras = 0;
    uint64_t budget_mb = 0;
    const opt_spec opts[] = {
        OPT_ENUM("tlas", &karras, tlas_names, "T", "TLAS layout", "sweep, the seeds' implicit tree"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take", "256"),
        OPT_PATH("output", 'o', &out, "DIR", "output bundle directory"),
        OPT_END,
    };
    const opt_command cmd = {"build", build_usage, NULL, opts, 1, 1, "one SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    static const char *const required[] = {"output", NULL};
    if ((rc = opts_require(&cmd, &args, required)))
        return rc;
    const char *scene = args.arg[0];
    rto_msg msg = {{0}};
    rto_scene *sc = NULL;
    rto_scene_load_desc load = {0};
    load.texture_budget_bytes = (size_t)(budget_mb << 20); /* 0 (not given): the default */
    rto_status s = rto_scene_load_ex(scene, &load, &sc, &msg);
    if (s) /* the message names the scene file itself */
        return cli_fail("build", "%s", msg.text);
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle build: warning: %s\n", sc->warnings[w]);
    rto_bundle *b = NULL;
    s = rto_bundle_begin(out, "build", &b, &msg);
    uint64_t triangles = 0, blas_nodes = 0;
    if (!s) {
        rto_bundle_set_str(b, "", "scene", sc->source);
        rto_bundle_set_int(b, "counts", "meshes", sc->mesh_count);
        rto_bundle_set_int(b, "counts", "instances", sc->instance_count);
        for (uint32_t i = 0; i < sc->instance_count; i++)
            triangles += sc->meshes[sc->instances[i].blas].triangle_count;
        rto_bundle_set_int(b, "counts", "instanced_triangles", (int64_t)triangles);
        s = build_tlas(b, sc, (int)karras, &msg);
    }
    for (uint32_t m = 0; !s && m < sc->mesh_count; m++)
        s = build_blas(b, sc, m, &blas_nodes, &msg);
    if (!s) {
        rto_bundle_set_int(b, "counts", "blas_nodes", (int64_t)blas_nodes);
        s = rto_bundle_commit(b, &msg);
    } else {
        rto_bundle_abort(b);
    }
    rto_scene_destroy(sc);
    return cli_status("build", s, &msg);
}
