/* Scenes (DESIGN.md §5), part of unit.scene (main() in test_scene.c): hand-made glTF files for each accessor / node /
 * primitive rule, malformed files, truncation and byte-flip sweeps of a GLB, and hostile inputs (non-regular files,
 * buffer sizes, accessor amplification, bounds overflow, names, glTF 1.0). The glTF file writers and the memory cap
 * here serve test_scene_textures.c too. */
#include "test_scene.h"

#include <math.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hand-made glTF files                                                                                             */

char *base64(const unsigned char *b, size_t n)
{
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = malloc(4 * (n / 3 + 1) + 1), *p = o;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)b[i] << 16 | (i + 1 < n ? (uint32_t)b[i + 1] << 8 : 0) | (i + 2 < n ? b[i + 2] : 0);
        *p++ = tab[v >> 18 & 63];
        *p++ = tab[v >> 12 & 63];
        *p++ = i + 1 < n ? tab[v >> 6 & 63] : '=';
        *p++ = i + 2 < n ? tab[v & 63] : '=';
    }
    *p = '\0';
    return o;
}

/* Writes tmp/NAME: asset 2.0, one buffer holding bin as a data URI, then BODY (more top-level properties). Returns
 * the path in a static buffer. */
const char *gltf_file(const char *name, const void *bin, size_t binlen, const char *body)
{
    static char path[512];
    char *b64 = base64(bin, binlen);
    size_t cap = strlen(b64) + strlen(body) + 256;
    char *text = malloc(cap);
    snprintf(text, cap,
             "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": %zu, \"uri\": "
             "\"data:application/octet-stream;base64,%s\"}]%s%s}",
             binlen, b64, *body ? ", " : "", body);
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    write_bytes(path, text, strlen(text));
    free(text);
    free(b64);
    return path;
}

void test_gltf_nan_position_refused(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *body = TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}], "
                                       "\"nodes\": [{\"mesh\": 0}], \"scenes\": [{\"nodes\": [0]}]";
    rto_scene *s = load_ok(gltf_file("ok.gltf", p, sizeof p, body));
    assert_int_equal(s->instance_count, 1);
    rto_scene_destroy(s);
    p[4] = NAN;
    expect_refusal(gltf_file("nan.gltf", p, sizeof p, body), RTO_ERR_PARSE, "vertex 1 is not finite");
    p[4] = 0;
    p[8] = -INFINITY;
    expect_refusal(gltf_file("inf.gltf", p, sizeof p, body), RTO_ERR_PARSE, "vertex 2 is not finite");
}

/* Interleaved positions + normalized u16 texcoords, u8 indices, a strip, a fan, a short list and lines; TRS and
 * matrix nodes; a camera on a rotated, scaled node. */
void test_gltf_primitives_and_nodes(void **state)
{
    (void)state;
    unsigned char bin[68];
    const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    const uint16_t uv[4][2] = {{0, 0}, {65535, 0}, {0, 32768}, {65535, 65535}};
    for (int v = 0; v < 4; v++) {
        memcpy(bin + 16 * v, pos[v], 12);
        memcpy(bin + 16 * v + 12, uv[v], 4);
    }
    const uint8_t idx[4] = {0, 1, 2, 3};
    memcpy(bin + 64, idx, 4);
    const char *body =
        "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 64, \"byteStride\": 16},"
        " {\"buffer\": 0, \"byteOffset\": 64, \"byteLength\": 4}],"
        "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\"},"
        " {\"bufferView\": 0, \"byteOffset\": 12, \"componentType\": 5123, \"normalized\": true, \"count\": 4,"
        "  \"type\": \"VEC2\"},"
        " {\"bufferView\": 1, \"componentType\": 5121, \"count\": 4, \"type\": \"SCALAR\"}],"
        "\"meshes\": [{\"primitives\": ["
        "  {\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2, \"mode\": 5},"
        "  {\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"mode\": 6},"
        "  {\"attributes\": {\"POSITION\": 0}, \"mode\": 4},"
        "  {\"attributes\": {\"POSITION\": 0}, \"mode\": 1}]}],"
        "\"cameras\": [{\"type\": \"perspective\", \"perspective\": {\"yfov\": 0.5, \"znear\": 0.01}}],"
        "\"nodes\": [{\"mesh\": 0, \"translation\": [1, 2, 3]},"
        " {\"mesh\": 0, \"children\": [2], \"rotation\": [0, 0, 0.7071067811865476, 0.7071067811865476],"
        "  \"scale\": [2, 2, 2]},"
        " {\"camera\": 0, \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1]}],"
        "\"scene\": 0, \"scenes\": [{\"nodes\": [0, 1]}]";
    const char *path = gltf_file("prims.gltf", bin, sizeof bin, body);
    rto_scene *s = load_ok(path);
    check_loaded(path, s);
    assert_int_equal(s->mesh_count, 3);
    assert_int_equal(s->instance_count, 6);
    /* strip p_i = {v_i, v_{i+1+i%2}, v_{i+2-i%2}}; fan p_i = {v_{i+1}, v_{i+2}, v_0} (glTF 2.0 §3.7.2.1) */
    const uint32_t strip[6] = {0, 1, 2, 1, 3, 2}, fan[6] = {1, 2, 0, 2, 3, 0}, list[3] = {0, 1, 2};
    assert_int_equal(s->meshes[0].triangle_count, 2);
    assert_memory_equal(s->meshes[0].indices, strip, sizeof strip);
    assert_memory_equal(s->meshes[1].indices, fan, sizeof fan);
    assert_int_equal(s->meshes[2].triangle_count, 1);
    assert_memory_equal(s->meshes[2].indices, list, sizeof list);
    assert_string_equal(s->meshes[0].name, "mesh0/0");
    assert_non_null(s->meshes[0].uvs);
    assert_null(s->meshes[1].uvs);
    assert_true(s->meshes[0].uvs[2] == 1.0f && s->meshes[0].uvs[5] == 32768.0f / 65535.0f);
    assert_true(s->meshes[0].positions[3] == 1.0f && s->meshes[0].positions[7] == 1.0f);
    assert_true(has_warning(s, "4 vertices in a triangle list; the last 1 are ignored"));
    assert_true(has_warning(s, "lines skipped"));
    /* Instances: node 0's three primitives, then node 1's; the same three BLAS. */
    for (uint32_t i = 0; i < 6; i++) {
        assert_int_equal(s->instances[i].blas, i % 3);
        assert_int_equal(s->instances[i].custom_index, i / 3);
    }
    assert_true(s->instances[0].obj_to_world.m[2][3] == 3.0f && s->instances[0].world_to_obj.m[1][3] == -2.0f);
    /* node 1: R(90 deg about z) * S(2): x -> 2y, y -> -2x */
    const float want[3][4] = {{0, -2, 0, 0}, {2, 0, 0, 0}, {0, 0, 2, 0}};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            assert_true(fabsf(s->instances[3].obj_to_world.m[r][c] - want[r][c]) < 1e-6f);
    /* The camera: node 2 = node 1 * T(10, 0, 0): at (0, 20, 0), looking down world -Z, up = world -X. */
    assert_int_equal(s->camera_count, 1);
    const rto_camera *c = &s->cameras[0];
    assert_true(fabsf(c->position.x) < 1e-5f && fabsf(c->position.y - 20.0f) < 1e-5f && c->position.z == 0.0f);
    assert_true(fabsf(c->target.z + 1.0f) < 1e-6f && fabsf(c->target.y - 20.0f) < 1e-5f);
    assert_true(fabsf(c->up.x + 1.0f) < 1e-6f && fabsf(c->up.y) < 1e-6f);
    assert_true(c->fov_y == 0.5f && c->aspect == 0.0f && c->znear == 0.01f && c->zfar == 0.0f);
    rto_scene_destroy(s);
}

