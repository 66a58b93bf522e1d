/* .npy files (NumPy format 1.0 / 2.0 / 3.0), read and written byte-compatibly with numpy.save (DESIGN.md §8).
 *
 * The reader takes untrusted input: every byte access is checked against the header's or the buffer's end, integers
 * are range-checked before they are combined, and nothing recurses on input structure (nested structs are refused
 * rather than parsed). Offsets in messages are byte offsets from the start of the file, so they match a hexdump. */
#define _POSIX_C_SOURCE 200809L /* fileno, fstat, O_CLOEXEC */

#include "internal.h"

#include <errno.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Array bytes are copied between file and memory verbatim and every supported descr is '<' (or byte-sized), so the
 * host must be little-endian. Header lengths are decoded byte by byte and do not depend on this. */
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__)
_Static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "rtoracle's .npy code needs a little-endian host");
#endif

static const unsigned char npy_magic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};

/* numpy pads the preamble so the data starts 64-byte aligned (mmap-friendly), and reserves room for the growth axis
 * to reach 21 digits so a writer can grow the array in place; both are needed to match numpy.save byte for byte. */
#define NPY_ALIGN 64
#define NPY_GROWTH_DIGITS 21
#define NPY_MAX_FILE_BYTES (UINT64_C(16) << 30)
/* Longest header text the writer can produce: 16 fields of 31-character names with 10-digit counts come to under
 * 1 KiB of descr, 4 dims of 20 digits to under 100 bytes of shape. */
#define NPY_HEADER_CAP 4096
/* numpy keeps a dtype's itemsize in a C int and refuses larger records, so neither side goes beyond it. */
#define NPY_MAX_RECORD INT32_MAX
/* Strings from a file are echoed in messages up to this many characters. */
#define NPY_ECHO_MAX 40

typedef struct scalar_info {
    rto_dtype type;
    const char *descr;
    const char *name;
    size_t size;
} scalar_info;

static const scalar_info scalars[] = {
    {RTO_DTYPE_U8, "|u1", "uint8", 1},    {RTO_DTYPE_U32, "<u4", "uint32", 4}, {RTO_DTYPE_U64, "<u8", "uint64", 8},
    {RTO_DTYPE_I32, "<i4", "int32", 4},   {RTO_DTYPE_F32, "<f4", "float32", 4},
};

static const scalar_info *scalar_find(rto_dtype t)
{
    for (size_t i = 0; i < sizeof scalars / sizeof scalars[0]; i++)
        if (scalars[i].type == t)
            return &scalars[i];
    return NULL;
}

/* Field names are limited to what Python's repr() prints between plain single quotes, so that the reader accepts
 * exactly the names the writer can reproduce. */
static bool name_char_ok(unsigned char c) { return c >= 0x20 && c < 0x7f && c != '\'' && c != '"' && c != '\\'; }

/* ---------------------------------------------------------------------------------------------------------------- */
/* String building with truncation tracking: len counts what would have been written, so a too-small buffer is
 * detected after the fact instead of at every append. */

typedef struct sbuf {
    char *p;
    size_t cap;
    size_t len;
} sbuf;

static void sb_add(sbuf *b, const char *s, size_t n)
{
    if (b->len < b->cap) {
        size_t room = b->cap - b->len;
        memcpy(b->p + b->len, s, n < room ? n : room);
    }
    b->len += n;
}

static void sb_str(sbuf *b, const char *s) { sb_add(b, s, strlen(s)); }

static void sb_u64(sbuf *b, uint64_t v)
{
    char t[24];
    int n = snprintf(t, sizeof t, "%llu", (unsigned long long)v);
    sb_add(b, t, (size_t)n);
}

/* NUL-terminates; false if the text did not fit (the buffer then holds a truncated, terminated prefix). */
static bool sb_finish(sbuf *b)
{
    if (b->len < b->cap) {
        b->p[b->len] = '\0';
        return true;
    }
    if (b->cap)
        b->p[b->cap - 1] = '\0';
    return false;
}

/* Python's repr of a tuple of ints: "()", "(5,)", "(2, 3)". */
static void sb_tuple(sbuf *b, const uint64_t *dims, uint32_t n)
{
    sb_str(b, "(");
    for (uint32_t i = 0; i < n; i++) {
        if (i)
            sb_str(b, ", ");
        sb_u64(b, dims[i]);
    }
    sb_str(b, n == 1 ? ",)" : ")");
}

