/* SIMD kernels of the bitonic network (sort/bitonic_internal.h): AVX2 and AVX-512, compiled for those instruction sets
 * function by function (the library itself targets baseline x86-64) and chosen at run time by bitonic.c. Each kernel
 * runs exactly the compare-exchanges of the baseline kernels, a vector of slots at a time: keys and carried indices
 * are selected with the same mask, one signed compare of the biased keys XOR the direction mask, so equal keys never
 * swap (DESIGN.md §4). Strides below the vector width pair lanes of one register (a lane permute); the lane's partner
 * decides with the roles reversed, which is the same compare with both operands complemented. */
#include "bitonic_internal.h"

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>

/* Vector-stride pass JV (vectors t and t + JV of the 8 in registers) inside P##_tail. */
#define P_VPASS(P, W, JV)                                                                                              \
    do {                                                                                                               \
        _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++) if (!(t & (JV)))                                           \
            P##_ce(&x[t], &x[t + (JV)], P##_dvec(((p + (size_t)t * (W)) & k) != 0));                                  \
    } while (0)

/* The loops shared by every variant P with W lanes: P##_v a vector of keys with its indices, P##_d a key vector,
 * P##_load / P##_store / P##_dvec / P##_ce / P##_gt / P##_sel / P##_inreg defined per variant before. The pass
 * kernels run a whole call in one direction, so each has an ascending and a descending copy (DESC a constant):
 * descending swaps when y > x, which is the biased compare (x ^ ~0) > (y ^ ~0) without the two XORs. */
#define P_CED(P, x, y, DESC) P##_sel((x), (y), (DESC) ? P##_gt((y)->k, (x)->k) : P##_gt((x)->k, (y)->k))
#define P_BY_DIR(P, NAME)                                                                                              \
    static void P##_##NAME(void *a, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1)               \
    {                                                                                                                  \
        if (desc)                                                                                                      \
            P##_##NAME##_dir(a, ix, 1, base, j, o0, o1);                                                               \
        else                                                                                                           \
            P##_##NAME##_dir(a, ix, 0, base, j, o0, o1);                                                               \
    }
#define DEFINE_PASSES(P, W)                                                                                            \
    static inline __attribute__((always_inline)) void P##_pass1_dir(void *a, uint32_t *ix, const int desc, size_t base, \
                                                                    size_t j, size_t o0, size_t o1)                    \
    {                                                                                                                  \
        for (size_t o = base + o0; o < base + o1; o += (W)) {                                                          \
            P##_v x = P##_load(a, ix, o), y = P##_load(a, ix, o + j);                                                  \
            P_CED(P, &x, &y, desc);                                                                                    \
            P##_store(a, ix, o, x);                                                                                    \
            P##_store(a, ix, o + j, y);                                                                                \
        }                                                                                                              \
    }                                                                                                                  \
    static inline __attribute__((always_inline)) void P##_pass2_dir(void *a, uint32_t *ix, const int desc, size_t base, \
                                                                    size_t j, size_t o0, size_t o1)                    \
    {                                                                                                                  \
        const size_t h = j >> 1;                                                                                       \
        for (size_t o = base + o0; o < base + o1; o += (W)) {                                                          \
            P##_v x0 = P##_load(a, ix, o), x1 = P##_load(a, ix, o + h);                                                \
            P##_v x2 = P##_load(a, ix, o + j), x3 = P##_load(a, ix, o + j + h);                                        \
            P_CED(P, &x0, &x2, desc);                                                                                  \
            P_CED(P, &x1, &x3, desc);                                                                                  \
            P_CED(P, &x0, &x1, desc);                                                                                  \
            P_CED(P, &x2, &x3, desc);                                                                                  \
            P##_store(a, ix, o, x0);                                                                                   \
            P##_store(a, ix, o + h, x1);                                                                               \
            P##_store(a, ix, o + j, x2);                                                                               \
            P##_store(a, ix, o + j + h, x3);                                                                           \
        }                                                                                                              \
    }                                                                                                                  \
    static inline __attribute__((always_inline)) void P##_pass3_dir(void *a, uint32_t *ix, const int desc, size_t base, \
                                                                    size_t j, size_t o0, size_t o1)                    \
    {                                                                                                                  \
        const size_t q = j >> 2;                                                                                       \
        for (size_t o = base + o0; o < base + o1; o += (W)) {                                                          \
            P##_v x[8];                                                                                                \
            _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++)                                                        \
                x[t] = P##_load(a, ix, o + (size_t)t * q);                                                             \
            _Pragma("GCC unroll 4") for (int t = 0; t < 4; t++)                                                        \
                P_CED(P, &x[t], &x[t + 4], desc);                                                                      \
            _Pragma("GCC unroll 2") for (int h = 0; h < 8; h += 4) { /* then each half on its own */                  \
                P_CED(P, &x[h], &x[h + 2], desc);                                                                      \
                P_CED(P, &x[h + 1], &x[h + 3], desc);                                                                  \
                P_CED(P, &x[h], &x[h + 1], desc);                                                                      \
                P_CED(P, &x[h + 2], &x[h + 3], desc);                                                                  \
                _Pragma("GCC unroll 4") for (int t = h; t < h + 4; t++)                                                \
                    P##_store(a, ix, o + (size_t)t * q, x[t]);                                                         \
            }                                                                                                          \
        }                                                                                                              \
    }                                                                                                                  \
    P_BY_DIR(P, pass1)                                                                                                 \
    P_BY_DIR(P, pass2)                                                                                                 \
    P_BY_DIR(P, pass3)

