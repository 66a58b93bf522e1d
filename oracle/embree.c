/* Embree 3 beside the oracle (see embree.h for what differs from the oracle and how it is bridged). */
#include "embree.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

struct emb_device {
    RTCDevice dev;
    char config[160];
    bool ray_masks;
    /* The first error the callback saw since the last emb_device_check. The callback may run on Embree's worker
     * threads during a commit, hence the lock. */
    pthread_mutex_t lock;
    enum RTCError error;
    char error_text[256];
};

struct emb_scene {
    emb_device *d;
    const rto_scene *scene;
    emb_scene_desc desc;
    RTCScene top;
    RTCScene *blas; /* one per mesh; NULL for an empty mesh */
    uint8_t mask_excludes[256]; /* [c]: some instance of a non-empty mesh has (mask & c) == 0 */
};

static const char *error_name(enum RTCError e)
{
    switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    }
    return "error";
}

static rto_status error_status(enum RTCError e)
{
    switch (e) {
    case RTC_ERROR_NONE: return RTO_OK;
    case RTC_ERROR_OUT_OF_MEMORY: return RTO_ERR_OUT_OF_MEMORY;
    case RTC_ERROR_INVALID_ARGUMENT: return RTO_ERR_INVALID_ARGUMENT;
    default: return RTO_ERR_UNSUPPORTED;
    }
}

/* Embree's device error callback: keep the first error for emb_device_check; print nothing. */
static void on_error(void *user, enum RTCError code, const char *text)
{
    emb_device *d = user;
    pthread_mutex_lock(&d->lock);
    if (d->error == RTC_ERROR_NONE) {
        d->error = code;
        snprintf(d->error_text, sizeof d->error_text, "%s", text ? text : "");
        /* one line: a detail with a newline would break the one-line message channel */
        for (char *p = d->error_text; *p; p++)
            if (*p == '\n' || *p == '\r')
                *p = ' ';
    }
    pthread_mutex_unlock(&d->lock);
}

rto_status emb_device_check(emb_device *d, const char *what, rto_msg *msg)
{
    /* rtcGetDeviceError clears Embree's sticky code; the callback has normally seen the error already. */
    enum RTCError sticky = rtcGetDeviceError(d->dev);
    pthread_mutex_lock(&d->lock);
    enum RTCError e = d->error != RTC_ERROR_NONE ? d->error : sticky;
    char text[256];
    snprintf(text, sizeof text, "%s", d->error != RTC_ERROR_NONE ? d->error_text : "");
    d->error = RTC_ERROR_NONE;
    d->error_text[0] = 0;
    pthread_mutex_unlock(&d->lock);
    if (e == RTC_ERROR_NONE)
        return RTO_OK;
    if (text[0])
        return rto_msg_set(msg, error_status(e), "Embree error during %s: %s (%s)", what, error_name(e), text);
    return rto_msg_set(msg, error_status(e), "Embree error during %s: %s", what, error_name(e));
}

rto_status emb_device_create(uint32_t threads, const char *extra, emb_device **out, rto_msg *msg)
{
    *out = NULL;
    emb_device *d = calloc(1, sizeof *d);
    if (!d)
        return rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for an Embree device");
    char base[32] = "";
    if (threads)
        snprintf(base, sizeof base, "threads=%u", threads);
    bool more = extra && *extra;
    int len = snprintf(d->config, sizeof d->config, "%s%s%s", base, *base && more ? "," : "", more ? extra : "");
    if (len < 0 || (size_t)len >= sizeof d->config) {
        free(d);
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "Embree device config too long");
    }
    pthread_mutex_init(&d->lock, NULL);
    d->dev = rtcNewDevice(d->config);
    if (!d->dev) {
        /* No device, no callback: the error is the thread's, read with a NULL device. */
        enum RTCError e = rtcGetDeviceError(NULL);
        pthread_mutex_destroy(&d->lock);
        rto_status s = rto_msg_set(msg, e == RTC_ERROR_NONE ? RTO_ERR_UNSUPPORTED : error_status(e),
                                   "Embree device (config \"%s\") could not be created: %s", d->config, error_name(e));
        free(d);
        return s;
    }
    rtcSetDeviceErrorFunction(d->dev, on_error, d);
    d->ray_masks = rtcGetDeviceProperty(d->dev, RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED) != 0;
    rto_status s = emb_device_check(d, "device creation", msg);
    if (s) {
        emb_device_destroy(d);
        return s;
    }
    *out = d;
    return RTO_OK;
}

