/* The fluid stage's private helpers (DESIGN.md §12): the splat's reference evaluation of one (particle, voxel) pair,
 * the conformance model's interval for it, the voxels a particle may reach, the resolve and its admissible range,
 * and trilinear sampling of the resolved volume for the raymarch. Not installed. */
#ifndef RTO_FLUID_INTERNAL_H
#define RTO_FLUID_INTERNAL_H

#include "rtoracle.h"

#include <stdbool.h>

/* After the public header: its declarations keep default visibility (a hidden redeclaration would hide them from the
 * shared library under link-time optimisation). */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** Component a (0 x, 1 y, 2 z) of v, and a pointer to it. */
static inline float rto__v3get(const rto_vec3 *v, int a) { return a == 0 ? v->x : a == 1 ? v->y : v->z; }
static inline float *rto__v3ptr(rto_vec3 *v, int a) { return a == 0 ? &v->x : a == 1 ? &v->y : &v->z; }

/** The most (particle, candidate voxel) pairs one splat visits (§12.2): more is refused before any work. */
#define RTO_FLUID_PAIRS_MAX (UINT64_C(1) << 33)

/** Voxel centre i on axis a (§12.2): bounds_min_a + (f32(i) + 0.5) * voxel_size_a in binary32. */
float rto__fluid_centre(const rto_fluid_uniforms *u, int a, uint32_t i);

/** The reference contribution of the particle at p to the voxel centred at c (§12.2, binary32, no contraction):
 * u32((h - r)^2 * S * scale) truncated (saturated at 2^32 - 1) where r < h, else 0. *inside (may be NULL) is set
 * when r < h. */
uint32_t rto__fluid_contribution(const rto_fluid_uniforms *u, const float p[3], const float c[3], bool *inside);

/** The conformance model's interval of one contribution (§12.2): [*lo, *hi]. *reach is set when the GPU's r may be
 * below h (then the pair may contribute). Certain iff *lo == *hi. */
void rto__fluid_interval(const rto_fluid_uniforms *u, const float p[3], const float c[3], uint32_t *lo, uint32_t *hi,
                         bool *reach);

/** The voxels [lo[a], hi[a]] (inclusive, per axis) the particle at p may reach under the model (a superset of those
 * with r < h, one voxel wider); false when none. */
bool rto__fluid_voxel_range(const rto_fluid_uniforms *u, const float p[3], uint32_t lo[3], uint32_t hi[3]);

/** The resolve (§12.2): binary16 (round to nearest even) of f32(v) / scale. */
uint16_t rto__fluid_resolve(uint32_t v, float scale);
/** The admissible binary16 bit patterns of the resolve of v: [*lo, *hi] (positive values, ordered as their bits);
 * nearest: only round-to-nearest-even binary16 stores, else round toward zero too. */
void rto__fluid_resolve_range(uint32_t v, float scale, bool nearest, uint16_t *lo, uint16_t *hi);
/** binary16 of a non-negative float rounded toward zero (finite values never give infinity). */
uint16_t rto__f16_rtz(float f);

/** The model's per-voxel sums (§12.2) of particles pos: lo, hi (u64 each, NULL to skip) and reach (1 where some
 * particle may reach the voxel; NULL to skip); *uncertain counts pairs whose interval holds more than one value. */
rto_status rto__fluid_model(const rto_fluid_uniforms *u, const float *pos, uint64_t count, uint32_t threads,
                            uint64_t *lo, uint64_t *hi, uint8_t *reach, uint64_t *uncertain, rto_msg *msg);

/**
 * Trilinear sample of the resolved density (volume_f16, (nz, ny, nx)) at the world point p, as a GPU's
 * textureSampleLevel of the rgba16float texture (level 0, clamp-to-edge, linear filter) reads it, in binary32 with
 * exact binary16 texels: texel coordinates t_a = (p_a - bounds_min_a) / (bounds_max_a - bounds_min_a) * res_a - 0.5,
 * clamped neighbours, weights t_a - floor(t_a), lerps in x, then y, then z. Points outside the box read the edge.
 */
float rto__fluid_sample(const rto_splat *s, const float p[3]);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
