// librto_image.so: decodes texture images with OpenImageIO behind the C function of image_module.h. Loaded with
// dlopen by the glTF shim on the first texture (see image_module.h for why it is a separate module).
#include "image_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
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
    snprintf(why, cap, "%s", line.empty() ? "unknown OpenImageIO error" : line.c_str());
}

// OIIO picks its reader by file extension; the format is taken from the content, so a wrong mimeType or name does
// not matter.
const char *sniff_extension(const unsigned char *b, size_t n)
{
    auto starts = [&](const char *magic, size_t len, size_t at = 0) {
        return n >= at + len && memcmp(b + at, magic, len) == 0;
    };
    if (starts("\x89PNG", 4))
        return "png";
    if (starts("\xFF\xD8\xFF", 3))
        return "jpg";
    if (starts("RIFF", 4) && starts("WEBP", 4, 8))
        return "webp";
    if (starts("GIF8", 4))
        return "gif";
    if (starts("BM", 2))
        return "bmp";
    return nullptr;
}

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

// The PNG chunk structure (PNG spec §5.3): every chunk inside the data with a correct CRC, up to IEND. Checked
// before OpenImageIO sees the data: on a truncated or corrupt stream, OIIO 2.4's libpng read callback leaks its
// error string when libpng longjmps out of it, and libpng prints its own messages to stderr.
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

int decode(const unsigned char *bytes, size_t len, uint64_t max_texels, uint32_t *width, uint32_t *height,
           unsigned char **rgba, char *why, size_t why_cap)
{
    const char *ext = sniff_extension(bytes, len);
    if (!ext) {
        set_why(why, why_cap, "not a PNG, JPEG, WebP, GIF or BMP image");
        return 0;
    }
    std::string bad;
    if (!strcmp(ext, "png") && !png_structure_ok(bytes, len, &bad)) {
        set_why(why, why_cap, bad);
        return 0;
    }
    OIIO::Filesystem::IOMemReader mem(bytes, len);
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1); // keep straight alpha, as stored
    // OIIO 2.4 ignores open()'s ioproxy argument for some readers (PNG among them); the config attribute works.
    void *proxy = &mem;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    auto in = OIIO::ImageInput::open(std::string("texture.") + ext, &config);
    if (!in) {
        set_why(why, why_cap, OIIO::geterror());
        return 0;
    }
    const OIIO::ImageSpec &spec = in->spec();
    const int nch = spec.nchannels;
    if (spec.width <= 0 || spec.height <= 0 || nch <= 0 || nch > 64 || spec.depth > 1 ||
        uint64_t(spec.width) * uint64_t(spec.height) > max_texels) {
        set_why(why, why_cap, "unsupported size " + std::to_string(spec.width) + "x" + std::to_string(spec.height));
        return 0;
    }
    if (spec.tile_width) {
        set_why(why, why_cap, "tiled images are not supported");
        return 0;
    }
    const size_t w = size_t(spec.width), h = size_t(spec.height), nc = size_t(nch), keep = std::min(nc, size_t(4));
    // Row by row: OIIO's read_image stages through a 64 MiB buffer whatever the image size, which costs dearly
    // under MALLOC_PERTURB_ (meson test) and sanitizers.
    std::vector<uint8_t> row(w * nc);
    std::unique_ptr<unsigned char, decltype(&free)> out(static_cast<unsigned char *>(malloc(w * h * 4)), free);
    if (!out) {
        set_why(why, why_cap, "out of memory");
        return 0;
    }
    for (size_t y = 0; y < h; y++) {
        if (!in->read_scanline(spec.y + int(y), spec.z, OIIO::TypeDesc::UINT8, row.data())) {
            set_why(why, why_cap, in->geterror());
            return 0;
        }
        for (size_t x = 0; x < w; x++) {
            const uint8_t *s = &row[x * nc];
            uint8_t *d = out.get() + (y * w + x) * 4;
            d[0] = s[0];
            d[1] = keep >= 3 ? s[1] : s[0];
            d[2] = keep >= 3 ? s[2] : s[0];
            d[3] = keep == 4 ? s[3] : keep == 2 ? s[1] : 255;
        }
    }
    *width = uint32_t(w);
    *height = uint32_t(h);
    *rgba = out.release();
    return 1;
}

} // namespace

extern "C" __attribute__((visibility("default"))) int rto_image_module_abi(void) { return RTO_IMAGE_MODULE_ABI; }

extern "C" __attribute__((visibility("default"))) int rto_image_decode_rgba(const unsigned char *bytes, size_t len,
                                                                             uint64_t max_texels, uint32_t *width,
                                                                             uint32_t *height, unsigned char **rgba,
                                                                             char *why, size_t why_cap)
{
    try {
        return decode(bytes, len, max_texels, width, height, rgba, why, why_cap);
    } catch (const std::exception &e) {
        set_why(why, why_cap, e.what());
    } catch (...) {
        set_why(why, why_cap, "unknown C++ exception");
    }
    return 0;
}
