/* Shared plumbing of the rtoracle command. */
#include "cli.h"

#include <errno.h>
#include <jansson.h>
#include <stdarg.h>
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

bool cli_parse_u64(const char *text, uint64_t max, uint64_t *out)
{
    if (!text || !*text || *text == '-' || *text == '+' || *text == ' ')
        return false;
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 0);
    if (errno || !end || *end || v > max)
        return false;
    *out = v;
    return true;
}

bool cli_parse_format(const char *text, rto_key_format *f)
{
    if (text && !strcmp(text, "u32"))
        *f = RTO_KEY_U32;
    else if (text && !strcmp(text, "u64"))
        *f = RTO_KEY_U64;
    else
        return false;
    return true;
}

bool cli_parse_algo(const char *text, rto_sort_algo *a)
{
    if (text && !strcmp(text, "bitonic"))
        *a = RTO_SORT_BITONIC;
    else if (text && !strcmp(text, "radix"))
        *a = RTO_SORT_RADIX;
    else
        return false;
    return true;
}

void cli_write_report(const char *gpu_path, const char *command, const json_t *report)
{
    size_t len = strlen(gpu_path) + strlen(command) + 16;
    char *path = malloc(len), *tmp = malloc(len + 16);
    if (path && tmp) {
        snprintf(path, len, "%s.%s.json", gpu_path, command);
        snprintf(tmp, len + 16, "%s.tmp.XXXXXX", path);
        int fd = mkstemp(tmp);
        if (fd >= 0) {
            close(fd);
            if (json_dump_file(report, tmp, JSON_INDENT(2) | JSON_REAL_PRECISION(9)) == 0 && rename(tmp, path) == 0)
                fprintf(stderr, "rtoracle %s: report written to %s\n", command, path);
            else
                remove(tmp);
        }
    }
    free(path);
    free(tmp);
}

/* Renders a report with one of the library's writers into a fresh buffer sized by a first call. */
static char *render(const rto_report *r, int json)
{
    size_t len = 0;
    rto_status s = json ? rto_report_json(r, NULL, 0, &len, NULL) : rto_report_text(r, NULL, 0, &len);
    char *text = s == RTO_ERR_BUFFER_TOO_SMALL ? malloc(len + 1) : NULL;
    if (text && (json ? rto_report_json(r, text, len + 1, &len, NULL) : rto_report_text(r, text, len + 1, &len))) {
        free(text);
        text = NULL;
    }
    return text;
}

int cli_report(const char *cmd, const rto_report *r, bool json, bool artifacts, const char *gpu_path)
{
    const int passed = rto_report_passed(r);
    char *out = render(r, json), *jtext = json ? out : render(r, 1);
    int rc = passed ? EXIT_PASS : EXIT_MISMATCH;
    if (!out || !jtext) {
        rc = cli_fail(cmd, "out of memory writing the report");
    } else if (fputs(out, stdout) < 0 || (json && fputc('\n', stdout) == EOF) || fflush(stdout) != 0) {
        /* a verdict that did not reach its reader is no verdict */
        rc = cli_fail(cmd, "cannot write the report to stdout");
    } else if (!passed && artifacts) {
        json_t *j = json_loads(jtext, 0, NULL);
        if (j)
            cli_write_report(gpu_path, cmd, j);
        else
            rc = cli_fail(cmd, "out of memory writing the report");
        json_decref(j);
    }
    if (jtext != out)
        free(jtext);
    free(out);
    return rc;
}

bool cli_npy_same(const rto_npy_desc *have, const rto_npy_desc *want)
{
    if (have->dtype != want->dtype || have->ndim != want->ndim)
        return false;
    for (uint32_t i = 0; i < want->ndim && i < RTO_NPY_MAX_DIMS; i++)
        if (have->shape[i] != want->shape[i])
            return false;
    if (want->dtype != RTO_DTYPE_STRUCT)
        return true;
    if (have->nfields != want->nfields)
        return false;
    for (uint32_t i = 0; i < want->nfields && i < RTO_NPY_MAX_FIELDS; i++) {
        const rto_npy_field *a = &have->fields[i], *b = &want->fields[i];
        if (a->type != b->type || a->count != b->count || a->offset != b->offset || strcmp(a->name, b->name))
            return false;
    }
    return true;
}

const char *cli_npy_what(const rto_npy_desc *d, const char *layout, char *buf, size_t cap)
{
    char descr[256];
    int used;
    if (d->dtype == RTO_DTYPE_STRUCT && layout) /* a struct's full descr would fill the line */
        used = snprintf(buf, cap, "%s records, shape (", layout);
    else if (d->dtype == RTO_DTYPE_STRUCT)
        used = snprintf(buf, cap, "%zu-byte records, shape (", rto_npy_itemsize(d));
    else
        used = snprintf(buf, cap, "dtype %s, shape (", rto_npy_descr(d, descr, sizeof descr) ? "?" : descr);
    for (uint32_t i = 0; used >= 0 && (size_t)used < cap && i < d->ndim && i < RTO_NPY_MAX_DIMS; i++)
        used += snprintf(buf + used, cap - (size_t)used, "%s%llu%s", i ? " " : "", (unsigned long long)d->shape[i],
                         d->ndim == 1 || i + 1 < d->ndim ? "," : "");
    if (used >= 0 && (size_t)used < cap)
        snprintf(buf + used, cap - (size_t)used, ")");
    return buf;
}
