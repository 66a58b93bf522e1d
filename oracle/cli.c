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
            if (json_dump_file(report, tmp, JSON_INDENT(2)) == 0 && rename(tmp, path) == 0)
                fprintf(stderr, "rtoracle %s: report written to %s\n", command, path);
            else
                remove(tmp);
        }
    }
    free(path);
    free(tmp);
}
