/* The one report shape of every validator (rtoracle.h: rto_report) and its two writers. A report is a plain struct
 * of fixed-size fields, so a validator fills it without allocating and a harness can read it without parsing; the
 * writers decide nothing about content, only layout: text for people, JSON (jansson) for tools. */
#include "report_internal.h"
#include "core/json.h"

#include <inttypes.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void copy_name(char *dst, size_t cap, const char *src)
{
    snprintf(dst, cap, "%s", src ? src : "");
}

void rto__report_begin(rto_report *r, const char *validator)
{
    memset(r, 0, sizeof *r);
    copy_name(r->validator, sizeof r->validator, validator);
    copy_name(r->fault, sizeof r->fault, "none");
}

void rto__report_add_check(rto_report *r, const char *name)
{
    if (r->nchecks < RTO_REPORT_MAX_CHECKS) {
        copy_name(r->checks[r->nchecks].name, sizeof r->checks[0].name, name);
        r->checks[r->nchecks].state = RTO_CHECK_NOT_RUN;
        r->nchecks++;
    }
}

void rto__report_mark(rto_report *r, const char *name, rto_check_state state)
{
    for (uint32_t i = 0; i < r->nchecks; i++)
        if (!strcmp(r->checks[i].name, name) && r->checks[i].state != RTO_CHECK_FAILED)
            r->checks[i].state = state;
}

int rto__report_claim(rto_report *r, int code, const char *name)
{
    uint32_t i = 0;
    while (i < r->nfaults_seen && strcmp(r->faults_seen[i], name))
        i++;
    if (i == r->nfaults_seen && i < RTO_REPORT_MAX_FAULTS)
        copy_name(r->faults_seen[r->nfaults_seen++], sizeof r->faults_seen[0], name);
    if (r->code != 0)
        return 0;
    r->code = code;
    copy_name(r->fault, sizeof r->fault, name);
    r->nwhere = 0;
    r->nrows = 0;
    return 1;
}

void rto__report_summary(rto_report *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->summary, sizeof r->summary, fmt, ap);
    va_end(ap);
}

void rto__report_append(rto_report *r, const char *fmt, ...)
{
    size_t used = strlen(r->summary);
    if (used + 1 >= sizeof r->summary)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->summary + used, sizeof r->summary - used, fmt, ap);
    va_end(ap);
}

static void set_field(rto_report_field *fields, uint32_t *count, const char *name, int64_t value)
{
    uint32_t i = 0;
    while (i < *count && strcmp(fields[i].name, name))
        i++;
    if (i == *count) {
        if (i >= RTO_REPORT_MAX_FIELDS)
            return;
        copy_name(fields[i].name, sizeof fields[i].name, name);
        (*count)++;
    }
    fields[i].value = value;
}

void rto__report_at(rto_report *r, const char *name, int64_t value) { set_field(r->where, &r->nwhere, name, value); }

void rto__report_fact(rto_report *r, const char *name, int64_t value) { set_field(r->facts, &r->nfacts, name, value); }

void rto__report_table(rto_report *r, const char *title, const char *index_name)
{
    copy_name(r->table_title, sizeof r->table_title, title);
    copy_name(r->index_name, sizeof r->index_name, index_name);
}

rto_report_row *rto__report_row_add(rto_report *r, uint64_t index, const char *field)
{
    if (r->nrows >= RTO_REPORT_MAX_ROWS)
        return NULL;
    rto_report_row *row = &r->rows[r->nrows++];
    memset(row, 0, sizeof *row);
    row->index = index;
    copy_name(row->field, sizeof row->field, field);
    row->expected = row->actual = row->diff = row->tolerance = rto__val_none();
    return row;
}

int rto_report_passed(const rto_report *r) { return r && r->code == 0; }

int rto_report_where(const rto_report *r, const char *name, int64_t *value)
{
    for (uint32_t i = 0; r && name && i < r->nwhere && i < RTO_REPORT_MAX_FIELDS; i++)
        if (!strcmp(r->where[i].name, name)) {
            if (value)
                *value = r->where[i].value;
            return 1;
        }
    return 0;
}

