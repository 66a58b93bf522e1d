/* The scene model shared by every loader (src/scene/): limits, warnings, names, the load options and the validation
 * every loaded scene goes through. The loaders (procedural.c, gltf*.cpp) depend on this file only; scene.c dispatches
 * a spec to them. Not installed; included from the C++ glTF shim too. */
#ifndef RTO_SCENE_MODEL_H
#define RTO_SCENE_MODEL_H

#include "core/utf8.h"
#include "rtoracle.h"

/* Library-private (like internal.h): not exported from librtoracle.so. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

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

/* Largest coordinate magnitude of a vertex (object space) and of an instance's world bounds: FLT_MAX / 2. Keys are
 * built from box centroids (min + max) * 0.5 and their spans hi - lo (DESIGN.md §3); below this bound neither can
 * overflow binary32, so every scene the loader accepts can be built. */
#define RTO_SCENE_MAX_COORD 0x1.fffffep+126f

/** Writes the load options with every zero field replaced by its default (desc may be NULL: all defaults). */
void rto__load_desc_resolve(const rto_scene_load_desc *desc, rto_scene_load_desc *out);

/** Records a warning: counts it and keeps the text of the first RTO_SCENE_MAX_WARNINGS (one line, valid UTF-8,
 * cut at a character boundary). */
void rto__scene_warn(rto_scene *scene, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/** Appends a file the loader opened (or tried to) to scene->sources; 0 when out of memory. */
int rto__scene_add_source(rto_scene *scene, const char *path);


/** 1 if every coordinate of a non-empty box lies within +-RTO_SCENE_MAX_COORD (an empty box passes). */
int rto__aabb_in_range(const rto_aabb *box);

/** Checks what every loader must guarantee (finite data within RTO_SCENE_MAX_COORD, indices in range, limits);
 * names the offending item. */
rto_status rto__scene_validate(const rto_scene *scene, rto_msg *msg);

#ifdef __cplusplus
}
#endif

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
