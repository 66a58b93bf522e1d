/* The built-in programs of DESIGN.md §7 (one per seed scene), the surface a closest-hit program shades, texture
 * sampling, and the checks every program table passes before a frame runs it. Every formula is binary32 in the
 * operation order written here (DESIGN.md §7 states it), so a GPU port can match it. */
#include "frame_internal.h"

#include <math.h>
#include <pthread.h>
#include <string.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Vector helpers                                                                                                   */

static float dot3(const float a[3], const float b[3]) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }

void rto__normalize3(const float v[3], float out[3])
{
    const float len = sqrtf(dot3(v, v));
    for (int c = 0; c < 3; c++)
        out[c] = v[c] / len;
}

/* w0 a + w1 b + w2 c, summed left to right */
static float interp(float w0, float w1, float w2, float a, float b, float c) { return (w0 * a + w1 * b) + w2 * c; }

/* The object-space normal n to world space: transpose(W2O) n, each row ((m0r x + m1r y) + m2r z), then unit. */
static void normal_to_world(const rto_mat34 *w2o, const float n[3], float out[3])
{
    float w[3];
    for (int r = 0; r < 3; r++)
        w[r] = (w2o->m[0][r] * n[0] + w2o->m[1][r] * n[1]) + w2o->m[2][r] * n[2];
    rto__normalize3(w, out);
}

static int finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* ---------------------------------------------------------------------------------------------------------------- */
/* Textures: bilinear, wrap (REPEAT), sRGB decoded per texel before filtering, as a GPU's sRGB texture does        */

static float srgb_table[256];
static pthread_once_t srgb_once = PTHREAD_ONCE_INIT;

static void srgb_init(void)
{
    for (int i = 0; i < 256; i++) {
        const float c = (float)i / 255.0f;
        srgb_table[i] = c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
    }
}

/* floor(x) mod n for any finite x, in [0, n) */
static uint32_t wrap_index(double x, uint32_t n) { return (uint32_t)(x - (double)n * floor(x / (double)n)) % n; }