/* The in-register kernels. In P##_tail, a stage of 8 vectors and up has one direction for the whole group (its
 * vector passes take the direction-specialised compare); P##_inregd is the in-register pass of such a stage (a
 * variant without a cheaper one defines it as P##_inreg). */
#define DEFINE_REGS(P, W)                                                                                              \
    static void P##_small(void *a, uint32_t *ix, size_t k, size_t jtop, size_t jbot, size_t lo, size_t hi)             \
    {                                                                                                                  \
        for (size_t p = lo; p < hi; p += (W)) {                                                                        \
            P##_v x = P##_load(a, ix, p);                                                                              \
            for (size_t j = jtop; j >= jbot; j >>= 1)                                                                  \
                x = P##_inreg(x, k, j, p);                                                                             \
            P##_store(a, ix, p, x);                                                                                    \
        }                                                                                                              \
    }                                                                                                                  \
    static inline __attribute__((always_inline)) void P##_group_dir(void *a, uint32_t *ix, size_t k, size_t jtop,      \
                                                                    size_t p, const int desc)                          \
    {                                                                                                                  \
        P##_v x[8];                                                                                                    \
        if (jtop >= 4 * (size_t)(W)) { /* stride 4 vectors, then the halves are independent: one at a time */         \
            _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++) x[t] = P##_load(a, ix, p + (size_t)t * (W));         \
            _Pragma("GCC unroll 4") for (int t = 0; t < 4; t++) P_CED(P, &x[t], &x[t + 4], desc);                    \
            _Pragma("GCC unroll 4") for (int t = 4; t < 8; t++) P##_store(a, ix, p + (size_t)t * (W), x[t]);         \
        } else {                                                                                                       \
            _Pragma("GCC unroll 4") for (int t = 0; t < 4; t++) x[t] = P##_load(a, ix, p + (size_t)t * (W));         \
        }                                                                                                              \
        _Pragma("GCC unroll 2") for (int h = 0; h < 8; h += 4) {                                                       \
            P##_v *y = x + h;                                                                                          \
            if (h)                                                                                                     \
                _Pragma("GCC unroll 4") for (int t = 0; t < 4; t++) y[t] = P##_load(a, ix, p + (size_t)(h + t) * (W)); \
            if (jtop >= 2 * (size_t)(W)) {                                                                             \
                P_CED(P, &y[0], &y[2], desc);                                                                          \
                P_CED(P, &y[1], &y[3], desc);                                                                          \
            }                                                                                                          \
            if (jtop >= (W)) {                                                                                         \
                P_CED(P, &y[0], &y[1], desc);                                                                          \
                P_CED(P, &y[2], &y[3], desc);                                                                          \
            }                                                                                                          \
            _Pragma("GCC unroll 4") for (int t = 0; t < 4; t++) {                                                      \
                _Pragma("GCC unroll 4") for (size_t j = (W) / 2; j; j >>= 1) if (j <= jtop) y[t] =                     \
                    P##_inregd(y[t], k, j, p, desc);                                                                   \
                P##_store(a, ix, p + (size_t)(h + t) * (W), y[t]);                                                     \
            }                                                                                                          \
        }                                                                                                              \
    }                                                                                                                  \
    static void P##_tail(void *a, uint32_t *ix, size_t k0, size_t k1, size_t jtop, size_t lo, size_t hi)              \
    {                                                                                                                  \
        if (k0 >= 8 * (size_t)(W)) { /* then k1 == k0: one stage, one direction per group, straight-line code */       \
            for (size_t p = lo; p < hi; p += 8 * (size_t)(W)) {                                                        \
                if (p & k0)                                                                                            \
                    P##_group_dir(a, ix, k0, jtop, p, 1);                                                              \
                else                                                                                                   \
                    P##_group_dir(a, ix, k0, jtop, p, 0);                                                              \
            }                                                                                                          \
            return;                                                                                                    \
        }                                                                                                              \
        for (size_t p = lo; p < hi; p += 8 * (size_t)(W)) {                                                            \
            P##_v x[8];                                                                                                \
            _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++) x[t] = P##_load(a, ix, p + (size_t)t * (W));         \
            for (size_t k = k0; k <= k1; k <<= 1)                                                                      \
                for (size_t j = k == k0 ? jtop : k >> 1; j; j >>= 1) {                                                 \
                    if (j >= (W)) {                                                                                    \
                        switch (j / (W)) {                                                                             \
                        case 4: P##_VPASS(4); break;                                                                   \
                        case 2: P##_VPASS(2); break;                                                                   \
                        default: P##_VPASS(1); break;                                                                  \
                        }                                                                                              \
                    } else {                                                                                           \
                        _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++) x[t] =                                     \
                            P##_inreg(x[t], k, j, p + (size_t)t * (W));                                                \
                    }                                                                                                  \
                }                                                                                                      \
            _Pragma("GCC unroll 8") for (int t = 0; t < 8; t++) P##_store(a, ix, p + (size_t)t * (W), x[t]);         \
        }                                                                                                              \
    }

