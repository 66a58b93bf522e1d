/* Images (DESIGN.md §8-§9): PNG and OpenEXR files read, compared and (OpenEXR) written through OpenImageIO, which
 * lives in the dlopen'ed image module (scene/image_module.h says why), never in this library's link line.
 *
 * Reading: the file is opened only if it is a regular file (a FIFO would block, /dev/zero never end), read into
 * memory once, and handed to the module twice: a probe of its header (size, channels, type), then, once the size
 * is known to be sane, a decode straight into the block allocated for it. Writing: the module encodes OpenEXR into
 * memory, io/png_write.c PNG (without the module), and rto_file_write puts the bytes in place atomically, with every
 * rule of io/atomic.c. Comparing: the module runs ImageBufAlgo::compare (and absdiff / mul for the diff image); the
 * verdict is idiff's rule, computed here. */
#include "io_internal.h"
#include "scene/image_module.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* A file larger than this cannot be an image of at most 2^28 pixels in any format read here (4 channels of binary32
 * uncompressed take 4 GiB, plus headers and offset tables): refused before it is read. */
#define IMAGE_MAX_FILE_BYTES (UINT64_C(5) << 30)

/* idiff's defaults (its -fail, -warn and -hardfail / -hardwarn: FLT_MAX, so that an infinite error, a NaN against a
 * number, still fails). */
#define IDIFF_THRESHOLD 1e-6
#define IDIFF_HARD FLT_MAX

static const rto_image_module *image_module(const char *what, rto_status *s, rto_msg *msg)
{
    const char *error = "";
    const rto_image_module *m = rto__image_module(&error);
    if (!m)
        *s = rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: %s", what, error);
    return m;
}

static rto_status module_status(int code)
{
    switch (code) {
    case RTO_IMAGE_MODULE_OK: return RTO_OK;
    case RTO_IMAGE_MODULE_UNSUPPORTED: return RTO_ERR_UNSUPPORTED;
    case RTO_IMAGE_MODULE_NO_MEMORY: return RTO_ERR_OUT_OF_MEMORY;
    default: return RTO_ERR_PARSE;
    }
}

static size_t pixel_bytes(rto_pixel_type t) { return t == RTO_PIXEL_U8 ? 1 : 4; }

/* The checks every entry point makes of an image it is given. */
static rto_status image_check(const rto_image *im, const char *what, rto_msg *msg)
{
    if (!im)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL %s image", what);
    if (im->type != RTO_PIXEL_U8 && im->type != RTO_PIXEL_F32)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s image: unknown pixel type %d", what, (int)im->type);
    if (!im->width || !im->height || im->channels < 1 || im->channels > 4)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s image: %ux%u with %u channels (1 to 4 channels, at least "
                        "one pixel)", what, im->width, im->height, im->channels);
    if ((uint64_t)im->width * im->height > RTO_IMAGE_MODULE_MAX_PIXELS)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s image: %ux%u is more than 2^28 pixels", what, im->width,
                        im->height);
    if (!im->pixels)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s image: NULL pixels", what);
    return RTO_OK;
}

/* Whether path ends in ext (".png", ".exr"), in any letter case. */
static bool has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

/* The file's name without its directories: what the module's readers pick a format by. */
static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* ---------------------------------------------------------------------------------------------------------------- */

static rto_status load_file(const char *path, unsigned char **bytes, size_t *len, rto_msg *msg)
{
    *bytes = NULL;
    *len = 0;
    uint64_t size = 0;
    rto_status s = RTO_OK;
    FILE *fp = rto__open_regular(path, &size, &s, msg);
    if (!fp)
        return s;
    if (size > IMAGE_MAX_FILE_BYTES || size > SIZE_MAX)
        s = rto__fail(msg, RTO_ERR_UNSUPPORTED, "'%s' is %llu bytes, too large for an image of at most 2^28 pixels",
                     path, (unsigned long long)size);
    else if (size == 0)
        s = rto__fail(msg, RTO_ERR_PARSE, "'%s' is empty", path);
    unsigned char *buf = s ? NULL : rto__alloc((size_t)size, 1);
    if (!s && !buf)
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "'%s': out of memory for %llu bytes", path, (unsigned long long)size);
    /* One byte more than the size asked for: a file that grew since fstat is noticed rather than cut short. */
    if (!s && (fread(buf, 1, (size_t)size, fp) != (size_t)size || fgetc(fp) != EOF || ferror(fp)))
        s = rto__fail(msg, RTO_ERR_IO, "'%s': read error (the file changed while it was read?)", path);
    fclose(fp);
    if (s) {
        free(buf);
        return s;
    }
    *bytes = buf;
    *len = (size_t)size;
    return RTO_OK;
}

