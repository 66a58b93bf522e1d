// The glTF 2.0 loader: a thin C++17 shim over tinygltf (parsing) and the image module of image_module.h (base-colour
// textures) behind the C entry point of gltf.h. Every exception stops here and becomes a status plus a one-line
// message.
//
// The loader is split by concern, sharing declarations through gltf_internal.h: this file holds the entry point,
// the files it reads (InFile), the schema pass and tinygltf's parse; gltf_nodes.cpp the node graph, transforms,
// instances and cameras, and the hand-over to the C scene; gltf_mesh.cpp accessors, primitives (one BLAS each),
// materials and textures.
//
// tinygltf is compiled into this translation unit (TINYGLTF_IMPLEMENTATION) rather than linked from Debian's
// libtinygltf.so: that library decodes images with stb_image, and building it here lets it be compiled with
// TINYGLTF_NO_STB_IMAGE (so stb is neither linked nor reachable) and instrumented by the sanitizer and fuzzing
// builds. An image loader callback keeps embedded images' encoded bytes; the image module decodes the ones that
// materials use, straight into the scene's texture buffer.
//
// tinygltf parses leniently: a property of the wrong JSON type is silently ignored. A schema pass over the raw JSON
// (nlohmann, which tinygltf itself uses) runs first, so a file that violates the glTF 2.0 core schema is refused
// with the JSON path of the offending value; after parsing, every index, range and size this loader relies on is
// checked again here, so tinygltf's own checks are never trusted for memory safety.
//
// Files: tinygltf never opens one itself. The scene file is read here; external buffers are read by the schema pass
// (regular files only, opened without blocking, size checked against byteLength with fstat before a byte is read,
// and only byteLength bytes read) and handed to tinygltf through its FsCallbacks; external images are not loaded by
// tinygltf at all (TINYGLTF_NO_EXTERNAL_IMAGE) but read here, only when a material uses them. URIs resolve against
// the glTF file's directory only. With rto_scene_load_desc.embedded_only no file but the scene file is opened.
//
// Decisions (see also rto_scene_load in rtoracle.h):
//  - Scene: the glTF `scene`, else scene 0; with no scenes at all, the root nodes (nodes no node lists as a child) in
//    index order. A `scene` index that names no scene is refused (TestNoRootNode/NoScene.gltf); a scene without
//    nodes is an empty, valid scene (TestNoRootNode/SceneWithoutNodes.gltf).
//  - Node graph: every child index in range, no node with two parents, no cycle, a scene root that is nobody's child,
//    depth at most kMaxDepth; traversal uses an explicit stack, never recursion.
//  - One BLAS per (glTF mesh, triangle primitive), in first-use order of the depth-first pre-order traversal; one
//    instance per (node, primitive). customIndex = node index & 0xFFFFFF, mask 0xFF, sbtOffset 0, flags 0. A
//    primitive without triangles is an empty BLAS (with a warning).
//  - Modes 4 (triangles), 5 (strip) and 6 (fan) become triangle lists by the glTF 2.0 spec's formulas (§3.7.2.1);
//    points and lines (0-3) are skipped with a warning. Trailing indices of a list that is not a multiple of 3 are
//    dropped with a warning.
//  - Sparse accessors are supported (base values, or zeros without a bufferView, then the substitutions). Every
//    accessor's range is checked before anything sized by its count is allocated.
//  - Required extensions are refused by name (none is supported); optional ones are ignored.
//  - Morph targets and skins are ignored with a warning: meshes are placed by their node transforms.
//  - Textures: PNG and JPEG (the formats glTF 2.0 allows). Width and height come from the image header, and the
//    scene's texture budget is checked before a pixel is decoded; an image is decoded once however many textures
//    name it (and once for identical embedded bytes or the same external file). An image that cannot be decoded
//    costs its material the texture, with a warning.
//  - glTF 1.0 (by asset.version, its GLB container version, or its shape) is refused as such.
#define TINYGLTF_IMPLEMENTATION // here only; the options (TINYGLTF_NO_*) are gltf_internal.h's
#include "gltf_internal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "gltf.h"