#define DEFINE_KERNELS(P, W)                                                                                           \
    DEFINE_PASSES(P, W)                                                                                                \
    DEFINE_REGS(P, W)                                                                                                  \
    static const rto__bitonic_kernels P##_kernels = {(W), P##_pass1, P##_pass2, P##_pass3, P##_small, P##_tail};

/* ---------------------------------------------------------------------------------------------------------------- */
RTO__TARGET_BEGIN("avx2")

/* AVX2, 32-bit keys: 8 keys and 8 indices per vector. */
typedef struct {
    __m256i k, i;
} a2w_v;
typedef __m256i a2w_d;

static inline a2w_v a2w_load(const void *a, const uint32_t *ix, size_t p)
{
    a2w_v v = {_mm256_loadu_si256((const __m256i *)((const int32_t *)a + p)),
               _mm256_loadu_si256((const __m256i *)(ix + p))};
    return v;
}
static inline void a2w_store(void *a, uint32_t *ix, size_t p, a2w_v v)
{
    _mm256_storeu_si256((__m256i *)((int32_t *)a + p), v.k);
    _mm256_storeu_si256((__m256i *)(ix + p), v.i);
}
static inline a2w_d a2w_dvec(int desc) { return _mm256_set1_epi32(desc ? -1 : 0); }
/* Blend through the floating-point form (see a2d_blend below). */
static inline __m256i a2w_blend(__m256i a, __m256i b, __m256i m)
{
    return _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b), _mm256_castsi256_ps(m)));
}
static inline __m256i a2w_gt(__m256i x, __m256i y) { return _mm256_cmpgt_epi32(x, y); }
/* Swap x and y (keys and indices) where m is all ones. */
static inline void a2w_sel(a2w_v *x, a2w_v *y, __m256i m)
{
    const a2w_v nx = {a2w_blend(x->k, y->k, m), a2w_blend(x->i, y->i, m)};
    const a2w_v ny = {a2w_blend(y->k, x->k, m), a2w_blend(y->i, x->i, m)};
    *x = nx;
    *y = ny;
}
static inline void a2w_ce(a2w_v *x, a2w_v *y, a2w_d d)
{
    a2w_sel(x, y, _mm256_cmpgt_epi32(_mm256_xor_si256(x->k, d), _mm256_xor_si256(y->k, d)));
}
/* Pass j < 8 inside the vector of slots p .. p+7: lane l meets lane l ^ j; f is all ones where the lane is the upper
 * of its pair XOR the stage's direction is descending. */
