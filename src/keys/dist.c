/* Named key distributions and size classes (DESIGN.md §3). Every value is a pure function of (dist, format, seed,
 * n), built from the shared PRNG, so a JS or WGSL harness can regenerate any input bit for bit. */
#include "keys_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Independent streams of the PRNG: stream s draws from seed + s * golden (u32 wrap-around). */
#define STREAM(seed, s) ((uint32_t)((seed) + (uint32_t)(s) * UINT32_C(0x9E3779B9)))

static const rto_dist_info dists[] = {
    {"uniform", RTO_DIST_CENTROID, 0, "centroids uniform in the unit cube"},
    {"one-bucket", RTO_DIST_CENTROID, 0, "all centroids equal: every Morton code identical"},
    {"clustered", RTO_DIST_CENTROID, 0, "n-1 centroids in a 1e-3 cube at 0.5, one small object 2e-3 away"},
    {"clustered-far", RTO_DIST_CENTROID, 0, "n-1 centroids in a 1e-3 cube at 0.5, one far away at the origin"},
    {"line", RTO_DIST_CENTROID, 0, "centroids on a line along x (y and z degenerate)"},
    {"two-clusters", RTO_DIST_CENTROID, 0, "alternating between two 1e-3 cubes at 0.25 and 0.75"},
    {"random", RTO_DIST_RAW, 0, "uniform random keys"},
    {"entropy-1", RTO_DIST_RAW, 0, "random keys (AND of 1 word)"},
    {"entropy-3", RTO_DIST_RAW, 0, "AND of 3 random words: bits set with probability 1/8"},
    {"entropy-9", RTO_DIST_RAW, 0, "AND of 9 random words: bits set with probability 1/512"},
    {"entropy-15", RTO_DIST_RAW, 0, "AND of 15 random words: almost all keys zero"},
    {"sorted", RTO_DIST_RAW, 0, "random keys, already ascending"},
    {"reversed", RTO_DIST_RAW, 0, "random keys, descending"},
    {"all-equal", RTO_DIST_RAW, 0, "one random key repeated"},
    {"few-unique", RTO_DIST_RAW, 0, "at most 8 distinct random keys"},
    {"sentinel-heavy", RTO_DIST_RAW, 0, "3 in 4 keys equal to the padding sentinel"},
    {"digit-0-one-bucket", RTO_DIST_RAW, 0, "random keys sharing byte 0 (8-bit radix digit 0)"},
    {"digit-1-one-bucket", RTO_DIST_RAW, 0, "random keys sharing byte 1"},
    {"digit-2-one-bucket", RTO_DIST_RAW, 0, "random keys sharing byte 2"},
    {"digit-3-one-bucket", RTO_DIST_RAW, 0, "random keys sharing byte 3"},
    {"digit-4-one-bucket", RTO_DIST_RAW, 1, "random keys sharing byte 4 (u64 only)"},
    {"digit-5-one-bucket", RTO_DIST_RAW, 1, "random keys sharing byte 5 (u64 only)"},
    {"digit-6-one-bucket", RTO_DIST_RAW, 1, "random keys sharing byte 6 (u64 only)"},
    {"digit-7-one-bucket", RTO_DIST_RAW, 1, "random keys sharing byte 7 (u64 only)"},
    {"tile-overflow", RTO_DIST_RAW, 0, "runs of 512 equal keys: >= 256 equal digits in any tile of <= 512"},
};

size_t rto_dist_count(void) { return sizeof dists / sizeof dists[0]; }

const rto_dist_info *rto_dist_at(size_t i) { return i < rto_dist_count() ? &dists[i] : NULL; }

const rto_dist_info *rto_dist_find(const char *name)
{
    for (size_t i = 0; name && i < rto_dist_count(); i++)
        if (strcmp(dists[i].name, name) == 0)
            return &dists[i];
    return NULL;
}

