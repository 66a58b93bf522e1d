/* The trace bundle (DESIGN.md §8): everything a GPU's TRACE kernel reads (instances, trees, mesh geometry, rays, the
 * camera block) and what it must write (one 96-byte hit record per ray), plus per-ray traversal counters and their
 * statistics in the manifest; and the same bundle read back for check-hits, every array validated first. The order
 * of files and manifest fields is part of the output bytes: keep it. */
#include "io/bundle_in.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Counter statistics: min, max, mean and a histogram over power-of-two buckets (0, 1, 2-3, 4-7, ...). */
static rto_status write_counter_stats(rto_bundle *b, const rto_trace_counters *c, size_t n, rto_msg *msg)
{
    static const char *const names[4] = {"nodes_visited", "box_tests", "triangle_tests", "instance_entries"};
    int bad = 0;
    for (int k = 0; k < 4; k++) {
        uint64_t total = 0, hist[33] = {0};
        uint32_t lo = UINT32_MAX, hi = 0;
        for (size_t i = 0; i < n; i++) {
            const uint32_t v = k == 0 ? c[i].nodes_visited
                               : k == 1 ? c[i].box_tests
                               : k == 2 ? c[i].triangle_tests
                                        : c[i].instance_entries;
            total += v;
            lo = v < lo ? v : lo;
            hi = v > hi ? v : hi;
            unsigned bucket = 0;
            while (bucket < 32 && (UINT64_C(1) << bucket) <= v)
                bucket++;
            hist[bucket]++;
        }
        char key[64], section[64];
        snprintf(key, sizeof key, "%s_total", names[k]);
        bad |= rto_bundle_set_int(b, "counters", key, (int64_t)total);
        snprintf(key, sizeof key, "%s_min", names[k]);
        bad |= rto_bundle_set_int(b, "counters", key, n ? lo : 0);
        snprintf(key, sizeof key, "%s_max", names[k]);
        bad |= rto_bundle_set_int(b, "counters", key, hi);
        snprintf(key, sizeof key, "%s_mean", names[k]);
        bad |= rto_bundle_set_real(b, "counters", key, n ? (double)total / (double)n : 0.0);
        snprintf(section, sizeof section, "histogram_%s", names[k]);
        for (unsigned j = 0; j <= 32; j++) {
            if (!hist[j])
                continue;
            if (j <= 1)
                snprintf(key, sizeof key, "%u", j);
            else
                snprintf(key, sizeof key, "%llu-%llu", 1ULL << (j - 1), (1ULL << j) - 1);
            bad |= rto_bundle_set_int(b, section, key, (int64_t)hist[j]);
        }
    }
    /* The setters keep their first failure for rto_bundle_commit too; this only stops early, with one status. */
    return bad ? rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "writing the manifest's counter statistics") : RTO_OK;
}

static rto_status add_file(rto_bundle *b, rto_bundle_file f, rto_layout layout, const void *data, size_t n,
                           rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    const rto_npy_desc d = rto_layout_desc(layout, n);
    return rto_bundle_add_npy(b, rto__bundle_name(f, 0, name), rto_bundle_file_role(f), rto_layout_name(layout), &d,
                              data, msg);
}

static void set_vec(rto_bundle *b, const char *key, rto_vec3 v)
{
    char text[96];
    snprintf(text, sizeof text, "%.9g,%.9g,%.9g", (double)v.x, (double)v.y, (double)v.z);
    rto_bundle_set_str(b, "camera", key, text);
}

rto_status rto_trace_bundle_write(const rto_trace_bundle_desc *d, rto_bundle *b, rto_msg *msg)
{
    if (!d || !b || !d->accel || !d->ray_set || (d->count && (!d->rays || !d->hits || !d->counters)) ||
        (d->camera && !d->camera_block))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "incomplete trace bundle description");
    rto_status s = rto_bvh_bundle_write(d->accel, b, msg);
    if (!s)
        s = rto_scene_bundle_write(rto_accel_scene(d->accel), b, msg);
    if (!s)
        s = add_file(b, RTO_FILE_RAYS, RTO_LAYOUT_WF_RAY, d->rays, d->count, msg);
    if (!s)
        s = add_file(b, RTO_FILE_HITS, RTO_LAYOUT_HIT_RECORD, d->hits, d->count, msg);
    if (!s)
        s = add_file(b, RTO_FILE_COUNTERS, RTO_LAYOUT_TRACE_COUNTERS, d->counters, d->count, msg);
    if (!s && d->camera)
        s = add_file(b, RTO_FILE_CAMERA, RTO_LAYOUT_CAMERA, d->camera_block, 1, msg);
    if (s)
        return s;
    size_t hit_count = 0;
    for (size_t i = 0; i < d->count; i++)
        hit_count += d->hits[i].miss_flag == 0;
    rto_bundle_set_str(b, "trace", "rays", d->ray_set);
    rto_bundle_set_int(b, "trace", "count", (int64_t)d->count);
    rto_bundle_set_int(b, "trace", "hits", (int64_t)hit_count);
    rto_bundle_set_int(b, "trace", "misses", (int64_t)(d->count - hit_count));
    if (d->generated) {
        rto_bundle_set_int(b, "trace", "seed", (int64_t)d->seed);
        if (d->camera) {
            const rto_camera *cam = d->camera;
            rto_bundle_set_int(b, "trace", "width", (int64_t)d->width);
            rto_bundle_set_int(b, "trace", "height", (int64_t)d->height);
            rto_bundle_set_str(b, "camera", "name", cam->name);
            set_vec(b, "position", cam->position);
            set_vec(b, "target", cam->target);
            set_vec(b, "up", cam->up);
            rto_bundle_set_real(b, "camera", "fov_y_degrees", (double)cam->fov_y * 180.0 / 3.14159265358979323846);
            rto_bundle_set_real(b, "camera", "znear", (double)cam->znear);
            rto_bundle_set_real(b, "camera", "zfar", (double)cam->zfar);
        }
        if (d->light)
            rto_bundle_set_str(b, "trace", "light", d->light);
    }
    return write_counter_stats(b, d->counters, d->count, msg);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Reading it back (check-hits)                                                                                     */

