/* What the commands that trace a scene share (trace, render): numbers from the command line, the camera chosen by
 * --camera, and the mesh geometry a GPU uploads. */
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
