// librto_image.so: the C functions of image_module.h (texture decoding; reading, writing and comparing image
// files). Loaded with dlopen by image_module_load.c the first time an image is touched (image_module.h says why it
// is a module).
//
// PNG is read through libpng directly, with error and warning handlers of its own: OpenImageIO 2.4 creates its
// libpng reader with libpng's default handlers, which print "libpng error: ..." to stderr for a corrupt image, and a
// refusal must be one line (and a successful run silent). Everything else (JPEG textures, OpenEXR and the other
// formats of image files, PNG writing, the comparison) goes through OpenImageIO, which reports through its error
// state, silently.
#define RTO_IMAGE_MODULE_BUILDING
#include "image_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <png.h>

#include <algorithm>
#include <array>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace {

void set_why(char *why, size_t cap, const std::string &text)
{
    if (!why || !cap)
        return;
    std::string line = text.substr(0, text.find('\n'));
    snprintf(why, cap, "%s", line.empty() ? "unknown decoder error" : line.c_str());
}

bool is_png(const unsigned char *b, size_t n) { return n >= 8 && memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0; }

bool is_jpeg(const unsigned char *b, size_t n) { return n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF; }

uint32_t be32(const unsigned char *p)
{
    return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

// CRC-32 of the PNG spec (Annex D), table built once (thread-safe static initialisation).
uint32_t crc32(const unsigned char *p, size_t n)
{
    static const std::array<uint32_t, 256> table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[i] = c;
        }
        return t;
    }();
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++)
        c = table[(c ^ p[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

// The PNG chunk structure (PNG spec §5.3): every chunk inside the data with a correct CRC, up to IEND. Checked before
// libpng sees the data, so a truncated or corrupt file is named as such (libpng would only warn about a bad CRC in
// an ancillary chunk and go on).
bool png_structure_ok(const unsigned char *b, size_t n, std::string *why)
{
    size_t at = 8;
    for (int chunk = 0;; chunk++) {
        if (n - at < 12) {
            *why = "corrupt PNG: truncated before IEND (chunk " + std::to_string(chunk) + ")";
            return false;
        }
        const uint32_t len = be32(b + at);
        if (len > n - at - 12) {
            *why = "corrupt PNG: chunk " + std::to_string(chunk) + " runs past the end of the data";
            return false;
        }
        if (crc32(b + at + 4, size_t(len) + 4) != be32(b + at + 8 + len)) {
            *why = "corrupt PNG: CRC mismatch in chunk " + std::to_string(chunk) + " ('" +
                   std::string(reinterpret_cast<const char *>(b + at + 4), 4) + "')";
            return false;
        }
        if (memcmp(b + at + 4, "IEND", 4) == 0)
            return true;
        at += size_t(len) + 12;
    }
}

// libpng's I/O and diagnostics, all in one struct reachable from the png_struct: no C++ object lives across the
// setjmp below, so the longjmp out of libpng skips no destructor.
struct PngRead {
    const unsigned char *data;
    size_t len, at;
    char message[160];
};

void png_read_memory(png_structp png, png_bytep out, size_t n)
{
    auto *r = static_cast<PngRead *>(png_get_io_ptr(png));
    if (n > r->len - r->at)
        png_error(png, "truncated data");
    memcpy(out, r->data + r->at, n);
    r->at += n;
}

void png_on_error(png_structp png, png_const_charp text)
{
    auto *r = static_cast<PngRead *>(png_get_error_ptr(png));
    snprintf(r->message, sizeof r->message, "%s", text ? text : "unknown libpng error");
    png_longjmp(png, 1);
}

// A warning (an ancillary chunk dropped, a questionable profile) changes nothing this module outputs: ignored,
// rather than printed to stderr as libpng's default handler would.
void png_on_warning(png_structp, png_const_charp) {}

int decode_png(const unsigned char *bytes, size_t len, uint32_t width, uint32_t height, unsigned char *rgba,
               char *why, size_t why_cap)
{
    PngRead r{bytes, len, 0, ""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, png_on_error, png_on_warning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    png_bytep *volatile rows = nullptr; // written after setjmp, read after the longjmp: volatile
    if (!png || !info) {
        png_destroy_read_struct(png ? &png : nullptr, nullptr, nullptr);
        set_why(why, why_cap, "out of memory");
        return 0;
    }
    if (setjmp(png_jmpbuf(png))) {
        free(rows);
        png_destroy_read_struct(&png, &info, nullptr);
        set_why(why, why_cap, std::string("PNG read error: ") + r.message);
        return 0;
    }
    png_set_read_fn(png, &r, png_read_memory);
    // The size the caller allocated for is the most libpng accepts; ancillary chunks are bounded too (a compressed
    // iCCP or zTXt chunk could otherwise inflate to any size).
    png_set_user_limits(png, width, height);
    png_set_chunk_malloc_max(png, 8u << 20);
    png_set_chunk_cache_max(png, 1000);
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int depth = 0, type = 0;
    png_get_IHDR(png, info, &w, &h, &depth, &type, nullptr, nullptr, nullptr);
    if (w != width || h != height)
        png_error(png, "the image size differs from its header");
    // To 8-bit RGBA: palette and low-bit grey expanded, tRNS to alpha, 16 bits scaled with rounding, grey to RGB,
    // alpha 255 where there is none. No gamma or colour-space conversion.
    if (type == PNG_COLOR_TYPE_PALETTE)
        png_set_palette_to_rgb(png);
    if (type == PNG_COLOR_TYPE_GRAY && depth < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_tRNS_to_alpha(png);
    if (depth == 16)
        png_set_scale_16(png);
    if (type == PNG_COLOR_TYPE_GRAY || type == PNG_COLOR_TYPE_GRAY_ALPHA)
        png_set_gray_to_rgb(png);
    png_set_filler(png, 0xFF, PNG_FILLER_AFTER);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != size_t(width) * 4 || png_get_channels(png, info) != 4 ||
        png_get_bit_depth(png, info) != 8)
        png_error(png, "not RGBA8 after conversion");
    rows = static_cast<png_bytep *>(malloc(sizeof(png_bytep) * size_t(height)));
    if (!rows)
        png_error(png, "out of memory");
    for (size_t y = 0; y < height; y++)
        rows[y] = rgba + y * size_t(width) * 4;
    png_read_image(png, rows);
    png_read_end(png, nullptr);
    free(rows);
    png_destroy_read_struct(&png, &info, nullptr);
    return 1;
}

int decode_jpeg(const unsigned char *bytes, size_t len, uint32_t width, uint32_t height, unsigned char *rgba,
                char *why, size_t why_cap)
{
    OIIO::Filesystem::IOMemReader mem(bytes, len);
    OIIO::ImageSpec config;
    // OIIO 2.4 ignores open()'s ioproxy argument for some readers; the config attribute works.
    void *proxy = &mem;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    auto in = OIIO::ImageInput::open("texture.jpg", &config);
    if (!in) {
        set_why(why, why_cap, OIIO::geterror());
        return 0;
    }
    const OIIO::ImageSpec &spec = in->spec();
    const int nch = spec.nchannels;
    if (spec.width <= 0 || spec.height <= 0 || uint32_t(spec.width) != width || uint32_t(spec.height) != height ||
        spec.depth > 1) {
        set_why(why, why_cap, "the image size " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                                  " differs from its header");
        return 0;
    }
    if (nch <= 0 || nch > 4 || spec.tile_width) {
        set_why(why, why_cap, "unsupported layout (" + std::to_string(nch) + " channels)");
        return 0;
    }
    const size_t w = width, h = height, nc = size_t(nch);
    // Row by row into the caller's block; one row of staging, never a second image.
    std::vector<uint8_t> row(w * nc);
    for (size_t y = 0; y < h; y++) {
        if (!in->read_scanline(spec.y + int(y), spec.z, OIIO::TypeDesc::UINT8, row.data())) {
            set_why(why, why_cap, in->geterror());
            return 0;
        }
        for (size_t x = 0; x < w; x++) {
            const uint8_t *s = &row[x * nc];
            uint8_t *d = rgba + (y * w + x) * 4;
            d[0] = s[0];
            d[1] = nc >= 3 ? s[1] : s[0];
            d[2] = nc >= 3 ? s[2] : s[0];
            d[3] = nc == 4 ? s[3] : nc == 2 ? s[1] : 255;
        }
    }
    return 1;
}

int decode(const unsigned char *bytes, size_t len, uint32_t width, uint32_t height, unsigned char *rgba, char *why,
           size_t why_cap)
{
    if (!bytes || !rgba || !width || !height) {
        set_why(why, why_cap, "no data");
        return 0;
    }
    if (is_png(bytes, len)) {
        std::string bad;
        if (!png_structure_ok(bytes, len, &bad)) {
            set_why(why, why_cap, bad);
            return 0;
        }
        return decode_png(bytes, len, width, height, rgba, why, why_cap);
    }
    if (is_jpeg(bytes, len))
        return decode_jpeg(bytes, len, width, height, rgba, why, why_cap);
    set_why(why, why_cap, "not a PNG or JPEG image");
    return 0;
}


// ---------------------------------------------------------------------------------------------------------------
// Image files (io/image.c): probe, read, encode, compare.

// Thrown inside the module only, and turned into a status and a reason at the C boundary.
struct Refusal {
    int code;
    std::string why;
};

[[noreturn]] void refuse(int code, const std::string &why) { throw Refusal{code, why}; }

OIIO::TypeDesc oiio_type(rto_pixel_type t) { return t == RTO_PIXEL_U8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT; }

// The channel names every writer gives 1 to 4 channels, so that a reader finds luminance, alpha and colour by name.
void name_channels(OIIO::ImageSpec &spec)
{
    static const char *const names[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    spec.channelnames.clear();
    for (int c = 0; c < spec.nchannels; c++)
        spec.channelnames.emplace_back(names[spec.nchannels - 1][c]);
    spec.alpha_channel = spec.nchannels == 2 || spec.nchannels == 4 ? spec.nchannels - 1 : -1;
}

OIIO::ImageSpec spec_of(const rto_image *image)
{
    OIIO::ImageSpec spec(int(image->width), int(image->height), int(image->channels), oiio_type(image->type));
    name_channels(spec);
    return spec;
}

// --- PNG, through libpng ---------------------------------------------------------------------------------------

// A PNG decoder on a memory block: the setjmp / longjmp of libpng's error handling stays inside one function per
// step (no C++ object lives across it), and every step ends with the structs destroyed.
struct PngReader {
    PngRead io;
    png_structp png = nullptr;
    png_infop info = nullptr;
    PngReader(const unsigned char *bytes, size_t len) : io{bytes, len, 0, ""} {}
    ~PngReader() { png_destroy_read_struct(png ? &png : nullptr, info ? &info : nullptr, nullptr); }
};

// The channels a PNG has once palette, low-bit grey and tRNS are expanded (no grey to RGB: channels stay as stored).
uint32_t png_channels(int color_type, bool trns)
{
    switch (color_type) {
    case PNG_COLOR_TYPE_GRAY: return trns ? 2 : 1;
    case PNG_COLOR_TYPE_GRAY_ALPHA: return 2;
    case PNG_COLOR_TYPE_PALETTE:
    case PNG_COLOR_TYPE_RGB: return trns ? 4 : 3;
    default: return 4;
    }
}

// Reads the header chunks (up to the first IDAT); with rows non-NULL, also sets the transformations and decodes every
// row into rows[y] (8-bit, or 16-bit in host order). Returns 1, or 0 with r->io.message set.
int png_steps(PngReader *r, rto_image *info, png_bytep *rows)
{
    r->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r->io, png_on_error, png_on_warning);
    r->info = r->png ? png_create_info_struct(r->png) : nullptr;
    if (!r->png || !r->info) {
        snprintf(r->io.message, sizeof r->io.message, "out of memory");
        return 0;
    }
    png_structp png = r->png;
    png_infop in = r->info;
    if (setjmp(png_jmpbuf(png)))
        return 0;
    png_set_read_fn(png, &r->io, png_read_memory);
    // Each dimension at most 2^28 (the caller refuses more pixels than that); ancillary chunks are bounded too (a
    // compressed iCCP or zTXt chunk could otherwise inflate to any size).
    png_set_user_limits(png, 1u << 28, 1u << 28);
    png_set_chunk_malloc_max(png, 8u << 20);
    png_set_chunk_cache_max(png, 1000);
    png_read_info(png, in);
    png_uint_32 w = 0, h = 0;
    int depth = 0, type = 0;
    png_get_IHDR(png, in, &w, &h, &depth, &type, nullptr, nullptr, nullptr);
    const bool trns = png_get_valid(png, in, PNG_INFO_tRNS) != 0;
    const uint32_t channels = png_channels(type, trns);
    const rto_pixel_type ptype = depth == 16 ? RTO_PIXEL_F32 : RTO_PIXEL_U8;
    if (!rows) {
        info->width = w;
        info->height = h;
        info->channels = channels;
        info->type = ptype;
        return 1;
    }
    if (w != info->width || h != info->height || channels != info->channels || ptype != info->type)
        png_error(png, "the image header changed between two reads");
    if (type == PNG_COLOR_TYPE_PALETTE)
        png_set_palette_to_rgb(png);
    if (type == PNG_COLOR_TYPE_GRAY && depth < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    if (trns)
        png_set_tRNS_to_alpha(png);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (depth == 16)
        png_set_swap(png); // PNG stores 16-bit samples big-endian; the rows are read as host uint16_t
#endif
    png_set_interlace_handling(png);
    png_read_update_info(png, in);
    const size_t sample = depth == 16 ? 2 : 1;
    if (png_get_rowbytes(png, in) != size_t(w) * channels * sample || png_get_channels(png, in) != channels)
        png_error(png, "unexpected row layout after conversion");
    png_read_image(png, rows);
    png_read_end(png, nullptr);
    return 1;
}

void png_probe(const unsigned char *bytes, size_t len, rto_image *info)
{
    std::string bad;
    if (!png_structure_ok(bytes, len, &bad))
        refuse(RTO_IMAGE_MODULE_CORRUPT, bad);
    PngReader r(bytes, len);
    if (!png_steps(&r, info, nullptr))
        refuse(RTO_IMAGE_MODULE_CORRUPT, std::string("PNG read error: ") + r.io.message);
}

void png_read(const unsigned char *bytes, size_t len, const rto_image *image)
{
    std::string bad;
    if (!png_structure_ok(bytes, len, &bad))
        refuse(RTO_IMAGE_MODULE_CORRUPT, bad);
    const size_t w = image->width, h = image->height, nc = image->channels;
    const bool wide = image->type == RTO_PIXEL_F32;
    // 8-bit rows are decoded straight into the caller's block; 16-bit ones into a block of half its size, then
    // scaled to [0, 1] (interlaced images need every row at once, so there is no row-by-row path).
    std::vector<uint16_t> wide_rows(wide ? w * h * nc : 0);
    std::vector<png_bytep> rows(h);
    for (size_t y = 0; y < h; y++)
        rows[y] = wide ? reinterpret_cast<png_bytep>(wide_rows.data() + y * w * nc)
                       : static_cast<png_bytep>(image->pixels) + y * w * nc;
    rto_image expect = *image;
    PngReader r(bytes, len);
    if (!png_steps(&r, &expect, rows.data()))
        refuse(RTO_IMAGE_MODULE_CORRUPT, std::string("PNG read error: ") + r.io.message);
    if (wide) {
        float *out = static_cast<float *>(image->pixels);
        for (size_t i = 0; i < wide_rows.size(); i++)
            out[i] = float(wide_rows[i] / 65535.0); // rounded once from the exact quotient
    }
}

// --- OpenEXR and the rest, through OpenImageIO -----------------------------------------------------------------

bool is_exr(const unsigned char *b, size_t n) { return n >= 4 && memcmp(b, "\x76\x2f\x31\x01", 4) == 0; }

uint32_t le32(const unsigned char *p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

// The data window of an OpenEXR header (OpenEXR file layout: magic, version, then name\0 type\0 size value ... \0),
// read before OpenImageIO sees the file: OpenEXR allocates the chunk offset table from it when it opens a file, so a
// tiny file claiming 2^31 rows would cost gigabytes before any size check could run.
void exr_data_window(const unsigned char *b, size_t n, uint64_t *w, uint64_t *h)
{
    if (n < 8)
        refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: truncated header");
    size_t at = 8;
    auto cstr = [&](const char *what) {
        const void *end = at < n ? memchr(b + at, 0, n - at) : nullptr;
        if (!end)
            refuse(RTO_IMAGE_MODULE_CORRUPT, std::string("corrupt OpenEXR: truncated header (") + what + ")");
        std::string s(reinterpret_cast<const char *>(b + at), static_cast<const unsigned char *>(end) - (b + at));
        at += s.size() + 1;
        return s;
    };
    for (;;) {
        const std::string name = cstr("attribute name");
        if (name.empty())
            refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: no dataWindow in the header");
        const std::string type = cstr("attribute type");
        if (n - at < 4)
            refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: truncated header (attribute size)");
        const uint32_t size = le32(b + at);
        at += 4;
        if (size > n - at)
            refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: attribute '" + name.substr(0, 40) +
                                                 "' runs past the end of the file");
        if (name == "dataWindow") {
            if (type != "box2i" || size != 16)
                refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: dataWindow is not a box2i");
            const int64_t x0 = int32_t(le32(b + at)), y0 = int32_t(le32(b + at + 4));
            const int64_t x1 = int32_t(le32(b + at + 8)), y1 = int32_t(le32(b + at + 12));
            if (x1 < x0 || y1 < y0)
                refuse(RTO_IMAGE_MODULE_CORRUPT, "corrupt OpenEXR: empty dataWindow");
            *w = uint64_t(x1 - x0) + 1;
            *h = uint64_t(y1 - y0) + 1;
            return;
        }
        at += size;
    }
}

std::string last_line(std::string text)
{
    while (!text.empty() && (text.back() == '\n' || text.back() == ' '))
        text.pop_back();
    return text.empty() ? "unknown OpenImageIO error" : text.substr(0, text.find('\n'));
}

// An ImageInput on the bytes (OpenImageIO's memory I/O proxy). name picks the reader by its extension, except for
// OpenEXR, recognised by its magic number.
std::unique_ptr<OIIO::ImageInput> oiio_open(const unsigned char *bytes, size_t len, const char *name,
                                            OIIO::Filesystem::IOMemReader *mem)
{
    uint64_t w = 0, h = 0;
    if (is_exr(bytes, len)) {
        exr_data_window(bytes, len, &w, &h);
        if (w > RTO_IMAGE_MODULE_MAX_PIXELS || h > RTO_IMAGE_MODULE_MAX_PIXELS || w * h > RTO_IMAGE_MODULE_MAX_PIXELS)
            refuse(RTO_IMAGE_MODULE_UNSUPPORTED, std::to_string(w) + "x" + std::to_string(h) +
                                                     " is more than 2^28 pixels");
    }
    OIIO::ImageSpec config;
    // OIIO 2.4 ignores open()'s ioproxy argument for some readers; the config attribute works. Alpha is read as
    // stored (OpenImageIO would otherwise premultiply a format's unassociated alpha).
    void *proxy = mem;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    config.attribute("oiio:UnassociatedAlpha", 1);
    // The name only picks the reader (the bytes come from the proxy); an OpenEXR file is read as one whatever its
    // name, and keeps its name in OpenEXR's messages.
    std::string fname = name && *name ? name : "image";
    if (is_exr(bytes, len) && !OIIO::Strutil::iends_with(fname, ".exr"))
        fname += ".exr";
    auto in = OIIO::ImageInput::open(fname, &config);
    if (!in) {
        std::string e = last_line(OIIO::geterror());
        // OpenImageIO's words for a name whose extension names no reader it has, and no reader took the bytes.
        if (e.find("does not exist") != std::string::npos || e.find("not the name of an image format") != std::string::npos)
            refuse(RTO_IMAGE_MODULE_UNSUPPORTED, "not an image OpenImageIO can read (PNG, OpenEXR, ...)");
        refuse(RTO_IMAGE_MODULE_CORRUPT, e);
    }
    return in;
}

void oiio_info(const OIIO::ImageSpec &spec, rto_image *info)
{
    if (spec.deep)
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, "deep images are not supported");
    if (spec.depth > 1)
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, "volume images are not supported");
    if (spec.width <= 0 || spec.height <= 0)
        refuse(RTO_IMAGE_MODULE_CORRUPT, "empty image");
    if (spec.nchannels < 1 || spec.nchannels > 4)
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, std::to_string(spec.nchannels) + " channels (1 to 4 are supported)");
    info->width = uint32_t(spec.width);
    info->height = uint32_t(spec.height);
    info->channels = uint32_t(spec.nchannels);
    info->type = spec.format == OIIO::TypeDesc::UINT8 ? RTO_PIXEL_U8 : RTO_PIXEL_F32;
    info->pixels = nullptr;
}

void probe(const unsigned char *bytes, size_t len, const char *name, rto_image *info)
{
    if (!bytes || !len)
        refuse(RTO_IMAGE_MODULE_CORRUPT, "empty file");
    if (is_png(bytes, len))
        return png_probe(bytes, len, info);
    OIIO::Filesystem::IOMemReader mem(const_cast<unsigned char *>(bytes), len);
    auto in = oiio_open(bytes, len, name, &mem);
    oiio_info(in->spec(), info);
}

void read(const unsigned char *bytes, size_t len, const char *name, const rto_image *image)
{
    if (!bytes || !len || !image || !image->pixels)
        refuse(RTO_IMAGE_MODULE_CORRUPT, "no data");
    if (is_png(bytes, len))
        return png_read(bytes, len, image);
    OIIO::Filesystem::IOMemReader mem(const_cast<unsigned char *>(bytes), len);
    auto in = oiio_open(bytes, len, name, &mem);
    rto_image now{};
    oiio_info(in->spec(), &now);
    if (now.width != image->width || now.height != image->height || now.channels != image->channels ||
        now.type != image->type)
        refuse(RTO_IMAGE_MODULE_CORRUPT, "the image header changed between two reads");
    // In bands of 64 rows, read in the file's own format and converted here by OpenImageIO's convert_pixel_values:
    // read_image / read_scanlines stage every call through a 64 MiB block, whatever the image's size. A file whose
    // channels have different formats takes that path still (OpenImageIO's conversion handles the mix).
    const OIIO::ImageSpec &spec = in->spec();
    const OIIO::TypeDesc want = oiio_type(image->type);
    const size_t w = image->width, nc = image->channels, row = w * nc * want.size();
    unsigned char *out = static_cast<unsigned char *>(image->pixels);
    const bool uniform = spec.channelformats.empty();
    std::vector<unsigned char> band(uniform ? size_t(spec.scanline_bytes(true)) * std::min<uint32_t>(64, image->height)
                                            : 0);
    for (uint32_t y = 0; y < image->height; y += 64) {
        const uint32_t n = std::min<uint32_t>(64, image->height - y);
        const int y0 = spec.y + int(y), y1 = y0 + int(n);
        bool ok = uniform ? in->read_native_scanlines(0, 0, y0, y1, spec.z, 0, int(nc), band.data()) &&
                                OIIO::convert_pixel_values(spec.format, band.data(), want, out + y * row,
                                                           int(n * w * nc))
                          : in->read_scanlines(0, 0, y0, y1, spec.z, 0, int(nc), want, out + y * row);
        if (!ok)
            refuse(RTO_IMAGE_MODULE_CORRUPT, last_line(in->geterror()));
    }
}

void encode(const rto_image *image, int exr, unsigned char **bytes, size_t *len)
{
    OIIO::ImageSpec spec = spec_of(image);
    std::vector<unsigned char> out;
    OIIO::Filesystem::IOVecOutput vec(out);
    void *proxy = &vec;
    spec.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    // PNG files are written by the library itself (io/png_write.c, libpng), without this module.
    if (!exr)
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, "the module writes OpenEXR only (PNG: io/png_write.c)");
    spec.attribute("compression", "zip");
    // OpenImageIO writes OpenEXR's capDate from DateTime, and the current time when there is none: a fixed value keeps
    // the bytes a function of the pixels.
    spec.attribute("DateTime", "1970:01:01 00:00:00");
    const char *fname = "image.exr";
    auto o = OIIO::ImageOutput::create(fname);
    if (!o)
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, last_line(OIIO::geterror()));
    if (!o->open(fname, spec) || !o->write_image(oiio_type(image->type), image->pixels) || !o->close())
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, last_line(o->geterror()));
    o.reset();
    *bytes = static_cast<unsigned char *>(malloc(out.size() ? out.size() : 1));
    if (!*bytes)
        throw std::bad_alloc();
    memcpy(*bytes, out.data(), out.size());
    *len = out.size();
}

