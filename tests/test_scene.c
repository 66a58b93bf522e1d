/* Scenes (DESIGN.md §5): every fixture and every assimp-testmodels glTF 2.0 file against counts taken independently
 * from the glTF JSON (jansson), the named broken files with their expected refusals, hand-made glTF files for each
 * accessor / node / primitive rule, truncation and byte-flip sweeps, procedural scenes and the transform helpers. */
#include "testutil.h"

#include <ctype.h>
#include <ftw.h>
#include <jansson.h>
#include <math.h>
#include <strings.h>
#include <sys/resource.h>
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

static void memory_cap_on(void)
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

static void memory_cap_off(void)
{
#ifndef TEST_ASAN
    assert_int_equal(setrlimit(RLIMIT_AS, &saved_as), 0);
#endif
}

static void expect_refusal_ex(const char *spec, const rto_scene_load_desc *desc, rto_status want,
                              const char *substring)
{
    rto_msg msg = {{0}};
    rto_scene *s = (rto_scene *)&msg;
    rto_status st = rto_scene_load_ex(spec, desc, &s, &msg);
    if (st != want || !strstr(msg.text, substring))
        fail_msg("%s: got %s '%s', want %s containing '%s'", spec, rto_status_string(st), msg.text,
                 rto_status_string(want), substring);
    assert_null(s);
    assert_one_line(&msg);
}

static rto_scene *load_ok_ex(const char *spec, const rto_scene_load_desc *desc)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_status st = rto_scene_load_ex(spec, desc, &s, &msg);
    if (st)
        fail_msg("%s: %s (%s)", spec, msg.text, rto_status_string(st));
    return s;
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
static const char *text_file(const char *name, const char *text)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    write_bytes(path, text, strlen(text));
    return path;
}

static const char *tmp_path(const char *name)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    return path;
}

/* One triangle whose buffer is the external file URI (36 bytes declared) and, when image_uri is set, a material with
 * a base-colour texture from that image URI. */
static const char *external_gltf(const char *name, const char *buffer_uri, const char *image_uri)
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
static void test_non_regular_files(void **state)
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
static void test_buffer_file_size(void **state)
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
static void test_accessor_amplification(void **state)
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
static void test_accessor_count_zero(void **state)
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
static void test_bounds_overflow(void **state)
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
static void test_names_utf8(void **state)
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

static void test_gltf1_refused(void **state)
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

/* ---------------------------------------------------------------------------------------------------------------- */
/* Textures: PNG written here (stored deflate blocks), decoded pixels known by construction                         */

static void put_be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24), p[1] = (unsigned char)(v >> 16), p[2] = (unsigned char)(v >> 8),
    p[3] = (unsigned char)v;
}

typedef struct bytes {
    unsigned char *p;
    size_t n;
} bytes;

