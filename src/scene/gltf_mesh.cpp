// The glTF loader's geometry and materials (gltf.cpp describes the loader and its decisions): accessors read
// with every range checked (sparse ones included), each (mesh, primitive) turned into one BLAS within the scene's
// limits, and the materials with their base-colour textures, decoded by the image module once per image.
#include "gltf_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "image_module.h"

namespace rto_gltf {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Accessors

// An accessor's elements, tightly packed (count * ncomp components of comp_size bytes), sparse substitutions applied.
struct Packed {
    std::vector<unsigned char> bytes;
    size_t count = 0, ncomp = 0, comp_size = 0;
    int component_type = 0;
    bool normalized = false;
};

size_t component_size(int t)
{
    switch (t) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

const char *component_name(int t)
{
    switch (t) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "byte";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "unsigned byte";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "unsigned short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "unsigned int";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "float";
    default: return "unknown";
    }
}

const char *type_name(int ncomp)
{
    switch (ncomp) {
    case 1: return "SCALAR";
    case 2: return "VEC2";
    case 3: return "VEC3";
    case 4: return "VEC4";
    case 9: return "MAT3";
    case 16: return "MAT4";
    default: return "unknown";
    }
}

size_t type_components(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
    }
}

// The bytes of bufferView v that an element run of `count` elements of `elem` bytes at `offset` with `stride` spans,
// checked against the view and the view against its buffer. Returns the first element's address.
const unsigned char *view_range(const tinygltf::Model &g, int v, uint64_t offset, uint64_t stride, uint64_t elem,
                                uint64_t count, const std::string &what)
{
    if (v < 0 || size_t(v) >= g.bufferViews.size())
        refuse(RTO_ERR_PARSE, "%s: bufferView %d out of range (%zu bufferViews)", what.c_str(), v,
               g.bufferViews.size());
    const tinygltf::BufferView &bv = g.bufferViews[size_t(v)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= g.buffers.size())
        refuse(RTO_ERR_PARSE, "%s: bufferView %d names buffer %d (%zu buffers)", what.c_str(), v, bv.buffer,
               g.buffers.size());
    const tinygltf::Buffer &buf = g.buffers[size_t(bv.buffer)];
    const uint64_t blen = buf.data.size();
    if (uint64_t(bv.byteOffset) > blen || uint64_t(bv.byteLength) > blen - uint64_t(bv.byteOffset))
        refuse(RTO_ERR_PARSE, "%s: bufferView %d (bytes %zu .. %zu) runs past buffer %d (%llu bytes)", what.c_str(), v,
               bv.byteOffset, bv.byteOffset + bv.byteLength, bv.buffer, (unsigned long long)blen);
    // count <= 2^28, stride <= 2^8, elem <= 64, offset <= 2^53: no overflow in 64 bits.
    const uint64_t need = count ? offset + (count - 1) * stride + elem : offset;
    if (need > bv.byteLength)
        refuse(RTO_ERR_PARSE, "%s: needs bytes %llu .. %llu of bufferView %d, which holds %zu", what.c_str(),
               (unsigned long long)offset, (unsigned long long)need, v, bv.byteLength);
    return buf.data.data() + bv.byteOffset + offset;
}

// Accessor a, its index checked (its ranges are plan_accessor's).
const tinygltf::Accessor &accessor_at(const tinygltf::Model &g, int a, const std::string &role)
{
    if (a < 0 || size_t(a) >= g.accessors.size())
        refuse(RTO_ERR_PARSE, "%s: accessor %d out of range (%zu accessors)", role.c_str(), a, g.accessors.size());
    return g.accessors[size_t(a)];
}

// Where an accessor's bytes are, every range checked: its elements (and sparse substitutions) inside their
// bufferViews, each view inside its buffer. Nothing is allocated.
struct AccessorPlan {
    const tinygltf::Accessor *acc = nullptr;
    std::string what;
    size_t ncomp = 0, comp_size = 0, elem = 0, stride = 0, isz = 0;
    const unsigned char *src = nullptr, *ip = nullptr, *vp = nullptr; // elements, sparse indices, sparse values
};

