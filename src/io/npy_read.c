/* .npy reading (npy_internal.h): the header parser, rto_npy_parse and rto_npy_read.
 *
 * The reader takes untrusted input: every byte access is checked against the header's or the buffer's end, integers
 * are range-checked before they are combined, and nothing recurses on input structure (nested structs are refused
 * rather than parsed). Offsets in messages are byte offsets from the start of the file, so they match a hexdump. */
#define _POSIX_C_SOURCE 200809L /* fileno, fstat, O_CLOEXEC */

#include "io_internal.h"
#include "npy_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The largest file rto_npy_read loads. */
#define NPY_MAX_FILE_BYTES (UINT64_C(16) << 30)
/* Strings from a file are echoed in messages up to this many characters. */
#define NPY_ECHO_MAX 40

/* ---------------------------------------------------------------------------------------------------------------- */
/* Header parser: a Python dict literal restricted to what numpy writes and reasonable hand-written variants. */

typedef struct parser {
    const unsigned char *p;
    size_t pos;
    size_t end; /* one past the last header byte */
    rto_msg *msg;
} parser;

typedef struct token {
    const char *s;
    size_t n;
    size_t at; /* offset of the opening quote */
} token;

#define TOK_FMT "'%.*s%s'"
#define TOK_ARG(t) (int)((t).n < NPY_ECHO_MAX ? (t).n : NPY_ECHO_MAX), (t).s, ((t).n > NPY_ECHO_MAX ? "..." : "")

/* Whitespace Python's tokenizer skips inside brackets (newlines included, since the whole dict is bracketed). */
static bool is_ws(unsigned char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f'; }

static int peek(parser *ps)
{
    while (ps->pos < ps->end && is_ws(ps->p[ps->pos]))
        ps->pos++;
    return ps->pos < ps->end ? ps->p[ps->pos] : -1;
}

static const char *found(const parser *ps, char *buf, size_t cap)
{
    if (ps->pos >= ps->end)
        return "end of header";
    unsigned c = ps->p[ps->pos];
    if (c >= 0x20 && c < 0x7f)
        snprintf(buf, cap, "'%c'", (char)c);
    else
        snprintf(buf, cap, "byte 0x%02x", c & 0xffu);
    return buf;
}

static rto_status expected(parser *ps, const char *what)
{
    char buf[16];
    return rto__fail(ps->msg, RTO_ERR_PARSE, "header: expected %s at offset %zu, found %s", what, ps->pos,
                    found(ps, buf, sizeof buf));
}

static rto_status expect(parser *ps, int c, const char *what)
{
    if (peek(ps) != c)
        return expected(ps, what);
    ps->pos++;
    return RTO_OK;
}

static bool tok_is(const token *t, const char *s) { return t->n == strlen(s) && memcmp(t->s, s, t->n) == 0; }

static rto_status parse_string(parser *ps, token *t, const char *what)
{
    int q = peek(ps);
    if (q != '\'' && q != '"')
        return expected(ps, what);
    t->at = ps->pos++;
    size_t start = ps->pos;
    for (;;) {
        if (ps->pos >= ps->end)
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: unterminated string at offset %zu", t->at);
        unsigned char c = ps->p[ps->pos];
        if (c == q)
            break;
        if (c == '\n' || c == '\r')
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: unterminated string at offset %zu", t->at);
        /* Escapes and non-ASCII are legal Python but never needed by a supported dtype or field name. */
        if (c == '\\')
            return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED,
                            "header: escape sequences in strings are not supported (offset %zu)", ps->pos);
        if (c < 0x20 || c >= 0x7f)
            return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED,
                            "header: non-ASCII or control byte 0x%02x in a string at offset %zu is not supported",
                            (unsigned)c, ps->pos);
        ps->pos++;
    }
    t->s = (const char *)ps->p + start;
    t->n = ps->pos - start;
    ps->pos++;
    return RTO_OK;
}