static void put(bytes *b, const void *data, size_t n)
{
    b->p = realloc(b->p, b->n + n + 1);
    assert_non_null(b->p);
    if (n)
        memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void chunk(bytes *b, const char *type, const unsigned char *data, size_t n)
{
    unsigned char len[4], crc[4];
    put_be32(len, (uint32_t)n);
    put(b, len, 4);
    size_t start = b->n;
    put(b, type, 4);
    put(b, data, n);
    put_be32(crc, tu_crc32_png(b->p + start, n + 4));
    put(b, crc, 4);
}

/* A PNG of the given IHDR whose IDAT holds raw (filter byte + row) data in stored deflate blocks; extra chunks
 * (already framed) go before IDAT. */
static bytes make_png(uint32_t w, uint32_t h, int depth, int type, int interlace, const unsigned char *raw,
                      size_t rawlen, const bytes *extra)
{
    bytes b = {NULL, 0}, z = {NULL, 0};
    put(&b, "\x89PNG\r\n\x1a\n", 8);
    unsigned char ihdr[13];
    put_be32(ihdr, w);
    put_be32(ihdr + 4, h);
    ihdr[8] = (unsigned char)depth, ihdr[9] = (unsigned char)type, ihdr[10] = 0, ihdr[11] = 0,
    ihdr[12] = (unsigned char)interlace;
    chunk(&b, "IHDR", ihdr, 13);
    if (extra && extra->n)
        put(&b, extra->p, extra->n);
    put(&z, "\x78\x01", 2);
    size_t at = 0;
    do {
        size_t n = rawlen - at < 65535 ? rawlen - at : 65535;
        unsigned char hdr[5] = {(unsigned char)(at + n == rawlen), (unsigned char)n, (unsigned char)(n >> 8),
                                (unsigned char)~n, (unsigned char)(~n >> 8)};
        put(&z, hdr, 5);
        put(&z, raw + at, n);
        at += n;
    } while (at < rawlen);
    uint32_t a = 1, bb = 0;
    for (size_t i = 0; i < rawlen; i++)
        a = (a + raw[i]) % 65521, bb = (bb + a) % 65521;
    unsigned char adler[4];
    put_be32(adler, bb << 16 | a);
    put(&z, adler, 4);
    chunk(&b, "IDAT", z.p, z.n);
    chunk(&b, "IEND", NULL, 0);
    free(z.p);
    return b;
}

/* A w x h RGBA8 PNG (filter 0) whose texel (x, y) is (x, y, seed, 255 - x). */
static bytes rgba_png(uint32_t w, uint32_t h, unsigned seed)
{
    size_t rawlen = (size_t)h * (1 + 4 * (size_t)w);
    unsigned char *raw = calloc(rawlen, 1);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            unsigned char *t = raw + (size_t)y * (1 + 4 * w) + 1 + 4 * x;
            t[0] = (unsigned char)x, t[1] = (unsigned char)y, t[2] = (unsigned char)seed, t[3] = (unsigned char)(255 - x);
        }
    bytes b = make_png(w, h, 8, 6, 0, raw, rawlen, NULL);
    free(raw);
    return b;
}

/* A textured triangle: images as data URIs (one per png), textures naming images (tex_images[i] = source of texture
 * i) and one material per texture; more top-level properties may follow in extra. */
static const char *textured_gltf(const char *name, const bytes *pngs, size_t npng, const int *tex_images,
                                 size_t ntex)
{
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    size_t cap = 4096;
    for (size_t i = 0; i < npng; i++)
        cap += pngs[i].n * 2 + 64;
    char *body = malloc(cap);
    size_t at = (size_t)snprintf(body, cap, "%s, \"images\": [", TRI_BODY_PREFIX);
    for (size_t i = 0; i < npng; i++) {
        char *b64 = base64(pngs[i].p, pngs[i].n);
        at += (size_t)snprintf(body + at, cap - at, "%s{\"uri\": \"data:image/png;base64,%s\"}", i ? ", " : "", b64);
        free(b64);
    }
    at += (size_t)snprintf(body + at, cap - at, "], \"textures\": [");
    for (size_t i = 0; i < ntex; i++)
        at += (size_t)snprintf(body + at, cap - at, "%s{\"source\": %d}", i ? ", " : "", tex_images[i]);
    at += (size_t)snprintf(body + at, cap - at, "], \"materials\": [");
    for (size_t i = 0; i < ntex; i++)
        at += (size_t)snprintf(body + at, cap - at,
                               "%s{\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": %zu}}}", i ? ", " : "",
                               i);
    at += (size_t)snprintf(body + at, cap - at, "], \"meshes\": [{\"primitives\": [");
    for (size_t i = 0; i < ntex; i++)
        at += (size_t)snprintf(body + at, cap - at, "%s{\"attributes\": {\"POSITION\": 0}, \"material\": %zu}",
                               i ? ", " : "", i);
    snprintf(body + at, cap - at, "]}], \"nodes\": [{\"mesh\": 0}]");
    const char *path = gltf_file(name, p, sizeof p, body);
    free(body);
    return path;
}

