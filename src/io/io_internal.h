/* Private pieces of the I/O stage (src/io/) used beyond the file that defines them: path joining and the input-file
 * opener, atomic output (atomic.c), bundle entries that are not .npy arrays and what a bundle reader lists
 * (bundle.c, bundle_read.c; check-frame reads bundles through it too), stamps (stamp.c), PNG encoding (png_write.c)
 * and .npy writes hashed from memory (npy_write.c). What only the bundle or the .npy files share is in
 * bundle_internal.h and npy_internal.h. Not installed; not exported. */
#ifndef RTO_IO_INTERNAL_H
#define RTO_IO_INTERNAL_H

#include "../core/internal.h"

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** dir + "/" + name in new memory (NULL when out of memory); the caller frees it (io/bundle.c). */
char *rto__path_join(const char *dir, const char *name);

/* Input files (io/npy_read.c). */

/**
 * Opens path for reading only if it is a regular file (a symbolic link is followed): a FIFO, a directory or a device
 * (/dev/zero) is refused at once, without blocking in open() and without a byte read, so no input can hang the
 * command or make it read without end. *size gets the file's size. NULL with *status set and msg written on refusal.
 */
FILE *rto__open_regular(const char *path, uint64_t *size, rto_status *status, rto_msg *msg);

/* Atomic output (io/atomic.c). */

/** Creates `target.tmp.PID-XXXXXX` (a directory with mode 0777, or a file with 0666 whose descriptor goes to *fd; the
 * umask applies) and lists it for rto_temporaries_remove. *tmp is malloc'ed. */
rto_status rto__tmp_create(const char *target, bool is_dir, char **tmp, int *fd, rto_msg *msg);
/** Takes a temporary off the list (after it was renamed into place or removed). */
void rto__tmp_forget(const char *tmp);
/** Blocks SIGINT, SIGTERM and SIGHUP in the calling thread while a temporary is created, renamed or removed. */
void rto__signals_hold(sigset_t *old);
void rto__signals_release(const sigset_t *old);
/**
 * Where output to path may go (*where, malloc'ed): path itself when absent (its directory must exist) or a regular
 * file / directory (is_dir); the real path for a symbolic link or "." / ".."; path written through in place
 * (*in_place) for a character device or FIFO when allow_special. Everything else is refused.
 */
rto_status rto__output_target(const char *path, bool is_dir, bool allow_special, char **where, bool *in_place,
                             rto_msg *msg);

/** A file being written atomically: fp writes to tmp, which rto__atomic_close renames to path. */
typedef struct rto_atomic_file {
    FILE *fp;
    char *path;
    char *tmp; /* NULL when written in place */
    bool in_place;
} rto_atomic_file;
rto_status rto__atomic_open(rto_atomic_file *f, const char *path, bool allow_special, rto_msg *msg);
/** Flushes, closes and renames into place; on any failure the temporary is removed. */
rto_status rto__atomic_close(rto_atomic_file *f, rto_msg *msg);
/** Closes and removes the temporary (a failed write). */
void rto__atomic_discard(rto_atomic_file *f);

/* Bundle entries that are not .npy arrays (io/bundle.c owns manifest.json; io/image.c writes and reads images). */

/** Writes name (a plain file name) into the bundle's temporary directory with write(path, image) and lists it like an
 * array: name, role, sha256 of the file written, and "image": {width, height, channels, type ("u8" / "f32")}. A
 * failure, the writer's included, is kept for rto_bundle_commit. */
rto_status rto__bundle_add_image(rto_bundle *b, const char *name, const char *role, const rto_image *image,
                                 rto_status (*write)(const char *path, const rto_image *image, rto_msg *msg),
                                 rto_msg *msg);
/** The path (malloc'ed, in *path) of the file the manifest lists as name, once its sha256 matches the manifest's. */
rto_status rto__bundle_checked_path(rto_bundle_reader *r, const char *name, char **path, rto_msg *msg);
/** 1 when the manifest of a bundle opened for reading lists a file of that name (on disk or not), else 0: how a
 * reader tells a file the writer did not keep from one that was removed. */
int rto__bundle_lists(rto_bundle_reader *r, const char *name);

/* Up-to-date bundles (io/stamp.c). */

/** The stamp text's head for a request and its source files (malloc'ed in *out), hashing each source now. *out stays
 * NULL (and RTO_OK is returned) when the bundle cannot be stamped: no build identity, or source names that do not
 * fit the record; such a bundle is simply rewritten by every run. */
rto_status rto__stamp_head(const char *request, const char *const *sources, size_t count, char **out, rto_msg *msg);
/** Stamps a finished bundle directory (manifest.json written) with head plus the digest of its files; a file system
 * without user extended attributes leaves it unstamped. head NULL: nothing. */
void rto__stamp_write(const char *dir, const char *head);

/** An 8-bit image of 1 to 4 channels as PNG file bytes (io/png_write.c, libpng; malloc'ed in *bytes). */
rto_status rto__png_encode(const rto_image *im, unsigned char **bytes, size_t *len, rto_msg *msg);

/* .npy files hashed from memory (io/npy_write.c), for bundles. */

/** Writes an .npy file that does not exist yet (O_EXCL; inside a bundle's temporary directory, which is itself what
 * is made atomic) and, unless hex is NULL, its SHA-256, hashed from memory while writing: no second read of the file.
 * Never opens an existing file for writing. */
rto_status rto__npy_write_hashed(const char *path, const rto_npy_desc *desc, const void *data, char hex[65],
                                 rto_msg *msg);
/** The SHA-256 and size of the .npy file rto__npy_write_hashed would write for desc and data, from memory (the same
 * preamble, built by the same code); name is only for messages. */
rto_status rto__npy_hash(const char *name, const rto_npy_desc *desc, const void *data, char hex[65],
                         uint64_t *file_bytes, rto_msg *msg);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
