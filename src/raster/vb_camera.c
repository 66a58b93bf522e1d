/* The visibility pass's camera (DESIGN.md §11.1): the Stage-2 camera's view and projection (trace/ray.c), with clip z
 * mapped from OpenGL's [-w, w] to WebGPU's [0, w], multiplied and inverted in binary64 and rounded once. */
#include "internal.h"
#include "trace/trace_internal.h"

#include <math.h>
#include <string.h>

rto_status rto_vbuffer_camera_make(const rto_camera *camera, uint32_t width, uint32_t height, rto_vbuffer_camera *out,
                                   rto_msg *msg)
{
    if (!camera || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL camera or output");
    double view[16], proj[16], iproj[16], vp[16];
    rto_status st = rto__camera_matrices(camera, width, height, view, proj, msg);
    if (st != RTO_OK)
        return st;
    /* Row 2 (elements [4c + 2]) becomes 0.5 row 2 + 0.5 row 3: z_webgpu = (z_gl + w) / 2. */
    for (int c = 0; c < 4; c++)
        proj[4 * c + 2] = 0.5 * proj[4 * c + 2] + 0.5 * proj[4 * c + 3];
    if (!rto__invert4(proj, iproj))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "camera '%.64s': its projection matrix is singular",
                        camera->name);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++) {
            double v = 0.0;
            for (int k = 0; k < 4; k++)
                v += proj[4 * k + r] * view[4 * c + k];
            vp[4 * c + r] = v;
        }
    rto_vbuffer_camera u;
    memset(&u, 0, sizeof u);
    for (int k = 0; k < 16; k++) {
        u.view_proj[k] = (float)vp[k];
        u.inverse_projection[k] = (float)iproj[k];
        if (!isfinite(u.view_proj[k]) || !isfinite(u.inverse_projection[k]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "camera '%.64s': a matrix element overflows binary32 (near %g, far %g)", camera->name,
                            (double)camera->znear, (double)camera->zfar);
    }
    u.position[0] = camera->position.x;
    u.position[1] = camera->position.y;
    u.position[2] = camera->position.z;
    *out = u;
    return RTO_OK;
}
