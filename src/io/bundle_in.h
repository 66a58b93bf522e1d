/* Reading a stage's bundle back (every rto_<stage>_bundle_read): each array is checked like a GPU dump before use —
 * dtype and shape as the manifest implies, counts in range — and a bundle that disagrees with itself is refused with
 * one line naming the directory and the file ("DIR: FILE: what"). Private to the library. */
#ifndef RTO_BUNDLE_IN_H
#define RTO_BUNDLE_IN_H

#include "core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** An open bundle being read, with the directory named in messages. */
typedef struct rto__bundle_in {
    rto_bundle_reader *r;
    const char *dir;
    rto_msg *msg;
} rto__bundle_in;

/**
 * Opens dir and, with kind, requires the manifest's kind to be it: a bundle of another kind is refused with "DIR is
 * not a KIND bundle (rtoracle WRITER)". in->r is NULL on failure; close with rto__bundle_in_close either way.
 */
rto_status rto__bundle_in_open(rto__bundle_in *in, const char *dir, const char *kind, const char *writer, rto_msg *msg);
void rto__bundle_in_close(rto__bundle_in *in);
/** Refuses the bundle: "DIR: FILE: text" into in->msg; returns RTO_ERR_PARSE. */
rto_status rto__bundle_refuse(const rto__bundle_in *in, const char *file, const char *fmt, ...) RTO_PRINTF(3, 4);
/** A manifest count section.key in 0 .. max, or the bundle refused. */
rto_status rto__bundle_count(const rto__bundle_in *in, const char *section, const char *key, uint64_t max,
                             size_t *out);
/** Reads the listed array name (sha256 checked) and requires want's dtype and shape (want->shape[0] UINT64_MAX:
 * any row count); layout names a structured dtype in the message. */
rto_status rto__bundle_load(const rto__bundle_in *in, const char *name, const rto_npy_desc *want, const char *layout,
                            rto_npy *out);
/** The name of a bundle file (rto_bundle_file_name; every name fits). */
const char *rto__bundle_name(rto_bundle_file f, uint32_t index, char name[RTO_BUNDLE_FILE_NAME_MAX]);
/** Whether all n floats are finite. */
bool rto__all_finite(const float *v, size_t n);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
