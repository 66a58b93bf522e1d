/* Bundles: atomic replacement, refusal to clobber, sha256 verification, version refusal, determinism; what -o may
 * replace, temporaries removed on a signal, JSON that is valid whatever the values, every jansson failure reported. */
#include "testutil.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

static char root[256];

static int setup(void **state)
{
    (void)state;
    return tu_tmpdir_make(root, sizeof root, "bundle");
}

static int teardown(void **state)
{
    (void)state;
    return tu_tmpdir_remove(root);
}

static void write_bundle(const char *dir, uint32_t fill)
{
    uint32_t data[5] = {fill, 2, 3, 4, 5};
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_OK);
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 5);
    assert_int_equal(rto_bundle_add_npy(b, "a.npy", "things", NULL, &d, data, &msg), RTO_OK);
    assert_int_equal(rto_bundle_set_str(b, "params", "algo", "bitonic"), RTO_OK);
    assert_int_equal(rto_bundle_set_int(b, "params", "n", 5), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK);
}

static void test_commit_abort_and_replace(void **state)
{
    (void)state;
    char dir[300], file[320];
    snprintf(dir, sizeof dir, "%s/b", root);
    rto_bundle *b = NULL;
    assert_int_equal(rto_bundle_begin(dir, "test", &b, NULL), RTO_OK);
    uint32_t x = 1;
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 1);
    assert_int_equal(rto_bundle_add_npy(b, "x.npy", "x", NULL, &d, &x, NULL), RTO_OK);
    assert_int_equal(tu_dir_entries(root), 1); /* only the temporary directory */
    rto_bundle_abort(b);
    assert_int_equal(tu_dir_entries(root), 0);

    write_bundle(dir, 1);
    assert_int_equal(tu_dir_entries(root), 1);
    rto_bundle_reader *r = NULL;
    assert_int_equal(rto_bundle_open(dir, &r, NULL), RTO_OK);
    assert_string_equal(rto_bundle_get_str(r, "params", "algo"), "bitonic");
    int64_t n = 0;
    assert_true(rto_bundle_get_int(r, "params", "n", &n));
    assert_int_equal(n, 5);
    assert_null(rto_bundle_get_str(r, "params", "missing"));
    rto_npy a = {0};
    assert_int_equal(rto_bundle_read_role(r, "things", &a, NULL), RTO_OK);
    assert_int_equal(((uint32_t *)a.data)[0], 1);
    rto_npy_free(&a);
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_read_role(r, "absent", &a, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "absent"));
    rto_bundle_close(r);

    /* replacing a previous bundle swaps it whole and leaves no temporary behind */
    write_bundle(dir, 7);
    assert_int_equal(tu_dir_entries(root), 1);
    assert_int_equal(rto_bundle_open(dir, &r, NULL), RTO_OK);
    assert_int_equal(rto_bundle_read_role(r, "things", &a, NULL), RTO_OK);
    assert_int_equal(((uint32_t *)a.data)[0], 7);
    rto_npy_free(&a);

    /* a changed file is refused by its sha256 */
    snprintf(file, sizeof file, "%s/a.npy", dir);
    FILE *fp = fopen(file, "r+b");
    assert_non_null(fp);
    fseek(fp, -1, SEEK_END);
    fputc(0x55, fp);
    fclose(fp);
    assert_int_equal(rto_bundle_read_role(r, "things", &a, &msg), RTO_ERR_PARSE);
    assert_non_null(strstr(msg.text, "sha256"));
    rto_bundle_close(r);
    rto_bundle_close(NULL);
    rto_bundle_abort(NULL);
}

/* A bundle is input: a file it names, or its manifest, may be a FIFO (an open would wait for a writer) or a link to
 * /dev/zero (a read would never end). Each is refused at once; the alarm turns a hang into a failure. */
