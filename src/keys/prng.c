/* The counter-based PRNG shared with GPU harnesses (DESIGN.md §3). Written so the same three lines port to JS
 * (Math.imul) and WGSL (u32 wrap-around) unchanged. */
#include "internal.h"

uint32_t rto_hash32(uint32_t x)
{
    x ^= x >> 16;
    x *= UINT32_C(0x7feb352d);
    x ^= x >> 15;
    x *= UINT32_C(0x846ca68b);
    x ^= x >> 16;
    return x;
}

uint32_t rto_rng(uint32_t seed, uint32_t i) { return rto_hash32(i ^ rto_hash32(seed)); }

float rto_unit(uint32_t seed, uint32_t i)
{
    /* 24 bits fit a binary32 mantissa exactly, so the value is the same on every platform. */
    return (float)(rto_rng(seed, i) >> 8) * 0x1p-24f;
}