/* Decodes a file's bytes: probe, size checks, allocation, read (budget 0: the header only). */
static rto_status decode(const char *path, const unsigned char *bytes, size_t len, size_t budget, rto_image *out,
                         rto_msg *msg)
{
    rto_status s = RTO_OK;
    const rto_image_module *m = image_module(path, &s, msg);
    if (!m)
        return s;
    char why[256] = "";
    rto_image info = {0};
    int code = m->probe(bytes, len, base_name(path), &info, why, sizeof why);
    if (code)
        return rto__fail(msg, module_status(code), "'%s': %s", path, why);
    if (info.channels < 1 || info.channels > 4)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "'%s': %u channels (1 to 4 are supported)", path, info.channels);
    const uint64_t pixels = (uint64_t)info.width * info.height;
    if (!pixels || pixels > RTO_IMAGE_MODULE_MAX_PIXELS)
        return rto__fail(msg, pixels ? RTO_ERR_UNSUPPORTED : RTO_ERR_PARSE, "'%s': %ux%u %s", path, info.width,
                        info.height, pixels ? "is more than 2^28 pixels" : "is empty");
    const uint64_t need = pixels * info.channels * pixel_bytes(info.type);
    if (!budget) {
        *out = info;
        return RTO_OK;
    }
    if (need > budget)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "'%s': %ux%u with %u channel%s of %s needs %llu MiB decoded, over "
                        "the budget of %llu MiB", path, info.width, info.height, info.channels,
                        info.channels == 1 ? "" : "s", info.type == RTO_PIXEL_U8 ? "8 bits" : "float",
                        (unsigned long long)((need + (1u << 20) - 1) >> 20), (unsigned long long)(budget >> 20));
    info.pixels = rto__alloc((size_t)pixels * info.channels, pixel_bytes(info.type));
    if (!info.pixels)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "'%s': out of memory for %ux%u pixels", path, info.width,
                        info.height);
    code = m->read(bytes, len, base_name(path), &info, why, sizeof why);
    if (code) {
        free(info.pixels);
        return rto__fail(msg, module_status(code), "'%s': %s", path, why);
    }
    *out = info;
    return RTO_OK;
}

/* The file's bytes, then its header and, with a budget (0: the header only), its pixels. */
static rto_status read_with(const char *path, size_t budget, rto_image *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output image");
    memset(out, 0, sizeof *out);
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path");
    unsigned char *bytes = NULL;
    size_t len = 0;
    rto_status s = load_file(path, &bytes, &len, msg);
    if (!s)
        s = decode(path, bytes, len, budget, out, msg);
    free(bytes);
    return s;
}

rto_status rto_image_read_budget(const char *path, size_t budget_bytes, rto_image *out, rto_msg *msg)
{
    return read_with(path, budget_bytes ? budget_bytes : RTO_IMAGE_BUDGET_DEFAULT, out, msg);
}

rto_status rto_image_read(const char *path, rto_image *out, rto_msg *msg)
{
    return rto_image_read_budget(path, 0, out, msg);
}

rto_status rto_image_probe(const char *path, rto_image *out, rto_msg *msg) { return read_with(path, 0, out, msg); }

void rto_image_free(rto_image *image)
{
    if (!image)
        return;
    free(image->pixels);
    memset(image, 0, sizeof *image);
}

rto_status rto_image_write(const char *path, const rto_image *image, rto_msg *msg)
{
    if (!path || !*path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no image path given");
    rto_status s = image_check(image, "output", msg);
    if (s)
        return s;
    const bool exr = has_ext(path, ".exr");
    if (!exr && !has_ext(path, ".png"))
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "cannot write %s: images are written as .png (8-bit) or .exr "
                        "(32-bit float)", path);
    if (image->type != (exr ? RTO_PIXEL_F32 : RTO_PIXEL_U8))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "cannot write %s: %s holds %s pixels", path,
                        exr ? "OpenEXR" : "PNG", exr ? "32-bit float" : "8-bit");
    unsigned char *bytes = NULL;
    size_t len = 0;
    if (exr) {
        const rto_image_module *m = image_module(path, &s, msg);
        if (!m)
            return s;
        char why[256] = "";
        int code = m->encode(image, exr, &bytes, &len, why, sizeof why);
        if (code)
            s = rto__fail(msg, module_status(code), "cannot encode %s: %s", path, why);
    } else if ((s = rto__png_encode(image, &bytes, &len, msg))) {
        char why[sizeof msg->text];
        snprintf(why, sizeof why, "%s", msg ? msg->text : "PNG encoding failed");
        s = rto__fail(msg, s, "cannot encode %s: %s", path, why);
    }
    if (!s)
        s = rto_file_write(path, bytes, len, msg);
    free(bytes);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* A threshold of the description: finite and >= 0; 0 (a zero-initialised field) means def. */
static rto_status threshold(double v, double def, const char *name, double *out, rto_msg *msg)
{
    if (!(v >= 0) || !isfinite(v))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s = %g: expected a finite number >= 0", name, v);
    *out = v > 0 ? v : def;
    return RTO_OK;
}