static void test_reader_refuses_special_files(void **state)
{
    (void)state;
    char dir[300], file[320], manifest[320];
    snprintf(dir, sizeof dir, "%s/b", root);
    write_bundle(dir, 1);
    snprintf(file, sizeof file, "%s/a.npy", dir);
    snprintf(manifest, sizeof manifest, "%s/manifest.json", dir);
    alarm(20);
    rto_bundle_reader *r = NULL;
    rto_msg msg = {{0}};
    rto_npy a = {0};
    assert_int_equal(rto_bundle_open(dir, &r, &msg), RTO_OK);
    assert_int_equal(unlink(file), 0);
    assert_int_equal(symlink("/dev/zero", file), 0);
    assert_int_equal(rto_bundle_read_role(r, "things", &a, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a regular file"));
    assert_int_equal(unlink(file), 0);
    assert_int_equal(mkfifo(file, 0644), 0);
    assert_int_equal(rto_bundle_read_role(r, "things", &a, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a regular file"));
    assert_int_equal(rto_npy_read(file, &a, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a regular file"));
    rto_bundle_close(r);
    assert_int_equal(unlink(manifest), 0);
    assert_int_equal(mkfifo(manifest, 0644), 0);
    r = NULL;
    assert_int_equal(rto_bundle_open(dir, &r, &msg), RTO_ERR_IO);
    assert_null(r);
    assert_non_null(strstr(msg.text, "not a regular file"));
    alarm(0);
}

static void test_refuses_foreign_directory_and_versions(void **state)
{
    (void)state;
    char dir[300], file[320];
    snprintf(dir, sizeof dir, "%s/foreign", root);
    mkdir(dir, 0755);
    snprintf(file, sizeof file, "%s/notes.txt", dir);
    FILE *fp = fopen(file, "w");
    fputs("keep me\n", fp);
    fclose(fp);
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_ERR_IO);
    assert_null(b);
    assert_non_null(strstr(msg.text, "not an rtoracle bundle"));
    assert_int_equal(access(file, F_OK), 0);

    snprintf(file, sizeof file, "%s/manifest.json", dir);
    fp = fopen(file, "w");
    fputs("{\"format\": \"rtoracle-bundle\", \"format_version\": 2}", fp);
    fclose(fp);
    rto_bundle_reader *r = NULL;
    assert_int_equal(rto_bundle_open(dir, &r, &msg), RTO_ERR_UNSUPPORTED);
    assert_non_null(strstr(msg.text, "version 2"));
    fp = fopen(file, "w");
    fputs("{\"format\": \"something-else\"", fp);
    fclose(fp);
    assert_int_equal(rto_bundle_open(dir, &r, &msg), RTO_ERR_PARSE);
    assert_null(r);
}

static void test_same_input_same_bytes(void **state)
{
    (void)state;
    char a[300], b[300], cmd[700];
    snprintf(a, sizeof a, "%s/d1", root);
    snprintf(b, sizeof b, "%s/d2", root);
    write_bundle(a, 3);
    write_bundle(b, 3);
    snprintf(cmd, sizeof cmd, "diff -r '%s' '%s' >/dev/null", a, b);
    assert_int_equal(system(cmd), 0);
    write_bundle(b, 4);
    assert_int_not_equal(system(cmd), 0); /* control: different data, different bytes */
}

static void put_file(const char *path, const char *text)
{
    FILE *fp = fopen(path, "w");
    assert_non_null(fp);
    fputs(text, fp);
    fclose(fp);
}

static char *slurp(const char *path)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return NULL;
    static char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, fp);
    fclose(fp);
    buf[n] = '\0';
    return buf;
}

/* Unicode §3.9's own example (Table 3-8) and one case per rule of Table 3-7, with the expected bytes written out. */
static void test_utf8_repair(void **state)
{
    (void)state;
#define R "\xef\xbf\xbd"
    static const struct {
        const char *in, *out;
    } cases[] = {
        {"plain ascii", "plain ascii"},
        {"", ""},
        {"\x61\xF1\x80\x80\xE1\x80\xC2\x62\x80\x63\x80\xBF\x64", "a" R R R "b" R "c" R R "d"},
        {"caf\xc3\xa9", "caf\xc3\xa9"},               /* valid two-byte */
        {"\xf0\x9f\x98\x80!", "\xf0\x9f\x98\x80!"},   /* valid four-byte */
        {"ab\xe2\x82", "ab" R},                       /* cut inside a three-byte character: one U+FFFD */
        {"x\xc3", "x" R},                             /* cut inside a two-byte character */
        {"\xc0\xaf", R R},                            /* overlong lead C0 */
        {"\xe0\x80\x80", R R R},                      /* overlong three-byte */
        {"\xed\xa0\x80", R R R},                      /* a surrogate */
        {"\xf4\x90\x80\x80", R R R R},                /* above U+10FFFF */
        {"\xf5\x80", R R},                            /* F5 never starts a character */
        {"\xff" "a\xfe", R "a" R},
        {"\xe2\x82\xac\xe2\x82", "\xe2\x82\xac" R},   /* euro sign, then a cut one */
    };
#undef R
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char out[64];
        size_t n = rto_utf8_repair(cases[i].in, out, sizeof out);
        assert_int_equal(n, strlen(cases[i].out));
        assert_string_equal(out, cases[i].out);
        assert_int_equal(rto_utf8_repair(cases[i].in, NULL, 0), n);
    }
    /* cut to capacity at a character boundary only: "éé" (4 bytes) in 4 bytes keeps one é */
    char small[4];
    assert_int_equal(rto_utf8_repair("\xc3\xa9\xc3\xa9", small, sizeof small), 4);
    assert_string_equal(small, "\xc3\xa9");
    assert_int_equal(rto_utf8_repair("\xc3\xa9\xc3\xa9", small, 1), 4);
    assert_string_equal(small, "");
}

/* Non-finite reals and strings that are not UTF-8 are encoded, not dropped; the manifest stays valid JSON. */
static void test_manifest_encodes_what_json_cannot_hold(void **state)
{
    (void)state;
    char dir[300], path[320];
    snprintf(dir, sizeof dir, "%s/enc", root);
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_OK);
    assert_int_equal(rto_bundle_set_real(b, "stats", "pos", INFINITY), RTO_OK);
    assert_int_equal(rto_bundle_set_real(b, "stats", "neg", -INFINITY), RTO_OK);
    assert_int_equal(rto_bundle_set_real(b, "stats", "nan", NAN), RTO_OK);
    assert_int_equal(rto_bundle_set_real(b, "stats", "fine", 0.25), RTO_OK);
    assert_int_equal(rto_bundle_set_str(b, "", "scene", "bad\xffname \xce"), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK);

    snprintf(path, sizeof path, "%s/manifest.json", dir);
    json_error_t err;
    json_t *j = json_load_file(path, JSON_REJECT_DUPLICATES, &err); /* jansson accepts only valid UTF-8 JSON */
    assert_non_null(j);
    json_t *stats = json_object_get(j, "stats");
    assert_string_equal(json_string_value(json_object_get(stats, "pos")), "inf");
    assert_string_equal(json_string_value(json_object_get(stats, "neg")), "-inf");
    assert_string_equal(json_string_value(json_object_get(stats, "nan")), "nan");
    assert_true(json_real_value(json_object_get(stats, "fine")) == 0.25);
    assert_string_equal(json_string_value(json_object_get(j, "scene")), "bad\xef\xbf\xbdname \xef\xbf\xbd");
    json_decref(j);
}

/* A failed setter is not lost when the caller ignores its status: commit fails with it and writes nothing. */
static void test_setter_failure_fails_commit(void **state)
{
    (void)state;
    char dir[300];
    snprintf(dir, sizeof dir, "%s/sticky", root);
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_OK);
    assert_int_equal(rto_bundle_set_str(b, "params", NULL, "x"), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_bundle_set_int(b, "params", "n", 1), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "manifest.json"));
    assert_int_equal(tu_dir_entries(root), 0);
}