namespace rto_gltf {

[[noreturn]] void refuse(rto_status s, const char *fmt, ...)
{
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    throw Refusal{s, buf};
}

namespace {

using json = nlohmann::json;

// First non-empty line of a (possibly multi-line) message, trimmed.
std::string first_line(const std::string &text)
{
    size_t at = 0;
    while (at < text.size()) {
        size_t end = text.find('\n', at);
        if (end == std::string::npos)
            end = text.size();
        std::string line = text.substr(at, end - at);
        while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
            line.pop_back();
        size_t lead = line.find_first_not_of(" \t");
        if (lead != std::string::npos)
            return line.substr(lead);
        at = end + 1;
    }
    return std::string();
}

// What a path that is not a regular file is, for the message.
const char *file_kind(mode_t m)
{
    if (S_ISDIR(m))
        return "a directory";
    if (S_ISFIFO(m))
        return "a FIFO";
    if (S_ISCHR(m))
        return "a character device";
    if (S_ISBLK(m))
        return "a block device";
    if (S_ISSOCK(m))
        return "a socket";
    return "not a plain file";
}

} // namespace

InFile::InFile(const std::string &path, const std::string &what, bool optional) : what_(what)
{
    fd_ = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) {
        error_ = strerror(errno);
        if (!optional)
            refuse(RTO_ERR_IO, "%scannot open: %s", prefix().c_str(), error_.c_str());
        return;
    }
    struct stat st;
    if (fstat(fd_, &st) != 0) {
        const int e = errno;
        fail(RTO_ERR_IO, "cannot stat: " + std::string(strerror(e)));
    }
    if (!S_ISREG(st.st_mode))
        fail(RTO_ERR_IO, std::string("not a regular file (") + file_kind(st.st_mode) + ")");
    size_ = st.st_size < 0 ? 0 : uint64_t(st.st_size);
    dev_ = st.st_dev;
    ino_ = st.st_ino;
}

InFile::~InFile()
{
    if (fd_ >= 0)
        close(fd_);
}

std::vector<unsigned char> InFile::read(uint64_t n)
{
    if (n > size_ || n > uint64_t(std::numeric_limits<size_t>::max()))
        fail(RTO_ERR_IO, "asked for more bytes than the file holds");
    std::vector<unsigned char> data(static_cast<size_t>(n));
    size_t at = 0;
    while (at < data.size()) {
        const ssize_t got = ::read(fd_, data.data() + at, std::min(data.size() - at, size_t(1) << 30));
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0)
            fail(RTO_ERR_IO, "read error: " + std::string(strerror(errno)));
        if (got == 0)
            fail(RTO_ERR_IO, "the file shrank while it was read");
        at += size_t(got);
    }
    return data;
}

void InFile::fail(rto_status s, const std::string &why)
{
    close(fd_); // the destructor does not run for a constructor that throws
    fd_ = -1;
    refuse(s, "%s%s", prefix().c_str(), why.c_str());
}

