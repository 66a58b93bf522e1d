/* What the commands that trace a scene share (trace, render): numbers from the command line, the camera chosen by
 * --camera, and the scene loaded with its trees. */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Parses exactly n comma-separated finite numbers. */
bool cli_parse_floats(const char *text, float *out, size_t n)
{
    const char *p = text;
    for (size_t i = 0; i < n; i++) {
        char *end = NULL;
        const double v = strtod(p, &end);
        if (end == p || !isfinite(v) || fabs(v) > 3.0e38)
            return false;
        out[i] = (float)v;
        p = end;
        if (i + 1 < n) {
            if (*p != ',')
                return false;
            p++;
        }
    }
    return *p == '\0';
}

bool cli_camera_numbers(const char *spec, rto_camera *cam)
{
    float v[10];
    if (!cli_parse_floats(spec, v, 10))
        return false;
    *cam = rto_camera_default();
    snprintf(cam->name, sizeof cam->name, "command line");
    cam->position = (rto_vec3){v[0], v[1], v[2]};
    cam->target = (rto_vec3){v[3], v[4], v[5]};
    cam->up = (rto_vec3){v[6], v[7], v[8]};
    cam->fov_y = (float)((double)v[9] * 3.14159265358979323846 / 180.0);
    return true;
}

/* The camera named by --camera into *cam; the automatic framing is resolved here, so the manifest can name the
 * camera used whichever way it was chosen. Returns false (after one line) on a bad value. */
bool cli_pick_camera(const char *cmd, const char *spec, const rto_scene *sc, float aspect, rto_camera *cam)
{
    uint64_t index = 0;
    const bool scene_camera = (!spec || !strcmp(spec, "scene")) && sc->camera_count;
    if (scene_camera) {
        *cam = sc->cameras[0];
    } else if (!spec || !strcmp(spec, "scene") || !strcmp(spec, "auto")) {
        const rto_aabb bounds = rto_scene_aabb(sc);
        *cam = rto_camera_frame(&bounds, aspect);
        snprintf(cam->name, sizeof cam->name, "auto");
    } else if (opts_parse_uint(spec, UINT32_MAX, &index)) {
        if (index >= sc->camera_count) {
            cli_fail(cmd, "--camera %s: the scene has %u camera%s", spec, sc->camera_count,
                     sc->camera_count == 1 ? "" : "s");
            return false;
        }
        *cam = sc->cameras[index];
    } else if (!cli_camera_numbers(spec, cam)) {
        cli_fail(cmd, "--camera %s: expected scene, auto, a camera index or 10 numbers "
                          "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY", spec);
        return false;
    }
    return true;
}

int cli_load_traced_scene(const char *cmd, const char *spec, uint64_t texture_budget_mb, const char *camera_arg,
                          uint32_t width, uint32_t height, unsigned karras, uint32_t threads, cli_traced_scene *out)
{
    memset(out, 0, sizeof *out);
    rto_msg msg = {{0}};
    rto_scene_load_desc load = {0};
    load.texture_budget_bytes = (size_t)(texture_budget_mb << 20);
    if (rto_scene_load_ex(spec, &load, &out->scene, &msg))
        return cli_fail(cmd, "%s", msg.text);
    const rto_scene *sc = out->scene;
    for (uint32_t w = 0; w < sc->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        fprintf(stderr, "rtoracle %s: warning: %s\n", cmd, sc->warnings[w]);
    rto_camera *cam = &out->camera;
    if (!cli_pick_camera(cmd, camera_arg, sc, (float)width / (float)height, cam)) {
        cli_traced_scene_free(out);
        return EXIT_BAD_INPUT;
    }
    /* A scene camera's own aspect wins over the image's (rto_camera_uniforms_make): say so when they differ, since
     * the image is then stretched (a 4:3 glTF camera on a 16:9 frame draws circles as ellipses). */
    const double image_aspect = (double)width / (double)height;
    if (cam->aspect > 0.0f && fabs((double)cam->aspect - image_aspect) > 1e-3 * image_aspect)
        fprintf(stderr, "rtoracle %s: warning: camera '%s' has aspect %.4g, the image %ux%u has %.4g: the image is "
                "stretched (use a size of aspect %.4g, or pass --camera auto)\n", cmd, cam->name, (double)cam->aspect,
                (unsigned)width, (unsigned)height, image_aspect, (double)cam->aspect);
    const rto_accel_desc adesc = {karras ? RTO_TLAS_KARRAS : RTO_TLAS_SWEEP, threads};
    rto_report r;
    rto_status s = rto_accel_build(sc, &adesc, &out->accel, &msg);
    if (!s && (s = rto_accel_check(out->accel, &r, &msg)) == RTO_ERR_MISMATCH) {
        cli_traced_scene_free(out);
        return cli_fail(cmd, "internal self-check of the trees failed: %s", msg.text);
    }
    if (s) {
        cli_traced_scene_free(out);
        return cli_status(cmd, s, &msg);
    }
    return EXIT_PASS;
}

void cli_traced_scene_free(cli_traced_scene *t)
{
    rto_accel_destroy(t->accel);
    rto_scene_destroy(t->scene);
    t->accel = NULL;
    t->scene = NULL;
}

int cli_stage2_camera(const char *cmd, const char *camera_arg, rto_camera *cam)
{
    *cam = rto_camera_default();
    snprintf(cam->name, sizeof cam->name, "stage2 default");
    if (camera_arg && strcmp(camera_arg, "scene") && strcmp(camera_arg, "auto") && !cli_camera_numbers(camera_arg, cam))
        return cli_fail(cmd, "--camera %s: stage2 takes scene (its default camera) or 10 numbers", camera_arg);
    return EXIT_PASS;
}
