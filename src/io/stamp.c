/* Up-to-date bundles: a bundle remembers what made it, so that a run asking for the same thing again leaves it alone
 * instead of rewriting identical bytes (the main job's second run writes nothing).
 *
 * The record (the "stamp") is an extended attribute of the bundle directory, user.rtoracle.stamp, not a file: the
 * bundle's files and manifest.json stay byte for byte what they were (the committed goldens and the determinism
 * checks compare whole directories), and a copy that drops extended attributes (cp without -a, a tarball) just makes
 * the next run rewrite. It is text:
 *
 *   rtoracle-stamp 1
 *   build   SHA256    the build-ids of the program and every library loaded with it, and the image module file
 *   request SHA256    of the request text the command composed (its arguments and option values)
 *   source  SHA256|- PATH   one per input file read (a scene, its buffers and images, a plugin); - when absent
 *   written NS        CLOCK_REALTIME when the stamp was made
 *   files   SHA256    of (name, inode, size, mtime) of manifest.json and every file the manifest lists, and of each
 *                     suite case's own stamp (checked the same way, recursively)
 *
 * A bundle is current when all of that still holds: same build, same request, every source file hashing as before,
 * and no listed file replaced, resized, rewritten or removed since. Checking costs a stat per file and a hash of the
 * (small) source files, never a read of the bundle's arrays. A write that restores a file's mtime, size and inode
 * is not seen; `--force` rewrites regardless. An input file modified while the command ran leaves the bundle
 * unstamped (the next run writes it again). The build identity covers the program, its link-time libraries and the
 * image module's file, not the libraries the module loads (OpenImageIO, libpng): after an upgrade of those alone,
 * `--force` rewrites textured scenes' bundles. */
#define _GNU_SOURCE
#include "io_internal.h"
#include "scene/image_module.h"

#include <errno.h>
#include <inttypes.h>
#include <jansson.h>
#include <link.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <time.h>

#define STAMP_ATTR "user.rtoracle.stamp"
#define STAMP_MAX (64u << 10)
/* Suites nest one level; the bound only stops a hostile tree (as in bundle.c). */
#define STAMP_NEST_MAX 4

/* ---------------------------------------------------------------------------------------------------------------- */
/* SHA-256 helpers                                                                                                  */

static void hex_of(const unsigned char md[32], char hex[65])
{
    static const char digits[] = "0123456789abcdef";
    for (int i = 0; i < 32; i++) {
        hex[2 * i] = digits[md[i] >> 4];
        hex[2 * i + 1] = digits[md[i] & 15];
    }
    hex[64] = 0;
}

static int sha_finish(EVP_MD_CTX *ctx, char hex[65])
{
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    int ok = EVP_DigestFinal_ex(ctx, md, &len) == 1 && len == 32;
    if (ok)
        hex_of(md, hex);
    return ok;
}

static void sha_text(const char *text, size_t len, char hex[65])
{
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1 || EVP_DigestUpdate(ctx, text, len) != 1 ||
        !sha_finish(ctx, hex))
        memset(hex, '0', 64), hex[64] = 0;
    EVP_MD_CTX_free(ctx);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Build identity                                                                                                   */

static char g_build[65];
/* When this process started (CLOCK_REALTIME, ns): an input file changed since may have been read half old, half new,
 * or after the hash a stamp would record, so such a bundle goes unstamped. */
static long long g_start_ns;

/* The GNU build-id note of a loaded object, or 0 bytes when it has none. */
static size_t build_id_of(const struct dl_phdr_info *info, const unsigned char **id)
{
    for (int i = 0; i < info->dlpi_phnum; i++) {
        const ElfW(Phdr) *ph = &info->dlpi_phdr[i];
        if (ph->p_type != PT_NOTE)
            continue;
        const unsigned char *p = (const unsigned char *)(info->dlpi_addr + ph->p_vaddr), *end = p + ph->p_memsz;
        while (p + sizeof(ElfW(Nhdr)) <= end) {
            const ElfW(Nhdr) *n = (const ElfW(Nhdr) *)(const void *)p;
            const size_t name_sz = (n->n_namesz + 3u) & ~3u, desc_sz = (n->n_descsz + 3u) & ~3u;
            const unsigned char *name = p + sizeof *n, *desc = name + name_sz;
            if (desc + desc_sz > end)
                break;
            if (n->n_type == NT_GNU_BUILD_ID && n->n_namesz == 4 && !memcmp(name, "GNU", 4)) {
                *id = desc;
                return n->n_descsz;
            }
            p = desc + desc_sz;
        }
    }
    return 0;
}

