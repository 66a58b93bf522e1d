/* Scenes (DESIGN.md §5): every fixture and every assimp-testmodels glTF 2.0 file against counts taken independently
 * from the glTF JSON (jansson), the named broken files with their expected refusals, hand-made glTF files for each
 * accessor / node / primitive rule, truncation and byte-flip sweeps, procedural scenes and the transform helpers. */
#include "testutil.h"

#include <ctype.h>
#include <ftw.h>
#include <jansson.h>
#include <math.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Files                                                                                                            */

static const char *fixtures_dir(void)
{
    const char *d = getenv("RTO_FIXTURES");
    return d && *d ? d : "fixtures";
}

static const char *assimp_dir(void)
{
    const char *d = getenv("RTO_ASSIMP_MODELS");
    return d && *d ? d : "/usr/share/assimp/models/glTF2";
}

static char tmp_dir[256];

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path);
}

static int setup_tmp(void **state)
{
    (void)state;
    snprintf(tmp_dir, sizeof tmp_dir, "/tmp/rto_test_scene_XXXXXX");
    return mkdtemp(tmp_dir) ? 0 : -1;
}

static int teardown_tmp(void **state)
{
    (void)state;
    return nftw(tmp_dir, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

static void write_bytes(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

static unsigned char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return b;
}

/* Every *.gltf / *.glb under a directory, sorted. */
static char **found;
static size_t nfound;

static int collect(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)ftw;
    size_t n = strlen(path);
    if (flag != FTW_F)
        return 0;
    int hit = (n > 5 && !strcasecmp(path + n - 5, ".gltf")) || (n > 4 && !strcasecmp(path + n - 4, ".glb"));
    if (hit) {
        found = realloc(found, (nfound + 1) * sizeof *found);
        found[nfound++] = strdup(path);
    }
    return 0;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static size_t find_gltf(const char *dir)
{
    for (size_t i = 0; i < nfound; i++)
        free(found[i]);
    free(found);
    found = NULL;
    nfound = 0;
    if (nftw(dir, collect, 16, FTW_PHYS))
        fail_msg("cannot walk %s (assimp-testmodels / fixtures missing?)", dir);
    qsort(found, nfound, sizeof *found, cmp_str);
    return nfound;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The independent count: straight from the JSON                                                                   */

static json_t *gltf_json(const char *path)
{
    size_t len;
    unsigned char *b = read_all(path, &len);
    json_t *doc = NULL;
    if (len >= 20 && !memcmp(b, "glTF", 4)) {
        uint32_t jlen = (uint32_t)b[12] | (uint32_t)b[13] << 8 | (uint32_t)b[14] << 16 | (uint32_t)b[15] << 24;
        if (20 + (size_t)jlen <= len)
            doc = json_loadb((const char *)b + 20, jlen, 0, NULL);
    } else {
        doc = json_loadb((const char *)b, len, 0, NULL);
    }
    free(b);
    return doc;
}

typedef struct counts {
    long instances, tris_instanced, tris_unique, meshes;
} counts;

/* Triangles of a primitive: modes 4, 5, 6 (default 4); -1 for points and lines. */
static long prim_tris(json_t *doc, json_t *prim)
{
    json_t *mode = json_object_get(prim, "mode");
    long m = mode ? (long)json_integer_value(mode) : 4;
    if (m < 4)
        return -1;
    json_t *acc = json_object_get(prim, "indices");
    if (!acc)
        acc = json_object_get(json_object_get(prim, "attributes"), "POSITION");
    long n = (long)json_integer_value(
        json_object_get(json_array_get(json_object_get(doc, "accessors"), (size_t)json_integer_value(acc)), "count"));
    return m == 4 ? n / 3 : (n >= 3 ? n - 2 : 0);
}

static void count_node(json_t *doc, long n, int depth, counts *c, long *seen, size_t *nseen)
{
    assert_true(depth < 2000);
    json_t *node = json_array_get(json_object_get(doc, "nodes"), (size_t)n);
    json_t *mesh = json_object_get(node, "mesh");
    if (mesh) {
        long m = (long)json_integer_value(mesh);
        json_t *prims = json_object_get(json_array_get(json_object_get(doc, "meshes"), (size_t)m), "primitives");
        for (size_t p = 0; p < json_array_size(prims); p++) {
            long t = prim_tris(doc, json_array_get(prims, p));
            if (t < 0)
                continue;
            c->instances++;
            c->tris_instanced += t;
            long key = m * 4096 + (long)p, k = 0;
            while (k < (long)*nseen && seen[k] != key)
                k++;
            if (k == (long)*nseen) {
                seen[(*nseen)++] = key;
                c->tris_unique += t;
                c->meshes++;
            }
        }
    }
    json_t *ch = json_object_get(node, "children");
    for (size_t i = 0; i < json_array_size(ch); i++)
        count_node(doc, (long)json_integer_value(json_array_get(ch, i)), depth + 1, c, seen, nseen);
}

/* Scene: `scene`, else scene 0, else every node that is nobody's child. */
static counts independent_count(const char *path)
{
    counts c = {0, 0, 0, 0};
    json_t *doc = gltf_json(path);
    assert_non_null(doc);
    json_t *nodes = json_object_get(doc, "nodes"), *scenes = json_object_get(doc, "scenes");
    size_t nn = json_array_size(nodes);
    long *roots = calloc(nn + 1, sizeof *roots), *seen = calloc(4096, sizeof *seen);
    size_t nroots = 0, nseen = 0;
    if (json_array_size(scenes)) {
        json_t *sc = json_object_get(doc, "scene");
        json_t *list = json_object_get(json_array_get(scenes, sc ? (size_t)json_integer_value(sc) : 0), "nodes");
        for (size_t i = 0; i < json_array_size(list); i++)
            roots[nroots++] = (long)json_integer_value(json_array_get(list, i));
    } else {
        char *child = calloc(nn + 1, 1);
        for (size_t i = 0; i < nn; i++) {
            json_t *ch = json_object_get(json_array_get(nodes, i), "children");
            for (size_t k = 0; k < json_array_size(ch); k++)
                child[json_integer_value(json_array_get(ch, k))] = 1;
        }
        for (size_t i = 0; i < nn; i++)
            if (!child[i])
                roots[nroots++] = (long)i;
        free(child);
    }
    for (size_t r = 0; r < nroots; r++)
        count_node(doc, roots[r], 0, &c, seen, &nseen);
    free(roots);
    free(seen);
    json_decref(doc);
    return c;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Invariants of a loaded scene                                                                                     */

/* obj_to_world * world_to_obj (as 4x4 affine products of the stored binary32 values) is the identity. */
static void check_inverse(const rto_instance *in, const char *what, uint32_t i)
{
    const float(*a)[4] = in->obj_to_world.m, (*b)[4] = in->world_to_obj.m;
    double tmax = 1.0;
    for (int r = 0; r < 3; r++)
        tmax = fmax(tmax, fabs((double)a[r][3]));
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++) {
            double v = (double)a[r][0] * b[0][c] + (double)a[r][1] * b[1][c] + (double)a[r][2] * b[2][c];
            if (c == 3)
                v += a[r][3];
            double want = (c == r) ? 1.0 : 0.0, tol = c == 3 ? 1e-5 * tmax : 1e-5;
            if (fabs(v - want) > tol)
                fail_msg("%s instance %u: (objToWorld * worldToObj)[%d][%d] = %.9g", what, i, r, c, v);
        }
}

static uint64_t instanced_tris(const rto_scene *s)
{
    uint64_t t = 0;
    for (uint32_t i = 0; i < s->instance_count; i++)
        t += s->meshes[s->instances[i].blas].triangle_count;
    return t;
}

static uint64_t unique_tris(const rto_scene *s)
{
    uint64_t t = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        t += s->meshes[m].triangle_count;
    return t;
}

static void check_loaded(const char *path, const rto_scene *s)
{
    counts c = independent_count(path);
    if ((long)s->instance_count != c.instances || (long)instanced_tris(s) != c.tris_instanced ||
        (long)unique_tris(s) != c.tris_unique || (long)s->mesh_count != c.meshes)
        fail_msg("%s: loaded %u instances / %llu triangles (%llu unique, %u BLAS); the JSON says %ld / %ld (%ld, %ld)",
                 path, s->instance_count, (unsigned long long)instanced_tris(s), (unsigned long long)unique_tris(s),
                 s->mesh_count, c.instances, c.tris_instanced, c.tris_unique, c.meshes);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        check_inverse(&s->instances[i], path, i);
        assert_true(s->instances[i].custom_index <= RTO_INSTANCE_CUSTOM_INDEX_MASK);
        assert_int_equal(s->instances[i].mask, 0xFF);
        assert_int_equal(s->instances[i].sbt_offset, 0);
        assert_int_equal(s->instances[i].flags, 0);
    }
    for (uint32_t t = 0; t < s->texture_count; t++)
        assert_true(s->textures[t].width > 0 && s->textures[t].height > 0 && s->textures[t].rgba);
}

static void assert_one_line(const rto_msg *m)
{
    assert_true(m->text[0] != '\0');
    assert_null(strchr(m->text, '\n'));
}

static rto_scene *load_ok(const char *spec)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_status st = rto_scene_load(spec, &s, &msg);
    if (st)
        fail_msg("%s: %s (%s)", spec, msg.text, rto_status_string(st));
    assert_non_null(s);
    return s;
}

static void expect_refusal(const char *spec, rto_status want, const char *substring)
{
    rto_msg msg = {{0}};
    rto_scene *s = (rto_scene *)&msg; /* must be reset to NULL on failure */
    rto_status st = rto_scene_load(spec, &s, &msg);
    if (st != want || !strstr(msg.text, substring))
        fail_msg("%s: got %s '%s', want %s containing '%s'", spec, rto_status_string(st), msg.text,
                 rto_status_string(want), substring);
    assert_null(s);
    assert_one_line(&msg);
}

static int has_warning(const rto_scene *s, const char *substring)
{
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        if (strstr(s->warnings[i], substring))
            return 1;
    return 0;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Fixtures and assimp-testmodels                                                                                   */

static void test_fixtures_load_with_independent_counts(void **state)
{
    (void)state;
    size_t n = find_gltf(fixtures_dir());
    assert_true(n >= 7);
    for (size_t i = 0; i < n; i++) {
        rto_scene *s = load_ok(found[i]);
        assert_true(s->instance_count > 0);
        check_loaded(found[i], s);
        assert_string_equal(s->source, found[i]);
        rto_scene_destroy(s);
    }
}

static void test_assimp_models_load_or_refuse(void **state)
{
    (void)state;
    size_t n = find_gltf(assimp_dir()), loaded = 0;
    assert_true(n >= 40);
    for (size_t i = 0; i < n; i++) {
        rto_msg msg = {{0}};
        rto_scene *s = NULL;
        rto_status st = rto_scene_load(found[i], &s, &msg);
        if (st == RTO_OK) {
            check_loaded(found[i], s);
            loaded++;
        } else {
            assert_null(s);
            assert_one_line(&msg);
            assert_true(st == RTO_ERR_PARSE || st == RTO_ERR_UNSUPPORTED || st == RTO_ERR_IO);
        }
        rto_scene_destroy(s);
    }
    print_message("assimp glTF2: %zu files, %zu load, %zu refused\n", n, loaded, n - loaded);
    assert_true(loaded >= 30);
}

static void assimp_path(char *buf, size_t cap, const char *rel)
{
    snprintf(buf, cap, "%s/%s", assimp_dir(), rel);
}

static void test_assimp_broken_files(void **state)
{
    (void)state;
    static const struct {
        const char *file;
        rto_status status;
        const char *substring;
    } cases[] = {
        {"IndexOutOfRange/IndexOutOfRange.gltf", RTO_ERR_PARSE, "index 255 at element 0 is out of range (24"},
        {"IndexOutOfRange/AllIndicesOutOfRange.gltf", RTO_ERR_PARSE, "is out of range (24 vertices)"},
        {"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", RTO_ERR_PARSE,
         "POSITION of mesh 0 primitive 0): vertex 0 is not finite"},
        {"RecursiveNodes/RecursiveNodes.gltf", RTO_ERR_PARSE, "cycle through node 0"},
        {"MissingBin/BoxTextured.gltf", RTO_ERR_IO, "BoxTextured0.bin"},
        {"wrongTypes/badArray.gltf", RTO_ERR_PARSE, "schema: meshes[0].primitives must be an array"},
        {"wrongTypes/badExtension.gltf", RTO_ERR_PARSE, "extensions.KHR_texture_transform must be an object"},
        {"wrongTypes/badNumber.gltf", RTO_ERR_PARSE, "schema: materials[0].normalTexture.scale must be a number"},
        {"wrongTypes/badObject.gltf", RTO_ERR_PARSE, "schema: materials[0].pbrMetallicRoughness must be an object"},
        {"wrongTypes/badString.gltf", RTO_ERR_PARSE, "schema: scenes[0].name must be a string"},
        {"wrongTypes/badUint.gltf", RTO_ERR_PARSE, "baseColorTexture.index must be a non-negative integer"},
        {"TestNoRootNode/NoScene.gltf", RTO_ERR_PARSE, "default scene 0 does not exist (the file has 0 scenes)"},
        {"SchemaFailures/sceneWrongType.gltf", RTO_ERR_PARSE, "schema: scene must be a non-negative integer"},
        {"draco/2CylinderEngine.gltf", RTO_ERR_UNSUPPORTED, "KHR_draco_mesh_compression"},
        {"BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf", RTO_ERR_UNSUPPORTED, "KHR_technique_webgl"},
    };
    char path[1024];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        assimp_path(path, sizeof path, cases[i].file);
        expect_refusal(path, cases[i].status, cases[i].substring);
    }
    /* A scene without nodes is a valid, empty scene. */
    assimp_path(path, sizeof path, "TestNoRootNode/SceneWithoutNodes.gltf");
    rto_scene *s = load_ok(path);
    assert_int_equal(s->instance_count, 0);
    assert_int_equal(s->mesh_count, 0);
    rto_aabb b = rto_scene_aabb(s);
    assert_true(b.min.x == INFINITY && b.max.x == -INFINITY);
    rto_scene_destroy(s);
    /* Truncated triangle lists lose their last 1-2 indices, line primitives are skipped, both with a warning. */
    assimp_path(path, sizeof path, "IncorrectVertexArrays/Cube.gltf");
    s = load_ok(path);
    assert_int_equal(s->instance_count, 4);
    assert_int_equal(unique_tris(s), 12 + 11 + 12 + 11);
    assert_true(has_warning(s, "35 vertices in a triangle list; the last 2 are ignored"));
    assert_true(has_warning(s, "lines skipped"));
    rto_scene_destroy(s);
    /* Orthographic cameras are skipped; the engine's instanced count matches SOURCES.md. */
    assimp_path(path, sizeof path, "cameras/Cameras.gltf");
    s = load_ok(path);
    assert_int_equal(s->camera_count, 1);
    assert_true(has_warning(s, "orthographic cameras are not supported"));
    rto_scene_destroy(s);
    assimp_path(path, sizeof path, "2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    s = load_ok(path);
    assert_int_equal(instanced_tris(s), 121496);
    rto_scene_destroy(s);
}

static void fixture_path(char *buf, size_t cap, const char *rel)
{
    snprintf(buf, cap, "%s/%s", fixtures_dir(), rel);
}

static void test_fixture_details(void **state)
{
    (void)state;
    char path[1024];
    /* Duck: the root node scales by 0.01; without it the duck would be ~160 units across. */
    fixture_path(path, sizeof path, "Duck/glTF/Duck.gltf");
    rto_scene *s = load_ok(path);
    rto_aabb b = rto_scene_aabb(s);
    float ext[3] = {b.max.x - b.min.x, b.max.y - b.min.y, b.max.z - b.min.z};
    for (int a = 0; a < 3; a++)
        assert_true(ext[a] > 0.5f && ext[a] < 3.0f);
    assert_int_equal(s->camera_count, 1);
    assert_int_equal(s->texture_count, 1);
    assert_int_equal(s->textures[0].width, 512);
    assert_int_equal(s->textures[0].height, 512);
    assert_int_equal(s->materials[0].base_color_texture, 0);
    assert_int_equal(s->warning_count, 0);
    rto_scene_destroy(s);

    /* CornellBox: 11 nodes (10 meshes + camera), one mesh used by two nodes, emissive 3, a dangling texture. */
    fixture_path(path, sizeof path, "CornellBox-nvpro-glTF/cornellBox.gltf");
    s = load_ok(path);
    assert_int_equal(s->instance_count, 10);
    assert_int_equal(s->mesh_count, 9);
    uint32_t shared = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        uint32_t uses = 0;
        for (uint32_t i = 0; i < s->instance_count; i++)
            uses += s->instances[i].blas == m;
        shared += uses == 2;
    }
    assert_int_equal(shared, 1);
    assert_int_equal(s->camera_count, 1);
    assert_true(fabsf(s->cameras[0].position.z - 19.992092f) < 1e-4f);
    assert_true(fabsf(s->cameras[0].fov_y - 0.71754146f) < 1e-6f);
    assert_true(s->cameras[0].target.z < s->cameras[0].position.z); /* looks down -Z */
    int emissive3 = 0;
    for (uint32_t i = 0; i < s->material_count; i++)
        emissive3 |= s->materials[i].emissive[0] == 3.0f;
    assert_true(emissive3);
    assert_true(has_warning(s, "names image 0, but the file has 0 images"));
    /* customIndex is the glTF node index: the camera is node 0, the meshes sit on nodes 1..10 */
    for (uint32_t i = 0; i < s->instance_count; i++)
        assert_int_equal(s->instances[i].custom_index, i + 1);
    rto_scene_destroy(s);

    /* SimpleMeshes: one BLAS, two instances, the second translated by (1, 0, 0). */
    fixture_path(path, sizeof path, "SimpleMeshes/glTF/SimpleMeshes.gltf");
    s = load_ok(path);
    assert_int_equal(s->mesh_count, 1);
    assert_int_equal(s->instance_count, 2);
    assert_true(s->instances[1].obj_to_world.m[0][3] == 1.0f);
    rto_scene_destroy(s);

    /* Textures from a data URI and from a GLB bufferView decode alike. */
    const char *boxes[] = {"BoxTextured-glTF-Embedded/BoxTextured.gltf", "BoxTextured-glTF-Binary/BoxTextured.glb",
                           "BoxTextured-glTF/BoxTextured.gltf"};
    uint8_t first[16];
    for (int i = 0; i < 3; i++) {
        assimp_path(path, sizeof path, boxes[i]);
        s = load_ok(path);
        assert_int_equal(s->texture_count, 1);
        assert_int_equal(s->textures[0].width, 211); /* CesiumLogoFlat.png, a palette PNG */
        assert_int_equal(s->textures[0].height, 211);
        if (i == 0)
            memcpy(first, s->textures[0].rgba, sizeof first);
        else
            assert_memory_equal(first, s->textures[0].rgba, sizeof first);
        rto_scene_destroy(s);
    }
}

/* Loading is a pure function of the file: two loads give the same bytes. */
static void test_load_is_deterministic(void **state)
{
    (void)state;
    char path[1024];
    fixture_path(path, sizeof path, "CornellBox-nvpro-glTF/cornellBox.gltf");
    rto_scene *a = load_ok(path), *b = load_ok(path);
    assert_int_equal(a->mesh_count, b->mesh_count);
    assert_int_equal(a->instance_count, b->instance_count);
    assert_memory_equal(a->instances, b->instances, a->instance_count * sizeof *a->instances);
    assert_memory_equal(a->materials, b->materials, a->material_count * sizeof *a->materials);
    assert_memory_equal(a->cameras, b->cameras, a->camera_count * sizeof *a->cameras);
    for (uint32_t m = 0; m < a->mesh_count; m++) {
        assert_int_equal(a->meshes[m].vertex_count, b->meshes[m].vertex_count);
        assert_memory_equal(a->meshes[m].positions, b->meshes[m].positions, 12 * (size_t)a->meshes[m].vertex_count);
        assert_memory_equal(a->meshes[m].indices, b->meshes[m].indices, 12 * (size_t)a->meshes[m].triangle_count);
    }
    rto_scene_destroy(a);
    rto_scene_destroy(b);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Hand-made glTF files                                                                                             */

static char *base64(const unsigned char *b, size_t n)
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
static const char *gltf_file(const char *name, const void *bin, size_t binlen, const char *body)
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

/* One triangle's positions (x, y, z per vertex) as a buffer, a bufferView and a POSITION accessor 0. */
#define TRI_BODY_PREFIX                                                                                              \
    "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, \"componentType\": " \
    "5126, \"count\": 3, \"type\": \"VEC3\"}]"

static void test_gltf_nan_position_refused(void **state)
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
static void test_gltf_primitives_and_nodes(void **state)
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
static void test_gltf_no_scene_uses_root_nodes(void **state)
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

static void test_gltf_sparse_accessors(void **state)
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

static void test_gltf_refusals(void **state)
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

static void test_gltf_malformed_files(void **state)
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
        {"{\"asset\": {\"version\": \"1.0\"}}", RTO_ERR_UNSUPPORTED, "glTF version '1.0'"},
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
static void test_glb_truncation_and_flips(void **state)
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
/* Procedural scenes                                                                                                */

static void test_triangle(void **state)
{
    (void)state;
    rto_scene *s = load_ok("triangle");
    assert_int_equal(s->mesh_count, 1);
    assert_int_equal(s->instance_count, 1);
    const float pos[9] = {1, 1, 0, -1, 1, 0, 0, -1, 0};
    const uint32_t idx[3] = {0, 1, 2};
    assert_memory_equal(s->meshes[0].positions, pos, sizeof pos);
    assert_memory_equal(s->meshes[0].indices, idx, sizeof idx);
    const rto_mat34 id = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    assert_memory_equal(&s->instances[0].obj_to_world, &id, sizeof id);
    assert_memory_equal(&s->instances[0].world_to_obj, &id, sizeof id);
    assert_int_equal(s->instances[0].mask, 0xFF);
    assert_int_equal(s->camera_count, 1);
    assert_true(s->cameras[0].position.z == 2.5f && s->cameras[0].target.z == 0.0f && s->cameras[0].up.y == 1.0f);
    assert_true(fabsf(s->cameras[0].fov_y - 1.0471976f) < 1e-6f);
    assert_string_equal(s->source, "triangle");
    rto_scene_destroy(s);
}

static void test_rtstress_all_sizes(void **state)
{
    (void)state;
    for (uint32_t n = 1; n <= 40; n++) {
        char spec[32];
        snprintf(spec, sizeof spec, "rtstress:%u", n);
        rto_scene *s = load_ok(spec);
        assert_int_equal(s->mesh_count, 1);
        assert_int_equal(s->meshes[0].triangle_count, 12);
        assert_int_equal(s->meshes[0].vertex_count, 8);
        assert_int_equal(s->instance_count, n * n * n);
        /* A few instances at their documented positions (all of them for small N). */
        for (uint32_t i = 0; i < n * n * n; i += n <= 4 ? 1 : 997) {
            const uint32_t ix = i % n, iy = i / n % n, iz = i / (n * n);
            const rto_instance *in = &s->instances[i];
            assert_int_equal(in->custom_index, i);
            assert_true(in->obj_to_world.m[0][3] == (float)(2 * (int)ix - (int)(n - 1)));
            assert_true(in->obj_to_world.m[1][3] == (float)(2 * (int)iy - (int)(n - 1)));
            assert_true(in->obj_to_world.m[2][3] == (float)(2 * (int)iz - (int)(n - 1)));
            assert_true(in->world_to_obj.m[0][3] == -in->obj_to_world.m[0][3]);
        }
        rto_aabb b = rto_scene_aabb(s);
        assert_true(b.min.x == -(float)n + 0.5f && b.max.z == (float)n - 0.5f);
        rto_scene_destroy(s);
    }
    /* The cube: 8 corners of [-0.5, 0.5]^3, every vertex used, every triangle counter-clockwise seen from outside. */
    rto_scene *s = load_ok("rtstress:1");
    const rto_mesh *m = &s->meshes[0];
    for (uint32_t t = 0; t < 12; t++) {
        const float *a = &m->positions[3 * m->indices[3 * t]], *b = &m->positions[3 * m->indices[3 * t + 1]],
                    *c = &m->positions[3 * m->indices[3 * t + 2]];
        float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        float cen[3] = {a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2]};
        assert_true(n[0] * cen[0] + n[1] * cen[1] + n[2] * cen[2] > 0.0f);
    }
    rto_aabb ob = rto_mesh_aabb(m);
    assert_true(ob.min.x == -0.5f && ob.min.y == -0.5f && ob.min.z == -0.5f && ob.max.x == 0.5f && ob.max.z == 0.5f);
    rto_scene_destroy(s);
}

static void test_instances_distributions(void **state)
{
    (void)state;
    const size_t sizes[] = {0, 1, 2, 3, 4097};
    for (size_t d = 0; d < rto_dist_count(); d++) {
        const rto_dist_info *info = rto_dist_at(d);
        if (info->kind != RTO_DIST_CENTROID)
            continue;
        for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
            const size_t n = sizes[k];
            char spec[64];
            snprintf(spec, sizeof spec, "instances:%s:%zu", info->name, n);
            rto_scene *s = load_ok(spec);
            assert_int_equal(s->instance_count, n);
            assert_int_equal(s->mesh_count, 1);
            rto_vec3 *c = malloc((n ? n : 1) * sizeof *c);
            assert_int_equal(rto_centroids_generate(info->name, 1, n, c, NULL), RTO_OK);
            for (uint32_t i = 0; i < n; i++) {
                rto_aabb b = rto_instance_aabb(s, i);
                rto_vec3 cc = rto_aabb_centroid(&b);
                assert_true(fabsf(cc.x - c[i].x) < 1e-6f && fabsf(cc.y - c[i].y) < 1e-6f &&
                            fabsf(cc.z - c[i].z) < 1e-6f);
                assert_true(fabsf((b.max.x - b.min.x) - 2e-4f) < 1e-6f);
                assert_int_equal(s->instances[i].custom_index, i);
                check_inverse(&s->instances[i], spec, i);
            }
            free(c);
            rto_scene_destroy(s);
        }
    }
    rto_scene *s = load_ok("instances:uniform:65536");
    assert_int_equal(s->instance_count, 65536);
    rto_scene_destroy(s);
}

