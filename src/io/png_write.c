/* 8-bit PNG files written by libpng in this library (DESIGN.md §8): the image a frame bundle always holds is written
 * without loading the image module, whose OpenImageIO takes about half a second to load; a render that writes no
 * float image and reads no JPEG texture never loads it. The bytes depend on the pixels and zlib alone: no time, no
 * text chunks, zlib's level 6 and libpng's default filter choice. */
#include "io_internal.h"

#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

typedef struct png_out {
    unsigned char *bytes;
    size_t len, cap;
    char why[128];
} png_out;

static void on_error(png_structp png, png_const_charp text)
{
    png_out *o = png_get_error_ptr(png);
    snprintf(o->why, sizeof o->why, "%s", text ? text : "libpng error");
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp text) { (void)png, (void)text; }

static void on_write(png_structp png, png_bytep data, png_size_t n)
{
    png_out *o = png_get_io_ptr(png);
    if (n > o->cap - o->len) {
        size_t cap = o->cap ? o->cap : 1 << 16;
        while (n > cap - o->len)
            cap *= 2;
        unsigned char *p = realloc(o->bytes, cap);
        if (!p)
            png_error(png, "out of memory");
        o->bytes = p;
        o->cap = cap;
    }
    memcpy(o->bytes + o->len, data, n);
    o->len += n;
}

static void on_flush(png_structp png) { (void)png; }

rto_status rto__png_encode(const rto_image *im, unsigned char **bytes, size_t *len, rto_msg *msg)
{
    static const int types[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                PNG_COLOR_TYPE_RGB_ALPHA};
    *bytes = NULL;
    *len = 0;
    if (im->type != RTO_PIXEL_U8 || im->channels < 1 || im->channels > 4)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "a PNG holds 1 to 4 channels of 8-bit pixels");
    /* on the heap, and the pointer never changed after setjmp: its contents are sure after a longjmp */
    png_out *const o = calloc(1, sizeof *o);
    png_structp png = o ? png_create_write_struct(PNG_LIBPNG_VER_STRING, o, on_error, on_warning) : NULL;
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        free(o);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for a PNG encoder");
    }
    /* volatile: read after a longjmp */
    png_bytep *volatile rows = NULL;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(rows);
        rto_status s = rto__fail(msg, strstr(o->why, "memory") ? RTO_ERR_OUT_OF_MEMORY : RTO_ERR_IO,
                                "PNG encoding: %s", o->why);
        free(o->bytes);
        free(o);
        return s;
    }
    rows = malloc(im->height * sizeof *rows);
    if (!rows)
        png_error(png, "out of memory");
    const size_t stride = (size_t)im->width * im->channels;
    for (uint32_t y = 0; y < im->height; y++)
        rows[y] = (png_bytep)im->pixels + y * stride;
    png_set_write_fn(png, o, on_write, on_flush);
    png_set_compression_level(png, 6);
    png_set_IHDR(png, info, im->width, im->height, 8, types[im->channels - 1], PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    free(rows);
    *bytes = o->bytes;
    *len = o->len;
    free(o);
    return RTO_OK;
}