/* The descr as numpy's repr(dtype_to_descr(dtype)); desc must have passed check_desc. */
static void sb_descr(sbuf *b, const rto_npy_desc *d)
{
    if (d->dtype != RTO_DTYPE_STRUCT) {
        sb_str(b, "'");
        sb_str(b, scalar_find(d->dtype)->descr);
        sb_str(b, "'");
        return;
    }
    sb_str(b, "[");
    for (uint32_t i = 0; i < d->nfields; i++) {
        const rto_npy_field *f = &d->fields[i];
        sb_str(b, i ? ", ('" : "('");
        sb_str(b, f->name);
        sb_str(b, "', '");
        sb_str(b, scalar_find(f->type)->descr);
        sb_str(b, "'");
        if (f->count != 1) {
            uint64_t c = f->count;
            sb_str(b, ", ");
            sb_tuple(b, &c, 1);
        }
        sb_str(b, ")");
    }
    sb_str(b, "]");
}

/* A shape for messages; tolerates a corrupt ndim. */
static void format_shape(const rto_npy_desc *d, char *buf, size_t cap)
{
    sbuf b = {buf, cap, 0};
    sb_tuple(&b, d->shape, d->ndim <= RTO_NPY_MAX_DIMS ? d->ndim : RTO_NPY_MAX_DIMS);
    sb_finish(&b);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Descriptions */

size_t rto_dtype_size(rto_dtype t)
{
    const scalar_info *s = scalar_find(t);
    return s ? s->size : 0;
}

size_t rto_npy_itemsize(const rto_npy_desc *desc)
{
    if (!desc)
        return 0;
    if (desc->dtype != RTO_DTYPE_STRUCT)
        return rto_dtype_size(desc->dtype);
    if (desc->nfields == 0 || desc->nfields > RTO_NPY_MAX_FIELDS)
        return 0;
    uint64_t total = 0; /* at most 16 * (2^32 - 1) * 8: cannot wrap */
    for (uint32_t i = 0; i < desc->nfields; i++) {
        size_t s = rto_dtype_size(desc->fields[i].type);
        if (s == 0)
            return 0;
        total += (uint64_t)desc->fields[i].count * s;
    }
    return total <= SIZE_MAX ? (size_t)total : 0;
}

uint64_t rto_npy_count(const rto_npy_desc *desc, int *ok)
{
    int good = 0;
    uint64_t count = 0;
    if (desc && desc->ndim <= RTO_NPY_MAX_DIMS) {
        good = 1;
        count = 1;
        /* A zero dimension makes the array empty whatever the others are, so it must win over an overflow. */
        for (uint32_t i = 0; i < desc->ndim; i++)
            if (desc->shape[i] == 0)
                count = 0;
        for (uint32_t i = 0; count && i < desc->ndim; i++) {
            if (count > UINT64_MAX / desc->shape[i]) {
                good = 0;
                count = 0;
                break;
            }
            count *= desc->shape[i];
        }
    }
    if (ok)
        *ok = good;
    return count;
}

/* Whether the writer can reproduce desc exactly: scalar dtype, or packed fields with unique repr-safe names. */
static rto_status check_desc(const rto_npy_desc *d, rto_msg *msg)
{
    if (!d)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL array description");
    if (d->ndim > RTO_NPY_MAX_DIMS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "ndim %u exceeds the maximum of %d", d->ndim,
                        RTO_NPY_MAX_DIMS);
    if (scalar_find(d->dtype))
        return RTO_OK;
    if (d->dtype != RTO_DTYPE_STRUCT)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "invalid dtype %d", (int)d->dtype);
    if (d->nfields == 0 || d->nfields > RTO_NPY_MAX_FIELDS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "a structured dtype needs 1 to %d fields, got %u",
                        RTO_NPY_MAX_FIELDS, d->nfields);
    uint64_t offset = 0;
    for (uint32_t i = 0; i < d->nfields; i++) {
        const rto_npy_field *f = &d->fields[i];
        const char *nul = memchr(f->name, '\0', sizeof f->name);
        if (!nul)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "field %u: name is not NUL-terminated within %d bytes", i,
                            RTO_NPY_NAME_MAX);
        if (nul == f->name)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "field %u has an empty name", i);
        for (const char *c = f->name; c < nul; c++)
            if (!name_char_ok((unsigned char)*c))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "field %u: names must be printable ASCII without quotes or backslashes", i);
        for (uint32_t j = 0; j < i; j++)
            if (strcmp(d->fields[j].name, f->name) == 0)
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "duplicate field name '%s'", f->name);
        const scalar_info *s = scalar_find(f->type);
        if (!s)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "field '%s': invalid dtype %d", f->name, (int)f->type);
        if (f->count == 0)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "field '%s': count must be at least 1", f->name);
        if (f->offset != offset)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "field '%s': offset %u, but packed fields put it at %llu",
                            f->name, f->offset, (unsigned long long)offset);
        offset += (uint64_t)f->count * s->size;
        if (offset > NPY_MAX_RECORD)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "record size exceeds %ld bytes", (long)NPY_MAX_RECORD);
    }
    return RTO_OK;
}

