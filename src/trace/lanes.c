/* The tracer's SIMD lanes (trace/lanes_kernel.h, DESIGN.md §6): 8 rays at a time with AVX2, 16 with AVX-512,
 * compiled for those instruction sets function by function (the library itself targets baseline x86-64) and taken by
 * rto_trace when RTO_TRACE_ISA asks for them and the CPU has them (traverse.c; the packed path, packed.c, is the
 * default, being the faster on the machines measured: docs/trace.md, "Benchmark"). Each lane is one ray with its own stacks and its own traversal order, as a GPU thread is;
 * only the slab tests and the Möller–Trumbore tests of the lanes that reached one run side by side, lane-wise, with
 * the scalar tracer's operations in its order. Records and counters equal the scalar tracer's bit for bit
 * (unit.trace_lanes holds them to it on every ray set; bench_trace compares the records too). */
#include "internal.h"
#include "trace_internal.h"

#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>

/* What a lane wants next. */
enum { LANE_NONE = 0, LANE_BOX = 1, LANE_TRIANGLE = 2 };

/* One lane's ray and traversal: the ray's record so far, its counters, its stacks, the BLAS in hand. */
typedef struct rto__lane {
    const rto_wf_ray *ray; /* NULL: none in flight */
    size_t index;          /* of the ray, and of its record */
    float winv[3];         /* the world ray's inverse direction */
    int found, done, object; /* a hit so far; TERMINATE_ON_FIRST_HIT hit; the lane holds the object-space ray */
    uint32_t inst;           /* the instance entered */
    const rto_accel_blas *blas;
    const rto_mesh *mesh;
    uint32_t prim;                     /* the staged triangle */
    uint32_t inst_hit, prim_hit;       /* the best hit */
    rto_tri_hit h;
    rto_trace_counters c;
    rto__trace_entry *tstack, *bstack;
    uint32_t ttop, btop;
    uint32_t lref, rref; /* the staged box pair's children, */
    int lvalid, rvalid;  /* whether each is tested (a sweep TLAS's EMPTY child is not), */
    int blas_pair;       /* and whose stack they go on */
} rto__lane;

/* After a box pair's slab tests: the children hit pushed farther first (§6; equal entry t: left visited first). */
static inline void rto__lane_push(rto__lane *s, int hl, float tl, int hr, float tr)
{
    rto__trace_entry *stack = s->blas_pair ? s->bstack : s->tstack;
    uint32_t *top = s->blas_pair ? &s->btop : &s->ttop;
    s->c.box_tests += (uint32_t)(s->lvalid + s->rvalid);
    hl = hl && s->lvalid;
    hr = hr && s->rvalid;
    if (hl && hr) {
        if (tl <= tr) {
            stack[(*top)++] = (rto__trace_entry){s->rref, tr};
            stack[(*top)++] = (rto__trace_entry){s->lref, tl};
        } else {
            stack[(*top)++] = (rto__trace_entry){s->lref, tl};
            stack[(*top)++] = (rto__trace_entry){s->rref, tr};
        }
    } else if (hl) {
        stack[(*top)++] = (rto__trace_entry){s->lref, tl};
    } else if (hr) {
        stack[(*top)++] = (rto__trace_entry){s->rref, tr};
    }
}

/* After a triangle's test: culling, then the hit taken as the best (1: the caller sets the lane's best t). */
static inline int rto__lane_take(rto__lane *s, int ok, const rto_tri_hit *h)
{
    s->c.triangle_tests++;
    if (!ok || rto__triangle_culled(s->ray->flags, h->det))
        return 0;
    s->h = *h;
    s->inst_hit = s->inst;
    s->prim_hit = s->prim;
    s->found = 1;
    if (s->ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) { /* the whole traversal ends */
        s->done = 1;
        s->btop = 0;
    }
    return 1;
}

#define PN_(p, x) p##_##x
#define PN__(p, x) PN_(p, x)
#define PN(x) PN__(LANES_PREFIX, x)

/* ---------------------------------------------------------------------------------------------------------------- */
RTO__TARGET_BEGIN("avx2")

#define VEC_AVX2
#include "vec_ops.h"
#define LANES_PREFIX lanes8
#define VLD _mm256_load_ps
#define VST _mm256_store_ps
#define VGATHER(rows, f)                                                                                             \
    _mm256_i32gather_ps((rows), _mm256_add_epi32(_mm256_setr_epi32(0, 16, 32, 48, 64, 80, 96, 112),                 \
                                                 _mm256_set1_epi32(f)), 4)
#include "lanes_kernel.h"
#undef LANES_PREFIX
#undef VLD
#undef VST
#undef VGATHER
#include "vec_ops_end.h"

RTO__TARGET_END

/* ---------------------------------------------------------------------------------------------------------------- */
RTO__TARGET_BEGIN("avx512f,avx512bw,avx512dq,avx512vl")

#define VEC_AVX512
#include "vec_ops.h"
#define LANES_PREFIX lanes16
#define VLD _mm512_load_ps
#define VST _mm512_store_ps
#define VGATHER(rows, f)                                                                                             \
    _mm512_i32gather_ps(_mm512_add_epi32(_mm512_setr_epi32(0, 16, 32, 48, 64, 80, 96, 112, 128, 144, 160, 176, 192,  \
                                                           208, 224, 240), _mm512_set1_epi32(f)), (rows), 4)
#include "lanes_kernel.h"
#undef LANES_PREFIX
#undef VLD
#undef VST
#undef VGATHER
#include "vec_ops_end.h"

RTO__TARGET_END

const rto__trace_lanes *rto__trace_lanes_kernel(rto__trace_isa isa)
{
    if (isa == RTO__TRACE_AVX2)
        return &lanes8_kernel;
    if (isa == RTO__TRACE_AVX512)
        return &lanes16_kernel;
    return NULL;
}

#else

const rto__trace_lanes *rto__trace_lanes_kernel(rto__trace_isa isa)
{
    (void)isa;
    return NULL;
}

#endif
