/* Private pieces of the key stage (src/keys/): TLAS keys of a subset of instances, the Morton bit spread, and the
 * BLAS / TLAS keys in parts for a team (box_keys.c), which the accelerator build (bvh/accel.c) and the key
 * distributions (dist.c) run. Not installed; not exported. */
#ifndef RTO_KEYS_INTERNAL_H
#define RTO_KEYS_INTERNAL_H

#include "../core/internal.h"

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** TLAS keys whose index field is index[i] (the instance a centroid belongs to) instead of i: the keys of a subset
 * of instances, quantised over that subset's bounds. index == NULL means index[i] = i (rto_tlas_keys). */
rto_status rto__tlas_keys_indexed(const rto_vec3 *centroids, const uint32_t *index, size_t n, uint32_t *keys,
                                 rto_msg *msg);

/** Spreads the low 10 bits of v so that bit b lands on bit 3b (keys/morton.c's Morton codes). */
static inline uint32_t rto__spread3(uint32_t v)
{
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

/* BLAS keys in parts (keys/box_keys.c), for a team: each worker takes a static range of triangles. */

/** What one range of triangles contributes to the mesh: the union of its boxes in triangle order (rto__minf /
 * rto__maxf: the later operand kept when equal), the bounds of its centroids (the earlier kept, as rto_blas_keys),
 * and whether a centroid is not finite. Parts combine in range order with rto__key_part_merge. */
typedef struct rto__key_part {
    rto_aabb u;
    float lo[3], hi[3];
    int bad;
} rto__key_part;
void rto__key_part_init(rto__key_part *p);
void rto__key_part_merge(rto__key_part *into, const rto__key_part *p);
/** Boxes of triangles [begin, end) of a mesh (rto_mesh_triangle_aabb) into boxes[begin..end), their centroids into
 * cent[axis][begin..end), and their part. */
void rto__blas_boxes_part(const rto_mesh *mesh, size_t begin, size_t end, rto_aabb *boxes, float *const cent[3],
                          rto__key_part *part);
/** The mesh's centroid bounds are usable for keys (every centroid finite, spans within binary32). */
int rto__key_bounds_ok(const rto__key_part *all, size_t n);
/** BLAS keys [begin, end) (rto_blas_keys' bytes) from the centroids and the whole mesh's part. */
void rto__blas_keys_part(float *const cent[3], size_t begin, size_t end, const rto__key_part *all,
                         uint64_t *keys);
/** World boxes of instances [begin, end): rto_aabb_transform of their BLAS's bounds; with the part of the non-empty
 * ones (their union and centroid bounds) and their number (*keyed). */
void rto__instance_boxes_part(const rto_instance *inst, const rto_aabb *blas_bounds, size_t begin, size_t end,
                              rto_aabb *boxes, rto__key_part *part, size_t *keyed);
/** TLAS key of centroid c (rto__tlas_keys_indexed's bytes), with centroid bounds lo / hi. */
uint32_t rto__tlas_key(rto_vec3 c, const float lo[3], const float hi[3], uint32_t index);
/** TLAS keys of the non-empty boxes among [begin, end) (rto_tlas_keys_from_boxes' bytes), written from keys[first] on,
 * with the bounds of all the keyed centroids (merged parts of rto__instance_boxes_part). */
void rto__tlas_keys_part(const rto_aabb *boxes, size_t begin, size_t end, const rto__key_part *all, size_t first,
                         uint32_t *keys);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
