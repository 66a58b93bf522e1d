/* Golden bundles (DESIGN.md §8): a directory of .npy files plus manifest.json. A bundle is built in a temporary
 * sibling directory and renamed into place, so a reader never sees a half-written bundle and a failed run never
 * leaves one behind. The manifest is written by jansson with a fixed key order and no timestamps, so the same
 * inputs give the same bytes. */
#define _GNU_SOURCE /* renameat2 (glibc >= 2.28) */
#include "internal.h"
#include "core/json.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <stdarg.h>
#include <jansson.h>
#include <math.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

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

struct rto_bundle_reader {
    char *dir;
    json_t *root;
};

rto_status rto_sha256_file(const char *path, char hex[65], rto_msg *msg)
{
    /* A bundle's file may be anything by now: a FIFO or a link to /dev/zero would hash forever. */
    uint64_t size;
    rto_status opened = RTO_OK;
    FILE *fp = rto__open_regular(path, &size, &opened, msg);
    if (!fp)
        return opened;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    rto_status s = RTO_OK;
    if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1) {
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot start SHA-256");
        goto out;
    }
    unsigned char buf[1 << 16];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, fp)) > 0)
        EVP_DigestUpdate(ctx, buf, got);
    if (ferror(fp)) {
        s = rto__fail(msg, RTO_ERR_IO, "%s: read error", path);
        goto out;
    }
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    EVP_DigestFinal_ex(ctx, md, &mdlen);
    for (unsigned i = 0; i < 32; i++)
        snprintf(hex + 2 * i, 3, "%02x", md[i]);
out:
    EVP_MD_CTX_free(ctx);
    fclose(fp);
    return s;
}

char *rto__path_join(const char *dir, const char *name)
{
    size_t a = strlen(dir), b = strlen(name);
    char *p = malloc(a + b + 2);
    if (p) {
        memcpy(p, dir, a);
        p[a] = '/';
        memcpy(p + a + 1, name, b + 1);
    }
    return p;
}

static int rm_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st;
    (void)flag;
    (void)ftw;
    return remove(path);
}

