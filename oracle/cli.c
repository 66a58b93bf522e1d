/* Shared plumbing of the rtoracle command. */
#include "cli.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
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

int cli_status(const char *cmd, rto_status s, const rto_msg *msg)
{
    if (s == RTO_OK)
        return EXIT_PASS;
    if (s == RTO_ERR_MISMATCH)
        return EXIT_MISMATCH;
    return cli_fail(cmd, "%s", msg && msg->text[0] ? msg->text : rto_status_string(s));
}

rto_status cli_error(rto_msg *m, rto_status s, const char *fmt, ...)
{
    if (m) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(m->text, sizeof m->text, fmt, ap);
        va_end(ap);
    }
    return s;
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

json_t *cli_json_string(const char *text)
{
    size_t len = rto_utf8_repair(text, NULL, 0);
    char *buf = malloc(len + 1);
    if (!buf)
        return NULL;
    rto_utf8_repair(text, buf, len + 1);
    json_t *v = json_stringn(buf, len);
    free(buf);
    return v;
}

json_t *cli_json_real(double v)
{
    if (isnan(v))
        return json_string("nan");
    if (isinf(v))
        return json_string(v > 0 ? "inf" : "-inf");
    return json_real(v);
}

/* The text buffer of cli_json_text: once an append fails, all later ones fail. jansson's dump does not check its
 * callback's result while writing an object's key (dump.c, do_dump), so json_dumps can return text with a key cut
 * short after one failed allocation; a sticky failure makes the next write report it, and the flag is checked. */
typedef struct text_buffer {
    char *text;
    size_t len, cap;
    bool failed;
} text_buffer;

static int text_append(const char *chunk, size_t n, void *data)
{
    text_buffer *t = data;
    if (!t->failed && n >= t->cap - t->len) {
        size_t cap = t->cap ? t->cap : 4096;
        while (cap - t->len <= n && cap < SIZE_MAX / 2)
            cap *= 2;
        char *p = cap - t->len > n ? realloc(t->text, cap) : NULL;
        if (p) {
            t->text = p;
            t->cap = cap;
        } else {
            t->failed = true;
        }
    }
    if (t->failed)
        return -1;
    memcpy(t->text + t->len, chunk, n);
    t->len += n;
    t->text[t->len] = '\0';
    return 0;
}

char *cli_json_text(const json_t *root)
{
    text_buffer t = {NULL, 0, 0, false};
    if (!root || json_dump_callback(root, text_append, &t, JSON_INDENT(2)) != 0 || t.failed ||
        text_append("\n", 1, &t) != 0) {
        free(t.text);
        return NULL;
    }
    return t.text;
}

int cli_json_print(const json_t *root)
{
    char *text = cli_json_text(root);
    if (!text)
        return 0;
    /* All or nothing from here: the text is complete before the first byte goes out, and a failed write (a full
     * disk, a closed pipe) is reported rather than taken for success. */
    errno = 0;
    int ok = fputs(text, stdout) >= 0 && fflush(stdout) == 0;
    free(text);
    return ok;
}

int cli_write_report(const char *gpu_path, const char *command, const json_t *report)
{
    /* The report goes next to the user's dump: atomically, and never over anything but a regular file
     * (rto_file_write). A report that could not be built or serialised is an error, not a silent omission. */
    size_t len = strlen(gpu_path) + strlen(command) + 16;
    char *path = malloc(len);
    char *text = cli_json_text(report);
    int rc = EXIT_PASS;
    if (!path || !text) {
        rc = cli_fail(command, "cannot write the report next to %s: out of memory", gpu_path);
    } else {
        snprintf(path, len, "%s.%s.json", gpu_path, command);
        rto_msg msg = {{0}};
        rto_status s = rto_file_write(path, text, strlen(text), &msg);
        if (s)
            rc = cli_fail(command, "cannot write the report: %s", msg.text);
        else
            fprintf(stderr, "rtoracle %s: report written to %s\n", command, path);
    }
    free(path);
    free(text);
    return rc;
}

/* SIGINT / SIGTERM / SIGHUP: remove the temporaries of the outputs being written, then die of the same signal, so
 * the caller sees the usual status (130, 143, ...) and no OUT.tmp.* is left. Only async-signal-safe calls here. */
static void on_stop_signal(int sig)
{
    rto_temporaries_remove();
    signal(sig, SIG_DFL);
    raise(sig); /* pending until the handler returns, then the default action ends the process */
}

void cli_cleanup_on_signals(void)
{
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
