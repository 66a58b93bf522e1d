/* Private helpers shared by the library's stages. Not installed; never included by users. */
#ifndef RTO_INTERNAL_H
#define RTO_INTERNAL_H

#include "rtoracle.h"

#include <stdarg.h>
#include <stdbool.h>

#if defined(__GNUC__)
#define RTO_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define RTO_PRINTF(a, b)
#endif

/** Writes a formatted one-line reason into m (if non-NULL) and returns s. */
rto_status rto_fail(rto_msg *m, rto_status s, const char *fmt, ...) RTO_PRINTF(3, 4);

/** Key i of a u32 or u64 key array, widened to 64 bits. */
static inline uint64_t rto_key_get(rto_key_format f, const void *keys, size_t i)
{
    return f == RTO_KEY_U32 ? ((const uint32_t *)keys)[i] : ((const uint64_t *)keys)[i];
}

static inline void rto_key_put(rto_key_format f, void *keys, size_t i, uint64_t v)
{
    if (f == RTO_KEY_U32)
        ((uint32_t *)keys)[i] = (uint32_t)v;
    else
        ((uint64_t *)keys)[i] = v;
}

/* min / max with a fixed choice between +0 and -0 (the second operand when equal), so that unions are the same bytes
 * whether the compiler inlines minss or calls fminf. */
static inline float rto_minf(float a, float b) { return a < b ? a : b; }
static inline float rto_maxf(float a, float b) { return a > b ? a : b; }

/** Surface area of a box given as min / max triples, in binary64; 0 for an empty box (SAH statistics). */
static inline double rto_box_area(const float *mn, const float *mx)
{
    double d[3];
    for (int a = 0; a < 3; a++) {
        d[a] = (double)mx[a] - (double)mn[a];
        if (!(d[a] >= 0))
            return 0;
    }
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/** TLAS keys whose index field is index[i] (the instance a centroid belongs to) instead of i: the keys of a subset
 * of instances, quantised over that subset's bounds. index == NULL means index[i] = i (rto_tlas_keys). */
rto_status rto_tlas_keys_indexed(const rto_vec3 *centroids, const uint32_t *index, size_t n, uint32_t *keys,
                                 rto_msg *msg);

/** malloc of count * size bytes with an overflow check; count 0 gives a 1-byte block so NULL always means failure. */
void *rto_alloc(size_t count, size_t size);

#endif
