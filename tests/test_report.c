/* The one report shape and its two writers: typed values print as hex, integers or floats; the text writer keeps
 * the layout of the sort report; the JSON writer gives valid JSON (parsed back here with jansson), encodes what JSON
 * cannot hold as strings, and both honour the buffer contract (size query, BUFFER_TOO_SMALL, NUL-terminated). */
#include "testutil.h"

#include <jansson.h>
#include <math.h>

/* A report filled by hand through the public struct, as a harness or a future validator would read it. */
static void sample(rto_report *r)
{
    memset(r, 0, sizeof *r);
    snprintf(r->validator, sizeof r->validator, "check-demo");
    snprintf(r->what, sizeof r->what, "BLAS 3");
    snprintf(r->context, sizeof r->context, "7 nodes over 8 leaves");
    snprintf(r->mode, sizeof r->mode, "exact");
    r->code = 11;
    snprintf(r->fault, sizeof r->fault, "box");
    snprintf(r->faults_seen[0], sizeof r->faults_seen[0], "box");
    snprintf(r->faults_seen[1], sizeof r->faults_seen[1], "empty");
    r->nfaults_seen = 2;
    snprintf(r->checks[0].name, sizeof r->checks[0].name, "links");
    r->checks[0].state = RTO_CHECK_PASSED;
    snprintf(r->checks[1].name, sizeof r->checks[1].name, "boxes");
    r->checks[1].state = RTO_CHECK_FAILED;
    snprintf(r->checks[2].name, sizeof r->checks[2].name, "oracle");
    r->nchecks = 3;
    snprintf(r->where[0].name, sizeof r->where[0].name, "node");
    r->where[0].value = 5;
    snprintf(r->where[1].name, sizeof r->where[1].name, "leaf");
    r->where[1].value = 2;
    r->nwhere = 2;
    snprintf(r->facts[0].name, sizeof r->facts[0].name, "nodes");
    r->facts[0].value = 7;
    r->nfacts = 1;
    snprintf(r->tolerance, sizeof r->tolerance, "leaves within the transform bound");
    r->tolerance_bound = 0.125;
    snprintf(r->table_title, sizeof r->table_title, "boxes");
    snprintf(r->index_name, sizeof r->index_name, "node");
    rto_report_row *row = &r->rows[0];
    row->index = 5;
    snprintf(row->field, sizeof row->field, "min.x");
    row->expected = (rto_value){RTO_VALUE_F32, {.f = 1.5f}};
    row->actual = (rto_value){RTO_VALUE_F32, {.f = 0.1f}};
    row->diff = (rto_value){RTO_VALUE_F64, {.f = (double)0.1f - 1.5}};
    row->tolerance = (rto_value){RTO_VALUE_F64, {.f = 0.125}};
    row = &r->rows[1];
    row->index = 5;
    snprintf(row->field, sizeof row->field, "max.y");
    row->expected = (rto_value){RTO_VALUE_F32, {.f = -INFINITY}};
    row->actual = (rto_value){RTO_VALUE_F32, {.f = NAN}};
    row->diff = (rto_value){RTO_VALUE_F64, {.f = NAN}};
    row = &r->rows[2];
    row->index = 6;
    snprintf(row->field, sizeof row->field, "item");
    row->expected = (rto_value){RTO_VALUE_HEX32, {.u = 0xFFFFFFFEu}};
    row->actual = (rto_value){RTO_VALUE_HEX32, {.u = 0x2Au}};
    row = &r->rows[3];
    row->index = 7;
    snprintf(row->field, sizeof row->field, "key");
    row->expected = (rto_value){RTO_VALUE_HEX64, {.u = UINT64_C(0x123456789)}};
    row->actual = (rto_value){RTO_VALUE_UINT, {.u = UINT64_MAX}};
    row->diff = (rto_value){RTO_VALUE_INT, {.i = -3}};
    r->nrows = 4;
    snprintf(r->summary, sizeof r->summary, "box: node 5 min.x out of tolerance");
}