AccessorPlan plan_accessor(const tinygltf::Model &g, int a, const std::string &role)
{
    AccessorPlan pl;
    const tinygltf::Accessor &acc = accessor_at(g, a, role);
    pl.acc = &acc;
    pl.what = "accessor " + std::to_string(a) + " (" + role + ")";
    const char *what = pl.what.c_str();
    pl.comp_size = component_size(acc.componentType);
    pl.ncomp = type_components(acc.type);
    if (!pl.comp_size || !pl.ncomp)
        refuse(RTO_ERR_PARSE, "%s: unknown componentType %d or type", what, acc.componentType);
    if (acc.count > kMaxAccessorCount)
        refuse(RTO_ERR_UNSUPPORTED, "%s: %zu elements (at most %llu are supported)", what, acc.count,
               (unsigned long long)kMaxAccessorCount);
    pl.elem = pl.stride = pl.ncomp * pl.comp_size;
    if (acc.bufferView >= 0) {
        const tinygltf::BufferView *bv =
            size_t(acc.bufferView) < g.bufferViews.size() ? &g.bufferViews[size_t(acc.bufferView)] : nullptr;
        pl.stride = bv && bv->byteStride ? bv->byteStride : pl.elem;
        if (pl.stride < pl.elem)
            refuse(RTO_ERR_PARSE, "%s: byteStride %zu is smaller than an element (%zu bytes)", what, pl.stride,
                   pl.elem);
        pl.src = view_range(g, acc.bufferView, acc.byteOffset, pl.stride, pl.elem, acc.count, pl.what);
    } else if (acc.count > kMaxZeroAccessorCount) {
        // Without a bufferView the elements are zeros (glTF 2.0 §3.6.2.3), backed by no data at all.
        refuse(RTO_ERR_UNSUPPORTED, "%s: %zu elements without a bufferView (at most %llu are supported)", what,
               acc.count, (unsigned long long)kMaxZeroAccessorCount);
    }
    const auto &sp = acc.sparse;
    if (sp.isSparse) {
        const std::string swhat = pl.what + " sparse";
        if (sp.count < 1 || size_t(sp.count) > acc.count)
            refuse(RTO_ERR_PARSE, "%s: count %d not in 1 .. %zu", swhat.c_str(), sp.count, acc.count);
        pl.isz = component_size(sp.indices.componentType);
        if (sp.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
            sp.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
            sp.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
            refuse(RTO_ERR_PARSE, "%s: index componentType %d is not an unsigned integer type", swhat.c_str(),
                   sp.indices.componentType);
        if (sp.indices.byteOffset < 0 || sp.values.byteOffset < 0)
            refuse(RTO_ERR_PARSE, "%s: negative byteOffset", swhat.c_str());
        pl.ip = view_range(g, sp.indices.bufferView, uint64_t(sp.indices.byteOffset), pl.isz, pl.isz,
                           uint64_t(sp.count), swhat + " indices");
        pl.vp = view_range(g, sp.values.bufferView, uint64_t(sp.values.byteOffset), pl.elem, pl.elem,
                           uint64_t(sp.count), swhat + " values");
    }
    return pl;
}

// The accessor's elements, packed. Every range is checked first (plan_accessor): nothing sized by count is
// allocated until the data behind it is known to exist, so a small file cannot make the loader allocate gigabytes.
Packed read_accessor(const tinygltf::Model &g, int a, const std::string &role)
{
    const AccessorPlan pl = plan_accessor(g, a, role);
    const tinygltf::Accessor &acc = *pl.acc;
    Packed p;
    p.comp_size = pl.comp_size;
    p.ncomp = pl.ncomp;
    p.component_type = acc.componentType;
    p.normalized = acc.normalized;
    p.count = acc.count;
    const size_t elem = pl.elem;
    p.bytes.assign(p.count * elem, 0);
    if (pl.src)
        for (size_t i = 0; i < p.count; i++)
            memcpy(&p.bytes[i * elem], pl.src + i * pl.stride, elem);
    const auto &sp = acc.sparse;
    if (sp.isSparse) {
        uint64_t prev = 0;
        for (size_t k = 0; k < size_t(sp.count); k++) {
            uint64_t idx = 0;
            if (pl.isz == 1)
                idx = pl.ip[k];
            else if (pl.isz == 2) {
                uint16_t v;
                memcpy(&v, pl.ip + 2 * k, 2);
                idx = v;
            } else {
                uint32_t v;
                memcpy(&v, pl.ip + 4 * k, 4);
                idx = v;
            }
            if (idx >= p.count || (k > 0 && idx <= prev))
                refuse(RTO_ERR_PARSE, "%s sparse: index %llu (entry %zu) out of range or not strictly increasing",
                       pl.what.c_str(), (unsigned long long)idx, k);
            prev = idx;
            memcpy(&p.bytes[size_t(idx) * elem], pl.vp + k * elem, elem);
        }
    }
    return p;
}

// Component c of element i as an unsigned integer (integer component types only).
uint32_t packed_uint(const Packed &p, size_t i, size_t c)
{
    const unsigned char *s = &p.bytes[(i * p.ncomp + c) * p.comp_size];
    if (p.comp_size == 1)
        return s[0];
    if (p.comp_size == 2) {
        uint16_t v;
        memcpy(&v, s, 2);
        return v;
    }
    uint32_t v;
    memcpy(&v, s, 4);
    return v;
}

// The accessor as floats: float components as stored, normalized unsigned byte / short divided by 255 / 65535.
std::vector<float> read_floats(const tinygltf::Model &g, int a, size_t ncomp, bool allow_normalized,
                               const std::string &role)
{
    Packed p = read_accessor(g, a, role);
    const bool is_float = p.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT;
    const bool is_unorm = allow_normalized && p.normalized &&
                          (p.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                           p.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    if (p.ncomp != ncomp || !(is_float || is_unorm))
        refuse(RTO_ERR_PARSE, "accessor %d (%s): expected %s float%s, got %s %s%s", a, role.c_str(),
               type_name(int(ncomp)), allow_normalized ? " or normalized unsigned byte / short" : "",
               type_name(int(p.ncomp)), component_name(p.component_type), p.normalized ? " normalized" : "");
    std::vector<float> out(p.count * ncomp);
    if (out.empty()) {
        // count 0: nothing to copy (and data() may be NULL, which memcpy must not be given even for 0 bytes)
    } else if (is_float) {
        memcpy(out.data(), p.bytes.data(), out.size() * sizeof(float));
    } else {
        const float scale = p.comp_size == 1 ? 255.0f : 65535.0f;
        for (size_t i = 0; i < p.count; i++)
            for (size_t c = 0; c < ncomp; c++)
                out[i * ncomp + c] = float(packed_uint(p, i, c)) / scale;
    }
    return out;
}

std::vector<uint32_t> read_indices(const tinygltf::Model &g, int a, const std::string &role)
{
    Packed p = read_accessor(g, a, role);
    if (p.ncomp != 1 || (p.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                         p.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                         p.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
        refuse(RTO_ERR_PARSE, "accessor %d (%s): expected SCALAR unsigned byte / short / int, got %s %s", a,
               role.c_str(), type_name(int(p.ncomp)), component_name(p.component_type));
    std::vector<uint32_t> out(p.count);
    for (size_t i = 0; i < p.count; i++)
        out[i] = packed_uint(p, i, 0);
    return out;
}

// ---------------------------------------------------------------------------------------------------------------
// Textures

uint16_t be16(const unsigned char *p) { return uint16_t(p[0] << 8 | p[1]); }

uint32_t be32(const unsigned char *p)
{
    return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
}

// Width and height from an image's header, without decoding a pixel: a PNG's IHDR (PNG spec §11.2.2) or a JPEG's
// first frame header SOFn (ITU-T T.81 §B.2.2), found by walking the marker segments. PNG and JPEG are the formats
// glTF 2.0 allows (§3.8.1). False with a reason for anything else.
bool image_header(const unsigned char *b, size_t n, uint32_t *w, uint32_t *h, std::string *why)
{
    if (n >= 8 && memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0) {
        if (n < 8 + 8 + 13 || be32(b + 8) != 13 || memcmp(b + 12, "IHDR", 4) != 0) {
            *why = "corrupt PNG: no IHDR chunk first";
            return false;
        }
        *w = be32(b + 16);
        *h = be32(b + 20);
        if (*w == 0 || *h == 0 || *w > 0x7FFFFFFFu || *h > 0x7FFFFFFFu) {
            *why = "corrupt PNG: size " + std::to_string(*w) + "x" + std::to_string(*h) + " in IHDR";
            return false;
        }
        return true;
    }
    if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) {
        size_t at = 2;
        for (;;) {
            if (at >= n || b[at] != 0xFF) {
                *why = at >= n ? "corrupt JPEG: no frame header" : "corrupt JPEG: no marker where one must be";
                return false;
            }
            while (at < n && b[at] == 0xFF) // fill bytes
                at++;
            if (at >= n) {
                *why = "corrupt JPEG: no frame header";
                return false;
            }
            const unsigned m = b[at++];
            if (m == 0x01 || (m >= 0xD0 && m <= 0xD8)) // TEM, RSTn, SOI: no length
                continue;
            if (m == 0xD9 || m == 0xDA || m == 0x00) {
                *why = "corrupt JPEG: no frame header before the scan";
                return false;
            }
            if (n - at < 2 || be16(b + at) < 2 || be16(b + at) > n - at) {
                *why = "corrupt JPEG: a marker segment runs past the end of the data";
                return false;
            }
            const size_t len = be16(b + at);
            // SOF0..SOF15 but DHT (C4), JPG (C8) and DAC (CC), which share the range.
            if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
                if (len < 8) {
                    *why = "corrupt JPEG: short frame header";
                    return false;
                }
                *h = be16(b + at + 3);
                *w = be16(b + at + 5);
                if (*w == 0 || *h == 0) {
                    *why = "JPEG without its height in the frame header (DNL) is not supported";
                    return false;
                }
                return true;
            }
            at += len;
        }
    }
    *why = "not a PNG or JPEG image (the formats glTF 2.0 allows)";
    return false;
}

// "256 MiB" for whole mebibytes, else the exact byte count (budgets in tests are small).
std::string bytes_text(uint64_t n)
{
    if (n && n % (uint64_t(1) << 20) == 0)
        return std::to_string(n >> 20) + " MiB";
    return std::to_string(n) + " bytes";
}

} // namespace

// Decodes one image's encoded bytes into a new texture, straight into the block the scene will own, after its
// header has shown that it fits the texture budget. -1 (with a warning) if it cannot be decoded; a refusal if it
// does not fit.
int32_t Loader::decode_image(int i, const std::string &label, const unsigned char *bytes, size_t len, size_t material)
{
    uint32_t w = 0, h = 0;
    std::string why;
    if (!image_header(bytes, len, &w, &h, &why)) {
        rto__scene_warn(s, "image %d ('%.80s'): cannot decode: %.100s; material %zu is untextured", i,
                        label.c_str(), why.c_str(), material);
        return -1;
    }
    const uint64_t texels = uint64_t(w) * h, need = 4 * texels;
    if (texels > RTO_SCENE_MAX_TEXELS) {
        rto__scene_warn(s, "image %d ('%.80s'): %ux%u is more than %u texels; material %zu is untextured", i,
                        label.c_str(), w, h, RTO_SCENE_MAX_TEXELS, material);
        return -1;
    }
    const uint64_t budget = ctx.opts.texture_budget_bytes;
    if (need > budget - std::min(budget, texture_bytes))
        refuse(RTO_ERR_UNSUPPORTED,
               "image %d ('%.80s', %ux%u): the decoded textures would take %s, over the texture budget of %s "
               "(raise it with --texture-budget MB)",
               i, label.c_str(), w, h, bytes_text(texture_bytes + need).c_str(), bytes_text(budget).c_str());
    // The image module is loaded on the first texture that passes the header and budget checks; a failure to
    // load it is reported with every texture, as a warning.
    const char *module_error = "";
    const rto_image_module *mod = rto__image_module(&module_error);
    if (!mod) {
        rto__scene_warn(s, "image %d ('%.80s'): cannot decode: %.100s; material %zu is untextured", i,
                        label.c_str(), module_error, material);
        return -1;
    }
    TexBuf tb;
    tb.rgba.reset(static_cast<uint8_t *>(malloc(size_t(need))));
    if (!tb.rgba)
        throw std::bad_alloc();
    char reason[256] = "";
    if (!mod->decode_rgba(bytes, len, w, h, tb.rgba.get(), reason, sizeof reason)) {
        rto__scene_warn(s, "image %d ('%.80s'): cannot decode: %.100s; material %zu is untextured", i,
                        label.c_str(), reason, material);
        return -1;
    }
    texture_bytes += need;
    tb.name = label;
    tb.width = w;
    tb.height = h;
    textures.push_back(std::move(tb));
    return int32_t(textures.size() - 1);
}

// The texture of glTF image i: decoded once, however many textures name it; identical embedded bytes and the
// same external file are decoded once too.
int32_t Loader::image_texture(int i, size_t material)
{
    auto it = image_of.find(i);
    if (it != image_of.end())
        return it->second;
    const tinygltf::Image &img = g.images[size_t(i)];
    const bool external = img.bufferView < 0 && !img.uri.empty() && !tinygltf::IsDataURI(img.uri);
    const std::string label = !img.name.empty() ? img.name : external ? img.uri : "image " + std::to_string(i);
    int32_t r = -1;
    if (external) {
        const std::string path = ctx.resolve("image " + std::to_string(i), img.uri);
        ctx.images.push_back(path);
        InFile f(path, "image " + std::to_string(i) + " ('" + path.substr(0, 200) + "')", true);
        if (!f.is_open()) {
            rto__scene_warn(s, "image %d ('%.80s'): cannot open %.100s: %s; material %zu is untextured", i,
                            label.c_str(), path.c_str(), f.error().c_str(), material);
        } else if (auto known = by_file.find(f.identity()); known != by_file.end()) {
            r = known->second;
        } else {
            // Encoded bytes are held only while the image decodes, and never more than the budget.
            if (f.size() > ctx.opts.texture_budget_bytes)
                refuse(RTO_ERR_UNSUPPORTED, "image %d ('%.200s'): the file is %llu bytes, more than the texture "
                       "budget of %s (raise it with --texture-budget MB)", i, path.c_str(),
                       (unsigned long long)f.size(), bytes_text(ctx.opts.texture_budget_bytes).c_str());
            const std::vector<unsigned char> bytes = f.read(f.size());
            r = decode_image(i, label, bytes.data(), bytes.size(), material);
            by_file[f.identity()] = r;
        }
    } else {
        const unsigned char *bytes = img.image.data();
        size_t len = img.image.size();
        if (img.bufferView >= 0) {
            const tinygltf::BufferView *bv =
                size_t(img.bufferView) < g.bufferViews.size() ? &g.bufferViews[size_t(img.bufferView)] : nullptr;
            len = bv ? bv->byteLength : 0;
            bytes = view_range(g, img.bufferView, 0, 1, 1, len, "image " + std::to_string(i));
        }
        if (!len) {
            rto__scene_warn(s, "image %d ('%.80s'): missing or empty; material %zu is untextured", i,
                            label.c_str(), material);
        } else {
            const std::string_view key(reinterpret_cast<const char *>(bytes), len);
            auto known = by_bytes.find(key);
            if (known != by_bytes.end()) {
                r = known->second;
            } else {
                r = decode_image(i, label, bytes, len, material);
                by_bytes[key] = r;
            }
        }
    }
    image_of[i] = r;
    return r;
}

int32_t Loader::texture_index(size_t material, int tex)
{
    if (tex < 0)
        return -1;
    if (size_t(tex) >= g.textures.size())
        refuse(RTO_ERR_PARSE, "material %zu: baseColorTexture.index %d out of range (%zu textures)", material, tex,
               g.textures.size());
    auto it = texture_of.find(tex);
    if (it != texture_of.end())
        return it->second;
    int32_t result = -1;
    const tinygltf::Texture &t = g.textures[size_t(tex)];
    if (t.source < 0)
        rto__scene_warn(s, "texture %d has no image source (an extension's?); material %zu is untextured", tex,
                        material);
    else if (size_t(t.source) < g.images.size())
        result = image_texture(t.source, material);
    // (a source out of range was warned about by load_materials, which checks every texture)
    texture_of[tex] = result;
    return result;
}

void Loader::load_materials()
{
    // A dangling image reference is a warning even on a texture no material uses (CornellBox's textures[0]).
    for (size_t t = 0; t < g.textures.size(); t++)
        if (g.textures[t].source >= 0 && size_t(g.textures[t].source) >= g.images.size())
            rto__scene_warn(s, "texture %zu ('%.60s') names image %d, but the file has %zu images", t,
                            g.textures[t].name.c_str(), g.textures[t].source, g.images.size());
    for (size_t i = 0; i < g.materials.size(); i++) {
        const tinygltf::Material &m = g.materials[i];
        const auto &bc = m.pbrMetallicRoughness.baseColorFactor;
        if (bc.size() != 4 || m.emissiveFactor.size() != 3)
            refuse(RTO_ERR_PARSE, "material %zu: baseColorFactor needs 4 and emissiveFactor 3 numbers", i);
        rto_material r;
        memset(&r, 0, sizeof r);
        for (int c = 0; c < 4; c++)
            r.base_color[c] = float(bc[size_t(c)]);
        for (int c = 0; c < 3; c++)
            r.emissive[c] = float(m.emissiveFactor[size_t(c)]);
        r.base_color_texture = texture_index(i, m.pbrMetallicRoughness.baseColorTexture.index);
        materials.push_back(r);
    }
}

// The BLAS of (mesh m, primitive p): built on first use.
// "node 3 ('arm'), mesh 1 ('hand')": where a BLAS or an instance comes from, for messages.
std::string Loader::node_mesh(size_t n, int m) const
{
    char buf[200];
    snprintf(buf, sizeof buf, "node %zu ('%.60s'), mesh %d ('%.60s')", n, g.nodes[n].name.c_str(), m,
             g.meshes[size_t(m)].name.c_str());
    return buf;
}

// The BLAS of (mesh m, primitive p): built on first use, by node n (named in messages).
uint32_t Loader::blas(size_t n, int m, int p)
{
    auto key = std::make_pair(m, p);
    auto it = blas_of.find(key);
    if (it != blas_of.end())
        return it->second;
    const tinygltf::Mesh &mesh = g.meshes[size_t(m)];
    const tinygltf::Primitive &prim = mesh.primitives[size_t(p)];
    const std::string where = "mesh " + std::to_string(m) + " primitive " + std::to_string(p);
    MeshBuf mb;
    mb.name = mesh.name.empty() ? "mesh" + std::to_string(m) : mesh.name;
    if (mesh.primitives.size() > 1)
        mb.name += "/" + std::to_string(p);
    auto pos = prim.attributes.find("POSITION");
    if (pos == prim.attributes.end())
        refuse(RTO_ERR_PARSE, "%s: no POSITION attribute", where.c_str());
    // The limits on the scene's totals hold before a BLAS is allocated. Each BLAS holds its own copy of the
    // vertices it names, so a small file whose primitives all name one large accessor could otherwise make the
    // loader hold it many times over: the meshes may take at most kMaxAmplification times the bytes of the file
    // and its buffers (or kMinMeshBytes).
    const uint64_t nv_declared = plan_accessor(g, pos->second, "POSITION of " + where).acc->count;
    if (total_vertices + nv_declared > RTO_SCENE_MAX_VERTICES)
        refuse(RTO_ERR_UNSUPPORTED, "%s: the meshes would hold more than %u vertices", where.c_str(),
               RTO_SCENE_MAX_VERTICES);
    {
        const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        const uint64_t nidx =
            prim.indices >= 0 ? plan_accessor(g, prim.indices, "indices of " + where).acc->count : nv_declared;
        const uint64_t tris = mode == TINYGLTF_MODE_TRIANGLES ? nidx / 3 : nidx >= 3 ? nidx - 2 : 0;
        const uint64_t per_vertex = 12 + (prim.attributes.count("NORMAL") ? 12 : 0) +
                                    (prim.attributes.count("TEXCOORD_0") ? 8 : 0);
        const uint64_t need = nv_declared * per_vertex + 12 * tris;
        const uint64_t limit = std::max(kMinMeshBytes, kMaxAmplification * ctx.input_bytes);
        if (mesh_bytes + need > limit)
            refuse(RTO_ERR_UNSUPPORTED, "%s: the meshes would take %llu bytes, more than %llu times the %llu "
                   "bytes of the file and its buffers (each BLAS holds its own copy of the vertices it names)",
                   where.c_str(), (unsigned long long)(mesh_bytes + need),
                   (unsigned long long)kMaxAmplification, (unsigned long long)ctx.input_bytes);
    }
    mb.positions = read_floats(g, pos->second, 3, false, "POSITION of " + where);
    const size_t nv = mb.positions.size() / 3;
    for (size_t i = 0; i < mb.positions.size(); i++)
        if (!std::isfinite(mb.positions[i]))
            refuse(RTO_ERR_PARSE, "accessor %d (POSITION of %s): vertex %zu is not finite (%g)", pos->second,
                   where.c_str(), i / 3, double(mb.positions[i]));
    for (size_t i = 0; i < mb.positions.size(); i++)
        if (!(std::fabs(mb.positions[i]) <= RTO_SCENE_MAX_COORD))
            refuse(RTO_ERR_UNSUPPORTED, "%s primitive %d: vertex %zu has coordinate %g, beyond +-%g (box "
                   "centroids would overflow binary32)", node_mesh(n, m).c_str(), p, i / 3,
                   double(mb.positions[i]), double(RTO_SCENE_MAX_COORD));
    auto nrm = prim.attributes.find("NORMAL");
    if (nrm != prim.attributes.end()) {
        mb.normals = read_floats(g, nrm->second, 3, false, "NORMAL of " + where);
        if (mb.normals.size() != mb.positions.size())
            refuse(RTO_ERR_PARSE, "accessor %d (NORMAL of %s): %zu elements, POSITION has %zu", nrm->second,
                   where.c_str(), mb.normals.size() / 3, nv);
    }
    auto uv = prim.attributes.find("TEXCOORD_0");
    if (uv != prim.attributes.end()) {
        mb.uvs = read_floats(g, uv->second, 2, true, "TEXCOORD_0 of " + where);
        if (mb.uvs.size() / 2 != nv)
            refuse(RTO_ERR_PARSE, "accessor %d (TEXCOORD_0 of %s): %zu elements, POSITION has %zu", uv->second,
                   where.c_str(), mb.uvs.size() / 2, nv);
    }
    if (!prim.targets.empty() && !warned_targets) {
        warned_targets = true;
        rto__scene_warn(s, "%s: morph targets are ignored (base geometry only)", where.c_str());
    }
    std::vector<uint32_t> v;
    if (prim.indices >= 0) {
        v = read_indices(g, prim.indices, "indices of " + where);
        for (size_t i = 0; i < v.size(); i++)
            if (v[i] >= nv)
                refuse(RTO_ERR_PARSE, "accessor %d (indices of %s): index %u at element %zu is out of range "
                       "(%zu vertices)", prim.indices, where.c_str(), v[i], i, nv);
    } else {
        v.resize(nv);
        for (size_t i = 0; i < nv; i++)
            v[i] = uint32_t(i);
    }
    const size_t nidx = v.size();
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    const size_t tris = mode == TINYGLTF_MODE_TRIANGLES ? nidx / 3 : nidx >= 3 ? nidx - 2 : 0;
    if (total_triangles + tris > RTO_SCENE_MAX_TRIANGLES)
        refuse(RTO_ERR_UNSUPPORTED, "%s: the meshes would hold more than %u triangles", where.c_str(),
               RTO_SCENE_MAX_TRIANGLES);
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (nidx % 3)
            rto__scene_warn(s, "%s: %zu vertices in a triangle list; the last %zu are ignored", where.c_str(),
                            nidx, nidx % 3);
        mb.indices.assign(v.begin(), v.begin() + std::ptrdiff_t(nidx / 3 * 3));
    } else if (nidx >= 3) {
        // glTF 2.0 §3.7.2.1: strip p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2-i%2)}}; fan p_i = {v_{i+1}, v_{i+2}, v_0}.
        mb.indices.reserve(3 * (nidx - 2));
        for (size_t i = 0; i + 2 < nidx; i++) {
            if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
                mb.indices.insert(mb.indices.end(), {v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]});
            } else {
                mb.indices.insert(mb.indices.end(), {v[i + 1], v[i + 2], v[0]});
            }
        }
    }
    if (mb.indices.empty())
        rto__scene_warn(s, "%s: no triangles (an empty BLAS)", where.c_str());
    if (prim.material >= 0 && size_t(prim.material) >= g.materials.size())
        refuse(RTO_ERR_PARSE, "%s: material %d out of range (%zu materials)", where.c_str(), prim.material,
               g.materials.size());
    mb.material = prim.material;
    if (meshes.size() >= RTO_SCENE_MAX_MESHES)
        refuse(RTO_ERR_UNSUPPORTED, "more than %u BLAS", RTO_SCENE_MAX_MESHES);
    rto_mesh view;
    memset(&view, 0, sizeof view);
    view.positions = mb.positions.data();
    view.vertex_count = uint32_t(nv);
    view.indices = mb.indices.data();
    view.triangle_count = uint32_t(mb.indices.size() / 3);
    mb.box = rto_mesh_aabb(&view);
    total_vertices += nv;
    mesh_bytes += 4 * (mb.positions.size() + mb.normals.size() + mb.uvs.size() + mb.indices.size());
    total_triangles += mb.indices.size() / 3;
    const uint32_t id = uint32_t(meshes.size());
    meshes.push_back(std::move(mb));
    blas_of[key] = id;
    return id;
}

} // namespace rto_gltf