void compare(const rto_image *expected, const rto_image *actual, double fail, double warn, double diff_scale,
             rto_image *diff, rto_image_compare_result *result)
{
    // The caller's pixels are wrapped, not copied (ImageBuf over an application buffer, read only here).
    OIIO::ImageBuf a(spec_of(expected), expected->pixels), b(spec_of(actual), actual->pixels);
    OIIO::ImageBufAlgo::CompareResults cr =
        OIIO::ImageBufAlgo::compare(a, b, float(fail), float(warn), OIIO::ROI(), 1);
    // cr.error is not an error flag: OpenImageIO 2.4 sets it whenever a pixel failed. The buffers' own error
    // states say whether the comparison itself went wrong.
    if (a.has_error() || b.has_error())
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, last_line(a.geterror() + b.geterror()));
    result->mean_error = cr.meanerror;
    result->rms_error = cr.rms_error;
    result->psnr = cr.PSNR;
    result->max_error = cr.maxerror;
    result->max_x = uint32_t(cr.maxx);
    result->max_y = uint32_t(cr.maxy);
    result->max_c = uint32_t(cr.maxc);
    result->pixels = uint64_t(expected->width) * expected->height;
    result->fail_count = uint64_t(cr.nfail);
    result->warn_count = uint64_t(cr.nwarn);
    if (!diff)
        return;
    OIIO::ImageSpec fspec = spec_of(expected);
    fspec.set_format(OIIO::TypeDesc::FLOAT);
    OIIO::ImageBuf d(fspec), scaled(fspec), shown(fspec);
    bool ok = OIIO::ImageBufAlgo::absdiff(d, a, b, OIIO::ROI(), 1) &&
              OIIO::ImageBufAlgo::mul(scaled, d, float(diff_scale), OIIO::ROI(), 1);
    const OIIO::ImageBuf *out = &scaled;
    if (ok && fspec.alpha_channel >= 0) {
        // An alpha channel of |alpha difference| would make the diff image transparent wherever the images agree
        // in alpha, i.e. invisible in most viewers: it is made opaque (alpha differences are still measured).
        const int n = fspec.nchannels;
        std::vector<int> order(static_cast<size_t>(n), 0);
        std::vector<float> values(size_t(n), 0.0f);
        for (int c = 0; c < n; c++)
            order[size_t(c)] = c;
        order[size_t(n - 1)] = -1;
        values[size_t(n - 1)] = 1.0f;
        ok = OIIO::ImageBufAlgo::channels(shown, scaled, n, order, values, {}, false, 1);
        out = &shown;
    }
    if (!ok || !out->get_pixels(OIIO::ROI::All(), oiio_type(diff->type), diff->pixels))
        refuse(RTO_IMAGE_MODULE_UNSUPPORTED, last_line(d.geterror() + scaled.geterror() + shown.geterror()));
}

