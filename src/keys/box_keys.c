/* Keys of scene boxes (DESIGN.md §3, docs/bvh.md "Primitive boxes"): the box each key is built from (a triangle's
 * vertex bounds, an instance's world box), its centroid, and the TLAS / BLAS keys of a whole set of boxes. The BVH
 * builders consume these keys; nothing here knows a tree. */
#include "internal.h"

#include <math.h>
#include <stdlib.h>

rto_vec3 rto_aabb_centroid(const rto_aabb *b)
{
    rto_vec3 c = {(b->min.x + b->max.x) * 0.5f, (b->min.y + b->max.y) * 0.5f, (b->min.z + b->max.z) * 0.5f};
    return c;
}

int rto_aabb_is_empty(const rto_aabb *b)
{
    /* Strict comparisons: a NaN bound is not "empty" (it reaches the keys' finite check and is refused there). */
    return b->min.x > b->max.x || b->min.y > b->max.y || b->min.z > b->max.z;
}

rto_aabb rto_aabb_transform(const rto_mat34 *m, const rto_aabb *box)
{
    rto_aabb w = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    if (!(box->min.x <= box->max.x && box->min.y <= box->max.y && box->min.z <= box->max.z))
        return w; /* +-inf corners would give NaN through the matrix */
    /* A fixed corner order and min / max that keep the later operand when equal: the same bytes everywhere, and the
     * same as rto_instance_aabb, which the tests compare it with on every scene. */
    for (int c = 0; c < 8; c++) {
        rto_vec3 p = {(c & 1) ? box->max.x : box->min.x, (c & 2) ? box->max.y : box->min.y,
                      (c & 4) ? box->max.z : box->min.z};
        rto_vec3 q = rto_mat34_point(m, p);
        w.min.x = rto_minf(w.min.x, q.x);
        w.min.y = rto_minf(w.min.y, q.y);
        w.min.z = rto_minf(w.min.z, q.z);
        w.max.x = rto_maxf(w.max.x, q.x);
        w.max.y = rto_maxf(w.max.y, q.y);
        w.max.z = rto_maxf(w.max.z, q.z);
    }
    return w;
}

rto_aabb rto_mesh_triangle_aabb(const rto_mesh *m, uint32_t t)
{
    rto_aabb b;
    const float *p0 = &m->positions[3 * (size_t)m->indices[3 * (size_t)t]];
    b.min.x = b.max.x = p0[0];
    b.min.y = b.max.y = p0[1];
    b.min.z = b.max.z = p0[2];
    for (int v = 1; v < 3; v++) {
        const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + (size_t)v]];
        b.min.x = rto_minf(b.min.x, p[0]);
        b.min.y = rto_minf(b.min.y, p[1]);
        b.min.z = rto_minf(b.min.z, p[2]);
        b.max.x = rto_maxf(b.max.x, p[0]);
        b.max.y = rto_maxf(b.max.y, p[1]);
        b.max.z = rto_maxf(b.max.z, p[2]);
    }
    return b;
}

rto_status rto_blas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint64_t *keys, rto_msg *msg)
{
    if (n && (!boxes || !keys))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL boxes or keys");
    rto_vec3 *c = rto_alloc(n, sizeof *c);
    if (!c)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t t = 0; t < n; t++)
        c[t] = rto_aabb_centroid(&boxes[t]);
    rto_status s = rto_blas_keys(c, n, keys, msg);
    free(c);
    return s;
}

rto_status rto_mesh_keys(const rto_mesh *mesh, uint64_t *keys, rto_msg *msg)
{
    if (!mesh || (mesh->triangle_count && !keys))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL mesh or keys");
    rto_aabb *b = rto_alloc(mesh->triangle_count, sizeof *b);
    if (!b)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t t = 0; t < mesh->triangle_count; t++)
        b[t] = rto_mesh_triangle_aabb(mesh, t);
    rto_status s = rto_blas_keys_from_boxes(b, mesh->triangle_count, keys, msg);
    free(b);
    return s;
}

rto_status rto_tlas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint32_t *keys, size_t *key_count, rto_msg *msg)
{
    if (!key_count || (n && (!boxes || !keys)))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL boxes, keys or key count");
    *key_count = 0;
    if (n > RTO_TLAS_MAX_INSTANCES)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "%zu instances: a TLAS key indexes at most %u", n,
                        RTO_TLAS_MAX_INSTANCES);
    rto_vec3 *c = rto_alloc(n, sizeof *c);
    uint32_t *index = rto_alloc(n, sizeof *index);
    rto_status s = RTO_OK;
    if (!c || !index)
        s = rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
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
        s = rto_tlas_keys_indexed(c, index, m, keys, msg);
    if (!s)
        *key_count = m;
    free(c);
    free(index);
    return s;
}
