/* Morton keys for the TLAS (u32, 5 bits per axis) and BLAS (u64, 10 bits per axis), DESIGN.md §3. */
#include "keys_internal.h"

#include <math.h>

static uint32_t spread3(uint32_t v) { return rto__spread3(v); }

uint32_t rto_morton15(uint32_t qx, uint32_t qy, uint32_t qz)
{
    return (spread3(qx & 31u) << 2) | (spread3(qy & 31u) << 1) | spread3(qz & 31u);
}

uint32_t rto_morton30(uint32_t qx, uint32_t qy, uint32_t qz)
{
    return (spread3(qx) << 2) | (spread3(qy) << 1) | spread3(qz);
}

static float axis(const rto_vec3 *v, int a) { return a == 0 ? v->x : a == 1 ? v->y : v->z; }

/* Bounds of all centroids; refuses non-finite centroids and spans that overflow binary32, where the quantisation
 * below would divide inf by inf. A centroid is named by its key index (index[i], or i without an index array). */
static rto_status centroid_bounds(const rto_vec3 *c, const uint32_t *index, size_t n, float lo[3], float hi[3],
                                  rto_msg *msg)
{
    for (int a = 0; a < 3; a++) {
        lo[a] = INFINITY;
        hi[a] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            float v = axis(&c[i], a);
            if (!isfinite(v))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "centroid %zu has a non-finite coordinate (%g)",
                                index ? (size_t)index[i] : i, (double)v);
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    }
    for (int a = 0; a < 3; a++)
        if (n > 0 && !isfinite(hi[a] - lo[a]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "centroid bounds on axis %c span more than binary32 holds",
                            "xyz"[a]);
    return RTO_OK;
}

/* q = min(cells - 1, u32(floor(((c - lo) / (hi - lo)) * cells))) in binary32, and 0 where hi == lo. */
static uint32_t quantise(float c, float lo, float hi, uint32_t cells)
{
    if (hi == lo)
        return 0;
    float t = ((c - lo) / (hi - lo)) * (float)cells;
    uint32_t q = (uint32_t)floorf(t);
    return q < cells - 1 ? q : cells - 1;
}

uint32_t rto__tlas_key(rto_vec3 c, const float lo[3], const float hi[3], uint32_t index)
{
    uint32_t q[3];
    for (int a = 0; a < 3; a++)
        q[a] = quantise(axis(&c, a), lo[a], hi[a], 32);
    return (rto_morton15(q[0], q[1], q[2]) << 16) | index;
}

rto_status rto__tlas_keys_indexed(const rto_vec3 *centroids, const uint32_t *index, size_t n, uint32_t *keys,
                                 rto_msg *msg)
{
    if (n > RTO_TLAS_MAX_INSTANCES)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu instances: a TLAS key indexes at most %u", n,
                        RTO_TLAS_MAX_INSTANCES);
    if (n && (!centroids || !keys))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL centroids or keys");
    for (size_t i = 0; index && i < n; i++)
        if (index[i] >= RTO_TLAS_MAX_INSTANCES)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance index %u: a TLAS key indexes at most %u",
                            index[i], RTO_TLAS_MAX_INSTANCES);
    float lo[3], hi[3];
    rto_status s = centroid_bounds(centroids, index, n, lo, hi, msg);
    if (s)
        return s;
    for (size_t i = 0; i < n; i++)
        keys[i] = rto__tlas_key(centroids[i], lo, hi, index ? index[i] : (uint32_t)i);
    return RTO_OK;
}

rto_status rto_tlas_keys(const rto_vec3 *centroids, size_t n, uint32_t *keys, rto_msg *msg)
{
    return rto__tlas_keys_indexed(centroids, NULL, n, keys, msg);
}

rto_status rto_blas_keys(const rto_vec3 *centroids, size_t n, uint64_t *keys, rto_msg *msg)
{
    if ((uint64_t)n > UINT32_MAX)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu triangles: a BLAS key indexes fewer than 2^32", n);
    if (n && (!centroids || !keys))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL centroids or keys");
    float lo[3], hi[3];
    rto_status s = centroid_bounds(centroids, NULL, n, lo, hi, msg);
    if (s)
        return s;
    for (size_t i = 0; i < n; i++) {
        uint32_t q[3];
        for (int a = 0; a < 3; a++)
            q[a] = quantise(axis(&centroids[i], a), lo[a], hi[a], 1024);
        keys[i] = ((uint64_t)rto_morton30(q[0], q[1], q[2]) << 32) | (uint64_t)i;
    }
    return RTO_OK;
}

size_t rto_key_size(rto_key_format f) { return f == RTO_KEY_U32 ? 4 : 8; }

uint64_t rto_key_sentinel(rto_key_format f) { return f == RTO_KEY_U32 ? RTO_SENTINEL_U32 : RTO_SENTINEL_U64; }

uint32_t rto_key_prim(rto_key_format f, uint64_t key)
{
    return f == RTO_KEY_U32 ? (uint32_t)(key & 0xFFFFu) : (uint32_t)key;
}
