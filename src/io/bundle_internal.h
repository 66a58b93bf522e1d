/* Private pieces of the bundle code shared by its files: bundle.c (writing), bundle_share.c (the share table),
 * bundle_read.c (reading). Not installed; not exported. */
#ifndef RTO_IO_BUNDLE_INTERNAL_H
#define RTO_IO_BUNDLE_INTERNAL_H

#include "../core/internal.h"

#include <jansson.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>
#include <time.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/* A file a bundle wrote: its content (sha256 and size) and where it is, with the inode, size and mtime it had when
 * recorded. A file that no longer has them was changed or replaced by someone else and is not linked to. */
typedef struct share_file {
    char hex[65];
    uint64_t bytes;
    char *path; /* the bundle's own files: the name in its temporary directory; the table's: the final path */
    dev_t dev;
    ino_t ino;
    off_t size;
    struct timespec mtime;
} share_file;

struct rto_bundle {
    char *name;   /* outdir as the caller gave it, for messages */
    char *outdir; /* where the bundle goes: name, or the real path a symbolic link names */
    char *tmpdir;
    json_t *root;
    json_t *files;
    json_t *cases;
    char *stamp; /* the stamp's head (rto_bundle_set_request), written at commit; NULL: unstamped */
    /* The first failure of a setter, kept so that rto_bundle_commit fails with it even when the caller ignored it. */
    rto_status err;
    rto_msg err_msg;
    /* Shared arrays (rto_bundle_set_share): the table, and the arrays this bundle wrote itself (not linked), which
     * other arrays of the bundle may link to and which commit registers in the table. */
    rto_bundle_share *share;
    struct share_file *own;
    size_t own_count, own_cap;
};

/** A name a bundle may list: not empty, no '/', not "." or "..". */
int rto__bundle_plain_name(const char *name);
/** The object section of a manifest (root itself for NULL or ""), made when create is set; NULL if it is not an
 * object (or making it failed). */
json_t *rto__bundle_section(json_t *root, const char *section, int create);

/** Links path (in the bundle's temporary directory) to an identical file the bundle wrote already or the table lists,
 * if one is still as recorded. true: linked. */
bool rto__bundle_share_link(rto_bundle *b, const char *hex, uint64_t bytes, const char *path);
/** Remembers a file the bundle wrote (name in its temporary directory) for links within the bundle and for commit. */
void rto__bundle_share_own(rto_bundle *b, const char *name, const char *hex, uint64_t bytes, const char *path);
/** At commit, once the bundle is at outdir: its own files go into the table under their final paths. */
void rto__bundle_share_commit(rto_bundle *b);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