/* A file by path, size and mtime: what identifies an object without a build-id, and the image module. */
static void file_identity(EVP_MD_CTX *ctx, const char *path)
{
    struct stat st;
    char line[96];
    EVP_DigestUpdate(ctx, path, strlen(path) + 1);
    if (stat(path, &st) == 0) {
        int n = snprintf(line, sizeof line, "%lld %lld.%09ld\n", (long long)st.st_size, (long long)st.st_mtim.tv_sec,
                         st.st_mtim.tv_nsec);
        EVP_DigestUpdate(ctx, line, (size_t)n);
    }
}

static int add_object(struct dl_phdr_info *info, size_t size, void *data)
{
    (void)size;
    EVP_MD_CTX *ctx = data;
    const char *name = info->dlpi_name ? info->dlpi_name : "";
    /* The kernel's vDSO does not compute anything a bundle holds; a kernel update should not rewrite the goldens. */
    if (!strncmp(name, "linux-vdso", 10) || !strncmp(name, "linux-gate", 10))
        return 0;
    const unsigned char *id = NULL;
    size_t len = build_id_of(info, &id);
    if (len) {
        EVP_DigestUpdate(ctx, "id", 2);
        EVP_DigestUpdate(ctx, id, len);
    } else if (*name) {
        file_identity(ctx, name);
    } else {
        EVP_DigestUpdate(ctx, "main", 4); /* a program without a build-id: /proc/self/exe */
        file_identity(ctx, "/proc/self/exe");
    }
    return 0;
}

/* Computed once, when the library is loaded: the objects loaded then are the program and its link-time libraries,
 * the same set every run, whatever a command dlopens later. The image module, which decodes textures, is added by
 * its file (it is loaded only when a texture needs it). */
__attribute__((constructor)) static void build_identity_init(void)
{
    struct timespec now;
    if (clock_gettime(CLOCK_REALTIME, &now) == 0)
        g_start_ns = (long long)now.tv_sec * 1000000000LL + now.tv_nsec;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1) {
        EVP_MD_CTX_free(ctx);
        return; /* g_build stays empty: nothing is stamped, so nothing is ever skipped */
    }
    EVP_DigestUpdate(ctx, RTO_VERSION_STRING, strlen(RTO_VERSION_STRING));
    dl_iterate_phdr(add_object, ctx);
    const char *module = rto__image_module_path();
    if (module)
        file_identity(ctx, module);
    if (!sha_finish(ctx, g_build))
        g_build[0] = 0;
    EVP_MD_CTX_free(ctx);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* The stamp                                                                                                        */

typedef struct stamp {
    char build[65], request[65], files[65];
    long long written;
} stamp;

static int parse_hex(const char *s, char out[65])
{
    for (int i = 0; i < 64; i++)
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return 0;
    if (s[64] && s[64] != '\n' && s[64] != ' ')
        return 0;
    memcpy(out, s, 64);
    out[64] = 0;
    return 1;
}

/* Reads dir's stamp into text (NUL-terminated, malloc'ed) and its fixed fields into st. 0 when there is none or it
 * is not one this format. */
static int stamp_read(const char *dir, char **text, stamp *st)
{
    *text = NULL;
    memset(st, 0, sizeof *st);
    char *buf = malloc(STAMP_MAX + 1);
    if (!buf)
        return 0;
    ssize_t n = getxattr(dir, STAMP_ATTR, buf, STAMP_MAX);
    if (n <= 0) {
        free(buf);
        return 0;
    }
    buf[n] = 0;
    int have = 0;
    if (strncmp(buf, "rtoracle-stamp 1\n", 17) == 0) {
        for (char *line = buf; line && *line; line = strchr(line, '\n'), line = line ? line + 1 : NULL) {
            if (!strncmp(line, "build ", 6) && parse_hex(line + 6, st->build))
                have |= 1;
            else if (!strncmp(line, "request ", 8) && parse_hex(line + 8, st->request))
                have |= 2;
            else if (!strncmp(line, "files ", 6) && parse_hex(line + 6, st->files))
                have |= 4;
            else if (!strncmp(line, "written ", 8))
                have |= 8 * (sscanf(line + 8, "%lld", &st->written) == 1);
        }
    }
    if (have != 15) {
        free(buf);
        return 0;
    }
    *text = buf;
    return 1;
}

/* What a directory's check found: the digest, or the first thing that is wrong. */
typedef struct digest_state {
    long long since; /* files modified after this (ns) are named as changed */
    char changed[400];
} digest_state;

static int plain(const char *name)
{
    return name && *name && !strchr(name, '/') && strcmp(name, ".") && strcmp(name, "..");
}

static int digest_dir(const char *dir, int depth, digest_state *ds, char hex[65]);