static void test_spec_refusals(void **state)
{
    (void)state;
    static const struct {
        const char *spec;
        const char *substring;
    } cases[] = {
        {"rtstress:0", "N must be an integer 1 .. 40"},
        {"rtstress:41", "N must be an integer 1 .. 40"},
        {"rtstress:abc", "N must be an integer"},
        {"rtstress:", "N must be an integer"},
        {"rtstress:5x", "N must be an integer"},
        {"rtstress:+5", "N must be an integer"},
        {"rtstress:-1", "N must be an integer"},
        {"rtstress: 5", "N must be an integer"},
        {"rtstress:99999999999999", "N must be an integer"},
        {"instances:random:5", "'random' is not a centroid distribution; centroid distributions: uniform"},
        {"instances:no-such:5", "an unknown distribution"},
        {"instances:uniform:65537", "N must be an integer 0 .. 65536"},
        {"instances:uniform:5:1", "N must be an integer"},
        {"instances:uniform:", "N must be an integer"},
        {"instances:uniform", "expected instances:DIST:N"},
        {"instances::5", "expected instances:DIST:N"},
        {"triangle:2", "unknown procedural scene 'triangle:2'"},
        {"foo:bar", "unknown procedural scene"},
        {"scene.obj", "neither a .gltf / .glb path nor a procedural scene"},
        {"triangles", "neither a .gltf / .glb path"},
        {"", "empty scene spec"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        expect_refusal(cases[i].spec, RTO_ERR_INVALID_ARGUMENT, cases[i].substring);
    rto_msg msg = {{0}};
    assert_int_equal(rto_scene_load(NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_scene_destroy(NULL);
    /* Extension matching is case-insensitive: a missing .GLB is an I/O refusal, not an unknown spec. */
    char path[512];
    snprintf(path, sizeof path, "%s/missing.GLB", tmp_dir);
    expect_refusal(path, RTO_ERR_IO, "cannot open");
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Transforms and bounds                                                                                            */

static void test_set_transform(void **state)
{
    (void)state;
    rto_instance in;
    memset(&in, 0, sizeof in);
    rto_msg msg = {{0}};
    /* Exactly representable: scale 2 and a translation invert exactly. */
    const double a[3][4] = {{2, 0, 0, 1}, {0, 2, 0, -3}, {0, 0, 2, 8}};
    assert_int_equal(rto_instance_set_transform(&in, a, &msg), RTO_OK);
    const rto_mat34 inv = {{{0.5f, 0, 0, -0.5f}, {0, 0.5f, 0, 1.5f}, {0, 0, 0.5f, -4}}};
    assert_memory_equal(&in.world_to_obj, &inv, sizeof inv);
    /* Random affine matrices: the product is the identity, and both are binary64 results rounded once. */
    for (uint32_t k = 0; k < 2000; k++) {
        double m[3][4];
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                /* diagonally dominant, so well conditioned: the 1e-5 identity tolerance applies */
                m[r][c] = (double)rto_unit(k, (uint32_t)(r * 4 + c)) * 2.0 - 1.0 + (c == r ? 4.0 : 0.0);
        /* C11 does not convert double (*)[4] to const double (*)[4] implicitly (C23 does). */
        if (rto_instance_set_transform(&in, (const double(*)[4])m, &msg))
            fail_msg("matrix %u: %s", k, msg.text);
        check_inverse(&in, "random", k);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                assert_true(in.obj_to_world.m[r][c] == (float)m[r][c]);
    }
    rto_instance before = in;
    const double singular[3][4] = {{1, 2, 3, 0}, {2, 4, 6, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&in, singular, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "singular"));
    const double nearly[3][4] = {{1, 0, 0, 0}, {1, 1e-14, 0, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&in, nearly, &msg), RTO_ERR_INVALID_ARGUMENT);
    const double zero[3][4] = {{0}};
    assert_int_equal(rto_instance_set_transform(&in, zero, &msg), RTO_ERR_INVALID_ARGUMENT);
    const double nan[3][4] = {{1, 0, 0, NAN}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&in, nan, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "not finite"));
    const double huge[3][4] = {{1e39, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    assert_int_equal(rto_instance_set_transform(&in, huge, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "binary32"));
    assert_memory_equal(&in, &before, sizeof in); /* refused calls leave the instance alone */
    /* A tiny uniform scale is not singular: scale-independent test. */
    const double tiny[3][4] = {{1e-6, 0, 0, 0}, {0, 1e-6, 0, 0}, {0, 0, 1e-6, 0}};
    assert_int_equal(rto_instance_set_transform(&in, tiny, &msg), RTO_OK);
    assert_true(in.world_to_obj.m[1][1] == 1e6f);
}

static void test_mat34_point_order(void **state)
{
    (void)state;
    /* ((m0 x + m1 y) + m2 z) + m3: 1 + 2^25 rounds to 2^25 in binary32, so the first sum loses the 1. */
    const rto_mat34 m = {{{1, 33554432.0f, -33554432.0f, 0}, {0, 1, 0, 0.25f}, {0, 0, 1, 0}}};
    rto_vec3 q = rto_mat34_point(&m, (rto_vec3){1, 1, 1});
    assert_true(q.x == 0.0f);
    assert_true(q.y == 1.25f && q.z == 1.0f);
}

static void test_bounds(void **state)
{
    (void)state;
    rto_scene *s = load_ok("triangle");
    rto_mesh *m = &s->meshes[0];
    /* An unreferenced vertex does not count: append one far away. */
    float *grown = realloc(m->positions, 12 * sizeof(float));
    assert_non_null(grown);
    m->positions = grown;
    m->positions[9] = 100.0f, m->positions[10] = 100.0f, m->positions[11] = 100.0f;
    m->vertex_count = 4;
    rto_aabb b = rto_mesh_aabb(m);
    assert_true(b.min.x == -1.0f && b.max.x == 1.0f && b.min.y == -1.0f && b.max.y == 1.0f && b.max.z == 0.0f);
    /* Instance bounds: the 8 corners through objToWorld (a 90 degree rotation about z plus a translation). */
    const double r[3][4] = {{0, -1, 0, 10}, {1, 0, 0, 0}, {0, 0, 1, -5}};
    assert_int_equal(rto_instance_set_transform(&s->instances[0], r, NULL), RTO_OK);
    rto_aabb w = rto_instance_aabb(s, 0);
    assert_true(w.min.x == 9.0f && w.max.x == 11.0f && w.min.y == -1.0f && w.max.y == 1.0f && w.min.z == -5.0f);
    rto_aabb sb = rto_scene_aabb(s);
    assert_memory_equal(&sb, &w, sizeof w);
    rto_aabb none = rto_instance_aabb(s, 1);
    assert_true(none.min.x == INFINITY && none.max.x == -INFINITY);
    /* An empty mesh has the empty box, and so do its instances. */
    m->triangle_count = 0;
    b = rto_mesh_aabb(m);
    assert_true(b.min.y == INFINITY && b.max.y == -INFINITY);
    w = rto_instance_aabb(s, 0);
    assert_true(w.min.z == INFINITY && w.max.z == -INFINITY);
    rto_scene_destroy(s);
    rto_camera c = rto_camera_default();
    assert_true(c.position.x == 0.0f && c.position.y == 2.0f && c.position.z == 5.0f && c.up.y == 1.0f);
    assert_true(fabsf(c.fov_y - 1.0471976f) < 1e-6f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fixtures_load_with_independent_counts),
        cmocka_unit_test(test_assimp_models_load_or_refuse),
        cmocka_unit_test(test_assimp_broken_files),
        cmocka_unit_test(test_fixture_details),
        cmocka_unit_test(test_load_is_deterministic),
        cmocka_unit_test(test_gltf_nan_position_refused),
        cmocka_unit_test(test_gltf_primitives_and_nodes),
        cmocka_unit_test(test_gltf_no_scene_uses_root_nodes),
        cmocka_unit_test(test_gltf_sparse_accessors),
        cmocka_unit_test(test_gltf_refusals),
        cmocka_unit_test(test_gltf_malformed_files),
        cmocka_unit_test(test_glb_truncation_and_flips),
        cmocka_unit_test(test_triangle),
        cmocka_unit_test(test_rtstress_all_sizes),
        cmocka_unit_test(test_instances_distributions),
        cmocka_unit_test(test_spec_refusals),
        cmocka_unit_test(test_set_transform),
        cmocka_unit_test(test_mat34_point_order),
        cmocka_unit_test(test_bounds),
    };
    int rc = cmocka_run_group_tests(tests, setup_tmp, teardown_tmp);
    for (size_t i = 0; i < nfound; i++)
        free(found[i]);
    free(found);
    return rc;
}
