/* The bitonic network's kernels (sort/bitonic.c, sort/bitonic_simd.c) and the entry points the tests and benchmarks
 * use to run one instruction-set path against the kept scalar reference. Not installed; not exported. */
#ifndef RTO_BITONIC_INTERNAL_H
#define RTO_BITONIC_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** Instruction-set paths of the network. Every path runs the same compare-exchanges and gives the same bytes. */
typedef enum rto__bitonic_isa {
    RTO__BITONIC_AUTO = 0,     /* the widest the CPU has (or RTO_BITONIC_ISA from the environment, capped by it) */
    RTO__BITONIC_BASELINE = 1, /* branch-free scalar, fused and cache-blocked: any x86-64 (or other) CPU */
    RTO__BITONIC_AVX2 = 2,
    RTO__BITONIC_AVX512 = 3,   /* AVX-512 F, BW, DQ and VL */
    RTO__BITONIC_ISA_COUNT = 4
} rto__bitonic_isa;

/** "auto", "baseline", "avx2", "avx512". */
const char *rto__bitonic_isa_name(rto__bitonic_isa isa);
/** Whether this CPU (and build) can run the path; AUTO and BASELINE always can. */
int rto__bitonic_isa_supported(rto__bitonic_isa isa);

/**
 * The scalar network as first written, one pass at a time with a branch per compare-exchange: the reference every
 * other path is tested against, pass by pass (arguments as rto_bitonic_sort).
 */
rto_status rto__bitonic_sort_scalar(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                                    void *checkpoints, rto_msg *msg);

/**
 * rto_bitonic_sort on a chosen path (an unsupported one is refused: RTO_ERR_UNSUPPORTED) and thread count (0: one per
 * online CPU; output bytes never depend on it).
 */
rto_status rto__bitonic_sort_with(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                                  void *checkpoints, rto__bitonic_isa isa, uint32_t threads, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Kernels. The working array holds the keys XOR their sign bit (so that signed SIMD compares order them as unsigned
 * keys) and a parallel uint32 array of carried source indices. A compare-exchange of slots x < y with direction mask
 * d (0 ascending, all ones descending) swaps both arrays exactly when (a[x] ^ d) > (a[y] ^ d) as signed integers:
 * a[x] > a[y] ascending, a[x] < a[y] descending, never for equal keys (DESIGN.md §4). */

/** The kernels of one path for one key width. `lanes` slots per vector (1 for the baseline). */
typedef struct rto__bitonic_kernels {
    uint32_t lanes;
    /** Pass j on pairs (base + o, base + o + j) for o in [o0, o1): base a multiple of 2j, o1 - o0 and o0 multiples of
     * lanes, j >= lanes. desc: the block's direction (all slots of a 2j block share it). */
    void (*pass1)(void *a, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1);
    /** Passes j and j/2 fused, slots base + o + {0, j/2, j, 3j/2}, o in [o0, o1) within [0, j/2); j/2 >= lanes. */
    void (*pass2)(void *a, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1);
    /** Passes j, j/2 and j/4 fused, slots base + o + t j/4 (t = 0..7), o within [0, j/4); j/4 >= lanes. */
    void (*pass3)(void *a, uint32_t *ix, int desc, size_t base, size_t j, size_t o0, size_t o1);
    /** Passes jtop, jtop/2, ..., jbot of stage k (jbot <= jtop < lanes) inside each vector of [lo, hi) (lo, hi
     * multiples of lanes); NULL for the baseline. */
    void (*small)(void *a, uint32_t *ix, size_t k, size_t jtop, size_t jbot, size_t lo, size_t hi);
    /** Stages k0 .. k1 (k1 <= 8 lanes) on groups of 8 vectors of [lo, hi) held in registers: stage k0 from stride
     * jtop, the others from k/2, down to stride 1. lo, hi multiples of 8 lanes. NULL for the baseline. */
    void (*tail)(void *a, uint32_t *ix, size_t k0, size_t k1, size_t jtop, size_t lo, size_t hi);
} rto__bitonic_kernels;

/** The kernels of a SIMD path (AVX2 or AVX512) for 4- or 8-byte keys; NULL when not built. */
const rto__bitonic_kernels *rto__bitonic_simd_kernels(rto__bitonic_isa isa, size_t key_size);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