/* One file's line of the digest; 0 (with ds->changed) when it is missing or not a regular file. */
static int digest_file(EVP_MD_CTX *ctx, const char *dir, const char *name, digest_state *ds)
{
    char *path = plain(name) ? rto__path_join(dir, name) : NULL;
    struct stat st;
    int ok = path && lstat(path, &st) == 0 && S_ISREG(st.st_mode);
    if (!ok) {
        snprintf(ds->changed, sizeof ds->changed, "%s/%s is missing", dir, name ? name : "(unnamed)");
    } else {
        const long long mtime = (long long)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec;
        if (mtime > ds->since && !ds->changed[0])
            snprintf(ds->changed, sizeof ds->changed, "%s was modified after the bundle was written", path);
        char line[160];
        int n = snprintf(line, sizeof line, "\n%llu %lld %lld", (unsigned long long)st.st_ino,
                         (long long)st.st_size, mtime);
        EVP_DigestUpdate(ctx, name, strlen(name));
        EVP_DigestUpdate(ctx, line, (size_t)n);
        EVP_DigestUpdate(ctx, "\n", 1);
    }
    free(path);
    return ok;
}

/* A suite case's line: its own stamp, checked against its files. */
static int digest_case(EVP_MD_CTX *ctx, const char *dir, const char *name, int depth, digest_state *ds)
{
    char *path = plain(name) ? rto__path_join(dir, name) : NULL;
    char *text = NULL, hex[65];
    stamp st;
    int ok = 0;
    if (!path) {
        snprintf(ds->changed, sizeof ds->changed, "%s: a case is not a plain name", dir);
    } else if (depth + 1 >= STAMP_NEST_MAX || !stamp_read(path, &text, &st)) {
        snprintf(ds->changed, sizeof ds->changed, "%s is missing or was replaced", path);
    } else {
        digest_state inner = {st.written, {0}};
        if (!digest_dir(path, depth + 1, &inner, hex) || strcmp(hex, st.files) != 0) {
            snprintf(ds->changed, sizeof ds->changed, "%s", inner.changed[0] ? inner.changed : "a case changed");
        } else {
            char sha[65];
            sha_text(text, strlen(text), sha);
            EVP_DigestUpdate(ctx, "case ", 5);
            EVP_DigestUpdate(ctx, name, strlen(name));
            EVP_DigestUpdate(ctx, sha, 64);
            EVP_DigestUpdate(ctx, "\n", 1);
            ok = 1;
        }
    }
    free(text);
    free(path);
    return ok;
}

/* The digest of a bundle directory: manifest.json and what it lists. 0 (ds->changed says why) when something is
 * missing or the manifest cannot be read; a file modified after ds->since is named in ds->changed but still
 * digested (the caller decides by the digest). */
static int digest_dir(const char *dir, int depth, digest_state *ds, char hex[65])
{
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1) {
        EVP_MD_CTX_free(ctx);
        snprintf(ds->changed, sizeof ds->changed, "out of memory");
        return 0;
    }
    int ok = digest_file(ctx, dir, "manifest.json", ds);
    json_t *root = NULL;
    if (ok) {
        char *m = rto__path_join(dir, "manifest.json");
        json_error_t jerr;
        root = m ? json_load_file(m, JSON_REJECT_DUPLICATES, &jerr) : NULL;
        if (!root) {
            snprintf(ds->changed, sizeof ds->changed, "%s/manifest.json cannot be read", dir);
            ok = 0;
        }
        free(m);
    }
    size_t i;
    json_t *e;
    json_array_foreach(json_object_get(root, "files"), i, e)
    {
        if (ok)
            ok = digest_file(ctx, dir, json_string_value(json_object_get(e, "name")), ds);
    }
    json_array_foreach(json_object_get(root, "cases"), i, e)
    {
        if (ok)
            ok = digest_case(ctx, dir, json_string_value(json_object_get(e, "dir")), depth, ds);
    }
    json_decref(root);
    ok = sha_finish(ctx, hex) && ok;
    EVP_MD_CTX_free(ctx);
    return ok;
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* "source HEX PATH\n" of one input file; the hash of what is there now, - when it cannot be read. */
static char *source_line(const char *path)
{
    char hex[65];
    if (rto_sha256_file(path, hex, NULL) != RTO_OK)
        strcpy(hex, "-");
    size_t len = strlen(path) + 80;
    char *line = malloc(len);
    if (line)
        snprintf(line, len, "source %s %s\n", hex, path);
    return line;
}

static void request_hash(const char *request, char hex[65])
{
    sha_text(request, strlen(request), hex);
}