/* A point of a 1e-3 cube centred at c, from three PRNG draws of element i. */
static rto_vec3 in_cube(uint32_t seed, uint32_t i, float c)
{
    rto_vec3 v;
    v.x = c + (rto_unit(seed, 3 * i + 0) - 0.5f) * 1e-3f;
    v.y = c + (rto_unit(seed, 3 * i + 1) - 0.5f) * 1e-3f;
    v.z = c + (rto_unit(seed, 3 * i + 2) - 0.5f) * 1e-3f;
    return v;
}

/* Centroids [begin, end) of n of distribution d into out[0 .. end - begin). */
static void centroids_range(const rto_dist_info *d, uint32_t seed, size_t n, size_t begin, size_t end, rto_vec3 *out)
{
    for (size_t k = begin; k < end; k++) {
        uint32_t i = (uint32_t)k;
        rto_vec3 v = {0.5f, 0.5f, 0.5f};
        if (strcmp(d->name, "uniform") == 0) {
            v.x = rto_unit(seed, 3 * i + 0);
            v.y = rto_unit(seed, 3 * i + 1);
            v.z = rto_unit(seed, 3 * i + 2);
        } else if (strcmp(d->name, "clustered") == 0 || strcmp(d->name, "clustered-far") == 0) {
            /* The lone object is the last index; the seeds' failing case was "a small object next to a tight
             * cluster". */
            if (k + 1 < n)
                v = in_cube(seed, i, 0.5f);
            else if (strcmp(d->name, "clustered-far") == 0)
                v.x = v.y = v.z = 0.0f;
            else
                v.x = 0.5f + 2e-3f;
        } else if (strcmp(d->name, "line") == 0) {
            v.x = rto_unit(seed, i);
        } else if (strcmp(d->name, "two-clusters") == 0) {
            v = in_cube(seed, i, (i & 1u) ? 0.75f : 0.25f);
        } /* one-bucket: the default (0.5, 0.5, 0.5) */
        out[k - begin] = v;
    }
}