/* Runs a load with fd 2 sent to a file; returns what was written there (malloc'd). */
static char *stderr_of_load(const char *path, rto_scene **s)
{
    fflush(stderr);
    int saved = dup(2);
    assert_true(saved >= 0);
    FILE *cap = fopen(tmp_path("stderr.txt"), "w+");
    assert_non_null(cap);
    assert_true(dup2(fileno(cap), 2) >= 0);
    rto_msg msg = {{0}};
    rto_status st = rto_scene_load(path, s, &msg);
    fflush(stderr);
    assert_true(dup2(saved, 2) >= 0);
    close(saved);
    fclose(cap);
    if (st)
        fail_msg("%s: %s", path, msg.text);
    size_t n;
    char *text = (char *)read_all(tmp_path("stderr.txt"), &n);
    text[n] = '\0';
    return text;
}

/* PNG decoding: every colour type to RGBA8 with the texels known by construction; a corrupt image costs the texture
 * with a warning and prints nothing (libpng's default handlers write "libpng error" to stderr). */
static void test_png_decoding(void **state)
{
    (void)state;
    /* 2x2 palette with tRNS: index 0 red opaque, 1 green half transparent, 2 blue (no alpha entry: 255) */
    bytes extra = {NULL, 0};
    const unsigned char plte[9] = {255, 0, 0, 0, 255, 0, 0, 0, 255}, trns[2] = {255, 128};
    chunk(&extra, "PLTE", plte, 9);
    chunk(&extra, "tRNS", trns, 2);
    const unsigned char pal_raw[] = {0, 0x10, 0, 0x80}; /* 2-bit indices: row 0 = 0,1; row 1 = 2,0 */
    bytes pngs[5];
    pngs[0] = make_png(2, 2, 2, 3, 0, pal_raw, 4, &extra);
    free(extra.p);
    /* 2x1 grey 16-bit: 0x0000 and 0x8080 (scaled with rounding: 128) */
    const unsigned char g16_raw[] = {0, 0x00, 0x00, 0x80, 0x80};
    pngs[1] = make_png(2, 1, 16, 0, 0, g16_raw, sizeof g16_raw, NULL);
    /* 1x2 grey + alpha 8-bit */
    const unsigned char ga_raw[] = {0, 10, 20, 0, 30, 40};
    pngs[2] = make_png(1, 2, 8, 4, 0, ga_raw, sizeof ga_raw, NULL);
    /* 3x3 RGB, Adam7-interlaced: passes 1 (0,0), 4 (2,0), 5 (0,2)(2,2), 6 (1,0)(1,2), 7 (0,1)(1,1)(2,1);
     * texel (x, y) = (10x, 10y, 7) */
#define T(x, y) (unsigned char)(10 * (x)), (unsigned char)(10 * (y)), 7
    const unsigned char adam_raw[] = {0, T(0, 0), 0, T(2, 0), 0, T(0, 2), T(2, 2), 0, T(1, 0), 0, T(1, 2),
                                      0, T(0, 1), T(1, 1), T(2, 1)};
#undef T
    pngs[3] = make_png(3, 3, 8, 2, 1, adam_raw, sizeof adam_raw, NULL);
    /* an invalid filter type (7) in an otherwise well-formed file */
    const unsigned char bad_raw[] = {7, 1, 2, 3, 4};
    pngs[4] = make_png(1, 1, 8, 6, 0, bad_raw, sizeof bad_raw, NULL);
    const int tex[5] = {0, 1, 2, 3, 4};
    rto_scene *s = NULL;
    char *err = stderr_of_load(textured_gltf("pngs.gltf", pngs, 5, tex, 5), &s);
    if (err[0])
        fail_msg("a successful load wrote to stderr: %s", err);
    free(err);
    assert_int_equal(s->texture_count, 4);
    const uint8_t pal[16] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 255, 0, 0, 255};
    const uint8_t g16[8] = {0, 0, 0, 255, 128, 128, 128, 255};
    const uint8_t ga[8] = {10, 10, 10, 20, 30, 30, 30, 40};
    assert_int_equal(s->textures[0].width, 2);
    assert_memory_equal(s->textures[0].rgba, pal, 16);
    assert_memory_equal(s->textures[1].rgba, g16, 8);
    assert_memory_equal(s->textures[2].rgba, ga, 8);
    for (uint32_t y = 0; y < 3; y++)
        for (uint32_t x = 0; x < 3; x++) {
            const uint8_t want[4] = {(uint8_t)(10 * x), (uint8_t)(10 * y), 7, 255};
            assert_memory_equal(s->textures[3].rgba + 4 * (3 * y + x), want, 4);
        }
    assert_int_equal(s->materials[4].base_color_texture, -1);
    assert_true(has_warning(s, "image 4 ('image 4'): cannot decode: PNG read error: bad adaptive filter value"));
    rto_scene_destroy(s);
    for (int i = 0; i < 5; i++)
        free(pngs[i].p);
}