static rto_status parse_uint(parser *ps, uint64_t *v)
{
    int c = peek(ps);
    if (c == '-')
        return rto__fail(ps->msg, RTO_ERR_PARSE, "header: negative integer at offset %zu", ps->pos);
    if (c < '0' || c > '9')
        return expected(ps, "a non-negative integer");
    size_t at = ps->pos;
    uint64_t x = 0;
    while (ps->pos < ps->end && ps->p[ps->pos] >= '0' && ps->p[ps->pos] <= '9') {
        unsigned d = (unsigned)(ps->p[ps->pos] - '0');
        if (x > (UINT64_MAX - d) / 10)
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: integer at offset %zu does not fit in 64 bits", at);
        x = x * 10 + d;
        ps->pos++;
    }
    /* Python 3 rejects "05"; so does numpy, so accepting it would make files only this reader loads. */
    if (ps->p[at] == '0' && ps->pos - at > 1)
        return rto__fail(ps->msg, RTO_ERR_PARSE, "header: integer with a leading zero at offset %zu", at);
    *v = x;
    return RTO_OK;
}

/* A tuple of non-negative ints. Stores at most cap of them but counts all, so the caller can say how many there
 * were; "(5)" is refused because Python reads it as a plain int. */
static rto_status parse_tuple(parser *ps, uint64_t *dims, uint32_t cap, uint32_t *count, const char *what)
{
    if (peek(ps) != '(')
        return expected(ps, what);
    size_t at = ps->pos++;
    uint32_t n = 0;
    if (peek(ps) == ')') {
        ps->pos++;
        *count = 0;
        return RTO_OK;
    }
    for (;;) {
        uint64_t v = 0;
        rto_status s = parse_uint(ps, &v);
        if (s != RTO_OK)
            return s;
        if (n < cap)
            dims[n] = v;
        if (n < UINT32_MAX)
            n++;
        int c = peek(ps);
        if (c == ')') {
            ps->pos++;
            if (n == 1)
                return rto__fail(ps->msg, RTO_ERR_PARSE,
                                "header: '(%llu)' at offset %zu is an integer, not a tuple (write '(%llu,)')",
                                (unsigned long long)v, at, (unsigned long long)v);
            break;
        }
        if (c != ',')
            return expected(ps, "',' or ')'");
        ps->pos++;
        if (peek(ps) == ')') {
            ps->pos++;
            break;
        }
    }
    *count = n;
    return RTO_OK;
}

