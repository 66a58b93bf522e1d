// The glTF 2.0 loader: a thin C++17 shim over tinygltf (parsing) and the image module of image_module.h (base-colour
// textures) behind the C entry point of gltf.h. Every exception stops here and becomes a status plus a one-line
// message.
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
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

extern "C" {
#include "internal.h"
}
#include "gltf.h"
#include "image_module.h"
#include "model.h"

namespace {

using json = nlohmann::json;

constexpr size_t kMaxDepth = 1024;          // node hierarchy levels
constexpr size_t kMaxJsonDepth = 128;       // nesting of the JSON document (tinygltf converts extras recursively)
constexpr uint64_t kMaxFileBytes = 0xFFFFFFFFull; // tinygltf takes the GLB size as unsigned int
constexpr uint64_t kMaxAccessorCount = uint64_t(1) << 28;
// Elements of an accessor without a bufferView: zeros that no byte of the file backs, so their count amplifies a
// small file into a large allocation unless it is bounded on its own.
constexpr uint64_t kMaxZeroAccessorCount = uint64_t(1) << 20;
// Mesh memory (positions, normals, texture coordinates, indices of every BLAS) may be this many times the bytes of
// the scene file and its buffers, and at least kMinMeshBytes (see Loader::blas).
constexpr uint64_t kMaxAmplification = 256;
constexpr uint64_t kMinMeshBytes = uint64_t(256) << 20;

// A refusal: thrown anywhere below, caught once in rto__gltf_load.
struct Refusal {
    rto_status status;
    std::string text;
};

[[noreturn]] void refuse(rto_status s, const char *fmt, ...) RTO_PRINTF(2, 3);
[[noreturn]] void refuse(rto_status s, const char *fmt, ...)
{
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    throw Refusal{s, buf};
}

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

// A file the loader reads. open() itself blocks on a FIFO until a writer comes, so the file is opened with
// O_NONBLOCK, and anything fstat does not call a regular file (a FIFO, a directory, /dev/zero) is refused before a
// byte is read; its size is known before anything is allocated for it. `what` names the file in messages ("" for the
// scene file, whose path the caller puts in front of every message). With `optional`, a file that cannot be opened
// is not a refusal: is_open() says so and error() why (a missing texture costs a warning, not the scene).
class InFile {
  public:
    InFile(const std::string &path, const std::string &what, bool optional = false) : what_(what)
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
    InFile(const InFile &) = delete;
    InFile &operator=(const InFile &) = delete;
    ~InFile()
    {
        if (fd_ >= 0)
            close(fd_);
    }
    bool is_open() const { return fd_ >= 0; }
    const std::string &error() const { return error_; }
    uint64_t size() const { return size_; }
    std::pair<uint64_t, uint64_t> identity() const { return {uint64_t(dev_), uint64_t(ino_)}; }

    // The first n bytes (n <= size()): a file that shrinks meanwhile is an I/O error; nothing past n is read.
    std::vector<unsigned char> read(uint64_t n)
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

  private:
    int fd_ = -1;
    uint64_t size_ = 0;
    dev_t dev_ = 0;
    ino_t ino_ = 0;
    std::string what_, error_;

    std::string prefix() const { return what_.empty() ? std::string() : what_ + ": "; }
    [[noreturn]] void fail(rto_status s, const std::string &why)
    {
        close(fd_); // the destructor does not run for a constructor that throws
        fd_ = -1;
        refuse(s, "%s%s", prefix().c_str(), why.c_str());
    }
};

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

// One load: the options, where relative URIs resolve, and the external buffer files read by the schema pass, keyed
// by the path tinygltf will ask its FsCallbacks for.
struct Context {
    rto_scene_load_desc opts{};
    std::string base_dir;
    struct Pending {
        std::vector<unsigned char> bytes;
        size_t uses = 0; // buffers still to hand it to; the last one takes the bytes without a copy
    };
    std::map<std::string, Pending> files;
    mutable std::vector<std::string> images; // external image files opened (or tried), in order
    uint64_t input_bytes = 0; // the scene file and the external buffers read: what mesh memory is measured against