void emb_device_destroy(emb_device *d)
{
    if (!d)
        return;
    rtcReleaseDevice(d->dev);
    pthread_mutex_destroy(&d->lock);
    free(d);
}

RTCDevice emb_device_rtc(const emb_device *d) { return d->dev; }
const char *emb_device_config(const emb_device *d) { return d->config; }
bool emb_device_ray_masks(const emb_device *d) { return d->ray_masks; }

const char *emb_quality_name(emb_quality q)
{
    switch (q) {
    case EMB_QUALITY_LOW: return "low";
    case EMB_QUALITY_HIGH: return "high";
    default: return "medium";
    }
}

enum RTCBuildQuality emb_quality_rtc(emb_quality q)
{
    switch (q) {
    case EMB_QUALITY_LOW: return RTC_BUILD_QUALITY_LOW;
    case EMB_QUALITY_HIGH: return RTC_BUILD_QUALITY_HIGH;
    default: return RTC_BUILD_QUALITY_MEDIUM;
    }
}

/* ---- culling -------------------------------------------------------------------------------------------------- */

/* What the filters need beside Embree's own context: the world-space ray being traced and the mirror. Embree hands
 * the filter the context pointer it was given, so the context is the first member. */
typedef struct emb_ctx {
    struct RTCIntersectContext ctx;
    const rto_wf_ray *ray;
    const emb_scene *s;
} emb_ctx;

/* Intersection / occlusion filter for CULL_BACK_FACING / CULL_FRONT_FACING rays. Embree 3 has no per-ray culling,
 * so the facing is decided here as the oracle decides it (DESIGN.md §6): the sign of the Möller–Trumbore
 * determinant det = dot(e1, cross(d', e2)) with d' the object-space direction (det > 0: front, counter-clockwise as
 * seen from the origin; a mirroring instance flips it). It is evaluated in binary64 from the scene's worldToObj and
 * vertices, independently of how Embree transformed the ray; it can differ from the oracle's binary32 sign only
 * where det is near 0, i.e. for rays grazing the triangle's plane. */
static void cull_filter(const struct RTCFilterFunctionNArguments *args)
{
    const emb_ctx *c = (const emb_ctx *)args->context;
    uint32_t flags = c->ray->flags & (RTO_RAY_FLAG_CULL_BACK_FACING | RTO_RAY_FLAG_CULL_FRONT_FACING);
    if (!flags)
        return;
    const rto_scene *sc = c->s->scene;
    for (unsigned i = 0; i < args->N; i++) {
        if (!args->valid[i])
            continue;
        uint32_t inst = args->context->instID[0];
        /* RTCHitN is structure-of-arrays: primID is the sixth array of N (rtcore_ray.h's C++ RTCHitN_primID) */
        uint32_t prim = ((const unsigned *)args->hit)[5 * args->N + i];
        if (inst >= sc->instance_count)
            continue;
        const rto_instance *in = &sc->instances[inst];
        const rto_mesh *m = &sc->meshes[in->blas];
        if (prim >= m->triangle_count)
            continue;
        double d[3];
        for (int r = 0; r < 3; r++)
            d[r] = (double)in->world_to_obj.m[r][0] * c->ray->dir[0] + (double)in->world_to_obj.m[r][1] * c->ray->dir[1] +
                   (double)in->world_to_obj.m[r][2] * c->ray->dir[2];
        const float *v0 = m->positions + 3 * (size_t)m->indices[3 * (size_t)prim];
        const float *v1 = m->positions + 3 * (size_t)m->indices[3 * (size_t)prim + 1];
        const float *v2 = m->positions + 3 * (size_t)m->indices[3 * (size_t)prim + 2];
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)v1[k] - v0[k];
            e2[k] = (double)v2[k] - v0[k];
        }
        double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
        double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (((flags & RTO_RAY_FLAG_CULL_BACK_FACING) && det < 0) || ((flags & RTO_RAY_FLAG_CULL_FRONT_FACING) && det > 0))
            args->valid[i] = 0;
    }
}

