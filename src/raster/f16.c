/* binary16 (DESIGN.md §11.4): conversion from binary32 rounded to nearest even, as a render target of RG16float /
 * RGBA16float stores it, the same rounded toward zero (what check-vbuffer's rounding test looks for), the exact
 * conversion back; and the octahedral normal encoding of Cigolle et al. 2014. */
#include "internal.h"
#include "raster/raster_internal.h"

#include <math.h>
#include <string.h>

static uint16_t f16_from_f32(float f, int nearest)
{
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    const uint16_t sign = (uint16_t)((x >> 16) & 0x8000u);
    const uint32_t exp = (x >> 23) & 0xffu, man = x & 0x7fffffu;
    if (exp == 0xffu) /* infinity, or NaN kept quiet with the top mantissa bits */
        return (uint16_t)(sign | 0x7c00u | (man ? 0x200u | (man >> 13) : 0u));
    const int e = (int)exp - 127 + 15;
    if (e >= 31) /* 2^16 and beyond: infinity, or the largest finite value toward zero */
        return (uint16_t)(sign | (nearest ? 0x7c00u : 0x7bffu));
    uint32_t h, rem, mid;
    if (e <= 0) { /* a subnormal binary16, or zero */
        if (e < -10)
            return sign; /* under half the smallest subnormal (2^-25): zero either way */
        const uint32_t m = man | 0x800000u;
        const int shift = 14 - e;
        h = m >> shift;
        rem = m & ((1u << shift) - 1u);
        mid = 1u << (shift - 1);
    } else {
        h = ((uint32_t)e << 10) | (man >> 13);
        rem = man & 0x1fffu;
        mid = 0x1000u;
    }
    /* A carry out of the mantissa moves into the exponent, which is the right result (up to infinity). */
    if (nearest && (rem > mid || (rem == mid && (h & 1u))))
        h++;
    return (uint16_t)(sign | h);
}

uint16_t rto_f16_from_f32(float f)
{
    return f16_from_f32(f, 1);
}

uint16_t rto__f16_from_f32_rtz(float f)
{
    return f16_from_f32(f, 0);
}

float rto_f16_to_f32(uint16_t h)
{
    const uint32_t sign = (uint32_t)(h & 0x8000u) << 16, exp = (h >> 10) & 0x1fu, man = h & 0x3ffu;
    uint32_t x;
    if (exp == 0x1fu)
        x = sign | 0x7f800000u | (man << 13);
    else if (exp != 0)
        x = sign | ((exp - 15 + 127) << 23) | (man << 13);
    else if (man == 0)
        x = sign;
    else { /* subnormal: man * 2^-24, exact in binary32 */
        const float v = (float)man * 0x1p-24f;
        memcpy(&x, &v, sizeof x);
        x |= sign;
    }
    float f;
    memcpy(&f, &x, sizeof f);
    return f;
}

static float sign_not_zero(float v)
{
    return v >= 0.0f ? 1.0f : -1.0f;
}

void rto__oct_encode(const float n[3], float out[2])
{
    const float l1 = (fabsf(n[0]) + fabsf(n[1])) + fabsf(n[2]);
    if (!(l1 > 0.0f)) {
        out[0] = out[1] = 0.0f;
        return;
    }
    float px = n[0] / l1, py = n[1] / l1;
    if (n[2] < 0.0f) {
        const float ox = (1.0f - fabsf(py)) * sign_not_zero(px);
        const float oy = (1.0f - fabsf(px)) * sign_not_zero(py);
        px = ox;
        py = oy;
    }
    out[0] = px;
    out[1] = py;
}

void rto__oct_decode(const float e[2], float n[3])
{
    float x = e[0], y = e[1];
    const float z = (1.0f - fabsf(x)) - fabsf(y);
    if (z < 0.0f) {
        const float ox = (1.0f - fabsf(y)) * sign_not_zero(x);
        const float oy = (1.0f - fabsf(x)) * sign_not_zero(y);
        x = ox;
        y = oy;
    }
    const float l = sqrtf((x * x + y * y) + z * z);
    n[0] = l > 0.0f ? x / l : 0.0f;
    n[1] = l > 0.0f ? y / l : 0.0f;
    n[2] = l > 0.0f ? z / l : 0.0f;
}
