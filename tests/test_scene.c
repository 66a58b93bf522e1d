/* Scenes (DESIGN.md §5): every fixture and every assimp-testmodels glTF 2.0 file against counts taken independently
 * from the glTF JSON (jansson), the named broken files with their expected refusals, procedural scenes and the
 * transform helpers; the file and scene helpers the other files share, and main(). One executable (unit.scene)
 * with test_scene_gltf.c (hand-made glTF files, hostile inputs) and test_scene_textures.c (textures). */
#include "test_scene.h"

#include <ctype.h>
#include <ftw.h>
#include <jansson.h>
#include <math.h>
#include <strings.h>
#include <sys/stat.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Files                                                                                                            */

static const char *fixtures_dir(void)
{
    const char *d = getenv("RTO_FIXTURES");
    return d && *d ? d : "fixtures";
}

const char *assimp_dir(void)
{
    const char *d = getenv("RTO_ASSIMP_MODELS");
    return d && *d ? d : "/usr/share/assimp/models/glTF2";
}

char tmp_dir[256];

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

void write_bytes(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

unsigned char *read_all(const char *path, size_t *len)
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

void check_loaded(const char *path, const rto_scene *s)
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

void assert_one_line(const rto_msg *m)
{
    assert_true(m->text[0] != '\0');
    assert_null(strchr(m->text, '\n'));
}

rto_scene *load_ok(const char *spec)
{
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_status st = rto_scene_load(spec, &s, &msg);
    if (st)
        fail_msg("%s: %s (%s)", spec, msg.text, rto_status_string(st));
    assert_non_null(s);
    return s;
}

void expect_refusal(const char *spec, rto_status want, const char *substring)
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

int has_warning(const rto_scene *s, const char *substring)
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

void assimp_path(char *buf, size_t cap, const char *rel)
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