void rto__texture_sample(const rto_scene *scene, int32_t texture, const float uv[2], float rgba[4])
{
    if (!scene || texture < 0 || (uint32_t)texture >= scene->texture_count || !scene->textures[texture].rgba ||
        !scene->textures[texture].width || !scene->textures[texture].height) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
        return;
    }
    pthread_once(&srgb_once, srgb_init);
    const rto_texture *t = &scene->textures[texture];
    /* texel centres at +0.5; row 0 is the top row, where glTF's v = 0 is */
    const float x = (isfinite(uv[0]) ? uv[0] : 0.0f) * (float)t->width - 0.5f;
    const float y = (isfinite(uv[1]) ? uv[1] : 0.0f) * (float)t->height - 0.5f;
    const float x0 = floorf(x), y0 = floorf(y);
    const float fx = x - x0, fy = y - y0;
    const uint32_t ix0 = wrap_index(x0, t->width), iy0 = wrap_index(y0, t->height);
    const uint32_t ix1 = (ix0 + 1) % t->width, iy1 = (iy0 + 1) % t->height;
    const uint8_t *row0 = t->rgba + 4 * (size_t)iy0 * t->width, *row1 = t->rgba + 4 * (size_t)iy1 * t->width;
    const uint8_t *p00 = row0 + 4 * ix0, *p10 = row0 + 4 * ix1, *p01 = row1 + 4 * ix0, *p11 = row1 + 4 * ix1;
    for (int c = 0; c < 4; c++) {
        float a, b, cc, d;
        if (c < 3) {
            a = srgb_table[p00[c]], b = srgb_table[p10[c]], cc = srgb_table[p01[c]], d = srgb_table[p11[c]];
        } else {
            a = (float)p00[c] / 255.0f, b = (float)p10[c] / 255.0f, cc = (float)p01[c] / 255.0f,
            d = (float)p11[c] / 255.0f;
        }
        const float top = a * (1.0f - fx) + b * fx, bottom = cc * (1.0f - fx) + d * fx;
        rgba[c] = top * (1.0f - fy) + bottom * fy;
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The surface at a hit                                                                                             */

void rto__surface_mesh(const rto_frame_env *env, const rto_wf_ray *ray, const rto_hit_record *hit, rto_surface *out)
{
    const rto_scene *s = env->scene;
    memset(out, 0, sizeof *out);
    for (int c = 0; c < 3; c++)
        out->position[c] = ray->origin[c] + hit->t * ray->dir[c];
    out->material = -1;
    for (int c = 0; c < 4; c++)
        out->base_color[c] = 1.0f;
    if (hit->miss_flag || hit->instance_id >= s->instance_count)
        return;
    const rto_instance *inst = &s->instances[hit->instance_id];
    const rto_mesh *m = &s->meshes[inst->blas];
    if (hit->prim_id >= m->triangle_count)
        return;
    const uint32_t *ix = m->indices + 3 * (size_t)hit->prim_id;
    const float *v0 = m->positions + 3 * (size_t)ix[0], *v1 = m->positions + 3 * (size_t)ix[1],
                *v2 = m->positions + 3 * (size_t)ix[2];
    const float e1[3] = {v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]};
    const float e2[3] = {v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]};
    const float ng[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    normal_to_world(&inst->world_to_obj, ng, out->geometric_normal);
    const float u = hit->bary[0], v = hit->bary[1], w = (1.0f - u) - v;
    memcpy(out->normal, out->geometric_normal, sizeof out->normal);
    if (m->normals) {
        const float *n0 = m->normals + 3 * (size_t)ix[0], *n1 = m->normals + 3 * (size_t)ix[1],
                    *n2 = m->normals + 3 * (size_t)ix[2];
        const float n[3] = {interp(w, u, v, n0[0], n1[0], n2[0]), interp(w, u, v, n0[1], n1[1], n2[1]),
                            interp(w, u, v, n0[2], n1[2], n2[2])};
        float nw[3];
        normal_to_world(&inst->world_to_obj, n, nw);
        if (finite3(nw)) /* normals that cancel out (or a zero normal) keep the geometric one */
            memcpy(out->normal, nw, sizeof nw);
    }
    if (m->uvs) {
        const float *t0 = m->uvs + 2 * (size_t)ix[0], *t1 = m->uvs + 2 * (size_t)ix[1], *t2 = m->uvs + 2 * (size_t)ix[2];
        out->uv[0] = interp(w, u, v, t0[0], t1[0], t2[0]);
        out->uv[1] = interp(w, u, v, t0[1], t1[1], t2[1]);
    }
    if (m->material >= 0 && (uint32_t)m->material < s->material_count) {
        const rto_material *mat = &s->materials[m->material];
        out->material = m->material;
        float tex[4];
        rto__texture_sample(s, mat->base_color_texture, out->uv, tex);
        for (int c = 0; c < 4; c++)
            out->base_color[c] = mat->base_color[c] * tex[c];
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Built-in programs                                                                                                */

/* The primary ray of a pixel: the seed's generateRay (rto_camera_ray), kind PRIMARY, missIndex 0. */
static void emit_camera_ray(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const rto_wf_ray ray = rto_frame_camera_ray(ctx, x, y);
    rto_emit_primary_ray(ctx, &ray, NULL);
}

/* triangle (VulkanTriangle): barycentric colour, a dark blue miss, no resolve, maxDepth 1. */
static void triangle_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)payload;
    const float rgb[3] = {(1.0f - hit->bary[0]) - hit->bary[1], hit->bary[0], hit->bary[1]};
    rto_accumulate(ctx, ray->pixel, rgb);
}

static void triangle_miss(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    (void)payload;
    const float *miss = ctx->env->params[0];
    rto_accumulate(ctx, ray->pixel, miss);
}

static const rto_program_param triangle_params[] = {
    {"miss", 3, {0.0f, 0.0f, 0.2f, 0.0f}, "colour of a ray that hits nothing"},
};

/* normals (Stage-2): n * 0.5 + 0.5, the sky gradient on a miss, no resolve, maxDepth 1. */
static void normals_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)payload;
    rto_surface s;
    rto_surface_at(ctx, ray, hit, &s);
    float rgb[3];
    for (int c = 0; c < 3; c++)
        rgb[c] = s.normal[c] * 0.5f + 0.5f;
    rto_accumulate(ctx, ray->pixel, rgb);
}

/* The seed's sky: mix(a, b, t) = a (1 - t) + b t with t = 0.5 (dir.y + 1); a and b are parameters. */
static void sky(const rto_frame_ctx *ctx, const rto_wf_ray *ray, uint32_t horizon, uint32_t zenith, float rgb[3])
{
    const float *a = ctx->env->params[horizon], *b = ctx->env->params[zenith];
    const float t = 0.5f * (ray->dir[1] + 1.0f);
    for (int c = 0; c < 3; c++)
        rgb[c] = a[c] * (1.0f - t) + b[c] * t;
}

