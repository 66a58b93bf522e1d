/* The option parser of every rtoracle command (see opts.h). */
#include "opts.h"

#include <assert.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* Bad usage: exit status 2, as every command's. */
#define OPTS_BAD_USAGE 2

/* Column of the help text in --help, and the width it wraps at. */
#define HELP_COLUMN 24
#define HELP_WIDTH 118

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static int usage_error(const opt_command *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "rtoracle %s: ", c->name);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, " (rtoracle %s --help)\n", c->name);
    va_end(ap);
    return OPTS_BAD_USAGE;
}

/* Same shape without the pointer to --help, for a value the user gave: the message says what is accepted. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static int value_error(const opt_command *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "rtoracle %s: ", c->name);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return OPTS_BAD_USAGE;
}

bool opts_parse_uint(const char *text, uint64_t max, uint64_t *out)
{
    if (!text)
        return false;
    const char *p = text;
    unsigned base = 10;
    /* Hexadecimal only with an explicit prefix; a leading zero is never octal ("010" is ten, as a user means). */
    if (p[0] == '0' && (p[1] == 'x' || p[1] == 'X')) {
        base = 16;
        p += 2;
    }
    if (!*p)
        return false;
    uint64_t v = 0;
    for (; *p; p++) {
        unsigned d;
        if (*p >= '0' && *p <= '9')
            d = (unsigned)(*p - '0');
        else if (base == 16 && *p >= 'a' && *p <= 'f')
            d = (unsigned)(*p - 'a' + 10);
        else if (base == 16 && *p >= 'A' && *p <= 'F')
            d = (unsigned)(*p - 'A' + 10);
        else
            return false;
        if (v > (UINT64_MAX - d) / base)
            return false;
        v = v * base + d;
    }
    if (v > max)
        return false;
    *out = v;
    return true;
}

bool opts_parse_real(const char *text, double *out)
{
    if (!text)
        return false;
    /* The shape is checked first: strtod alone would take a sign, leading space, "inf", "nan" and hex floats. */
    const char *p = text;
    size_t digits = strspn(p, "0123456789");
    p += digits;
    if (*p == '.') {
        size_t frac = strspn(p + 1, "0123456789");
        digits += frac;
        p += 1 + frac;
    }
    if (!digits)
        return false;
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-')
            p++;
        size_t exp = strspn(p, "0123456789");
        if (!exp)
            return false;
        p += exp;
    }
    if (*p)
        return false;
    errno = 0;
    char *end = NULL;
    double v = strtod(text, &end);
    if (*end || !isfinite(v) || (errno == ERANGE && v != 0))
        return false;
    *out = v;
    return true;
}

static const opt_name *find_name(const opt_name *names, const char *text, size_t len)
{
    for (const opt_name *n = names; n->name; n++)
        if (strlen(n->name) == len && !strncmp(n->name, text, len))
            return n;
    return NULL;
}

/* "a or b", "a, b or c" into buf. */
static const char *names_text(const opt_name *names, char *buf, size_t cap)
{
    size_t count = 0, used = 0;
    while (names[count].name)
        count++;
    buf[0] = '\0';
    for (size_t i = 0; i < count && used < cap; i++) {
        const char *sep = i == 0 ? "" : i + 1 == count ? " or " : ", ";
        int w = snprintf(buf + used, cap - used, "%s%s", sep, names[i].name);
        if (w < 0)
            break;
        used += (size_t)w;
    }
    return buf;
}

/* Writes v into an unsigned integer (or enum) target of the spec's size; the table check made sure it fits. */
static void store_uint(const opt_spec *s, uint64_t v)
{
    switch (s->target_size) {
    case 1: { uint8_t x = (uint8_t)v; memcpy(s->target, &x, 1); break; }
    case 2: { uint16_t x = (uint16_t)v; memcpy(s->target, &x, 2); break; }
    case 4: { uint32_t x = (uint32_t)v; memcpy(s->target, &x, 4); break; }
    default: memcpy(s->target, &v, 8); break;
    }
}

static uint64_t size_max(size_t bytes)
{
    return bytes >= 8 ? UINT64_MAX : (UINT64_C(1) << (8 * bytes)) - 1;
}

