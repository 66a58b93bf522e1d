/* Private helpers with which the validators fill an rto_report (the one report shape of rtoracle.h). Not installed. */
#ifndef RTO_REPORT_INTERNAL_H
#define RTO_REPORT_INTERNAL_H

#include "internal.h"

/* Everything declared below stays inside librtoracle.so: not part of the public API, not exported. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

static inline rto_value rto__val_none(void)
{
    rto_value v;
    v.type = RTO_VALUE_NONE;
    v.v.u = 0;
    return v;
}

static inline rto_value rto__val_hex32(uint32_t u)
{
    rto_value v;
    v.type = RTO_VALUE_HEX32;
    v.v.u = u;
    return v;
}

static inline rto_value rto__val_hex64(uint64_t u)
{
    rto_value v;
    v.type = RTO_VALUE_HEX64;
    v.v.u = u;
    return v;
}

static inline rto_value rto__val_uint(uint64_t u)
{
    rto_value v;
    v.type = RTO_VALUE_UINT;
    v.v.u = u;
    return v;
}

static inline rto_value rto__val_int(int64_t i)
{
    rto_value v;
    v.type = RTO_VALUE_INT;
    v.v.i = i;
    return v;
}

static inline rto_value rto__val_f32(float f)
{
    rto_value v;
    v.type = RTO_VALUE_F32;
    v.v.f = f;
    return v;
}

static inline rto_value rto__val_f64(double f)
{
    rto_value v;
    v.type = RTO_VALUE_F64;
    v.v.f = f;
    return v;
}

/** Clears r and names the validator: passed, no checks, tolerance "". */
void rto__report_begin(rto_report *r, const char *validator);
/** Adds a check (state "n/a") to the fixed list a validator prints. */
void rto__report_add_check(rto_report *r, const char *name);
/** Sets a check's state; FAILED is sticky (a later PASSED does not clear it). */
void rto__report_mark(rto_report *r, const char *name, rto_check_state state);
/**
 * Records that fault class (code, name) was found. The first one claimed becomes the primary fault: it returns 1
 * and the caller fills summary, location and rows; later ones are only listed in faults_seen and return 0.
 */
int rto__report_claim(rto_report *r, int code, const char *name);
/** Writes the summary line (printf format). */
void rto__report_summary(rto_report *r, const char *fmt, ...) RTO_PRINTF(2, 3);
/** Appends to the summary line. */
void rto__report_append(rto_report *r, const char *fmt, ...) RTO_PRINTF(2, 3);
/** Sets a location field of the primary fault (replacing one of the same name). */
void rto__report_at(rto_report *r, const char *name, int64_t value);
/** Sets a size fact. */
void rto__report_fact(rto_report *r, const char *name, int64_t value);
/** Names the table: what its rows compare and what their index counts. */
void rto__report_table(rto_report *r, const char *title, const char *index_name);
/** Appends a row (values NONE) and returns it, or NULL once RTO_REPORT_MAX_ROWS rows are held. */
rto_report_row *rto__report_row_add(rto_report *r, uint64_t index, const char *field);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
