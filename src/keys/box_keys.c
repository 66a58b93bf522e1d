/* Keys of scene boxes (DESIGN.md §3, docs/bvh.md "Primitive boxes"): the box each key is built from (a triangle's
 * vertex bounds, an instance's world box; the box rules themselves are core/aabb.c's), and the TLAS / BLAS keys of a
 * whole set of boxes. The BVH builders consume these keys; nothing here knows a tree. */
#include "core/aabb.h"
#include "keys_internal.h"

#include <math.h>
#include <stdlib.h>

rto_aabb rto_mesh_triangle_aabb(const rto_mesh *m, uint32_t t)
{
    const float *p0 = &m->positions[3 * (size_t)m->indices[3 * (size_t)t]];
    rto_aabb b = {{p0[0], p0[1], p0[2]}, {p0[0], p0[1], p0[2]}};
    for (int v = 1; v < 3; v++) {
        const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + (size_t)v]];
        rto__aabb_grow(&b, (rto_vec3){p[0], p[1], p[2]});
    }
    return b;
}

rto_status rto_blas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint64_t *keys, rto_msg *msg)
{
    if (n && (!boxes || !keys))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL boxes or keys");
    rto_vec3 *c = rto__alloc(n, sizeof *c);
    if (!c)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t t = 0; t < n; t++)
        c[t] = rto_aabb_centroid(&boxes[t]);
    rto_status s = rto_blas_keys(c, n, keys, msg);
    free(c);
    return s;
}

rto_status rto_mesh_keys(const rto_mesh *mesh, uint64_t *keys, rto_msg *msg)
{
    if (!mesh || (mesh->triangle_count && !keys))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL mesh or keys");
    rto_aabb *b = rto__alloc(mesh->triangle_count, sizeof *b);
    if (!b)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t t = 0; t < mesh->triangle_count; t++)
        b[t] = rto_mesh_triangle_aabb(mesh, t);
    rto_status s = rto_blas_keys_from_boxes(b, mesh->triangle_count, keys, msg);
    free(b);
    return s;
}

rto_status rto_tlas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint32_t *keys, size_t *key_count, rto_msg *msg)
{
    if (!key_count || (n && (!boxes || !keys)))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL boxes, keys or key count");
    *key_count = 0;
    if (n > RTO_TLAS_MAX_INSTANCES)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu instances: a TLAS key indexes at most %u", n,
                        RTO_TLAS_MAX_INSTANCES);
    rto_vec3 *c = rto__alloc(n, sizeof *c);
    uint32_t *index = rto__alloc(n, sizeof *index);
    rto_status s = RTO_OK;
    if (!c || !index)
        s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    /* An empty box (the world box of an instance of an empty BLAS) has no centroid: it gets no key, and the
     * quantisation bounds are those of the keyed boxes only (DESIGN.md §5). */
    size_t m = 0;
    for (size_t i = 0; !s && i < n; i++) {
        if (rto_aabb_is_empty(&boxes[i]))
            continue;
        c[m] = rto_aabb_centroid(&boxes[i]);
        index[m++] = (uint32_t)i;
    }
    if (!s)
        s = rto__tlas_keys_indexed(c, index, m, keys, msg);
    if (!s)
        *key_count = m;
    free(c);
    free(index);
    return s;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* In parts, for the accel's team: the same bytes as the functions above, a static range of items per worker.       */

void rto__key_part_init(rto__key_part *p)
{
    p->u = rto_aabb_empty();
    for (int a = 0; a < 3; a++) {
        p->lo[a] = INFINITY;
        p->hi[a] = -INFINITY;
    }
    p->bad = 0;
}

/* u = u ∪ b, the later operand kept when equal (rto__minf / rto__maxf). */
static inline void union_into(rto_aabb *u, const rto_aabb *b)
{
    u->min.x = rto__minf(u->min.x, b->min.x);
    u->min.y = rto__minf(u->min.y, b->min.y);
    u->min.z = rto__minf(u->min.z, b->min.z);
    u->max.x = rto__maxf(u->max.x, b->max.x);
    u->max.y = rto__maxf(u->max.y, b->max.y);
    u->max.z = rto__maxf(u->max.z, b->max.z);
}

