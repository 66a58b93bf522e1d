/* rtoracle check-hits: validates a GPU's hit records against a trace bundle (rtoracle trace) by the rules of
 * DESIGN.md §9: IDs, customIndex, hitGroup, missFlag and objToWorld exact, t and barycentrics within tolerance, and
 * another primitive than the oracle's accepted only as a tie (its own re-intersection gives the oracle's t). The
 * bundle's geometry is what the claimed primitives are intersected with, so every array read from it is first checked
 * like a GPU dump: dtype, shape, counts against the manifest, indices and BLAS numbers in range, finite floats. A
 * hand-edited bundle is refused with one line, never trusted. */
#include "cli.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char check_hits_usage[] =
    "usage: rtoracle check-hits --expected OUTDIR --gpu hits.npy [--json] [--no-artifacts]\n\n"
    "Compares a GPU's hit records (one 96-byte HitRecord per ray, in ray order) with the trace bundle written\n"
    "by `rtoracle trace`. The dump may be the structured HitRecord records, a (count, 24) uint32/float32\n"
    "array or the raw buffer as flat uint32/float32 words.\n"
    "Rules (DESIGN.md §9's conformance model: every binary32 operation of §6 correctly rounded, any a*b + c\n"
    "fused or not, division and reciprocal within 2.5 ulp): a record equal to the oracle's passes; otherwise\n"
    "a hit must name a primitive that a conforming implementation may hit, with t and the barycentrics inside\n"
    "the intervals the model gives for it (computed per ray, in binary64 with outward rounding), customIndex,\n"
    "hitGroup and objToWorld exactly its instance's (the column padding is ignored), and no primitive that\n"
    "every conforming implementation reaches and hits may lie before it. A miss must be the miss record (t =\n"
    "the ray's tMax, IDs 0xFFFFFFFF, bary and objToWorld 0), and no primitive may be certainly reached and\n"
    "hit. Each accepted difference is named by the freedom that explains it: arithmetic (the same primitive,\n"
    "other rounding), tie (another primitive at a t the model cannot tell apart), edge (hit or miss is not\n"
    "certain: a vertex, an edge, a ray nearly parallel to the plane), box (certainly hit, not certainly\n"
    "reached), t-range (t within rounding of tMin or tMax), first-hit (a TERMINATE_ON_FIRST_HIT ray ending\n"
    "on another hit: only hit / miss and the claim's t are defined).\n";

static const char check_hits_epilog[] =
    "Fault classes, in priority order: size, miss-flag, instance, prim, t, bary, custom-index, hit-group,\n"
    "transform. The report names the highest-priority fault of the first wrong ray and lists every class\n"
    "seen. Exit status: 0 valid (differences the model allows included), 1 a fault was found, 2 bad usage or\n"
    "input (including a bundle whose arrays disagree with its manifest).\n";

/* What check-hits reads from a trace bundle, each array validated before use. */
typedef struct trace_arrays {
    cli_bundle in; /* the bundle, for cli_bundle_* */
    rto_npy rays, hits, inst;
    rto_npy *mesh_npy; /* 2 per mesh: positions, indices */
    rto_mesh *meshes;
    uint32_t mesh_count, mesh_cap;
    rto_instance *instances;
    uint32_t instance_count;
} trace_arrays;

static void arrays_free(trace_arrays *a)
{
    rto_npy_free(&a->rays);
    rto_npy_free(&a->hits);
    rto_npy_free(&a->inst);
    for (uint32_t m = 0; m < a->mesh_count; m++) {
        rto_npy_free(&a->mesh_npy[2 * m]);
        rto_npy_free(&a->mesh_npy[2 * m + 1]);
    }
    free(a->mesh_npy);
    free(a->meshes);
    free(a->instances);
}

static int all_finite(const float *v, size_t n)
{
    for (size_t k = 0; k < n; k++)
        if (!isfinite(v[k]))
            return 0;
    return 1;
}

/* instances.npy: each record's BLAS exists, both transforms are finite, customIndex and mask within their bits. */
static int load_instances(trace_arrays *a, size_t n)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    cli_bundle_file_name(RTO_FILE_INSTANCES, 0, name);
    rto_npy_desc want = rto_layout_desc(RTO_LAYOUT_INSTANCE, n);
    int rc = cli_bundle_load(&a->in, name, &want, rto_layout_name(RTO_LAYOUT_INSTANCE), &a->inst);
    if (rc)
        return rc;
    a->instances = cli_alloc(n, sizeof *a->instances);
    if (!a->instances)
        return cli_fail("check-hits", "out of memory");
    for (size_t i = 0; i < n; i++) {
        rto_instance_record rec; /* the array's records are this struct's bytes (rto_layout_desc) */
        memcpy(&rec, (const unsigned char *)a->inst.data + i * sizeof rec, sizeof rec);
        if (rec.blas >= a->mesh_count)
            return cli_bundle_refuse(&a->in, name,
                                     "instance %zu names BLAS %" PRIu32 "; the bundle has %" PRIu32 " meshes", i,
                                     rec.blas, a->mesh_count);
        if (!all_finite(&rec.obj_to_world[0][0], 12) || !all_finite(&rec.world_to_obj[0][0], 12))
            return cli_bundle_refuse(&a->in, name, "a transform of instance %zu is not finite", i);
        if (rec.custom_index > RTO_INSTANCE_CUSTOM_INDEX_MASK || rec.mask > 0xFFu)
            return cli_bundle_refuse(&a->in, name,
                                     "instance %zu has customIndex 0x%" PRIx32 " or mask 0x%" PRIx32
                                     " outside their 24 / 8 bits",
                                     i, rec.custom_index, rec.mask);
        a->instances[i] = rto_instance_from_record(&rec);
    }
    a->instance_count = (uint32_t)n;
    return EXIT_PASS;
}

