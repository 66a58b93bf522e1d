/* Acceleration-structure benchmarks: the oracle's BLAS build (BLAS keys, bitonic sort, Karras tree, boxes) of the
 * Stanford bunny and of 2CylinderEngine, and its sweep TLAS over 65,536 instances, each as Mprims/s beside Embree's
 * rtcCommitScene on the same geometry in the same process (median of RUNS runs). Embree runs with one thread, like
 * the oracle, and at two build qualities: LOW (its Morton builder, the closest relative of an LBVH) and MEDIUM (its
 * default binned-SAH builder). Usage: bench_bvh [bunny.gltf] [2CylinderEngine.glb]. */
#include "rtoracle.h"
#include "bench_util.h"

#include <embree3/rtcore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static void die(const char *what, const rto_msg *msg)
{
    fprintf(stderr, "bench_bvh: %s: %s\n", what, msg ? msg->text : "");
    exit(1);
}

/* The oracle's BLAS build of one mesh; returns seconds. */
static double oracle_blas(const rto_mesh *m)
{
    size_t n = m->triangle_count, np = rto_next_pow2(n);
    uint64_t *keys = malloc(n * 8), *sorted = malloc(np * 8);
    rto_aabb *boxes = malloc(n * sizeof *boxes);
    rto_bvh_node *nodes = malloc((n ? n : 1) * sizeof *nodes);
    rto_msg msg = {{0}};
    double t0 = now();
    for (size_t t = 0; t < n; t++)
        boxes[t] = rto_mesh_triangle_aabb(m, (uint32_t)t);
    if (rto_mesh_keys(m, keys, &msg) || rto_bitonic_sort(RTO_KEY_U64, keys, n, sorted, NULL, NULL, &msg) ||
        rto_karras_build(RTO_KEY_U64, sorted, n, boxes, nodes, &msg))
        die("oracle BLAS", &msg);
    double t = now() - t0;
    free(keys);
    free(sorted);
    free(boxes);
    free(nodes);
    return t;
}

static RTCScene embree_mesh_scene(RTCDevice dev, const rto_mesh *m, enum RTCBuildQuality q)
{
    RTCScene sc = rtcNewScene(dev);
    rtcSetSceneBuildQuality(sc, q);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, m->vertex_count);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, m->triangle_count);
    memcpy(vb, m->positions, (size_t)m->vertex_count * 12);
    memcpy(ib, m->indices, (size_t)m->triangle_count * 12);
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    return sc;
}

/* Embree's rtcCommitScene over every mesh of a scene, one scene per mesh as the oracle builds one BLAS each. */
static double embree_blas(RTCDevice dev, const rto_scene *s, enum RTCBuildQuality q)
{
    double total = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        RTCScene sc = embree_mesh_scene(dev, &s->meshes[m], q);
        double t0 = now();
        rtcCommitScene(sc);
        total += now() - t0;
        rtcReleaseScene(sc);
    }
    return total;
}

static void bench_blas(RTCDevice dev, const char *path)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    if (rto_scene_load(path, &s, &msg)) {
        fprintf(stderr, "bench_bvh: skipping %s: %s\n", path, msg.text);
        return;
    }
    uint64_t tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        tris += s->meshes[m].triangle_count;
    double to[RUNS], tl[RUNS], tm[RUNS];
    for (int r = 0; r < RUNS; r++) {
        to[r] = 0;
        for (uint32_t m = 0; m < s->mesh_count; m++)
            to[r] += oracle_blas(&s->meshes[m]);
        tl[r] = embree_blas(dev, s, RTC_BUILD_QUALITY_LOW);
        tm[r] = embree_blas(dev, s, RTC_BUILD_QUALITY_MEDIUM);
    }
    double o = median(to), l = median(tl), md = median(tm);
    const char *base = strrchr(path, '/');
    printf("BLAS %-22s %8llu tris %3u meshes | oracle %8.2f ms %7.2f Mprims/s | embree LOW %7.2f ms %7.2f Mprims/s"
           " | MEDIUM %7.2f ms %7.2f Mprims/s | oracle/LOW %5.1fx oracle/MEDIUM %5.1fx\n",
           base ? base + 1 : path, (unsigned long long)tris, s->mesh_count, o * 1e3, (double)tris / o * 1e-6,
           l * 1e3, (double)tris / l * 1e-6, md * 1e3, (double)tris / md * 1e-6, o / l, o / md);
    rto_scene_destroy(s);
}

static void bench_tlas(RTCDevice dev, const char *spec)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    if (rto_scene_load(spec, &s, &msg))
        die(spec, &msg);
    const size_t n = s->instance_count, np = rto_next_pow2(n);
    rto_aabb *boxes = malloc(n * sizeof *boxes);
    uint32_t *keys = malloc(n * 4), *sorted = malloc(np * 4);
    rto_tlas_node *nodes = malloc(rto_tlas_sweep_node_count(n) * sizeof *nodes);
    RTCScene blas = embree_mesh_scene(dev, &s->meshes[0], RTC_BUILD_QUALITY_MEDIUM);
    rtcCommitScene(blas);
    double to[RUNS], te[2][RUNS];
    for (int r = 0; r < RUNS; r++) {
        double t0 = now();
        for (size_t i = 0; i < n; i++)
            boxes[i] = rto_instance_aabb(s, (uint32_t)i);
        if (rto_tlas_build_sweep(boxes, n, keys, sorted, nodes, &msg))
            die("oracle TLAS", &msg);
        to[r] = now() - t0;
        for (int q = 0; q < 2; q++) {
            RTCScene top = rtcNewScene(dev);
            rtcSetSceneBuildQuality(top, q ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_LOW);
            for (size_t i = 0; i < n; i++) {
                RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
                rtcSetGeometryInstancedScene(g, blas);
                rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, s->instances[i].obj_to_world.m);
                rtcCommitGeometry(g);
                rtcAttachGeometry(top, g);
                rtcReleaseGeometry(g);
            }
            double t1 = now();
            rtcCommitScene(top);
            te[q][r] = now() - t1;
            rtcReleaseScene(top);
        }
    }
    double o = median(to), l = median(te[0]), md = median(te[1]);
    printf("TLAS %-22s %8zu inst            | oracle %8.2f ms %7.2f Mprims/s | embree LOW %7.2f ms %7.2f Mprims/s"
           " | MEDIUM %7.2f ms %7.2f Mprims/s | oracle/LOW %5.1fx oracle/MEDIUM %5.1fx\n",
           spec, n, o * 1e3, (double)n / o * 1e-6, l * 1e3, (double)n / l * 1e-6, md * 1e3, (double)n / md * 1e-6,
           o / l, o / md);
    rtcReleaseScene(blas);
    free(boxes);
    free(keys);
    free(sorted);
    free(nodes);
    rto_scene_destroy(s);
}

int main(int argc, char **argv)
{
    RTCDevice dev = rtcNewDevice("threads=1");
    if (!dev) {
        fprintf(stderr, "bench_bvh: rtcNewDevice failed\n");
        return 1;
    }
    for (int i = 1; i < argc; i++)
        bench_blas(dev, argv[i]);
    bench_tlas(dev, "instances:uniform:65536");
    printf("median of %d runs each; Embree %d.%d.%d with threads=1; ratios are time(oracle) / time(embree)\n", RUNS,
           RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH);
    rtcReleaseDevice(dev);
    return 0;
}