/* Removes a temporary directory of our own making (nothing in it is the user's). */
static void remove_tree(const char *path)
{
    if (path)
        nftw(path, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

static int plain_name(const char *name)
{
    return name && *name && !strchr(name, '/') && strcmp(name, ".") && strcmp(name, "..");
}

/* 1: an empty directory, 0: anything else (not empty, not a directory, unreadable). */
static int empty_dir(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0 || !S_ISDIR(st.st_mode))
        return 0;
    DIR *d = opendir(path);
    if (!d)
        return 0;
    int empty = 1;
    for (struct dirent *e; empty && (e = readdir(d));)
        empty = !strcmp(e->d_name, ".") || !strcmp(e->d_name, "..");
    closedir(d);
    return empty;
}

#define RTO_STR_(x) #x
#define RTO_STR(x) RTO_STR_(x)

/* A manifest larger than this is not one rtoracle wrote (a suite of every case lists ~1 MB). */
#define MANIFEST_BYTES_MAX (64u << 20)
/* Bundles nest one level (a suite's cases); the bound only stops a hostile tree. */
#define BUNDLE_NEST_MAX 4

/* The one refusal message of a directory that is not ours: "refusing to replace TOP: it is not an rtoracle bundle
 * (REASON)". */
static rto_status refuse(rto_msg *msg, const char *top, const char *fmt, ...) RTO_PRINTF(3, 4);
static rto_status refuse(rto_msg *msg, const char *top, const char *fmt, ...)
{
    char reason[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(reason, sizeof reason, fmt, ap);
    va_end(ap);
    return rto__fail(msg, RTO_ERR_IO, "refusing to replace %s: it is not an rtoracle bundle (%s)", top, reason);
}

/* Loads dir/manifest.json if it is an rtoracle bundle manifest of this format version, else says why not. */
static rto_status load_own_manifest(const char *dir, const char *top, json_t **out, rto_msg *msg)
{
    *out = NULL;
    char *path = rto__path_join(dir, "manifest.json");
    if (!path)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    struct stat st;
    json_t *root = NULL;
    json_error_t jerr;
    rto_status s = RTO_OK;
    if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
        s = refuse(msg, top, "%s holds no manifest.json", dir);
    else if ((uint64_t)st.st_size > MANIFEST_BYTES_MAX)
        s = refuse(msg, top, "%s has %lld bytes", path, (long long)st.st_size);
    else if (!(root = json_load_file(path, JSON_REJECT_DUPLICATES, &jerr)))
        s = json_error_code(&jerr) == json_error_out_of_memory
                ? rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "%s: out of memory reading %s", top, path)
                : refuse(msg, top, "%s: %s", path, jerr.text);
    if (root) {
        const char *format = json_string_value(json_object_get(root, "format"));
        json_t *version = json_object_get(root, "format_version");
        const char *why = NULL;
        if (!format || strcmp(format, "rtoracle-bundle") != 0)
            why = "\"format\" is not \"rtoracle-bundle\"";
        else if (!json_is_integer(version) || json_integer_value(version) != RTO_BUNDLE_FORMAT_VERSION)
            why = "\"format_version\" is not " RTO_STR(RTO_BUNDLE_FORMAT_VERSION) ", the one this rtoracle writes";
        else if (!json_is_array(json_object_get(root, "files")))
            why = "no \"files\" list";
        if (why) {
            s = refuse(msg, top, "%s: %s", path, why);
            json_decref(root);
            root = NULL;
        }
    }
    free(path);
    *out = root;
    return s;
}

/* What a manifest lists: file name -> true, suite case directory -> false. Refuses an entry that is not a plain
 * name, names manifest.json, or is listed once as a file and once as a case. */
static rto_status listed_entries(json_t *manifest, const char *dir, const char *top, json_t **out, rto_msg *msg)
{
    json_t *set = json_object();
    *out = NULL;
    if (!set)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    static const struct {
        const char *list, *field;
        int is_file;
    } kinds[] = {{"files", "name", 1}, {"cases", "dir", 0}};
    for (size_t k = 0; k < 2; k++) {
        json_t *arr = json_object_get(manifest, kinds[k].list), *e;
        size_t i;
        if (arr && !json_is_array(arr)) {
            json_decref(set);
            return refuse(msg, top, "%s/manifest.json: \"%s\" is not a list", dir, kinds[k].list);
        }
        json_array_foreach(arr, i, e)
        {
            const char *name = json_string_value(json_object_get(e, kinds[k].field));
            json_t *prev = name ? json_object_get(set, name) : NULL;
            if (!plain_name(name) || !strcmp(name, "manifest.json") ||
                (prev && json_is_true(prev) != kinds[k].is_file)) {
                json_decref(set);
                return refuse(msg, top, "%s/manifest.json: %s entry %zu is not a plain name", dir, kinds[k].list, i);
            }
            if (json_object_set_new(set, name, json_boolean(kinds[k].is_file))) {
                json_decref(set);
                return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
            }
        }
    }
    *out = set;
    return RTO_OK;
}

/*
 * Whether dir is an rtoracle bundle that a new bundle may replace (the rules of rto_bundle_begin): a real directory
 * (not a link), manifest.json ours, and every other entry listed in it — a file as a regular file, a suite case as a
 * directory that passes the same test. A single entry the manifest does not list (a user's notes, an index.html)
 * makes it not ours. With remove, it then deletes what it checked and only that, going by the manifest's list
 * rather than by what the directory holds, so a file that appears meanwhile survives (and keeps its directory).
 */
static rto_status scan_bundle(const char *dir, const char *top, int depth, bool remove, rto_msg *msg)
{
    struct stat st;
    if (lstat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return refuse(msg, top, "%s is not a directory", dir);
    json_t *manifest = NULL, *listed = NULL;
    rto_status s = load_own_manifest(dir, top, &manifest, msg);
    if (!s)
        s = listed_entries(manifest, dir, top, &listed, msg);
    json_decref(manifest);
    if (s)
        return s;
    DIR *d = opendir(dir);
    if (!d)
        s = rto__fail(msg, RTO_ERR_IO, "refusing to replace %s: cannot list %s: %s", top, dir, strerror(errno));
    for (struct dirent *e; !s && d && (e = readdir(d));) {
        const char *name = e->d_name;
        if (!strcmp(name, ".") || !strcmp(name, "..") || !strcmp(name, "manifest.json"))
            continue;
        json_t *kind = json_object_get(listed, name); /* NULL also for a name that is not UTF-8 */
        char *path = rto__path_join(dir, name);
        if (!path)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        else if (!kind)
            s = refuse(msg, top, "%s is not listed in its manifest.json", path);
        else if (lstat(path, &st) != 0)
            s = rto__fail(msg, RTO_ERR_IO, "refusing to replace %s: %s: %s", top, path, strerror(errno));
        else if (json_is_true(kind) && !S_ISREG(st.st_mode))
            s = refuse(msg, top, "%s is listed as a file but is not a regular file", path);
        else if (!json_is_true(kind) && depth + 1 >= BUNDLE_NEST_MAX)
            s = refuse(msg, top, "bundles nested too deep at %s", path);
        else if (!json_is_true(kind))
            s = scan_bundle(path, top, depth + 1, false, msg);
        free(path);
    }
    if (d)
        closedir(d);
    if (!s && remove) {
        const char *name;
        json_t *kind;
        json_object_foreach(listed, name, kind)
        {
            char *path = rto__path_join(dir, name);
            if (path && json_is_true(kind))
                unlink(path);
            else if (path && lstat(path, &st) == 0)
                scan_bundle(path, top, depth + 1, true, NULL);
            free(path);
        }
        char *m = rto__path_join(dir, "manifest.json");
        if (m)
            unlink(m);
        free(m);
        rmdir(dir); /* fails, keeping it, if anything unlisted appeared after the check */
    }
    json_decref(listed);
    return s;
}

/* Whether outdir (already resolved) may become the new bundle: absent, an empty directory, or a bundle of ours. */
static rto_status check_replaceable(const char *outdir, const char *top, rto_msg *msg)
{
    struct stat st;
    if (lstat(outdir, &st) != 0 && errno == ENOENT)
        return RTO_OK;
    if (empty_dir(outdir))
        return RTO_OK;
    return scan_bundle(outdir, top, 0, false, msg);
}

/* Records the first failure of a setter or writer (see rto_bundle_set_str) for commit, and returns s. */
static rto_status keep_error(rto_bundle *b, rto_status s, const rto_msg *why, const char *what, const char *section,
                             const char *key)
{
    if (b && s && !b->err) {
        b->err = s;
        if (why && why->text[0])
            b->err_msg = *why;
        else
            rto__fail(&b->err_msg, s, "%s: cannot record %s%s%s%s in manifest.json (%s)", b->name, what,
                     section && *section ? section : "", section && *section ? "." : "", key ? key : "(NULL)",
                     rto_status_string(s));
    }
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Shared arrays (rtoracle.h, rto_bundle_share)                                                                     */

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
static bool share_link(rto_bundle *b, const char *hex, uint64_t bytes, const char *path)
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
static void share_own(rto_bundle *b, const char *name, const char *hex, uint64_t bytes, const char *path)
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
static void share_commit(rto_bundle *b)
{
    for (size_t i = 0; i < b->own_count; i++) {
        char *path = rto__path_join(b->outdir, b->own[i].path);
        if (path)
            share_register(b->share, &b->own[i], path);
        free(path);
    }
}

rto_status rto_bundle_begin(const char *outdir, const char *kind, rto_bundle **out, rto_msg *msg)
{
    *out = NULL;
    if (!outdir || !*outdir || !kind)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no output directory given");
    rto_bundle *b = calloc(1, sizeof *b);
    if (!b)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    size_t len = strlen(outdir);
    while (len > 1 && outdir[len - 1] == '/')
        len--;
    b->name = strndup(outdir, len);
    bool in_place = false;
    rto_status s = b->name ? rto__output_target(b->name, true, false, &b->outdir, &in_place, msg)
                           : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    if (!s)
        s = check_replaceable(b->outdir, b->name, msg);
    if (!s)
        s = rto__tmp_create(b->outdir, true, &b->tmpdir, NULL, msg);
    if (!s) {
        b->root = json_object();
        b->files = json_array();
        int bad = !b->root || !b->files;
        bad |= json_object_set_new(b->root, "format", json_string("rtoracle-bundle"));
        bad |= json_object_set_new(b->root, "format_version", json_integer(RTO_BUNDLE_FORMAT_VERSION));
        bad |= json_object_set_new(b->root, "tool", json_string("rtoracle"));
        bad |= json_object_set_new(b->root, "tool_version", json_string(RTO_VERSION_STRING));
        bad |= json_object_set_new(b->root, "kind", json_string(kind));
        if (bad)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "%s: cannot start manifest.json (out of memory)", b->name);
    }
    if (s) {
        rto_bundle_abort(b);
        return s;
    }
    *out = b;
    return RTO_OK;
}

const char *rto_bundle_tmpdir(const rto_bundle *b) { return b ? b->tmpdir : NULL; }

static json_t *section_of(json_t *root, const char *section, int create)
{
    if (!section || !*section)
        return root;
    json_t *o = json_object_get(root, section);
    if (!o && create) {
        o = json_object();
        if (json_object_set_new(root, section, o))
            return NULL;
    }
    return json_is_object(o) ? o : NULL;
}

/* Sets key in section to v (a new reference, NULL if making it failed); a failure is kept for commit. */
static rto_status set_value(rto_bundle *b, const char *section, const char *key, json_t *v)
{
    if (!b) {
        json_decref(v);
        return RTO_ERR_INVALID_ARGUMENT;
    }
    json_t *o = key ? section_of(b->root, section, 1) : NULL;
    if (!o) {
        /* no key, or a section name already used by a value that is not an object; otherwise out of memory */
        json_t *had = section && *section ? json_object_get(b->root, section) : b->root;
        json_decref(v);
        return keep_error(b, !key || (had && !json_is_object(had)) ? RTO_ERR_INVALID_ARGUMENT : RTO_ERR_OUT_OF_MEMORY,
                          NULL, "", section, key);
    }
    if (!v || json_object_set_new(o, key, v))
        return keep_error(b, RTO_ERR_OUT_OF_MEMORY, NULL, "", section, key);
    return RTO_OK;
}

rto_status rto_bundle_set_str(rto_bundle *b, const char *section, const char *key, const char *value)
{
    if (b && !value)
        return keep_error(b, RTO_ERR_INVALID_ARGUMENT, NULL, "", section, key);
    return set_value(b, section, key, b ? rto__json_string(value) : NULL);
}

rto_status rto_bundle_set_int(rto_bundle *b, const char *section, const char *key, int64_t value)
{
    return set_value(b, section, key, b ? json_integer((json_int_t)value) : NULL);
}

rto_status rto_bundle_set_real(rto_bundle *b, const char *section, const char *key, double value)
{
    return set_value(b, section, key, b ? rto__json_real(value) : NULL);
}

/* Ends a file's manifest entry e with its sha256 and lists it; bad: building e failed already. */
static rto_status list_file(rto_bundle *b, const char *name, json_t *e, const char *hex, int bad, rto_msg *why)
{
    bad |= json_object_set_new(e, "sha256", json_string(hex));
    bad |= json_array_append_new(b->files, e);
    if (bad)
        return rto__fail(why, RTO_ERR_OUT_OF_MEMORY, "%s: cannot list %s in manifest.json (out of memory, or a name "
                        "that is not UTF-8)", b->name, name);
    return RTO_OK;
}

/* The status of adding a file: its message to the caller, and the bundle's first error kept for commit. */
static rto_status file_added(rto_bundle *b, const char *name, rto_status s, rto_msg *why, rto_msg *msg)
{
    if (s && msg)
        *msg = *why;
    return keep_error(b, s, why, "file ", "", name);
}

rto_status rto_bundle_add_npy(rto_bundle *b, const char *name, const char *role, const char *layout,
                              const rto_npy_desc *desc, const void *data, rto_msg *msg)
{
    rto_msg why = {{0}};
    char hex[65], descr[1024];
    char *path = b && plain_name(name) && role && desc ? rto__path_join(b->tmpdir, name) : NULL;
    rto_status s = path ? RTO_OK
                 : b && plain_name(name) && role && desc
                     ? rto__fail(&why, RTO_ERR_OUT_OF_MEMORY, "out of memory")
                     : rto__fail(&why, RTO_ERR_INVALID_ARGUMENT, "bad bundle file '%s'", name ? name : "(null)");
    if (!s && b->share) {
        /* The file's bytes hashed in memory first: an identical file already written is linked to, else this one
         * is written (without hashing it again) and remembered. */
        uint64_t bytes = 0;
        s = rto__npy_hash(name, desc, data, hex, &bytes, &why);
        if (!s && !share_link(b, hex, bytes, path)) {
            s = rto__npy_write_hashed(path, desc, data, NULL, &why);
            if (!s)
                share_own(b, name, hex, bytes, path);
        }
    } else if (!s) {
        s = rto__npy_write_hashed(path, desc, data, hex, &why);
    }
    if (!s)
        s = rto_npy_descr(desc, descr, sizeof descr);
    free(path);
    if (!s) {
        json_t *shape = json_array(), *e = json_object();
        int bad = !shape;
        for (uint32_t i = 0; i < desc->ndim; i++)
            bad |= json_array_append_new(shape, json_integer((json_int_t)desc->shape[i]));
        bad |= json_object_set_new(e, "name", json_string(name));
        bad |= json_object_set_new(e, "role", json_string(role));
        bad |= json_object_set_new(e, "dtype", json_string(descr));
        bad |= json_object_set_new(e, "shape", shape);
        bad |= json_object_set_new(e, "layout", layout ? json_string(layout) : json_null());
        s = list_file(b, name, e, hex, bad, &why);
    }
    return file_added(b, name, s, &why, msg);
}

rto_status rto__bundle_add_image(rto_bundle *b, const char *name, const char *role, const rto_image *image,
                                 rto_status (*write)(const char *path, const rto_image *image, rto_msg *msg),
                                 rto_msg *msg)
{
    rto_msg why = {{0}};
    char hex[65];
    const bool valid = b && plain_name(name) && role && image && write;
    char *path = valid ? rto__path_join(b->tmpdir, name) : NULL;
    rto_status s = path    ? write(path, image, &why)
                   : valid ? rto__fail(&why, RTO_ERR_OUT_OF_MEMORY, "out of memory")
                           : rto__fail(&why, RTO_ERR_INVALID_ARGUMENT, "bad bundle file '%s'", name ? name : "(null)");
    if (!s)
        s = rto_sha256_file(path, hex, &why);
    free(path);
    if (!s) {
        json_t *e = json_object(), *info = json_object();
        int bad = !e || !info;
        bad |= json_object_set_new(e, "name", json_string(name));
        bad |= json_object_set_new(e, "role", json_string(role));
        bad |= json_object_set_new(info, "width", json_integer((json_int_t)image->width));
        bad |= json_object_set_new(info, "height", json_integer((json_int_t)image->height));
        bad |= json_object_set_new(info, "channels", json_integer((json_int_t)image->channels));
        bad |= json_object_set_new(info, "type", json_string(image->type == RTO_PIXEL_U8 ? "u8" : "f32"));
        bad |= json_object_set_new(e, "image", info);
        s = list_file(b, name, e, hex, bad, &why);
    }
    return file_added(b, name, s, &why, msg);
}

rto_status rto_bundle_add_case(rto_bundle *b, const char *name, const char *case_id, rto_msg *msg)
{
    rto_msg why = {{0}};
    char hex[65];
    bool valid = b && plain_name(name) && case_id;
    char *dir = valid ? rto__path_join(b->tmpdir, name) : NULL;
    char *m = dir ? rto__path_join(dir, "manifest.json") : NULL;
    rto_status s = m       ? rto_sha256_file(m, hex, &why)
                   : valid ? rto__fail(&why, RTO_ERR_OUT_OF_MEMORY, "out of memory")
                           : rto__fail(&why, RTO_ERR_INVALID_ARGUMENT, "bad case '%s'", name ? name : "(null)");
    free(dir);
    free(m);
    if (!s) {
        int bad = 0;
        if (!b->cases) {
            b->cases = json_array();
            bad |= json_object_set_new(b->root, "cases", b->cases);
        }
        json_t *e = json_object();
        bad |= json_object_set_new(e, "case", json_string(case_id));
        bad |= json_object_set_new(e, "dir", json_string(name));
        bad |= json_object_set_new(e, "manifest_sha256", json_string(hex));
        bad |= json_array_append_new(b->cases, e);
        if (bad)
            s = rto__fail(&why, RTO_ERR_OUT_OF_MEMORY, "%s: cannot list case %s in manifest.json (out of memory, or a "
                         "name that is not UTF-8)", b->name, name);
    }
    if (s && msg)
        *msg = why;
    return keep_error(b, s, &why, "case ", "", name);
}

rto_status rto_bundle_set_request(rto_bundle *b, const char *request, const char *const *sources, size_t count,
                                  rto_msg *msg)
{
    if (!b || !request || (count && !sources))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bundle, request or sources");
    char *head = NULL;
    rto_status s = rto__stamp_head(request, sources, count, &head, msg);
    if (!s) {
        free(b->stamp);
        b->stamp = head;
    }
    return s;
}

void rto_bundle_abort(rto_bundle *b)
{
    if (!b)
        return;
    if (b->tmpdir) {
        remove_tree(b->tmpdir);
        rto__tmp_forget(b->tmpdir);
    }
    json_decref(b->root);
    json_decref(b->files);
    for (size_t i = 0; i < b->own_count; i++)
        free(b->own[i].path);
    free(b->own);
    free(b->stamp);
    free(b->name);
    free(b->outdir);
    free(b->tmpdir);
    free(b);
}

/* manifest.json into the temporary directory, in a file created 0666 (umask). */
static rto_status write_manifest(rto_bundle *b, rto_msg *msg)
{
    if (json_object_set(b->root, "files", b->files))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "%s: cannot assemble manifest.json (out of memory)", b->name);
    char *text = rto__json_text(b->root, JSON_INDENT(2));
    if (!text)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "%s: cannot serialise manifest.json (out of memory)", b->name);
    char *path = rto__path_join(b->tmpdir, "manifest.json");
    int fd = path ? open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666) : -1;
    FILE *fp = fd >= 0 ? fdopen(fd, "wb") : NULL;
    rto_status s = RTO_OK;
    if (!fp) {
        s = rto__fail(msg, path ? RTO_ERR_IO : RTO_ERR_OUT_OF_MEMORY, "cannot write %s: %s",
                     path ? path : "manifest.json", strerror(errno));
        if (fd >= 0)
            close(fd);
    } else {
        errno = 0;
        bool bad = fputs(text, fp) < 0 || fflush(fp) != 0;
        int e = errno;
        if (fclose(fp) != 0 && !bad) {
            bad = true;
            e = errno;
        }
        if (bad)
            s = rto__fail(msg, RTO_ERR_IO, "cannot write %s: %s", path, strerror(e ? e : EIO));
    }
    free(path);
    free(text);
    return s;
}