rto_status rto_centroids_generate(const char *dist, uint32_t seed, size_t n, rto_vec3 *out, rto_msg *msg)
{
    const rto_dist_info *d = rto_dist_find(dist);
    if (!d || d->kind != RTO_DIST_CENTROID)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%s' is not a centroid distribution", dist ? dist : "(null)");
    /* 3 draws per element index a u32 counter: keep 3n below 2^32. */
    if ((uint64_t)n > RTO_MAX_KEYS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu", n,
                        (unsigned long long)RTO_MAX_KEYS);
    if (n && !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");
    centroids_range(d, seed, n, 0, n, out);
    return RTO_OK;
}

/* Element i of the raw random stream: one word for u32, two (hi, lo) for u64. */
static uint64_t raw(rto_key_format f, uint32_t seed, uint32_t i)
{
    if (f == RTO_KEY_U32)
        return rto_rng(seed, i);
    return ((uint64_t)rto_rng(seed, 2 * i) << 32) | rto_rng(seed, 2 * i + 1);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Centroids per chunk of BLAS keys: 2^16 (768 KiB of centroids in structure-of-arrays form). */
#define KEY_CHUNK ((size_t)1 << 16)

/* rto_blas_keys of the n centroids of d without holding them: the centroid bounds over every chunk (the earlier
 * value kept when equal, as rto_blas_keys does), then each chunk's keys from those bounds, its centroids made again
 * (each is a pure function of seed, n and its index). The bytes of rto_blas_keys over rto_centroids_generate. */
static rto_status blas_keys_chunked(const rto_dist_info *d, uint32_t seed, size_t n, uint64_t *keys, rto_msg *msg)
{
    const size_t cap = n < KEY_CHUNK ? n : KEY_CHUNK;
    rto_vec3 *c = rto__alloc(cap, sizeof *c);
    float *cent = rto__alloc(3 * cap, sizeof *cent);
    if (!c || !cent) {
        free(c);
        free(cent);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu centroids", cap);
    }
    rto__key_part all;
    rto__key_part_init(&all);
    for (size_t begin = 0; begin < n; begin += KEY_CHUNK) {
        const size_t m = n - begin < KEY_CHUNK ? n - begin : KEY_CHUNK;
        centroids_range(d, seed, n, begin, begin + m, c);
        for (size_t k = 0; k < m; k++)
            for (int a = 0; a < 3; a++) {
                const float v = a == 0 ? c[k].x : a == 1 ? c[k].y : c[k].z;
                all.bad |= !isfinite(v);
                all.lo[a] = v < all.lo[a] ? v : all.lo[a];
                all.hi[a] = v > all.hi[a] ? v : all.hi[a];
            }
    }
    /* generated centroids lie in [0, 1]: the bounds are always usable */
    rto_status s = rto__key_bounds_ok(&all, n) ? RTO_OK
                                               : rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unusable centroid bounds of '%s'", d->name);
    float *const soa[3] = {cent, cent + cap, cent + 2 * cap};
    for (size_t begin = 0; !s && begin < n; begin += KEY_CHUNK) {
        const size_t m = n - begin < KEY_CHUNK ? n - begin : KEY_CHUNK;
        centroids_range(d, seed, n, begin, begin + m, c);
        for (size_t k = 0; k < m; k++) {
            soa[0][k] = c[k].x;
            soa[1][k] = c[k].y;
            soa[2][k] = c[k].z;
        }
        /* keys of the chunk's indices 0 .. m - 1, then moved to begin .. (the index is the low 32 bits) */
        rto__blas_keys_part(soa, 0, m, &all, keys + begin);
        for (size_t k = 0; k < m; k++)
            keys[begin + k] += begin;
    }
    free(c);
    free(cent);
    return s;
}

uint64_t rto_keys_memory_bound(const char *dist, rto_key_format f, size_t n)
{
    const rto_dist_info *d = rto_dist_find(dist);
    if (!d)
        return 0;
    if (d->kind == RTO_DIST_CENTROID)
        return f == RTO_KEY_U64 ? (uint64_t)(n < KEY_CHUNK ? n : KEY_CHUNK) * (sizeof(rto_vec3) + 3 * sizeof(float))
                                : (uint64_t)n * sizeof(rto_vec3);
    /* glibc's qsort sorts through a buffer of the whole array */
    return strcmp(d->name, "sorted") == 0 || strcmp(d->name, "reversed") == 0 ? (uint64_t)n * rto_key_size(f) : 0;
}

rto_status rto_keys_generate(const char *dist, rto_key_format f, uint32_t seed, size_t n, void *keys, rto_msg *msg)
{
    const rto_dist_info *d = rto_dist_find(dist);
    if (!d)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown distribution '%s'", dist ? dist : "(null)");
    if (f != RTO_KEY_U32 && f != RTO_KEY_U64)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown key format %d", (int)f);
    if (d->u64_only && f == RTO_KEY_U32)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "distribution '%s' needs 64-bit keys", d->name);
    if ((uint64_t)n > RTO_MAX_KEYS)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "n = %zu exceeds the limit of %llu keys", n,
                        (unsigned long long)RTO_MAX_KEYS);
    if (n && !keys)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL output");

    if (d->kind == RTO_DIST_CENTROID) {
        if (f == RTO_KEY_U32 && n > RTO_TLAS_MAX_INSTANCES)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                            "n = %zu: TLAS keys index at most %u instances (use --format u64)", n,
                            RTO_TLAS_MAX_INSTANCES);
        if (f == RTO_KEY_U64)
            return blas_keys_chunked(d, seed, n, keys, msg);
        rto_vec3 *c = rto__alloc(n, sizeof *c);
        if (!c)
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %zu centroids", n);
        rto_status s = rto_centroids_generate(d->name, seed, n, c, msg);
        if (!s)
            s = rto_tlas_keys(c, n, keys, msg);
        free(c);
        return s;
    }

    const char *name = d->name;
    uint64_t sentinel = rto_key_sentinel(f);
    uint64_t shared = raw(f, STREAM(seed, 3), 0) & 0xffu;
    for (size_t k = 0; k < n; k++) {
        uint32_t i = (uint32_t)k;
        uint64_t v;
        if (strncmp(name, "entropy-", 8) == 0) {
            int rounds = atoi(name + 8);
            v = ~UINT64_C(0);
            for (int r = 0; r < rounds; r++)
                v &= raw(f, STREAM(seed, r), i);
        } else if (strcmp(name, "all-equal") == 0) {
            v = raw(f, seed, 0);
        } else if (strcmp(name, "few-unique") == 0) {
            v = raw(f, STREAM(seed, 1), rto_rng(seed, i) & 7u);
        } else if (strcmp(name, "sentinel-heavy") == 0) {
            v = (rto_rng(STREAM(seed, 2), i) & 3u) ? sentinel : raw(f, seed, i);
        } else if (strncmp(name, "digit-", 6) == 0) {
            unsigned byte = (unsigned)(name[6] - '0');
            v = (raw(f, seed, i) & ~(UINT64_C(0xff) << (8 * byte))) | (shared << (8 * byte));
        } else if (strcmp(name, "tile-overflow") == 0) {
            v = raw(f, seed, i / 512u);
        } else { /* random, sorted, reversed */
            v = raw(f, seed, i);
        }
        rto__key_put(f, keys, k, v);
    }
    int sorted = strcmp(name, "sorted") == 0, reversed = strcmp(name, "reversed") == 0;
    if (sorted || reversed) {
        qsort(keys, n, rto_key_size(f), f == RTO_KEY_U32 ? cmp_u32 : cmp_u64);
        if (reversed) {
            for (size_t a = 0, b = n; a + 1 < b; a++, b--) {
                uint64_t t = rto__key_get(f, keys, a);
                rto__key_put(f, keys, a, rto__key_get(f, keys, b - 1));
                rto__key_put(f, keys, b - 1, t);
            }
        }
    }
    return RTO_OK;
}