static rto_status percent(double v, const char *name, rto_msg *msg)
{
    if (!(v >= 0 && v <= 100))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%s = %g: expected a percentage 0 .. 100", name, v);
    return RTO_OK;
}

rto_status rto_image_compare(const rto_image *expected, const rto_image *actual, const rto_image_compare_desc *desc,
                             rto_image_compare_result *result, rto_msg *msg)
{
    if (!result)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL result");
    memset(result, 0, sizeof *result);
    rto_image_compare_desc d = {0};
    if (desc)
        d = *desc;
    rto_status s = image_check(expected, "expected", msg);
    if (!s)
        s = image_check(actual, "actual", msg);
    if (s)
        return s;
    /* Images of different sizes or channel counts are compared as idiff compares them: over the union of the two,
     * a pixel or channel one image lacks reading as 0 (so they fail unless the extra pixels are 0); the
     * percentages are of the expected image's pixels. A diff image needs one geometry: none is written then. */
    const bool same_geometry = expected->width == actual->width && expected->height == actual->height &&
                               expected->channels == actual->channels;
    if (!same_geometry)
        d.diff_path = NULL;
    double fail = 0, warn = 0, hard_fail = IDIFF_HARD, hard_warn = IDIFF_HARD, scale = 1;
    if ((s = threshold(d.fail, IDIFF_THRESHOLD, "fail", &fail, msg)) ||
        (s = threshold(d.warn, IDIFF_THRESHOLD, "warn", &warn, msg)) ||
        (s = percent(d.fail_percent, "fail_percent", msg)) || (s = percent(d.warn_percent, "warn_percent", msg)) ||
        (d.hard_fail_set && (s = threshold(d.hard_fail, 0, "hard_fail", &hard_fail, msg))) ||
        (d.hard_warn_set && (s = threshold(d.hard_warn, 0, "hard_warn", &hard_warn, msg))) ||
        (s = threshold(d.diff_scale, 1, "diff_scale", &scale, msg)))
        return s;
    if (d.hard_fail_set)
        hard_fail = d.hard_fail; /* 0 here is a real threshold: any difference fails */
    if (d.hard_warn_set)
        hard_warn = d.hard_warn;
    /* The diff image's format is checked before the comparison, so a bad name is not found after the work. */
    rto_image diff = {0};
    if (d.diff_path) {
        const bool exr = has_ext(d.diff_path, ".exr");
        if (!exr && !has_ext(d.diff_path, ".png"))
            return rto__fail(msg, RTO_ERR_UNSUPPORTED, "cannot write the diff image %s: it must be a .png or .exr",
                            d.diff_path);
        diff = *expected;
        diff.type = exr ? RTO_PIXEL_F32 : RTO_PIXEL_U8;
        diff.pixels = rto__alloc((size_t)diff.width * diff.height * diff.channels, pixel_bytes(diff.type));
        if (!diff.pixels)
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for the diff image");
    }
    const rto_image_module *m = image_module("cannot compare images", &s, msg);
    if (m) {
        char why[256] = "";
        int code = m->compare(expected, actual, fail, warn, scale, d.diff_path ? &diff : NULL, result, why,
                              sizeof why);
        if (code)
            s = rto__fail(msg, module_status(code), "cannot compare the images: %s", why);
    }
    if (!s) {
        /* The verdict of Debian's idiff 2.4.7 (OpenImageIO 2.4.7), measured on a table of cases (tests/cli_compare.sh
         * compares the two where idiff is installed): FAIL when more than fail_percent % of the pixels fail or the
         * largest error is over hard_fail; else WARN when some pixel failed (tolerated by fail_percent) and more
         * than warn_percent % of the pixels warn or the largest error is over hard_warn; else PASS. idiff's
         * documentation leaves out "some pixel failed": differences under the fail threshold everywhere pass. */
        const double n = (double)result->pixels;
        if ((double)result->fail_count > d.fail_percent / 100.0 * n || result->max_error > hard_fail)
            result->verdict = RTO_IMAGE_FAIL;
        else if (result->fail_count > 0 &&
                 ((double)result->warn_count > d.warn_percent / 100.0 * n || result->max_error > hard_warn))
            result->verdict = RTO_IMAGE_WARN;
        else
            result->verdict = RTO_IMAGE_PASS;
    }
    if (!s && d.diff_path)
        s = rto_image_write(d.diff_path, &diff, msg);
    free(diff.pixels);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */

rto_status rto_bundle_add_image(rto_bundle *b, const char *name, const char *role, const rto_image *image,
                                rto_msg *msg)
{
    return rto__bundle_add_image(b, name, role, image, rto_image_write, msg);
}

rto_status rto_bundle_read_image(rto_bundle_reader *r, const char *name, rto_image *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output image");
    memset(out, 0, sizeof *out);
    char *path = NULL;
    rto_status s = rto__bundle_checked_path(r, name, &path, msg);
    if (!s)
        s = rto_image_read(path, out, msg);
    free(path);
    return s;
}
