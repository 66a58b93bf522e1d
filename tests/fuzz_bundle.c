/* libFuzzer targets for what a GPU harness hands rtoracle: a trace bundle and GPU hit dump through `check-hits`
 * (fuzz_check_hits), and a frame bundle and GPU frame dump through `check-frame` (fuzz_check_frame; FUZZ_FRAME).
 * Built with the command-line sources (build: meson setup -Dfuzz=true with clang; README "Fuzzing").
 *
 * At start-up a small bundle is written with the command itself (`trace rtstress:2`, `render rtstress:2`) into a
 * private directory, and the GPU dump is a copy of its answers. An input is one byte choosing a file — of the bundle
 * (manifest.json included) or of the GPU dump — and that file's new bytes. A bundle file gets its sha256 rewritten in
 * the manifest, as a careless harness would, so the input reaches the readers and validators behind the checksum. The
 * command then runs as `rtoracle check-* --expected BUNDLE --gpu DUMP`, and the files are put back.
 *
 * Beyond "no crash, no leak, no hang, no huge allocation": the exit status is 0, 1 or 2, and a refusal (2) is one
 * line on stderr. Run with -close_fd_mask=1 (the reports go to stdout); stderr is checked through a pipe.
 *
 * RTO_FUZZ_SEEDS=DIR writes the seed corpus (each file as it is, behind its selector byte) to DIR and exits. */
#include "cli.h"

#include <dirent.h>
#include <fcntl.h>
#include <jansson.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#ifdef FUZZ_FRAME
#define FUZZ_NAME "fuzz_check_frame"
#define FUZZ_COMMAND "check-frame"
#define FUZZ_CHECK cmd_check_frame
#define FUZZ_MAKE cmd_render
#else
#define FUZZ_NAME "fuzz_check_hits"
#define FUZZ_COMMAND "check-hits"
#define FUZZ_CHECK cmd_check_hits
#define FUZZ_MAKE cmd_trace
#endif

#define MAX_FILES 64

typedef struct {
    char path[192];
    unsigned char *bytes; /* the original content */
    size_t len;
    int in_bundle; /* its sha256 is in the bundle's manifest */
} fuzz_file;

static char root[64], bundle[96], gpu[96], gpu_arg[128], manifest[128];
static fuzz_file files[MAX_FILES];
static size_t nfiles;
static unsigned char *manifest_bytes;
static size_t manifest_len;

static void check(int cond, const char *what)
{
    if (!cond) {
        fprintf(stderr, FUZZ_NAME " invariant violated: %s\n", what);
        abort();
    }
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    check(fp != NULL, "open a seed file");
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *b = malloc(n > 0 ? (size_t)n : 1);
    check(b && n >= 0 && fread(b, 1, (size_t)n, fp) == (size_t)n, "read a seed file");
    fclose(fp);
    *len = (size_t)n;
    return b;
}

static void spill(const char *path, const void *data, size_t len)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    check(fd >= 0, "open a file to write");
    for (size_t at = 0; at < len;) {
        ssize_t n = write(fd, (const char *)data + at, len - at);
        check(n > 0, "write a file");
        at += (size_t)n;
    }
    check(close(fd) == 0, "close a written file");
}

static void remove_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[512];
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
            snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
            unlink(p);
        }
    closedir(d);
    rmdir(dir);
}

static void cleanup(void)
{
    remove_dir(bundle);
    remove_dir(gpu);
    rmdir(root);
}

