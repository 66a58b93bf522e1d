/* libFuzzer target for the glTF loader (build: meson setup -Dfuzz=true with clang; seeds: tests/tools/gltf_corpus.py).
 *
 * An input is a text glTF or a GLB: the loader tells them apart by the "glTF" magic, not by the file name. It is
 * written to one file in a private directory made at start-up (the loader reads paths) and loaded with
 * embedded_only, so a URI in the input opens no other file; a 1 MiB texture budget keeps decoding cheap.
 *
 * Beyond "no crash, no leak, no huge allocation", it checks what every load must satisfy: a refusal has one of the
 * loader's statuses, a NULL scene and a one-line message of valid UTF-8 that names the file; an accepted scene has
 * valid UTF-8 names and warnings, indices in range, decoded textures within the budget, and instance world bounds
 * whose centroids and spans are finite (so the build can key every scene the loader accepts). */
#include "rtoracle.h"

#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_TEXTURE_BUDGET ((size_t)1 << 20)

static char dir[64], path[96];

static void check(int cond, const char *what)
{
    if (!cond) {
        fprintf(stderr, "fuzz_gltf invariant violated: %s\n", what);
        abort();
    }
}

static void cleanup(void)
{
    unlink(path);
    rmdir(dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/rto_fuzz_gltf_XXXXXX", tmp && *tmp && strlen(tmp) < 32 ? tmp : "/tmp");
    check(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/input.glb", dir);
    atexit(cleanup);
    return 0;
}

/* RFC 3629 UTF-8 (shortest form, no surrogates, at most U+10FFFF), checked here independently of the loader. */
static int valid_utf8(const char *text, size_t cap)
{
    const unsigned char *s = (const unsigned char *)text;
    size_t i = 0;
    while (i < cap && s[i]) {
        uint32_t cp;
        size_t n;
        if (s[i] < 0x80)
            cp = s[i], n = 1;
        else if ((s[i] & 0xE0) == 0xC0)
            cp = s[i] & 0x1Fu, n = 2;
        else if ((s[i] & 0xF0) == 0xE0)
            cp = s[i] & 0x0Fu, n = 3;
        else if ((s[i] & 0xF8) == 0xF0)
            cp = s[i] & 0x07u, n = 4;
        else
            return 0;
        for (size_t k = 1; k < n; k++) {
            if (i + k >= cap || (s[i + k] & 0xC0) != 0x80)
                return 0;
            cp = cp << 6 | (s[i + k] & 0x3Fu);
        }
        static const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
        if (cp < least[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
            return 0;
        i += n;
    }
    return i < cap; /* terminated inside the array */
}

static int box_ok(const rto_aabb *b)
{
    const float v[6] = {b->min.x, b->min.y, b->min.z, b->max.x, b->max.y, b->max.z};
    for (int i = 0; i < 6; i++)
        if (isnan(v[i]))
            return 0;
    if (!(b->min.x <= b->max.x && b->min.y <= b->max.y && b->min.z <= b->max.z))
        return b->min.x == INFINITY && b->max.x == -INFINITY; /* the empty box of an empty mesh */
    const rto_vec3 c = rto_aabb_centroid(b);
    return isfinite(c.x) && isfinite(c.y) && isfinite(c.z) && isfinite(b->max.x - b->min.x) &&
           isfinite(b->max.y - b->min.y) && isfinite(b->max.z - b->min.z);
}

static void check_scene(const rto_scene *s)
{
    check(valid_utf8(s->source, sizeof s->source), "source is valid UTF-8");
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rto_mesh *me = &s->meshes[m];
        check(valid_utf8(me->name, sizeof me->name), "mesh name is valid UTF-8");
        for (size_t k = 0; k < 3 * (size_t)me->triangle_count; k++)
            check(me->indices[k] < me->vertex_count, "indices in range");
    }
    uint64_t texture_bytes = 0;
    for (uint32_t t = 0; t < s->texture_count; t++) {
        check(valid_utf8(s->textures[t].name, sizeof s->textures[t].name), "texture name is valid UTF-8");
        check(s->textures[t].width && s->textures[t].height && s->textures[t].rgba, "texture has pixels");
        texture_bytes += 4 * (uint64_t)s->textures[t].width * s->textures[t].height;
    }
    check(texture_bytes <= FUZZ_TEXTURE_BUDGET, "decoded textures within the budget");
    for (uint32_t c = 0; c < s->camera_count; c++)
        check(valid_utf8(s->cameras[c].name, sizeof s->cameras[c].name), "camera name is valid UTF-8");
    for (uint32_t w = 0; w < s->warning_count && w < RTO_SCENE_MAX_WARNINGS; w++)
        check(valid_utf8(s->warnings[w], sizeof s->warnings[w]) && !strchr(s->warnings[w], '\n'),
              "warning is one line of valid UTF-8");
    for (uint32_t i = 0; i < s->instance_count; i++) {
        check(s->instances[i].blas < s->mesh_count, "instance BLAS in range");
        const rto_aabb b = rto_instance_aabb(s, i);
        check(box_ok(&b), "instance world bounds keyable");
    }
    const rto_aabb all = rto_scene_aabb(s);
    check(box_ok(&all), "scene bounds keyable");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    check(fd >= 0, "open the input file");
    for (size_t at = 0; at < size;) {
        ssize_t n = write(fd, data + at, size - at);
        check(n > 0, "write the input file");
        at += (size_t)n;
    }
    check(close(fd) == 0, "close the input file");

    rto_scene_load_desc desc = {0};
    desc.texture_budget_bytes = FUZZ_TEXTURE_BUDGET;
    desc.embedded_only = 1;
    rto_msg msg = {{0}};
    rto_scene *s = (rto_scene *)&msg; /* must be set to NULL on failure */
    rto_status st = rto_scene_load_ex(path, &desc, &s, &msg);
    if (st != RTO_OK) {
        check(st == RTO_ERR_PARSE || st == RTO_ERR_UNSUPPORTED || st == RTO_ERR_IO || st == RTO_ERR_OUT_OF_MEMORY,
              "failure status");
        check(s == NULL, "no scene on failure");
        check(msg.text[0] != '\0' && valid_utf8(msg.text, sizeof msg.text), "message is valid UTF-8");
        check(strchr(msg.text, '\n') == NULL, "message is one line");
        check(strncmp(msg.text, path, strlen(path)) == 0, "message names the file");
        return 0;
    }
    check(s != NULL, "scene on success");
    check_scene(s);
    rto_scene_destroy(s);
    return 0;
}