static char *text_of(const rto_report *r)
{
    size_t len = 0;
    assert_int_equal(rto_report_text(r, NULL, 0, &len), RTO_ERR_BUFFER_TOO_SMALL);
    char *buf = malloc(len + 1);
    size_t again = 0;
    assert_int_equal(rto_report_text(r, buf, len + 1, &again), RTO_OK);
    assert_int_equal(again, len);
    assert_int_equal(strlen(buf), len);
    return buf;
}

/* The table row of text whose whitespace-separated cells are exactly cells (NULL-terminated). */
static int has_row(const char *text, const char *const *cells)
{
    for (const char *line = text; line && *line;) {
        const char *end = strchr(line, '\n');
        size_t n = end ? (size_t)(end - line) : strlen(line);
        char buf[512];
        snprintf(buf, sizeof buf, "%.*s", (int)n, line);
        int ok = 1, k = 0;
        for (char *save = NULL, *tok = strtok_r(buf, " ", &save); ok && tok; tok = strtok_r(NULL, " ", &save), k++)
            ok = cells[k] && !strcmp(tok, cells[k]);
        if (ok && !cells[k])
            return 1;
        line = end ? end + 1 : NULL;
    }
    return 0;
}

static void test_text_writer(void **state)
{
    (void)state;
    rto_report r;
    sample(&r);
    char *t = text_of(&r);
    /* header, verdict, mode, checks, location, the other faults, tolerance, then the table */
    const char *lines[] = {
        "check-demo BLAS 3: 7 nodes over 8 leaves\n",
        "FAIL box: node 5 min.x out of tolerance\n",
        "  mode         exact\n",
        "  links        ok\n",
        "  boxes        FAIL\n",
        "  oracle       n/a\n",
        "  where        node 5, leaf 2\n",
        "  faults seen  box empty\n",
        "  tolerance    leaves within the transform bound\n",
        "  bound        0.125 at the reported element\n",
        "  first differing nodes (boxes):\n",
    };
    const char *at = t;
    for (size_t i = 0; i < sizeof lines / sizeof lines[0]; i++) {
        const char *hit = strstr(at, lines[i]);
        if (!hit)
            fail_msg("missing or out of order: %s--- in ---\n%s", lines[i], t);
        at = hit + strlen(lines[i]);
    }
    /* typed cells: floats as floats (9 digits), bit patterns as hex, NaN without a sign, absent as "-" */
    static const char *const header[] = {"node", "field", "expected", "actual", "diff", "tolerance", NULL},
                             *row0[] = {"5", "min.x", "1.5", "0.100000001", "-1.4", "0.125", NULL},
                             *row1[] = {"5", "max.y", "-inf", "nan", "nan", "-", NULL},
                             *row2[] = {"6", "item", "0xfffffffe", "0x0000002a", "-", "-", NULL},
                             *row3[] = {"7", "key", "0x0000000123456789", "18446744073709551615", "-3", "-", NULL};
    const char *const *rows[] = {header, row0, row1, row2, row3};
    for (size_t i = 0; i < 5; i++)
        if (!has_row(t, rows[i]))
            fail_msg("no table row %s %s ... in\n%s", rows[i][0], rows[i][1], t);
    assert_null(strstr(t, "-nan"));
    /* the buffer contract: a short buffer gets a NUL-terminated prefix */
    char small[16];
    size_t len = 0;
    assert_int_equal(rto_report_text(&r, small, sizeof small, &len), RTO_ERR_BUFFER_TOO_SMALL);
    assert_int_equal(len, strlen(t));
    assert_int_equal(strlen(small), sizeof small - 1);
    assert_int_equal(strncmp(small, t, sizeof small - 1), 0);
    /* a pass prints no location, table or other faults */
    r.code = 0;
    snprintf(r.fault, sizeof r.fault, "none");
    snprintf(r.summary, sizeof r.summary, "ok: fine");
    free(t);
    t = text_of(&r);
    assert_non_null(strstr(t, "PASS ok: fine\n"));
    assert_null(strstr(t, "where"));
    assert_null(strstr(t, "first differing"));
    free(t);
}

