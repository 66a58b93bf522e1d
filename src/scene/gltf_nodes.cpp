// The glTF loader's scene graph (gltf.cpp describes the loader and its decisions): the node hierarchy checked and
// walked without recursion from the scene's roots, each node's local transform (matrix or TRS) composed into its
// world transform, an instance per (node, triangle primitive), the perspective cameras, and the hand-over of
// everything assembled into the C scene.
#include "gltf_internal.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace rto_gltf {
namespace {

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

} // namespace

Mat Loader::local_transform(size_t n) const
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

void Loader::add_camera(size_t n, const Mat &w)
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

void Loader::visit(size_t n, const Mat &w)
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

void Loader::load_nodes()
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

template <typename T> T *Loader::c_array(const std::vector<T> &v)
{
    T *p = static_cast<T *>(rto__alloc(v.size(), sizeof(T)));
    if (!p)
        throw std::bad_alloc();
    if (!v.empty())
        memcpy(p, v.data(), v.size() * sizeof(T));
    return p;
}

// Moves everything into the C scene; counts follow the arrays, so rto_scene_destroy frees a partial copy.
void Loader::emit()
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

} // namespace rto_gltf