static inline a2w_v a2w_inreg(a2w_v x, size_t k, size_t j, size_t p)
{
    const __m256i L = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), J = _mm256_set1_epi32((int)j);
    const __m256i up = _mm256_cmpeq_epi32(_mm256_and_si256(L, J), J);
    __m256i dl;
    if (k < 8) {
        const __m256i K = _mm256_set1_epi32((int)k);
        dl = _mm256_cmpeq_epi32(_mm256_and_si256(L, K), K);
    } else {
        dl = a2w_dvec((p & k) != 0);
    }
    const __m256i f = _mm256_xor_si256(up, dl), perm = _mm256_xor_si256(L, J);
    const __m256i pk = _mm256_permutevar8x32_epi32(x.k, perm), pi = _mm256_permutevar8x32_epi32(x.i, perm);
    const __m256i m = _mm256_cmpgt_epi32(_mm256_xor_si256(x.k, f), _mm256_xor_si256(pk, f));
    a2w_v r = {a2w_blend(x.k, pk, m), a2w_blend(x.i, pi, m)};
    return r;
}
#define a2w_inregd(x, k, j, p, desc) a2w_inreg(x, k, j, p)
#define a2w_VPASS(JV) P_VPASS(a2w, 8, JV)
DEFINE_KERNELS(a2w, 8)

/* AVX2, 64-bit keys: 4 keys per vector, their 4 indices widened to 64-bit lanes on load (narrowed again on store), so
 * that the compare's 64-bit mask selects keys and indices alike and a lane permute moves both the same way. */

/* Blends through the floating-point forms: the selects are by sign bit either way, and GCC (12) turns the integer
 * _mm*_blendv_epi8 of a 32- or 64-bit compare mask into a byte compare and a blend (two instructions). */
static inline __m256i a2d_blend(__m256i a, __m256i b, __m256i m)
{
    return _mm256_castpd_si256(_mm256_blendv_pd(_mm256_castsi256_pd(a), _mm256_castsi256_pd(b), _mm256_castsi256_pd(m)));
}
/* The low 32 bits of each 64-bit lane, packed into 128 bits. */
static inline __m128i a2d_narrow(__m256i v)
{
    return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(v, _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7)));
}

typedef struct {
    __m256i k, i;
} a2d_v;
typedef __m256i a2d_d;

static inline a2d_v a2d_load(const void *a, const uint32_t *ix, size_t p)
{
    a2d_v v = {_mm256_loadu_si256((const __m256i *)((const int64_t *)a + p)),
               _mm256_cvtepu32_epi64(_mm_loadu_si128((const __m128i *)(ix + p)))};
    return v;
}
static inline void a2d_store(void *a, uint32_t *ix, size_t p, a2d_v v)
{
    _mm256_storeu_si256((__m256i *)((int64_t *)a + p), v.k);
    _mm_storeu_si128((__m128i *)(ix + p), a2d_narrow(v.i));
}
static inline a2d_d a2d_dvec(int desc) { return _mm256_set1_epi64x(desc ? -1 : 0); }
static inline __m256i a2d_gt(__m256i x, __m256i y) { return _mm256_cmpgt_epi64(x, y); }
static inline void a2d_sel(a2d_v *x, a2d_v *y, __m256i m)
{
    const a2d_v nx = {a2d_blend(x->k, y->k, m), a2d_blend(x->i, y->i, m)};
    const a2d_v ny = {a2d_blend(y->k, x->k, m), a2d_blend(y->i, x->i, m)};
    *x = nx;
    *y = ny;
}
static inline void a2d_ce(a2d_v *x, a2d_v *y, a2d_d d)
{
    a2d_sel(x, y, _mm256_cmpgt_epi64(_mm256_xor_si256(x->k, d), _mm256_xor_si256(y->k, d)));
}
static inline a2d_v a2d_inreg(a2d_v x, size_t k, size_t j, size_t p)
{
    const __m256i L = _mm256_setr_epi64x(0, 1, 2, 3), J = _mm256_set1_epi64x((long long)j);
    const __m256i up = _mm256_cmpeq_epi64(_mm256_and_si256(L, J), J);
    __m256i dl;
    if (k < 4) {
        const __m256i K = _mm256_set1_epi64x((long long)k);
        dl = _mm256_cmpeq_epi64(_mm256_and_si256(L, K), K);
    } else {
        dl = a2d_dvec((p & k) != 0);
    }
    const __m256i f = _mm256_xor_si256(up, dl);
    /* 64-bit lane l ^ j is 32-bit lanes (2l, 2l+1) ^ 2j. */
    const __m256i perm = _mm256_xor_si256(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(2 * (int)j));
    const __m256i pk = _mm256_permutevar8x32_epi32(x.k, perm), pi = _mm256_permutevar8x32_epi32(x.i, perm);
    const __m256i m = _mm256_cmpgt_epi64(_mm256_xor_si256(x.k, f), _mm256_xor_si256(pk, f));
    a2d_v r = {a2d_blend(x.k, pk, m), a2d_blend(x.i, pi, m)};
    return r;
}
/* Pass j (1 or 2) of a stage of one direction DESC (a constant): one compare g = x > partner; a lower lane swaps on
 * its own g ascending, on its partner's g descending (the partner then holds y > x), and the upper lane of the pair
 * takes the same decision. */