/* Every regular file of dir, in name order (so a selector byte means the same file every run). */
static void collect(const char *dir, int in_bundle)
{
    struct dirent **list;
    int n = scandir(dir, &list, NULL, alphasort);
    check(n >= 0, "list a seed directory");
    for (int i = 0; i < n; i++) {
        if (list[i]->d_name[0] != '.' && nfiles < MAX_FILES) {
            fuzz_file *f = &files[nfiles++];
            snprintf(f->path, sizeof f->path, "%s/%s", dir, list[i]->d_name);
            f->bytes = slurp(f->path, &f->len);
            f->in_bundle = in_bundle && strcmp(list[i]->d_name, "manifest.json") != 0;
        }
        free(list[i]);
    }
    free(list);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    snprintf(root, sizeof root, "/tmp/" FUZZ_NAME ".XXXXXX");
    check(mkdtemp(root) != NULL, "make the private directory");
    snprintf(bundle, sizeof bundle, "%s/e", root);
    snprintf(gpu, sizeof gpu, "%s/g", root);
    snprintf(manifest, sizeof manifest, "%s/manifest.json", bundle);
    atexit(cleanup);
#ifdef FUZZ_FRAME
    char *make[] = {"render", "rtstress:2", "--program", "sun-shadow", "--width", "8", "--height", "6", "--no-timings",
                    "-o", bundle, NULL};
    snprintf(gpu_arg, sizeof gpu_arg, "%s", gpu);
#else
    char *make[] = {"trace", "rtstress:2", "--rays", "random", "--count", "64", "-o", bundle, NULL};
    snprintf(gpu_arg, sizeof gpu_arg, "%s/hits.npy", gpu);
#endif
    check(FUZZ_MAKE((int)(sizeof make / sizeof make[0]) - 1, make) == 0, "write the seed bundle");
    /* The GPU dump: the bundle's own answers (a passing dump). */
    check(mkdir(gpu, 0755) == 0, "make the dump directory");
    DIR *d = opendir(bundle);
    check(d != NULL, "open the seed bundle");
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
#ifndef FUZZ_FRAME
        if (strcmp(e->d_name, "hits.npy"))
            continue;
#endif
        char from[512], to[512];
        snprintf(from, sizeof from, "%s/%s", bundle, e->d_name);
        snprintf(to, sizeof to, "%s/%s", gpu, e->d_name);
        size_t len;
        unsigned char *b = slurp(from, &len);
        spill(to, b, len);
        free(b);
    }
    closedir(d);
    collect(bundle, 1);
    collect(gpu, 0);
    manifest_bytes = slurp(manifest, &manifest_len);

    const char *seeds = getenv("RTO_FUZZ_SEEDS");
    if (seeds) {
        mkdir(seeds, 0755);
        for (size_t i = 0; i < nfiles; i++) {
            char p[512];
            snprintf(p, sizeof p, "%s/seed-%02zu", seeds, i);
            unsigned char *b = malloc(files[i].len + 1);
            check(b != NULL, "malloc");
            b[0] = (unsigned char)i;
            memcpy(b + 1, files[i].bytes, files[i].len);
            spill(p, b, files[i].len + 1);
            free(b);
        }
        fprintf(stderr, FUZZ_NAME ": %zu seeds written to %s\n", nfiles, seeds);
        exit(0);
    }
    return 0;
}

/* The manifest with the sha256 of the bundle file f (now holding data) rewritten. */
static void rewrite_sha(const fuzz_file *f)
{
    char hex[65];
    rto_msg msg = {{0}};
    check(rto_sha256_file(f->path, hex, &msg) == RTO_OK, "sha256 of the edited file");
    json_t *m = json_loadb((const char *)manifest_bytes, manifest_len, 0, NULL);
    check(m != NULL, "parse the seed manifest");
    const char *name = strrchr(f->path, '/') + 1;
    size_t i;
    json_t *e;
    json_array_foreach(json_object_get(m, "files"), i, e)
    {
        if (!strcmp(json_string_value(json_object_get(e, "name")), name))
            json_object_set_new(e, "sha256", json_string(hex));
    }
    check(json_dump_file(m, manifest, JSON_INDENT(2)) == 0, "write the manifest");
    json_decref(m);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || nfiles == 0)
        return 0;
    fuzz_file *f = &files[data[0] % nfiles];
    spill(f->path, data + 1, size - 1);
    if (f->in_bundle)
        rewrite_sha(f);

    /* stderr through a pipe, to count its lines (a refusal is one line; the pipe holds far more than one). */
    int pipefd[2], saved = dup(2);
    check(saved >= 0 && pipe(pipefd) == 0, "pipe");
    fcntl(pipefd[0], F_SETFL, O_NONBLOCK);
    fflush(stderr);
    dup2(pipefd[1], 2);
    close(pipefd[1]);
    char *argv[] = {FUZZ_COMMAND, "--expected", bundle, "--gpu", gpu_arg, "--no-artifacts", NULL};
    int rc = FUZZ_CHECK((int)(sizeof argv / sizeof argv[0]) - 1, argv);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    char err[4096];
    ssize_t n = read(pipefd[0], err, sizeof err - 1);
    close(pipefd[0]);
    err[n > 0 ? n : 0] = '\0';

    check(rc == 0 || rc == 1 || rc == 2, "exit status 0, 1 or 2");
    if (rc == 2) {
        char *nl = strchr(err, '\n');
        check(n > 0 && nl && nl[1] == '\0', "a refusal is one line on stderr");
        check(strncmp(err, "rtoracle " FUZZ_COMMAND ": ", strlen("rtoracle " FUZZ_COMMAND ": ")) == 0,
              "a refusal names the command");
    }

    spill(f->path, f->bytes, f->len);
    if (f->in_bundle)
        spill(manifest, manifest_bytes, manifest_len);
    return 0;
}
