/* Private plumbing of the scene stage (src/scene/): limits, warnings and the two loaders behind rto_scene_load.
 * Not installed; included by scene.c, procedural.c and the C++ glTF shim (gltf.cpp). */
#ifndef RTO_SCENE_INTERNAL_H
#define RTO_SCENE_INTERNAL_H

#include "rtoracle.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Limits every loaded scene is validated against. They keep every count in uint32_t with room for the GPU-side
 * arithmetic (3 * triangles, 2 * nodes) and bound memory for hostile files; 2^24 instances also matches the 24-bit
 * customIndex field. The TLAS itself takes at most RTO_TLAS_MAX_INSTANCES, which the build checks, not the loader. */
#define RTO_SCENE_MAX_MESHES (UINT32_C(1) << 24)
#define RTO_SCENE_MAX_INSTANCES (UINT32_C(1) << 24)
#define RTO_SCENE_MAX_TRIANGLES (UINT32_C(1) << 28) /* summed over the meshes (unique BLAS triangles) */
#define RTO_SCENE_MAX_VERTICES (UINT32_C(1) << 28)  /* summed over the meshes */
#define RTO_SCENE_MAX_TEXELS (UINT32_C(1) << 28)    /* per texture (16384 x 16384) */

/** Records a warning: counts it and keeps the text of the first RTO_SCENE_MAX_WARNINGS (one line, truncated). */
void rto__scene_warn(rto_scene *scene, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/** Fills an empty scene from a procedural spec ("triangle", "rtstress:N", "instances:DIST:N"). */
rto_status rto__procedural_load(const char *spec, rto_scene *scene, rto_msg *msg);

/** Checks what every loader must guarantee (finite data, indices in range, limits); names the offending item. */
rto_status rto__scene_validate(const rto_scene *scene, rto_msg *msg);

#ifdef __cplusplus
}
#endif

#endif
