/* Golden bundles read back (DESIGN.md §8): rto_bundle_open checks manifest.json once, and every file is read after
 * its sha256 is checked against the manifest (bundle_internal.h). */
#include "bundle_internal.h"
#include "io_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

struct rto_bundle_reader {
    char *dir;
    json_t *root;
};

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
        if (!rto__bundle_plain_name(name) || strlen(name) != json_string_length(jn)) {
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
    json_t *o = r ? rto__bundle_section(r->root, section, 0) : NULL;
    return o ? json_string_value(json_object_get(o, key)) : NULL;
}

int rto_bundle_get_int(rto_bundle_reader *r, const char *section, const char *key, int64_t *value)
{
    json_t *o = r ? rto__bundle_section(r->root, section, 0) : NULL;
    json_t *v = o ? json_object_get(o, key) : NULL;
    if (!json_is_integer(v))
        return 0;
    *value = (int64_t)json_integer_value(v);
    return 1;
}

int rto_bundle_get_real(rto_bundle_reader *r, const char *section, const char *key, double *value)
{
    json_t *o = r ? rto__bundle_section(r->root, section, 0) : NULL;
    json_t *v = o ? json_object_get(o, key) : NULL;
    if (!json_is_number(v))
        return 0;
    *value = json_number_value(v);
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
        if (!rto__bundle_plain_name(name) || !sha)
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