/* No scenes: every node nobody lists as a child is a root, in index order; traversal is depth-first pre-order. */
void test_gltf_no_scene_uses_root_nodes(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *body = TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}], "
                                       "\"nodes\": [{\"mesh\": 0, \"children\": [2]}, {\"mesh\": 0}, {\"mesh\": 0}]";
    const char *path = gltf_file("noscene.gltf", p, sizeof p, body);
    rto_scene *s = load_ok(path);
    check_loaded(path, s);
    assert_int_equal(s->instance_count, 3);
    assert_int_equal(s->instances[0].custom_index, 0);
    assert_int_equal(s->instances[1].custom_index, 2);
    assert_int_equal(s->instances[2].custom_index, 1);
    rto_scene_destroy(s);
}

void test_gltf_sparse_accessors(void **state)
{
    (void)state;
    /* base: 3 vertices; sparse: index 1 -> (5, 5, 5). Second accessor: no bufferView (zeros) + the same sparse. */
    unsigned char bin[36 + 4 + 12];
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, v[3] = {5, 5, 5};
    const uint32_t i1 = 1;
    memcpy(bin, p, 36);
    memcpy(bin + 36, &i1, 4);
    memcpy(bin + 40, v, 12);
    const char *body =
        "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": 4},"
        " {\"buffer\": 0, \"byteOffset\": 40, \"byteLength\": 12}],"
        "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"sparse\":"
        "  {\"count\": 1, \"indices\": {\"bufferView\": 1, \"componentType\": 5125}, \"values\": {\"bufferView\": 2}}},"
        " {\"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"sparse\":"
        "  {\"count\": 1, \"indices\": {\"bufferView\": 1, \"componentType\": 5125},"
        "   \"values\": {\"bufferView\": 2}}}],"
        "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}, {\"attributes\": {\"POSITION\": 1}}]}],"
        "\"nodes\": [{\"mesh\": 0}], \"scenes\": [{\"nodes\": [0]}]";
    rto_scene *s = load_ok(gltf_file("sparse.gltf", bin, sizeof bin, body));
    const float want0[9] = {0, 0, 0, 5, 5, 5, 0, 1, 0}, want1[9] = {0, 0, 0, 5, 5, 5, 0, 0, 0};
    assert_memory_equal(s->meshes[0].positions, want0, sizeof want0);
    assert_memory_equal(s->meshes[1].positions, want1, sizeof want1);
    rto_scene_destroy(s);
    /* sparse index out of range */
    const uint32_t i9 = 9;
    memcpy(bin + 36, &i9, 4);
    expect_refusal(gltf_file("sparse_bad.gltf", bin, sizeof bin, body), RTO_ERR_PARSE, "strictly increasing");
}