/*
 * Moves the finished temporary directory to outdir. An absent outdir is a rename. Anything else is exchanged with
 * the temporary atomically (renameat2 RENAME_EXCHANGE), and what comes out is checked again — it may have changed
 * since rto_bundle_begin looked — before it is deleted: if it is no longer an empty directory or a bundle of ours,
 * the exchange is undone and nothing is deleted. Stop signals are held meanwhile, so the signal cleanup of the
 * temporary name never deletes a previous bundle half-way, nor a directory that is about to go back into place.
 */
static rto_status install(rto_bundle *b, rto_msg *msg)
{
    rto_status s = RTO_OK;
    sigset_t old;
    rto__signals_hold(&old);
    struct stat st;
    if (lstat(b->outdir, &st) != 0 && errno == ENOENT) {
        /* rename replaces nothing but an empty directory that appeared meanwhile */
        if (rename(b->tmpdir, b->outdir) != 0)
            s = rto__fail(msg, RTO_ERR_IO, "cannot rename %s to %s: %s", b->tmpdir, b->outdir, strerror(errno));
    } else if (renameat2(AT_FDCWD, b->tmpdir, AT_FDCWD, b->outdir, RENAME_EXCHANGE) != 0) {
        s = rto__fail(msg, RTO_ERR_IO, "cannot replace %s: %s", b->name, strerror(errno));
    } else if (empty_dir(b->tmpdir)) {
        rmdir(b->tmpdir);
    } else if ((s = scan_bundle(b->tmpdir, b->name, 0, true, msg)) != RTO_OK &&
               renameat2(AT_FDCWD, b->tmpdir, AT_FDCWD, b->outdir, RENAME_EXCHANGE) != 0) {
        /* The new bundle stays at outdir; what was there is left untouched under the temporary name. */
        rto__fail(msg, RTO_ERR_IO, "%s changed while the bundle was written and could not be put back: it is now %s",
                 b->name, b->tmpdir);
        rto__tmp_forget(b->tmpdir);
        free(b->tmpdir);
        b->tmpdir = NULL;
    }
    if (!s) {
        rto__tmp_forget(b->tmpdir);
        free(b->tmpdir);
        b->tmpdir = NULL;
    }
    rto__signals_release(&old);
    return s;
}