/* mesh_M_positions.npy (f32 (V, 3), finite) and mesh_M_indices.npy (u32 (T, 3), T = the manifest's blas_M.triangles,
 * every index < V). The mesh array grows as files are found, so a manifest claiming millions of meshes costs
 * nothing before its first missing file. */
static int load_mesh(trace_arrays *a, uint32_t m)
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
            return cli_fail("check-hits", "out of memory");
        a->mesh_cap = cap;
    }
    rto_npy *pos = &a->mesh_npy[2 * m], *idx = &a->mesh_npy[2 * m + 1];
    memset(pos, 0, sizeof *pos);
    memset(idx, 0, sizeof *idx);
    a->mesh_count = m + 1; /* owned from here on: freed with the others */
    char section[32], pname[RTO_BUNDLE_FILE_NAME_MAX], iname[RTO_BUNDLE_FILE_NAME_MAX];
    snprintf(section, sizeof section, "blas_%" PRIu32, m);
    size_t t = 0;
    int rc = cli_bundle_count(&a->in, section, "triangles", UINT32_MAX, &t);
    if (rc)
        return rc;
    cli_bundle_file_name(RTO_FILE_MESH_POSITIONS, m, pname);
    cli_bundle_file_name(RTO_FILE_MESH_INDICES, m, iname);
    rto_npy_desc pd = rto_npy_desc_array(RTO_DTYPE_F32, 2, UINT64_MAX, 3, 0);
    rto_npy_desc id = rto_npy_desc_array(RTO_DTYPE_U32, 2, t, 3, 0);
    if ((rc = cli_bundle_load(&a->in, pname, &pd, NULL, pos)) || (rc = cli_bundle_load(&a->in, iname, &id, NULL, idx)))
        return rc;
    const uint64_t v = pos->desc.shape[0];
    if (v > UINT32_MAX)
        return cli_bundle_refuse(&a->in, pname, "%" PRIu64 " vertices: more than a mesh can index", v);
    if (!all_finite(pos->data, 3 * (size_t)v))
        return cli_bundle_refuse(&a->in, pname, "a vertex position is not finite");
    const uint32_t *ix = idx->data;
    for (size_t k = 0; k < 3 * t; k++)
        if (ix[k] >= v)
            return cli_bundle_refuse(&a->in, iname,
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
    return EXIT_PASS;
}

/* rays.npy (WfRay, trace.count of them, each traceable) and hits.npy (HitRecord, one per ray; as many misses as the
 * manifest says). Whether each expected record is the hit or miss record of its ray is checked by the validator. */
static int load_rays_and_hits(trace_arrays *a, size_t count, size_t hits, size_t misses)
{
    char rname[RTO_BUNDLE_FILE_NAME_MAX], hname[RTO_BUNDLE_FILE_NAME_MAX];
    cli_bundle_file_name(RTO_FILE_RAYS, 0, rname);
    cli_bundle_file_name(RTO_FILE_HITS, 0, hname);
    rto_npy_desc rd = rto_layout_desc(RTO_LAYOUT_WF_RAY, count), hd = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, count);
    int rc = cli_bundle_load(&a->in, rname, &rd, rto_layout_name(RTO_LAYOUT_WF_RAY), &a->rays);
    if (!rc)
        rc = cli_bundle_load(&a->in, hname, &hd, rto_layout_name(RTO_LAYOUT_HIT_RECORD), &a->hits);
    if (rc)
        return rc;
    const rto_wf_ray *rays = a->rays.data;
    for (size_t i = 0; i < count; i++) {
        if (!all_finite(rays[i].origin, 3) || !all_finite(rays[i].dir, 3) || !isfinite(rays[i].t_min) ||
            !isfinite(rays[i].t_max))
            return cli_bundle_refuse(&a->in, rname, "ray %zu has a non-finite origin, direction, tMin or tMax", i);
        if (rays[i].t_min > rays[i].t_max)
            return cli_bundle_refuse(&a->in, rname, "ray %zu has tMin %.9g > tMax %.9g", i, (double)rays[i].t_min,
                                     (double)rays[i].t_max);
    }
    const rto_hit_record *h = a->hits.data;
    size_t m = 0;
    for (size_t i = 0; i < count; i++)
        m += h[i].miss_flag == 1;
    if (m != misses || count - m != hits)
        return cli_bundle_refuse(&a->in, hname,
                                 "%zu hits and %zu misses; the manifest says trace.hits %zu, trace.misses %zu",
                                 count - m, m, hits, misses);
    return EXIT_PASS;
}

