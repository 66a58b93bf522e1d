/* Bundles written together sharing identical arrays (DESIGN.md §8; rtoracle.h, rto_bundle_share): the share table,
 * and the links a bundle makes to a file it or an earlier committed bundle wrote (bundle_internal.h). */
#include "bundle_internal.h"
#include "io_internal.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* Shared arrays (rtoracle.h, rto_bundle_share)                                                                     */

/* Open addressing on the sha256's first 64 bits, linear probing, at most half full. */
struct rto_bundle_share {
    share_file *slot; /* path NULL: empty */
    size_t cap, used;
};

rto_bundle_share *rto_bundle_share_create(void)
{
    rto_bundle_share *t = calloc(1, sizeof *t);
    if (t && !(t->slot = calloc(t->cap = 1024, sizeof *t->slot))) {
        free(t);
        t = NULL;
    }
    return t;
}

void rto_bundle_share_destroy(rto_bundle_share *t)
{
    if (!t)
        return;
    for (size_t i = 0; i < t->cap; i++)
        free(t->slot[i].path);
    free(t->slot);
    free(t);
}

void rto_bundle_set_share(rto_bundle *b, rto_bundle_share *t)
{
    if (b)
        b->share = t;
}

static size_t share_home(const rto_bundle_share *t, const char *hex)
{
    uint64_t h = 0;
    for (int i = 0; i < 16; i++)
        h = h << 4 | (uint64_t)(hex[i] <= '9' ? hex[i] - '0' : hex[i] - 'a' + 10);
    return (size_t)(h & (t->cap - 1));
}

/* The slot of (hex, bytes), or the empty slot where it would go. */
static share_file *share_slot(rto_bundle_share *t, const char *hex, uint64_t bytes)
{
    for (size_t i = share_home(t, hex);; i = (i + 1) & (t->cap - 1)) {
        share_file *e = &t->slot[i];
        if (!e->path || (e->bytes == bytes && !memcmp(e->hex, hex, 64)))
            return e;
    }
}

/* Whether path is still the file recorded in e: a regular file with the same inode, size and mtime. */
static bool share_unchanged(const share_file *e, const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0 && S_ISREG(st.st_mode) && st.st_dev == e->dev && st.st_ino == e->ino &&
           st.st_size == e->size && (uint64_t)st.st_size == e->bytes && st.st_mtim.tv_sec == e->mtime.tv_sec &&
           st.st_mtim.tv_nsec == e->mtime.tv_nsec;
}

static bool share_record(share_file *e, const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return false;
    e->dev = st.st_dev;
    e->ino = st.st_ino;
    e->size = st.st_size;
    e->mtime = st.st_mtim;
    return true;
}

/* Registers a file the bundle wrote, now at path (final), replacing what the table had for the same content (a file
 * found changed, or one a link to failed): the newest copy is the one to link to. Out of memory: not registered. */
static void share_register(rto_bundle_share *t, const share_file *own, const char *path)
{
    if (t->used + 1 > t->cap / 2) {
        share_file *old = t->slot;
        size_t old_cap = t->cap;
        share_file *grown = calloc(old_cap * 2, sizeof *grown);
        if (!grown)
            return;
        t->slot = grown;
        t->cap = old_cap * 2;
        for (size_t i = 0; i < old_cap; i++)
            if (old[i].path)
                *share_slot(t, old[i].hex, old[i].bytes) = old[i];
        free(old);
    }
    share_file rec = *own;
    char *copy = strdup(path);
    if (!copy || !share_record(&rec, path)) {
        free(copy);
        return;
    }
    rec.path = copy;
    share_file *e = share_slot(t, own->hex, own->bytes);
    if (e->path)
        free(e->path);
    else
        t->used++;
    *e = rec;
}

/* The link just made at path (in the bundle's temporary directory) is the recorded file: the file was not replaced
 * between the check and link(). Otherwise the new name is removed again (it is the bundle's own) and not used. */
static bool linked_as_recorded(const share_file *e, const char *path)
{
    if (share_unchanged(e, path))
        return true;
    unlink(path);
    return false;
}

/* Links path to an identical file the bundle wrote already or the table lists, if one is still as recorded.
 * true: linked. */
bool rto__bundle_share_link(rto_bundle *b, const char *hex, uint64_t bytes, const char *path)
{
    for (size_t i = 0; i < b->own_count; i++) {
        const share_file *e = &b->own[i];
        if (e->bytes != bytes || memcmp(e->hex, hex, 64) != 0)
            continue;
        char *src = rto__path_join(b->tmpdir, e->path);
        bool ok = src && share_unchanged(e, src) && link(src, path) == 0 && linked_as_recorded(e, path);
        free(src);
        if (ok)
            return true;
    }
    const share_file *e = share_slot(b->share, hex, bytes);
    return e->path && share_unchanged(e, e->path) && link(e->path, path) == 0 && linked_as_recorded(e, path);
}

/* Remembers a file the bundle wrote (name in its temporary directory) for links within the bundle and for commit.
 * Out of memory: it is just not shared. */
void rto__bundle_share_own(rto_bundle *b, const char *name, const char *hex, uint64_t bytes, const char *path)
{
    if (b->own_count == b->own_cap) {
        size_t cap = b->own_cap ? 2 * b->own_cap : 8;
        share_file *grown = realloc(b->own, cap * sizeof *grown);
        if (!grown)
            return;
        b->own = grown;
        b->own_cap = cap;
    }
    share_file *e = &b->own[b->own_count];
    memcpy(e->hex, hex, 65);
    e->bytes = bytes;
    if (!share_record(e, path) || !(e->path = strdup(name)))
        return;
    b->own_count++;
}

/* At commit, once the bundle is at outdir: its own files go into the table under their final paths. */
void rto__bundle_share_commit(rto_bundle *b)
{
    for (size_t i = 0; i < b->own_count; i++) {
        char *path = rto__path_join(b->outdir, b->own[i].path);
        if (path)
            share_register(b->share, &b->own[i], path);
        free(path);
    }
}