static rto_status parse_bool(parser *ps, bool *v)
{
    peek(ps);
    size_t at = ps->pos;
    size_t n = 0;
    while (ps->pos + n < ps->end) {
        unsigned char ch = ps->p[ps->pos + n];
        if (!((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_'))
            break;
        n++;
    }
    const char *w = (const char *)ps->p + at;
    if (n == 4 && memcmp(w, "True", 4) == 0)
        *v = true;
    else if (n == 5 && memcmp(w, "False", 5) == 0)
        *v = false;
    else
        return expected(ps, "True or False for 'fortran_order'");
    ps->pos += n;
    return RTO_OK;
}

static rto_status scalar_from_token(parser *ps, const token *t, rto_dtype *type)
{
    for (size_t i = 0; i < sizeof rto__npy_scalars / sizeof rto__npy_scalars[0]; i++)
        if (tok_is(t, rto__npy_scalars[i].descr)) {
            *type = rto__npy_scalars[i].type;
            return RTO_OK;
        }
    if (t->n > 0 && t->s[0] == '>')
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "big-endian dtype " TOK_FMT " is not supported", TOK_ARG(*t));
    char list[128];
    size_t used = 0;
    for (size_t i = 0; i < sizeof rto__npy_scalars / sizeof rto__npy_scalars[0] && used < sizeof list; i++)
        used += (size_t)snprintf(list + used, sizeof list - used, "%s'%s'", i ? ", " : "", rto__npy_scalars[i].descr);
    return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "unknown dtype " TOK_FMT " (supported: %s)", TOK_ARG(*t), list);
}

/* One ('name', 'type') or ('name', 'type', (n,)) entry; *offset advances past it. */
static rto_status parse_field(parser *ps, rto_npy_desc *d, uint64_t *offset)
{
    uint32_t index = d->nfields;
    if (peek(ps) == '[')
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "fields written as lists rather than tuples are not supported "
                        "(offset %zu)", ps->pos);
    rto_status s = expect(ps, '(', "'(' to start a field");
    if (s != RTO_OK)
        return s;
    if (peek(ps) == '(')
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field titles ((title, name) pairs) are not supported "
                        "(offset %zu)", ps->pos);
    token name;
    if ((s = parse_string(ps, &name, "a field name")) != RTO_OK)
        return s;
    if (name.n == 0)
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field %u has an empty name (padding fields are not "
                        "supported)", index);
    if (name.n >= RTO_NPY_NAME_MAX)
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field name " TOK_FMT " is longer than %d characters",
                        TOK_ARG(name), RTO_NPY_NAME_MAX - 1);
    for (size_t i = 0; i < name.n; i++)
        if (!rto__npy_name_char_ok((unsigned char)name.s[i]))
            return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field name " TOK_FMT " contains a quote character",
                            TOK_ARG(name));
    for (uint32_t j = 0; j < index; j++)
        if (tok_is(&name, d->fields[j].name))
            return rto__fail(ps->msg, RTO_ERR_PARSE, "duplicate field name " TOK_FMT, TOK_ARG(name));
    if ((s = expect(ps, ',', "',' after the field name")) != RTO_OK)
        return s;
    if (peek(ps) == '[')
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "nested structured field " TOK_FMT " is not supported",
                        TOK_ARG(name));
    token type;
    rto_dtype t = RTO_DTYPE_NONE;
    if ((s = parse_string(ps, &type, "a dtype string")) != RTO_OK || (s = scalar_from_token(ps, &type, &t)) != RTO_OK)
        return s;
    uint64_t count = 1;
    int c = peek(ps);
    if (c == ',') {
        ps->pos++;
        c = peek(ps);
        if (c == '(') {
            uint64_t dim = 0;
            uint32_t n = 0;
            if ((s = parse_tuple(ps, &dim, 1, &n, "a subarray shape")) != RTO_OK)
                return s;
            if (n != 1)
                return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field " TOK_FMT ": subarray shapes of %u dimensions "
                                "are not supported (only (n,))", TOK_ARG(name), n);
            if (dim == 0)
                return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field " TOK_FMT ": zero-length subarrays are not "
                                "supported", TOK_ARG(name));
            count = dim;
            if (peek(ps) == ',')
                ps->pos++;
            c = peek(ps);
        } else if (c >= '0' && c <= '9') {
            return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "field " TOK_FMT ": a subarray shape must be a tuple such "
                            "as (3,) (offset %zu)", TOK_ARG(name), ps->pos);
        } else if (c != ')') {
            return expected(ps, "a subarray shape or ')'");
        }
    }
    if (c != ')')
        return expected(ps, "')' to end the field");
    ps->pos++;
    uint64_t size = rto_dtype_size(t);
    /* count is bounded first so that count * size cannot wrap. */
    if (count > NPY_MAX_RECORD || *offset + count * size > NPY_MAX_RECORD)
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "record size exceeds %ld bytes at field " TOK_FMT,
                        (long)NPY_MAX_RECORD, TOK_ARG(name));
    rto_npy_field *f = &d->fields[index];
    memcpy(f->name, name.s, name.n);
    f->name[name.n] = '\0';
    f->type = t;
    f->count = (uint32_t)count;
    f->offset = (uint32_t)*offset;
    *offset += count * size;
    d->nfields = index + 1;
    return RTO_OK;
}

static rto_status parse_descr(parser *ps, rto_npy_desc *d)
{
    int c = peek(ps);
    if (c == '\'' || c == '"') {
        token t;
        rto_status s = parse_string(ps, &t, "a dtype string");
        return s != RTO_OK ? s : scalar_from_token(ps, &t, &d->dtype);
    }
    if (c != '[')
        return expected(ps, "a dtype string or a list of fields for 'descr'");
    size_t at = ps->pos++;
    d->dtype = RTO_DTYPE_STRUCT;
    uint64_t offset = 0;
    for (;;) {
        c = peek(ps);
        if (c == ']') {
            if (d->nfields == 0)
                return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "structured dtype with no fields (offset %zu) is not "
                                "supported", at);
            ps->pos++;
            return RTO_OK;
        }
        if (d->nfields == RTO_NPY_MAX_FIELDS)
            return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "structured dtype has more than %d fields",
                            RTO_NPY_MAX_FIELDS);
        rto_status s = parse_field(ps, d, &offset);
        if (s != RTO_OK)
            return s;
        c = peek(ps);
        if (c == ',') {
            ps->pos++;
        } else if (c != ']') {
            return expected(ps, "',' or ']'");
        }
    }
}

enum { KEY_DESCR, KEY_FORTRAN, KEY_SHAPE, KEY_COUNT };

