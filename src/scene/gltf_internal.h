// The glTF loader's private header (C++ only, never installed): what its three files share. gltf.cpp reads the
// files, runs the schema pass and tinygltf's parse and holds the C entry point (gltf.h); gltf_nodes.cpp walks the node
// graph (transforms, instances, cameras) and hands the result to the C scene; gltf_mesh.cpp reads accessors and
// builds each primitive's BLAS, the materials and their textures. What one file alone uses stays in that file's
// anonymous namespace; the rest is in namespace rto_gltf, hidden like gltf.h's declarations (the shared library
// exports only rto_* symbols: src/rtoracle.map).
#ifndef RTO_GLTF_INTERNAL_H
#define RTO_GLTF_INTERNAL_H

#ifndef __cplusplus
#error "gltf_internal.h is the C++ glTF shim's own header"
#endif

// tinygltf's declarations, with the options its code is compiled with: gltf.cpp alone defines TINYGLTF_IMPLEMENTATION
// before including this header. The options shape the TinyGLTF class, so every file sees the same ones.
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

extern "C" {
#include "internal.h"
}
#include "model.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

namespace rto_gltf {

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

// A refusal: thrown anywhere in the loader, caught once in rto__gltf_load.
struct Refusal {
    rto_status status;
    std::string text;
};

[[noreturn]] void refuse(rto_status s, const char *fmt, ...) RTO_PRINTF(2, 3);

// A file the loader reads. open() itself blocks on a FIFO until a writer comes, so the file is opened with
// O_NONBLOCK, and anything fstat does not call a regular file (a FIFO, a directory, /dev/zero) is refused before a
// byte is read; its size is known before anything is allocated for it. `what` names the file in messages ("" for the
// scene file, whose path the caller puts in front of every message). With `optional`, a file that cannot be opened
// is not a refusal: is_open() says so and error() why (a missing texture costs a warning, not the scene).
class InFile {
  public:
    InFile(const std::string &path, const std::string &what, bool optional = false);
    InFile(const InFile &) = delete;
    InFile &operator=(const InFile &) = delete;
    ~InFile();
    bool is_open() const { return fd_ >= 0; }
    const std::string &error() const { return error_; }
    uint64_t size() const { return size_; }
    std::pair<uint64_t, uint64_t> identity() const { return {uint64_t(dev_), uint64_t(ino_)}; }

    // The first n bytes (n <= size()): a file that shrinks meanwhile is an I/O error; nothing past n is read.
    std::vector<unsigned char> read(uint64_t n);

  private:
    int fd_ = -1;
    uint64_t size_ = 0;
    dev_t dev_ = 0;
    ino_t ino_ = 0;
    std::string what_, error_;

    std::string prefix() const { return what_.empty() ? std::string() : what_ + ": "; }
    [[noreturn]] void fail(rto_status s, const std::string &why);
};

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
    std::string resolve(const std::string &what, const std::string &uri) const; // gltf.cpp
};

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

// ---------------------------------------------------------------------------------------------------------------
// Scene assembly

struct Mat {
    double m[3][4];
};

struct MeshBuf {
    std::string name;
    std::vector<float> positions, normals, uvs;
    std::vector<uint32_t> indices;
    int32_t material = -1;
    rto_aabb box{}; // object-space bounds (rto_mesh_aabb), for the instances' world bounds
};

// One load's scene, assembled from the parsed model; its members are defined in gltf_nodes.cpp (the node graph,
// transforms, cameras and the hand-over to the C scene) and gltf_mesh.cpp (BLAS, materials and textures).
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

    // gltf_nodes.cpp
    Mat local_transform(size_t n) const;
    void add_camera(size_t n, const Mat &w);
    void visit(size_t n, const Mat &w);
    void load_nodes();
    template <typename T> static T *c_array(const std::vector<T> &v);
    void emit();

    // gltf_mesh.cpp
    int32_t decode_image(int i, const std::string &label, const unsigned char *bytes, size_t len, size_t material);
    int32_t image_texture(int i, size_t material);
    int32_t texture_index(size_t material, int tex);
    void load_materials();
    std::string node_mesh(size_t n, int m) const;
    uint32_t blas(size_t n, int m, int p);
};

} // namespace rto_gltf

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