rto_status rto_bundle_commit(rto_bundle *b, rto_msg *msg)
{
    if (!b)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bundle");
    rto_status s = b->err;
    if (s && msg)
        *msg = b->err_msg;
    if (!s)
        s = write_manifest(b, msg);
    if (!s)
        rto__stamp_write(b->tmpdir, b->stamp);
    if (!s)
        s = install(b, msg);
    if (!s && b->share)
        share_commit(b);
    rto_bundle_abort(b);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */

static int cmp_cstr(const void *a, const void *b) { return strcmp(*(const char *const *)a, *(const char *const *)b); }

/* The N of a file named PREFIX N _..., or -1. */
static long long indexed_name(const char *name, const char *prefix)
{
    size_t n = strlen(prefix);
    if (strncmp(name, prefix, n) != 0 || name[n] < '0' || name[n] > '9')
        return -1;
    char *end;
    long long v = strtoll(name + n, &end, 10);
    return *end == '_' && v >= 0 ? v : -1;
}

/*
 * What every reader may then take for granted of manifest.json, checked once when the bundle is opened: `files` is a
 * list of entries with plain, unique file names (no path, no NUL); a shape is a list of non-negative integers whose
 * product fits the file it describes (each element takes at least a byte); counts.meshes (when present) numbers the
 * mesh_N_ and blas_N_ files exactly. Kind-specific agreements (instances.npy against counts.instances, the TLAS
 * figures) stay with the validators that read those arrays.
 */
static rto_status validate_manifest(const char *dir, json_t *root, rto_msg *msg)
{
    json_t *files = json_object_get(root, "files");
    if (!json_is_array(files))
        return rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json has no files list", dir);
    const size_t count = json_array_size(files);
    const char **names = calloc(count ? count : 1, sizeof *names);
    if (!names)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_status s = RTO_OK;
    long long meshes = -1;
    json_t *jm = json_object_get(json_object_get(root, "counts"), "meshes");
    if (jm && (!json_is_integer(jm) || json_integer_value(jm) < 0 || json_integer_value(jm) > UINT32_MAX))
        s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: counts.meshes is not a count", dir);
    else if (jm)
        meshes = json_integer_value(jm);
    size_t i;
    json_t *e;
    json_array_foreach(files, i, e)
    {
        if (s)
            break;
        json_t *jn = json_object_get(e, "name");
        const char *name = json_string_value(jn);
        if (!json_is_object(e) || !name) {
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: files entry %zu has no name", dir, i);
            break;
        }
        if (!plain_name(name) || strlen(name) != json_string_length(jn)) {
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: files entry %zu names '%.200s', not a plain file name "
                         "inside the bundle", dir, i, name);
            break;
        }
        names[i] = name;
        json_t *shape = json_object_get(e, "shape");
        if (shape) {
            uint64_t elements = 1;
            size_t k;
            json_t *d;
            int bad = !json_is_array(shape);
            json_array_foreach(shape, k, d)
            {
                const json_int_t v = json_is_integer(d) ? json_integer_value(d) : -1;
                if (v < 0 || (v && elements > (UINT64_C(1) << 62) / (uint64_t)v)) {
                    bad = 1;
                    break;
                }
                elements *= (uint64_t)v;
            }
            struct stat st;
            char *path = bad ? NULL : rto__path_join(dir, name);
            if (!bad && path && lstat(path, &st) == 0 && S_ISREG(st.st_mode) && elements > (uint64_t)st.st_size)
                bad = 2;
            free(path);
            if (bad) {
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: the shape of %.200s %s", dir, name,
                             bad == 2 ? "has more elements than the file has bytes"
                                      : "is not a list of non-negative integers with a product under 2^62");
                break;
            }
        }
        for (int p = 0; p < 2 && meshes >= 0; p++) {
            const long long n = indexed_name(name, p ? "blas_" : "mesh_");
            if (n >= meshes) {
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: counts.meshes is %lld, but the bundle lists %s",
                             dir, meshes, name);
                break;
            }
        }
    }
    if (!s && count > 1) {
        qsort(names, count, sizeof *names, cmp_cstr);
        for (i = 1; i < count && !s; i++)
            if (strcmp(names[i - 1], names[i]) == 0)
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json lists %.200s twice", dir, names[i]);
    }
    /* Every mesh counted has its files, when the bundle holds mesh or BLAS files at all. */
    for (int p = 0; p < 2 && !s && meshes > 0; p++) {
        const char *prefix = p ? "blas_" : "mesh_";
        unsigned char *seen = calloc((size_t)meshes, 1);
        size_t listed = 0;
        if (!seen) {
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
            break;
        }
        for (i = 0; i < count; i++) {
            const long long n = indexed_name(names[i], prefix);
            if (n >= 0) {
                seen[n] = 1;
                listed++;
            }
        }
        for (long long m = 0; listed && m < meshes && !s; m++)
            if (!seen[m])
                s = rto__fail(msg, RTO_ERR_PARSE, "%s: manifest.json: counts.meshes is %lld, but no %s%lld_ file is "
                             "listed", dir, meshes, prefix, m);
        free(seen);
    }
    free(names);
    return s;
}