static const char *const header_keys[KEY_COUNT] = {"descr", "fortran_order", "shape"};

static rto_status parse_header(parser *ps, rto_npy_desc *d)
{
    bool have[KEY_COUNT] = {false, false, false};
    rto_status s = expect(ps, '{', "'{' to start the header dictionary");
    if (s != RTO_OK)
        return s;
    for (;;) {
        if (peek(ps) == '}') {
            ps->pos++;
            break;
        }
        token key;
        if ((s = parse_string(ps, &key, "a quoted key or '}'")) != RTO_OK)
            return s;
        int k = 0;
        while (k < KEY_COUNT && !tok_is(&key, header_keys[k]))
            k++;
        if (k == KEY_COUNT)
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: unexpected key " TOK_FMT " at offset %zu",
                            TOK_ARG(key), key.at);
        /* Python keeps the last of duplicate keys; refusing them avoids guessing which one a writer meant. */
        if (have[k])
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: duplicate key '%s' at offset %zu", header_keys[k],
                            key.at);
        have[k] = true;
        if ((s = expect(ps, ':', "':'")) != RTO_OK)
            return s;
        if (k == KEY_DESCR) {
            s = parse_descr(ps, d);
        } else if (k == KEY_FORTRAN) {
            bool fortran = false;
            s = parse_bool(ps, &fortran);
            if (s == RTO_OK && fortran)
                return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "fortran_order arrays are not supported");
        } else {
            uint32_t n = 0;
            s = parse_tuple(ps, d->shape, RTO_NPY_MAX_DIMS, &n, "a tuple for 'shape'");
            if (s == RTO_OK && n > RTO_NPY_MAX_DIMS)
                return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "shape has %u dimensions; at most %d are supported", n,
                                RTO_NPY_MAX_DIMS);
            d->ndim = n;
        }
        if (s != RTO_OK)
            return s;
        int c = peek(ps);
        if (c == ',') {
            ps->pos++;
        } else if (c == '}') {
            ps->pos++;
            break;
        } else {
            return expected(ps, "',' or '}'");
        }
    }
    if (peek(ps) != -1) {
        char buf[16];
        return rto__fail(ps->msg, RTO_ERR_PARSE, "header: unexpected %s at offset %zu after the closing '}'",
                        found(ps, buf, sizeof buf), ps->pos);
    }
    for (int k = 0; k < KEY_COUNT; k++)
        if (!have[k])
            return rto__fail(ps->msg, RTO_ERR_PARSE, "header: missing key '%s'", header_keys[k]);
    return RTO_OK;
}

rto_status rto_npy_parse(const void *buf, size_t len, rto_npy *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");
    memset(out, 0, sizeof *out);
    if (!buf && len)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL buffer of %zu bytes", len);
    if (len == 0)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: empty file");
    const unsigned char *p = buf;
    if (memcmp(p, rto__npy_magic, len < sizeof rto__npy_magic ? len : sizeof rto__npy_magic) != 0)
        return rto__fail(msg, RTO_ERR_PARSE, "bad magic: not a .npy file");
    if (len < 8)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: %zu bytes end inside the .npy preamble", len);
    unsigned major = p[6], minor = p[7];
    size_t pre;
    if (major == 1 && minor == 0)
        pre = 10;
    else if ((major == 2 || major == 3) && minor == 0)
        pre = 12; /* 3.0 differs from 2.0 only in allowing UTF-8 in the header, which this reader refuses anyway */
    else
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "unsupported .npy version %u.%u", major, minor);
    if (len < pre)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: %zu bytes end inside the %zu-byte .npy %u.0 preamble", len,
                        pre, major);
    uint64_t hlen = (uint64_t)p[8] | (uint64_t)p[9] << 8;
    if (pre == 12)
        hlen |= (uint64_t)p[10] << 16 | (uint64_t)p[11] << 24;
    if (hlen > len - pre)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: header length is %llu bytes but only %zu bytes follow the "
                        "preamble", (unsigned long long)hlen, len - pre);

    rto_npy_desc d;
    memset(&d, 0, sizeof d);
    parser ps = {p, pre, pre + (size_t)hlen, msg};
    rto_status s = parse_header(&ps, &d);
    if (s != RTO_OK)
        return s;

    size_t avail = len - ps.end;
    int ok = 0;
    uint64_t count = rto_npy_count(&d, &ok);
    uint64_t item = rto_npy_itemsize(&d); /* >= 1: every accepted dtype has a size */
    char shape[128];
    rto__npy_format_shape(&d, shape, sizeof shape);
    if (!ok)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: shape %s has 2^64 or more elements but %zu data bytes follow",
                        shape, avail);
    if (count > UINT64_MAX / item)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: header says %llu elements of %llu bytes (2^64 bytes or more) "
                        "but %zu data bytes follow", (unsigned long long)count, (unsigned long long)item, avail);
    uint64_t nbytes = count * item;
    if (nbytes > avail)
        return rto__fail(msg, RTO_ERR_PARSE, "truncated: header says %llu elements (%llu bytes) but %zu data bytes "
                        "follow", (unsigned long long)count, (unsigned long long)nbytes, avail);
    if (nbytes < avail)
        return rto__fail(msg, RTO_ERR_PARSE, "trailing garbage: %llu bytes after the data",
                        (unsigned long long)(avail - nbytes));

    void *data = rto__alloc((size_t)nbytes, 1);
    if (!data)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot allocate %llu bytes for the array data",
                        (unsigned long long)nbytes);
    memcpy(data, p + ps.end, (size_t)nbytes);
    out->desc = d;
    out->data = data;
    out->nbytes = (size_t)nbytes;
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Files */

