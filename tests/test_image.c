/* Images: PNG and OpenEXR files written by hand here (stored deflate blocks, uncompressed scanlines) read back
 * exactly; round trips through rto_image_write; the same bytes from two writes and two processes; refusals (missing,
 * directory, FIFO, empty, every truncation, corrupt data with valid CRCs, absurd sizes) with one line and nothing on
 * stderr; main(). One executable (unit.image) with test_image_compare.c (the metrics of rto_image_compare, idiff's
 * verdict rule, diff images, bundle entries). */
#define _GNU_SOURCE /* memmem */
#include "test_image.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdbool.h>
#include <sys/stat.h>
#include <unistd.h>

static char root[256];

static int setup(void **state)
{
    (void)state;
    return tu_tmpdir_make(root, sizeof root, "image");
}

static int teardown(void **state)
{
    (void)state;
    return tu_tmpdir_remove(root);
}

void path_in(char *out, size_t cap, const char *name) { snprintf(out, cap, "%s/%s", root, name); }

/* ---------------------------------------------------------------------------------------------------------------- */
/* Byte buffers and files */

static void put(bytes *b, const void *src, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = realloc(b->p, b->cap);
        assert_non_null(b->p);
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}
static void put8(bytes *b, unsigned v)
{
    unsigned char c = (unsigned char)v;
    put(b, &c, 1);
}
static void put_be32(bytes *b, uint32_t v)
{
    unsigned char c[4] = {(unsigned char)(v >> 24), (unsigned char)(v >> 16), (unsigned char)(v >> 8), (unsigned char)v};
    put(b, c, 4);
}
static void put_le32(bytes *b, uint32_t v)
{
    unsigned char c[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16), (unsigned char)(v >> 24)};
    put(b, c, 4);
}
static void put_str(bytes *b, const char *s) { put(b, s, strlen(s) + 1); }

void save(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(p, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

bytes load(const char *path)
{
    bytes b = {0};
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char buf[4096];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, f)) > 0)
        put(&b, buf, got);
    fclose(f);
    return b;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* A PNG writer of the tests' own (PNG spec §5, §9, §10; zlib RFC 1950 with stored deflate blocks, RFC 1951 §3.2.4):
 * no compression library, so what the reader returns is checked against bytes nothing else produced. */

static void png_chunk(bytes *b, const char *kind, const unsigned char *data, size_t n)
{
    put_be32(b, (uint32_t)n);
    size_t at = b->n;
    put(b, kind, 4);
    if (n)
        put(b, data, n);
    put_be32(b, tu_crc32_png(b->p + at, n + 4));
}

/* colour type by channels: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA; depth 8 or 16 (samples big-endian). */
static bytes hand_png(uint32_t w, uint32_t h, uint32_t c, int depth, const uint16_t *samples)
{
    static const unsigned char colour_type[5] = {0, 0, 4, 2, 6};
    bytes raw = {0}, z = {0}, out = {0};
    for (uint32_t y = 0; y < h; y++) {
        put8(&raw, 0); /* filter type None */
        for (uint32_t i = 0; i < w * c; i++) {
            uint16_t v = samples[(size_t)y * w * c + i];
            if (depth == 16)
                put8(&raw, v >> 8);
            put8(&raw, v & 0xFF);
        }
    }
    put8(&z, 0x78);
    put8(&z, 0x01);
    size_t at = 0;
    do {
        size_t n = raw.n - at > 65535 ? 65535 : raw.n - at;
        put8(&z, at + n == raw.n ? 1 : 0);
        put8(&z, n & 0xFF);
        put8(&z, n >> 8);
        put8(&z, ~n & 0xFF);
        put8(&z, (~n >> 8) & 0xFF);
        put(&z, raw.p + at, n);
        at += n;
    } while (at < raw.n);
    uint32_t s1 = 1, s2 = 0;
    for (size_t i = 0; i < raw.n; i++) {
        s1 = (s1 + raw.p[i]) % 65521;
        s2 = (s2 + s1) % 65521;
    }
    put_be32(&z, s2 << 16 | s1);
    put(&out, "\x89PNG\r\n\x1a\n", 8);
    bytes ihdr = {0};
    put_be32(&ihdr, w);
    put_be32(&ihdr, h);
    put8(&ihdr, (unsigned)depth);
    put8(&ihdr, colour_type[c]);
    put8(&ihdr, 0);
    put8(&ihdr, 0);
    put8(&ihdr, 0);
    png_chunk(&out, "IHDR", ihdr.p, ihdr.n);
    png_chunk(&out, "IDAT", z.p, z.n);
    png_chunk(&out, "IEND", NULL, 0);
    free(raw.p);
    free(z.p);
    free(ihdr.p);
    return out;
}

