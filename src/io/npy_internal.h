/* Private pieces of the .npy code shared by its files: npy.c (descriptions, dtypes, the header text), npy_read.c
 * (the parser and the reader), npy_write.c (the writers and the hash). Not installed; not exported. */
#ifndef RTO_IO_NPY_INTERNAL_H
#define RTO_IO_NPY_INTERNAL_H

#include "../core/internal.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* Longest header text the writer can produce: 16 fields of 31-character names with 10-digit counts come to under
 * 1 KiB of descr, 4 dims of 20 digits to under 100 bytes of shape. */
#define NPY_HEADER_CAP 4096
/* numpy keeps a dtype's itemsize in a C int and refuses larger records, so neither side goes beyond it. */
#define NPY_MAX_RECORD INT32_MAX

/** The six bytes every .npy file starts with. */
extern const unsigned char rto__npy_magic[6];

typedef struct scalar_info {
    rto_dtype type;
    const char *descr;
    const char *name;
    size_t size;
} scalar_info;

/** The scalar dtypes, with numpy's descr and name. */
#define RTO__NPY_SCALARS 7
extern const scalar_info rto__npy_scalars[RTO__NPY_SCALARS];
/** The scalar dtype t, NULL if t is none (RTO_DTYPE_STRUCT included). */
const scalar_info *rto__npy_scalar_find(rto_dtype t);
/** Whether a field name may hold c: what Python's repr() prints between plain single quotes. */
bool rto__npy_name_char_ok(unsigned char c);
/** Whether the writer can reproduce desc exactly: scalar dtype, or packed fields with unique repr-safe names. */
rto_status rto__npy_check_desc(const rto_npy_desc *d, rto_msg *msg);
/** A shape for messages, "(2, 3)"; tolerates a corrupt ndim. */
void rto__npy_format_shape(const rto_npy_desc *d, char *buf, size_t cap);
/** The preamble numpy.save would write for desc (which passed rto__npy_check_desc): magic, version, header length,
 * header text padded to a multiple of 64 bytes. Returns its length; out holds NPY_HEADER_CAP bytes. */
size_t rto__npy_preamble(const rto_npy_desc *d, unsigned char *out);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