/* One item into a part: its box into the union, its centroid c into the centroid bounds (the earlier kept when
 * equal, as centroid_bounds) and the non-finite flag. */
static inline void part_add(rto__key_part *p, const rto_aabb *b, const float c[3])
{
    union_into(&p->u, b);
    for (int a = 0; a < 3; a++) {
        p->bad |= !isfinite(c[a]);
        p->lo[a] = c[a] < p->lo[a] ? c[a] : p->lo[a];
        p->hi[a] = c[a] > p->hi[a] ? c[a] : p->hi[a];
    }
}

/* Both folds are associative with their tie rules, so parts merged in range order give the sequential bytes: the
 * union keeps the later operand when equal (rto__minf), the centroid bounds the earlier (centroid_bounds). */
void rto__key_part_merge(rto__key_part *into, const rto__key_part *p)
{
    union_into(&into->u, &p->u);
    for (int a = 0; a < 3; a++) {
        into->lo[a] = p->lo[a] < into->lo[a] ? p->lo[a] : into->lo[a];
        into->hi[a] = p->hi[a] > into->hi[a] ? p->hi[a] : into->hi[a];
    }
    into->bad |= p->bad;
}

void rto__blas_boxes_part(const rto_mesh *mesh, size_t begin, size_t end, rto_aabb *boxes, float *const cent[3],
                          rto__key_part *part)
{
    rto__key_part p;
    rto__key_part_init(&p);
    const float *pos = mesh->positions;
    const uint32_t *idx = mesh->indices;
    for (size_t t = begin; t < end; t++) {
        const float *p0 = &pos[3 * (size_t)idx[3 * t]], *p1 = &pos[3 * (size_t)idx[3 * t + 1]],
                    *p2 = &pos[3 * (size_t)idx[3 * t + 2]];
        rto_aabb b;
        b.min.x = rto__minf(rto__minf(p0[0], p1[0]), p2[0]);
        b.min.y = rto__minf(rto__minf(p0[1], p1[1]), p2[1]);
        b.min.z = rto__minf(rto__minf(p0[2], p1[2]), p2[2]);
        b.max.x = rto__maxf(rto__maxf(p0[0], p1[0]), p2[0]);
        b.max.y = rto__maxf(rto__maxf(p0[1], p1[1]), p2[1]);
        b.max.z = rto__maxf(rto__maxf(p0[2], p1[2]), p2[2]);
        boxes[t] = b;
        const float c[3] = {(b.min.x + b.max.x) * 0.5f, (b.min.y + b.max.y) * 0.5f, (b.min.z + b.max.z) * 0.5f};
        for (int a = 0; a < 3; a++)
            cent[a][t] = c[a];
        part_add(&p, &b, c);
    }
    *part = p;
}

int rto__key_bounds_ok(const rto__key_part *all, size_t n)
{
    if (all->bad)
        return 0;
    for (int a = 0; a < 3; a++)
        if (n > 0 && !isfinite(all->hi[a] - all->lo[a]))
            return 0;
    return 1;
}

/* Morton code of 4 quantised triples (SSE2, the baseline of x86-64): rto__spread3 lane by lane. */
#if defined(__SSE2__)
#include <emmintrin.h>

static inline __m128i spread3_x4(__m128i v)
{
    v = _mm_and_si128(_mm_or_si128(v, _mm_slli_epi32(v, 16)), _mm_set1_epi32(0x030000ff));
    v = _mm_and_si128(_mm_or_si128(v, _mm_slli_epi32(v, 8)), _mm_set1_epi32(0x0300f00f));
    v = _mm_and_si128(_mm_or_si128(v, _mm_slli_epi32(v, 4)), _mm_set1_epi32(0x030c30c3));
    v = _mm_and_si128(_mm_or_si128(v, _mm_slli_epi32(v, 2)), _mm_set1_epi32(0x09249249));
    return v;
}

/* min(1023, trunc(((c - lo) / span) * 1024)) of 4 centroids; the values are in [0, 1024], so the 16-bit minimum
 * is the 32-bit one (the high halves are 0). */