void test_gltf_refusals(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *mesh = "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}]";
    static const struct {
        const char *body; /* after the buffer; %s = the mesh above */
        rto_status status;
        const char *substring;
    } cases[] = {
        {"\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, "
         "\"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\"}], %s, \"nodes\": [{\"mesh\": 0}]",
         RTO_ERR_PARSE, "needs bytes 0 .. 48 of bufferView 0, which holds 36"},
        {"\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 40}], \"accessors\": [{\"bufferView\": 0, "
         "\"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}], %s, \"nodes\": [{\"mesh\": 0}]",
         RTO_ERR_PARSE, "runs past buffer 0 (36 bytes)"},
        {"\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36, \"byteStride\": 4}], \"accessors\": [{\"bufferView\": "
         "0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}], %s, \"nodes\": [{\"mesh\": 0}]",
         RTO_ERR_PARSE, "byteStride 4 is smaller than an element"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"children\": [2]}, {\"children\": [2]}, {\"mesh\": 0}]", RTO_ERR_PARSE,
         "node 2 has two parents (nodes 0 and 1)"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"children\": [0]}]", RTO_ERR_PARSE, "node 0 lists itself as a child"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"children\": [5]}]", RTO_ERR_PARSE, "child 5 out of range (1 nodes)"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 3}]", RTO_ERR_PARSE, "mesh 3 out of range"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0}], \"scenes\": [{\"nodes\": [0, 0]}]", RTO_ERR_PARSE,
         "scene 0 lists node 0 twice"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0}], \"scene\": 1, \"scenes\": [{\"nodes\": [0]}]",
         RTO_ERR_PARSE, "default scene 1 does not exist"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"scale\": [1, 0, 1]}]", RTO_ERR_PARSE,
         "node 0: singular transform"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0.5, 0,0,0,1]}]",
         RTO_ERR_PARSE, "node 0: matrix is not affine"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"matrix\": [1,0,0,0]}]", RTO_ERR_PARSE,
         "matrix has 4 elements"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"rotation\": [0, 0, 0, 0]}]", RTO_ERR_PARSE,
         "rotation quaternion of length 0"},
        {"\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, "
         "\"componentType\": 5126, \"count\": 4, \"type\": \"VEC2\"}], %s, \"nodes\": [{\"mesh\": 0}]",
         RTO_ERR_PARSE, "expected VEC3 float, got VEC2 float"},
        {TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"NORMAL\": 0}}]}], \"nodes\": "
         "[{\"mesh\": 0}]%s",
         RTO_ERR_PARSE, "no POSITION attribute"},
        {TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 0}]}], "
         "\"nodes\": [{\"mesh\": 0}]%s",
         RTO_ERR_PARSE, "expected SCALAR unsigned byte / short / int, got VEC3 float"},
        {TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"mode\": 7}]}], "
         "\"nodes\": [{\"mesh\": 0}]%s",
         RTO_ERR_PARSE, "invalid mode 7"},
        {TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"material\": 2}]}], "
         "\"nodes\": [{\"mesh\": 0}]%s",
         RTO_ERR_PARSE, "material 2 out of range (0 materials)"},
        {TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1}}]}], "
         "\"nodes\": [{\"mesh\": 0}]%s",
         RTO_ERR_PARSE, "NORMAL of mesh 0 primitive 0: accessor 1 out of range (1 accessors)"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0}], \"extensionsRequired\": [\"KHR_mesh_quantization\"]",
         RTO_ERR_UNSUPPORTED, "requires extension KHR_mesh_quantization"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"camera\": 0}]", RTO_ERR_PARSE,
         "node 0: camera 0 out of range (0 cameras)"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"children\": \"all\"}]", RTO_ERR_PARSE,
         "schema: nodes[0].children must be an array, not a string"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0}], \"scene\": 4294967296", RTO_ERR_PARSE,
         "schema: scene must be a non-negative integer below 2^31"},
        {TRI_BODY_PREFIX ", %s, \"nodes\": [{\"mesh\": 0, \"extensions\": {\"X\": 1}}]", RTO_ERR_PARSE,
         "nodes[0].extensions.X must be an object"},
    };
    char body[2048];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(body, sizeof body, cases[i].body, strstr(cases[i].body, "\"meshes\"") ? "" : mesh);
        char name[32];
        snprintf(name, sizeof name, "refuse%02zu.gltf", i);
        expect_refusal(gltf_file(name, p, sizeof p, body), cases[i].status, cases[i].substring);
    }
}