/* The texture budget, checked from the image headers before a pixel is decoded; an image is decoded once however
 * many textures and images name the same bytes. */
static void test_texture_budget(void **state)
{
    (void)state;
    bytes a = rgba_png(16, 16, 1), b = rgba_png(16, 16, 2); /* 1024 bytes decoded each */
    bytes pngs[3] = {a, b, a};
    /* textures 0, 1 -> image 0; texture 2 -> image 2 (the same bytes as image 0); texture 3 -> image 1 */
    const int tex[4] = {0, 0, 2, 1};
    const char *path = textured_gltf("budget.gltf", pngs, 3, tex, 4);
    rto_scene_load_desc d = {0};
    d.texture_budget_bytes = 2048;
    rto_scene *s = load_ok_ex(path, &d);
    assert_int_equal(s->texture_count, 2);
    assert_int_equal(s->materials[0].base_color_texture, 0);
    assert_int_equal(s->materials[1].base_color_texture, 0);
    assert_int_equal(s->materials[2].base_color_texture, 0);
    assert_int_equal(s->materials[3].base_color_texture, 1);
    const uint8_t t_5_3[4] = {5, 3, 2, 250}; /* texture 1 = seed 2, texel (5, 3) */
    assert_memory_equal(s->textures[1].rgba + 4 * (3 * 16 + 5), t_5_3, 4);
    rto_scene_destroy(s);
    d.texture_budget_bytes = 2047;
    expect_refusal_ex(path, &d, RTO_ERR_UNSUPPORTED,
                      "image 1 ('image 1', 16x16): the decoded textures would take 2048 bytes, over the texture budget "
                      "of 2047 bytes (raise it with --texture-budget MB)");
    /* one image: 1024 fits exactly, 1023 does not */
    const int one[2] = {0, 0};
    path = textured_gltf("budget1.gltf", pngs, 1, one, 2);
    d.texture_budget_bytes = 1024;
    s = load_ok_ex(path, &d);
    assert_int_equal(s->texture_count, 1);
    rto_scene_destroy(s);
    d.texture_budget_bytes = 1023;
    expect_refusal_ex(path, &d, RTO_ERR_UNSUPPORTED, "over the texture budget of 1023 bytes");
    /* an image that fails to decode takes nothing from the budget */
    bytes broken = rgba_png(16, 16, 3);
    broken.p[broken.n - 20] ^= 0x55; /* inside the IDAT chunk: CRC mismatch */
    bytes two[2] = {broken, a};
    const int both[2] = {0, 1};
    d.texture_budget_bytes = 1024;
    s = load_ok_ex(textured_gltf("budget2.gltf", two, 2, both, 2), &d);
    assert_int_equal(s->texture_count, 1);
    assert_int_equal(s->materials[0].base_color_texture, -1);
    assert_int_equal(s->materials[1].base_color_texture, 0);
    rto_scene_destroy(s);
    free(broken.p);
    /* Default budget, 256 MiB: 8192 x 8193 RGBA8 is 16 bytes over. The header alone decides: the image data is not
     * even valid, and nothing is decoded. Three images of one 16384^2 PNG likewise. */
    unsigned char row[2] = {0, 0};
    bytes big = make_png(8192, 8193, 8, 6, 0, row, 2, NULL);
    path = textured_gltf("big.gltf", &big, 1, one, 1);
    memory_cap_on();
    expect_refusal(path, RTO_ERR_UNSUPPORTED,
                   "image 0 ('image 0', 8192x8193): the decoded textures would take 268468224 bytes, over the texture "
                   "budget of 256 MiB");
    free(big.p);
    big = make_png(16384, 16384, 8, 6, 0, row, 2, NULL);
    bytes three[3] = {big, big, big};
    const int all3[3] = {0, 1, 2};
    expect_refusal(textured_gltf("big3.gltf", three, 3, all3, 3), RTO_ERR_UNSUPPORTED,
                   "would take 1024 MiB, over the texture budget of 256 MiB");
    memory_cap_off();
    free(big.p);
    /* External files: the same file under two URIs is read and decoded once; a file larger than the budget is
     * refused before it is read. */
    write_bytes(tmp_path("tex.png"), a.p, a.n);
    const char *ext = text_file(
        "ext_tex.gltf",
        "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 36, \"uri\": "
        "\"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}], "
        "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, "
        "\"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}], \"images\": [{\"uri\": \"tex.png\"}, {\"uri\": "
        "\"./tex.png\"}], \"textures\": [{\"source\": 0}, {\"source\": 1}], \"materials\": [{\"pbrMetallicRoughness\": "
        "{\"baseColorTexture\": {\"index\": 0}}}, {\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 1}}}], "
        "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"material\": 0}, {\"attributes\": "
        "{\"POSITION\": 0}, \"material\": 1}]}], \"nodes\": [{\"mesh\": 0}]}");
    d.texture_budget_bytes = 1200; /* the file (1108 bytes) and one decode (1024) fit, two decodes do not */
    assert_true(a.n <= 1200);
    s = load_ok_ex(ext, &d);
    assert_int_equal(s->texture_count, 1);
    assert_int_equal(s->materials[1].base_color_texture, 0);
    assert_string_equal(s->textures[0].name, "tex.png");
    rto_scene_destroy(s);
    d.texture_budget_bytes = a.n - 1;
    expect_refusal_ex(ext, &d, RTO_ERR_UNSUPPORTED, "tex.png'): the file is");
    free(a.p);
    free(b.p);
}

