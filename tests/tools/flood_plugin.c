/* Test program plugin: a frame with accumulate conflicts and, on request, drops at capacity, the two cases where a
 * GPU's frame is not comparable with the oracle's pixel for pixel (cli.check_frame).
 *
 * Raygen emits one camera ray per pixel, and a second one (weight 0.5) for pixels with x < 4, so those pixels
 * accumulate twice in the first SHADE pass: a conflict. Each primary ray's hit or miss accumulates its weight times a
 * colour and emits `emit` (0 .. 2) secondary rays along its direction; with emit = 2 the second queue receives
 * 2 (W H + 4 H) emits for 2 W H slots, so 8 H of them are dropped. Secondary rays only count. */
#include <rtoracle.h>

enum { EMIT };

static const rto_program_param params[] = {
    [EMIT] = {"emit", 1, {2.0f, 0, 0, 0}, "secondary rays each primary ray emits (0, 1 or 2)"},
};

static void raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    rto_wf_ray ray = rto_frame_camera_ray(ctx, x, y);
    ray.kind = RTO_RAY_KIND_PRIMARY;
    const float one = 1.0f, half = 0.5f;
    rto_emit_primary_ray(ctx, &ray, &one);
    if (x < 4)
        rto_emit_primary_ray(ctx, &ray, &half);
}

static void shade(rto_frame_ctx *ctx, const rto_wf_ray *ray, float t, const void *payload)
{
    if (ray->kind != RTO_RAY_KIND_PRIMARY)
        return;
    const float w = *(const float *)payload;
    const float rgb[3] = {0.25f * w, 0.5f * w, t > 0.0f ? 0.75f * w : 0.1f * w};
    rto_accumulate(ctx, ray->pixel, rgb);
    const int n = (int)ctx->env->params[EMIT][0];
    for (int k = 0; k < n && k < 2; k++) {
        rto_wf_ray r = *ray;
        r.kind = RTO_RAY_KIND_SHADOW;
        r.t_min = ctx->env->ray_offset;
        r.flags = RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT;
        rto_emit_ray(ctx, &r, payload);
    }
}

static void closest_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    shade(ctx, ray, hit->t, payload);
}

static void miss(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload) { shade(ctx, ray, 0.0f, payload); }

static const rto_program program = {
    RTO_PROGRAM_ABI_VERSION, "flood", "conflicts at x < 4 and, with emit = 2, drops in the second queue", 4, 2, params,
    1, NULL, NULL, raygen, closest_hit, miss, NULL,
};

__attribute__((visibility("default"))) const rto_program *rto_program_entry_v1(void);
const rto_program *rto_program_entry_v1(void) { return &program; }