void test_gltf_malformed_files(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/nope/missing.gltf", tmp_dir);
    expect_refusal(path, RTO_ERR_IO, "cannot open");
    static const struct {
        const char *text;
        rto_status status;
        const char *substring;
    } cases[] = {
        {"", RTO_ERR_PARSE, "invalid JSON"},
        {"{", RTO_ERR_PARSE, "invalid JSON"},
        {"[1, 2]", RTO_ERR_PARSE, "the document must be a JSON object, not an array"},
        {"{}", RTO_ERR_PARSE, "asset.version is required"},
        {"{\"asset\": {\"version\": \"1.0\"}}", RTO_ERR_UNSUPPORTED, "glTF 1.0 is not supported"},
        {"{\"asset\": {\"version\": \"3.0\"}}", RTO_ERR_UNSUPPORTED, "glTF version '3.0'"},
        {"{\"asset\": {\"version\": \"2.0\", \"minVersion\": \"2.1\"}}", RTO_ERR_UNSUPPORTED, "minVersion '2.1'"},
        {"{\"asset\": {\"version\": 2}}", RTO_ERR_PARSE, "schema: asset.version must be a string"},
        {"glTF\x02", RTO_ERR_PARSE, "GLB shorter than its 20-byte header"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(path, sizeof path, "%s/bad%zu.gltf", tmp_dir, i);
        write_bytes(path, cases[i].text, strlen(cases[i].text));
        expect_refusal(path, cases[i].status, cases[i].substring);
    }
    /* Deep JSON (tinygltf converts extras recursively) and a deep node chain: refused, not a stack overflow. */
    size_t depth = 5000, cap = 2 * depth + 256, at = 0;
    char *deep = malloc(cap);
    at += (size_t)snprintf(deep, cap, "{\"asset\": {\"version\": \"2.0\"}, \"extras\": ");
    for (size_t i = 0; i < depth; i++)
        deep[at++] = '[';
    for (size_t i = 0; i < depth; i++)
        deep[at++] = ']';
    deep[at++] = '}';
    snprintf(path, sizeof path, "%s/deep.gltf", tmp_dir);
    write_bytes(path, deep, at);
    free(deep);
    expect_refusal(path, RTO_ERR_UNSUPPORTED, "JSON nested deeper than 128 levels");

    const size_t chain = 1100;
    char *nodes = malloc(chain * 32 + 64);
    at = (size_t)sprintf(nodes, "\"nodes\": [");
    for (size_t i = 0; i < chain; i++)
        at += (size_t)sprintf(nodes + at, i + 1 < chain ? "{\"children\": [%zu]}, " : "{}]", i + 1);
    float p[9] = {0};
    expect_refusal(gltf_file("chain.gltf", p, sizeof p, nodes), RTO_ERR_UNSUPPORTED, "levels deep");
    free(nodes);
}

/* Every prefix and a sample of single-byte corruptions of a GLB: loaded or refused with one line, never a crash. */
void test_glb_truncation_and_flips(void **state)
{
    (void)state;
    char src[1024], path[512];
    assimp_path(src, sizeof src, "BoxTextured-glTF-Binary/BoxTextured.glb");
    size_t len;
    unsigned char *b = read_all(src, &len);
    snprintf(path, sizeof path, "%s/cut.glb", tmp_dir);
    size_t tried = 0, loaded = 0;
    for (size_t cut = 0; cut < len; cut += cut < 64 || cut > len - 32 ? 1 : 37) {
        write_bytes(path, b, cut);
        rto_msg msg = {{0}};
        rto_scene *s = NULL;
        if (rto_scene_load(path, &s, &msg) == RTO_OK)
            loaded++;
        else
            assert_one_line(&msg);
        rto_scene_destroy(s);
        tried++;
    }
    assert_int_equal(loaded, 0);
    for (size_t at = 0; at < len; at += 5) {
        unsigned char keep = b[at];
        b[at] ^= (unsigned char)(0x5A + at);
        write_bytes(path, b, len);
        b[at] = keep;
        rto_msg msg = {{0}};
        rto_scene *s = NULL;
        if (rto_scene_load(path, &s, &msg) == RTO_OK) {
            assert_true(s->instance_count <= 1);
            loaded++;
        } else {
            assert_one_line(&msg);
        }
        rto_scene_destroy(s);
        tried++;
    }
    print_message("GLB sweep: %zu variants, %zu still load\n", tried, loaded);
    /* A corrupt embedded PNG costs the texture, with a warning, not the scene. */
    size_t png = 0;
    while (png + 8 < len && memcmp(b + png, "\x89PNG", 4))
        png++;
    assert_true(png + 200 < len);
    b[png + 150] ^= 0xFF;
    write_bytes(path, b, len);
    rto_scene *s = load_ok(path);
    assert_int_equal(s->texture_count, 0);
    assert_int_equal(s->materials[0].base_color_texture, -1);
    assert_true(has_warning(s, "cannot decode: corrupt PNG: CRC mismatch in chunk"));
    rto_scene_destroy(s);
    free(b);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hostile inputs: non-regular files, amplification, budgets                                                        */

/* Loads that must not allocate much are run under a cap, so a regression fails here instead of swapping: in ASan
 * builds the allocator's own limit (below), elsewhere an address-space limit around the load. */
#if defined(__SANITIZE_ADDRESS__)
#define TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TEST_ASAN 1
#endif
#endif
#ifdef TEST_ASAN
const char *__asan_default_options(void);
const char *__asan_default_options(void) { return "max_allocation_size_mb=1024"; }
#endif

#ifndef TEST_ASAN
static struct rlimit saved_as;
#endif

void memory_cap_on(void)
{
#ifndef TEST_ASAN
    /* 1 GiB more than the process maps now. */
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long pages = 0;
    assert_non_null(f);
    assert_int_equal(fscanf(f, "%lu", &pages), 1);
    fclose(f);
    assert_int_equal(getrlimit(RLIMIT_AS, &saved_as), 0);
    struct rlimit cap = saved_as;
    cap.rlim_cur = (rlim_t)pages * (rlim_t)sysconf(_SC_PAGESIZE) + ((rlim_t)1 << 30);
    if (saved_as.rlim_max != RLIM_INFINITY && cap.rlim_cur > saved_as.rlim_max)
        cap.rlim_cur = saved_as.rlim_max;
    assert_int_equal(setrlimit(RLIMIT_AS, &cap), 0);
#endif
}

void memory_cap_off(void)
{
#ifndef TEST_ASAN
    assert_int_equal(setrlimit(RLIMIT_AS, &saved_as), 0);
#endif
}

/* How often needle occurs in hay. */
static int occurrences(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(hay, needle); p; p = strstr(p + 1, needle))
        n++;
    return n;
}

/* Writes tmp/NAME as the text given; returns the path in a static buffer. */
const char *text_file(const char *name, const char *text)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    write_bytes(path, text, strlen(text));
    return path;
}