// Runs f, turning every exception into a status and a reason.
template <class F> int guarded(char *why, size_t why_cap, F &&f)
{
    try {
        f();
        return RTO_IMAGE_MODULE_OK;
    } catch (const Refusal &r) {
        set_why(why, why_cap, r.why);
        return r.code;
    } catch (const std::bad_alloc &) {
        set_why(why, why_cap, "out of memory");
        return RTO_IMAGE_MODULE_NO_MEMORY;
    } catch (const std::exception &e) {
        set_why(why, why_cap, e.what());
    } catch (...) {
        set_why(why, why_cap, "unknown C++ exception");
    }
    return RTO_IMAGE_MODULE_CORRUPT;
}

} // namespace

extern "C" __attribute__((visibility("default"))) int rto_image_module_abi(void) { return RTO_IMAGE_MODULE_ABI; }

extern "C" __attribute__((visibility("default"))) int rto_image_decode_rgba(const unsigned char *bytes, size_t len,
                                                                             uint32_t width, uint32_t height,
                                                                             unsigned char *rgba, char *why,
                                                                             size_t why_cap)
{
    try {
        return decode(bytes, len, width, height, rgba, why, why_cap);
    } catch (const std::exception &e) {
        set_why(why, why_cap, e.what());
    } catch (...) {
        set_why(why, why_cap, "unknown C++ exception");
    }
    return 0;
}