/* A table that cannot hold what it promises is a programming error, caught on the first run of the command. */
static void check_table(const opt_command *c)
{
    size_t n = 0;
    for (const opt_spec *s = c->opts; s->name; s++, n++) {
        switch (s->kind) {
        case OPT_KIND_FLAG: assert(s->target_size == sizeof(bool)); break;
        case OPT_KIND_UINT:
            assert(s->target_size == 1 || s->target_size == 2 || s->target_size == 4 || s->target_size == 8);
            assert(s->min <= s->max && s->max <= size_max(s->target_size));
            for (const opt_name *m = s->names; m && m->name; m++)
                assert(m->value >= 0 && (uint64_t)m->value <= size_max(s->target_size));
            break;
        case OPT_KIND_ENUM:
            assert(s->names && (s->target_size == 1 || s->target_size == 2 || s->target_size == 4));
            for (const opt_name *m = s->names; m->name; m++)
                assert(m->value >= 0 && (uint64_t)m->value <= size_max(s->target_size));
            break;
        case OPT_KIND_PATH: assert(s->target_size == sizeof(const char *)); break;
        case OPT_KIND_LIST: assert(s->target_size == sizeof(opt_list)); break;
        case OPT_KIND_REAL: assert(s->target_size == sizeof(double)); break;
        }
    }
    assert(n <= OPT_MAX_SPECS && c->max_args <= OPT_MAX_ARGS && c->min_args <= c->max_args);
    (void)n;
    (void)size_max;
}

static int parse_list(const opt_command *c, const opt_spec *s, const char *v)
{
    opt_list *l = s->target;
    char what[256];
    size_t len = strlen(v);
    if (len >= sizeof l->buf)
        return value_error(c, "--%s: the list is longer than %zu characters", s->name, sizeof l->buf - 1);
    l->count = 0;
    memcpy(l->buf, v, len + 1);
    for (char *item = l->buf;;) {
        char *comma = strchr(item, ',');
        if (comma)
            *comma = '\0';
        if (!*item)
            return value_error(c, "--%s %s: empty item in the list", s->name, v);
        int value = 0;
        if (s->names) {
            const opt_name *n = find_name(s->names, item, strlen(item));
            if (!n)
                return value_error(c, "--%s %s: expected %s", s->name, item, names_text(s->names, what, sizeof what));
            value = n->value;
        }
        /* A repeated item would repeat work (suite cases): keep its first occurrence only. */
        bool dup = false;
        for (size_t i = 0; i < l->count && !dup; i++)
            dup = !strcmp(l->item[i], item);
        if (!dup) {
            if (l->count == OPT_LIST_MAX)
                return value_error(c, "--%s: more than %d items", s->name, OPT_LIST_MAX);
            l->item[l->count] = item;
            l->value[l->count++] = value;
        }
        if (!comma)
            break;
        item = comma + 1;
    }
    return -1;
}

/* Checks value v of option s and writes its target; -1 on success, else the exit status. */
static int take_value(const opt_command *c, const opt_spec *s, const char *v)
{
    char what[256];
    uint64_t x;
    switch (s->kind) {
    case OPT_KIND_UINT:
        if (s->names) {
            const opt_name *n = NULL;
            if (opts_parse_uint(v, UINT64_MAX, &x))
                for (n = s->names; n->name && (uint64_t)n->value != x; n++)
                    ;
            if (!n || !n->name)
                return value_error(c, "--%s %s: expected %s", s->name, *v ? v : "''",
                                   names_text(s->names, what, sizeof what));
            store_uint(s, x);
            return -1;
        }
        if (!opts_parse_uint(v, s->max, &x) || x < s->min)
            return value_error(c, "--%s %s: expected an integer %llu .. %llu", s->name, *v ? v : "''",
                               (unsigned long long)s->min, (unsigned long long)s->max);
        store_uint(s, x);
        return -1;
    case OPT_KIND_ENUM: {
        const opt_name *n = find_name(s->names, v, strlen(v));
        if (!n)
            return value_error(c, "--%s %s: expected %s", s->name, *v ? v : "''",
                               names_text(s->names, what, sizeof what));
        store_uint(s, (uint64_t)n->value);
        return -1;
    }
    case OPT_KIND_PATH:
        if (!*v)
            return value_error(c, "--%s '': expected a path", s->name);
        *(const char **)s->target = v;
        return -1;
    case OPT_KIND_LIST: return parse_list(c, s, v);
    case OPT_KIND_REAL: {
        double r = 0;
        if (!opts_parse_real(v, &r) || (s->max && r > (double)s->max)) {
            if (s->max)
                return value_error(c, "--%s %s: expected a number 0 .. %llu", s->name, *v ? v : "''",
                                   (unsigned long long)s->max);
            return value_error(c, "--%s %s: expected a number >= 0 (such as 0.004 or 1e-6)", s->name, *v ? v : "''");
        }
        *(double *)s->target = r;
        return -1;
    }
    case OPT_KIND_FLAG: break;
    }
    return -1;
}