rto_status rto_bundle_open(const char *dir, rto_bundle_reader **out, rto_msg *msg)
{
    *out = NULL;
    char *path = dir ? rto__path_join(dir, "manifest.json") : NULL;
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no bundle directory given");
    json_error_t err;
    /* Opened as a plain file first: json_load_file would wait for ever on a manifest.json that is a FIFO. */
    uint64_t size;
    rto_status opened = RTO_OK;
    FILE *fp = rto__open_regular(path, &size, &opened, msg);
    if (!fp) {
        free(path);
        return opened;
    }
    json_t *root = json_loadf(fp, JSON_REJECT_DUPLICATES, &err);
    fclose(fp);
    if (!root) {
        rto_status s = rto__fail(msg, RTO_ERR_PARSE, "%s: %s (line %d)", path, err.text, err.line);
        free(path);
        return s;
    }
    free(path);
    rto_status s = RTO_OK;
    const char *format = json_string_value(json_object_get(root, "format"));
    json_t *version = json_object_get(root, "format_version");
    if (!format || strcmp(format, "rtoracle-bundle") != 0)
        s = rto__fail(msg, RTO_ERR_PARSE, "%s is not an rtoracle bundle (manifest format '%s')", dir,
                     format ? format : "missing");
    else if (!json_is_integer(version) || json_integer_value(version) != RTO_BUNDLE_FORMAT_VERSION)
        s = rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: bundle format version %lld is not supported (this rtoracle reads %d)",
                     dir, json_is_integer(version) ? (long long)json_integer_value(version) : -1LL,
                     RTO_BUNDLE_FORMAT_VERSION);
    else
        s = validate_manifest(dir, root, msg);
    rto_bundle_reader *r = s ? NULL : calloc(1, sizeof *r);
    if (!s && (!r || !(r->dir = strdup(dir)))) {
        free(r);
        r = NULL;
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (s) {
        json_decref(root);
        return s;
    }
    r->root = root;
    *out = r;
    return RTO_OK;
}