/* jansson's allocation number g_json_budget (counting from 0) fails, the others succeed: each must give an error,
 * never a manifest with something missing. The number grows until a bundle needs fewer allocations, so every
 * allocation of every jansson call is made to fail once, with every call after it still working. */
static long g_json_budget = -1;
static void *budget_malloc(size_t n)
{
    if (g_json_budget >= 0 && g_json_budget-- == 0)
        return NULL;
    return malloc(n);
}

/* One bundle like write_bundle(…, 9), every status ignored: commit must still fail if any step did. */
static rto_status write_ignoring_statuses(const char *dir, rto_msg *msg)
{
    uint32_t data[5] = {9, 2, 3, 4, 5};
    rto_bundle *b = NULL;
    rto_status s = rto_bundle_begin(dir, "test", &b, msg);
    if (s)
        return s;
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 5);
    rto_bundle_add_npy(b, "a.npy", "things", NULL, &d, data, msg);
    rto_bundle_set_str(b, "params", "algo", "bitonic");
    rto_bundle_set_int(b, "params", "n", 5);
    return rto_bundle_commit(b, msg);
}

static void test_every_jansson_failure_is_an_error(void **state)
{
    (void)state;
    char ref[300], dir[300], prev[300], cmd[1000];
    snprintf(ref, sizeof ref, "%s/ref", root);
    snprintf(dir, sizeof dir, "%s/oom", root);
    snprintf(prev, sizeof prev, "%s/prev", root);
    write_bundle(ref, 9);
    write_bundle(prev, 1);
    json_set_alloc_funcs(budget_malloc, free);
    long budget = 0;
    for (; budget < 100000; budget++) {
        int untouched = 1; /* no allocation failed: the budget is past the last one */
        /* a fresh directory, then over a previous bundle (which also parses the old manifest) */
        for (int over = 0; over < 2; over++) {
            const char *target = over ? prev : dir;
            rto_msg msg = {{0}};
            g_json_budget = budget;
            rto_status s = write_ignoring_statuses(target, &msg);
            untouched &= g_json_budget >= 0;
            g_json_budget = -1;
            json_set_alloc_funcs(malloc, free);
            if (s == RTO_OK) {
                snprintf(cmd, sizeof cmd, "diff -r '%s' '%s' >/dev/null && rm -rf '%s'", ref, target, dir);
                assert_int_equal(system(cmd), 0); /* complete, byte for byte */
                if (over)
                    write_bundle(prev, 1);
            } else {
                /* jansson reports some allocation failures while parsing as syntax errors ("invalid token"); the
                 * previous bundle then is refused as not ours, which is safe: it is kept */
                if (!(over && s == RTO_ERR_IO && strstr(msg.text, "refusing to replace")))
                    assert_int_equal(s, RTO_ERR_OUT_OF_MEMORY);
                assert_true(msg.text[0] != '\0');
                assert_int_equal(access(dir, F_OK), -1); /* nothing written */
                rto_bundle_reader *r = NULL;             /* the previous bundle is intact */
                rto_npy a = {0};
                assert_int_equal(rto_bundle_open(prev, &r, NULL), RTO_OK);
                assert_int_equal(rto_bundle_read_role(r, "things", &a, NULL), RTO_OK);
                assert_int_equal(((uint32_t *)a.data)[0], 1);
                rto_npy_free(&a);
                rto_bundle_close(r);
            }
            assert_int_equal(tu_dir_entries(root), 2); /* ref and prev: no temporaries, no half bundle */
            json_set_alloc_funcs(budget_malloc, free);
        }
        if (untouched)
            break;
    }
    json_set_alloc_funcs(malloc, free);
    assert_true(budget > 10 && budget < 100000);
}

