/* The image module (librto_image.so, src/scene/image_module.cpp): texture decoding for the glTF loader, and reading,
 * writing and comparing images (io/image.c) through OpenImageIO, behind C functions.
 *
 * It is a separate shared module, loaded with dlopen the first time an image is touched, because linking
 * OpenImageIO into the library would make every rtoracle process load its ~260 shared libraries (all bound at load
 * time, ~0.2 s) even for commands that never touch an image. Search order: $RTO_IMAGE_MODULE, beside the running
 * executable, the install layout's place relative to it (<exe>/../<libdir>/rtoracle/), then the build tree and the
 * install directory (paths fixed at configure time): a relocated install uses its own module. The loader (image_module_load.c) is the one place that opens
 * it; the glTF shim and io/image.c both go through it.
 *
 * Every function below never throws, writes nothing to stdout or stderr, and reports failure with a one-line reason
 * in why (why_cap bytes). */
#ifndef RTO_IMAGE_MODULE_H
#define RTO_IMAGE_MODULE_H

#include "rtoracle.h"

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* 2: the caller reads the size from the image header and hands in the output block (1 returned a malloc'd one).
 * 3: image files: probe, read, encode and compare. */
#define RTO_IMAGE_MODULE_ABI 3
#define RTO_IMAGE_MODULE_ABI_SYMBOL "rto_image_module_abi"
#define RTO_IMAGE_MODULE_DECODE_SYMBOL "rto_image_decode_rgba"
#define RTO_IMAGE_MODULE_PROBE_SYMBOL "rto_image_module_probe"
#define RTO_IMAGE_MODULE_READ_SYMBOL "rto_image_module_read"
#define RTO_IMAGE_MODULE_ENCODE_SYMBOL "rto_image_module_encode"
#define RTO_IMAGE_MODULE_COMPARE_SYMBOL "rto_image_module_compare"

/** RTO_IMAGE_MODULE_ABI of the module, so a stale module is refused rather than called with the wrong arguments. */
typedef int (*rto_image_abi_fn)(void);

/**
 * Decodes an encoded PNG or JPEG texture to 8-bit RGBA rows, top row first, without colour conversion or alpha
 * premultiplication: grey becomes RGB, a missing alpha 255, 16-bit channels are scaled to 8 bits with rounding.
 * The caller has read width x height from the image header and passes rgba, 4 * width * height bytes: rows are
 * decoded straight into it, and no image-sized buffer is allocated besides. Refuses an image whose decoder reports
 * another size. Returns 1, or 0 and a reason in why (rgba is then undefined).
 */
typedef int (*rto_image_decode_fn)(const unsigned char *bytes, size_t len, uint32_t width, uint32_t height,
                                   unsigned char *rgba, char *why, size_t why_cap);

/** The most pixels (width * height) an image file may have: more is refused before anything image-sized is
 * allocated (2^28: a 16384 x 16384 image). */
#define RTO_IMAGE_MODULE_MAX_PIXELS (UINT64_C(1) << 28)

/* What the image-file functions return. */
enum {
    RTO_IMAGE_MODULE_OK = 0,
    RTO_IMAGE_MODULE_CORRUPT = 1,     /* malformed or truncated data */
    RTO_IMAGE_MODULE_UNSUPPORTED = 2, /* a format, layout or size this module does not handle */
    RTO_IMAGE_MODULE_NO_MEMORY = 3
};

/**
 * Reads the header of an encoded image file (bytes, len; name is the file's name, whose extension picks the reader
 * for formats other than PNG and OpenEXR): width, height, channels and pixel type go to info (pixels NULL). Nothing
 * image-sized is allocated: the caller checks the size before it allocates the pixels. PNG is read with libpng
 * (OpenImageIO 2.4's PNG reader prints libpng's errors to stderr), the rest with OpenImageIO.
 */
typedef int (*rto_image_probe_fn)(const unsigned char *bytes, size_t len, const char *name, rto_image *info,
                                  char *why, size_t why_cap);
/**
 * Decodes the pixels of the file probed as *image into image->pixels (width * height * channels values of
 * image->type, caller-allocated): 8-bit files as they are stored, others as binary32 without colour conversion or
 * alpha (un)premultiplication. Refuses a file whose header now says something else.
 */
typedef int (*rto_image_read_fn)(const unsigned char *bytes, size_t len, const char *name, const rto_image *image,
                                 char *why, size_t why_cap);
/**
 * Encodes an image as OpenEXR (exr != 0; RTO_PIXEL_F32, 32-bit float, ZIP; exr == 0 is refused: the library writes
 * PNG itself, io/png_write.c) into a malloc'ed block (*bytes, *len; the caller frees it). The bytes depend only on the pixels: no time, software name or
 * version is written (OpenEXR's capDate, which OpenImageIO always writes, is the fixed "1970:01:01 00:00:00").
 */
typedef int (*rto_image_encode_fn)(const rto_image *image, int exr, unsigned char **bytes, size_t *len, char *why,
                                   size_t why_cap);
/**
 * Compares two images of the same size and channel count with ImageBufAlgo::compare (one thread, so the sums are
 * the same every run) in [0, 1] units: mean, RMS, PSNR, max error and where, and the pixels over fail / warn
 * (result->verdict is left to the caller). diff, when not NULL, is a caller-allocated image of the same size and
 * channels (U8 or F32) that gets |expected - actual| * diff_scale (ImageBufAlgo::absdiff and mul; an alpha channel
 * is made opaque so the image stays visible).
 */
typedef int (*rto_image_compare_fn)(const rto_image *expected, const rto_image *actual, double fail, double warn,
                                    double diff_scale, rto_image *diff, rto_image_compare_result *result, char *why,
                                    size_t why_cap);

#ifndef RTO_IMAGE_MODULE_BUILDING
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif
/** The module's functions, as the loader found them. */
typedef struct rto_image_module {
    rto_image_decode_fn decode_rgba;
    rto_image_probe_fn probe;
    rto_image_read_fn read;
    rto_image_encode_fn encode;
    rto_image_compare_fn compare;
} rto_image_module;
/** Loads the module once per process (thread-safe); NULL, with *error set to one line saying why, when it cannot. */
const rto_image_module *rto__image_module(const char **error);
/** The image module file rtoracle would load (scene/image_module_load.c), or NULL when there is none. */
const char *rto__image_module_path(void);
/** The places a module loaded on demand is searched, in order (scene/image_module_load.c): $ENV_NAME, FILE beside the
 * running executable, <exe dir>/../RELATIVE (the install layout, so a copied install uses its own module), then the
 * build tree's and the configured install path. Returns how many (at most RTO_MODULE_PATHS); rel holds the two
 * executable-relative paths. */
#define RTO_MODULE_PATHS 5
size_t rto__module_paths(const char *env_name, const char *file, const char *relative, const char *build,
                         const char *install, const char *paths[RTO_MODULE_PATHS], char rel[2][4096]);
#if defined(__GNUC__)
#pragma GCC visibility pop
#endif
#endif

#ifdef __cplusplus
}
#endif

#endif