    // The path of an external URI, exactly as tinygltf forms it (percent-decoded, joined to the base directory). A
    // URI whose decoded name holds a NUL byte ("%00") names no file, and would cut every message quoting it short:
    // refused with the URI as written.
    std::string resolve(const std::string &what, const std::string &uri) const
    {
        const std::string name = tinygltf::dlib::urldecode(uri);
        if (name.find('\0') != std::string::npos)
            refuse(RTO_ERR_PARSE, "%s: URI '%.200s' decodes to a name with a NUL byte", what.c_str(), uri.c_str());
        return tinygltf::JoinPath(base_dir, name);
    }
};

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

struct FreeDeleter {
    void operator()(void *p) const { free(p); }
};

// A decoded texture: its pixels sit in the malloc'd block the scene will own, decoded there directly.
struct TexBuf {
    std::string name;
    uint32_t width = 0, height = 0;
    std::unique_ptr<uint8_t, FreeDeleter> rgba;
};

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

// "256 MiB" for whole mebibytes, else the exact byte count (budgets in tests are small).
std::string bytes_text(uint64_t n)
{
    if (n && n % (uint64_t(1) << 20) == 0)
        return std::to_string(n >> 20) + " MiB";
    return std::to_string(n) + " bytes";
}

// ---------------------------------------------------------------------------------------------------------------
// Scene assembly

struct Mat {
    double m[3][4];
};

Mat identity()
{
    return Mat{{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
}

Mat mul(const Mat &a, const Mat &b)
{
    Mat r;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++)
            r.m[i][j] = (a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j]) + a.m[i][2] * b.m[2][j];
        r.m[i][3] += a.m[i][3];
    }
    return r;
}

struct MeshBuf {
    std::string name;
    std::vector<float> positions, normals, uvs;
    std::vector<uint32_t> indices;
    int32_t material = -1;
    rto_aabb box{}; // object-space bounds (rto_mesh_aabb), for the instances' world bounds
};

struct Loader {
    const tinygltf::Model &g;
    rto_scene *s;
    std::vector<MeshBuf> meshes;
    std::map<std::pair<int, int>, uint32_t> blas_of; // (glTF mesh, primitive) -> BLAS, assigned in first-use order
    std::vector<rto_instance> instances;
    std::vector<rto_camera> cameras;
    std::vector<rto_material> materials;
    std::vector<TexBuf> textures;
    std::map<int, int32_t> texture_of;  // glTF texture -> rto texture (-1: none)
    std::map<int, int32_t> image_of;    // glTF image -> rto texture (-1: could not be decoded)
    std::unordered_map<std::string_view, int32_t> by_bytes;         // embedded encoded bytes -> rto texture
    std::map<std::pair<uint64_t, uint64_t>, int32_t> by_file;       // external file (device, inode) -> rto texture
    uint64_t texture_bytes = 0;                                     // decoded so far, against the budget
    uint64_t total_vertices = 0, total_triangles = 0;               // over the BLAS built so far, against the limits
    uint64_t mesh_bytes = 0;                                        // their arrays' bytes, against amplification
    bool warned_skin = false, warned_targets = false;
    const Context &ctx;

    Loader(const tinygltf::Model &model, rto_scene *scene, const Context &context) : g(model), s(scene), ctx(context)
    {
    }