FILE *rto__open_regular(const char *path, uint64_t *size, rto_status *status, rto_msg *msg)
{
    /* O_NONBLOCK: open() of a FIFO waits for a writer, so without it a FIFO would hang the command before fstat
     * could refuse it. On a regular file the flag changes nothing; it is cleared anyway before the stream is made. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        *status = rto__fail(msg, RTO_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        return NULL;
    }
    struct stat st;
    int flags;
    if (fstat(fd, &st) != 0 || (flags = fcntl(fd, F_GETFL)) < 0) {
        *status = rto__fail(msg, RTO_ERR_IO, "cannot stat '%s': %s", path, strerror(errno));
        close(fd);
        return NULL;
    }
    /* The size of a FIFO or a device is unknown (/dev/zero never ends): only plain files are inputs. */
    if (!S_ISREG(st.st_mode)) {
        *status = rto__fail(msg, RTO_ERR_IO, S_ISDIR(st.st_mode) ? "'%s' is a directory" : "'%s' is not a regular file",
                           path);
        close(fd);
        return NULL;
    }
    FILE *fp = fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) == 0 ? fdopen(fd, "rb") : NULL;
    if (!fp) {
        *status = rto__fail(msg, RTO_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
        close(fd);
        return NULL;
    }
    *size = st.st_size < 0 ? 0 : (uint64_t)st.st_size;
    return fp;
}

rto_status rto_npy_read(const char *path, rto_npy *out, rto_msg *msg)
{
    if (!out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");
    memset(out, 0, sizeof *out);
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path");
    uint64_t file_size = 0;
    rto_status opened = RTO_OK;
    FILE *fp = rto__open_regular(path, &file_size, &opened, msg);
    if (!fp)
        return opened;
    if (file_size > NPY_MAX_FILE_BYTES || file_size > SIZE_MAX) {
        fclose(fp);
        return rto__fail(msg, RTO_ERR_IO, "'%s' is %llu bytes; files over 16 GiB are refused", path,
                        (unsigned long long)file_size);
    }
    size_t size = (size_t)file_size;
    unsigned char *buf = rto__alloc(size, 1);
    if (!buf) {
        fclose(fp);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot allocate %zu bytes to read '%s'", size, path);
    }
    size_t got = fread(buf, 1, size, fp);
    int e = errno;
    /* A file that changes size while read would be parsed as something it never was. */
    bool bad = ferror(fp) != 0;
    bool changed = !bad && (got != size || fgetc(fp) != EOF);
    fclose(fp);
    if (bad || changed) {
        free(buf);
        if (bad)
            return rto__fail(msg, RTO_ERR_IO, "reading '%s': %s", path, strerror(e));
        return rto__fail(msg, RTO_ERR_IO, "'%s' changed size while being read", path);
    }
    rto_msg inner = {{0}};
    rto_status s = rto_npy_parse(buf, size, out, &inner);
    free(buf);
    if (s != RTO_OK)
        return rto__fail(msg, s, "%s: %s", path, inner.text);
    return RTO_OK;
}