/* A single-part scanline OpenEXR file, compression NONE, FLOAT channels (the OpenEXR file layout document): channels
 * are stored in alphabetical order of their names, every scanline is "y, byte count, each channel's row". */
static bytes hand_exr(uint32_t w, uint32_t h, uint32_t c, const float *px, int32_t y0)
{
    static const char *const order[5][4] = {{0}, {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    static const char *const sorted[5][4] = {{0}, {"Y"}, {"A", "Y"}, {"B", "G", "R"}, {"A", "B", "G", "R"}};
    bytes b = {0}, ch = {0};
    put(&b, "\x76\x2f\x31\x01", 4);
    put_le32(&b, 2);
    for (uint32_t k = 0; k < c; k++) {
        put_str(&ch, sorted[c][k]);
        put_le32(&ch, 2); /* FLOAT */
        put_le32(&ch, 0); /* pLinear + reserved */
        put_le32(&ch, 1);
        put_le32(&ch, 1);
    }
    put8(&ch, 0);
    int32_t win[4] = {0, y0, (int32_t)w - 1, y0 + (int32_t)h - 1};
    float one = 1, zero = 0;
    uint32_t bits;
    put_str(&b, "channels");
    put_str(&b, "chlist");
    put_le32(&b, (uint32_t)ch.n);
    put(&b, ch.p, ch.n);
    put_str(&b, "compression");
    put_str(&b, "compression");
    put_le32(&b, 1);
    put8(&b, 0);
    const char *windows[2] = {"dataWindow", "displayWindow"};
    for (int i = 0; i < 2; i++) {
        put_str(&b, windows[i]);
        put_str(&b, "box2i");
        put_le32(&b, 16);
        for (int k = 0; k < 4; k++)
            put_le32(&b, (uint32_t)win[k]);
    }
    put_str(&b, "lineOrder");
    put_str(&b, "lineOrder");
    put_le32(&b, 1);
    put8(&b, 0);
    put_str(&b, "pixelAspectRatio");
    put_str(&b, "float");
    put_le32(&b, 4);
    memcpy(&bits, &one, 4);
    put_le32(&b, bits);
    put_str(&b, "screenWindowCenter");
    put_str(&b, "v2f");
    put_le32(&b, 8);
    memcpy(&bits, &zero, 4);
    put_le32(&b, bits);
    put_le32(&b, bits);
    put_str(&b, "screenWindowWidth");
    put_str(&b, "float");
    put_le32(&b, 4);
    memcpy(&bits, &one, 4);
    put_le32(&b, bits);
    put8(&b, 0);
    const size_t line_bytes = 8 + (size_t)w * c * 4;
    uint64_t offset = b.n + 8 * (uint64_t)h;
    for (uint32_t y = 0; y < h; y++, offset += line_bytes) {
        put_le32(&b, (uint32_t)offset);
        put_le32(&b, (uint32_t)(offset >> 32));
    }
    for (uint32_t y = 0; y < h; y++) {
        put_le32(&b, (uint32_t)(y0 + (int32_t)y));
        put_le32(&b, (uint32_t)(w * c * 4));
        for (uint32_t k = 0; k < c; k++) {
            uint32_t src = 0;
            while (strcmp(order[c][src], sorted[c][k]))
                src++;
            for (uint32_t x = 0; x < w; x++) {
                memcpy(&bits, &px[((size_t)y * w + x) * c + src], 4);
                put_le32(&b, bits);
            }
        }
    }
    free(ch.p);
    return b;
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* stderr goes to a file while f runs; returns what was written there (the library must print nothing). */
static size_t stderr_bytes_during(void (*f)(void *), void *ctx)
{
    char path[300];
    path_in(path, sizeof path, "stderr.txt");
    fflush(stderr);
    int saved = dup(2), fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    f(ctx);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (size_t)st.st_size;
}

static void one_line(const rto_msg *m)
{
    assert_true(m->text[0] != '\0');
    assert_null(strchr(m->text, '\n'));
}

rto_image make_u8(uint32_t w, uint32_t h, uint32_t c)
{
    rto_image im = {w, h, c, RTO_PIXEL_U8, malloc((size_t)w * h * c)};
    assert_non_null(im.pixels);
    unsigned char *p = im.pixels;
    for (size_t i = 0; i < (size_t)w * h * c; i++)
        p[i] = (unsigned char)((i * 37 + 11) % 256);
    return im;
}

rto_image make_f32(uint32_t w, uint32_t h, uint32_t c)
{
    rto_image im = {w, h, c, RTO_PIXEL_F32, malloc((size_t)w * h * c * 4)};
    assert_non_null(im.pixels);
    float *p = im.pixels;
    for (size_t i = 0; i < (size_t)w * h * c; i++)
        p[i] = (float)((double)((i * 7919) % 1000) / 997.0 - 0.25);
    return im;
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* Writes a hand-made file to path (freeing its bytes), reads it with rto_image_read and checks its header. */
static void read_back(const char *path, bytes b, uint32_t w, uint32_t h, uint32_t c, rto_pixel_type t, rto_image *im)
{
    save(path, b.p, b.n);
    free(b.p);
    rto_msg msg = {{0}};
    assert_int_equal(rto_image_read(path, im, &msg), RTO_OK);
    assert_int_equal(im->width, w);
    assert_int_equal(im->height, h);
    assert_int_equal(im->channels, c);
    assert_int_equal(im->type, t);
}

/* Hand-made PNGs: every channel count, 8 and 16 bits, read back value for value. */
static void test_reads_hand_made_png(void **state)
{
    (void)state;
    char path[300];
    path_in(path, sizeof path, "hand.png");
    for (uint32_t c = 1; c <= 4; c++)
        for (int depth = 8; depth <= 16; depth += 8) {
            const uint32_t w = 7, h = 5;
            uint16_t s[7 * 5 * 4];
            for (uint32_t i = 0; i < w * h * c; i++)
                s[i] = (uint16_t)(depth == 8 ? (i * 53 + c) % 256 : (i * 40503u + c) % 65536);
            rto_image im;
            read_back(path, hand_png(w, h, c, depth, s), w, h, c, depth == 8 ? RTO_PIXEL_U8 : RTO_PIXEL_F32, &im);
            for (uint32_t i = 0; i < w * h * c; i++) {
                if (depth == 8)
                    assert_int_equal(((unsigned char *)im.pixels)[i], s[i]);
                else
                    assert_true(((float *)im.pixels)[i] == (float)(s[i] / 65535.0));
            }
            rto_image_free(&im);
            assert_null(im.pixels);
        }
}

/* A hand-made OpenEXR (channels stored A, B, G, R) comes back as R, G, B, A, bit for bit, a non-zero data window
 * origin included. */
static void test_reads_hand_made_exr(void **state)
{
    (void)state;
    char path[300];
    path_in(path, sizeof path, "hand.exr");
    for (uint32_t c = 1; c <= 4; c++) {
        const uint32_t w = 6, h = 4;
        float px[6 * 4 * 4];
        for (uint32_t i = 0; i < w * h * c; i++)
            px[i] = (float)i * 0.125f - 1.5f + (float)c;
        px[1] = INFINITY;
        rto_image im;
        read_back(path, hand_exr(w, h, c, px, c == 3 ? 10 : 0), w, h, c, RTO_PIXEL_F32, &im);
        assert_memory_equal(im.pixels, px, (size_t)w * h * c * 4);
        rto_image_free(&im);
    }
}

/* Written, then read: the same pixels (8-bit alpha 0 and 128 kept as stored, not divided; NaN, infinities, -0 and
 * subnormals kept in float), for every channel count and a size over several ZIP blocks. */
static void test_round_trips(void **state)
{
    (void)state;
    char png[300], exr[300];
    path_in(png, sizeof png, "rt.png");
    path_in(exr, sizeof exr, "rt.exr");
    for (uint32_t c = 1; c <= 4; c++) {
        rto_image a = make_u8(67, 33, c), f = make_f32(67, 33, c), back;
        unsigned char *p = a.pixels;
        p[c - 1] = 0; /* alpha 0 (for 2 and 4 channels) over colour that must survive */
        p[2 * c - 1] = 128;
        float *q = f.pixels;
        q[0] = NAN;
        q[1] = INFINITY;
        q[2 % (67 * 33 * c)] = -INFINITY;
        q[3] = -0.0f;
        q[4] = 1e-40f;
        rto_msg msg = {{0}};
        assert_int_equal(rto_image_write(png, &a, &msg), RTO_OK);
        assert_int_equal(rto_image_read(png, &back, &msg), RTO_OK);
        assert_int_equal(back.type, RTO_PIXEL_U8);
        assert_int_equal(back.channels, c);
        assert_memory_equal(back.pixels, a.pixels, (size_t)67 * 33 * c);
        rto_image_free(&back);
        assert_int_equal(rto_image_write(exr, &f, &msg), RTO_OK);
        assert_int_equal(rto_image_read(exr, &back, &msg), RTO_OK);
        assert_int_equal(back.type, RTO_PIXEL_F32);
        assert_int_equal(back.channels, c);
        const float *r = back.pixels;
        assert_true(isnan(r[0]));
        assert_memory_equal(r + 1, q + 1, ((size_t)67 * 33 * c - 1) * 4);
        rto_image_free(&back);
        rto_image_free(&a);
        rto_image_free(&f);
    }
}

/* What a PNG's chunks and an OpenEXR header's attributes are called: nothing that could vary (tIME, text, software),
 * and OpenEXR's capDate (OpenImageIO always writes one) is the fixed epoch. */
static void check_no_varying_metadata(const bytes *pngb, const bytes *exrb)
{
    for (size_t at = 8; at + 12 <= pngb->n;) {
        uint32_t n = (uint32_t)pngb->p[at] << 24 | (uint32_t)pngb->p[at + 1] << 16 | (uint32_t)pngb->p[at + 2] << 8 |
                     pngb->p[at + 3];
        const char *kind = (const char *)pngb->p + at + 4;
        assert_true(!memcmp(kind, "IHDR", 4) || !memcmp(kind, "IDAT", 4) || !memcmp(kind, "IEND", 4) ||
                    !memcmp(kind, "oFFs", 4));
        at += 12 + (size_t)n;
    }
    const char *allowed[] = {"capDate", "channels", "compression", "dataWindow", "displayWindow", "lineOrder",
                             "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth"};
    size_t at = 8;
    for (;;) {
        const char *name = (const char *)exrb->p + at;
        if (!*name)
            break;
        const char *type = name + strlen(name) + 1;
        const unsigned char *sz = (const unsigned char *)type + strlen(type) + 1;
        uint32_t n = sz[0] | (uint32_t)sz[1] << 8 | (uint32_t)sz[2] << 16 | (uint32_t)sz[3] << 24;
        bool ok = false;
        for (size_t i = 0; i < sizeof allowed / sizeof allowed[0]; i++)
            ok |= !strcmp(name, allowed[i]);
        if (!ok)
            fail_msg("unexpected OpenEXR attribute '%s'", name);
        if (!strcmp(name, "capDate")) {
            assert_int_equal(n, 19);
            assert_memory_equal(sz + 4, "1970:01:01 00:00:00", 19);
        }
        at = (size_t)(sz + 4 + n - exrb->p);
    }
}

/* The images test_same_bytes writes, the same in every process. */
static void write_pair(const char *png, const char *exr)
{
    rto_image a = make_u8(40, 30, 4), f = make_f32(40, 30, 4);
    assert_int_equal(rto_image_write(png, &a, NULL), RTO_OK);
    assert_int_equal(rto_image_write(exr, &f, NULL), RTO_OK);
    rto_image_free(&a);
    rto_image_free(&f);
}

/* The same image gives the same bytes: twice in one process, and in another process started later (this program
 * run again with --write; a fork would inherit OpenEXR's thread pool without its threads). */
static void test_same_bytes(void **state)
{
    (void)state;
    char png[2][300], exr[2][300], cmd[1000];
    path_in(png[0], 300, "a.png");
    path_in(png[1], 300, "b.png");
    path_in(exr[0], 300, "a.exr");
    path_in(exr[1], 300, "b.exr");
    write_pair(png[0], exr[0]);
    sleep(1); /* a timestamp would now differ */
    snprintf(cmd, sizeof cmd, "/proc/%d/exe --write '%s' '%s'", (int)getpid(), png[1], exr[1]);
    assert_int_equal(system(cmd), 0);
    bytes p0 = load(png[0]), p1 = load(png[1]), e0 = load(exr[0]), e1 = load(exr[1]);
    assert_int_equal(p0.n, p1.n);
    assert_memory_equal(p0.p, p1.p, p0.n);
    assert_int_equal(e0.n, e1.n);
    assert_memory_equal(e0.p, e1.p, e0.n);
    check_no_varying_metadata(&p0, &e0);
    /* and again in this process, over the first files */
    write_pair(png[0], exr[0]);
    bytes p2 = load(png[0]), e2 = load(exr[0]);
    assert_memory_equal(p0.p, p2.p, p0.n);
    assert_memory_equal(e0.p, e2.p, e0.n);
    free(p0.p), free(p1.p), free(e0.p), free(e1.p), free(p2.p), free(e2.p);
}

/* Writing follows rto_file_write: a regular file replaced, a link followed, a directory or FIFO refused and left as
 * it was, no temporary left; a format that does not hold the pixel type refused before anything is written. */
static void test_write_rules(void **state)
{
    (void)state;
    char path[300], dir[300], fifo[300], link[300], txt[300];
    path_in(path, sizeof path, "x.png");
    path_in(dir, sizeof dir, "d.png");
    path_in(fifo, sizeof fifo, "f.png");
    path_in(link, sizeof link, "l.png");
    path_in(txt, sizeof txt, "x.tif");
    rto_image a = make_u8(5, 4, 3), f = make_f32(5, 4, 3), back;
    rto_msg msg = {{0}};
    save(path, "old", 3);
    assert_int_equal(rto_image_write(path, &a, &msg), RTO_OK);
    assert_int_equal(rto_image_read(path, &back, &msg), RTO_OK);
    rto_image_free(&back);
    assert_int_equal(symlink("x.png", link), 0);
    assert_int_equal(rto_image_write(link, &a, &msg), RTO_OK);
    struct stat st;
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_int_equal(mkdir(dir, 0777), 0);
    assert_int_equal(rto_image_write(dir, &a, &msg), RTO_ERR_IO);
    one_line(&msg);
    assert_int_equal(mkfifo(fifo, 0666), 0);
    assert_int_equal(rto_image_write(fifo, &a, &msg), RTO_ERR_IO);
    one_line(&msg);
    assert_int_equal(rto_image_write(path, &f, &msg), RTO_ERR_INVALID_ARGUMENT); /* float into PNG */
    one_line(&msg);
    char e[300];
    path_in(e, sizeof e, "y.exr");
    assert_int_equal(rto_image_write(e, &a, &msg), RTO_ERR_INVALID_ARGUMENT); /* 8-bit into OpenEXR */
    assert_int_equal(rto_image_write(txt, &a, &msg), RTO_ERR_UNSUPPORTED);
    rto_image bad = a;
    bad.channels = 5;
    assert_int_equal(rto_image_write(path, &bad, &msg), RTO_ERR_INVALID_ARGUMENT);
    bad = a;
    bad.width = 1u << 20;
    bad.height = 1u << 9;
    assert_int_equal(rto_image_write(path, &bad, &msg), RTO_ERR_UNSUPPORTED); /* 2^29 pixels */
    assert_int_equal(tu_dir_entries(root), 4); /* x.png, l.png, d.png, f.png: nothing else, no temporary */
    assert_int_equal(lstat(dir, &st), 0);
    assert_true(S_ISDIR(st.st_mode));
    rto_image_free(&a);
    rto_image_free(&f);
}

typedef struct refusal {
    const char *path;
    rto_status got;
    rto_msg msg;
} refusal;

static void read_one(void *ctx)
{
    refusal *r = ctx;
    rto_image im = {1, 1, 1, RTO_PIXEL_U8, NULL};
    r->got = rto_image_read(r->path, &im, &r->msg);
    if (r->got == RTO_OK)
        rto_image_free(&im);
    else
        assert_null(im.pixels);
}

static void expect_refused(const char *path, rto_status want)
{
    refusal r = {path, RTO_OK, {{0}}};
    size_t printed = stderr_bytes_during(read_one, &r);
    if (r.got == RTO_OK)
        fail_msg("%s was read", path);
    if (want != RTO_OK && r.got != want)
        fail_msg("%s: status %d (want %d): %s", path, (int)r.got, (int)want, r.msg.text);
    one_line(&r.msg);
    assert_int_equal(printed, 0);
}

/* Every prefix of a PNG and of an OpenEXR file is refused (one line, nothing printed), as are missing files,
 * directories, FIFOs, empty files and a corrupt zlib stream whose CRCs are right. */
static void test_read_refusals(void **state)
{
    (void)state;
    char path[300], cut[300], fifo[300];
    path_in(path, sizeof path, "ok.png");
    path_in(cut, sizeof cut, "cut.png");
    path_in(fifo, sizeof fifo, "fifo.png");
    rto_image a = make_u8(9, 7, 4);
    assert_int_equal(rto_image_write(path, &a, NULL), RTO_OK);
    bytes b = load(path);
    for (size_t n = 1; n < b.n; n++) {
        save(cut, b.p, n);
        expect_refused(cut, RTO_ERR_PARSE);
    }
    save(cut, "", 0);
    expect_refused(cut, RTO_ERR_PARSE);
    /* a flipped bit in the compressed data, its chunk's CRC recomputed: libpng's inflate finds it */
    size_t idat = 8;
    while (memcmp(b.p + idat + 4, "IDAT", 4))
        idat += 12 + ((size_t)b.p[idat] << 24 | (size_t)b.p[idat + 1] << 16 | (size_t)b.p[idat + 2] << 8 |
                      b.p[idat + 3]);
    uint32_t n = (uint32_t)b.p[idat] << 24 | (uint32_t)b.p[idat + 1] << 16 | (uint32_t)b.p[idat + 2] << 8 |
                 b.p[idat + 3];
    b.p[idat + 8 + 2] ^= 0xFF;
    uint32_t crc = tu_crc32_png(b.p + idat + 4, (size_t)n + 4);
    unsigned char be[4] = {(unsigned char)(crc >> 24), (unsigned char)(crc >> 16), (unsigned char)(crc >> 8),
                           (unsigned char)crc};
    memcpy(b.p + idat + 8 + n, be, 4);
    save(cut, b.p, b.n);
    expect_refused(cut, RTO_ERR_PARSE);
    free(b.p);

    float px[4 * 3 * 3];
    for (int i = 0; i < 36; i++)
        px[i] = (float)i;
    bytes e = hand_exr(4, 3, 3, px, 0);
    path_in(cut, sizeof cut, "cut.exr");
    for (size_t k = 1; k < e.n; k++) {
        save(cut, e.p, k);
        expect_refused(cut, RTO_OK);
    }
    free(e.p);

    char missing[300];
    path_in(missing, sizeof missing, "missing.png");
    expect_refused(missing, RTO_ERR_IO);
    expect_refused(root, RTO_ERR_IO);
    assert_int_equal(mkfifo(fifo, 0666), 0);
    expect_refused(fifo, RTO_ERR_IO); /* at once: no writer is ever opened */
    expect_refused("/dev/zero", RTO_ERR_IO);
    rto_image_free(&a);
}

/* Headers claiming more than 2^28 pixels are refused from the header, before anything image-sized is allocated
 * (the files are a few hundred bytes; a read would need gigabytes). */
static void test_absurd_sizes(void **state)
{
    (void)state;
    char path[300];
    path_in(path, sizeof path, "huge.png");
    uint16_t s[4] = {1, 2, 3, 4};
    bytes b = hand_png(1, 1, 1, 8, s);
    /* IHDR width and height (bytes 16..23) rewritten to 2^15 x 2^14 = 2^29 pixels, CRC recomputed */
    const unsigned char wh[8] = {0, 0, 0x80, 0, 0, 0, 0x40, 0};
    memcpy(b.p + 16, wh, 8);
    uint32_t crc = tu_crc32_png(b.p + 12, 17);
    unsigned char be[4] = {(unsigned char)(crc >> 24), (unsigned char)(crc >> 16), (unsigned char)(crc >> 8),
                           (unsigned char)crc};
    memcpy(b.p + 29, be, 4);
    save(path, b.p, b.n);
    expect_refused(path, RTO_ERR_UNSUPPORTED);
    free(b.p);

    float px[3] = {1, 2, 3};
    bytes e = hand_exr(1, 1, 3, px, 0);
    /* dataWindow's xMax, yMax (after "dataWindow\0box2i\0" and the size) set to 2^20 - 1 and 2^30 */
    path_in(path, sizeof path, "huge.exr");
    const char key[] = "dataWindow\0box2i";
    unsigned char *at = memmem(e.p, e.n, key, sizeof key);
    assert_non_null(at);
    at += sizeof key + 4;
    const int32_t big[4] = {0, 0, (1 << 20) - 1, 1 << 30};
    memcpy(at, big, 16); /* little-endian host, as the file */
    save(path, e.p, e.n);
    expect_refused(path, RTO_ERR_UNSUPPORTED);
    /* exactly at the limit in pixels but with an inverted window: corrupt */
    const int32_t inverted[4] = {0, 5, 0, 2};
    memcpy(at, inverted, 16);
    save(path, e.p, e.n);
    expect_refused(path, RTO_ERR_PARSE);
    free(e.p);
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "--write")) { /* test_same_bytes's second process */
        write_pair(argv[2], argv[3]);
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_reads_hand_made_png, setup, teardown),
        cmocka_unit_test_setup_teardown(test_reads_hand_made_exr, setup, teardown),
        cmocka_unit_test_setup_teardown(test_round_trips, setup, teardown),
        cmocka_unit_test_setup_teardown(test_same_bytes, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_rules, setup, teardown),
        cmocka_unit_test_setup_teardown(test_read_refusals, setup, teardown),
        cmocka_unit_test_setup_teardown(test_absurd_sizes, setup, teardown),
        cmocka_unit_test(test_one_pixel_off),
        cmocka_unit_test(test_metrics_against_reference),
        cmocka_unit_test(test_verdicts),
        cmocka_unit_test(test_non_finite),
        cmocka_unit_test(test_size_mismatch),
        cmocka_unit_test_setup_teardown(test_diff_image, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bundle_images, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