const char *tmp_path(const char *name)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    return path;
}

/* One triangle whose buffer is the external file URI (36 bytes declared) and, when image_uri is set, a material with
 * a base-colour texture from that image URI. */
const char *external_gltf(const char *name, const char *buffer_uri, const char *image_uri)
{
    static const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    char body[4096], buf[512];
    char *b64 = base64((const unsigned char *)p, sizeof p);
    if (buffer_uri)
        snprintf(buf, sizeof buf, "{\"byteLength\": 36, \"uri\": \"%s\"}", buffer_uri);
    else
        snprintf(buf, sizeof buf, "{\"byteLength\": 36, \"uri\": \"data:application/octet-stream;base64,%s\"}", b64);
    free(b64);
    snprintf(body, sizeof body,
             "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [%s], "
             "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, "
             "\"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}], %s%s%s"
             "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}%s}]}], \"nodes\": [{\"mesh\": 0}]}",
             buf, image_uri ? "\"images\": [{\"uri\": \"" : "", image_uri ? image_uri : "",
             image_uri ? "\"}], \"textures\": [{\"source\": 0}], \"materials\": [{\"pbrMetallicRoughness\": "
                         "{\"baseColorTexture\": {\"index\": 0}}}], "
                       : "",
             image_uri ? ", \"material\": 0" : "");
    return text_file(name, body);
}

/* A FIFO, a directory or /dev/zero as the scene, as a buffer URI or as an image URI: refused at once with one line
 * naming the file (open() itself would block on a FIFO; /dev/zero never ends). The alarm turns a hang into a
 * failure. */
void test_non_regular_files(void **state)
{
    (void)state;
    alarm(60);
    assert_int_equal(mkfifo(tmp_path("fifo.gltf"), 0600), 0);
    assert_int_equal(mkdir(tmp_path("dir.gltf"), 0700), 0);
    assert_int_equal(symlink("/dev/zero", tmp_path("zero.glb")), 0);
    assert_int_equal(mkfifo(tmp_path("fifo.bin"), 0600), 0);
    assert_int_equal(mkdir(tmp_path("dir.bin"), 0700), 0);
    assert_int_equal(symlink("/dev/zero", tmp_path("zero.bin")), 0);
    assert_int_equal(mkfifo(tmp_path("fifo.png"), 0600), 0);
    assert_int_equal(mkdir(tmp_path("dir.png"), 0700), 0);
    assert_int_equal(symlink("/dev/zero", tmp_path("zero.png")), 0);
    static const struct {
        const char *file, *kind;
    } scenes[] = {{"fifo.gltf", "a FIFO"}, {"dir.gltf", "a directory"}, {"zero.glb", "a character device"}};
    for (size_t i = 0; i < 3; i++) {
        char want[64];
        snprintf(want, sizeof want, "not a regular file (%s)", scenes[i].kind);
        char path[1024];
        snprintf(path, sizeof path, "%s", tmp_path(scenes[i].file));
        expect_refusal(path, RTO_ERR_IO, want);
        rto_msg msg = {{0}};
        rto_scene *s = NULL;
        rto_scene_load(path, &s, &msg);
        assert_int_equal(occurrences(msg.text, scenes[i].file), 1); /* the file named once */
    }
    static const struct {
        const char *uri, *kind;
    } files[] = {{"fifo", "a FIFO"}, {"dir", "a directory"}, {"zero", "a character device"}};
    for (size_t i = 0; i < 3; i++) {
        char uri[64], want[128];
        snprintf(uri, sizeof uri, "%s.bin", files[i].uri);
        snprintf(want, sizeof want, "/%s.bin'): not a regular file (%s)", files[i].uri, files[i].kind);
        expect_refusal(external_gltf("extbuf.gltf", uri, NULL), RTO_ERR_IO, want);
        expect_refusal(external_gltf("extbuf.gltf", uri, NULL), RTO_ERR_IO, "buffer 0 (");
        snprintf(uri, sizeof uri, "%s.png", files[i].uri);
        snprintf(want, sizeof want, "/%s.png'): not a regular file (%s)", files[i].uri, files[i].kind);
        expect_refusal(external_gltf("extimg.gltf", NULL, uri), RTO_ERR_IO, want);
        expect_refusal(external_gltf("extimg.gltf", NULL, uri), RTO_ERR_IO, "image 0 (");
    }
    /* A missing image costs the texture, with a warning; a missing buffer, the scene. */
    rto_scene *s = load_ok(external_gltf("extimg.gltf", NULL, "missing.png"));
    assert_int_equal(s->texture_count, 0);
    assert_true(has_warning(s, "missing.png: No such file or directory; material 0 is untextured"));
    rto_scene_destroy(s);
    expect_refusal(external_gltf("extbuf.gltf", "missing.bin", NULL), RTO_ERR_IO, "cannot open");
    alarm(0);
}

