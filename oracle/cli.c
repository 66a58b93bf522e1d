/* Shared plumbing of the rtoracle command. */
#include "cli.h"

#include <stdint.h>
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
            if (json_dump_file(report, tmp, JSON_INDENT(2)) == 0 && rename(tmp, path) == 0)
                fprintf(stderr, "rtoracle %s: report written to %s\n", command, path);
            else
                remove(tmp);
        }
    }
    free(path);
    free(tmp);
}