rto_status rto_npy_descr(const rto_npy_desc *desc, char *buf, size_t cap)
{
    rto_status s = check_desc(desc, NULL);
    if (s != RTO_OK)
        return s;
    if (!buf && cap)
        return RTO_ERR_INVALID_ARGUMENT;
    sbuf b = {buf, cap, 0};
    if (desc->dtype == RTO_DTYPE_STRUCT) {
        sb_descr(&b, desc);
    } else {
        /* The bare string, without the quotes a header needs. */
        sb_str(&b, scalar_find(desc->dtype)->descr);
    }
    return sb_finish(&b) ? RTO_OK : RTO_ERR_BUFFER_TOO_SMALL;
}

rto_npy_desc rto_npy_desc_keys(rto_key_format f, uint64_t n)
{
    rto_npy_desc d;
    memset(&d, 0, sizeof d);
    d.dtype = f == RTO_KEY_U32 ? RTO_DTYPE_U32 : f == RTO_KEY_U64 ? RTO_DTYPE_U64 : RTO_DTYPE_NONE;
    d.ndim = 1;
    d.shape[0] = n;
    return d;
}

rto_npy_desc rto_npy_desc_array(rto_dtype t, uint32_t ndim, uint64_t d0, uint64_t d1, uint64_t d2)
{
    rto_npy_desc d;
    memset(&d, 0, sizeof d);
    /* Only three dimensions can be passed in; a fourth would have no size, so such a request yields a desc the
     * writer refuses rather than a silently empty array. */
    d.dtype = ndim <= 3 ? t : RTO_DTYPE_NONE;
    d.ndim = ndim;
    d.shape[0] = ndim > 0 ? d0 : 0;
    d.shape[1] = ndim > 1 ? d1 : 0;
    d.shape[2] = ndim > 2 ? d2 : 0;
    return d;
}

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
    for (size_t i = 0; i < sizeof scalars / sizeof scalars[0]; i++)
        if (tok_is(t, scalars[i].descr)) {
            *type = scalars[i].type;
            return RTO_OK;
        }
    if (t->n > 0 && t->s[0] == '>')
        return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "big-endian dtype " TOK_FMT " is not supported", TOK_ARG(*t));
    return rto__fail(ps->msg, RTO_ERR_UNSUPPORTED, "unknown dtype " TOK_FMT " (supported: '|u1', '<u4', '<u8', "
                    "'<i4', '<f4')", TOK_ARG(*t));
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
        if (!name_char_ok((unsigned char)name.s[i]))
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
    if (memcmp(p, npy_magic, len < sizeof npy_magic ? len : sizeof npy_magic) != 0)
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
    format_shape(&d, shape, sizeof shape);
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

