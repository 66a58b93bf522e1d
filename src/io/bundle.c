/* Golden bundles (DESIGN.md §8): a directory of .npy files plus manifest.json. A bundle is built in a temporary
 * sibling directory and renamed into place, so a reader never sees a half-written bundle and a failed run never
 * leaves one behind. The manifest is written by jansson with a fixed key order and no timestamps, so the same
 * inputs give the same bytes.
 *
 * This file writes bundles (rto_bundle_begin ... rto_bundle_commit) and decides what a new bundle may replace;
 * bundle_read.c reads them back, bundle_share.c holds the share table of arrays written together. */
#define _GNU_SOURCE /* renameat2 (glibc >= 2.28) */
#include "bundle_internal.h"
#include "io_internal.h"
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

int rto__bundle_plain_name(const char *name)
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
            if (!rto__bundle_plain_name(name) || !strcmp(name, "manifest.json") ||
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

json_t *rto__bundle_section(json_t *root, const char *section, int create)
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
    json_t *o = key ? rto__bundle_section(b->root, section, 1) : NULL;
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
    char *path = b && rto__bundle_plain_name(name) && role && desc ? rto__path_join(b->tmpdir, name) : NULL;
    rto_status s = path ? RTO_OK
                 : b && rto__bundle_plain_name(name) && role && desc
                     ? rto__fail(&why, RTO_ERR_OUT_OF_MEMORY, "out of memory")
                     : rto__fail(&why, RTO_ERR_INVALID_ARGUMENT, "bad bundle file '%s'", name ? name : "(null)");
    if (!s && b->share) {
        /* The file's bytes hashed in memory first: an identical file already written is linked to, else this one
         * is written (without hashing it again) and remembered. */
        uint64_t bytes = 0;
        s = rto__npy_hash(name, desc, data, hex, &bytes, &why);
        if (!s && !rto__bundle_share_link(b, hex, bytes, path)) {
            s = rto__npy_write_hashed(path, desc, data, NULL, &why);
            if (!s)
                rto__bundle_share_own(b, name, hex, bytes, path);
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
    const bool valid = b && rto__bundle_plain_name(name) && role && image && write;
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
    bool valid = b && rto__bundle_plain_name(name) && case_id;
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
        rto__bundle_share_commit(b);
    rto_bundle_abort(b);
    return s;
}