static void normals_miss(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    (void)payload;
    float rgb[3];
    sky(ctx, ray, 0, 1, rgb);
    rto_accumulate(ctx, ray->pixel, rgb);
}

static const rto_program_param normals_params[] = {
    {"sky_bottom", 3, {1.0f, 1.0f, 1.0f, 0.0f}, "sky colour looking straight down (dir.y = -1)"},
    {"sky_top", 3, {0.5f, 0.7f, 1.0f, 0.0f}, "sky colour looking straight up (dir.y = 1)"},
};

/* sun-shadow (Sponza): albedo * ambient at a primary hit, plus a shadow ray towards the sun carrying
 * albedo * sun * N.L, which adds it where it misses; sky on a primary miss; Reinhard then gamma 1/2.2. */
enum { SUN_DIR, SUN_COLOR, SUN_AMBIENT, SUN_SKY };
typedef struct sun_payload {
    float throughput[3];
} sun_payload;

static const rto_program_param sun_params[] = {
    [SUN_DIR] = {"sun_dir", 3, {0.3f, 1.0f, 0.2f, 0.0f}, "direction towards the sun (normalised)"},
    [SUN_COLOR] = {"sun_color", 3, {3.0f, 2.85f, 2.6f, 0.0f}, "radiance of the sun"},
    [SUN_AMBIENT] = {"ambient", 3, {0.15f, 0.15f, 0.18f, 0.0f}, "ambient light every primary hit gets"},
    [SUN_SKY] = {"sky", 3, {0.5f, 0.7f, 1.0f, 0.0f}, "colour of a primary ray that hits nothing"},
};

static int sun_init(const rto_frame_env *env, void **user, char *why, size_t cap)
{
    *user = NULL;
    float l[3];
    rto__normalize3(env->params[SUN_DIR], l);
    if (!finite3(l)) {
        snprintf(why, cap, "sun_dir (%g, %g, %g) cannot be normalised", (double)env->params[SUN_DIR][0],
                 (double)env->params[SUN_DIR][1], (double)env->params[SUN_DIR][2]);
        return 0;
    }
    return 1;
}

static void sun_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)payload;
    const rto_frame_env *env = ctx->env;
    rto_surface s;
    rto_surface_at(ctx, ray, hit, &s);
    float n[3];
    memcpy(n, s.normal, sizeof n);
    if (dot3(n, ray->dir) > 0.0f) /* face the viewer: glTF surfaces are seen from both sides */
        for (int c = 0; c < 3; c++)
            n[c] = -n[c];
    float ambient[3];
    for (int c = 0; c < 3; c++)
        ambient[c] = s.base_color[c] * env->params[SUN_AMBIENT][c];
    rto_accumulate(ctx, ray->pixel, ambient);
    float l[3];
    rto__normalize3(env->params[SUN_DIR], l);
    const float ndotl = dot3(n, l);
    if (!(ndotl > 0.0f))
        return;
    sun_payload p;
    for (int c = 0; c < 3; c++)
        p.throughput[c] = (s.base_color[c] * env->params[SUN_COLOR][c]) * ndotl;
    rto_wf_ray shadow;
    memset(&shadow, 0, sizeof shadow);
    memcpy(shadow.origin, s.position, sizeof shadow.origin);
    memcpy(shadow.dir, l, sizeof l);
    shadow.t_min = env->ray_offset;
    shadow.t_max = RTO_RAY_T_MAX;
    shadow.flags = RTO_RAY_FLAG_OPAQUE | RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RTO_RAY_FLAG_SKIP_CLOSEST_HIT;
    shadow.cull_mask = 0xFF;
    shadow.miss_index = 1;
    shadow.kind = RTO_RAY_KIND_SHADOW;
    rto_emit_ray(ctx, &shadow, &p);
}

static void sun_miss(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    if (ray->kind == RTO_RAY_KIND_SHADOW) {
        const sun_payload *p = payload;
        rto_accumulate(ctx, ray->pixel, p->throughput);
    } else {
        rto_accumulate(ctx, ray->pixel, ctx->env->params[SUN_SKY]);
    }
}