int cmd_check_hits(int argc, char **argv)
{
    const char *expected = NULL, *gpu = NULL;
    bool json = false, no_artifacts = false;
    const opt_spec opts[] = {
        OPT_PATH("expected", 0, &expected, "OUTDIR", "the trace bundle (rtoracle trace)"),
        OPT_PATH("gpu", 0, &gpu, "hits.npy", "the GPU's hit records, one per ray of the bundle"),
        OPT_FLAG("json", &json, "print the report as JSON"),
        OPT_FLAG("no-artifacts", &no_artifacts, "do not write the report next to the GPU dump"),
        OPT_END,
    };
    const opt_command cmd = {"check-hits", check_hits_usage, check_hits_epilog, opts, 0, 0, NULL};
    opt_args args;
    int parsed = opts_parse(&cmd, argc, argv, &args);
    if (parsed >= 0)
        return parsed;
    static const char *const required[] = {"expected", "gpu", NULL};
    if ((parsed = opts_require(&cmd, &args, required)))
        return parsed;

    rto_msg msg = {{0}};
    trace_arrays a;
    memset(&a, 0, sizeof a);
    a.in.cmd = "check-hits";
    a.in.dir = expected;
    rto_npy g = {0};
    int rc = EXIT_PASS;
    if (rto_bundle_open(expected, &a.in.b, &msg)) {
        rc = cli_fail("check-hits", "--expected: %s", msg.text);
        goto out;
    }
    const char *kind = rto_bundle_get_str(a.in.b, "", "kind");
    if (!kind || strcmp(kind, "trace")) {
        rc = cli_fail("check-hits", "--expected %s is not a trace bundle (rtoracle trace)", expected);
        goto out;
    }
    /* the GPU's dump first: a wrong file there is the likelier mistake, and it is cheap to read */
    if (rto_npy_read(gpu, &g, &msg)) {
        rc = cli_fail("check-hits", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    size_t gpu_count = 0;
    if (rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &g, &gpu_count, &msg)) {
        rc = cli_fail("check-hits", "--gpu %s: %s", gpu, msg.text);
        goto out;
    }
    size_t meshes = 0, instances = 0, count = 0, hits = 0, misses = 0;
    if ((rc = cli_bundle_count(&a.in, "counts", "meshes", UINT32_MAX, &meshes)) ||
        (rc = cli_bundle_count(&a.in, "counts", "instances", RTO_TLAS_MAX_INSTANCES, &instances)) ||
        (rc = cli_bundle_count(&a.in, "trace", "count", (uint64_t)INT64_MAX, &count)) ||
        (rc = cli_bundle_count(&a.in, "trace", "hits", count, &hits)) ||
        (rc = cli_bundle_count(&a.in, "trace", "misses", count, &misses)))
        goto out;
    if (hits + misses != count) {
        rc = cli_bundle_refuse(&a.in, "manifest.json", "trace.hits %zu + trace.misses %zu is not trace.count %zu", hits,
                               misses, count);
        goto out;
    }
    for (uint32_t m = 0; m < meshes; m++)
        if ((rc = load_mesh(&a, m)))
            goto out;
    if ((rc = load_instances(&a, instances)) || (rc = load_rays_and_hits(&a, count, hits, misses)))
        goto out;

    rto_hits_check_desc d;
    memset(&d, 0, sizeof d);
    d.rays = a.rays.data;
    d.ray_count = count;
    d.expected = a.hits.data;
    d.gpu = g.data;
    d.gpu_count = gpu_count;
    d.instances = a.instances;
    d.instance_count = a.instance_count;
    d.meshes = a.meshes;
    d.mesh_count = a.mesh_count;
    rto_report r;
    rto_status s = rto_hits_check(&d, &r, &msg);
    if (s == RTO_ERR_INVALID_ARGUMENT) {
        /* the bundle's own records or geometry disagree: refused as input, as any other bundle array */
        char hname[RTO_BUNDLE_FILE_NAME_MAX];
        rc = cli_bundle_refuse(&a.in, cli_bundle_file_name(RTO_FILE_HITS, 0, hname), "%s", msg.text);
        goto out;
    }
    if (s != RTO_OK && s != RTO_ERR_MISMATCH) {
        rc = cli_status("check-hits", s, &msg);
        goto out;
    }
    const char *set = rto_bundle_get_str(a.in.b, "trace", "rays");
    int64_t w = 0, h = 0;
    if (rto_bundle_get_int(a.in.b, "trace", "width", &w) && rto_bundle_get_int(a.in.b, "trace", "height", &h) &&
        w > 0 && h > 0)
        snprintf(r.what, sizeof r.what, "%.50s rays %" PRId64 "x%" PRId64, set ? set : "?", w, h);
    else
        snprintf(r.what, sizeof r.what, "%.80s rays", set ? set : "?");
    rc = cli_report("check-hits", &r, json, !no_artifacts, gpu);
out:
    rto_npy_free(&g);
    arrays_free(&a);
    rto_bundle_close(a.in.b);
    return rc;
}