/* ---- mirrors -------------------------------------------------------------------------------------------------- */

RTCScene emb_mesh_scene_new(emb_device *d, const rto_mesh *mesh, emb_quality quality, bool robust)
{
    RTCScene sc = rtcNewScene(d->dev);
    if (!sc)
        return NULL;
    rtcSetSceneBuildQuality(sc, emb_quality_rtc(quality));
    if (robust)
        rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(d->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g) {
        rtcReleaseScene(sc);
        return NULL;
    }
    rtcSetGeometryBuildQuality(g, emb_quality_rtc(quality));
    /* Embree's own buffers (it pads them for its vector loads), filled with a copy of the mesh. */
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, mesh->vertex_count);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, mesh->triangle_count);
    if (!vb || !ib) {
        rtcReleaseGeometry(g);
        rtcReleaseScene(sc);
        return NULL;
    }
    memcpy(vb, mesh->positions, (size_t)mesh->vertex_count * 12);
    memcpy(ib, mesh->indices, (size_t)mesh->triangle_count * 12);
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    return sc;
}

bool emb_instance_attach(emb_device *d, RTCScene top, RTCScene blas, const rto_instance *instance, uint32_t id,
                         emb_quality quality)
{
    RTCGeometry g = rtcNewGeometry(d->dev, RTC_GEOMETRY_TYPE_INSTANCE);
    if (!g)
        return false;
    rtcSetGeometryBuildQuality(g, emb_quality_rtc(quality));
    rtcSetGeometryInstancedScene(g, blas);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &instance->obj_to_world.m[0][0]);
    rtcSetGeometryMask(g, instance->mask);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(top, g, id);
    rtcReleaseGeometry(g);
    return true;
}

rto_status emb_scene_create(emb_device *d, const rto_scene *scene, const emb_scene_desc *desc, emb_scene **out,
                            rto_msg *msg)
{
    *out = NULL;
    if (scene->instance_count > RTO_TLAS_MAX_INSTANCES)
        return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "Embree mirror: %u instances, at most %u",
                           scene->instance_count, RTO_TLAS_MAX_INSTANCES);
    emb_scene *s = calloc(1, sizeof *s);
    if (s)
        s->blas = calloc(scene->mesh_count ? scene->mesh_count : 1, sizeof *s->blas);
    if (!s || !s->blas) {
        free(s);
        return rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the Embree mirror");
    }
    s->d = d;
    s->scene = scene;
    if (desc)
        s->desc = *desc;
    emb_device_check(d, "earlier work", NULL); /* start from a clean slate */
    rto_status st = RTO_OK;
    for (uint32_t m = 0; m < scene->mesh_count && !st; m++) {
        if (!scene->meshes[m].triangle_count)
            continue;
        RTCScene b = emb_mesh_scene_new(d, &scene->meshes[m], s->desc.quality, s->desc.robust);
        s->blas[m] = b;
        if (b && s->desc.culling) {
            RTCGeometry g = rtcGetGeometry(b, 0);
            rtcSetGeometryIntersectFilterFunction(g, cull_filter);
            rtcSetGeometryOccludedFilterFunction(g, cull_filter);
            rtcCommitGeometry(g);
        }
        if (b)
            rtcCommitScene(b);
        st = emb_device_check(d, "the mesh scenes' commit", msg);
        if (!st && !b)
            st = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "Embree could not create the scene of mesh %u", m);
    }
    if (!st) {
        s->top = rtcNewScene(d->dev);
        if (s->top) {
            rtcSetSceneBuildQuality(s->top, emb_quality_rtc(s->desc.quality));
            if (s->desc.robust)
                rtcSetSceneFlags(s->top, RTC_SCENE_FLAG_ROBUST);
        }
        for (uint32_t i = 0; s->top && i < scene->instance_count; i++) {
            const rto_instance *in = &scene->instances[i];
            if (in->blas < scene->mesh_count && s->blas[in->blas])
                emb_instance_attach(d, s->top, s->blas[in->blas], in, i, s->desc.quality);
        }
        if (s->top)
            rtcCommitScene(s->top);
        st = emb_device_check(d, "the top scene's commit", msg);
        if (!st && !s->top)
            st = rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "Embree could not create the top scene");
    }
    for (uint32_t c = 0; c < 256; c++)
        for (uint32_t i = 0; i < scene->instance_count; i++) {
            const rto_instance *in = &scene->instances[i];
            if (in->blas < scene->mesh_count && scene->meshes[in->blas].triangle_count && !(in->mask & c)) {
                s->mask_excludes[c] = 1;
                break;
            }
        }
    if (st) {
        emb_scene_destroy(s);
        return st;
    }
    *out = s;
    return RTO_OK;
}