static inline a2d_v a2d_inregd(a2d_v x, size_t k, size_t j, size_t p, const int desc)
{
    (void)k;
    (void)p;
    __m256i pk, pi, m;
    if (j == 1) {
        pk = _mm256_shuffle_epi32(x.k, 0x4E);
        pi = _mm256_shuffle_epi32(x.i, 0x4E);
        const __m256i g = _mm256_cmpgt_epi64(x.k, pk); /* immediates, also where -O0 folds no constant */
        m = desc ? _mm256_shuffle_epi32(g, 0xEE) : _mm256_shuffle_epi32(g, 0x44);
    } else {
        pk = _mm256_permute4x64_epi64(x.k, 0x4E);
        pi = _mm256_permute4x64_epi64(x.i, 0x4E);
        const __m256i g = _mm256_cmpgt_epi64(x.k, pk);
        m = desc ? _mm256_permute4x64_epi64(g, 0xEE) : _mm256_permute4x64_epi64(g, 0x44);
    }
    a2d_v r = {a2d_blend(x.k, pk, m), a2d_blend(x.i, pi, m)};
    return r;
}
#define a2d_VPASS(JV) P_VPASS(a2d, 4, JV)
DEFINE_KERNELS(a2d, 4)

RTO__TARGET_END

/* ---------------------------------------------------------------------------------------------------------------- */
RTO__TARGET_BEGIN("avx512f,avx512bw,avx512dq,avx512vl")

/* AVX-512, 32-bit keys: 16 keys and 16 indices per vector; masks in mask registers. */
typedef struct {
    __m512i k, i;
} a5w_v;
typedef __m512i a5w_d;

static inline a5w_v a5w_load(const void *a, const uint32_t *ix, size_t p)
{
    a5w_v v = {_mm512_loadu_si512((const void *)((const int32_t *)a + p)), _mm512_loadu_si512((const void *)(ix + p))};
    return v;
}
static inline void a5w_store(void *a, uint32_t *ix, size_t p, a5w_v v)
{
    _mm512_storeu_si512((void *)((int32_t *)a + p), v.k);
    _mm512_storeu_si512((void *)(ix + p), v.i);
}
static inline a5w_d a5w_dvec(int desc) { return _mm512_set1_epi32(desc ? -1 : 0); }
static inline __mmask16 a5w_gt(__m512i x, __m512i y) { return _mm512_cmpgt_epi32_mask(x, y); }
static inline void a5w_sel(a5w_v *x, a5w_v *y, __mmask16 m)
{
    const a5w_v nx = {_mm512_mask_blend_epi32(m, x->k, y->k), _mm512_mask_blend_epi32(m, x->i, y->i)};
    const a5w_v ny = {_mm512_mask_blend_epi32(m, y->k, x->k), _mm512_mask_blend_epi32(m, y->i, x->i)};
    *x = nx;
    *y = ny;
}
static inline void a5w_ce(a5w_v *x, a5w_v *y, a5w_d d)
{
    a5w_sel(x, y, _mm512_cmpgt_epi32_mask(_mm512_xor_si512(x->k, d), _mm512_xor_si512(y->k, d)));
}
static inline a5w_v a5w_inreg(a5w_v x, size_t k, size_t j, size_t p)
{
    const __m512i L = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512i J = _mm512_set1_epi32((int)j);
    const __mmask16 up = _mm512_test_epi32_mask(L, J);
    const __mmask16 dl = k < 16 ? _mm512_test_epi32_mask(L, _mm512_set1_epi32((int)k))
                                : (__mmask16)((p & k) ? 0xFFFF : 0);
    const __mmask16 f = (__mmask16)(up ^ dl);
    const __m512i perm = _mm512_xor_si512(L, J);
    const __m512i pk = _mm512_permutexvar_epi32(perm, x.k), pi = _mm512_permutexvar_epi32(perm, x.i);
    /* ascending-role lanes swap when key > partner, the others when partner > key */
    const __mmask16 m = (__mmask16)(_mm512_mask_cmpgt_epi32_mask((__mmask16)~f, x.k, pk) |
                                    _mm512_mask_cmpgt_epi32_mask(f, pk, x.k));
    a5w_v r = {_mm512_mask_blend_epi32(m, x.k, pk), _mm512_mask_blend_epi32(m, x.i, pi)};
    return r;
}
#define a5w_inregd(x, k, j, p, desc) a5w_inreg(x, k, j, p)
#define a5w_VPASS(JV) P_VPASS(a5w, 16, JV)
DEFINE_KERNELS(a5w, 16)

