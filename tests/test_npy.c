/* .npy reader and writer: round trips, byte-exact numpy headers, and refusal of malformed or unsupported files.
 * Expected bytes are written out by hand from the NumPy format spec (numpy.lib.format), never produced by the
 * writer under test. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, opendir */

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include "rtoracle.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char tmpdir[64];

static int make_tmpdir(void **state)
{
    (void)state;
    strcpy(tmpdir, "/tmp/rto_test_npy_XXXXXX");
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int remove_tmpdir(void **state)
{
    (void)state;
    DIR *dir = opendir(tmpdir);
    if (!dir)
        return -1;
    struct dirent *e;
    char path[512];
    while ((e = readdir(dir)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", tmpdir, e->d_name);
        remove(path);
    }
    closedir(dir);
    return rmdir(tmpdir);
}

static void tmp_path(char *buf, size_t cap, const char *name) { snprintf(buf, cap, "%s/%s", tmpdir, name); }

/* Whole file into a malloc block. */
static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    assert_int_equal(fseek(fp, 0, SEEK_END), 0);
    long n = ftell(fp);
    assert_true(n >= 0);
    rewind(fp);
    unsigned char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, fp), (size_t)n);
    fclose(fp);
    *len = (size_t)n;
    return buf;
}

/* A .npy file around a hand-written header: magic, version, little-endian length, header text, data. */
static unsigned char *make_npy(unsigned major, const char *header, const void *data, size_t ndata, size_t *len)
{
    size_t hlen = strlen(header);
    size_t pre = major == 1 ? 10 : 12;
    unsigned char *buf = malloc(pre + hlen + ndata + 1);
    assert_non_null(buf);
    memcpy(buf, "\x93NUMPY", 6);
    buf[6] = (unsigned char)major;
    buf[7] = 0;
    for (size_t i = 0; i < pre - 8; i++)
        buf[8 + i] = (unsigned char)(hlen >> (8 * i));
    memcpy(buf + pre, header, hlen);
    if (ndata)
        memcpy(buf + pre + hlen, data, ndata);
    *len = pre + hlen + ndata;
    return buf;
}

/* Parses header + data (version 1.0) and returns the status; msg gets the reason. */
static rto_status parse_header_text(const char *header, const void *data, size_t ndata, rto_msg *msg)
{
    size_t len;
    unsigned char *buf = make_npy(1, header, data, ndata, &len);
    rto_npy npy;
    rto_status s = rto_npy_parse(buf, len, &npy, msg);
    free(buf);
    if (s == RTO_OK)
        rto_npy_free(&npy);
    else
        assert_true(msg->text[0] != '\0');
    return s;
}

static void assert_refused(const char *header, const void *data, size_t ndata, rto_status want, const char *substr)
{
    rto_msg msg = {{0}};
    rto_status s = parse_header_text(header, data, ndata, &msg);
    if (s != want || !strstr(msg.text, substr))
        print_error("header %s\n  status %d (want %d), message: %s\n  (want substring: %s)\n", header, (int)s,
                    (int)want, msg.text, substr);
    assert_int_equal(s, want);
    assert_non_null(strstr(msg.text, substr));
}

static void assert_desc_equal(const rto_npy_desc *a, const rto_npy_desc *b)
{
    assert_int_equal(a->dtype, b->dtype);
    assert_int_equal(a->ndim, b->ndim);
    for (uint32_t i = 0; i < a->ndim; i++)
        assert_int_equal(a->shape[i], b->shape[i]);
    if (a->dtype != RTO_DTYPE_STRUCT)
        return;
    assert_int_equal(a->nfields, b->nfields);
    for (uint32_t i = 0; i < a->nfields; i++) {
        assert_string_equal(a->fields[i].name, b->fields[i].name);
        assert_int_equal(a->fields[i].type, b->fields[i].type);
        assert_int_equal(a->fields[i].count, b->fields[i].count);
        assert_int_equal(a->fields[i].offset, b->fields[i].offset);
    }
}

#define SP10 "          "
#define SP20 SP10 SP10
#define SP60 SP20 SP20 SP20

/* numpy.save(np.array([1, 2, 3], '<u4')): the 57-character dict, 20 growth-axis spaces (21 - len("3")), then 40
 * spaces and '\n' so that 10 + 57 + 20 + 40 + 1 = 128; header length 118 = 0x76. */
static const char u32_3_file[] = "\x93NUMPY\x01\x00\x76\x00"
                                 "{'descr': '<u4', 'fortran_order': False, 'shape': (3,), }" SP60 "\n"
                                 "\x01\x00\x00\x00\x02\x00\x00\x00\x03\x00\x00\x00";