    Mat local_transform(size_t n) const
    {
        const tinygltf::Node &node = g.nodes[n];
        if (!node.matrix.empty()) {
            if (node.matrix.size() != 16)
                refuse(RTO_ERR_PARSE, "node %zu: matrix has %zu elements, not 16", n, node.matrix.size());
            const double *c = node.matrix.data(); // column-major 4x4
            if (std::fabs(c[3]) > 1e-6 || std::fabs(c[7]) > 1e-6 || std::fabs(c[11]) > 1e-6 ||
                std::fabs(c[15] - 1.0) > 1e-6)
                refuse(RTO_ERR_PARSE, "node %zu: matrix is not affine (last row %g %g %g %g)", n, c[3], c[7], c[11],
                       c[15]);
            Mat m;
            for (int r = 0; r < 3; r++)
                for (int k = 0; k < 4; k++)
                    m.m[r][k] = c[k * 4 + r];
            return m;
        }
        const auto &t = node.translation, &q = node.rotation, &sc = node.scale;
        if ((!t.empty() && t.size() != 3) || (!q.empty() && q.size() != 4) || (!sc.empty() && sc.size() != 3))
            refuse(RTO_ERR_PARSE, "node %zu: translation / rotation / scale of the wrong length", n);
        double x = 0, y = 0, z = 0, w = 1;
        if (!q.empty()) {
            // Unit quaternion (x, y, z, w) per the spec; normalised here so that writers' rounding does not scale.
            const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            if (!(len > 0) || !std::isfinite(len))
                refuse(RTO_ERR_PARSE, "node %zu: rotation quaternion of length %g", n, len);
            x = q[0] / len, y = q[1] / len, z = q[2] / len, w = q[3] / len;
        }
        const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                                {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                                {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
        const double S[3] = {sc.empty() ? 1.0 : sc[0], sc.empty() ? 1.0 : sc[1], sc.empty() ? 1.0 : sc[2]};
        Mat m; // T * R * S
        for (int r = 0; r < 3; r++) {
            for (int k = 0; k < 3; k++)
                m.m[r][k] = R[r][k] * S[k];
            m.m[r][3] = t.empty() ? 0.0 : t[size_t(r)];
        }
        return m;
    }

    // Decodes one image's encoded bytes into a new texture, straight into the block the scene will own, after its
    // header has shown that it fits the texture budget. -1 (with a warning) if it cannot be decoded; a refusal if it
    // does not fit.
    int32_t decode_image(int i, const std::string &label, const unsigned char *bytes, size_t len, size_t material)
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
    int32_t image_texture(int i, size_t material)
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

    int32_t texture_index(size_t material, int tex)
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

    void load_materials()
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
    std::string node_mesh(size_t n, int m) const
    {
        char buf[200];
        snprintf(buf, sizeof buf, "node %zu ('%.60s'), mesh %d ('%.60s')", n, g.nodes[n].name.c_str(), m,
                 g.meshes[size_t(m)].name.c_str());
        return buf;
    }

    // The BLAS of (mesh m, primitive p): built on first use, by node n (named in messages).
    uint32_t blas(size_t n, int m, int p)
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

    void add_camera(size_t n, const Mat &w)
    {
        const int c = g.nodes[n].camera;
        if (c < 0 || size_t(c) >= g.cameras.size())
            refuse(RTO_ERR_PARSE, "node %zu: camera %d out of range (%zu cameras)", n, c, g.cameras.size());
        const tinygltf::Camera &cam = g.cameras[size_t(c)];
        if (cam.type != "perspective") {
            rto__scene_warn(s, "camera %d ('%.60s', node %zu): %.20s cameras are not supported, skipped", c,
                            cam.name.c_str(), n, cam.type.c_str());
            return;
        }
        // glTF cameras look down their node's -Z with +Y up (§3.10.1).
        double dir[3] = {-w.m[0][2], -w.m[1][2], -w.m[2][2]}, up[3] = {w.m[0][1], w.m[1][1], w.m[2][1]};
        const double dl = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        const double ul = std::sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
        const auto &p = cam.perspective;
        if (!(dl > 0) || !(ul > 0) || !std::isfinite(dl) || !std::isfinite(ul) || !(p.yfov > 0) ||
            !std::isfinite(p.yfov) || !(p.aspectRatio >= 0) || !(p.znear >= 0) || !(p.zfar >= 0)) {
            rto__scene_warn(s, "camera %d (node %zu): degenerate pose or parameters, skipped", c, n);
            return;
        }
        rto_camera r;
        memset(&r, 0, sizeof r);
        std::string name = cam.name;
        if (name.empty())
            name = !g.nodes[n].name.empty() ? g.nodes[n].name : "camera" + std::to_string(c);
        rto__utf8_copy(r.name, sizeof r.name, name.data(), name.size());
        // The axes are normalised so the target sits one unit ahead whatever the node's scale (Duck's is 0.01).
        r.position = rto_vec3{float(w.m[0][3]), float(w.m[1][3]), float(w.m[2][3])};
        r.target = rto_vec3{float(w.m[0][3] + dir[0] / dl), float(w.m[1][3] + dir[1] / dl),
                            float(w.m[2][3] + dir[2] / dl)};
        r.up = rto_vec3{float(up[0] / ul), float(up[1] / ul), float(up[2] / ul)};
        r.fov_y = float(p.yfov);
        r.aspect = float(p.aspectRatio);
        r.znear = float(p.znear);
        r.zfar = float(p.zfar);
        const float all[13] = {r.position.x, r.position.y, r.position.z, r.target.x, r.target.y, r.target.z, r.up.x,
                               r.up.y,       r.up.z,       r.fov_y,      r.aspect,   r.znear,    r.zfar};
        for (float v : all)
            if (!std::isfinite(v)) {
                rto__scene_warn(s, "camera %d (node %zu): parameters overflow binary32, skipped", c, n);
                return;
            }
        cameras.push_back(r);
    }

    void visit(size_t n, const Mat &w)
    {
        const tinygltf::Node &node = g.nodes[n];
        if (node.camera >= 0)
            add_camera(n, w);
        if (node.skin >= 0 && !warned_skin) {
            warned_skin = true;
            rto__scene_warn(s, "node %zu: skins are ignored; skinned meshes are placed by their node transform", n);
        }
        if (node.mesh < 0)
            return;
        if (size_t(node.mesh) >= g.meshes.size())
            refuse(RTO_ERR_PARSE, "node %zu: mesh %d out of range (%zu meshes)", n, node.mesh, g.meshes.size());
        const tinygltf::Mesh &mesh = g.meshes[size_t(node.mesh)];
        for (size_t p = 0; p < mesh.primitives.size(); p++) {
            const int mode = mesh.primitives[p].mode < 0 ? TINYGLTF_MODE_TRIANGLES : mesh.primitives[p].mode;
            if (mode < TINYGLTF_MODE_TRIANGLES) {
                static const char *names[] = {"points", "lines", "line loop", "line strip"};
                rto__scene_warn(s, "mesh %d primitive %zu (node %zu): %s skipped (triangles only)", node.mesh, p, n,
                                names[mode]);
                continue;
            }
            if (mode > TINYGLTF_MODE_TRIANGLE_FAN)
                refuse(RTO_ERR_PARSE, "mesh %d primitive %zu: invalid mode %d", node.mesh, p, mode);
            rto_instance in;
            memset(&in, 0, sizeof in);
            rto_msg m = {{0}};
            if (rto_instance_set_transform(&in, w.m, &m))
                refuse(RTO_ERR_PARSE, "node %zu: %s", n, m.text);
            in.blas = blas(n, node.mesh, int(p));
            // What the build computes from this instance (DESIGN.md §3: centroids and their span) must stay finite.
            const rto_aabb wb = rto_aabb_transform(&in.obj_to_world, &meshes[in.blas].box);
            if (!rto__aabb_in_range(&wb))
                refuse(RTO_ERR_UNSUPPORTED, "%s: world bounds (%g, %g, %g) .. (%g, %g, %g) reach beyond +-%g (box "
                       "centroids would overflow binary32)", node_mesh(n, node.mesh).c_str(), double(wb.min.x),
                       double(wb.min.y), double(wb.min.z), double(wb.max.x), double(wb.max.y), double(wb.max.z),
                       double(RTO_SCENE_MAX_COORD));
            in.custom_index = uint32_t(n) & RTO_INSTANCE_CUSTOM_INDEX_MASK;
            in.mask = 0xFFu;
            if (instances.size() >= RTO_SCENE_MAX_INSTANCES)
                refuse(RTO_ERR_UNSUPPORTED, "more than %u instances", RTO_SCENE_MAX_INSTANCES);
            instances.push_back(in);
        }
    }

    void load_nodes()
    {
        const size_t count = g.nodes.size();
        std::vector<int> parent(count, -1);
        for (size_t i = 0; i < count; i++)
            for (int c : g.nodes[i].children) {
                if (c < 0 || size_t(c) >= count)
                    refuse(RTO_ERR_PARSE, "node %zu: child %d out of range (%zu nodes)", i, c, count);
                if (size_t(c) == i)
                    refuse(RTO_ERR_PARSE, "node %zu lists itself as a child", i);
                if (parent[size_t(c)] >= 0)
                    refuse(RTO_ERR_PARSE, "node %d has two parents (nodes %d and %zu)", c, parent[size_t(c)], i);
                parent[size_t(c)] = int(i);
            }
        // With one parent per node, a cycle is a parent chain that comes back to itself. Walk each chain once
        // (0 = unseen, 1 = on the current chain, 2 = reaches a root), which also gives every node's depth.
        std::vector<uint8_t> state(count, 0);
        std::vector<size_t> depth(count, 0), chain;
        for (size_t i = 0; i < count; i++) {
            size_t at = i;
            chain.clear();
            while (state[at] == 0) {
                state[at] = 1;
                chain.push_back(at);
                if (parent[at] < 0)
                    break;
                at = size_t(parent[at]);
            }
            if (state[at] == 1 && parent[at] >= 0)
                refuse(RTO_ERR_PARSE, "the node hierarchy has a cycle through node %zu", at);
            for (size_t k = chain.size(); k-- > 0;) {
                const size_t nd = chain[k];
                depth[nd] = parent[nd] < 0 ? 0 : depth[size_t(parent[nd])] + 1;
                if (depth[nd] > kMaxDepth)
                    refuse(RTO_ERR_UNSUPPORTED, "node %zu is %zu levels deep (at most %zu are supported)", nd,
                           depth[nd], kMaxDepth);
                state[nd] = 2;
            }
        }
        std::vector<int> roots;
        if (g.defaultScene >= 0 || !g.scenes.empty()) {
            const size_t sc = g.defaultScene >= 0 ? size_t(g.defaultScene) : 0;
            if (sc >= g.scenes.size())
                refuse(RTO_ERR_PARSE, "the default scene %zu does not exist (the file has %zu scenes)", sc,
                       g.scenes.size());
            roots = g.scenes[sc].nodes;
            std::vector<uint8_t> listed(count, 0);
            for (int r : roots) {
                if (r < 0 || size_t(r) >= count)
                    refuse(RTO_ERR_PARSE, "scene %zu: node %d out of range (%zu nodes)", sc, r, count);
                if (parent[size_t(r)] >= 0)
                    refuse(RTO_ERR_PARSE, "scene %zu: root node %d is also a child of node %d", sc, r,
                           parent[size_t(r)]);
                if (listed[size_t(r)]++)
                    refuse(RTO_ERR_PARSE, "scene %zu lists node %d twice", sc, r);
            }
        } else {
            for (size_t i = 0; i < count; i++)
                if (parent[i] < 0)
                    roots.push_back(int(i));
        }
        // Depth-first pre-order: roots in scene order, children in listed order.
        std::vector<std::pair<size_t, Mat>> stack;
        for (size_t k = roots.size(); k-- > 0;)
            stack.emplace_back(size_t(roots[k]), identity());
        while (!stack.empty()) {
            auto [n, parent_world] = stack.back();
            stack.pop_back();
            const Mat w = mul(parent_world, local_transform(n));
            visit(n, w);
            const auto &ch = g.nodes[n].children;
            for (size_t k = ch.size(); k-- > 0;)
                stack.emplace_back(size_t(ch[k]), w);
        }
    }

    template <typename T> static T *c_array(const std::vector<T> &v)
    {
        T *p = static_cast<T *>(rto__alloc(v.size(), sizeof(T)));
        if (!p)
            throw std::bad_alloc();
        if (!v.empty())
            memcpy(p, v.data(), v.size() * sizeof(T));
        return p;
    }

    // Moves everything into the C scene; counts follow the arrays, so rto_scene_destroy frees a partial copy.
    void emit()
    {
        uint64_t tris = 0;
        for (const MeshBuf &m : meshes)
            tris += m.indices.size() / 3;
        if (tris > RTO_SCENE_MAX_TRIANGLES)
            refuse(RTO_ERR_UNSUPPORTED, "%llu triangles in the meshes (at most %u are supported)",
                   (unsigned long long)tris, RTO_SCENE_MAX_TRIANGLES);
        s->meshes = static_cast<rto_mesh *>(calloc(meshes.size() ? meshes.size() : 1, sizeof(rto_mesh)));
        if (!s->meshes)
            throw std::bad_alloc();
        for (MeshBuf &mb : meshes) {
            rto_mesh &m = s->meshes[s->mesh_count++];
            rto__utf8_copy(m.name, sizeof m.name, mb.name.data(), mb.name.size());
            m.material = mb.material;
            m.positions = c_array(mb.positions);
            if (!mb.normals.empty())
                m.normals = c_array(mb.normals);
            if (!mb.uvs.empty())
                m.uvs = c_array(mb.uvs);
            m.indices = c_array(mb.indices);
            m.vertex_count = uint32_t(mb.positions.size() / 3);
            m.triangle_count = uint32_t(mb.indices.size() / 3);
            mb = MeshBuf(); // each copy replaces its original at once: the meshes are never held twice in full
        }
        s->instances = c_array(instances);
        s->instance_count = uint32_t(instances.size());
        s->materials = c_array(materials);
        s->material_count = uint32_t(materials.size());
        s->cameras = c_array(cameras);
        s->camera_count = uint32_t(cameras.size());
        s->textures = static_cast<rto_texture *>(calloc(textures.size() ? textures.size() : 1, sizeof(rto_texture)));
        if (!s->textures)
            throw std::bad_alloc();
        for (TexBuf &tb : textures) {
            rto_texture &t = s->textures[s->texture_count++];
            rto__utf8_copy(t.name, sizeof t.name, tb.name.data(), tb.name.size());
            t.rgba = tb.rgba.release(); // decoded in place: handed over, not copied
            t.width = tb.width;
            t.height = tb.height;
        }
    }
};

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

extern "C" rto_status rto__gltf_load(const char *path, const rto_scene_load_desc *opts, rto_scene *scene,
                                     rto_msg *msg)
{
    if (!path || !opts || !scene)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path, options or scene");
    // Messages do not name the file: rto_scene_load_ex puts the path in front of every failure, once.
    try {
        load(path, opts, scene);
        return RTO_OK;
    } catch (const Refusal &r) {
        return rto__fail(msg, r.status, "%s", r.text.c_str());
    } catch (const std::bad_alloc &) {
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    } catch (const std::exception &e) {
        return rto__fail(msg, RTO_ERR_PARSE, "%s", first_line(e.what()).c_str());
    } catch (...) {
        return rto__fail(msg, RTO_ERR_PARSE, "unknown C++ exception");
    }
}