namespace {

std::vector<unsigned char> read_scene_file(const std::string &path)
{
    InFile f(path, "");
    if (f.size() > kMaxFileBytes)
        refuse(RTO_ERR_UNSUPPORTED, "file of %llu bytes (at most 4 GiB - 1 are supported)",
               (unsigned long long)f.size());
    return f.read(f.size());
}

uint32_t le32(const unsigned char *p)
{
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

bool is_glb(const std::vector<unsigned char> &bytes)
{
    return bytes.size() >= 4 && memcmp(bytes.data(), "glTF", 4) == 0;
}

// The JSON chunk of a GLB container (glTF 2.0 §4.4), bounds-checked; tinygltf re-checks the whole container.
std::string glb_json(const std::vector<unsigned char> &b)
{
    if (b.size() < 20)
        refuse(RTO_ERR_PARSE, "GLB shorter than its 20-byte header");
    if (le32(&b[4]) == 1)
        refuse(RTO_ERR_UNSUPPORTED, "glTF 1.0 is not supported (a binary glTF 1.0 container)");
    if (le32(&b[4]) != 2)
        refuse(RTO_ERR_UNSUPPORTED, "GLB container version %u (only 2 is supported)", le32(&b[4]));
    uint64_t len = le32(&b[12]);
    if (le32(&b[16]) != 0x4E4F534Au)
        refuse(RTO_ERR_PARSE, "GLB: the first chunk is not JSON");
    if (20 + len > b.size())
        refuse(RTO_ERR_PARSE, "GLB: the JSON chunk (%llu bytes) runs past the end of the file",
               (unsigned long long)len);
    return std::string(reinterpret_cast<const char *>(&b[20]), size_t(len));
}

// ---------------------------------------------------------------------------------------------------------------
// Schema pass: the JSON types of the glTF 2.0 core properties (glTF 2.0 §5, the JSON schema). Unknown properties
// are allowed; "extras" may hold anything; "extensions" must be an object of objects.

enum Kind { UINT, SIZE, NUM, STR, BOOL, OBJ, ARR_OBJ, ARR_UINT, ARR_NUM, ARR_STR, MAP_UINT, ARR_MAP_UINT };

struct Prop {
    const char *name;
    Kind kind;
    const char *type; // object type for OBJ / ARR_OBJ
};

struct Type {
    const char *name;
    std::vector<Prop> props;
};

const std::vector<Type> &schema()
{
    static const std::vector<Type> types = {
        {"root",
         {{"asset", OBJ, "asset"},
          {"scene", UINT, nullptr},
          {"scenes", ARR_OBJ, "scene"},
          {"nodes", ARR_OBJ, "node"},
          {"meshes", ARR_OBJ, "mesh"},
          {"accessors", ARR_OBJ, "accessor"},
          {"bufferViews", ARR_OBJ, "bufferView"},
          {"buffers", ARR_OBJ, "buffer"},
          {"materials", ARR_OBJ, "material"},
          {"textures", ARR_OBJ, "texture"},
          {"images", ARR_OBJ, "image"},
          {"samplers", ARR_OBJ, "sampler"},
          {"cameras", ARR_OBJ, "camera"},
          {"skins", ARR_OBJ, "skin"},
          {"animations", ARR_OBJ, "animation"},
          {"extensionsUsed", ARR_STR, nullptr},
          {"extensionsRequired", ARR_STR, nullptr}}},
        {"asset", {{"version", STR, nullptr}, {"minVersion", STR, nullptr}, {"generator", STR, nullptr},
                   {"copyright", STR, nullptr}}},
        {"scene", {{"nodes", ARR_UINT, nullptr}, {"name", STR, nullptr}}},
        {"node",
         {{"children", ARR_UINT, nullptr},
          {"mesh", UINT, nullptr},
          {"camera", UINT, nullptr},
          {"skin", UINT, nullptr},
          {"matrix", ARR_NUM, nullptr},
          {"rotation", ARR_NUM, nullptr},
          {"scale", ARR_NUM, nullptr},
          {"translation", ARR_NUM, nullptr},
          {"weights", ARR_NUM, nullptr},
          {"name", STR, nullptr}}},
        {"mesh", {{"primitives", ARR_OBJ, "primitive"}, {"weights", ARR_NUM, nullptr}, {"name", STR, nullptr}}},
        {"primitive",
         {{"attributes", MAP_UINT, nullptr},
          {"indices", UINT, nullptr},
          {"material", UINT, nullptr},
          {"mode", UINT, nullptr},
          {"targets", ARR_MAP_UINT, nullptr}}},
        {"accessor",
         {{"bufferView", UINT, nullptr},
          {"byteOffset", SIZE, nullptr},
          {"componentType", UINT, nullptr},
          {"normalized", BOOL, nullptr},
          {"count", SIZE, nullptr},
          {"type", STR, nullptr},
          {"max", ARR_NUM, nullptr},
          {"min", ARR_NUM, nullptr},
          {"sparse", OBJ, "sparse"},
          {"name", STR, nullptr}}},
        {"sparse", {{"count", UINT, nullptr}, {"indices", OBJ, "sparseIndices"}, {"values", OBJ, "sparseValues"}}},
        {"sparseIndices",
         {{"bufferView", UINT, nullptr}, {"byteOffset", UINT, nullptr}, {"componentType", UINT, nullptr}}},
        {"sparseValues", {{"bufferView", UINT, nullptr}, {"byteOffset", UINT, nullptr}}},
        {"bufferView",
         {{"buffer", UINT, nullptr},
          {"byteOffset", SIZE, nullptr},
          {"byteLength", SIZE, nullptr},
          {"byteStride", UINT, nullptr},
          {"target", UINT, nullptr},
          {"name", STR, nullptr}}},
        {"buffer", {{"uri", STR, nullptr}, {"byteLength", SIZE, nullptr}, {"name", STR, nullptr}}},
        {"material",
         {{"name", STR, nullptr},
          {"pbrMetallicRoughness", OBJ, "pbr"},
          {"normalTexture", OBJ, "normalTextureInfo"},
          {"occlusionTexture", OBJ, "occlusionTextureInfo"},
          {"emissiveTexture", OBJ, "textureInfo"},
          {"emissiveFactor", ARR_NUM, nullptr},
          {"alphaMode", STR, nullptr},
          {"alphaCutoff", NUM, nullptr},
          {"doubleSided", BOOL, nullptr}}},
        {"pbr",
         {{"baseColorFactor", ARR_NUM, nullptr},
          {"baseColorTexture", OBJ, "textureInfo"},
          {"metallicFactor", NUM, nullptr},
          {"roughnessFactor", NUM, nullptr},
          {"metallicRoughnessTexture", OBJ, "textureInfo"}}},
        {"textureInfo", {{"index", UINT, nullptr}, {"texCoord", UINT, nullptr}}},
        {"normalTextureInfo", {{"index", UINT, nullptr}, {"texCoord", UINT, nullptr}, {"scale", NUM, nullptr}}},
        {"occlusionTextureInfo", {{"index", UINT, nullptr}, {"texCoord", UINT, nullptr}, {"strength", NUM, nullptr}}},
        {"texture", {{"sampler", UINT, nullptr}, {"source", UINT, nullptr}, {"name", STR, nullptr}}},
        {"image", {{"uri", STR, nullptr}, {"mimeType", STR, nullptr}, {"bufferView", UINT, nullptr},
                   {"name", STR, nullptr}}},
        {"sampler", {{"magFilter", UINT, nullptr}, {"minFilter", UINT, nullptr}, {"wrapS", UINT, nullptr},
                     {"wrapT", UINT, nullptr}, {"name", STR, nullptr}}},
        {"camera", {{"orthographic", OBJ, "orthographic"}, {"perspective", OBJ, "perspective"}, {"type", STR, nullptr},
                    {"name", STR, nullptr}}},
        {"orthographic", {{"xmag", NUM, nullptr}, {"ymag", NUM, nullptr}, {"zfar", NUM, nullptr},
                          {"znear", NUM, nullptr}}},
        {"perspective", {{"aspectRatio", NUM, nullptr}, {"yfov", NUM, nullptr}, {"zfar", NUM, nullptr},
                         {"znear", NUM, nullptr}}},
        {"skin", {{"inverseBindMatrices", UINT, nullptr}, {"skeleton", UINT, nullptr}, {"joints", ARR_UINT, nullptr},
                  {"name", STR, nullptr}}},
        {"animation", {{"channels", ARR_OBJ, "channel"}, {"samplers", ARR_OBJ, "animationSampler"},
                       {"name", STR, nullptr}}},
        {"channel", {{"sampler", UINT, nullptr}, {"target", OBJ, "channelTarget"}}},
        {"channelTarget", {{"node", UINT, nullptr}, {"path", STR, nullptr}}},
        {"animationSampler", {{"input", UINT, nullptr}, {"interpolation", STR, nullptr}, {"output", UINT, nullptr}}},
    };
    return types;
}

const Type &type_named(const char *name)
{
    for (const Type &t : schema())
        if (!strcmp(t.name, name))
            return t;
    throw std::logic_error(std::string("schema type ") + name);
}

const char *json_kind(const json &v)
{
    if (v.is_null())
        return "null";
    if (v.is_boolean())
        return "a boolean";
    if (v.is_number_integer())
        return v.is_number_unsigned() || v.get<int64_t>() >= 0 ? "an integer" : "a negative integer";
    if (v.is_number())
        return "a non-integer number";
    if (v.is_string())
        return "a string";
    if (v.is_array())
        return "an array";
    return "an object";
}

// Indices are stored as int by tinygltf, byte sizes as size_t: keep both exactly representable.
bool is_uint(const json &v, uint64_t max)
{
    if (v.is_number_unsigned())
        return v.get<uint64_t>() <= max;
    return v.is_number_integer() && v.get<int64_t>() >= 0 && uint64_t(v.get<int64_t>()) <= max;
}

void schema_fail(const std::string &where, const char *expected, const json &v)
{
    refuse(RTO_ERR_PARSE, "schema: %s must be %s, not %s", where.c_str(), expected, json_kind(v));
}

void check_object(const json &o, const Type &t, const std::string &where);

void check_value(const json &v, const Prop &p, const std::string &where)
{
    const uint64_t int_max = uint64_t(std::numeric_limits<int32_t>::max());
    switch (p.kind) {
    case UINT:
        if (!is_uint(v, int_max))
            schema_fail(where, "a non-negative integer below 2^31", v);
        break;
    case SIZE:
        if (!is_uint(v, uint64_t(1) << 53))
            schema_fail(where, "a non-negative integer", v);
        break;
    case NUM:
        if (!v.is_number())
            schema_fail(where, "a number", v);
        break;
    case STR:
        if (!v.is_string())
            schema_fail(where, "a string", v);
        break;
    case BOOL:
        if (!v.is_boolean())
            schema_fail(where, "a boolean", v);
        break;
    case OBJ:
        if (!v.is_object())
            schema_fail(where, "an object", v);
        check_object(v, type_named(p.type), where);
        break;
    case ARR_OBJ:
    case ARR_UINT:
    case ARR_NUM:
    case ARR_STR:
    case ARR_MAP_UINT:
        if (!v.is_array())
            schema_fail(where, "an array", v);
        for (size_t i = 0; i < v.size(); i++) {
            const json &e = v[i];
            const std::string at = where + "[" + std::to_string(i) + "]";
            if (p.kind == ARR_OBJ) {
                if (!e.is_object())
                    schema_fail(at, "an object", e);
                check_object(e, type_named(p.type), at);
            } else if (p.kind == ARR_UINT) {
                if (!is_uint(e, int_max))
                    schema_fail(at, "a non-negative integer below 2^31", e);
            } else if (p.kind == ARR_NUM) {
                if (!e.is_number())
                    schema_fail(at, "a number", e);
            } else if (p.kind == ARR_STR) {
                if (!e.is_string())
                    schema_fail(at, "a string", e);
            } else {
                check_value(e, Prop{p.name, MAP_UINT, nullptr}, at);
            }
        }
        break;
    case MAP_UINT:
        if (!v.is_object())
            schema_fail(where, "an object", v);
        for (auto it = v.begin(); it != v.end(); ++it)
            if (!is_uint(it.value(), int_max))
                schema_fail(where + "." + it.key(), "a non-negative integer below 2^31", it.value());
        break;
    }
}

void check_object(const json &o, const Type &t, const std::string &where)
{
    for (const Prop &p : t.props) {
        auto it = o.find(p.name);
        if (it != o.end())
            check_value(*it, p, where.empty() ? p.name : where + "." + p.name);
    }
    auto ext = o.find("extensions");
    if (ext != o.end()) {
        const std::string at = where.empty() ? "extensions" : where + ".extensions";
        if (!ext->is_object())
            schema_fail(at, "an object", *ext);
        for (auto it = ext->begin(); it != ext->end(); ++it)
            if (!it.value().is_object())
                schema_fail(at + "." + it.key(), "an object", it.value());
    }
}

// Deepest nesting of a JSON value, without recursion.
size_t json_depth(const json &root)
{
    std::vector<std::pair<const json *, size_t>> stack{{&root, 1}};
    size_t deepest = 0;
    while (!stack.empty()) {
        auto [v, d] = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, d);
        if (d > kMaxJsonDepth)
            return d;
        if (v->is_structured())
            for (const json &c : *v)
                stack.push_back({&c, d + 1});
    }
    return deepest;
}

// glTF 1.0 is a different format (dictionaries where 2.0 has arrays, a string `scene`, shaders and techniques), not
// a malformed 2.0 file: say so rather than report its first difference from the 2.0 schema. By asset.version (a
// string or, as some 1.0 exporters wrote it, a number), else, when no 2.x version is given, by its shape.
bool is_gltf1(const json &doc)
{
    auto asset = doc.find("asset");
    if (asset != doc.end() && asset->is_object()) {
        auto v = asset->find("version");
        if (v != asset->end() && v->is_string()) {
            const std::string s = v->get<std::string>();
            if (s.rfind("2.", 0) == 0)
                return false;
            if (s == "1" || s.rfind("1.", 0) == 0)
                return true;
        } else if (v != asset->end() && v->is_number()) {
            const double d = v->get<double>();
            if (d >= 1.0 && d < 2.0)
                return true;
        }
    }
    auto scene = doc.find("scene");
    if (scene != doc.end() && scene->is_string())
        return true;
    for (const char *k : {"programs", "shaders", "techniques"})
        if (doc.contains(k))
            return true;
    for (const char *k : {"accessors", "animations", "bufferViews", "buffers", "cameras", "images", "materials",
                          "meshes", "nodes", "samplers", "scenes", "skins", "textures"}) {
        auto it = doc.find(k);
        if (it != doc.end() && it->is_object())
            return true;
    }
    return false;
}

} // namespace