static void test_json_writer(void **state)
{
    (void)state;
    rto_report r;
    sample(&r);
    size_t len = 0;
    assert_int_equal(rto_report_json(&r, NULL, 0, &len, NULL), RTO_ERR_BUFFER_TOO_SMALL);
    char *buf = malloc(len + 1);
    assert_int_equal(rto_report_json(&r, buf, len + 1, &len, NULL), RTO_OK);
    json_error_t err;
    json_t *o = json_loads(buf, 0, &err);
    if (!o)
        fail_msg("not JSON (%s): %s", err.text, buf);
    assert_string_equal(json_string_value(json_object_get(o, "command")), "check-demo");
    assert_string_equal(json_string_value(json_object_get(o, "what")), "BLAS 3");
    assert_string_equal(json_string_value(json_object_get(o, "mode")), "exact");
    assert_string_equal(json_string_value(json_object_get(o, "result")), "fail");
    assert_string_equal(json_string_value(json_object_get(o, "fault")), "box");
    assert_int_equal(json_array_size(json_object_get(o, "faults")), 2);
    json_t *loc = json_object_get(o, "location");
    assert_int_equal(json_integer_value(json_object_get(loc, "node")), 5);
    assert_int_equal(json_integer_value(json_object_get(loc, "leaf")), 2);
    json_t *checks = json_object_get(o, "checks");
    assert_true(json_is_true(json_object_get(checks, "links")));
    assert_true(json_is_false(json_object_get(checks, "boxes")));
    assert_true(json_is_null(json_object_get(checks, "oracle")));
    assert_int_equal(json_integer_value(json_object_get(json_object_get(o, "facts"), "nodes")), 7);
    json_t *tol = json_object_get(o, "tolerance");
    assert_true(json_real_value(json_object_get(tol, "bound")) == 0.125);
    json_t *diffs = json_object_get(o, "diffs"), *rows = json_object_get(diffs, "rows");
    assert_string_equal(json_string_value(json_object_get(diffs, "index")), "node");
    assert_int_equal(json_array_size(rows), 4);
    json_t *r0 = json_array_get(rows, 0), *r1 = json_array_get(rows, 1), *r2 = json_array_get(rows, 2),
           *r3 = json_array_get(rows, 3);
    /* the row's index is keyed by what it counts; floats round-trip through 9 digits */
    assert_int_equal(json_integer_value(json_object_get(r0, "node")), 5);
    assert_string_equal(json_string_value(json_object_get(r0, "field")), "min.x");
    assert_true((float)json_real_value(json_object_get(r0, "actual")) == 0.1f);
    assert_true(json_real_value(json_object_get(r0, "tolerance")) == 0.125);
    /* non-finite values as strings; an absent value as null; no tolerance key where none applied */
    assert_string_equal(json_string_value(json_object_get(r1, "expected")), "-inf");
    assert_string_equal(json_string_value(json_object_get(r1, "actual")), "nan");
    assert_null(json_object_get(r1, "tolerance"));
    assert_string_equal(json_string_value(json_object_get(r2, "expected")), "0xfffffffe");
    assert_true(json_is_null(json_object_get(r2, "diff")));
    assert_string_equal(json_string_value(json_object_get(r3, "expected")), "0x0000000123456789");
    /* an unsigned beyond json_int_t keeps every digit */
    assert_string_equal(json_string_value(json_object_get(r3, "actual")), "18446744073709551615");
    assert_int_equal(json_integer_value(json_object_get(r3, "diff")), -3);
    assert_string_equal(json_string_value(json_object_get(o, "message")), r.summary);
    json_decref(o);
    /* too small a buffer */
    rto_msg msg = {{0}};
    char small[8];
    assert_int_equal(rto_report_json(&r, small, sizeof small, &len, &msg), RTO_ERR_BUFFER_TOO_SMALL);
    assert_int_equal(strlen(small), sizeof small - 1);
    free(buf);
}

/* Text cut inside a UTF-8 character (a case id cut to fit `what`) or not UTF-8 at all is written repaired (U+FFFD),
 * not refused as if memory had run out. */