/* ---------------------------------------------------------------------------------------------------------------- */

static void test_sizes_and_counts(void **state)
{
    (void)state;
    assert_int_equal(rto_dtype_size(RTO_DTYPE_U8), 1);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_U32), 4);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_U64), 8);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_I32), 4);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_F32), 4);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_NONE), 0);
    assert_int_equal(rto_dtype_size(RTO_DTYPE_STRUCT), 0);

    int ok = -1;
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_F32, 0, 0, 0, 0);
    assert_int_equal(rto_npy_count(&d, &ok), 1);
    assert_int_equal(ok, 1);
    d = rto_npy_desc_array(RTO_DTYPE_F32, 3, 2, 3, 4);
    assert_int_equal(rto_npy_count(&d, &ok), 24);
    assert_int_equal(rto_npy_itemsize(&d), 4);
    d = rto_npy_desc_array(RTO_DTYPE_U8, 2, UINT64_C(1) << 40, UINT64_C(1) << 40, 0);
    assert_int_equal(rto_npy_count(&d, &ok), 0);
    assert_int_equal(ok, 0);
    /* An empty dimension makes the array empty, not overflowing. */
    d = rto_npy_desc_array(RTO_DTYPE_U8, 3, UINT64_MAX, UINT64_MAX, 0);
    assert_int_equal(rto_npy_count(&d, &ok), 0);
    assert_int_equal(ok, 1);

    d = rto_npy_desc_keys(RTO_KEY_U64, 7);
    assert_int_equal(d.dtype, RTO_DTYPE_U64);
    assert_int_equal(d.ndim, 1);
    assert_int_equal(d.shape[0], 7);
    assert_int_equal(rto_npy_itemsize(&d), 8);
}

static void test_roundtrip_scalars(void **state)
{
    (void)state;
    const rto_npy_desc descs[] = {
        rto_npy_desc_array(RTO_DTYPE_U8, 1, 13, 0, 0),   rto_npy_desc_array(RTO_DTYPE_U32, 2, 3, 5, 0),
        rto_npy_desc_array(RTO_DTYPE_U64, 1, 9, 0, 0),   rto_npy_desc_array(RTO_DTYPE_I32, 3, 2, 3, 4),
        rto_npy_desc_array(RTO_DTYPE_F32, 0, 0, 0, 0),   rto_npy_desc_array(RTO_DTYPE_F32, 1, 0, 0, 0),
        rto_npy_desc_keys(RTO_KEY_U32, 1000),
    };
    for (size_t k = 0; k < sizeof descs / sizeof descs[0]; k++) {
        const rto_npy_desc *d = &descs[k];
        int ok = 0;
        size_t nbytes = (size_t)rto_npy_count(d, &ok) * rto_npy_itemsize(d);
        assert_true(ok);
        unsigned char *data = malloc(nbytes + 1);
        assert_non_null(data);
        for (size_t i = 0; i < nbytes; i++)
            data[i] = (unsigned char)(i * 131u + k * 7u + 1u);
        char path[256];
        char name[32];
        snprintf(name, sizeof name, "scalar%zu.npy", k);
        tmp_path(path, sizeof path, name);
        rto_msg msg = {{0}};
        assert_int_equal(rto_npy_write(path, d, data, &msg), RTO_OK);
        rto_npy npy;
        assert_int_equal(rto_npy_read(path, &npy, &msg), RTO_OK);
        assert_desc_equal(&npy.desc, d);
        assert_int_equal(npy.nbytes, nbytes);
        if (nbytes)
            assert_memory_equal(npy.data, data, nbytes);
        rto_npy_free(&npy);
        free(data);
    }
}

static rto_npy_desc struct_desc(void)
{
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_STRUCT, 1, 6, 0, 0);
    const struct {
        const char *name;
        rto_dtype type;
        uint32_t count;
    } f[] = {{"key", RTO_DTYPE_U32, 1}, {"min", RTO_DTYPE_F32, 3}, {"id", RTO_DTYPE_U64, 1}, {"flag", RTO_DTYPE_U8, 1},
             {"delta", RTO_DTYPE_I32, 2}};
    uint32_t offset = 0;
    d.nfields = sizeof f / sizeof f[0];
    for (uint32_t i = 0; i < d.nfields; i++) {
        strcpy(d.fields[i].name, f[i].name);
        d.fields[i].type = f[i].type;
        d.fields[i].count = f[i].count;
        d.fields[i].offset = offset;
        offset += f[i].count * (uint32_t)rto_dtype_size(f[i].type);
    }
    return d;
}

