/* JSON values and text that never come out silently wrong: see json.h. */
#include "core/json.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

json_t *rto__json_string(const char *text)
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

json_t *rto__json_real(double value)
{
    if (isnan(value))
        return json_string("nan");
    if (isinf(value))
        return json_string(value > 0 ? "inf" : "-inf");
    return json_real(value);
}

/* The output buffer of rto__json_text: once an append fails, every later one fails too. jansson's dump ignores its
 * output callback's failure while writing an object's key (dump.c, do_dump: the result of dump_string for a key is
 * not checked, 2.14 and later alike), so json_dumps can return text with a key cut off after one failed allocation.
 * With a sticky failure jansson's next write reports it, and the flag is checked anyway. */
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

char *rto__json_text(const json_t *j, size_t flags)
{
    text_buffer t = {NULL, 0, 0, false};
    if (!j || json_dump_callback(j, text_append, &t, flags) != 0 || t.failed || text_append("\n", 1, &t) != 0) {
        free(t.text);
        return NULL;
    }
    return t.text;
}
