/* The image-decoding module (librto_image.so, src/scene/image_module.cpp): PNG through libpng and JPEG through
 * OpenImageIO, behind one C function.
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

/* 2: the caller reads the size from the image header and hands in the output block (1 returned a malloc'd one). */
#define RTO_IMAGE_MODULE_ABI 2
#define RTO_IMAGE_MODULE_ABI_SYMBOL "rto_image_module_abi"
#define RTO_IMAGE_MODULE_DECODE_SYMBOL "rto_image_decode_rgba"

/** RTO_IMAGE_MODULE_ABI of the module, so a stale module is refused rather than called with the wrong arguments. */
typedef int (*rto_image_abi_fn)(void);

/**
 * Decodes an encoded PNG or JPEG image to 8-bit RGBA rows, top row first, without colour conversion or alpha
 * premultiplication: grey becomes RGB, a missing alpha 255, 16-bit channels are scaled to 8 bits with rounding.
 * The caller has read width x height from the image header and passes rgba, 4 * width * height bytes: rows are
 * decoded straight into it, and no image-sized buffer is allocated besides. Refuses an image whose decoder reports
 * another size. Returns 1, or 0 and a one-line reason in why (why_cap bytes; rgba is then undefined). Never throws,
 * and writes nothing to stdout or stderr.
 */
typedef int (*rto_image_decode_fn)(const unsigned char *bytes, size_t len, uint32_t width, uint32_t height,
                                   unsigned char *rgba, char *why, size_t why_cap);

#ifdef __cplusplus
}
#endif

#endif
