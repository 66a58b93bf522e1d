/* A frame's files and manifest sections (DESIGN.md §8): what `rtoracle render` writes after the scene's build and
 * geometry files. Names and roles come from rto_bundle_file_name / rto_bundle_file_role. */
#include "frame_internal.h"

#include <stdio.h>
#include <string.h>

static rto_status add(rto_bundle *b, rto_bundle_file f, uint32_t index, const char *layout, const rto_npy_desc *d,
                      const void *data, rto_msg *msg)
{
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    rto_status s = rto_bundle_file_name(f, index, name, sizeof name);
    if (s)
        return rto__fail(msg, s, "bundle file name");
    return rto_bundle_add_npy(b, name, rto_bundle_file_role(f), layout, d, data, msg);
}

static rto_status add_records(rto_bundle *b, rto_bundle_file f, uint32_t index, rto_layout layout, const void *data,
                              size_t n, rto_msg *msg)
{
    const rto_npy_desc d = rto_layout_desc(layout, n);
    return add(b, f, index, rto_layout_name(layout), &d, data, msg);
}

static void set_floats(rto_bundle *b, const char *section, const char *key, const float *v, uint32_t n)
{
    if (n == 1) {
        rto_bundle_set_real(b, section, key, (double)v[0]);
        return;
    }
    char text[128];
    size_t len = 0;
    for (uint32_t i = 0; i < n; i++)
        len += (size_t)snprintf(text + len, sizeof text - len, "%s%.9g", i ? "," : "", (double)v[i]);
    rto_bundle_set_str(b, section, key, text);
}

