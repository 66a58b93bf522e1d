/* The glTF 2.0 loader: a C entry point over the C++17 shim in gltf.cpp, gltf_nodes.cpp and gltf_mesh.cpp (tinygltf
 * for parsing, the image module of image_module.h for textures; their shared C++ declarations are in
 * gltf_internal.h). Nothing C++ crosses this header. */
#ifndef RTO_GLTF_H
#define RTO_GLTF_H

#include "rtoracle.h"

/* Library-private (like internal.h): not exported from librtoracle.so. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Fills an empty (zeroed) scene from a .gltf or .glb file with the resolved options opts (no zero fields). Every C++
 * exception is caught and returned as a status with a one-line message, which does not repeat the path (the caller
 * names the file). On failure the scene may hold partial arrays; the caller destroys it.
 */
rto_status rto__gltf_load(const char *path, const rto_scene_load_desc *opts, rto_scene *scene, rto_msg *msg);

#ifdef __cplusplus
}
#endif

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