void rto_npy_free(rto_npy *npy)
{
    if (!npy)
        return;
    free(npy->data);
    memset(npy, 0, sizeof *npy);
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

/* The preamble numpy.save would write for desc: magic, version, header length, header text padded with spaces
 * and a newline to a multiple of 64 bytes. Returns its length; out holds NPY_HEADER_CAP bytes. */
static size_t build_preamble(const rto_npy_desc *d, unsigned char *out)
{
    char text[NPY_HEADER_CAP];
    sbuf b = {text, sizeof text, 0};
    sb_str(&b, "{'descr': ");
    sb_descr(&b, d);
    sb_str(&b, ", 'fortran_order': False, 'shape': ");
    sb_tuple(&b, d->shape, d->ndim);
    sb_str(&b, ", }");
    if (d->ndim > 0) {
        char digits[24];
        int n = snprintf(digits, sizeof digits, "%llu", (unsigned long long)d->shape[0]);
        for (int i = n; i < NPY_GROWTH_DIGITS; i++)
            sb_str(&b, " ");
    }
    if (b.len + 1 + 12 + NPY_ALIGN > NPY_HEADER_CAP)
        return 0; /* cannot happen for a desc that passed check_desc (see NPY_HEADER_CAP) */

    /* numpy pads by 64 - (preamble % 64), so an already aligned header still gets 64 spaces. Version 2.0 only when
     * the header length overflows 16 bits, which the field limits keep from happening. */
    size_t hlen = b.len + 1;
    size_t pre = 10;
    size_t pad = NPY_ALIGN - (pre + hlen) % NPY_ALIGN;
    if (hlen + pad > 0xFFFF) {
        pre = 12;
        pad = NPY_ALIGN - (pre + hlen) % NPY_ALIGN;
    }
    size_t total = hlen + pad;
    memcpy(out, npy_magic, sizeof npy_magic);
    out[6] = pre == 10 ? 1 : 2;
    out[7] = 0;
    for (size_t i = 0; i < pre - 8; i++)
        out[8 + i] = (unsigned char)(total >> (8 * i));
    memcpy(out + pre, text, b.len);
    memset(out + pre + b.len, ' ', pad);
    out[pre + b.len + pad] = '\n';
    return pre + total;
}

/* What the writers and the hasher check and build first: the description, the data's size (*nbytes) and the header
 * (pre, *plen). The one place a file's preamble is made, so a hash from memory is the hash of the file written. */
static rto_status npy_prepare(const char *path, const rto_npy_desc *desc, const void *data, unsigned char *pre,
                              size_t *plen, size_t *nbytes, rto_msg *msg)
{
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path");
    rto_status s = check_desc(desc, msg);
    if (s != RTO_OK)
        return s;
    int ok = 0;
    uint64_t count = rto_npy_count(desc, &ok);
    uint64_t item = rto_npy_itemsize(desc);
    if (!ok || (item && count > UINT64_MAX / item) || count * item > SIZE_MAX) {
        char shape[128];
        format_shape(desc, shape, sizeof shape);
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "shape %s of %llu-byte elements does not fit in memory", shape,
                        (unsigned long long)item);
    }
    *nbytes = (size_t)(count * item);
    if (!data && *nbytes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL data for %zu bytes", *nbytes);
    *plen = build_preamble(desc, pre);
    if (*plen == 0)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "header for '%s' is too long", path);
    return RTO_OK;
}