/* JPEG, the other format glTF allows: the size comes from the frame header (SOF2 in a progressive file, after APP0
 * and two DQT segments), found by walking the marker segments before anything is decoded. */
static void test_jpeg_textures(void **state)
{
    (void)state;
    char src[1024];
    snprintf(src, sizeof src, "%s/../OBJ/engineflare1.jpg", assimp_dir()); /* 128 x 128, progressive */
    size_t n;
    unsigned char *jpg = read_all(src, &n);
    assert_true(n > 200 && jpg[158] == 0xFF && jpg[159] == 0xC2); /* SOF2 at byte 158 */
    bytes img = {jpg, n};
    const int one[1] = {0};
    const char *path = textured_gltf("jpeg.gltf", &img, 1, one, 1);
    /* textured_gltf wrote a PNG mime type: the format is taken from the bytes, not from the URI */
    rto_scene *s = load_ok(path);
    assert_int_equal(s->texture_count, 1);
    assert_int_equal(s->textures[0].width, 128);
    assert_int_equal(s->textures[0].height, 128);
    rto_scene_destroy(s);
    rto_scene_load_desc d = {0};
    d.texture_budget_bytes = 128 * 128 * 4 - 1;
    expect_refusal_ex(path, &d, RTO_ERR_UNSUPPORTED, "image 0 ('image 0', 128x128): the decoded textures would take");
    /* cut before the frame header; a frame header whose height is 0 (defined later by DNL) */
    img.n = 158;
    s = load_ok(textured_gltf("jpeg_cut.gltf", &img, 1, one, 1));
    assert_int_equal(s->texture_count, 0);
    assert_true(has_warning(s, "cannot decode: corrupt JPEG: no frame header"));
    rto_scene_destroy(s);
    img.n = n;
    jpg[158 + 5] = 0, jpg[158 + 6] = 0;
    s = load_ok(textured_gltf("jpeg_dnl.gltf", &img, 1, one, 1));
    assert_true(has_warning(s, "JPEG without its height in the frame header (DNL) is not supported"));
    rto_scene_destroy(s);
    /* neither PNG nor JPEG (a GIF): glTF allows only those two */
    bytes gif = {(unsigned char *)"GIF89a\x01\x00\x01\x00\x00\x00\x00;", 14};
    s = load_ok(textured_gltf("gif.gltf", &gif, 1, one, 1));
    assert_true(has_warning(s, "not a PNG or JPEG image (the formats glTF 2.0 allows)"));
    rto_scene_destroy(s);
    free(jpg);
}