void emb_scene_destroy(emb_scene *s)
{
    if (!s)
        return;
    if (s->top)
        rtcReleaseScene(s->top);
    for (uint32_t m = 0; m < s->scene->mesh_count; m++)
        if (s->blas[m])
            rtcReleaseScene(s->blas[m]);
    free(s->blas);
    free(s);
}

RTCScene emb_scene_top(const emb_scene *s) { return s->top; }
const emb_scene_desc *emb_scene_get_desc(const emb_scene *s) { return &s->desc; }

/* ---- tracing -------------------------------------------------------------------------------------------------- */

/* The library's limit on tracing threads (rto_trace_desc.threads), so both sides split rays alike. */
#define EMB_THREADS_MAX 256u

uint32_t emb_thread_count(uint32_t threads)
{
    if (threads)
        return threads > EMB_THREADS_MAX ? EMB_THREADS_MAX : threads;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1)
        return 1;
    return n > (long)EMB_THREADS_MAX ? EMB_THREADS_MAX : (uint32_t)n;
}

void emb_partition(size_t n, uint32_t parts, uint32_t k, size_t *begin, size_t *end)
{
    /* [k n / parts, (k + 1) n / parts): the split rto_trace uses (ranges of equal size +-1). */
    if (!parts)
        parts = 1;
    *begin = (size_t)((uint64_t)n * k / parts);
    *end = (size_t)((uint64_t)n * (k + 1) / parts);
}

static bool finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* Embree's largest accepted origin and direction component (its FLT_LARGE, checked by an assertion in Debian's
 * build) */
#define EMB_COORD_MAX 1.844e18f

static bool embree_range(const float v[3])
{
    return fabsf(v[0]) <= EMB_COORD_MAX && fabsf(v[1]) <= EMB_COORD_MAX && fabsf(v[2]) <= EMB_COORD_MAX;
}

rto_status emb_rays_check(const emb_scene *s, const emb_device *d, const rto_wf_ray *rays, size_t n, rto_msg *msg)
{
    for (size_t i = 0; i < n; i++) {
        const rto_wf_ray *r = &rays[i];
        if (!finite3(r->origin) || !finite3(r->dir) || !isfinite(r->t_min) || !isfinite(r->t_max))
            return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "ray %zu: origin, direction, tMin or tMax not finite", i);
        if (r->t_min > r->t_max)
            return rto_msg_set(msg, RTO_ERR_INVALID_ARGUMENT, "ray %zu: tMin %.9g > tMax %.9g", i, r->t_min, r->t_max);
        if (r->t_min < 0)
            return rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "ray %zu: tMin %.9g < 0, which Embree does not trace", i,
                               r->t_min);
        if (!embree_range(r->origin) || !embree_range(r->dir))
            return rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "ray %zu: an origin or direction component beyond %.4g, "
                               "which Embree does not trace", i, (double)EMB_COORD_MAX);
        if (!d->ray_masks && s->mask_excludes[r->cull_mask & 0xFF])
            return rto_msg_set(msg, RTO_ERR_UNSUPPORTED,
                               "ray %zu: cull mask 0x%02x excludes instances, and this Embree was built without ray "
                               "masks", i, r->cull_mask & 0xFF);
        if (!s->desc.culling && (r->flags & (RTO_RAY_FLAG_CULL_BACK_FACING | RTO_RAY_FLAG_CULL_FRONT_FACING)))
            return rto_msg_set(msg, RTO_ERR_UNSUPPORTED,
                               "ray %zu: culling flags 0x%x, and the Embree mirror was made without culling", i,
                               r->flags);
    }
    return RTO_OK;
}