int opts_parse(const opt_command *c, int argc, char **argv, opt_args *out)
{
    check_table(c);
    memset(out, 0, sizeof *out);
    bool only_args = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (only_args || a[0] != '-' || a[1] == '\0') {
            if (out->count == c->max_args)
                return usage_error(c, "unexpected argument '%s'", a);
            out->arg[out->count++] = a;
            continue;
        }
        if (!strcmp(a, "--")) {
            only_args = true;
            continue;
        }
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            opts_help(c, stdout);
            return 0;
        }
        /* Find the option: --name, --name=value, -x, -xvalue. */
        const opt_spec *s = NULL;
        const char *attached = NULL;
        char shown[64];
        if (a[1] == '-') {
            const char *eq = strchr(a + 2, '=');
            size_t len = eq ? (size_t)(eq - (a + 2)) : strlen(a + 2);
            for (const opt_spec *t = c->opts; t->name && !s; t++)
                if (strlen(t->name) == len && !strncmp(t->name, a + 2, len))
                    s = t;
            snprintf(shown, sizeof shown, "--%.*s", (int)(len < 48 ? len : 48), a + 2);
            if (eq)
                attached = eq + 1;
        } else {
            for (const opt_spec *t = c->opts; t->name && !s; t++)
                if (t->short_name && t->short_name == a[1])
                    s = t;
            snprintf(shown, sizeof shown, "-%c", a[1]);
            if (a[2])
                attached = a + 2;
        }
        if (!s)
            return usage_error(c, "unknown option '%s'", shown);
        out->given[s - c->opts] = true;
        if (s->kind == OPT_KIND_FLAG) {
            if (attached)
                return usage_error(c, "option '%s' takes no value", shown);
            *(bool *)s->target = true;
            continue;
        }
        const char *v = attached;
        /* The next argument is the value unless there is none or it is itself a long option: "-o --json" is
         * more likely a forgotten value than a directory named "--json" (write -o=--json or -o ./--json for that). */
        if (!v) {
            if (i + 1 >= argc || !strncmp(argv[i + 1], "--", 2))
                return usage_error(c, "option '%s' needs a value", shown);
            v = argv[++i];
        }
        int rc = take_value(c, s, v);
        if (rc >= 0)
            return rc;
    }
    if (out->count < c->min_args)
        return usage_error(c, "expected %s", c->args_name ? c->args_name : "more arguments");
    return -1;
}

bool opts_given(const opt_command *c, const opt_args *a, const char *name)
{
    for (size_t i = 0; c->opts[i].name; i++)
        if (!strcmp(c->opts[i].name, name))
            return a->given[i];
    assert(!"opts_given: no such option");
    return false;
}

int opts_require(const opt_command *c, const opt_args *a, const char *const *names)
{
    for (; *names; names++)
        if (!opts_given(c, a, *names))
            return usage_error(c, "--%s is required", *names);
    return 0;
}

/* Prints text from column `col` (already reached), wrapping at word boundaries to HELP_WIDTH. */
static void print_wrapped(FILE *to, const char *text, size_t col)
{
    size_t at = col;
    while (*text) {
        while (*text == ' ')
            text++;
        size_t w = strcspn(text, " ");
        if (!w)
            break;
        if (at > col && at + 1 + w > HELP_WIDTH) {
            fprintf(to, "\n%*s", (int)col, "");
            at = col;
        } else if (at > col) {
            fputc(' ', to);
            at++;
        }
        fwrite(text, 1, w, to);
        at += w;
        text += w;
    }
    fputc('\n', to);
}