static void test_json_writer_repairs_text(void **state)
{
    (void)state;
    rto_report r;
    sample(&r);
    char id[200] = "case";
    for (int i = 0; i < 60; i++)
        strcat(id, "\xc3\xa9"); /* U+00E9 */
    memcpy(r.what, id, sizeof r.what - 1); /* as snprintf cuts it: "case", 45 characters and a first byte */
    r.what[sizeof r.what - 1] = '\0';
    assert_int_equal((unsigned char)r.what[94], 0xc3);
    snprintf(r.summary, sizeof r.summary, "box: \xff at node 5");
    size_t len = 0;
    rto_msg msg = {{0}};
    assert_int_equal(rto_report_json(&r, NULL, 0, &len, &msg), RTO_ERR_BUFFER_TOO_SMALL);
    char *buf = malloc(len + 1);
    assert_int_equal(rto_report_json(&r, buf, len + 1, &len, &msg), RTO_OK);
    json_error_t err;
    json_t *o = json_loads(buf, 0, &err);
    if (!o)
        fail_msg("not JSON (%s): %s", err.text, buf);
    char want[200];
    snprintf(want, sizeof want, "%.94s\xef\xbf\xbd", r.what);
    assert_string_equal(json_string_value(json_object_get(o, "what")), want);
    assert_string_equal(json_string_value(json_object_get(o, "message")), "box: \xef\xbf\xbd at node 5");
    json_decref(o);
    free(buf);
}

/* Validators fill the same shape: the lookups a harness uses work on a real check-sort report. */
static void test_lookups_on_a_validator_report(void **state)
{
    (void)state;
    uint32_t in[5] = {5, 1, 4, 2, 3}, gpu[5] = {1, 2, 4, 3, 5};
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.format = RTO_KEY_U32;
    d.input = in;
    d.n = 5;
    d.gpu_keys = gpu;
    d.gpu_n = 5;
    rto_report r;
    assert_int_equal(rto_sort_check(&d, &r, NULL), RTO_ERR_MISMATCH);
    assert_false(rto_report_passed(&r));
    assert_string_equal(r.validator, "check-sort");
    assert_string_equal(r.fault, "order");
    int64_t slot = -1;
    assert_int_equal(rto_report_where(&r, "slot", &slot), 1);
    assert_int_equal(slot, 2);
    assert_int_equal(rto_report_where(&r, "node", NULL), 0);
    assert_int_equal(rto_report_check_state(&r, "sorted"), RTO_CHECK_FAILED);
    assert_int_equal(rto_report_check_state(&r, "permutation"), RTO_CHECK_PASSED);
    assert_int_equal(rto_report_check_state(&r, "tail"), RTO_CHECK_NOT_RUN);
    assert_int_equal(rto_report_check_state(&r, "no-such-check"), RTO_CHECK_NOT_RUN);
    assert_int_equal(r.nrows, 2);
    assert_int_equal(r.rows[0].index, 2);
    assert_int_equal(r.rows[0].expected.type, RTO_VALUE_HEX32);
    assert_int_equal(r.rows[0].diff.v.u, 4u ^ 3u);
    assert_int_equal(rto_report_passed(NULL), 0);
}

/* A message prefixed with itself (rto_msg_set(m, s, "bounce %u: %s", d, m->text), as the frame's bounces do): the
 * prefix once, then the whole inner message. */
static void test_msg_prefixed_with_itself(void **state)
{
    (void)state;
    rto_msg m;
    rto_msg_set(&m, RTO_ERR_INVALID_ARGUMENT, "ray %d has a non-finite origin", 4);
    assert_int_equal(rto_msg_set(&m, RTO_ERR_INVALID_ARGUMENT, "bounce %u: %s", 0u, m.text), RTO_ERR_INVALID_ARGUMENT);
    assert_string_equal(m.text, "bounce 0: ray 4 has a non-finite origin");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_text_writer),
        cmocka_unit_test(test_json_writer),
        cmocka_unit_test(test_json_writer_repairs_text),
        cmocka_unit_test(test_lookups_on_a_validator_report),
        cmocka_unit_test(test_msg_prefixed_with_itself),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