/* embedded_only: no file but the scene file is opened. */
static void test_embedded_only(void **state)
{
    (void)state;
    rto_scene_load_desc d = {0};
    d.embedded_only = 1;
    float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    write_bytes(tmp_path("emb.bin"), p, sizeof p);
    expect_refusal_ex(external_gltf("emb.gltf", "emb.bin", NULL), &d, RTO_ERR_UNSUPPORTED,
                      "buffer 0: external URI 'emb.bin' refused (embedded-only load)");
    expect_refusal_ex(external_gltf("emb.gltf", NULL, "tex.png"), &d, RTO_ERR_UNSUPPORTED,
                      "image 0: external URI 'tex.png' refused (embedded-only load)");
    char path[1024];
    assimp_path(path, sizeof path, "BoxTextured-glTF-Binary/BoxTextured.glb");
    rto_scene *s = load_ok_ex(path, &d);
    assert_int_equal(s->texture_count, 1);
    rto_scene_destroy(s);
    assimp_path(path, sizeof path, "BoxTextured-glTF/BoxTextured.gltf");
    expect_refusal_ex(path, &d, RTO_ERR_UNSUPPORTED, "external URI");
    s = load_ok_ex(external_gltf("emb.gltf", "emb.bin", NULL), NULL); /* the default reads it */
    rto_scene_destroy(s);
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

/* rto_scene_json: the buffer contract of rto_report_text (size, truncate, exact), and what JSON cannot hold is
 * encoded, not dropped: a non-UTF-8 mesh name and a non-finite camera value. */
static void test_scene_json_buffer_and_encoding(void **state)
{
    (void)state;
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    assert_int_equal(rto_scene_load("triangle", &s, &msg), RTO_OK);
    memcpy(s->meshes[0].name, "bad\xff", 5);
    assert_true(s->camera_count >= 1);
    s->cameras[0].zfar = INFINITY;
    size_t len = 0;
    assert_int_equal(rto_scene_json(s, NULL, 0, &len, &msg), RTO_ERR_BUFFER_TOO_SMALL);
    assert_true(len > 100);
    char *text = malloc(len + 1);
    assert_non_null(text);
    size_t len2 = 0;
    assert_int_equal(rto_scene_json(s, text, len, &len2, &msg), RTO_ERR_BUFFER_TOO_SMALL); /* no room for NUL */
    assert_int_equal(len2, len);
    assert_int_equal(strlen(text), len - 1);
    assert_int_equal(rto_scene_json(s, text, len + 1, &len2, &msg), RTO_OK);
    assert_int_equal(strlen(text), len);
    assert_int_equal(text[len - 1], '\n');
    assert_non_null(strstr(text, "\"name\": \"bad\xef\xbf\xbd\"")); /* U+FFFD */
    assert_non_null(strstr(text, "\"zfar\": \"inf\""));
    assert_non_null(strstr(text, "\"source\": \"triangle\""));
    free(text);
    assert_int_equal(rto_scene_json(NULL, NULL, 0, &len, &msg), RTO_ERR_INVALID_ARGUMENT);
    rto_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_json_buffer_and_encoding),
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
        cmocka_unit_test(test_non_regular_files),
        cmocka_unit_test(test_buffer_file_size),
        cmocka_unit_test(test_accessor_amplification),
        cmocka_unit_test(test_accessor_count_zero),
        cmocka_unit_test(test_bounds_overflow),
        cmocka_unit_test(test_names_utf8),
        cmocka_unit_test(test_gltf1_refused),
        cmocka_unit_test(test_png_decoding),
        cmocka_unit_test(test_texture_budget),
        cmocka_unit_test(test_jpeg_textures),
        cmocka_unit_test(test_embedded_only),
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