static void test_roundtrip_struct(void **state)
{
    (void)state;
    rto_npy_desc d = struct_desc();
    assert_int_equal(rto_npy_itemsize(&d), 4 + 12 + 8 + 1 + 8);
    char descr[256];
    assert_int_equal(rto_npy_descr(&d, descr, sizeof descr), RTO_OK);
    assert_string_equal(descr, "[('key', '<u4'), ('min', '<f4', (3,)), ('id', '<u8'), ('flag', '|u1'), "
                               "('delta', '<i4', (2,))]");
    /* Too small by one: the terminator does not fit. */
    assert_int_equal(rto_npy_descr(&d, descr, strlen(descr)), RTO_ERR_BUFFER_TOO_SMALL);

    size_t nbytes = 6 * rto_npy_itemsize(&d);
    unsigned char data[6 * 33];
    assert_int_equal(nbytes, sizeof data);
    for (size_t i = 0; i < nbytes; i++)
        data[i] = (unsigned char)(255 - i);
    char path[256];
    tmp_path(path, sizeof path, "struct.npy");
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_OK);
    rto_npy npy;
    assert_int_equal(rto_npy_read(path, &npy, &msg), RTO_OK);
    assert_desc_equal(&npy.desc, &d);
    assert_int_equal(npy.nbytes, nbytes);
    assert_memory_equal(npy.data, data, nbytes);
    rto_npy_free(&npy);

    /* And the header text numpy writes for it. */
    size_t len;
    unsigned char *file = slurp(path, &len);
    const char *want = "{'descr': [('key', '<u4'), ('min', '<f4', (3,)), ('id', '<u8'), ('flag', '|u1'), "
                       "('delta', '<i4', (2,))], 'fortran_order': False, 'shape': (6,), }" SP20 "\n";
    /* 10 + 146-character dict + 20 growth spaces + '\n' = 177; padded to 192 with 15 more spaces. */
    assert_int_equal(len, 192 + nbytes);
    assert_int_equal(file[8] | file[9] << 8, 182);
    size_t dict_len = strlen(want) - 21;
    assert_int_equal(dict_len, 146);
    assert_memory_equal(file + 10, want, dict_len + 20);
    for (size_t i = 10 + dict_len; i < 191; i++)
        assert_int_equal(file[i], ' ');
    assert_int_equal(file[191], '\n');
    free(file);
}

static void test_header_bytes_match_numpy(void **state)
{
    (void)state;
    /* numpy.save(np.arange(5, dtype='<u4')), from the spec: magic, version 1.0, HEADER_LEN 118 (u16 LE), the
     * dict with keys sorted, 21 - len("5") growth spaces, 40 alignment spaces, '\n', then 5 little-endian words. */
    static const char want[] = "\x93NUMPY\x01\x00\x76\x00"
                               "{'descr': '<u4', 'fortran_order': False, 'shape': (5,), }" SP60 "\n"
                               "\x00\x00\x00\x00\x01\x00\x00\x00\x02\x00\x00\x00\x03\x00\x00\x00\x04\x00\x00\x00";
    assert_int_equal(sizeof want - 1, 128 + 20);
    uint32_t data[5] = {0, 1, 2, 3, 4};
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 5);
    char path[256];
    tmp_path(path, sizeof path, "exact.npy");
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_OK);
    size_t len;
    unsigned char *file = slurp(path, &len);
    assert_int_equal(len, sizeof want - 1);
    assert_memory_equal(file, want, len);
    free(file);
}

/* The preamble length of a written file, checked for alignment and a closing newline. */
static size_t written_preamble(const rto_npy_desc *d, const char *name)
{
    int ok = 0;
    size_t nbytes = (size_t)rto_npy_count(d, &ok) * rto_npy_itemsize(d);
    assert_true(ok);
    void *data = calloc(nbytes + 1, 1);
    assert_non_null(data);
    char path[256];
    tmp_path(path, sizeof path, name);
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_write(path, d, data, &msg), RTO_OK);
    free(data);
    size_t len;
    unsigned char *file = slurp(path, &len);
    assert_true(len >= 10);
    assert_memory_equal(file, "\x93NUMPY\x01\x00", 8);
    size_t pre = 10 + (size_t)(file[8] | file[9] << 8);
    assert_int_equal(pre % 64, 0);
    assert_int_equal(len, pre + nbytes);
    assert_int_equal(file[pre - 1], '\n');
    free(file);
    return pre;
}