struct rto_trace_bundle_data {
    rto_npy rays, hits;
};

void rto_trace_bundle_free(rto_trace_bundle *tb)
{
    if (!tb)
        return;
    rto_scene_bundle_free(&tb->scene);
    if (tb->data) {
        rto_npy_free(&tb->data->rays);
        rto_npy_free(&tb->data->hits);
        free(tb->data);
    }
    memset(tb, 0, sizeof *tb);
}

/* rays.npy (WfRay, trace.count of them, each traceable) and hits.npy (HitRecord, one per ray; as many misses as the
 * manifest says). Whether each expected record is the hit or miss record of its ray is the validator's to check. */
static rto_status load_rays_and_hits(const rto__bundle_in *in, struct rto_trace_bundle_data *a, size_t count,
                                     size_t hits, size_t misses)
{
    char rname[RTO_BUNDLE_FILE_NAME_MAX], hname[RTO_BUNDLE_FILE_NAME_MAX];
    rto__bundle_name(RTO_FILE_RAYS, 0, rname);
    rto__bundle_name(RTO_FILE_HITS, 0, hname);
    rto_npy_desc rd = rto_layout_desc(RTO_LAYOUT_WF_RAY, count), hd = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, count);
    rto_status s = rto__bundle_load(in, rname, &rd, rto_layout_name(RTO_LAYOUT_WF_RAY), &a->rays);
    if (!s)
        s = rto__bundle_load(in, hname, &hd, rto_layout_name(RTO_LAYOUT_HIT_RECORD), &a->hits);
    if (s)
        return s;
    const rto_wf_ray *rays = a->rays.data;
    for (size_t i = 0; i < count; i++) {
        if (!rto__all_finite(rays[i].origin, 3) || !rto__all_finite(rays[i].dir, 3) || !isfinite(rays[i].t_min) ||
            !isfinite(rays[i].t_max))
            return rto__bundle_refuse(in, rname, "ray %zu has a non-finite origin, direction, tMin or tMax", i);
        if (rays[i].t_min > rays[i].t_max)
            return rto__bundle_refuse(in, rname, "ray %zu has tMin %.9g > tMax %.9g", i, (double)rays[i].t_min,
                                      (double)rays[i].t_max);
    }
    const rto_hit_record *h = a->hits.data;
    size_t m = 0;
    for (size_t i = 0; i < count; i++)
        m += h[i].miss_flag == 1;
    if (m != misses || count - m != hits)
        return rto__bundle_refuse(in, hname, "%zu hits and %zu misses; the manifest says trace.hits %zu, trace.misses %zu",
                                  count - m, m, hits, misses);
    return RTO_OK;
}

rto_status rto_trace_bundle_read(const char *dir, rto_trace_bundle *tb, rto_msg *msg)
{
    if (!tb)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL trace bundle");
    memset(tb, 0, sizeof *tb);
    struct rto_trace_bundle_data *a = calloc(1, sizeof *a);
    if (!a)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    tb->data = a;
    rto__bundle_in in;
    size_t count = 0, hits = 0, misses = 0;
    rto_status s = rto__bundle_in_open(&in, dir, "trace", "trace", msg);
    if (!s && !(s = rto__bundle_count(&in, "trace", "count", (uint64_t)INT64_MAX, &count)) &&
        !(s = rto__bundle_count(&in, "trace", "hits", count, &hits)) &&
        !(s = rto__bundle_count(&in, "trace", "misses", count, &misses)) && hits + misses != count)
        s = rto__bundle_refuse(&in, "manifest.json", "trace.hits %zu + trace.misses %zu is not trace.count %zu", hits,
                               misses, count);
    if (!s)
        s = rto_scene_bundle_read(dir, &tb->scene, msg);
    if (!s)
        s = load_rays_and_hits(&in, a, count, hits, misses);
    if (!s) {
        const char *set = rto_bundle_get_str(in.r, "trace", "rays");
        int64_t w = 0, h = 0;
        snprintf(tb->ray_set, sizeof tb->ray_set, "%s", set ? set : "?");
        if (rto_bundle_get_int(in.r, "trace", "width", &w) && rto_bundle_get_int(in.r, "trace", "height", &h) &&
            w > 0 && h > 0 && w <= UINT32_MAX && h <= UINT32_MAX) {
            tb->width = (uint32_t)w;
            tb->height = (uint32_t)h;
        }
    }
    rto__bundle_in_close(&in);
    if (s) {
        rto_trace_bundle_free(tb);
        return s;
    }
    tb->rays = a->rays.data;
    tb->hits = a->hits.data;
    tb->count = count;
    return RTO_OK;
}