/* A buffer file's size is checked against byteLength before it is read, and only byteLength bytes are read: an
 * 8 GiB sparse file behind a 36-byte buffer loads at once under a 1 GiB allocation cap. */
void test_buffer_file_size(void **state)
{
    (void)state;
    static const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    write_bytes(tmp_path("short.bin"), p, 20);
    expect_refusal(external_gltf("short.gltf", "short.bin", NULL), RTO_ERR_PARSE,
                   "the file holds 20 bytes, less than the byteLength 36 it declares");
    write_bytes(tmp_path("huge.bin"), p, sizeof p);
    assert_int_equal(truncate(tmp_path("huge.bin"), (off_t)8 << 30), 0);
    alarm(60);
    memory_cap_on();
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_status st = rto_scene_load(external_gltf("huge.gltf", "huge.bin", NULL), &s, &msg);
    memory_cap_off();
    alarm(0);
    if (st)
        fail_msg("huge.gltf: %s", msg.text);
    assert_int_equal(s->meshes[0].vertex_count, 3);
    assert_memory_equal(s->meshes[0].positions, p, sizeof p);
    rto_scene_destroy(s);
    assert_int_equal(unlink(tmp_path("huge.bin")), 0);
    /* URIs resolve against the glTF's directory only: a file of that name in the working directory is not used. */
    char here[1024];
    assert_non_null(getcwd(here, sizeof here));
    assert_int_equal(mkdir(tmp_path("sub"), 0700), 0);
    write_bytes(tmp_path("cwd.bin"), p, sizeof p);
    external_gltf("sub/cwd.gltf", "cwd.bin", NULL);
    assert_int_equal(chdir(tmp_dir), 0);
    msg.text[0] = '\0';
    st = rto_scene_load("sub/cwd.gltf", &s, &msg);
    assert_int_equal(chdir(here), 0);
    assert_int_equal(st, RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "sub/cwd.bin"));
}

/* An accessor's range is checked before anything its count sizes is allocated. */
void test_accessor_amplification(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *mesh = "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}], \"nodes\": [{\"mesh\": 0}]";
    char body[1024];
    memory_cap_on();
    /* 2^28 VEC3 floats (3 GiB) over a 36-byte bufferView */
    snprintf(body, sizeof body,
             "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, "
             "\"componentType\": 5126, \"count\": 268435456, \"type\": \"VEC3\"}], %s",
             mesh);
    expect_refusal(gltf_file("amp1.gltf", p, sizeof p, body), RTO_ERR_PARSE,
                   "needs bytes 0 .. 3221225472 of bufferView 0, which holds 36");
    /* the same through a sparse accessor's values: the base has no bufferView, the sparse ranges are short */
    snprintf(body, sizeof body,
             "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"componentType\": 5126, "
             "\"count\": 1048576, \"type\": \"VEC3\", \"sparse\": {\"count\": 1048576, \"indices\": {\"bufferView\": "
             "0, \"componentType\": 5125}, \"values\": {\"bufferView\": 0}}}], %s",
             mesh);
    expect_refusal(gltf_file("amp2.gltf", p, sizeof p, body), RTO_ERR_PARSE, "sparse indices: needs bytes");
    /* no bufferView at all: 2^28 elements of zeros that no byte of the file backs */
    snprintf(body, sizeof body,
             "\"accessors\": [{\"componentType\": 5126, \"count\": 268435456, \"type\": \"VEC3\"}], %s", mesh);
    expect_refusal(gltf_file("amp3.gltf", p, sizeof p, body), RTO_ERR_UNSUPPORTED,
                   "268435456 elements without a bufferView (at most 1048576 are supported)");
    /* One accessor (2^20 zero vertices) named by 100 primitives: each BLAS holds its own copy, 12 * 2^20 bytes of
     * positions and 12 * floor(2^20 / 3) of indices (16777212 bytes), so with the meshes limited to 256 times the
     * file's bytes, or 256 MiB, the 17th is refused: 17 * 16777212 = 285212604. */
    char *many = malloc(16384);
    size_t at = (size_t)snprintf(many, 16384,
                                 "\"accessors\": [{\"componentType\": 5126, \"count\": 1048576, \"type\": \"VEC3\"}], "
                                 "\"meshes\": [{\"primitives\": [");
    for (int i = 0; i < 100; i++)
        at += (size_t)snprintf(many + at, 16384 - at, "%s{\"attributes\": {\"POSITION\": 0}}", i ? ", " : "");
    snprintf(many + at, 16384 - at, "]}], \"nodes\": [{\"mesh\": 0}]");
    expect_refusal(gltf_file("amp4.gltf", p, sizeof p, many), RTO_ERR_UNSUPPORTED,
                   "mesh 0 primitive 16: the meshes would take 285212604 bytes, more than 256 times the");
    free(many);
    memory_cap_off();
}

/* count 0 accessors (positions, normals, texcoords, indices): an empty BLAS, without passing NULL to memcpy (UBSan
 * aborts the ASan/UBSan build on that). */
