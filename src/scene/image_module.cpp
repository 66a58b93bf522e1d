// librto_image.so: decodes texture images behind the C function of image_module.h, straight into the caller's
// block. Loaded with dlopen by the glTF shim on the first texture (see image_module.h for why it is a module).
//
// PNG goes through libpng directly, with error and warning handlers of its own: OpenImageIO 2.4 creates its libpng
// reader with libpng's default handlers, which print "libpng error: ..." to stderr for a corrupt image even when the
// scene then loads with a warning, and a successful run must be silent. JPEG goes through OpenImageIO, whose libjpeg
// reader reports through OIIO's error state, silently.
#include "image_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
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
