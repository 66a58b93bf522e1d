/* Shared plumbing of the rtoracle command. */
#include "cli.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <jansson.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int cli_fail(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "rtoracle %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return EXIT_BAD_INPUT;
}

bool cli_within_budget(const char *cmd, uint64_t need, uint64_t budget_mb, const char *what)
{
    const uint64_t budget = budget_mb ? budget_mb << 20 : rto_memory_budget_default();
    if (!budget || need <= budget)
        return true;
    const double gib = 1.0 / (double)(UINT64_C(1) << 30);
    cli_fail(cmd, "%s may hold up to %.2f GiB at once, over the memory budget of %.2f GiB (%s)", what,
             (double)need * gib, (double)budget * gib,
             budget_mb ? "--memory-budget" : "half the memory this process may use; --memory-budget MiB changes it");
    return false;
}

int cli_status(const char *cmd, rto_status s, const rto_msg *msg)
{
    if (s == RTO_OK)
        return EXIT_PASS;
    if (s == RTO_ERR_MISMATCH)
        return EXIT_MISMATCH;
    return cli_fail(cmd, "%s", msg && msg->text[0] ? msg->text : rto_status_string(s));
}

void *cli_alloc(size_t count, size_t size)
{
    if (size != 0 && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    return malloc(bytes ? bytes : 1);
}

const opt_name cli_format_names[] = {{"u32", RTO_KEY_U32}, {"u64", RTO_KEY_U64}, {NULL, 0}};
const opt_name cli_algo_names[] = {{"bitonic", RTO_SORT_BITONIC}, {"radix", RTO_SORT_RADIX}, {NULL, 0}};
const opt_name cli_radix_bits_names[] = {{"4", 4}, {"8", 8}, {NULL, 0}};

static bool lookup(const opt_name *names, const char *text, int *value)
{
    for (; text && names->name; names++)
        if (!strcmp(names->name, text)) {
            *value = names->value;
            return true;
        }
    return false;
}

bool cli_parse_format(const char *text, rto_key_format *f)
{
    int v;
    if (!lookup(cli_format_names, text, &v))
        return false;
    *f = (rto_key_format)v;
    return true;
}

bool cli_parse_algo(const char *text, rto_sort_algo *a)
{
    int v;
    if (!lookup(cli_algo_names, text, &v))
        return false;
    *a = (rto_sort_algo)v;
    return true;
}

int cli_write_report_at(const char *path, const char *command, const char *text)
{
    /* The report goes next to the user's dump: atomically, and never over anything but a regular file
     * (rto_file_write). A report that could not be built or serialised is an error, not a silent omission. */
    if (!path || !text)
        return cli_fail(command, "cannot write the report: out of memory");
    rto_msg msg = {{0}};
    /* Next to a dump that lies in a bundle (a bundle's own array checked against itself), the report would make the
     * bundle one that no writer may replace: it is left out, with a note. */
    if (rto_output_check(path, 0, NULL, 0, &msg)) {
        fprintf(stderr, "rtoracle %s: report not written: %s\n", command, msg.text);
        return EXIT_PASS;
    }
    rto_status s = rto_file_write(path, text, strlen(text), &msg);
    if (s)
        return cli_fail(command, "cannot write the report: %s", msg.text);
    fprintf(stderr, "rtoracle %s: report written to %s\n", command, path);
    return EXIT_PASS;
}

int cli_write_report(const char *gpu_path, const char *command, const char *text)
{
    size_t len = strlen(gpu_path) + strlen(command) + 16;
    char *path = malloc(len);
    if (path)
        snprintf(path, len, "%s.%s.json", gpu_path, command);
    int rc = path ? cli_write_report_at(path, command, text)
                  : cli_fail(command, "cannot write the report next to %s: out of memory", gpu_path);
    free(path);
    return rc;
}

/* SIGINT / SIGTERM / SIGHUP, on whichever thread takes it: remove the temporaries of the outputs being written, then
 * die of the same signal, so the caller sees the usual status (130, 143, ...) and no OUT.tmp.* is left; a swap into
 * place under way finishes first (rto_stop_signal). */
static void on_stop_signal(int sig) { rto_stop_signal(sig); }

void cli_cleanup_on_signals(void)
{
    /* A command that meets an error because a stop on another thread removed its temporary does not exit with that
     * error's status: it waits for the stop to end the process. */
    atexit(rto_stop_settle);
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++) {
        struct sigaction old, sa;
        /* A signal ignored by whoever started us (nohup, a background job without job control) stays ignored. */
        if (sigaction(sigs[i], NULL, &old) != 0 || old.sa_handler == SIG_IGN)
            continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_stop_signal;
        sigfillset(&sa.sa_mask);
        sigaction(sigs[i], &sa, NULL);
    }
}

/* Renders a report with one of the library's writers into a fresh buffer sized by a first call, with a final
 * newline. */