rto_status rto_npy_write(const char *path, const rto_npy_desc *desc, const void *data, rto_msg *msg)
{
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(path, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;

    /* Atomically through a temporary sibling (io/atomic.c): a reader never sees half a file and a failed write
     * leaves the previous file intact. /dev/null or a FIFO is written through and never unlinked. */
    rto_atomic_file f;
    s = rto__atomic_open(&f, path, true, msg);
    if (s != RTO_OK)
        return s;
    errno = 0;
    if (fwrite(pre, 1, plen, f.fp) != plen || (nbytes && fwrite(data, 1, nbytes, f.fp) != nbytes)) {
        int e = errno;
        rto__atomic_discard(&f);
        return rto__fail(msg, RTO_ERR_IO, "writing '%s': %s", path, strerror(e ? e : EIO));
    }
    return rto__atomic_close(&f, msg);
}

/* The file's bytes are the preamble then the data: both writers and the hasher go through these two parts. */
static void hex_digest(const unsigned char md[32], char hex[65])
{
    for (unsigned i = 0; i < 32; i++)
        snprintf(hex + 2 * i, 3, "%02x", md[i]);
}

rto_status rto__npy_hash(const char *name, const rto_npy_desc *desc, const void *data, char hex[65],
                         uint64_t *file_bytes, rto_msg *msg)
{
    if (!hex || !file_bytes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL hex or size");
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(name, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    int ok = ctx && EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) == 1 && EVP_DigestUpdate(ctx, pre, plen) == 1 &&
             (!nbytes || EVP_DigestUpdate(ctx, data, nbytes) == 1) && EVP_DigestFinal_ex(ctx, md, &mdlen) == 1 &&
             mdlen == 32;
    EVP_MD_CTX_free(ctx);
    if (!ok)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot compute SHA-256");
    hex_digest(md, hex);
    *file_bytes = (uint64_t)plen + nbytes;
    return RTO_OK;
}

rto_status rto__npy_write_hashed(const char *path, const rto_npy_desc *desc, const void *data, char hex[65],
                                 rto_msg *msg)
{
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(path, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;
    EVP_MD_CTX *ctx = hex ? EVP_MD_CTX_new() : NULL;
    if (hex && (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1)) {
        EVP_MD_CTX_free(ctx);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot start SHA-256");
    }
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        EVP_MD_CTX_free(ctx);
        return rto__fail(msg, RTO_ERR_IO, "cannot create %s: %s", path, strerror(errno));
    }
    /* The bytes are hashed as they go out, in the same chunks, while they are still in cache. */
    const unsigned char *parts[2] = {pre, data};
    const size_t lens[2] = {plen, nbytes};
    int err = 0;
    for (int k = 0; k < 2 && !err; k++) {
        for (size_t at = 0; at < lens[k] && !err;) {
            size_t chunk = lens[k] - at < (1u << 20) ? lens[k] - at : (1u << 20);
            ssize_t w = write(fd, parts[k] + at, chunk);
            if (w < 0 && errno == EINTR)
                continue;
            if (w <= 0) {
                err = w < 0 ? errno : EIO;
                break;
            }
            if (ctx)
                EVP_DigestUpdate(ctx, parts[k] + at, (size_t)w);
            at += (size_t)w;
        }
    }
    if (close(fd) != 0 && !err)
        err = errno;
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    if (!err && ctx && (EVP_DigestFinal_ex(ctx, md, &mdlen) != 1 || mdlen != 32))
        err = ENOMEM;
    EVP_MD_CTX_free(ctx);
    if (err) {
        unlink(path); /* ours: created above with O_EXCL */
        return rto__fail(msg, RTO_ERR_IO, "writing '%s': %s", path, strerror(err));
    }
    if (hex)
        hex_digest(md, hex);
    return RTO_OK;
}

rto_status rto_npy_as_keys(const rto_npy *npy, rto_key_format *f, size_t *n, rto_msg *msg)
{
    if (!npy || !f || !n)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL argument");
    const rto_npy_desc *d = &npy->desc;
    if (d->ndim == 1 && (d->dtype == RTO_DTYPE_U32 || d->dtype == RTO_DTYPE_U64)) {
        uint64_t size = rto_dtype_size(d->dtype);
        /* A hand-filled rto_npy could disagree with itself; keys are read through data, so check it covers them. */
        if (d->shape[0] > SIZE_MAX / size || npy->nbytes != d->shape[0] * size || (!npy->data && npy->nbytes))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "array of %llu keys holds %zu data bytes",
                            (unsigned long long)d->shape[0], npy->nbytes);
        *f = d->dtype == RTO_DTYPE_U32 ? RTO_KEY_U32 : RTO_KEY_U64;
        *n = (size_t)d->shape[0];
        return RTO_OK;
    }
    char shape[128];
    format_shape(d, shape, sizeof shape);
    const scalar_info *s = scalar_find(d->dtype);
    if (s)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                        "expected a 1-D array of uint32 or uint64 keys, got %s with shape %s", s->name, shape);
    char descr[NPY_HEADER_CAP];
    if (d->dtype == RTO_DTYPE_STRUCT && rto_npy_descr(d, descr, sizeof descr) == RTO_OK)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                        "expected a 1-D array of uint32 or uint64 keys, got structured dtype %s with shape %s", descr,
                        shape);
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                    "expected a 1-D array of uint32 or uint64 keys, got invalid dtype %d with shape %s", (int)d->dtype,
                    shape);
}