/* AVX-512, 64-bit keys: 8 keys per vector, their 8 indices in a 256-bit vector, one 8-bit mask for both. */
typedef struct {
    __m512i k;
    __m256i i;
} a5d_v;
typedef __m512i a5d_d;

static inline a5d_v a5d_load(const void *a, const uint32_t *ix, size_t p)
{
    a5d_v v = {_mm512_loadu_si512((const void *)((const int64_t *)a + p)),
               _mm256_loadu_si256((const __m256i *)(ix + p))};
    return v;
}
static inline void a5d_store(void *a, uint32_t *ix, size_t p, a5d_v v)
{
    _mm512_storeu_si512((void *)((int64_t *)a + p), v.k);
    _mm256_storeu_si256((__m256i *)(ix + p), v.i);
}
static inline a5d_d a5d_dvec(int desc) { return _mm512_set1_epi64(desc ? -1 : 0); }
static inline __mmask8 a5d_gt(__m512i x, __m512i y) { return _mm512_cmpgt_epi64_mask(x, y); }
static inline void a5d_sel(a5d_v *x, a5d_v *y, __mmask8 m)
{
    const a5d_v nx = {_mm512_mask_blend_epi64(m, x->k, y->k), _mm256_mask_blend_epi32(m, x->i, y->i)};
    const a5d_v ny = {_mm512_mask_blend_epi64(m, y->k, x->k), _mm256_mask_blend_epi32(m, y->i, x->i)};
    *x = nx;
    *y = ny;
}
static inline void a5d_ce(a5d_v *x, a5d_v *y, a5d_d d)
{
    a5d_sel(x, y, _mm512_cmpgt_epi64_mask(_mm512_xor_si512(x->k, d), _mm512_xor_si512(y->k, d)));
}
static inline a5d_v a5d_inreg(a5d_v x, size_t k, size_t j, size_t p)
{
    const __m512i L = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7), J = _mm512_set1_epi64((long long)j);
    const __mmask8 up = _mm512_test_epi64_mask(L, J);
    const __mmask8 dl = k < 8 ? _mm512_test_epi64_mask(L, _mm512_set1_epi64((long long)k))
                              : (__mmask8)((p & k) ? 0xFF : 0);
    const __mmask8 f = (__mmask8)(up ^ dl);
    const __m512i pk = _mm512_permutexvar_epi64(_mm512_xor_si512(L, J), x.k);
    const __m256i iperm = _mm256_xor_si256(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32((int)j));
    const __m256i pi = _mm256_permutevar8x32_epi32(x.i, iperm);
    const __mmask8 m = (__mmask8)(_mm512_mask_cmpgt_epi64_mask((__mmask8)~f, x.k, pk) |
                                  _mm512_mask_cmpgt_epi64_mask(f, pk, x.k));
    a5d_v r = {_mm512_mask_blend_epi64(m, x.k, pk), _mm256_mask_blend_epi32(m, x.i, pi)};
    return r;
}
#define a5d_inregd(x, k, j, p, desc) a5d_inreg(x, k, j, p)
#define a5d_VPASS(JV) P_VPASS(a5d, 8, JV)
DEFINE_KERNELS(a5d, 8)

RTO__TARGET_END

const rto__bitonic_kernels *rto__bitonic_simd_kernels(rto__bitonic_isa isa, size_t key_size)
{
    if (isa == RTO__BITONIC_AVX2)
        return key_size == 4 ? &a2w_kernels : &a2d_kernels;
    if (isa == RTO__BITONIC_AVX512)
        return key_size == 4 ? &a5w_kernels : &a5d_kernels;
    return NULL;
}

#else

const rto__bitonic_kernels *rto__bitonic_simd_kernels(rto__bitonic_isa isa, size_t key_size)
{
    (void)isa;
    (void)key_size;
    return NULL;
}

#endif