/* What rto_bundle_begin may replace: our bundles (nested suites included) and nothing with a file of the user's. */
static void test_replaces_only_its_own_bundles(void **state)
{
    (void)state;
    char dir[300], file[400], link[300];
    rto_msg msg = {{0}};
    rto_bundle *b = NULL;
    /* the directory: an empty manifest.json and an index.html */
    snprintf(dir, sizeof dir, "%s/site", root);
    mkdir(dir, 0755);
    snprintf(file, sizeof file, "%s/manifest.json", dir);
    put_file(file, "{}");
    snprintf(file, sizeof file, "%s/index.html", dir);
    put_file(file, "x\n");
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_ERR_IO);
    assert_null(b);
    assert_non_null(strstr(msg.text, "not an rtoracle bundle"));
    assert_string_equal(slurp(file), "x\n");

    /* a suite: a case is a listed subdirectory that is a bundle itself */
    snprintf(dir, sizeof dir, "%s/suite", root);
    for (int round = 0; round < 2; round++) {
        assert_int_equal(rto_bundle_begin(dir, "suite", &b, &msg), RTO_OK);
        char sub[400];
        snprintf(sub, sizeof sub, "%s/case0", rto_bundle_tmpdir(b));
        write_bundle(sub, 2);
        assert_int_equal(rto_bundle_add_case(b, "case0", "test:0", &msg), RTO_OK);
        assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK); /* the second round replaces the first */
    }
    snprintf(file, sizeof file, "%s/case0/mine.txt", dir);
    put_file(file, "mine");
    assert_int_equal(rto_bundle_begin(dir, "suite", &b, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "case0/mine.txt"));
    assert_string_equal(slurp(file), "mine");
    unlink(file);

    /* a link is followed: the bundle it names is replaced, the link stays */
    snprintf(dir, sizeof dir, "%s/real", root);
    snprintf(link, sizeof link, "%s/link", root);
    write_bundle(dir, 3);
    assert_int_equal(symlink("real", link), 0);
    write_bundle(link, 4);
    struct stat st;
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    rto_bundle_reader *r = NULL;
    rto_npy a = {0};
    assert_int_equal(rto_bundle_open(dir, &r, NULL), RTO_OK);
    assert_int_equal(rto_bundle_read_role(r, "things", &a, NULL), RTO_OK);
    assert_int_equal(((uint32_t *)a.data)[0], 4);
    rto_npy_free(&a);
    rto_bundle_close(r);
    /* a dangling link, a regular file, a missing parent: refused, nothing created */
    snprintf(link, sizeof link, "%s/dangling", root);
    assert_int_equal(symlink("nowhere", link), 0);
    assert_int_equal(rto_bundle_begin(link, "test", &b, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "symbolic link"));
    snprintf(file, sizeof file, "%s/plain", root);
    put_file(file, "data");
    assert_int_equal(rto_bundle_begin(file, "test", &b, &msg), RTO_ERR_IO);
    assert_string_equal(slurp(file), "data");
    snprintf(file, sizeof file, "%s/missing/out", root);
    assert_int_equal(rto_bundle_begin(file, "test", &b, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "missing"));
    snprintf(file, sizeof file, "%s/nowhere", root);
    assert_int_equal(access(file, F_OK), -1);
}