static void record_miss(rto_hit_record *h, float t_max)
{
    memset(h, 0, sizeof *h);
    h->t = t_max;
    h->instance_id = h->prim_id = h->hit_group = h->custom_index = UINT32_MAX;
    h->miss_flag = 1;
}

static void record_hit(const rto_scene *sc, rto_hit_record *h, float t, uint32_t inst, uint32_t prim, float u, float v)
{
    memset(h, 0, sizeof *h);
    h->t = t;
    h->instance_id = inst;
    h->prim_id = prim;
    h->bary[0] = u;
    h->bary[1] = v;
    h->miss_flag = 0;
    if (inst < sc->instance_count) {
        const rto_instance *in = &sc->instances[inst];
        h->hit_group = in->sbt_offset;
        h->custom_index = in->custom_index;
        for (int c = 0; c < 4; c++)
            for (int r = 0; r < 3; r++)
                h->obj_to_world[c][r] = in->obj_to_world.m[r][c];
    } else {
        h->hit_group = h->custom_index = UINT32_MAX;
    }
}

static void to_rtc(const rto_wf_ray *r, struct RTCRay *out)
{
    out->org_x = r->origin[0];
    out->org_y = r->origin[1];
    out->org_z = r->origin[2];
    /* Embree accepts tnear < t <= tfar, the oracle tMin <= t < tMax: move both ends one float down, so a hit at
     * exactly tMin counts and one at exactly tMax does not. Embree asserts tnear >= 0, so tMin 0 stays 0 (a hit at
     * exactly t = 0, an origin on a surface, may be the oracle's alone). */
    out->tnear = r->t_min > 0 ? nextafterf(r->t_min, 0) : 0;
    out->dir_x = r->dir[0];
    out->dir_y = r->dir[1];
    out->dir_z = r->dir[2];
    out->time = 0;
    out->tfar = fmaxf(nextafterf(r->t_max, -INFINITY), out->tnear);
    out->mask = r->cull_mask & 0xFF;
    out->id = 0;
    out->flags = 0;
}

/* The record of a TERMINATE_ON_FIRST_HIT ray after rtcOccluded: Embree marks an occluded ray with tfar = -inf. */
static void record_occluded(rto_hit_record *h, const struct RTCRay *ray, float t_max)
{
    if (ray->tfar < 0 && isinf(ray->tfar)) {
        memset(h, 0, sizeof *h);
        h->t = -INFINITY;
        h->instance_id = h->prim_id = h->hit_group = h->custom_index = UINT32_MAX;
    } else {
        record_miss(h, t_max);
    }
}