static void test_preamble_alignment(void **state)
{
    (void)state;
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_F32, 0, 0, 0, 0);
    /* "{'descr': '<f4', 'fortran_order': False, 'shape': (), }": 55 characters, no growth axis; 10 + 55 + 1 = 66. */
    assert_int_equal(written_preamble(&d, "a0.npy"), 128);
    d = rto_npy_desc_array(RTO_DTYPE_U64, 3, 12, 345, 6789);
    assert_int_equal(written_preamble(&d, "a1.npy"), 128);
    d = rto_npy_desc_array(RTO_DTYPE_U8, 2, 4294967296ull, 0, 0);
    assert_int_equal(written_preamble(&d, "a2.npy"), 128);
    d = struct_desc();
    assert_int_equal(written_preamble(&d, "a3.npy"), 192);

    /* [('f0', '<u4'), ('xxxxxxxxxxxxxxxxx', '<u4')] with shape (0,) gives a 97-character dict, so 10 + 97 + 20 + 1
     * is already 128: numpy still pads by a full 64 bytes (padlen = 64 - 128 % 64), making 192. */
    memset(&d, 0, sizeof d);
    d.dtype = RTO_DTYPE_STRUCT;
    d.ndim = 1;
    d.nfields = 2;
    strcpy(d.fields[0].name, "f0");
    d.fields[0].type = RTO_DTYPE_U32;
    d.fields[0].count = 1;
    strcpy(d.fields[1].name, "xxxxxxxxxxxxxxxxx");
    d.fields[1].type = RTO_DTYPE_U32;
    d.fields[1].count = 1;
    d.fields[1].offset = 4;
    assert_int_equal(written_preamble(&d, "a4.npy"), 192);
}

static void test_parse_hand_built(void **state)
{
    (void)state;
    rto_npy npy;
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_parse(u32_3_file, sizeof u32_3_file - 1, &npy, &msg), RTO_OK);
    assert_int_equal(npy.desc.dtype, RTO_DTYPE_U32);
    assert_int_equal(npy.desc.ndim, 1);
    assert_int_equal(npy.desc.shape[0], 3);
    assert_int_equal(npy.nbytes, 12);
    const uint32_t want[3] = {1, 2, 3};
    assert_memory_equal(npy.data, want, sizeof want);
    /* The data is a copy, not a view into the input. */
    assert_true((const char *)npy.data < u32_3_file || (const char *)npy.data >= u32_3_file + sizeof u32_3_file);
    rto_npy_free(&npy);
    assert_null(npy.data);
    assert_int_equal(npy.nbytes, 0);
    assert_int_equal(npy.desc.dtype, RTO_DTYPE_NONE);
}

static void test_truncation_sweep(void **state)
{
    (void)state;
    size_t len = sizeof u32_3_file - 1;
    assert_int_equal(len, 140);
    for (size_t n = 0; n < len; n++) {
        /* A fresh exact-size copy so that ASan catches any read past the prefix. */
        unsigned char *prefix = malloc(n ? n : 1);
        assert_non_null(prefix);
        memcpy(prefix, u32_3_file, n);
        rto_npy npy;
        rto_msg msg = {{0}};
        rto_status s = rto_npy_parse(prefix, n, &npy, &msg);
        free(prefix);
        if (s == RTO_OK)
            print_error("prefix of %zu bytes was accepted\n", n);
        assert_int_equal(s, RTO_ERR_PARSE);
        assert_true(msg.text[0] != '\0');
        assert_null(npy.data);
        if (n >= 128)
            assert_non_null(strstr(msg.text, "truncated: header says 3 elements (12 bytes)"));
        else
            assert_true(strstr(msg.text, "truncated") != NULL);
    }
    rto_npy npy;
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_parse(u32_3_file, 137, &npy, &msg), RTO_ERR_PARSE);
    assert_string_equal(msg.text, "truncated: header says 3 elements (12 bytes) but 9 data bytes follow");
}

static void test_bad_magic(void **state)
{
    (void)state;
    unsigned char buf[sizeof u32_3_file];
    memcpy(buf, u32_3_file, sizeof buf);
    buf[1] = 'n';
    rto_npy npy;
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_parse(buf, sizeof buf - 1, &npy, &msg), RTO_ERR_PARSE);
    assert_string_equal(msg.text, "bad magic: not a .npy file");
    msg.text[0] = '\0';
    assert_int_equal(rto_npy_parse("PK\x03\x04", 4, &npy, &msg), RTO_ERR_PARSE);
    assert_string_equal(msg.text, "bad magic: not a .npy file");
}

