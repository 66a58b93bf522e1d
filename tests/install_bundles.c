/* Every bundle kind written and read back through an installed rtoracle (tests/install.sh): a sort bundle (bitonic
 * and radix), a build bundle (its TLAS and a BLAS), a trace bundle (with its scene) and a frame bundle, each written
 * with rto_<stage>_bundle_write into a bundle this program commits, then read with rto_<stage>_bundle_read and
 * compared with what was written; then one byte of a written array changed, which the reader must refuse. Prints one
 * line per kind. Compiles as C11 and as C++. */
#include <rtoracle.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static rto_msg msg;

#define CHECK(cond, what)                                                                                               \
    do {                                                                                                               \
        if (!(cond)) {                                                                                                 \
            fprintf(stderr, "FAIL %s (line %d): %s\n", what, __LINE__, msg.text);                                       \
            exit(1);                                                                                                   \
        }                                                                                                              \
    } while (0)

static char path[4096];
static const char *at(const char *dir, const char *name)
{
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return path;
}

/* Changes one byte of a committed file (the reader's sha256 check must notice). */
static void tamper(const char *dir, const char *name)
{
    FILE *f = fopen(at(dir, name), "r+b");
    CHECK(f, "open for tampering");
    CHECK(fseek(f, -1, SEEK_END) == 0, "seek");
    int c = fgetc(f);
    CHECK(c != EOF && fseek(f, -1, SEEK_END) == 0, "read last byte");
    fputc(c ^ 1, f);
    fclose(f);
}