/* rto_temporaries_remove (what a SIGINT handler calls) removes every temporary in progress, nested ones included,
 * and nothing else; the writers then fail or abort cleanly. */
static void test_temporaries_remove(void **state)
{
    (void)state;
    char keep[300], dir[300], sub[400];
    snprintf(keep, sizeof keep, "%s/keep", root);
    write_bundle(keep, 5);
    snprintf(dir, sizeof dir, "%s/out", root);
    rto_bundle *outer = NULL, *inner = NULL;
    assert_int_equal(rto_bundle_begin(dir, "suite", &outer, NULL), RTO_OK);
    snprintf(sub, sizeof sub, "%s/case0", rto_bundle_tmpdir(outer));
    write_bundle(sub, 1); /* a finished case inside the temporary */
    snprintf(sub, sizeof sub, "%s/case1", rto_bundle_tmpdir(outer));
    assert_int_equal(rto_bundle_begin(sub, "sort", &inner, NULL), RTO_OK);
    uint32_t x = 1;
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 1);
    assert_int_equal(rto_bundle_add_npy(inner, "x.npy", "x", NULL, &d, &x, NULL), RTO_OK);
    assert_int_equal(tu_dir_entries(root), 2); /* keep, out.tmp.* */

    rto_temporaries_remove();
    assert_int_equal(tu_dir_entries(root), 1);
    assert_int_equal(access(keep, F_OK), 0);
    rto_msg msg = {{0}};
    assert_int_not_equal(rto_bundle_commit(inner, &msg), RTO_OK);
    rto_bundle_abort(outer);
    assert_int_equal(tu_dir_entries(root), 1);
    /* the registry's slots were released: another bundle is cleaned up as well */
    for (int i = 0; i < 40; i++) {
        assert_int_equal(rto_bundle_begin(dir, "test", &outer, NULL), RTO_OK);
        if (i == 39) {
            rto_temporaries_remove();
            assert_int_equal(tu_dir_entries(root), 1);
        }
        rto_bundle_abort(outer);
    }
}