/* Size classes: the sizes that break GPU sorts (DESIGN.md §3). */
static int add_size(size_t *sizes, size_t *count, size_t v)
{
    for (size_t i = 0; i < *count; i++)
        if (sizes[i] == v)
            return 0;
    if (*count >= RTO_SIZE_CLASS_MAX)
        return -1;
    sizes[(*count)++] = v;
    return 0;
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

rto_status rto_size_class(const char *name, size_t *sizes, size_t *count, rto_msg *msg)
{
    /* tile: workgroup widths 64 and 256, a 256-thread x 4-key tile of 1024, and 4096. */
    static const size_t tiles[] = {64, 256, 1024, 4096};
    static const size_t large[] = {16384, 65535, 65536};
    int all = name && strcmp(name, "all") == 0, any = 0;
    *count = 0;
    if (all || (name && strcmp(name, "tiny") == 0)) {
        any = 1;
        for (size_t v = 0; v <= 3; v++)
            add_size(sizes, count, v);
    }
    if (all || (name && strcmp(name, "tile") == 0)) {
        any = 1;
        for (size_t t = 0; t < sizeof tiles / sizeof tiles[0]; t++)
            for (size_t v = tiles[t] - 1; v <= tiles[t] + 1; v++)
                add_size(sizes, count, v);
    }
    if (all || (name && strcmp(name, "pow2") == 0)) {
        any = 1;
        for (unsigned k = 2; k <= 16; k++) {
            size_t p = (size_t)1 << k;
            add_size(sizes, count, p - 1);
            add_size(sizes, count, p);
            if (p + 1 <= 65536)
                add_size(sizes, count, p + 1);
        }
    }
    if (all || (name && strcmp(name, "large") == 0)) {
        any = 1;
        for (size_t t = 0; t < sizeof large / sizeof large[0]; t++)
            add_size(sizes, count, large[t]);
    }
    if (!any)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "unknown size class '%s' (tiny, tile, pow2, large, all)",
                        name ? name : "(null)");
    qsort(sizes, *count, sizeof *sizes, cmp_size);
    return RTO_OK;
}
