/* Scenes (DESIGN.md §5), part of unit.scene (main() in test_scene.c): textures, PNG files written here (stored deflate
 * blocks) whose decoded pixels are known by construction, every colour type, the texture budget, JPEG and
 * embedded-only loading. */
#include "test_scene.h"

#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Textures: PNG written here (stored deflate blocks), decoded pixels known by construction                         */

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
void test_png_decoding(void **state)
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
void test_texture_budget(void **state)
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
void test_jpeg_textures(void **state)
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
void test_embedded_only(void **state)
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