// Context::resolve (gltf_internal.h) is defined here, beside the tinygltf code it calls (urldecode and JoinPath
// belong to tinygltf's implementation).
std::string Context::resolve(const std::string &what, const std::string &uri) const
{
    const std::string name = tinygltf::dlib::urldecode(uri);
    if (name.find('\0') != std::string::npos)
        refuse(RTO_ERR_PARSE, "%s: URI '%.200s' decodes to a name with a NUL byte", what.c_str(), uri.c_str());
    return tinygltf::JoinPath(base_dir, name);
}

namespace {

// External buffer files: regular files only, each at least its byteLength long (checked with fstat before reading),
// and only byteLength bytes read, once per file.
void read_buffers(const json &doc, Context &ctx)
{
    const json &buffers = doc.value("buffers", json::array());
    for (size_t i = 0; i < buffers.size(); i++) {
        const json &b = buffers[i];
        if (!b.contains("uri") || !b.contains("byteLength"))
            continue; // the GLB binary chunk, or refused by tinygltf
        const std::string uri = b["uri"].get<std::string>();
        if (uri.empty() || tinygltf::IsDataURI(uri))
            continue;
        if (ctx.opts.embedded_only)
            refuse(RTO_ERR_UNSUPPORTED, "buffer %zu: external URI '%.100s' refused (embedded-only load)", i,
                   uri.c_str());
        const uint64_t want = b["byteLength"].get<uint64_t>();
        const std::string path = ctx.resolve("buffer " + std::to_string(i), uri);
        Context::Pending &p = ctx.files[path];
        if (p.uses == 0) {
            InFile f(path, "buffer " + std::to_string(i) + " ('" + path.substr(0, 200) + "')");
            if (f.size() < want)
                refuse(RTO_ERR_PARSE, "buffer %zu ('%.200s'): the file holds %llu bytes, less than the byteLength %llu "
                       "it declares", i, path.c_str(), (unsigned long long)f.size(), (unsigned long long)want);
            p.bytes = f.read(want);
            ctx.input_bytes += want;
        } else if (p.bytes.size() != want) {
            refuse(RTO_ERR_PARSE, "buffer %zu ('%.200s'): byteLength %llu, but an earlier buffer names the same file "
                   "with byteLength %zu", i, path.c_str(), (unsigned long long)want, p.bytes.size());
        }
        p.uses++;
    }
}

// Everything that must hold before tinygltf sees the document.
void prepass(const std::string &text, Context &ctx)
{
    json doc;
    try {
        doc = json::parse(text);
    } catch (const json::parse_error &e) {
        refuse(RTO_ERR_PARSE, "invalid JSON: %s", e.what());
    }
    if (!doc.is_object())
        refuse(RTO_ERR_PARSE, "schema: the document must be a JSON object, not %s", json_kind(doc));
    if (json_depth(doc) > kMaxJsonDepth)
        refuse(RTO_ERR_UNSUPPORTED, "JSON nested deeper than %zu levels", kMaxJsonDepth);
    if (is_gltf1(doc))
        refuse(RTO_ERR_UNSUPPORTED, "glTF 1.0 is not supported");
    auto asset = doc.find("asset");
    if (asset == doc.end() || !asset->is_object() || !asset->contains("version"))
        refuse(RTO_ERR_PARSE, "schema: asset.version is required");
    check_object(doc, type_named("root"), "");
    const std::string version = (*asset)["version"].get<std::string>();
    if (version.rfind("2.", 0) != 0)
        refuse(RTO_ERR_UNSUPPORTED, "glTF version '%.40s' (only 2.x is supported)", version.c_str());
    if (asset->contains("minVersion") && (*asset)["minVersion"].get<std::string>() != "2.0")
        refuse(RTO_ERR_UNSUPPORTED, "glTF minVersion '%.40s' (only 2.0 is supported)",
               (*asset)["minVersion"].get<std::string>().c_str());
    // No extension is implemented; an optional one can be ignored, a required one changes what the data means.
    if (doc.contains("extensionsRequired"))
        for (const json &e : doc["extensionsRequired"])
            refuse(RTO_ERR_UNSUPPORTED, "the file requires extension %.100s, which this loader does not support",
                   e.get<std::string>().c_str());
    // tinygltf hands an image's bufferView bytes to the image callback with only an index check: its range must
    // lie inside the declared buffer, which tinygltf loads at exactly its byteLength.
    if (doc.contains("images")) {
        const json &views = doc.value("bufferViews", json::array()), &buffers = doc.value("buffers", json::array());
        for (size_t i = 0; i < doc["images"].size(); i++) {
            const json &img = doc["images"][i];
            if (ctx.opts.embedded_only && img.contains("uri") && !tinygltf::IsDataURI(img["uri"].get<std::string>()))
                refuse(RTO_ERR_UNSUPPORTED, "image %zu: external URI '%.100s' refused (embedded-only load)", i,
                       img["uri"].get<std::string>().c_str());
            if (!img.contains("bufferView"))
                continue;
            size_t v = img["bufferView"].get<size_t>();
            if (v >= views.size())
                refuse(RTO_ERR_PARSE, "image %zu: bufferView %zu out of range (%zu bufferViews)", i, v, views.size());
            const json &bv = views[v];
            size_t b = bv.value("buffer", size_t(0)), off = bv.value("byteOffset", size_t(0)),
                   len = bv.value("byteLength", size_t(0));
            if (b >= buffers.size() || !buffers[b].contains("byteLength") ||
                off + len > buffers[b]["byteLength"].get<size_t>())
                refuse(RTO_ERR_PARSE, "image %zu: bufferView %zu lies outside its buffer", i, v);
        }
    }
    read_buffers(doc, ctx);
}

// tinygltf's file access, all of it through here: a file "exists" only if the schema pass read it, so tinygltf opens
// nothing itself (no second search in the working directory, no ~ or $VAR expansion of URIs, no writes).
bool fs_exists(const std::string &path, void *user)
{
    return static_cast<Context *>(user)->files.count(path) != 0;
}

std::string fs_expand(const std::string &path, void *) { return path; }

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *user)
{
    auto &files = static_cast<Context *>(user)->files;
    auto it = files.find(path);
    if (it == files.end() || it->second.uses == 0) {
        if (err)
            *err = "not read by the loader";
        return false;
    }
    if (--it->second.uses == 0)
        out->swap(it->second.bytes);
    else
        *out = it->second.bytes;
    return true;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    if (err)
        *err = "the loader writes no files";
    return false;
}

