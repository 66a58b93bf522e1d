/* The vector operations the tracer's SIMD kernels are written in (trace/lanes_kernel.h, trace/groups_kernel.h), for
 * one instruction set: define VEC_AVX2 or VEC_AVX512 and include this inside that set's RTO__TARGET_BEGIN, then
 * trace/vec_ops_end.h after the kernel. W: lanes; VF: W floats, VI: W int32. VSET1, VZERO, VLDU / VSTU (unaligned),
 * VADD, VSUB, VMUL, VDIV (one binary32 operation per lane), VMIN / VMAX (the second operand when unordered or equal,
 * as minps / maxps: exactly rto__minf's a < b ? a : b and rto__maxf's a > b ? a : b), VABS, VSEL_LT(x, y, a, b) (a
 * where x < y, else b); VLE / VLT / VGE / VNEQ / VNGT give a bit mask of lanes (bit l for lane l; ordered compares,
 * VNEQ and VNGT unordered as C's != and !(a > b)); VI_ZERO, VI_STU. No header guard: included once per set. */
#if defined(VEC_AVX2)
#define W 8
#define VF __m256
#define VI __m256i
#define VSET1 _mm256_set1_ps
#define VZERO _mm256_setzero_ps
#define VLDU _mm256_loadu_ps
#define VSTU _mm256_storeu_ps
#define VADD _mm256_add_ps
#define VSUB _mm256_sub_ps
#define VMUL _mm256_mul_ps
#define VDIV _mm256_div_ps
#define VMIN _mm256_min_ps
#define VMAX _mm256_max_ps
#define VABS(x) _mm256_andnot_ps(_mm256_set1_ps(-0.0f), (x))
#define VSEL_LT(x, y, a, b) _mm256_blendv_ps((b), (a), _mm256_cmp_ps((x), (y), _CMP_LT_OQ))
#define VCMP_(a, b, p) ((uint32_t)_mm256_movemask_ps(_mm256_cmp_ps((a), (b), (p))))
#define VI_ZERO _mm256_setzero_si256
#define VI_STU(p, v) _mm256_storeu_si256((__m256i *)(void *)(p), (v))
#elif defined(VEC_AVX512)
#define W 16
#define VF __m512
#define VI __m512i
#define VSET1 _mm512_set1_ps
#define VZERO _mm512_setzero_ps
#define VLDU _mm512_loadu_ps
#define VSTU _mm512_storeu_ps
#define VADD _mm512_add_ps
#define VSUB _mm512_sub_ps
#define VMUL _mm512_mul_ps
#define VDIV _mm512_div_ps
#define VMIN _mm512_min_ps
#define VMAX _mm512_max_ps
#define VABS _mm512_abs_ps
#define VSEL_LT(x, y, a, b) _mm512_mask_blend_ps(_mm512_cmp_ps_mask((x), (y), _CMP_LT_OQ), (b), (a))
#define VCMP_(a, b, p) ((uint32_t)_mm512_cmp_ps_mask((a), (b), (p)))
#define VI_ZERO _mm512_setzero_si512
#define VI_STU(p, v) _mm512_storeu_si512((void *)(p), (v))
#else
#error "trace/vec_ops.h: define VEC_AVX2 or VEC_AVX512"
#endif
#define VLE(a, b) VCMP_(a, b, _CMP_LE_OQ)
#define VLT(a, b) VCMP_(a, b, _CMP_LT_OQ)
#define VGE(a, b) VCMP_(a, b, _CMP_GE_OQ)
#define VNEQ(a, b) VCMP_(a, b, _CMP_NEQ_UQ)
#define VNGT(a, b) VCMP_(a, b, _CMP_NGT_UQ)
