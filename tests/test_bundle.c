/* Bundles: atomic replacement, refusal to clobber, sha256 verification, version refusal, determinism. */
#include "testutil.h"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

static char root[256];

static int setup(void **state)
{
    (void)state;
    snprintf(root, sizeof root, "/tmp/rto_bundle_XXXXXX");
    return mkdtemp(root) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", root);
    return system(cmd) == 0 ? 0 : -1;
}

static size_t entries(const char *dir)
{
    DIR *d = opendir(dir);
    size_t n = 0;
    for (struct dirent *e; d && (e = readdir(d));)
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    if (d)
        closedir(d);
    return n;
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
    assert_int_equal(entries(root), 1); /* only the temporary directory */
    rto_bundle_abort(b);
    assert_int_equal(entries(root), 0);

    write_bundle(dir, 1);
    assert_int_equal(entries(root), 1);
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
    assert_int_equal(entries(root), 1);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_commit_abort_and_replace, setup, teardown),
        cmocka_unit_test_setup_teardown(test_refuses_foreign_directory_and_versions, setup, teardown),
        cmocka_unit_test_setup_teardown(test_same_input_same_bytes, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
