/* Well-formed UTF-8 for JSON writers. Names reach the manifests from files (glTF names, image URIs, paths) whose
 * bytes nobody checked, and a JSON string must be UTF-8 (RFC 8259 §8.1); jansson refuses anything else. Repairing
 * follows Unicode's "substitution of maximal subparts" (The Unicode Standard, §3.9, U+FFFD Substitution of Maximal
 * Subparts): each maximal prefix of a well-formed sequence that is cut short, and each byte that cannot start one,
 * becomes one U+FFFD, so a name cut inside a character keeps everything before the cut and ends in one U+FFFD. */
#include "core/utf8.h"
#include "internal.h"

#include <string.h>

/* Length of the well-formed sequence at s (Unicode Table 3-7), or 0 with *bad set to the length of the maximal
 * subpart to replace (at least 1). */
static size_t sequence_length(const unsigned char *s, size_t *bad)
{
    const unsigned char c = s[0];
    unsigned char lo = 0x80, hi = 0xBF;
    size_t n;
    if (c < 0x80)
        return 1;
    if (c >= 0xC2 && c <= 0xDF)
        n = 2;
    else if (c >= 0xE0 && c <= 0xEF)
        n = 3;
    else if (c >= 0xF0 && c <= 0xF4)
        n = 4;
    else {
        *bad = 1;
        return 0;
    }
    /* The second byte's range excludes overlongs (E0, F0), surrogates (ED) and code points above U+10FFFF (F4). */
    if (c == 0xE0)
        lo = 0xA0;
    else if (c == 0xED)
        hi = 0x9F;
    else if (c == 0xF0)
        lo = 0x90;
    else if (c == 0xF4)
        hi = 0x8F;
    for (size_t i = 1; i < n; i++) {
        if (s[i] < lo || s[i] > hi) { /* also stops at the terminating NUL */
            *bad = i;
            return 0;
        }
        lo = 0x80;
        hi = 0xBF;
    }
    return n;
}

size_t rto_utf8_repair(const char *in, char *out, size_t cap)
{
    static const char replacement[3] = {(char)0xEF, (char)0xBF, (char)0xBD};
    const unsigned char *s = (const unsigned char *)(in ? in : "");
    size_t total = 0, written = 0;
    bool full = false;
    while (*s) {
        size_t bad = 0, n = sequence_length(s, &bad);
        const char *piece = n ? (const char *)s : replacement;
        size_t len = n ? n : 3;
        /* Whole characters only: once one does not fit (with the NUL), nothing more is written. */
        if (!full && written + len < cap) {
            memcpy(out + written, piece, len);
            written += len;
        } else {
            full = true;
        }
        total += len;
        s += n ? n : bad;
    }
    if (cap)
        out[written] = '\0';
    return total;
}

void rto__utf8_copy(char *dst, size_t cap, const char *src, size_t len)
{
    if (!cap)
        return;
    /* rto_utf8_repair writes at least one byte for every byte it reads, so no byte past the first cap + 3 can reach
     * dst: a bounded copy of those, with control characters made '?', is all it needs to see. */
    char tmp[RTO__UTF8_COPY_MAX + 4];
    size_t n = len < cap + 3 ? len : cap + 3;
    if (n > RTO__UTF8_COPY_MAX + 3)
        n = RTO__UTF8_COPY_MAX + 3;
    for (size_t i = 0; i < n; i++) {
        const unsigned char c = (unsigned char)src[i];
        tmp[i] = c < 0x20 || c == 0x7F ? '?' : (char)c;
    }
    tmp[n] = '\0';
    rto_utf8_repair(tmp, dst, cap < RTO__UTF8_COPY_MAX ? cap : RTO__UTF8_COPY_MAX);
}

void rto__utf8_fix(char *s, size_t cap)
{
    rto__utf8_copy(s, cap, s, strlen(s));
}