static inline __m128i quantise_x4(__m128 c, __m128 lo, __m128 span)
{
    __m128i q = _mm_cvttps_epi32(_mm_mul_ps(_mm_div_ps(_mm_sub_ps(c, lo), span), _mm_set1_ps(1024.0f)));
    return _mm_min_epi16(q, _mm_set1_epi32(1023));
}
#endif

void rto__blas_keys_part(float *const cent[3], size_t begin, size_t end, const rto__key_part *all,
                         uint64_t *keys)
{
    /* quantise() of morton.c: q = min(1023, floor(((c - lo) / (hi - lo)) * 1024)), 0 where hi == lo. c >= lo, so the
     * product is >= 0 (or -0) and truncation is floor. Division stays division (binary32, exact as the scalar one). */
    float lo[3], span[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = all->lo[a];
        span[a] = all->hi[a] - all->lo[a];
    }
    size_t t = begin;
#if defined(__SSE2__)
    if (span[0] != 0 && span[1] != 0 && span[2] != 0) {
        const __m128 lx = _mm_set1_ps(lo[0]), ly = _mm_set1_ps(lo[1]), lz = _mm_set1_ps(lo[2]);
        const __m128 sx = _mm_set1_ps(span[0]), sy = _mm_set1_ps(span[1]), sz = _mm_set1_ps(span[2]);
        for (; t + 4 <= end; t += 4) {
            const __m128i qx = quantise_x4(_mm_loadu_ps(&cent[0][t]), lx, sx);
            const __m128i qy = quantise_x4(_mm_loadu_ps(&cent[1][t]), ly, sy);
            const __m128i qz = quantise_x4(_mm_loadu_ps(&cent[2][t]), lz, sz);
            const __m128i m = _mm_or_si128(_mm_or_si128(_mm_slli_epi32(spread3_x4(qx), 2),
                                                        _mm_slli_epi32(spread3_x4(qy), 1)),
                                           spread3_x4(qz));
            const __m128i idx = _mm_add_epi32(_mm_set1_epi32((int)(uint32_t)t), _mm_set_epi32(3, 2, 1, 0));
            /* key = m << 32 | index: (index, m) pairs as little-endian u64 */
            _mm_storeu_si128((__m128i *)&keys[t], _mm_unpacklo_epi32(idx, m));
            _mm_storeu_si128((__m128i *)&keys[t + 2], _mm_unpackhi_epi32(idx, m));
        }
    }
#endif
    for (; t < end; t++) {
        uint32_t q[3];
        for (int a = 0; a < 3; a++) {
            uint32_t v = span[a] == 0 ? 0 : (uint32_t)(((cent[a][t] - lo[a]) / span[a]) * 1024.0f);
            q[a] = v < 1023 ? v : 1023;
        }
        const uint32_t m = (rto__spread3(q[0]) << 2) | (rto__spread3(q[1]) << 1) | rto__spread3(q[2]);
        keys[t] = ((uint64_t)m << 32) | (uint64_t)t;
    }
}

void rto__instance_boxes_part(const rto_instance *inst, const rto_aabb *blas_bounds, size_t begin, size_t end,
                              rto_aabb *boxes, rto__key_part *part, size_t *keyed)
{
    rto__key_part p;
    rto__key_part_init(&p);
    size_t k = 0;
    for (size_t i = begin; i < end; i++) {
        const rto_aabb w = rto_aabb_transform(&inst[i].obj_to_world, &blas_bounds[inst[i].blas]);
        boxes[i] = w;
        if (rto_aabb_is_empty(&w))
            continue; /* no key (rto_tlas_keys_from_boxes) */
        k++;
        const rto_vec3 cv = rto_aabb_centroid(&w);
        const float c[3] = {cv.x, cv.y, cv.z};
        part_add(&p, &w, c);
    }
    *part = p;
    *keyed = k;
}

void rto__tlas_keys_part(const rto_aabb *boxes, size_t begin, size_t end, const rto__key_part *all, size_t first,
                         uint32_t *keys)
{
    for (size_t i = begin; i < end; i++)
        if (!rto_aabb_is_empty(&boxes[i]))
            keys[first++] = rto__tlas_key(rto_aabb_centroid(&boxes[i]), all->lo, all->hi, (uint32_t)i);
}