rto_status rto_frame_bundle_write(const rto_frame *f, int with_timings, rto_bundle *b, rto_msg *msg)
{
    if (!f || !b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL frame or bundle");
    const uint32_t rows = f->max_depth + 1;
    uint32_t emit[65];
    for (uint32_t d = 0; d < rows; d++)
        emit[d] = f->counters[d].emitted;
    const rto_npy_desc d1 = rto_npy_desc_array(RTO_DTYPE_U32, 1, rows, 0, 0);
    const rto_npy_desc d2 = rto_npy_desc_array(RTO_DTYPE_U32, 2, rows, 3, 0);
    rto_status s = add_records(b, RTO_FILE_CAMERA, 0, RTO_LAYOUT_CAMERA, &f->camera_uniforms, 1, msg);
    if (!s)
        s = add(b, RTO_FILE_EMIT_COUNTS, 0, NULL, &d1, emit, msg);
    if (!s)
        s = add(b, RTO_FILE_INDIRECT_ARGS, 0, NULL, &d2, f->indirect_args, msg);
    if (!s)
        s = add_records(b, RTO_FILE_FRAME_COUNTERS, 0, RTO_LAYOUT_FRAME_COUNTERS, f->counters, rows, msg);
    /* Every kept buffer is written, empty ones too (shape (0,)), so a harness finds one file per queue. */
    static const uint32_t none[1];
    for (uint32_t d = 0; !s && d < rows; d++) {
        const rto_frame_queue *q = &f->queues[d];
        const int traced = d < f->max_depth;
        if (f->keep & RTO_FRAME_KEEP_RAYS)
            s = add_records(b, RTO_FILE_BOUNCE_RAYS, d, RTO_LAYOUT_WF_RAY, q->rays ? (const void *)q->rays : none,
                            q->count, msg);
        if (!s && traced && (f->keep & RTO_FRAME_KEEP_HITS))
            s = add_records(b, RTO_FILE_BOUNCE_HITS, d, RTO_LAYOUT_HIT_RECORD, q->hits ? (const void *)q->hits : none,
                            q->count, msg);
        if (!s && traced && (f->keep & RTO_FRAME_KEEP_TRACE_COUNTERS))
            s = add_records(b, RTO_FILE_BOUNCE_TRACE_COUNTERS, d, RTO_LAYOUT_TRACE_COUNTERS,
                            q->trace_counters ? (const void *)q->trace_counters : none, q->count, msg);
        if (!s && f->payload_size && (f->keep & RTO_FRAME_KEEP_PAYLOADS)) {
            const rto_npy_desc dp = rto_npy_desc_array(RTO_DTYPE_U32, 2, q->count, f->payload_size / 4, 0);
            s = add(b, RTO_FILE_BOUNCE_PAYLOADS, d, NULL, &dp, q->payloads ? (const void *)q->payloads : none, msg);
        }
    }
    char name[RTO_BUNDLE_FILE_NAME_MAX];
    if (!s && (f->keep & RTO_FRAME_KEEP_ACCUM)) {
        const rto_npy_desc da = rto_npy_desc_array(RTO_DTYPE_F32, 3, f->height, f->width, 4);
        s = add(b, RTO_FILE_ACCUM, 0, NULL, &da, f->accum, msg);
    }
    if (!s && (f->keep & RTO_FRAME_KEEP_ACCUM_EXR)) {
        const rto_image img = {f->width, f->height, 4, RTO_PIXEL_F32, f->accum};
        if (!(s = rto_bundle_file_name(RTO_FILE_ACCUM_EXR, 0, name, sizeof name)))
            s = rto_bundle_add_image(b, name, rto_bundle_file_role(RTO_FILE_ACCUM_EXR), &img, msg);
    }
    if (!s && !(s = rto_bundle_file_name(RTO_FILE_IMAGE, 0, name, sizeof name))) {
        const rto_image img = {f->width, f->height, 4, RTO_PIXEL_U8, f->image};
        s = rto_bundle_add_image(b, name, rto_bundle_file_role(RTO_FILE_IMAGE), &img, msg);
    }
    if (!s) {
        const rto_npy_desc dn = rto_npy_desc_array(RTO_DTYPE_U8, 2, f->height, f->width, 0);
        s = add(b, RTO_FILE_NOT_COMPARABLE, 0, NULL, &dn, f->not_comparable, msg);
    }
    if (s)
        return s;

    char keep[96];
    rto__frame_keep_text(f->keep, keep, sizeof keep);
    rto_bundle_set_int(b, "frame", "width", f->width);
    rto_bundle_set_int(b, "frame", "height", f->height);
    rto_bundle_set_int(b, "frame", "max_depth", f->max_depth);
    rto_bundle_set_int(b, "frame", "capacity", (int64_t)f->capacity);
    rto_bundle_set_int(b, "frame", "payload_size", f->payload_size);
    rto_bundle_set_str(b, "frame", "stages", keep);
    rto_bundle_set_int(b, "frame", "invalid_calls", (int64_t)f->invalid_calls);
    rto_bundle_set_str(b, "program", "name", f->program);
    rto_bundle_set_str(b, "program", "kind", rto_program_builtin(f->program) ? "built-in" : "plugin");
    for (uint32_t i = 0; i < f->param_count; i++)
        set_floats(b, "parameters", f->params[i].name, f->params[i].value, f->params[i].count);
    rto_bundle_set_str(b, "camera", "name", f->camera.name);
    const rto_vec3 *vecs[3] = {&f->camera.position, &f->camera.target, &f->camera.up};
    static const char *const vec_keys[3] = {"position", "target", "up"};
    for (int i = 0; i < 3; i++) {
        const float v[3] = {vecs[i]->x, vecs[i]->y, vecs[i]->z};
        set_floats(b, "camera", vec_keys[i], v, 3);
    }
    rto_bundle_set_real(b, "camera", "fov_y_degrees", (double)f->camera.fov_y * 180.0 / 3.14159265358979323846);
    /* the aspect the projection used: the camera's own (a glTF camera's aspectRatio) or else the image's */
    const int own_aspect = f->camera.aspect > 0.0f;
    rto_bundle_set_real(b, "camera", "aspect", own_aspect ? (double)f->camera.aspect
                                                          : (double)f->width / (double)f->height);
    rto_bundle_set_str(b, "camera", "aspect_from", own_aspect ? "camera" : "image");
    rto_bundle_set_real(b, "camera", "znear", (double)f->camera.znear);
    rto_bundle_set_real(b, "camera", "zfar", (double)f->camera.zfar);
    uint64_t tot[10] = {0};
    for (uint32_t d = 0; d < rows; d++) {
        uint32_t c[10];
        RTO_STATIC_ASSERT(sizeof c == sizeof f->counters[0], "ten counters");
        memcpy(c, &f->counters[d], sizeof c);
        for (int k = 0; k < 10; k++)
            tot[k] += c[k];
    }
    static const char *const keys[10] = {"emitted", "queued", "dropped", "refused", "traced",
                                         "hits", "misses", "shaded", "accumulates", "conflicts"};
    for (int k = 0; k < 10; k++)
        rto_bundle_set_int(b, "counters", keys[k], (int64_t)tot[k]);
    if (with_timings) {
        double total = 0;
        for (int st = 0; st < RTO_FRAME_STAGE_COUNT; st++) {
            rto_bundle_set_real(b, "timings", rto_frame_stage_name((rto_frame_stage)st), f->seconds[st]);
            total += f->seconds[st];
        }
        rto_bundle_set_real(b, "timings", "total", total);
    }
    return RTO_OK;
}
