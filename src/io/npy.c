/* .npy files (NumPy format 1.0 / 2.0 / 3.0), read and written byte-compatibly with numpy.save (DESIGN.md §8): the
 * array descriptions, the dtypes, and the header text a writer produces (npy_internal.h). Parsing and reading are
 * in npy_read.c, writing and hashing in npy_write.c. */
#include "npy_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Array bytes are copied between file and memory verbatim and every supported descr is '<' (or byte-sized), so the
 * host must be little-endian. Header lengths are decoded byte by byte and do not depend on this. */
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__)
_Static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "rtoracle's .npy code needs a little-endian host");
#endif

const unsigned char rto__npy_magic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};

/* numpy pads the preamble so the data starts 64-byte aligned (mmap-friendly), and reserves room for the growth axis
 * to reach 21 digits so a writer can grow the array in place; both are needed to match numpy.save byte for byte. */
#define NPY_ALIGN 64
#define NPY_GROWTH_DIGITS 21

const scalar_info rto__npy_scalars[RTO__NPY_SCALARS] = {
    {RTO_DTYPE_U8, "|u1", "uint8", 1},    {RTO_DTYPE_U32, "<u4", "uint32", 4}, {RTO_DTYPE_U64, "<u8", "uint64", 8},
    {RTO_DTYPE_I32, "<i4", "int32", 4},   {RTO_DTYPE_F32, "<f4", "float32", 4}, {RTO_DTYPE_U16, "<u2", "uint16", 2},
    {RTO_DTYPE_F16, "<f2", "float16", 2},
};

const scalar_info *rto__npy_scalar_find(rto_dtype t)
{
    for (size_t i = 0; i < sizeof rto__npy_scalars / sizeof rto__npy_scalars[0]; i++)
        if (rto__npy_scalars[i].type == t)
            return &rto__npy_scalars[i];
    return NULL;
}

/* Field names are limited to what Python's repr() prints between plain single quotes, so that the reader accepts
 * exactly the names the writer can reproduce. */
bool rto__npy_name_char_ok(unsigned char c) { return c >= 0x20 && c < 0x7f && c != '\'' && c != '"' && c != '\\'; }

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
        sb_str(b, rto__npy_scalar_find(d->dtype)->descr);
        sb_str(b, "'");
        return;
    }
    sb_str(b, "[");
    for (uint32_t i = 0; i < d->nfields; i++) {
        const rto_npy_field *f = &d->fields[i];
        sb_str(b, i ? ", ('" : "('");
        sb_str(b, f->name);
        sb_str(b, "', '");
        sb_str(b, rto__npy_scalar_find(f->type)->descr);
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
void rto__npy_format_shape(const rto_npy_desc *d, char *buf, size_t cap)
{
    sbuf b = {buf, cap, 0};
    sb_tuple(&b, d->shape, d->ndim <= RTO_NPY_MAX_DIMS ? d->ndim : RTO_NPY_MAX_DIMS);
    sb_finish(&b);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Descriptions */

size_t rto_dtype_size(rto_dtype t)
{
    const scalar_info *s = rto__npy_scalar_find(t);
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
rto_status rto__npy_check_desc(const rto_npy_desc *d, rto_msg *msg)
{
    if (!d)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL array description");
    if (d->ndim > RTO_NPY_MAX_DIMS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "ndim %u exceeds the maximum of %d", d->ndim,
                        RTO_NPY_MAX_DIMS);
    if (rto__npy_scalar_find(d->dtype))
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
            if (!rto__npy_name_char_ok((unsigned char)*c))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "field %u: names must be printable ASCII without quotes or backslashes", i);
        for (uint32_t j = 0; j < i; j++)
            if (strcmp(d->fields[j].name, f->name) == 0)
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "duplicate field name '%s'", f->name);
        const scalar_info *s = rto__npy_scalar_find(f->type);
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
    rto_status s = rto__npy_check_desc(desc, NULL);
    if (s != RTO_OK)
        return s;
    if (!buf && cap)
        return RTO_ERR_INVALID_ARGUMENT;
    sbuf b = {buf, cap, 0};
    if (desc->dtype == RTO_DTYPE_STRUCT) {
        sb_descr(&b, desc);
    } else {
        /* The bare string, without the quotes a header needs. */
        sb_str(&b, rto__npy_scalar_find(desc->dtype)->descr);
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

/* The preamble numpy.save would write for desc: magic, version, header length, header text padded with spaces
 * and a newline to a multiple of 64 bytes. Returns its length; out holds NPY_HEADER_CAP bytes. */
size_t rto__npy_preamble(const rto_npy_desc *d, unsigned char *out)
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
    memcpy(out, rto__npy_magic, sizeof rto__npy_magic);
    out[6] = pre == 10 ? 1 : 2;
    out[7] = 0;
    for (size_t i = 0; i < pre - 8; i++)
        out[8 + i] = (unsigned char)(total >> (8 * i));
    memcpy(out + pre, text, b.len);
    memset(out + pre + b.len, ' ', pad);
    out[pre + b.len + pad] = '\n';
    return pre + total;
}

void rto_npy_free(rto_npy *npy)
{
    if (!npy)
        return;
    free(npy->data);
    memset(npy, 0, sizeof *npy);
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
    rto__npy_format_shape(d, shape, sizeof shape);
    const scalar_info *s = rto__npy_scalar_find(d->dtype);
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