rto_status rto__stamp_head(const char *request, const char *const *sources, size_t count, char **out, rto_msg *msg)
{
    *out = NULL;
    if (!request)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL request");
    if (!g_build[0])
        return RTO_OK; /* no build identity: bundles go unstamped */
    char req[65];
    request_hash(request, req);
    size_t len = 0;
    char *text = malloc(256);
    if (!text)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    len = (size_t)snprintf(text, 256, "rtoracle-stamp 1\nbuild %s\nrequest %s\n", g_build, req);
    for (size_t i = 0; i < count; i++) {
        /* A name the one-line text cannot hold, or more than fits: the bundle goes unstamped (rewritten each run). */
        if (!sources[i] || strchr(sources[i], '\n')) {
            free(text);
            return RTO_OK;
        }
        /* An input changed while this command ran: the bundle may not be what the recorded hash would give. */
        struct stat st;
        if (stat(sources[i], &st) == 0 &&
            ((long long)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec >= g_start_ns ||
             (long long)st.st_ctim.tv_sec * 1000000000LL + st.st_ctim.tv_nsec >= g_start_ns)) {
            free(text);
            return RTO_OK;
        }
        char *line = source_line(sources[i]);
        size_t n = line ? strlen(line) : 0;
        char *grown = line && len + n + 1 <= STAMP_MAX - 200 ? realloc(text, len + n + 1) : NULL;
        if (!grown) {
            free(line);
            free(text);
            return line ? RTO_OK : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        }
        text = grown;
        memcpy(text + len, line, n + 1);
        len += n;
        free(line);
    }
    *out = text;
    return RTO_OK;
}

void rto__stamp_write(const char *tmpdir, const char *head)
{
    if (!head)
        return;
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    digest_state ds = {INT64_MAX, {0}};
    char hex[65];
    if (!digest_dir(tmpdir, 0, &ds, hex))
        return;
    size_t len = strlen(head) + 128;
    char *text = malloc(len);
    if (!text)
        return;
    int n = snprintf(text, len, "%swritten %lld\nfiles %s\n", head,
                     (long long)now.tv_sec * 1000000000LL + now.tv_nsec, hex);
    /* A file system without user extended attributes (or one too small for the text) leaves the bundle unstamped:
     * still a good bundle, rewritten by the next run. */
    if (n > 0 && (size_t)n < len)
        (void)setxattr(tmpdir, STAMP_ATTR, text, (size_t)n, 0);
    free(text);
}

rto_bundle_state rto_bundle_check(const char *outdir, const char *request, rto_msg *why)
{
    if (why)
        why->text[0] = 0;
    struct stat st;
    if (!outdir || !request || stat(outdir, &st) != 0 || !S_ISDIR(st.st_mode))
        return RTO_BUNDLE_ABSENT;
    char *text = NULL;
    stamp sp;
    if (!stamp_read(outdir, &text, &sp)) {
        rto_msg_set(why, RTO_ERR_MISMATCH, "%s was not stamped by rtoracle", outdir);
        return RTO_BUNDLE_STALE;
    }
    rto_bundle_state state = RTO_BUNDLE_CURRENT;
    char req[65];
    request_hash(request, req);
    digest_state ds = {sp.written, {0}};
    char hex[65];
    if (!g_build[0] || strcmp(sp.build, g_build) != 0) {
        rto_msg_set(why, RTO_ERR_MISMATCH, "%s was written by another rtoracle build", outdir);
        state = RTO_BUNDLE_STALE;
    } else if (strcmp(sp.request, req) != 0) {
        rto_msg_set(why, RTO_ERR_MISMATCH, "%s was written for other arguments", outdir);
        state = RTO_BUNDLE_STALE;
    } else if (!digest_dir(outdir, 0, &ds, hex) || strcmp(hex, sp.files) != 0) {
        rto_msg_set(why, RTO_ERR_MISMATCH, "%s", ds.changed[0] ? ds.changed : "a file of the bundle was replaced");
        state = RTO_BUNDLE_CHANGED;
    } else {
        /* Every input file hashes as when the bundle was written. */
        for (char *line = text; line && *line && state == RTO_BUNDLE_CURRENT;
             line = strchr(line, '\n'), line = line ? line + 1 : NULL) {
            if (strncmp(line, "source ", 7) != 0)
                continue;
            char *end = strchr(line, '\n'), *sp1 = strchr(line + 7, ' ');
            if (!end || !sp1 || sp1 > end) {
                state = RTO_BUNDLE_STALE;
                break;
            }
            *end = 0;
            char *now = source_line(sp1 + 1);
            const size_t len = strlen(line);
            if (!now || strncmp(now, line, len) != 0 || strcmp(now + len, "\n") != 0) {
                rto_msg_set(why, RTO_ERR_MISMATCH, "%s changed since %s was written", sp1 + 1, outdir);
                state = RTO_BUNDLE_STALE;
            }
            free(now);
            *end = '\n';
        }
    }
    free(text);
    return state;
}