static void help_line(FILE *to, const opt_spec *s)
{
    char left[96], line[768], what[256];
    if (s->short_name)
        snprintf(left, sizeof left, "  -%c, --%s%s%s", s->short_name, s->name, s->metavar ? " " : "",
                 s->metavar ? s->metavar : "");
    else
        snprintf(left, sizeof left, "  --%s%s%s", s->name, s->metavar ? " " : "", s->metavar ? s->metavar : "");
    size_t used = (size_t)snprintf(line, sizeof line, "%s", s->help);
    if (s->kind == OPT_KIND_UINT && !s->names)
        used += (size_t)snprintf(line + used, sizeof line - used, ": %llu .. %llu", (unsigned long long)s->min,
                                 (unsigned long long)s->max);
    else if (s->kind == OPT_KIND_ENUM || s->kind == OPT_KIND_UINT)
        used += (size_t)snprintf(line + used, sizeof line - used, ": %s", names_text(s->names, what, sizeof what));
    else if (s->kind == OPT_KIND_REAL && s->max)
        used += (size_t)snprintf(line + used, sizeof line - used, ": 0 .. %llu", (unsigned long long)s->max);
    else if (s->kind == OPT_KIND_LIST && s->names)
        used += (size_t)snprintf(line + used, sizeof line - used, ", each %s",
                                 names_text(s->names, what, sizeof what));
    if (s->def && used < sizeof line)
        snprintf(line + used, sizeof line - used, " (default %s)", s->def);
    size_t len = strlen(left);
    if (len + 2 > HELP_COLUMN) {
        fprintf(to, "%s\n%*s", left, HELP_COLUMN, "");
    } else {
        fprintf(to, "%s%*s", left, (int)(HELP_COLUMN - len), "");
    }
    print_wrapped(to, line, HELP_COLUMN);
}

void opts_help(const opt_command *c, FILE *to)
{
    fputs(c->usage, to);
    fprintf(to, "\noptions:\n");
    for (const opt_spec *s = c->opts; s->name; s++)
        help_line(to, s);
    opt_spec h = {"help", 'h', OPT_KIND_FLAG, NULL, 0, 0, 0, NULL, NULL, "print this help and exit", NULL};
    help_line(to, &h);
    if (c->epilog) {
        fputc('\n', to);
        fputs(c->epilog, to);
    }
}

/* Appends "tag LEN:text\n" (the length keeps any text, a newline included, from running into the next field). */
static bool req_add(char **buf, size_t *len, const char *tag, const char *text)
{
    size_t n = strlen(tag) + strlen(text) + 32;
    char *grown = realloc(*buf, *len + n);
    if (!grown)
        return false;
    *buf = grown;
    *len += (size_t)snprintf(grown + *len, n, "%s %zu:%s\n", tag, strlen(text), text);
    return true;
}

static uint64_t load_uint(const opt_spec *s)
{
    switch (s->target_size) {
    case 1: { uint8_t x; memcpy(&x, s->target, 1); return x; }
    case 2: { uint16_t x; memcpy(&x, s->target, 2); return x; }
    case 4: { uint32_t x; memcpy(&x, s->target, 4); return x; }
    default: { uint64_t x; memcpy(&x, s->target, 8); return x; }
    }
}

char *opts_request(const opt_command *c, const opt_args *a, const char *const *skip)
{
    char *buf = NULL;
    size_t len = 0;
    bool ok = req_add(&buf, &len, "command", c->name);
    for (size_t i = 0; ok && i < a->count; i++)
        ok = req_add(&buf, &len, "arg", a->arg[i]);
    for (const opt_spec *s = c->opts; ok && s->name; s++) {
        bool skipped = false;
        for (size_t k = 0; skip && skip[k]; k++)
            skipped |= !strcmp(skip[k], s->name);
        if (skipped)
            continue;
        char text[64];
        const char *value = text;
        switch (s->kind) {
        case OPT_KIND_FLAG: value = *(const bool *)s->target ? "yes" : "no"; break;
        case OPT_KIND_UINT:
        case OPT_KIND_ENUM: snprintf(text, sizeof text, "%llu", (unsigned long long)load_uint(s)); break;
        case OPT_KIND_REAL: snprintf(text, sizeof text, "%a", *(const double *)s->target); break;
        case OPT_KIND_PATH: {
            const char *p = *(const char *const *)s->target;
            value = p ? p : "(unset)";
            break;
        }
        case OPT_KIND_LIST: {
            const opt_list *l = s->target;
            ok = req_add(&buf, &len, s->name, "(list)");
            for (size_t k = 0; ok && k < l->count; k++)
                ok = req_add(&buf, &len, "item", l->item[k]);
            continue;
        }
        }
        ok = req_add(&buf, &len, s->name, value);
    }
    if (!ok) {
        free(buf);
        return NULL;
    }
    return buf;
}