/* rto_file_write: atomic, over a regular file only, a link followed; the umask decides the mode. */
static void test_file_write(void **state)
{
    (void)state;
    char path[300], link[300], fifo[300];
    rto_msg msg = {{0}};
    snprintf(path, sizeof path, "%s/report.json", root);
    assert_int_equal(rto_file_write(path, "{}\n", 3, &msg), RTO_OK);
    assert_string_equal(slurp(path), "{}\n");
    mode_t old = umask(027);
    assert_int_equal(rto_file_write(path, "[1]\n", 4, &msg), RTO_OK);
    umask(old);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0640);
    assert_string_equal(slurp(path), "[1]\n");
    snprintf(link, sizeof link, "%s/link.json", root);
    assert_int_equal(symlink("report.json", link), 0);
    assert_int_equal(rto_file_write(link, "[2]\n", 4, &msg), RTO_OK);
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_string_equal(slurp(path), "[2]\n");
    snprintf(fifo, sizeof fifo, "%s/fifo.json", root);
    assert_int_equal(mkfifo(fifo, 0644), 0);
    assert_int_equal(rto_file_write(fifo, "x", 1, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a regular file"));
    assert_int_equal(rto_file_write(root, "x", 1, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "directory"));
    snprintf(path, sizeof path, "%s/no/such.json", root);
    assert_int_equal(rto_file_write(path, "x", 1, &msg), RTO_ERR_IO);
    assert_int_equal(tu_dir_entries(root), 3); /* report.json, link.json, fifo.json: no temporaries */
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Shared arrays (rto_bundle_share)                                                                                 */

/* A bundle of three arrays, the first two given by seeds: a.npy from sa, b.npy from sb, c.npy from sa again (the
 * same bytes as a.npy); with table t (NULL: none). */
static void write_shared(const char *dir, rto_bundle_share *t, uint32_t sa, uint32_t sb)
{
    uint32_t x[64], y[64];
    for (uint32_t i = 0; i < 64; i++) {
        x[i] = sa * 2654435761u + i;
        y[i] = sb * 2654435761u + i;
    }
    rto_bundle *b = NULL;
    rto_msg msg = {{0}};
    assert_int_equal(rto_bundle_begin(dir, "test", &b, &msg), RTO_OK);
    rto_bundle_set_share(b, t);
    rto_npy_desc d = rto_npy_desc_keys(RTO_KEY_U32, 64);
    assert_int_equal(rto_bundle_add_npy(b, "a.npy", "a", NULL, &d, x, &msg), RTO_OK);
    assert_int_equal(rto_bundle_add_npy(b, "b.npy", "b", NULL, &d, y, &msg), RTO_OK);
    assert_int_equal(rto_bundle_add_npy(b, "c.npy", "c", NULL, &d, x, &msg), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK);
}

static struct stat stat_of(const char *dir, const char *name)
{
    char path[400];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    assert_int_equal(lstat(path, &st), 0);
    return st;
}

/* 1 when dir/x and dir2/y are the same file (one inode). */
static int same_file(const char *dir, const char *x, const char *dir2, const char *y)
{
    struct stat a = stat_of(dir, x), b = stat_of(dir2, y);
    return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

/* Every array of the bundle reads back through its manifest's sha256. */
static void assert_bundle_reads(const char *dir)
{
    static const char *const names[] = {"a.npy", "b.npy", "c.npy"};
    rto_bundle_reader *r = NULL;
    assert_int_equal(rto_bundle_open(dir, &r, NULL), RTO_OK);
    for (int i = 0; i < 3; i++) {
        rto_npy a = {0};
        rto_msg msg = {{0}};
        rto_status s = rto_bundle_read_name(r, names[i], &a, &msg);
        if (s)
            fail_msg("%s/%s: %s", dir, names[i], msg.text);
        rto_npy_free(&a);
    }
    rto_bundle_close(r);
}

static void diff_r(const char *a, const char *b, int want)
{
    char cmd[800];
    snprintf(cmd, sizeof cmd, "diff -r '%s' '%s' >/dev/null", a, b);
    assert_int_equal(system(cmd) == 0, want);
}

/* Identical arrays are one file exactly where their bytes are the same, within a bundle and across bundles, and the
 * bundles are byte for byte those written without a table. */
static void test_share_links_identical_arrays(void **state)
{
    (void)state;
    char p1[300], p2[300], p3[300], q1[300], q2[300], q3[300];
    snprintf(p1, sizeof p1, "%s/p1", root);
    snprintf(p2, sizeof p2, "%s/p2", root);
    snprintf(p3, sizeof p3, "%s/p3", root);
    snprintf(q1, sizeof q1, "%s/q1", root);
    snprintf(q2, sizeof q2, "%s/q2", root);
    snprintf(q3, sizeof q3, "%s/q3", root);
    rto_bundle_share *t = rto_bundle_share_create();
    assert_non_null(t);
    write_shared(p1, t, 1, 2);
    write_shared(p2, t, 1, 3); /* a.npy and c.npy as p1's, b.npy not */
    write_shared(p3, t, 3, 1); /* a.npy and c.npy as p2's b.npy, b.npy as p1's a.npy */
    rto_bundle_share_destroy(t);
    write_shared(q1, NULL, 1, 2);
    write_shared(q2, NULL, 1, 3);
    write_shared(q3, NULL, 3, 1);
    diff_r(p1, q1, 1);
    diff_r(p2, q2, 1);
    diff_r(p3, q3, 1);
    diff_r(p1, p2, 0); /* control: b.npy differs */

    /* within a bundle */
    assert_true(same_file(p1, "a.npy", p1, "c.npy"));
    assert_false(same_file(p1, "a.npy", p1, "b.npy"));
    assert_false(same_file(q1, "a.npy", q1, "c.npy")); /* without a table: copies */
    /* across bundles */
    assert_true(same_file(p1, "a.npy", p2, "a.npy"));
    assert_true(same_file(p1, "a.npy", p2, "c.npy"));
    assert_false(same_file(p1, "b.npy", p2, "b.npy"));
    assert_true(same_file(p2, "b.npy", p3, "a.npy"));
    assert_true(same_file(p2, "b.npy", p3, "c.npy"));
    assert_true(same_file(p1, "a.npy", p3, "b.npy"));
    assert_int_equal(stat_of(p1, "a.npy").st_nlink, 5); /* p1 a, c; p2 a, c; p3 b */
    assert_int_equal(stat_of(p1, "b.npy").st_nlink, 1);
    assert_int_equal(stat_of(q1, "a.npy").st_nlink, 1);

    /* Rewriting one bundle (a new directory renamed into place) leaves the others' linked files as they were. */
    struct stat before = stat_of(p2, "a.npy");
    write_shared(p1, NULL, 7, 8);
    struct stat after = stat_of(p2, "a.npy");
    assert_int_equal(before.st_ino, after.st_ino);
    assert_int_equal(after.st_nlink, 3); /* p2's a.npy and c.npy, p3's b.npy: p1's two names went with the old one */
    assert_true(before.st_mtim.tv_sec == after.st_mtim.tv_sec && before.st_mtim.tv_nsec == after.st_mtim.tv_nsec);
    diff_r(p2, q2, 1);
    diff_r(p3, q3, 1);
    assert_bundle_reads(p2);
    assert_bundle_reads(p3);
    rto_bundle_share_destroy(NULL);
}

/* A registered file changed after its bundle was committed is not linked to: the next bundle writes its own copy
 * (and that copy is what later bundles link to). Each way a file can change, each seen by one attribute alone:
 * rewritten in place (same inode and size, later mtime), replaced by a copy (new inode; same size and mtime),
 * truncated (smaller; same inode and mtime), removed. */
static void test_share_skips_changed_files(void **state)
{
    (void)state;
    static const char *const how[] = {"in place", "replaced", "truncated", "removed"};
    for (int k = 0; k < 4; k++) {
        char p1[300], p2[300], p3[300], file[320], copy[340];
        snprintf(p1, sizeof p1, "%s/c%d_1", root, k);
        snprintf(p2, sizeof p2, "%s/c%d_2", root, k);
        snprintf(p3, sizeof p3, "%s/c%d_3", root, k);
        snprintf(file, sizeof file, "%s/b.npy", p1);
        snprintf(copy, sizeof copy, "%s/b.copy", root);
        rto_bundle_share *t = rto_bundle_share_create();
        assert_non_null(t);
        write_shared(p1, t, 1, 2);
        struct stat was = stat_of(p1, "b.npy");
        if (k == 0) {
            /* one byte of the data rewritten, the file's size kept; its mtime set one second on, so that the change
             * shows whatever the clock's grain */
            int fd = open(file, O_WRONLY);
            assert_true(fd >= 0);
            assert_int_equal(pwrite(fd, "\x55", 1, 200), 1);
            struct timespec ts[2] = {{0, UTIME_OMIT}, {was.st_mtim.tv_sec + 1, was.st_mtim.tv_nsec}};
            assert_int_equal(futimens(fd, ts), 0);
            close(fd);
        } else if (k == 1) {
            char cmd[1400];
            snprintf(cmd, sizeof cmd, "cp '%s' '%s' && mv '%s' '%s'", file, copy, copy, file);
            assert_int_equal(system(cmd), 0);
            assert_int_not_equal(stat_of(p1, "b.npy").st_ino, was.st_ino);
        } else if (k == 2) {
            assert_int_equal(truncate(file, 100), 0);
        } else {
            assert_int_equal(unlink(file), 0);
        }
        if (k == 1 || k == 2) {
            /* the old mtime back (touch -r): each change is seen by the one attribute it alters */
            struct timespec ts[2] = {{0, UTIME_OMIT}, was.st_mtim};
            assert_int_equal(utimensat(AT_FDCWD, file, ts, 0), 0);
        }
        write_shared(p2, t, 1, 2);
        if (k != 3 && same_file(p1, "b.npy", p2, "b.npy"))
            fail_msg("%s: a changed file was linked to", how[k]);
        assert_int_equal(stat_of(p2, "b.npy").st_nlink, 1);
        assert_true(same_file(p1, "a.npy", p2, "a.npy")); /* control: the unchanged file is linked */
        assert_bundle_reads(p2);
        write_shared(p3, t, 1, 2); /* links to p2's copy, now the registered one */
        assert_true(same_file(p2, "b.npy", p3, "b.npy"));
        assert_bundle_reads(p3);
        rto_bundle_share_destroy(t);
    }
}

/* A link that fails (here across file systems: EXDEV) writes the file instead; the bundle is complete. */
static void test_share_falls_back_to_writing(void **state)
{
    (void)state;
    char other[64] = "/dev/shm/rto_share_XXXXXX", p1[300], p2[300];
    struct stat a, b;
    if (!mkdtemp(other))
        skip();
    if (stat(other, &a) != 0 || stat(root, &b) != 0 || a.st_dev == b.st_dev) {
        tu_tmpdir_remove(other);
        skip(); /* one file system: no EXDEV to provoke */
    }
    snprintf(p1, sizeof p1, "%s/p1", other);
    snprintf(p2, sizeof p2, "%s/p2", root);
    rto_bundle_share *t = rto_bundle_share_create();
    write_shared(p1, t, 1, 2);
    write_shared(p2, t, 1, 2);
    rto_bundle_share_destroy(t);
    assert_int_equal(stat_of(p2, "a.npy").st_nlink, 2); /* its own a.npy and c.npy: one file */
    assert_int_equal(stat_of(p2, "b.npy").st_nlink, 1);
    diff_r(p1, p2, 1);
    assert_bundle_reads(p2);
    tu_tmpdir_remove(other);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_utf8_repair),
        cmocka_unit_test_setup_teardown(test_manifest_encodes_what_json_cannot_hold, setup, teardown),
        cmocka_unit_test_setup_teardown(test_setter_failure_fails_commit, setup, teardown),
        cmocka_unit_test_setup_teardown(test_every_jansson_failure_is_an_error, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replaces_only_its_own_bundles, setup, teardown),
        cmocka_unit_test_setup_teardown(test_temporaries_remove, setup, teardown),
        cmocka_unit_test_setup_teardown(test_file_write, setup, teardown),
        cmocka_unit_test_setup_teardown(test_commit_abort_and_replace, setup, teardown),
        cmocka_unit_test_setup_teardown(test_refuses_foreign_directory_and_versions, setup, teardown),
        cmocka_unit_test_setup_teardown(test_reader_refuses_special_files, setup, teardown),
        cmocka_unit_test_setup_teardown(test_same_input_same_bytes, setup, teardown),
        cmocka_unit_test_setup_teardown(test_share_links_identical_arrays, setup, teardown),
        cmocka_unit_test_setup_teardown(test_share_skips_changed_files, setup, teardown),
        cmocka_unit_test_setup_teardown(test_share_falls_back_to_writing, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