static void test_versions(void **state)
{
    (void)state;
    static const char header[] = "{'descr': '<u4', 'fortran_order': False, 'shape': (2,), }\n";
    const uint32_t data[2] = {0xdeadbeefu, 7};
    for (unsigned major = 2; major <= 3; major++) {
        size_t len;
        unsigned char *buf = make_npy(major, header, data, sizeof data, &len);
        assert_int_equal(len, 12 + strlen(header) + 8);
        rto_npy npy;
        rto_msg msg = {{0}};
        assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
        assert_int_equal(npy.desc.shape[0], 2);
        assert_memory_equal(npy.data, data, sizeof data);
        rto_npy_free(&npy);
        free(buf);
    }
    /* The same 2.0 file with the header length's high byte set claims a header far past the end. */
    {
        size_t len;
        unsigned char *buf = make_npy(2, header, data, sizeof data, &len);
        buf[11] = 0x80;
        rto_npy npy;
        rto_msg msg = {{0}};
        assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_ERR_PARSE);
        assert_non_null(strstr(msg.text, "truncated"));
        free(buf);
    }
    const unsigned char bad[][2] = {{4, 0}, {1, 1}, {0, 0}, {2, 1}, {255, 255}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        size_t len;
        unsigned char *buf = make_npy(1, header, data, sizeof data, &len);
        buf[6] = bad[i][0];
        buf[7] = bad[i][1];
        rto_npy npy;
        rto_msg msg = {{0}};
        assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_ERR_UNSUPPORTED);
        char want[64];
        snprintf(want, sizeof want, "unsupported .npy version %u.%u", bad[i][0], bad[i][1]);
        assert_string_equal(msg.text, want);
        free(buf);
    }
}

