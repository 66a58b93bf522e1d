/* JSON values and text that never come out silently wrong (library-private; jansson underneath). Used by the
 * manifest writer, the report writer and the scene description. */
#ifndef RTO_CORE_JSON_H
#define RTO_CORE_JSON_H

#include "internal.h"

#include <jansson.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** A JSON string of text repaired to well-formed UTF-8 (invalid sequences become U+FFFD); NULL if out of memory. */
json_t *rto__json_string(const char *text);
/** A JSON number, or the string "inf", "-inf" or "nan": JSON has no non-finite numbers (RFC 8259 §6). */
json_t *rto__json_real(double value);
/** Serialises j with jansson's flags plus a final newline into a malloc'ed string; NULL if out of memory. Unlike
 * json_dumps, never returns text cut short (see json.c). */
char *rto__json_text(const json_t *j, size_t flags);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