void rto_bundle_close(rto_bundle_reader *r)
{
    if (!r)
        return;
    json_decref(r->root);
    free(r->dir);
    free(r);
}

const char *rto_bundle_get_str(rto_bundle_reader *r, const char *section, const char *key)
{
    json_t *o = r ? section_of(r->root, section, 0) : NULL;
    return o ? json_string_value(json_object_get(o, key)) : NULL;
}

int rto_bundle_get_int(rto_bundle_reader *r, const char *section, const char *key, int64_t *value)
{
    json_t *o = r ? section_of(r->root, section, 0) : NULL;
    json_t *v = o ? json_object_get(o, key) : NULL;
    if (!json_is_integer(v))
        return 0;
    *value = (int64_t)json_integer_value(v);
    return 1;
}

/* The path of the first manifest entry whose field `key` equals `value` (malloc'ed), after checking its sha256. */
static rto_status checked_path(rto_bundle_reader *r, const char *key, const char *value, char **out, rto_msg *msg)
{
    *out = NULL;
    json_t *files = r ? json_object_get(r->root, "files") : NULL;
    size_t i;
    json_t *e;
    json_array_foreach(files, i, e)
    {
        const char *v = json_string_value(json_object_get(e, key));
        const char *name = json_string_value(json_object_get(e, "name"));
        const char *sha = json_string_value(json_object_get(e, "sha256"));
        if (!v || strcmp(v, value) != 0)
            continue;
        if (!plain_name(name) || !sha)
            return rto__fail(msg, RTO_ERR_PARSE, "%s: manifest entry '%s' lacks a plain name or sha256", r->dir, value);
        char *path = rto__path_join(r->dir, name);
        char hex[65];
        rto_status s = path ? rto_sha256_file(path, hex, msg) : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        if (!s && strcmp(hex, sha) != 0)
            s = rto__fail(msg, RTO_ERR_PARSE, "%s: sha256 %s does not match the manifest's %s (file changed?)", path,
                         hex, sha);
        if (s)
            free(path);
        else
            *out = path;
        return s;
    }
    return rto__fail(msg, RTO_ERR_IO, "%s: the bundle has no file with %s '%s'", r ? r->dir : "(null)", key, value);
}

