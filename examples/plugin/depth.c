/* An example program plugin: a depth-and-facing view, ported the way a user ports a WGSL closest-hit / miss pair.
 *
 *     cc -shared -fPIC -I<rtoracle include dir> depth.c -o librto_program_depth.so
 *     rtoracle render scene.gltf --program ./librto_program_depth.so --param range=20 -o out/
 *
 * The closest-hit program shades a hit by its distance (white near, black at `range`), tinted by whether the ray
 * sees the front (det > 0: the geometric normal faces the ray) or the back of the triangle; a miss writes `miss`.
 * It needs only rtoracle.h: every call into the frame goes through ctx->api (rto_frame_camera_ray, rto_emit_primary_ray,
 * rto_accumulate, rto_surface_at are inline wrappers), so the library links against nothing of rtoracle. */
#include <rtoracle.h>

#include <string.h>

enum { RANGE, FRONT, BACK, MISS };

static const rto_program_param params[] = {
    [RANGE] = {"range", 1, {10.0f, 0, 0, 0}, "distance that shades black"},
    [FRONT] = {"front", 3, {1.0f, 1.0f, 1.0f, 0}, "tint of front faces"},
    [BACK] = {"back", 3, {1.0f, 0.3f, 0.3f, 0}, "tint of back faces"},
    [MISS] = {"miss", 3, {0.1f, 0.1f, 0.1f, 0}, "colour of a ray that hits nothing"},
};

static int init(const rto_frame_env *env, void **user, char *why, size_t cap)
{
    *user = NULL;
    if (!(env->params[RANGE][0] > 0.0f)) {
        /* refusing is how a program reports parameters it cannot use: render exits 2 with this line */
        strncpy(why, "range must be positive", cap - 1);
        why[cap - 1] = '\0';
        return 0;
    }
    return 1;
}

static void raygen(rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    const rto_wf_ray ray = rto_frame_camera_ray(ctx, x, y);
    rto_emit_primary_ray(ctx, &ray, NULL);
}

static void closest_hit(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload)
{
    (void)payload;
    rto_surface s;
    rto_surface_at(ctx, ray, hit, &s);
    const float facing = (s.geometric_normal[0] * ray->dir[0] + s.geometric_normal[1] * ray->dir[1]) +
                         s.geometric_normal[2] * ray->dir[2];
    const float *tint = ctx->env->params[facing < 0.0f ? FRONT : BACK];
    float shade = 1.0f - hit->t / ctx->env->params[RANGE][0];
    shade = shade < 0.0f ? 0.0f : shade;
    const float rgb[3] = {tint[0] * shade, tint[1] * shade, tint[2] * shade};
    rto_accumulate(ctx, ray->pixel, rgb);
}

static void miss(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    (void)payload;
    rto_accumulate(ctx, ray->pixel, ctx->env->params[MISS]);
}

static const rto_program program = {
    RTO_PROGRAM_ABI_VERSION, "depth", "distance shading, front faces white and back faces red", 0, 1, params, 4, init,
    NULL, raygen, closest_hit, miss, NULL,
};

/* The one exported symbol (RTO_PROGRAM_ENTRY_SYMBOL); the library is built with hidden visibility otherwise. */
__attribute__((visibility("default"))) const rto_program *rto_program_entry_v1(void);
const rto_program *rto_program_entry_v1(void) { return &program; }