void test_accessor_count_zero(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *body =
        "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": ["
        "{\"bufferView\": 0, \"componentType\": 5126, \"count\": 0, \"type\": \"VEC3\"},"
        "{\"bufferView\": 0, \"componentType\": 5126, \"count\": 0, \"type\": \"VEC2\"},"
        "{\"bufferView\": 0, \"componentType\": 5125, \"count\": 0, \"type\": \"SCALAR\"},"
        "{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}],"
        "\"meshes\": [{\"name\": \"empty\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 0, "
        "\"TEXCOORD_0\": 1}, \"indices\": 2}, {\"attributes\": {\"POSITION\": 3}, \"indices\": 2}]}],"
        "\"nodes\": [{\"mesh\": 0, \"translation\": [1, 2, 3]}]";
    rto_scene *s = load_ok(gltf_file("empty.gltf", p, sizeof p, body));
    assert_int_equal(s->mesh_count, 2);
    assert_int_equal(s->instance_count, 2);
    assert_int_equal(s->meshes[0].vertex_count, 0);
    assert_int_equal(s->meshes[0].triangle_count, 0);
    assert_int_equal(s->meshes[1].vertex_count, 3);
    assert_int_equal(s->meshes[1].triangle_count, 0);
    assert_true(has_warning(s, "mesh 0 primitive 0: no triangles (an empty BLAS)"));
    for (uint32_t i = 0; i < 2; i++) {
        rto_aabb b = rto_instance_aabb(s, i);
        assert_true(b.min.x == INFINITY && b.max.x == -INFINITY);
    }
    rto_aabb b = rto_scene_aabb(s);
    assert_true(b.min.y == INFINITY && b.max.y == -INFINITY);
    rto_scene_destroy(s);
}

/* Finite positions whose bounds would overflow binary32 in a box centroid (min + max) or a span: refused by the
 * loader, naming the node and the mesh, since the build could not key them. */
void test_bounds_overflow(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1e38f, 0, 0, 0, 1e38f, 0};
    char body[1024];
    const char *fmt = TRI_BODY_PREFIX ", \"meshes\": [{\"name\": \"wing\", \"primitives\": [{\"attributes\": "
                                      "{\"POSITION\": 0}}]}], \"nodes\": [{\"name\": \"root\", \"children\": [1]}, "
                                      "{\"name\": \"big\", \"mesh\": 0, %s}]";
    snprintf(body, sizeof body, fmt, "\"scale\": [10, 10, 10]");
    expect_refusal(gltf_file("ovf1.gltf", p, sizeof p, body), RTO_ERR_UNSUPPORTED,
                   "node 1 ('big'), mesh 0 ('wing'): world bounds (0, 0, 0) .. (inf, inf, 0) reach beyond");
    /* the case: 3e38 under a scale of 10 (already too large in object space) */
    p[3] = 3e38f;
    expect_refusal(gltf_file("ovf2.gltf", p, sizeof p, body), RTO_ERR_UNSUPPORTED,
                   "node 1 ('big'), mesh 0 ('wing') primitive 0: vertex 1 has coordinate 3e+38, beyond +-1.70141e+38");
    /* both sides of the bound: FLT_MAX / 2 itself loads, and a translation past it is refused */
    p[3] = 0x1.fffffep+126f;
    p[7] = -0x1.fffffep+126f;
    snprintf(body, sizeof body, fmt, "\"translation\": [0, 0, 0]");
    rto_scene *s = load_ok(gltf_file("ovf3.gltf", p, sizeof p, body));
    rto_aabb b = rto_scene_aabb(s);
    rto_vec3 c = rto_aabb_centroid(&b);
    assert_true(isfinite(c.x) && isfinite(c.y) && b.max.x == 0x1.fffffep+126f);
    rto_scene_destroy(s);
    p[3] = nextafterf(0x1.fffffep+126f, INFINITY);
    expect_refusal(gltf_file("ovf4.gltf", p, sizeof p, body), RTO_ERR_UNSUPPORTED, "primitive 0: vertex 1 has");
    p[3] = 1e38f;
    snprintf(body, sizeof body, fmt, "\"translation\": [1e38, 0, 0]");
    expect_refusal(gltf_file("ovf5.gltf", p, sizeof p, body), RTO_ERR_UNSUPPORTED,
                   "node 1 ('big'), mesh 0 ('wing'): world bounds (1e+38, -1.70141e+38, 0) .. (2e+38");
}

