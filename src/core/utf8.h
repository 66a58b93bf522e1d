/* Names that reach JSON and one-line outputs, made well-formed UTF-8 (core/utf8.c). Library-private; included from
 * the C++ glTF shim too (through scene/model.h). */
#ifndef RTO_CORE_UTF8_H
#define RTO_CORE_UTF8_H

#include <stddef.h>

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The largest cap rto__utf8_copy fills (the scene's text arrays and rto_msg are smaller). */
#define RTO__UTF8_COPY_MAX 1024

/**
 * Copies len bytes of src into dst (cap bytes, always terminated) as valid UTF-8: control characters become '?'
 * (one line per item in the text output), ill-formed parts U+FFFD (rto_utf8_repair), and a character that does not
 * fit whole is left out rather than cut. Scene names, warnings and messages go to JSON writers and one-line outputs.
 */
void rto__utf8_copy(char *dst, size_t cap, const char *src, size_t len);

/** rto__utf8_copy of the string in s (an array of cap bytes) onto itself. */
void rto__utf8_fix(char *s, size_t cap);

#ifdef __cplusplus
}
#endif

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
