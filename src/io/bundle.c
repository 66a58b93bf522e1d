/* Golden bundles (DESIGN.md §8): a directory of .npy files plus manifest.json. A bundle is built in a temporary
 * sibling directory and renamed into place, so a reader never sees a half-written bundle and a failed run never
 * leaves one behind. The manifest is written by jansson with a fixed key order and no timestamps, so the same
 * inputs give the same bytes. */
#define _GNU_SOURCE /* renameat2 (glibc >= 2.28) */
#include "internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <jansson.h>
#include <math.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct rto_bundle {
    char *outdir;
    char *tmpdir;
    json_t *root;
    json_t *files;
    json_t *cases;
};

struct rto_bundle_reader {
    char *dir;
    json_t *root;
};

rto_status rto_sha256_file(const char *path, char hex[65], rto_msg *msg)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return rto_fail(msg, RTO_ERR_IO, "%s: %s", path, strerror(errno));
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    rto_status s = RTO_OK;
    if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1) {
        s = rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot start SHA-256");
        goto out;
    }
    unsigned char buf[1 << 16];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, fp)) > 0)
        EVP_DigestUpdate(ctx, buf, got);
    if (ferror(fp)) {
        s = rto_fail(msg, RTO_ERR_IO, "%s: read error", path);
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

static char *join(const char *dir, const char *name)
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

static void remove_tree(const char *path)
{
    if (path)
        nftw(path, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

/* 0: absent or empty, 1: a previous bundle, -1: something else that must not be replaced. */
static int outdir_state(const char *outdir)
{
    struct stat st;
    if (stat(outdir, &st) != 0)
        return 0;
    if (!S_ISDIR(st.st_mode))
        return -1;
    char *m = join(outdir, "manifest.json");
    int has_manifest = m && access(m, F_OK) == 0;
    free(m);
    if (has_manifest)
        return 1;
    DIR *d = opendir(outdir);
    if (!d)
        return -1;
    struct dirent *e;
    int empty = 1;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            empty = 0;
    closedir(d);
    return empty ? 0 : -1;
}

static int plain_name(const char *name)
{
    return name && *name && !strchr(name, '/') && strcmp(name, ".") && strcmp(name, "..");
}

rto_status rto_bundle_begin(const char *outdir, const char *kind, rto_bundle **out, rto_msg *msg)
{
    *out = NULL;
    if (!outdir || !*outdir || !kind)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "no output directory given");
    if (outdir_state(outdir) < 0)
        return rto_fail(msg, RTO_ERR_IO,
                        "refusing to replace %s: it exists and is not an rtoracle bundle (no manifest.json)", outdir);
    rto_bundle *b = calloc(1, sizeof *b);
    if (!b)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    size_t len = strlen(outdir);
    while (len > 1 && outdir[len - 1] == '/')
        len--;
    b->outdir = strndup(outdir, len);
    b->tmpdir = malloc(len + 16);
    if (b->outdir && b->tmpdir) {
        snprintf(b->tmpdir, len + 16, "%s.tmp.XXXXXX", b->outdir);
        if (!mkdtemp(b->tmpdir)) {
            rto_status s = rto_fail(msg, RTO_ERR_IO, "cannot create a temporary directory beside %s: %s", b->outdir,
                                    strerror(errno));
            free(b->tmpdir);
            b->tmpdir = NULL;
            rto_bundle_abort(b);
            return s;
        }
    }
    b->root = json_object();
    b->files = json_array();
    if (!b->outdir || !b->tmpdir || !b->root || !b->files) {
        rto_bundle_abort(b);
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    json_object_set_new(b->root, "format", json_string("rtoracle-bundle"));
    json_object_set_new(b->root, "format_version", json_integer(RTO_BUNDLE_FORMAT_VERSION));
    json_object_set_new(b->root, "tool", json_string("rtoracle"));
    json_object_set_new(b->root, "tool_version", json_string(RTO_VERSION_STRING));
    json_object_set_new(b->root, "kind", json_string(kind));
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
        json_object_set_new(root, section, o);
    }
    return json_is_object(o) ? o : NULL;
}

rto_status rto_bundle_set_str(rto_bundle *b, const char *section, const char *key, const char *value)
{
    json_t *o = b ? section_of(b->root, section, 1) : NULL;
    if (!o || !key || !value || json_object_set_new(o, key, json_string(value)))
        return RTO_ERR_INVALID_ARGUMENT;
    return RTO_OK;
}

rto_status rto_bundle_set_int(rto_bundle *b, const char *section, const char *key, int64_t value)
{
    json_t *o = b ? section_of(b->root, section, 1) : NULL;
    if (!o || !key || json_object_set_new(o, key, json_integer((json_int_t)value)))
        return RTO_ERR_INVALID_ARGUMENT;
    return RTO_OK;
}

rto_status rto_bundle_set_real(rto_bundle *b, const char *section, const char *key, double value)
{
    json_t *o = b ? section_of(b->root, section, 1) : NULL;
    if (!o || !key || !isfinite(value) || json_object_set_new(o, key, json_real(value)))
        return RTO_ERR_INVALID_ARGUMENT;
    return RTO_OK;
}

rto_status rto_bundle_add_npy(rto_bundle *b, const char *name, const char *role, const char *layout,
                              const rto_npy_desc *desc, const void *data, rto_msg *msg)
{
    if (!b || !plain_name(name) || !role || !desc)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "bad bundle file '%s'", name ? name : "(null)");
    char *path = join(b->tmpdir, name);
    if (!path)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    char hex[65], descr[1024];
    rto_status s = rto_npy_write(path, desc, data, msg);
    if (!s)
        s = rto_sha256_file(path, hex, msg);
    if (!s)
        s = rto_npy_descr(desc, descr, sizeof descr);
    free(path);
    if (s)
        return s;
    json_t *shape = json_array();
    for (uint32_t i = 0; i < desc->ndim; i++)
        json_array_append_new(shape, json_integer((json_int_t)desc->shape[i]));
    json_t *e = json_object();
    json_object_set_new(e, "name", json_string(name));
    json_object_set_new(e, "role", json_string(role));
    json_object_set_new(e, "dtype", json_string(descr));
    json_object_set_new(e, "shape", shape);
    json_object_set_new(e, "layout", layout ? json_string(layout) : json_null());
    json_object_set_new(e, "sha256", json_string(hex));
    json_array_append_new(b->files, e);
    return RTO_OK;
}

rto_status rto_bundle_add_case(rto_bundle *b, const char *name, const char *case_id, rto_msg *msg)
{
    if (!b || !plain_name(name) || !case_id)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "bad case '%s'", name ? name : "(null)");
    char *dir = join(b->tmpdir, name), *m = dir ? join(dir, "manifest.json") : NULL;
    char hex[65];
    rto_status s = m ? rto_sha256_file(m, hex, msg) : rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    free(dir);
    free(m);
    if (s)
        return s;
    if (!b->cases) {
        b->cases = json_array();
        json_object_set_new(b->root, "cases", b->cases);
    }
    json_t *e = json_object();
    json_object_set_new(e, "case", json_string(case_id));
    json_object_set_new(e, "dir", json_string(name));
    json_object_set_new(e, "manifest_sha256", json_string(hex));
    json_array_append_new(b->cases, e);
    return RTO_OK;
}