static void sort_kind(const char *root, rto_sort_algo algo, const char *name)
{
    enum { N = 1000 };
    uint32_t keys[N];
    CHECK(!rto_keys_generate("clustered", RTO_KEY_U32, 7, N, keys, &msg), "keys");
    rto_sort_bundle_desc d;
    memset(&d, 0, sizeof d);
    d.format = RTO_KEY_U32;
    d.keys = keys;
    d.n = N;
    d.algo = algo;
    d.radix_bits = 4;
    d.radix_tile = 128;
    d.checkpoints = 1;
    d.case_id = name;
    rto_bundle *b = NULL;
    const char *dir = at(root, name);
    char out[4096];
    snprintf(out, sizeof out, "%s", dir);
    CHECK(!rto_bundle_begin(out, "sort", &b, &msg) && !rto_sort_bundle_write(&d, b, &msg) &&
              !rto_bundle_commit(b, &msg), "sort bundle write");
    rto_sort_bundle sb;
    CHECK(!rto_sort_bundle_read(out, &sb, &msg), "sort bundle read");
    CHECK(sb.n == N && sb.n_padded == 1024 && sb.algo == algo && sb.format == RTO_KEY_U32 &&
              !strcmp(sb.case_id, name) && !memcmp(sb.keys.data, keys, sizeof keys) && sb.sorted.data,
          "sort bundle contents");
    CHECK(algo == RTO_SORT_BITONIC ? sb.passes == 55 : sb.radix_bits == 4 && sb.radix_tile == 128 && sb.passes == 8,
          "sort bundle schedule");
    /* the oracle's sorted keys pass as a GPU's */
    rto_sort_check_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.format = sb.format;
    cd.input = sb.keys.data;
    cd.n = sb.n;
    cd.gpu_keys = sb.sorted.data;
    cd.gpu_n = sb.n;
    cd.expected_keys = sb.sorted.data;
    rto_report r;
    CHECK(rto_sort_check(&cd, &r, &msg) == RTO_OK, "sorted keys pass");
    rto_sort_bundle_free(&sb);
    rto_sort_bundle_free(&sb); /* a freed bundle may be freed again */
    tamper(out, "sorted.npy");
    CHECK(rto_sort_bundle_read(out, &sb, &msg) == RTO_ERR_PARSE && strstr(msg.text, "sha256"), "tampered sort bundle");
    printf("sort %s: written, read back, checked; a changed sorted.npy refused\n", name);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: install_bundles DIR\n");
        return 2;
    }
    const char *root = argv[1];
    memset(&msg, 0, sizeof msg);
    sort_kind(root, RTO_SORT_BITONIC, "bitonic");
    sort_kind(root, RTO_SORT_RADIX, "radix");

    rto_scene *sc = NULL;
    rto_accel *acc = NULL;
    rto_accel_desc ad;
    memset(&ad, 0, sizeof ad);
    CHECK(!rto_scene_load("rtstress:2", &sc, &msg) && !rto_accel_build(sc, &ad, &acc, &msg), "scene and trees");

    /* build bundle: the TLAS and the BLAS of mesh 0, equal to the accel's own arrays */
    char build[4096], trace[4096], frame[4096];
    snprintf(build, sizeof build, "%s", at(root, "build"));
    snprintf(trace, sizeof trace, "%s", at(root, "trace"));
    snprintf(frame, sizeof frame, "%s", at(root, "frame"));
    rto_bundle *b = NULL;
    CHECK(!rto_bundle_begin(build, "build", &b, &msg) && !rto_bvh_bundle_write(acc, b, &msg) &&
              !rto_bundle_commit(b, &msg), "build bundle write");
    rto_bvh_bundle tl, bl;
    CHECK(!rto_bvh_bundle_read(build, -1, &tl, &msg) && !rto_bvh_bundle_read(build, 0, &bl, &msg), "build bundle read");
    const rto_accel_tlas *t = rto_accel_get_tlas(acc);
    const rto_accel_blas *b0 = rto_accel_get_blas(acc, 0);
    CHECK(tl.sweep && tl.blas == -1 && tl.prim_count == sc->instance_count && tl.node_count == t->node_count &&
              !memcmp(tl.nodes, t->sweep_nodes, t->node_count * sizeof *t->sweep_nodes),
          "TLAS read back");
    CHECK(!bl.sweep && bl.blas == 0 && bl.node_count == b0->node_count && bl.leaf_count == b0->triangle_count &&
              !memcmp(bl.nodes, b0->nodes, b0->node_count * sizeof *b0->nodes),
          "BLAS read back");
    rto_bvh_bundle_free(&tl);
    rto_bvh_bundle_free(&bl);
    CHECK(rto_bvh_bundle_read(build, (int64_t)sc->mesh_count, &bl, &msg) == RTO_ERR_INVALID_ARGUMENT, "missing BLAS");
    printf("build: TLAS and BLAS 0 written and read back\n");

    /* trace bundle: primary rays, their hits, and the scene they were traced in */
    rto_rays_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.set = RTO_RAYS_PRIMARY;
    rd.width = 16;
    rd.height = 12;
    const size_t cap = rto_rays_capacity(&rd);
    rto_wf_ray *rays = (rto_wf_ray *)malloc(cap * sizeof *rays);
    rto_hit_record *hits = (rto_hit_record *)malloc(cap * sizeof *hits);
    rto_trace_counters *cnt = (rto_trace_counters *)malloc(cap * sizeof *cnt);
    rto_camera_uniforms cu;
    size_t n = 0;
    const rto_trace_desc td = {1};
    CHECK(rays && hits && cnt && !rto_rays_generate(acc, &rd, rays, cap, &n, &cu, &msg) &&
              !rto_trace(acc, rays, n, &td, hits, cnt, &msg), "rays and hits");
    rto_trace_bundle_desc tbd;
    memset(&tbd, 0, sizeof tbd);
    tbd.accel = acc;
    tbd.rays = rays;
    tbd.count = n;
    tbd.hits = hits;
    tbd.counters = cnt;
    tbd.ray_set = "primary";
    CHECK(!rto_bundle_begin(trace, "trace", &b, &msg) && !rto_trace_bundle_write(&tbd, b, &msg) &&
              !rto_bundle_commit(b, &msg), "trace bundle write");
    rto_trace_bundle tb;
    CHECK(!rto_trace_bundle_read(trace, &tb, &msg), "trace bundle read");
    CHECK(tb.count == n && !memcmp(tb.rays, rays, n * sizeof *rays) && !memcmp(tb.hits, hits, n * sizeof *hits) &&
              tb.scene.mesh_count == sc->mesh_count && tb.scene.instance_count == sc->instance_count &&
              !strcmp(tb.ray_set, "primary"),
          "trace bundle contents");
    for (uint32_t m = 0; m < sc->mesh_count; m++)
        CHECK(tb.scene.meshes[m].triangle_count == sc->meshes[m].triangle_count &&
                  !memcmp(tb.scene.meshes[m].indices, sc->meshes[m].indices,
                          3 * sizeof(uint32_t) * sc->meshes[m].triangle_count),
              "scene read back");
    rto_hits_check_desc hd;
    memset(&hd, 0, sizeof hd);
    hd.rays = tb.rays;
    hd.ray_count = tb.count;
    hd.expected = tb.hits;
    hd.gpu = tb.hits;
    hd.gpu_count = tb.count;
    hd.instances = tb.scene.instances;
    hd.instance_count = tb.scene.instance_count;
    hd.meshes = tb.scene.meshes;
    hd.mesh_count = tb.scene.mesh_count;
    rto_report r;
    CHECK(rto_hits_check(&hd, &r, &msg) == RTO_OK, "the oracle's hits pass");
    rto_trace_bundle_free(&tb);
    rto_scene_bundle sb;
    CHECK(!rto_scene_bundle_read(trace, &sb, &msg) && sb.mesh_count == sc->mesh_count, "scene bundle read");
    rto_scene_bundle_free(&sb);
    tamper(trace, "mesh_0_indices.npy");
    CHECK(rto_scene_bundle_read(trace, &sb, &msg) == RTO_ERR_PARSE, "tampered scene");
    printf("trace: %zu rays written and read back with their scene; a changed mesh refused\n", n);
    free(rays);
    free(hits);
    free(cnt);

    /* frame bundle: a sun-shadow frame of the same scene, with the build and geometry files a mesh frame carries */
    rto_frame_desc fd;
    memset(&fd, 0, sizeof fd);
    fd.program = rto_program_builtin("sun-shadow");
    fd.accel = acc;
    fd.width = 16;
    fd.height = 12;
    fd.keep = RTO_FRAME_KEEP_LEAN;
    fd.threads = 1;
    rto_frame *fr = NULL;
    CHECK(fd.program && !rto_frame_render(&fd, &fr, &msg), "frame render");
    CHECK(!rto_bundle_begin(frame, "frame", &b, &msg) && !rto_bvh_bundle_write(acc, b, &msg) &&
              !rto_scene_bundle_write(sc, b, &msg) && !rto_frame_bundle_write(fr, 0, b, &msg) &&
              !rto_bundle_set_str(b, "frame", "scene_kind", "mesh") && !rto_bundle_commit(b, &msg),
          "frame bundle write");
    rto_frame_bundle fb;
    CHECK(!rto_frame_bundle_read(frame, &fb, &msg), "frame bundle read");
    const size_t q = fr->max_depth + 1;
    CHECK(fb.width == 16 && fb.height == 12 && fb.max_depth == fr->max_depth && !fb.stage2 &&
              !memcmp(fb.frame_counters, fr->counters, q * sizeof *fr->counters) &&
              !memcmp(fb.indirect_args, fr->indirect_args, q * sizeof *fr->indirect_args) &&
              !memcmp(fb.not_comparable, fr->not_comparable, 16 * 12) && fb.scene.mesh_count == sc->mesh_count,
          "frame bundle contents");
    for (size_t k = 0; k < q; k++)
        CHECK(fb.emit_counts[k] == fr->counters[k].emitted, "emit counts");
    rto_frame_bundle_free(&fb);
    tamper(frame, "emit_counts.npy");
    CHECK(rto_frame_bundle_read(frame, &fb, &msg) == RTO_ERR_PARSE, "tampered frame bundle");
    printf("frame: %ux%u, %zu queues written and read back with their scene; a changed emit_counts.npy refused\n",
           fr->width, fr->height, q);
    rto_frame_destroy(fr);
    rto_accel_destroy(acc);
    rto_scene_destroy(sc);
    return 0;
}