extern "C" __attribute__((visibility("default"))) int rto_image_module_probe(const unsigned char *bytes, size_t len,
                                                                              const char *name, rto_image *info,
                                                                              char *why, size_t why_cap)
{
    return guarded(why, why_cap, [&] { probe(bytes, len, name, info); });
}

extern "C" __attribute__((visibility("default"))) int rto_image_module_read(const unsigned char *bytes, size_t len,
                                                                             const char *name, const rto_image *image,
                                                                             char *why, size_t why_cap)
{
    return guarded(why, why_cap, [&] { read(bytes, len, name, image); });
}

extern "C" __attribute__((visibility("default"))) int rto_image_module_encode(const rto_image *image, int exr,
                                                                               unsigned char **bytes, size_t *len,
                                                                               char *why, size_t why_cap)
{
    *bytes = nullptr;
    *len = 0;
    return guarded(why, why_cap, [&] { encode(image, exr, bytes, len); });
}

extern "C" __attribute__((visibility("default"))) int
rto_image_module_compare(const rto_image *expected, const rto_image *actual, double fail, double warn,
                         double diff_scale, rto_image *diff, rto_image_compare_result *result, char *why,
                         size_t why_cap)
{
    return guarded(why, why_cap, [&] { compare(expected, actual, fail, warn, diff_scale, diff, result); });
}