/* RFC 3629 UTF-8, checked here independently of the loader. */
static int valid_utf8(const char *text)
{
    const unsigned char *s = (const unsigned char *)text;
    while (*s) {
        uint32_t cp;
        int n;
        if (s[0] < 0x80)
            cp = s[0], n = 1;
        else if ((s[0] & 0xE0) == 0xC0)
            cp = s[0] & 0x1Fu, n = 2;
        else if ((s[0] & 0xF0) == 0xE0)
            cp = s[0] & 0x0Fu, n = 3;
        else if ((s[0] & 0xF8) == 0xF0)
            cp = s[0] & 0x07u, n = 4;
        else
            return 0;
        for (int k = 1; k < n; k++) {
            if ((s[k] & 0xC0) != 0x80)
                return 0;
            cp = cp << 6 | (s[k] & 0x3Fu);
        }
        const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
        if (cp < least[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
            return 0;
        s += n;
    }
    return 1;
}

/* Names land in fixed arrays cut at a character boundary, as valid UTF-8 without control characters; warnings quoting
 * names, the source path and failure messages are valid UTF-8 too. */
void test_names_utf8(void **state)
{
    (void)state;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    char a62[63], c59[60], body[2048];
    memset(a62, 'a', 62), a62[62] = '\0';
    memset(c59, 'c', 59), c59[59] = '\0';
    /* "é" (2 bytes) at bytes 62-63 of a 64-byte array; "€" (3 bytes) at 61-63; a control character */
    snprintf(body, sizeof body,
             TRI_BODY_PREFIX ", \"meshes\": [{\"name\": \"%s\\u00e9\", \"primitives\": [{\"attributes\": "
                             "{\"POSITION\": 0}}]}, {\"name\": \"tab\\tbell\\u0007\", \"primitives\": [{\"attributes\": "
                             "{\"POSITION\": 0}}]}],"
                             "\"cameras\": [{\"name\": \"%.61s\\u20ac\", \"type\": \"perspective\", \"perspective\": "
                             "{\"yfov\": 1, \"znear\": 0.1}}, {\"name\": \"%s\\u00e9\\u00e9\", \"type\": "
                             "\"orthographic\", \"orthographic\": {\"xmag\": 1, \"ymag\": 1, \"zfar\": 2, \"znear\": "
                             "1}}],"
                             "\"nodes\": [{\"mesh\": 0, \"camera\": 0}, {\"mesh\": 1, \"camera\": 1}]",
             a62, a62, c59);
    rto_scene *s = load_ok(gltf_file("names.gltf", p, sizeof p, body));
    assert_string_equal(s->meshes[0].name, a62);
    assert_string_equal(s->meshes[1].name, "tab?bell?");
    char want[64];
    snprintf(want, sizeof want, "%.61s", a62);
    assert_string_equal(s->cameras[0].name, want);
    assert_true(has_warning(s, "orthographic cameras are not supported"));
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        if (!valid_utf8(s->warnings[i]))
            fail_msg("warning %u is not valid UTF-8: %s", i, s->warnings[i]);
    rto_scene_destroy(s);
    /* A path is bytes: the scene's source and a failure message naming it are valid UTF-8. */
    const char *ok = gltf_file("bad\xff\xfe.gltf", p, sizeof p,
                               TRI_BODY_PREFIX ", \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}]");
    s = load_ok(ok);
    assert_true(valid_utf8(s->source));
    assert_non_null(strstr(s->source, "/bad\xef\xbf\xbd\xef\xbf\xbd.gltf")); /* U+FFFD for each bad byte */
    rto_scene_destroy(s);
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load(tmp_path("missing\xc3.gltf"), &s, &msg), RTO_ERR_IO);
    assert_true(valid_utf8(msg.text));
    assert_non_null(strstr(msg.text, "missing\xef\xbf\xbd.gltf: cannot open"));
    /* A long path cut inside a character (the message keeps 200 bytes of it). */
    char longname[300];
    memset(longname, 'x', sizeof longname);
    size_t at = 200 - strlen(tmp_dir) - 2;
    memcpy(longname + at, "\xe2\x82\xac", 3);
    memcpy(longname + 240, ".gltf", 6);
    assert_int_equal(rto_scene_load(tmp_path(longname), &s, &msg), RTO_ERR_IO);
    assert_true(valid_utf8(msg.text));
}

void test_gltf1_refused(void **state)
{
    (void)state;
    static const char *files[] = {"BoxTextured-glTF/BoxTextured.gltf",
                                  "BoxTextured-glTF-Embedded/BoxTextured.gltf",
                                  "BoxTextured-glTF-MaterialsCommon/BoxTextured.gltf",
                                  "BoxTextured-glTF-Binary/BoxTextured.glb",
                                  "CesiumMilkTruck/CesiumMilkTruck.gltf",
                                  "IncorrectVertexArrays/Cube_v1.gltf",
                                  "TwoBoxes/TwoBoxes.gltf"};
    char path[1024];
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        /* Debian's assimp-testmodels keeps glTF 1.0 files next to glTF2/ */
        snprintf(path, sizeof path, "%s/../glTF/%s", assimp_dir(), files[i]);
        expect_refusal(path, RTO_ERR_UNSUPPORTED, "glTF 1.0 is not supported");
    }
    static const char *texts[] = {
        "{\"asset\": {\"version\": \"1.0\"}}",
        "{\"asset\": {\"version\": 1}, \"meshes\": []}",
        "{\"asset\": {}, \"scene\": \"defaultScene\", \"scenes\": {\"defaultScene\": {\"nodes\": []}}}",
        "{\"meshes\": {\"m\": {}}}",
    };
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++) {
        char name[32];
        snprintf(name, sizeof name, "v1_%zu.gltf", i);
        expect_refusal(text_file(name, texts[i]), RTO_ERR_UNSUPPORTED, "glTF 1.0 is not supported");
    }
    /* 2.0 with a dictionary where an array belongs stays a schema error */
    expect_refusal(text_file("v2dict.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": {\"m\": {}}}"),
                   RTO_ERR_PARSE, "schema: meshes must be an array");
}