static void trace_one(const emb_scene *s, const rto_wf_ray *r, bool closest, rto_hit_record *h)
{
    emb_ctx c;
    rtcInitIntersectContext(&c.ctx);
    c.ray = r;
    c.s = s;
    if (!closest && (r->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT)) {
        struct RTCRay ray;
        to_rtc(r, &ray);
        rtcOccluded1(s->top, &c.ctx, &ray);
        record_occluded(h, &ray, r->t_max);
        return;
    }
    struct RTCRayHit rh;
    to_rtc(r, &rh.ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->top, &c.ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        record_miss(h, r->t_max);
    else /* instID[0] is the geometry ID of the instance in the top scene: its index (emb_instance_attach) */
        record_hit(s->scene, h, rh.ray.tfar, rh.hit.instID[0], rh.hit.primID, rh.hit.u, rh.hit.v);
}

void emb_trace_closest(const emb_scene *s, const rto_wf_ray *ray, rto_hit_record *hit) { trace_one(s, ray, true, hit); }

typedef struct trace_job {
    const emb_scene *s;
    const rto_wf_ray *rays;
    rto_hit_record *hits;
    size_t begin, end;
    emb_api api;
} trace_job;

/* Rays [begin, end) as streams of STREAM rays: rtcIntersect1M (rtcOccluded1M for a run of TERMINATE_ON_FIRST_HIT
 * rays), each ray's record as trace_one writes it. */
#define STREAM 256
static void trace_stream(const emb_scene *s, const rto_wf_ray *rays, size_t begin, size_t end, bool coherent,
                         rto_hit_record *hits)
{
    struct RTCRayHit rh[STREAM];
    emb_ctx c;
    rtcInitIntersectContext(&c.ctx);
    c.ctx.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    c.ray = NULL; /* no filter runs: emb_trace refuses culling rays in a stream */
    c.s = s;
    for (size_t i = begin; i < end;) {
        const bool occ = (rays[i].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
        unsigned m = 0;
        while (i + m < end && m < STREAM && ((rays[i + m].flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0) == occ) {
            to_rtc(&rays[i + m], &rh[m].ray);
            rh[m].hit.geomID = rh[m].hit.primID = rh[m].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            m++;
        }
        if (occ)
            rtcOccluded1M(s->top, &c.ctx, &rh[0].ray, m, sizeof rh[0]);
        else
            rtcIntersect1M(s->top, &c.ctx, rh, m, sizeof rh[0]);
        for (unsigned k = 0; k < m; k++) {
            rto_hit_record *h = &hits[i + k];
            if (occ)
                record_occluded(h, &rh[k].ray, rays[i + k].t_max);
            else if (rh[k].hit.geomID == RTC_INVALID_GEOMETRY_ID)
                record_miss(h, rays[i + k].t_max);
            else
                record_hit(s->scene, h, rh[k].ray.tfar, rh[k].hit.instID[0], rh[k].hit.primID, rh[k].hit.u,
                           rh[k].hit.v);
        }
        i += m;
    }
}

static void *trace_range(void *arg)
{
    const trace_job *j = arg;
    if (j->api != EMB_API_SINGLE) {
        trace_stream(j->s, j->rays, j->begin, j->end, j->api == EMB_API_STREAM_COHERENT, j->hits);
        return NULL;
    }
    for (size_t i = j->begin; i < j->end; i++)
        trace_one(j->s, &j->rays[i], false, &j->hits[i]);
    return NULL;
}

rto_status emb_trace(const emb_scene *s, emb_device *d, const rto_wf_ray *rays, size_t n, uint32_t threads,
                     rto_hit_record *hits, rto_msg *msg)
{
    return emb_trace_api(s, d, rays, n, threads, EMB_API_SINGLE, hits, msg);
}

rto_status emb_trace_api(const emb_scene *s, emb_device *d, const rto_wf_ray *rays, size_t n, uint32_t threads,
                         emb_api api, rto_hit_record *hits, rto_msg *msg)
{
    rto_status st = emb_rays_check(s, d, rays, n, msg);
    if (st)
        return st;
    if (api != EMB_API_SINGLE && s->desc.culling)
        return rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "a ray stream through an Embree mirror made with culling");
    uint32_t t = emb_thread_count(threads);
    if ((size_t)t > n)
        t = n ? (uint32_t)n : 1;
    trace_job *jobs = calloc(t, sizeof *jobs);
    pthread_t *tid = calloc(t, sizeof *tid);
    if (!jobs || !tid) {
        free(jobs);
        free(tid);
        return rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u tracing threads", t);
    }
    uint32_t started = 0;
    for (uint32_t k = 0; k < t; k++) {
        jobs[k] = (trace_job){s, rays, hits, 0, 0, api};
        emb_partition(n, t, k, &jobs[k].begin, &jobs[k].end);
    }
    /* The calling thread takes part 0, so one thread means no thread is created at all. */
    for (uint32_t k = 1; k < t; k++) {
        if (pthread_create(&tid[k], NULL, trace_range, &jobs[k]))
            break;
        started = k;
    }
    trace_range(&jobs[0]);
    for (uint32_t k = 1; k <= started; k++)
        pthread_join(tid[k], NULL);
    /* A part whose thread could not be started is traced here: slower, same result. */
    for (uint32_t k = started + 1; k < t; k++)
        trace_range(&jobs[k]);
    free(jobs);
    free(tid);
    return emb_device_check(d, "tracing", msg);
}