static char *render(const rto_report *r, int json)
{
    size_t len = 0;
    rto_status s = json ? rto_report_json(r, NULL, 0, &len, NULL) : rto_report_text(r, NULL, 0, &len);
    char *text = s == RTO_ERR_BUFFER_TOO_SMALL ? malloc(len + 2) : NULL;
    if (text && (json ? rto_report_json(r, text, len + 1, &len, NULL) : rto_report_text(r, text, len + 1, &len))) {
        free(text);
        return NULL;
    }
    if (text && (!len || text[len - 1] != '\n'))
        memcpy(text + len, "\n", 2);
    return text;
}

/* Prints the report and, for a failure, writes its JSON with write(path_arg) when path_arg is not NULL. */
static int report_out(const char *cmd, const rto_report *r, bool json, const char *path_arg,
                      int (*write)(const char *, const char *, const char *))
{
    const int passed = rto_report_passed(r);
    char *out = render(r, json), *jtext = json ? out : render(r, 1);
    int rc = passed ? EXIT_PASS : EXIT_MISMATCH;
    if (!out || !jtext) {
        rc = cli_fail(cmd, "out of memory writing the report");
    } else if (fputs(out, stdout) < 0 || fflush(stdout) != 0) {
        /* a verdict that did not reach its reader is no verdict */
        rc = cli_fail(cmd, "cannot write the report to stdout");
    } else if (!passed && path_arg) {
        /* the very text --json prints, so the file and stdout agree digit for digit */
        int wrote = write(path_arg, cmd, jtext);
        rc = wrote != EXIT_PASS ? wrote : rc;
    }
    if (jtext != out)
        free(jtext);
    free(out);
    return rc;
}

int cli_report(const char *cmd, const rto_report *r, bool json, bool artifacts, const char *gpu_path)
{
    return report_out(cmd, r, json, artifacts ? gpu_path : NULL, cli_write_report);
}

int cli_report_at(const char *cmd, const rto_report *r, bool json, const char *report_path)
{
    return report_out(cmd, r, json, report_path, cli_write_report_at);
}

json_t *cli_json_text(const char *text)
{
    size_t need = rto_utf8_repair(text, NULL, 0);
    char *buf = malloc(need + 1);
    if (!buf)
        return NULL;
    rto_utf8_repair(text, buf, need + 1);
    json_t *s = json_string(buf);
    free(buf);
    return s;
}

const char *cli_dir_summary(const char *dir, char *buf, size_t cap)
{
    DIR *d = opendir(dir);
    unsigned long long files = 0, bytes = 0;
    for (struct dirent *e = d ? readdir(d) : NULL; e; e = readdir(d)) {
        struct stat st;
        if (fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode)) {
            files++;
            bytes += (unsigned long long)st.st_size;
        }
    }
    if (d)
        closedir(d);
    snprintf(buf, cap, "%llu file%s, %.1f MiB", files, files == 1 ? "" : "s", (double)bytes / (1024.0 * 1024.0));
    return buf;
}

int cli_up_to_date(const char *cmd, const char *out, const char *request, bool force)
{
    if (force || !request)
        return 0;
    rto_msg why = {{0}};
    rto_bundle_state st = rto_bundle_check(out, request, &why);
    if (st == RTO_BUNDLE_CURRENT) {
        printf("%s: %s is up to date (same inputs, options and rtoracle build); not rewritten\n", cmd, out);
        fflush(stdout);
        return 1;
    }
    if (st == RTO_BUNDLE_CHANGED)
        fprintf(stderr, "rtoracle %s: %s: %s; writing it again\n", cmd, out, why.text);
    return 0;
}

rto_status cli_set_request(rto_bundle *b, const char *request, const rto_scene *sc, const char *extra, rto_msg *msg)
{
    if (!request)
        return RTO_OK; /* out of memory composing it: the bundle goes unstamped */
    const size_t n = (sc ? sc->source_count : 0) + (extra ? 1 : 0);
    const char **src = cli_alloc(n, sizeof *src);
    if (!src)
        return rto_msg_set(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    size_t k = 0;
    for (uint32_t i = 0; sc && i < sc->source_count; i++)
        src[k++] = sc->sources[i];
    if (extra)
        src[k++] = extra;
    rto_status s = rto_bundle_set_request(b, request, src, k, msg);
    free(src);
    return s;
}

rto_status sort_bundle_write(const char *outdir, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                             const key_origin *origin, rto_bundle_share *share, rto_msg *msg)
{
    const rto_sort_bundle_desc d = {f, keys, n, p->algo, p->radix_bits, p->tile, p->checkpoints,
                                    origin->case_id, origin->dist, origin->seed, origin->file};
    rto_bundle *b = NULL;
    rto_status s = rto_bundle_begin(outdir, "sort", &b, msg);
    if (s)
        return s;
    rto_bundle_set_share(b, share);
    if (origin->request) {
        const char *src[1] = {origin->file};
        s = rto_bundle_set_request(b, origin->request, src, origin->file ? 1 : 0, msg);
    }
    if (!s)
        s = rto_sort_bundle_write(&d, b, msg);
    if (s) {
        rto_bundle_abort(b);
        return s;
    }
    return rto_bundle_commit(b, msg);
}
