/* The image-decoding module (librto_image.so, src/scene/image_oiio.cpp): OpenImageIO behind one C function.
 *
 * It is a separate shared module, loaded with dlopen the first time a texture is decoded, because linking
 * OpenImageIO into the library would make every rtoracle process load its ~260 shared libraries (all bound at load
 * time, ~0.2 s) even for commands that never touch an image. Search order: $RTO_IMAGE_MODULE, the build tree, the
 * install directory (paths fixed at configure time). */
#ifndef RTO_IMAGE_MODULE_H
#define RTO_IMAGE_MODULE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define RTO_IMAGE_MODULE_ABI 1
#define RTO_IMAGE_MODULE_ABI_SYMBOL "rto_image_module_abi"
#define RTO_IMAGE_MODULE_DECODE_SYMBOL "rto_image_decode_rgba"

/** RTO_IMAGE_MODULE_ABI of the module, so a stale module is refused rather than called with the wrong arguments. */
typedef int (*rto_image_abi_fn)(void);

/**
 * Decodes an encoded image (PNG, JPEG, WebP, GIF, BMP, ...) to 8-bit RGBA rows, top row first, without colour
 * conversion or alpha premultiplication: grey becomes RGB, a missing alpha 255. Refuses images of more than
 * max_texels texels. Returns 1 and a malloc'd *rgba (4 * width * height bytes; the caller frees it), or 0 and a
 * one-line reason in why (why_cap bytes). Never throws.
 */
typedef int (*rto_image_decode_fn)(const unsigned char *bytes, size_t len, uint64_t max_texels, uint32_t *width,
                                   uint32_t *height, unsigned char **rgba, char *why, size_t why_cap);

#ifdef __cplusplus
}
#endif

#endif