rto_check_state rto_report_check_state(const rto_report *r, const char *name)
{
    for (uint32_t i = 0; r && name && i < r->nchecks && i < RTO_REPORT_MAX_CHECKS; i++)
        if (!strcmp(r->checks[i].name, name))
            return r->checks[i].state;
    return RTO_CHECK_NOT_RUN;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Text                                                                                                             */

static const char *state_name(rto_check_state s)
{
    return s == RTO_CHECK_PASSED ? "ok" : s == RTO_CHECK_FAILED ? "FAIL" : "n/a";
}

/* A value as text: the same spelling in the table and, for hex, in JSON. */
static void format_value(const rto_value *v, char *buf, size_t cap)
{
    switch (v->type) {
    case RTO_VALUE_HEX32: snprintf(buf, cap, "0x%08" PRIx32, (uint32_t)v->v.u); return;
    case RTO_VALUE_HEX64: snprintf(buf, cap, "0x%016" PRIx64, v->v.u); return;
    case RTO_VALUE_UINT: snprintf(buf, cap, "%" PRIu64, v->v.u); return;
    case RTO_VALUE_INT: snprintf(buf, cap, "%+" PRId64, v->v.i); return;
    case RTO_VALUE_F32:
    case RTO_VALUE_F64:
        if (isnan(v->v.f))
            snprintf(buf, cap, "nan"); /* never "-nan": the sign of a NaN carries nothing */
        else
            snprintf(buf, cap, "%.9g", v->v.f);
        return;
    case RTO_VALUE_NONE: break;
    }
    snprintf(buf, cap, "-");
}

/* Output into a caller's buffer that keeps counting past its end, so one pass gives both text and length. */
typedef struct sink {
    char *buf;
    size_t cap, len;
} sink;

static void put(sink *s, const char *fmt, ...) RTO_PRINTF(2, 3);
static void put(sink *s, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t room = s->buf && s->len < s->cap ? s->cap - s->len : 0;
    int n = vsnprintf(room ? s->buf + s->len : NULL, room, fmt, ap);
    va_end(ap);
    if (n > 0)
        s->len += (size_t)n;
}

static rto_status sink_end(const sink *s, size_t *len)
{
    if (len)
        *len = s->len;
    if (s->buf && s->cap)
        s->buf[s->len < s->cap ? s->len : s->cap - 1] = '\0';
    return s->len < s->cap ? RTO_OK : RTO_ERR_BUFFER_TOO_SMALL;
}

static size_t max_sz(size_t a, size_t b) { return a > b ? a : b; }

static void put_table(sink *s, const rto_report *r)
{
    const uint32_t rows = r->nrows < RTO_REPORT_MAX_ROWS ? r->nrows : RTO_REPORT_MAX_ROWS;
    int fields = 0, tols = 0, hexdiff = 0;
    for (uint32_t i = 0; i < rows; i++) {
        fields |= r->rows[i].field[0] != '\0';
        tols |= r->rows[i].tolerance.type != RTO_VALUE_NONE;
        hexdiff |= r->rows[i].diff.type == RTO_VALUE_HEX32 || r->rows[i].diff.type == RTO_VALUE_HEX64;
    }
    const char *diff_name = hexdiff ? "xor" : "diff";
    /* columns: index (at least 10 wide, as the sort report always was), field, expected, actual, diff, tolerance */
    size_t w[6] = {max_sz(10, strlen(r->index_name)), strlen("field"), strlen("expected"), strlen("actual"),
                   strlen(diff_name), strlen("tolerance")};
    char cell[4][40];
    for (uint32_t i = 0; i < rows; i++) {
        const rto_report_row *row = &r->rows[i];
        char idx[24];
        snprintf(idx, sizeof idx, "%" PRIu64, row->index);
        w[0] = max_sz(w[0], strlen(idx));
        w[1] = max_sz(w[1], strlen(row->field));
        const rto_value *vals[4] = {&row->expected, &row->actual, &row->diff, &row->tolerance};
        for (int c = 0; c < 4; c++) {
            format_value(vals[c], cell[c], sizeof cell[c]);
            w[2 + c] = max_sz(w[2 + c], strlen(cell[c]));
        }
    }
    put(s, "  first differing %ss (%s):\n  %-*s", r->index_name[0] ? r->index_name : "element",
        r->table_title[0] ? r->table_title : "values", (int)w[0], r->index_name[0] ? r->index_name : "index");
    if (fields)
        put(s, " %-*s", (int)w[1], "field");
    put(s, " %-*s %-*s ", (int)w[2], "expected", (int)w[3], "actual");
    if (tols)
        put(s, "%-*s %s\n", (int)w[4], diff_name, "tolerance");
    else
        put(s, "%s\n", diff_name);
    for (uint32_t i = 0; i < rows; i++) {
        const rto_report_row *row = &r->rows[i];
        const rto_value *vals[4] = {&row->expected, &row->actual, &row->diff, &row->tolerance};
        for (int c = 0; c < 4; c++)
            format_value(vals[c], cell[c], sizeof cell[c]);
        put(s, "  %-*" PRIu64, (int)w[0], row->index);
        if (fields)
            put(s, " %-*s", (int)w[1], row->field);
        put(s, " %-*s %-*s ", (int)w[2], cell[0], (int)w[3], cell[1]);
        if (tols)
            put(s, "%-*s %s\n", (int)w[4], cell[2], cell[3]);
        else
            put(s, "%s\n", cell[2]);
    }
}

rto_status rto_report_text(const rto_report *r, char *buf, size_t cap, size_t *len)
{
    if (len)
        *len = 0;
    if (!r || (cap && !buf))
        return RTO_ERR_INVALID_ARGUMENT;
    sink s = {buf, cap, 0};
    const int failed = r->code != 0;
    put(&s, "%s%s%s%s%s\n", r->validator, r->what[0] ? " " : "", r->what, r->context[0] ? ": " : "",
        r->context);
    put(&s, "%s %s\n", failed ? "FAIL" : "PASS", r->summary);
    if (r->mode[0])
        put(&s, "  %-12s %s\n", "mode", r->mode);
    for (uint32_t i = 0; i < r->nchecks && i < RTO_REPORT_MAX_CHECKS; i++)
        put(&s, "  %-12s %s\n", r->checks[i].name, state_name(r->checks[i].state));
    if (failed && r->nwhere) {
        put(&s, "  %-12s", "where");
        for (uint32_t i = 0; i < r->nwhere && i < RTO_REPORT_MAX_FIELDS; i++)
            put(&s, "%s %s %" PRId64, i ? "," : "", r->where[i].name, r->where[i].value);
        put(&s, "\n");
    }
    if (failed && r->nfaults_seen > 1) {
        put(&s, "  %-12s", "faults seen");
        for (uint32_t i = 0; i < r->nfaults_seen && i < RTO_REPORT_MAX_FAULTS; i++)
            put(&s, " %s", r->faults_seen[i]);
        put(&s, "\n");
    }
    if (r->tolerance[0])
        put(&s, "  %-12s %s\n", "tolerance", r->tolerance);
    if (failed && r->tolerance_bound > 0)
        put(&s, "  %-12s %.9g at the reported element\n", "bound", r->tolerance_bound);
    if (failed && r->nrows)
        put_table(&s, r);
    return sink_end(&s, len);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* JSON                                                                                                             */

/* Sets key in o to v, taking v's reference; records any failure (v NULL from an allocation, or the set itself). */
static void jset(json_t *o, const char *key, json_t *v, int *bad)
{
    if (!v || !o || json_object_set_new(o, key, v) != 0)
        *bad = 1;
}

static void jappend(json_t *a, json_t *v, int *bad)
{
    if (!v || !a || json_array_append_new(a, v) != 0)
        *bad = 1;
}

static json_t *jvalue(const rto_value *v)
{
    char text[40];
    switch (v->type) {
    case RTO_VALUE_HEX32:
    case RTO_VALUE_HEX64: format_value(v, text, sizeof text); return json_string(text);
    case RTO_VALUE_UINT:
        if (v->v.u > (uint64_t)INT64_MAX) { /* beyond json_int_t: keep every digit as a string */
            format_value(v, text, sizeof text);
            return json_string(text);
        }
        return json_integer((json_int_t)v->v.u);
    case RTO_VALUE_INT: return json_integer((json_int_t)v->v.i);
    case RTO_VALUE_F32:
    case RTO_VALUE_F64:
        if (!isfinite(v->v.f)) { /* JSON has no infinities or NaN */
            format_value(v, text, sizeof text);
            return json_string(text);
        }
        return json_real(v->v.f);
    case RTO_VALUE_NONE: break;
    }
    return json_null();
}

static json_t *fields_json(const rto_report_field *f, uint32_t n, int *bad)
{
    json_t *o = json_object();
    for (uint32_t i = 0; i < n && i < RTO_REPORT_MAX_FIELDS; i++)
        jset(o, f[i].name, json_integer((json_int_t)f[i].value), bad);
    return o;
}

/* The report's strings are text a caller may have filled (a case id from a manifest, cut to fit `what`, can end
 * inside a character): written repaired to UTF-8, as jansson refuses anything else. */
static json_t *report_object(const rto_report *r, int *bad)
{
    json_t *o = json_object();
    jset(o, "command", rto__json_string(r->validator), bad);
    jset(o, "what", r->what[0] ? rto__json_string(r->what) : json_null(), bad);
    jset(o, "context", r->context[0] ? rto__json_string(r->context) : json_null(), bad);
    jset(o, "mode", r->mode[0] ? rto__json_string(r->mode) : json_null(), bad);
    jset(o, "result", json_string(r->code ? "fail" : "pass"), bad);
    jset(o, "fault", rto__json_string(r->fault), bad);
    json_t *faults = json_array();
    for (uint32_t i = 0; i < r->nfaults_seen && i < RTO_REPORT_MAX_FAULTS; i++)
        jappend(faults, rto__json_string(r->faults_seen[i]), bad);
    jset(o, "faults", faults, bad);
    jset(o, "location", fields_json(r->where, r->nwhere, bad), bad);
    json_t *checks = json_object();
    for (uint32_t i = 0; i < r->nchecks && i < RTO_REPORT_MAX_CHECKS; i++) {
        rto_check_state st = r->checks[i].state;
        jset(checks, r->checks[i].name, st == RTO_CHECK_NOT_RUN ? json_null() : json_boolean(st == RTO_CHECK_PASSED),
             bad);
    }
    jset(o, "checks", checks, bad);
    jset(o, "facts", fields_json(r->facts, r->nfacts, bad), bad);
    if (r->tolerance[0]) {
        json_t *t = json_object();
        rto_value b = rto__val_f64(r->tolerance_bound);
        jset(t, "rule", rto__json_string(r->tolerance), bad);
        jset(t, "bound", jvalue(&b), bad);
        jset(o, "tolerance", t, bad);
    } else {
        jset(o, "tolerance", json_null(), bad);
    }
    json_t *diffs = json_object(), *rows = json_array();
    const char *index_name = r->index_name[0] ? r->index_name : "index";
    jset(diffs, "title", rto__json_string(r->table_title), bad);
    jset(diffs, "index", rto__json_string(index_name), bad);
    for (uint32_t i = 0; i < r->nrows && i < RTO_REPORT_MAX_ROWS; i++) {
        const rto_report_row *row = &r->rows[i];
        json_t *jr = json_object();
        jset(jr, index_name, json_integer((json_int_t)row->index), bad);
        if (row->field[0])
            jset(jr, "field", rto__json_string(row->field), bad);
        jset(jr, "expected", jvalue(&row->expected), bad);
        jset(jr, "actual", jvalue(&row->actual), bad);
        jset(jr, "diff", jvalue(&row->diff), bad);
        if (row->tolerance.type != RTO_VALUE_NONE)
            jset(jr, "tolerance", jvalue(&row->tolerance), bad);
        jappend(rows, jr, bad);
    }
    jset(diffs, "rows", rows, bad);
    jset(o, "diffs", diffs, bad);
    jset(o, "message", rto__json_string(r->summary), bad);
    return o;
}

rto_status rto_report_json(const rto_report *r, char *buf, size_t cap, size_t *len, rto_msg *msg)
{
    if (len)
        *len = 0;
    if (!r || (cap && !buf))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL report or buffer");
    int bad = 0;
    json_t *o = report_object(r, &bad);
    /* 9 significant digits round-trip every binary32 value and are plenty for binary64 differences. */
    char *text = bad ? NULL : rto__json_text(o, JSON_INDENT(2) | JSON_REAL_PRECISION(9));
    json_decref(o);
    if (!text)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory writing the JSON report");
    sink s = {buf, cap, 0};
    put(&s, "%s", text);
    free(text);
    rto_status st = sink_end(&s, len);
    return st ? rto__fail(msg, st, "the JSON report needs %zu bytes", s.len + 1) : RTO_OK;
}