// tinygltf image callback: keep a data: URI image's encoded bytes (tinygltf frees its own copy); a bufferView
// image's bytes stay in the buffer and are read from there, so they are not held twice. Decoding waits until a
// material needs the image.
bool keep_encoded(tinygltf::Image *image, const int, std::string *, std::string *, int, int, const unsigned char *bytes,
                  int size, void *)
{
    image->image.clear();
    if (image->bufferView < 0 && bytes && size > 0)
        image->image.assign(bytes, bytes + size);
    image->as_is = true;
    return true;
}

void load(const char *path, const rto_scene_load_desc *opts, rto_scene *scene)
{
    const std::string p(path);
    const std::vector<unsigned char> bytes = read_scene_file(p);
    const bool binary = is_glb(bytes);
    Context ctx;
    ctx.opts = *opts;
    ctx.input_bytes = bytes.size();
    const size_t slash = p.find_last_of('/');
    ctx.base_dir = slash == std::string::npos ? std::string() : p.substr(0, slash);
    prepass(binary ? glb_json(bytes) : std::string(bytes.begin(), bytes.end()), ctx);

    tinygltf::TinyGLTF parser;
    parser.SetImageLoader(keep_encoded, nullptr);
    parser.SetStoreOriginalJSONForExtrasAndExtensions(false);
    tinygltf::FsCallbacks fs = {fs_exists, fs_expand, fs_read, fs_write, &ctx};
    parser.SetFsCallbacks(fs);
    tinygltf::Model model;
    std::string err, warn;
    const auto size = static_cast<unsigned int>(bytes.size());
    const bool ok = binary ? parser.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), size, ctx.base_dir)
                           : parser.LoadASCIIFromString(&model, &err, &warn,
                                                        reinterpret_cast<const char *>(bytes.data()), size,
                                                        ctx.base_dir);
    if (!ok) {
        std::string why = first_line(err);
        refuse(RTO_ERR_PARSE, "tinygltf: %s", why.empty() ? "failed without a reason" : why.c_str());
    }
    for (size_t at = 0; at < warn.size();) {
        size_t end = warn.find('\n', at);
        if (end == std::string::npos)
            end = warn.size();
        std::string line = first_line(warn.substr(at, end - at));
        if (!line.empty())
            rto__scene_warn(scene, "tinygltf: %.200s", line.c_str());
        at = end + 1;
    }
    Loader l(model, scene, ctx);
    l.load_materials();
    l.load_nodes();
    l.emit();
    // What was read, for up-to-date checks: the scene file, the buffers (tinygltf reads no other), the images.
    bool listed = rto__scene_add_source(scene, path) != 0;
    for (const auto &f : ctx.files)
        listed = listed && rto__scene_add_source(scene, f.first.c_str());
    for (const auto &img : ctx.images)
        listed = listed && rto__scene_add_source(scene, img.c_str());
    if (!listed)
        throw std::bad_alloc();
}

} // namespace

} // namespace rto_gltf

extern "C" rto_status rto__gltf_load(const char *path, const rto_scene_load_desc *opts, rto_scene *scene,
                                     rto_msg *msg)
{
    if (!path || !opts || !scene)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path, options or scene");
    // Messages do not name the file: rto_scene_load_ex puts the path in front of every failure, once.
    try {
        rto_gltf::load(path, opts, scene);
        return RTO_OK;
    } catch (const rto_gltf::Refusal &r) {
        return rto__fail(msg, r.status, "%s", r.text.c_str());
    } catch (const std::bad_alloc &) {
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    } catch (const std::exception &e) {
        return rto__fail(msg, RTO_ERR_PARSE, "%s", rto_gltf::first_line(e.what()).c_str());
    } catch (...) {
        return rto__fail(msg, RTO_ERR_PARSE, "unknown C++ exception");
    }
}