static void test_unsupported_headers(void **state)
{
    (void)state;
    const uint32_t d4[4] = {1, 2, 3, 4};
    assert_refused("{'descr': '<u4', 'fortran_order': True, 'shape': (2, 2), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "fortran_order arrays are not supported");
    assert_refused("{'descr': '>u4', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "big-endian dtype '>u4' is not supported");
    assert_refused("{'descr': '<c8', 'fortran_order': False, 'shape': (2,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "unknown dtype '<c8'");
    /* Only the five spellings numpy itself writes are accepted. */
    assert_refused("{'descr': '=u4', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "unknown dtype '=u4'");
    assert_refused("{'descr': '<u1', 'fortran_order': False, 'shape': (16,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "unknown dtype '<u1'");
    assert_refused("{'descr': '|b1', 'fortran_order': False, 'shape': (16,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "unknown dtype '|b1'");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (1, 1, 1, 2, 2), }", d4, 16,
                   RTO_ERR_UNSUPPORTED, "shape has 5 dimensions; at most 4 are supported");
    assert_refused("{'descr': [('a', '<u4'), ('b', [('c', '<u4')])], 'fortran_order': False, 'shape': (2,), }", d4, 16,
                   RTO_ERR_UNSUPPORTED, "nested structured field 'b' is not supported");
    assert_refused("{'descr': [('a', '<u4'), ('', '|V4')], 'fortran_order': False, 'shape': (2,), }", d4, 16,
                   RTO_ERR_UNSUPPORTED, "field 1 has an empty name");
    assert_refused("{'descr': [('a', '<f4', (2, 2))], 'fortran_order': False, 'shape': (1,), }", d4, 16,
                   RTO_ERR_UNSUPPORTED, "subarray shapes of 2 dimensions");
    assert_refused("{'descr': [('a', '>f4')], 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "big-endian dtype '>f4'");
    assert_refused("{'descr': [('abcdefghijklmnopqrstuvwxyz0123456', '<u4')], 'fortran_order': False, "
                   "'shape': (4,), }",
                   d4, 16, RTO_ERR_UNSUPPORTED, "is longer than 31 characters");
    assert_refused("{'descr': [], 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "structured dtype with no fields");
    assert_refused("{'descr': [('a', '<u4'), ('b', '<u4'), ('c', '<u4'), ('d', '<u4'), ('e', '<u4'), ('f', '<u4'), "
                   "('g', '<u4'), ('h', '<u4'), ('i', '<u4'), ('j', '<u4'), ('k', '<u4'), ('l', '<u4'), ('m', '<u4'), "
                   "('n', '<u4'), ('o', '<u4'), ('p', '<u4'), ('q', '<u4')], 'fortran_order': False, 'shape': (0,), }",
                   NULL, 0, RTO_ERR_UNSUPPORTED, "more than 16 fields");
    assert_refused("{'descr': 'caf\xc3\xa9', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_UNSUPPORTED,
                   "non-ASCII");
}

static void test_malformed_headers(void **state)
{
    (void)state;
    const uint32_t d4[4] = {1, 2, 3, 4};
    /* Offsets count from the start of the file: the 10-byte preamble, then "{'descr' " puts the quote at 19. */
    assert_refused("{'descr' '<u4', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "header: expected ':' at offset 19, found '''");
    assert_refused("{'descr': '<u4' 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "header: expected ',' or '}' at offset 26");
    assert_refused("{'descr': '<u4', 'fortran_order': False, }", d4, 16, RTO_ERR_PARSE, "header: missing key 'shape'");
    assert_refused("{'fortran_order': False, 'shape': (4,)}", d4, 16, RTO_ERR_PARSE, "header: missing key 'descr'");
    assert_refused("{}", d4, 16, RTO_ERR_PARSE, "missing key");
    assert_refused("", d4, 16, RTO_ERR_PARSE, "found end of header");
    assert_refused("{'descr': '<u4', 'descr': '<u4', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "duplicate key 'descr'");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4,), 'extra': 1}", d4, 16, RTO_ERR_PARSE,
                   "unexpected key 'extra'");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4), }", d4, 16, RTO_ERR_PARSE,
                   "is an integer, not a tuple");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (-4,), }", d4, 16, RTO_ERR_PARSE,
                   "negative integer");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (04,), }", d4, 16, RTO_ERR_PARSE,
                   "leading zero");
    assert_refused("{'descr': '<u4', 'fortran_order': false, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "expected True or False");
    assert_refused("{'descr': '<u4', 'fortran_order': Falsey, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "expected True or False");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4,), 'x}", d4, 16, RTO_ERR_PARSE,
                   "unterminated string at offset 66");
    assert_refused("{'descr': '<u4\n', 'fortran_order': False, 'shape': (4,), }", d4, 16, RTO_ERR_PARSE,
                   "unterminated string at offset 20");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4,), }\n\n'", d4, 16, RTO_ERR_PARSE,
                   "after the closing '}'");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4,), } x", d4, 16, RTO_ERR_PARSE,
                   "after the closing '}'");
    assert_refused("{'descr': [('a', '<u4'), ('a', '<u4')], 'fortran_order': False, 'shape': (2,), }", d4, 16,
                   RTO_ERR_PARSE, "duplicate field name 'a'");
    assert_refused("{'descr': [('a', '<u4') ('b', '<u4')], 'fortran_order': False, 'shape': (2,), }", d4, 16,
                   RTO_ERR_PARSE, "expected ',' or ']'");
    assert_refused("{'descr': 5, 'fortran_order': False, 'shape': (2,), }", d4, 16, RTO_ERR_PARSE,
                   "expected a dtype string or a list of fields");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4,,), }", d4, 16, RTO_ERR_PARSE,
                   "expected a non-negative integer");

    /* A NUL after the dict is not whitespace (numpy's literal_eval refuses it too). */
    size_t len;
    unsigned char *buf = make_npy(1, "{'descr': '<u4', 'fortran_order': False, 'shape': (4,), }X", d4, 16, &len);
    buf[10 + 57] = 0;
    rto_npy npy;
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_ERR_PARSE);
    assert_string_equal(msg.text, "header: unexpected byte 0x00 at offset 67 after the closing '}'");
    free(buf);
}

static void test_huge_shapes(void **state)
{
    (void)state;
    const uint32_t d4[4] = {1, 2, 3, 4};
    /* 2^64 - 1 elements of 4 bytes: the byte count would wrap to 2^64 - 4 in 64-bit arithmetic. */
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (18446744073709551615,), }", d4, 16,
                   RTO_ERR_PARSE, "truncated: header says 18446744073709551615 elements of 4 bytes");
    /* 2^62 elements of 4 bytes wrap to exactly 0 bytes: must not be taken for an empty array. */
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (4611686018427387904,), }", NULL, 0,
                   RTO_ERR_PARSE, "truncated");
    /* 2^32 * 2^32 elements: the element count itself overflows. */
    assert_refused("{'descr': '|u1', 'fortran_order': False, 'shape': (4294967296, 4294967296), }", d4, 16,
                   RTO_ERR_PARSE, "truncated: shape (4294967296, 4294967296) has 2^64 or more elements");
    assert_refused("{'descr': '<u4', 'fortran_order': False, 'shape': (18446744073709551616,), }", d4, 16,
                   RTO_ERR_PARSE, "does not fit in 64 bits");
    assert_refused("{'descr': [('a', '<u8', (4294967296,))], 'fortran_order': False, 'shape': (0,), }", NULL, 0,
                   RTO_ERR_UNSUPPORTED, "record size exceeds");
    /* An empty dimension next to a huge one is a valid empty array. */
    rto_msg msg = {{0}};
    assert_int_equal(parse_header_text("{'descr': '<u8', 'fortran_order': False, 'shape': (0, 18446744073709551615), }",
                                       NULL, 0, &msg),
                     RTO_OK);
}

static void test_trailing_garbage(void **state)
{
    (void)state;
    unsigned char buf[sizeof u32_3_file + 3];
    memcpy(buf, u32_3_file, sizeof u32_3_file - 1);
    memcpy(buf + sizeof u32_3_file - 1, "abc", 3);
    rto_npy npy;
    rto_msg msg = {{0}};
    assert_int_equal(rto_npy_parse(buf, sizeof u32_3_file - 1 + 3, &npy, &msg), RTO_ERR_PARSE);
    assert_string_equal(msg.text, "trailing garbage: 3 bytes after the data");
    assert_null(npy.data);
}

static void test_lenient_spellings(void **state)
{
    (void)state;
    const uint32_t d6[6] = {1, 2, 3, 4, 5, 6};
    const char *ok[] = {
        "{\"descr\": \"<u4\", \"fortran_order\": False, \"shape\": (6,)}",
        "{\"shape\": (2, 3), \"descr\": '<u4', 'fortran_order': False}\n",
        "  {'shape':(3,2,),'fortran_order':False,'descr':'<u4',}   \n",
        "{\n  'descr': '<u4',\n  'fortran_order': False,\n  'shape': ( 6 , ),\n}\n",
        "{'descr': [(\"a\", '<u4'), ('b', \"<u4\", (2,),)], 'fortran_order': False, 'shape': (2,), }",
        "{'descr': [('a', '<u4', (3,))], 'fortran_order': False, 'shape': (1, 2), }",
    };
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        size_t len;
        unsigned char *buf = make_npy(1, ok[i], d6, sizeof d6, &len);
        rto_npy npy;
        rto_msg msg = {{0}};
        rto_status s = rto_npy_parse(buf, len, &npy, &msg);
        if (s != RTO_OK)
            print_error("header %s refused: %s\n", ok[i], msg.text);
        assert_int_equal(s, RTO_OK);
        assert_int_equal(npy.nbytes, sizeof d6);
        assert_memory_equal(npy.data, d6, sizeof d6);
        if (i == 4) {
            assert_int_equal(npy.desc.dtype, RTO_DTYPE_STRUCT);
            assert_int_equal(npy.desc.nfields, 2);
            assert_string_equal(npy.desc.fields[1].name, "b");
            assert_int_equal(npy.desc.fields[1].count, 2);
            assert_int_equal(npy.desc.fields[1].offset, 4);
        }
        rto_npy_free(&npy);
        free(buf);
    }
}

static void test_as_keys(void **state)
{
    (void)state;
    rto_msg msg = {{0}};
    rto_key_format f;
    size_t n = 99;
    const uint64_t d3[3] = {5, 6, 7};
    size_t len;
    unsigned char *buf = make_npy(1, "{'descr': '<u8', 'fortran_order': False, 'shape': (3,), }", d3, sizeof d3, &len);
    rto_npy npy;
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_OK);
    assert_int_equal(f, RTO_KEY_U64);
    assert_int_equal(n, 3);
    rto_npy_free(&npy);

    assert_int_equal(rto_npy_parse(u32_3_file, sizeof u32_3_file - 1, &npy, &msg), RTO_OK);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_OK);
    assert_int_equal(f, RTO_KEY_U32);
    assert_int_equal(n, 3);
    rto_npy_free(&npy);

    const float fl[12] = {0};
    buf = make_npy(1, "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }", fl, sizeof fl, &len);
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_string_equal(msg.text, "expected a 1-D array of uint32 or uint64 keys, got float32 with shape (3, 4)");
    rto_npy_free(&npy);

    buf = make_npy(1, "{'descr': '<f4', 'fortran_order': False, 'shape': (12,), }", fl, sizeof fl, &len);
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "got float32 with shape (12,)"));
    rto_npy_free(&npy);

    const uint32_t u6[6] = {0};
    buf = make_npy(1, "{'descr': '<u4', 'fortran_order': False, 'shape': (2, 3), }", u6, sizeof u6, &len);
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "got uint32 with shape (2, 3)"));
    rto_npy_free(&npy);

    buf = make_npy(1, "{'descr': '<u4', 'fortran_order': False, 'shape': (), }", u6, 4, &len);
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "got uint32 with shape ()"));
    rto_npy_free(&npy);

    buf = make_npy(1, "{'descr': [('key', '<u4'), ('value', '<u4')], 'fortran_order': False, 'shape': (3,), }", u6,
                   sizeof u6, &len);
    assert_int_equal(rto_npy_parse(buf, len, &npy, &msg), RTO_OK);
    free(buf);
    assert_int_equal(rto_npy_as_keys(&npy, &f, &n, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_string_equal(msg.text, "expected a 1-D array of uint32 or uint64 keys, got structured dtype "
                                  "[('key', '<u4'), ('value', '<u4')] with shape (3,)");
    rto_npy_free(&npy);
}

static void test_free_null(void **state)
{
    (void)state;
    rto_npy_free(NULL);
    rto_npy npy;
    memset(&npy, 0xa5, sizeof npy);
    npy.data = malloc(16);
    rto_npy_free(&npy);
    assert_null(npy.data);
    assert_int_equal(npy.nbytes, 0);
    assert_int_equal(npy.desc.ndim, 0);
    rto_npy_free(&npy); /* twice is harmless once zeroed */
}

static void test_file_errors(void **state)
{
    (void)state;
    rto_npy npy;
    rto_msg msg = {{0}};
    char path[256];
    tmp_path(path, sizeof path, "does-not-exist.npy");
    assert_int_equal(rto_npy_read(path, &npy, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, path));
    assert_non_null(strstr(msg.text, "No such file"));

    assert_int_equal(rto_npy_read(tmpdir, &npy, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, tmpdir));
    assert_non_null(strstr(msg.text, "is a directory"));

    /* Parse errors from a file name it. */
    tmp_path(path, sizeof path, "garbage.npy");
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    fputs("hello", fp);
    fclose(fp);
    assert_int_equal(rto_npy_read(path, &npy, &msg), RTO_ERR_PARSE);
    assert_non_null(strstr(msg.text, path));
    assert_non_null(strstr(msg.text, "bad magic"));

    uint32_t data[2] = {1, 2};
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 2);
    tmp_path(path, sizeof path, "no-such-dir/x.npy");
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, path));

    if (access("/dev/full", W_OK) == 0) {
        assert_int_equal(rto_npy_write("/dev/full", &d, data, &msg), RTO_ERR_IO);
        assert_non_null(strstr(msg.text, "No space left on device"));
        assert_int_equal(access("/dev/full", F_OK), 0);
    }
}

static void test_write_refuses_bad_desc(void **state)
{
    (void)state;
    char path[256];
    tmp_path(path, sizeof path, "bad.npy");
    rto_msg msg = {{0}};
    uint32_t data[4] = {0};
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 4);
    assert_int_equal(rto_npy_write(path, &d, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.ndim = 5;
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = rto_npy_desc_array(RTO_DTYPE_NONE, 1, 4, 0, 0);
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = rto_npy_desc_array(RTO_DTYPE_STRUCT, 1, 4, 0, 0);
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);

    d = struct_desc();
    d.fields[2].offset += 1; /* not packed */
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "offset"));
    d = struct_desc();
    strcpy(d.fields[1].name, "key");
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "duplicate field name 'key'"));
    d = struct_desc();
    strcpy(d.fields[1].name, "it's");
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = struct_desc();
    memset(d.fields[0].name, 'k', sizeof d.fields[0].name);
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    d = rto_npy_desc_keys(RTO_KEY_U64, UINT64_C(1) << 62);
    assert_int_equal(rto_npy_write(path, &d, data, &msg), RTO_ERR_INVALID_ARGUMENT);
    /* No bad desc leaves a file behind. */
    assert_int_equal(access(path, F_OK), -1);
    char descr[16];
    d = rto_npy_desc_array(RTO_DTYPE_NONE, 1, 4, 0, 0);
    assert_int_equal(rto_npy_descr(&d, descr, sizeof descr), RTO_ERR_INVALID_ARGUMENT);
    d = rto_npy_desc_keys(RTO_KEY_U64, 3);
    assert_int_equal(rto_npy_descr(&d, descr, sizeof descr), RTO_OK);
    assert_string_equal(descr, "<u8");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sizes_and_counts),
        cmocka_unit_test(test_roundtrip_scalars),
        cmocka_unit_test(test_roundtrip_struct),
        cmocka_unit_test(test_header_bytes_match_numpy),
        cmocka_unit_test(test_preamble_alignment),
        cmocka_unit_test(test_parse_hand_built),
        cmocka_unit_test(test_truncation_sweep),
        cmocka_unit_test(test_bad_magic),
        cmocka_unit_test(test_versions),
        cmocka_unit_test(test_unsupported_headers),
        cmocka_unit_test(test_malformed_headers),
        cmocka_unit_test(test_huge_shapes),
        cmocka_unit_test(test_trailing_garbage),
        cmocka_unit_test(test_lenient_spellings),
        cmocka_unit_test(test_as_keys),
        cmocka_unit_test(test_free_null),
        cmocka_unit_test(test_file_errors),
        cmocka_unit_test(test_write_refuses_bad_desc),
    };
    return cmocka_run_group_tests_name("npy", tests, make_tmpdir, remove_tmpdir);
}