void rto_bundle_abort(rto_bundle *b)
{
    if (!b)
        return;
    remove_tree(b->tmpdir);
    json_decref(b->root);
    json_decref(b->files);
    free(b->outdir);
    free(b->tmpdir);
    free(b);
}

rto_status rto_bundle_commit(rto_bundle *b, rto_msg *msg)
{
    if (!b)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bundle");
    rto_status s = RTO_OK;
    json_object_set(b->root, "files", b->files);
    char *path = join(b->tmpdir, "manifest.json");
    char *text = json_dumps(b->root, JSON_INDENT(2));
    FILE *fp = path && text ? fopen(path, "wb") : NULL;
    if (!fp) {
        s = rto_fail(msg, RTO_ERR_IO, "cannot write %s: %s", path ? path : "manifest", strerror(errno));
    } else {
        int bad = fputs(text, fp) < 0 || fputc('\n', fp) == EOF;
        if (fclose(fp) != 0 || bad)
            s = rto_fail(msg, RTO_ERR_IO, "cannot write %s: %s", path, strerror(errno));
    }
    free(path);
    free(text);
    if (!s) {
        int state = outdir_state(b->outdir);
        if (state < 0) {
            s = rto_fail(msg, RTO_ERR_IO, "refusing to replace %s: it is not an rtoracle bundle", b->outdir);
        } else if (state == 0) {
            rmdir(b->outdir); /* an empty directory may stand in the way */
            if (rename(b->tmpdir, b->outdir) != 0)
                s = rto_fail(msg, RTO_ERR_IO, "cannot rename %s to %s: %s", b->tmpdir, b->outdir, strerror(errno));
        } else if (renameat2(AT_FDCWD, b->tmpdir, AT_FDCWD, b->outdir, RENAME_EXCHANGE) != 0) {
            s = rto_fail(msg, RTO_ERR_IO, "cannot replace %s: %s", b->outdir, strerror(errno));
        }
        /* After the exchange the temporary name holds the previous bundle; abort removes it. */
    }
    rto_bundle_abort(b);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */

rto_status rto_bundle_open(const char *dir, rto_bundle_reader **out, rto_msg *msg)
{
    *out = NULL;
    char *path = dir ? join(dir, "manifest.json") : NULL;
    if (!path)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "no bundle directory given");
    json_error_t err;
    json_t *root = json_load_file(path, JSON_REJECT_DUPLICATES, &err);
    if (!root) {
        rto_status s = rto_fail(msg, access(path, F_OK) ? RTO_ERR_IO : RTO_ERR_PARSE, "%s: %s (line %d)", path,
                                err.text, err.line);
        free(path);
        return s;
    }
    free(path);
    const char *format = json_string_value(json_object_get(root, "format"));
    json_t *version = json_object_get(root, "format_version");
    rto_status s = RTO_OK;
    if (!format || strcmp(format, "rtoracle-bundle") != 0)
        s = rto_fail(msg, RTO_ERR_PARSE, "%s is not an rtoracle bundle (manifest format '%s')", dir,
                     format ? format : "missing");
    else if (!json_is_integer(version) || json_integer_value(version) != RTO_BUNDLE_FORMAT_VERSION)
        s = rto_fail(msg, RTO_ERR_UNSUPPORTED, "%s: bundle format version %lld is not supported (this rtoracle reads %d)",
                     dir, json_is_integer(version) ? (long long)json_integer_value(version) : -1LL,
                     RTO_BUNDLE_FORMAT_VERSION);
    rto_bundle_reader *r = s ? NULL : calloc(1, sizeof *r);
    if (!s && (!r || !(r->dir = strdup(dir)))) {
        free(r);
        r = NULL;
        s = rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
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

/* Loads the file of the first manifest entry whose field `key` equals `value`, after checking its sha256. */
static rto_status read_entry(rto_bundle_reader *r, const char *key, const char *value, rto_npy *out, rto_msg *msg)
{
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
            return rto_fail(msg, RTO_ERR_PARSE, "%s: manifest entry '%s' lacks a plain name or sha256", r->dir, value);
        char *path = join(r->dir, name);
        char hex[65];
        rto_status s = path ? rto_sha256_file(path, hex, msg) : rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        if (!s && strcmp(hex, sha) != 0)
            s = rto_fail(msg, RTO_ERR_PARSE, "%s: sha256 %s does not match the manifest's %s (file changed?)", path,
                         hex, sha);
        if (!s)
            s = rto_npy_read(path, out, msg);
        free(path);
        return s;
    }
    return rto_fail(msg, RTO_ERR_IO, "%s: the bundle has no file with %s '%s'", r ? r->dir : "(null)", key, value);
}

rto_status rto_bundle_read_role(rto_bundle_reader *r, const char *role, rto_npy *out, rto_msg *msg)
{
    return read_entry(r, "role", role, out, msg);
}

rto_status rto_bundle_read_name(rto_bundle_reader *r, const char *name, rto_npy *out, rto_msg *msg)
{
    return read_entry(r, "name", name, out, msg);
}