static void sun_resolve(const rto_frame_env *env, uint32_t x, uint32_t y, const float hdr[4], float rgba[4])
{
    (void)env, (void)x, (void)y;
    for (int c = 0; c < 3; c++) {
        const float mapped = hdr[c] / (1.0f + hdr[c]);
        rgba[c] = powf(mapped, 1.0f / 2.2f);
    }
    rgba[3] = 1.0f;
}

static const rto_program builtins[] = {
    {RTO_PROGRAM_ABI_VERSION, "triangle", "barycentric colours (1-u-v, u, v), a dark blue miss (VulkanTriangle)", 0, 1,
     triangle_params, 1, NULL, NULL, emit_camera_ray, triangle_hit, triangle_miss, NULL},
    {RTO_PROGRAM_ABI_VERSION, "sun-shadow",
     "albedo x ambient, a shadow ray towards the sun, sky on a miss, Reinhard and gamma 1/2.2 (Sponza)",
     (uint32_t)sizeof(sun_payload), 2, sun_params, 4, sun_init, NULL, emit_camera_ray, sun_hit, sun_miss,
     sun_resolve},
    {RTO_PROGRAM_ABI_VERSION, "normals", "world normal n * 0.5 + 0.5, the sky gradient on a miss (Stage-2)", 0, 1,
     normals_params, 2, NULL, NULL, emit_camera_ray, normals_hit, normals_miss, NULL},
};
#define NBUILTINS (sizeof builtins / sizeof builtins[0])

const rto_program *rto_program_builtin(const char *name)
{
    for (size_t i = 0; name && i < NBUILTINS; i++)
        if (!strcmp(builtins[i].name, name))
            return &builtins[i];
    return NULL;
}

const rto_program *rto_program_builtin_at(uint32_t i) { return i < NBUILTINS ? &builtins[i] : NULL; }

/* ---------------------------------------------------------------------------------------------------------------- */
/* Program tables                                                                                                   */

static int name_ok(const char *s, const char *extra)
{
    if (!s || !*s || strlen(s) > 48)
        return 0;
    for (; *s; s++)
        if (!((*s >= 'a' && *s <= 'z') || (*s >= '0' && *s <= '9') || strchr(extra, *s)))
            return 0;
    return 1;
}

rto_status rto_program_validate(const rto_program *p, rto_msg *msg)
{
    if (!p)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "no program");
    if (p->abi_version != RTO_PROGRAM_ABI_VERSION)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program ABI version %u (this rtoracle speaks %u)", p->abi_version,
                        RTO_PROGRAM_ABI_VERSION);
    if (!name_ok(p->name, "-"))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program name must be 1-48 characters of a-z, 0-9 and '-'");
    /* A bundle names its program: another program under a built-in's name would be taken for it (check-frame holds
     * `triangle`'s accum to the barycentric rule, for one). */
    const rto_program *b = rto_program_builtin(p->name);
    if (b && b != p)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program name %s is taken by the built-in program", p->name);
    if (p->payload_size % 4 || p->payload_size > RTO_PAYLOAD_MAX)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: payload size %u is not a multiple of 4 up to %d",
                        p->name, p->payload_size, RTO_PAYLOAD_MAX);
    if (p->max_depth < 1 || p->max_depth > 64)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: default maxDepth %u is not 1 .. 64", p->name,
                        p->max_depth);
    if (!p->raygen)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s has no raygen", p->name);
    if (p->param_count > RTO_PROGRAM_PARAMS_MAX || (p->param_count && !p->params))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: %u parameters (at most %d, with a table)", p->name,
                        p->param_count, RTO_PROGRAM_PARAMS_MAX);
    for (uint32_t i = 0; i < p->param_count; i++) {
        const rto_program_param *q = &p->params[i];
        if (!name_ok(q->name, "_") || strlen(q->name) >= sizeof(((rto_param_value *)0)->name))
            return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: parameter %u's name must be 1-31 of a-z, 0-9, '_'",
                            p->name, i);
        if (q->count < 1 || q->count > 4)
            return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: parameter %s has %u values (1 .. 4)", p->name,
                            q->name, q->count);
        for (uint32_t k = 0; k < i; k++)
            if (!strcmp(p->params[k].name, q->name))
                return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: parameter %s declared twice", p->name, q->name);
        for (uint32_t c = 0; c < q->count; c++)
            if (!isfinite(q->value[c]))
                return rto__fail(msg, RTO_ERR_UNSUPPORTED, "program %s: parameter %s's default is not finite", p->name,
                                q->name);
    }
    return RTO_OK;
}