/* Loads the file of the first manifest entry whose field `key` equals `value`, after checking its sha256. */
static rto_status read_entry(rto_bundle_reader *r, const char *key, const char *value, rto_npy *out, rto_msg *msg)
{
    char *path = NULL;
    rto_status s = checked_path(r, key, value, &path, msg);
    if (!s)
        s = rto_npy_read(path, out, msg);
    free(path);
    return s;
}

rto_status rto__bundle_checked_path(rto_bundle_reader *r, const char *name, char **path, rto_msg *msg)
{
    *path = NULL;
    if (!r || !name)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bundle or name");
    return checked_path(r, "name", name, path, msg);
}

rto_status rto_bundle_read_role(rto_bundle_reader *r, const char *role, rto_npy *out, rto_msg *msg)
{
    return read_entry(r, "role", role, out, msg);
}

rto_status rto_bundle_read_name(rto_bundle_reader *r, const char *name, rto_npy *out, rto_msg *msg)
{
    return read_entry(r, "name", name, out, msg);
}

int rto__bundle_lists(rto_bundle_reader *r, const char *name)
{
    json_t *files = r && name ? json_object_get(r->root, "files") : NULL;
    size_t i;
    json_t *e;
    json_array_foreach(files, i, e)
    {
        const char *n = json_string_value(json_object_get(e, "name"));
        if (n && !strcmp(n, name))
            return 1;
    }
    return 0;
}
