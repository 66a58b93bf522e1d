/* Boxes and 3x4 matrices (DESIGN.md §3, §5): the one home of the rules every stage shares — what the empty box is,
 * when a box is empty, when two boxes are the same, a point and a box through a transform. The keys, the scene
 * model, the trees and their validators and the commands all ask here; none has a predicate of its own. */
#include "core/aabb.h"
#include "internal.h"

#include <math.h>

rto_aabb rto_aabb_empty(void)
{
    rto_aabb b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}

int rto_aabb_is_empty(const rto_aabb *b)
{
    /* Strict comparisons: a NaN bound is not "empty" (it reaches the finite checks and is refused there). */
    return b->min.x > b->max.x || b->min.y > b->max.y || b->min.z > b->max.z;
}

int rto_aabb_equal(const rto_aabb *a, const rto_aabb *b)
{
    return a->min.x == b->min.x && a->min.y == b->min.y && a->min.z == b->min.z && a->max.x == b->max.x &&
           a->max.y == b->max.y && a->max.z == b->max.z;
}

int rto_aabb_is_finite(const rto_aabb *b)
{
    const float mn[3] = {b->min.x, b->min.y, b->min.z}, mx[3] = {b->max.x, b->max.y, b->max.z};
    for (int k = 0; k < 3; k++)
        if (!isfinite(mn[k]) || !isfinite(mx[k]) || !(mn[k] <= mx[k]))
            return 0;
    return 1;
}

int rto__aabb_has_nan(const rto_aabb *b)
{
    return isnan(b->min.x) || isnan(b->min.y) || isnan(b->min.z) || isnan(b->max.x) || isnan(b->max.y) ||
           isnan(b->max.z);
}

rto_aabb rto__aabb_of(const float mn[3], const float mx[3])
{
    rto_aabb b = {{mn[0], mn[1], mn[2]}, {mx[0], mx[1], mx[2]}};
    return b;
}

void rto__aabb_grow(rto_aabb *b, rto_vec3 p)
{
    b->min.x = rto__minf(b->min.x, p.x);
    b->min.y = rto__minf(b->min.y, p.y);
    b->min.z = rto__minf(b->min.z, p.z);
    b->max.x = rto__maxf(b->max.x, p.x);
    b->max.y = rto__maxf(b->max.y, p.y);
    b->max.z = rto__maxf(b->max.z, p.z);
}

rto_vec3 rto_aabb_centroid(const rto_aabb *b)
{
    rto_vec3 c = {(b->min.x + b->max.x) * 0.5f, (b->min.y + b->max.y) * 0.5f, (b->min.z + b->max.z) * 0.5f};
    return c;
}

rto_vec3 rto_mat34_point(const rto_mat34 *m, rto_vec3 p)
{
    rto_vec3 q;
    q.x = ((m->m[0][0] * p.x + m->m[0][1] * p.y) + m->m[0][2] * p.z) + m->m[0][3];
    q.y = ((m->m[1][0] * p.x + m->m[1][1] * p.y) + m->m[1][2] * p.z) + m->m[1][3];
    q.z = ((m->m[2][0] * p.x + m->m[2][1] * p.y) + m->m[2][2] * p.z) + m->m[2][3];
    return q;
}

rto_aabb rto_aabb_transform(const rto_mat34 *m, const rto_aabb *box)
{
    rto_aabb w = rto_aabb_empty();
    if (rto_aabb_is_empty(box) || rto__aabb_has_nan(box))
        return w; /* +-inf corners would give NaN through the matrix */
    /* A fixed corner order and min / max that keep the later operand when equal: the same bytes everywhere, and the
     * same as rto_instance_aabb, which the tests compare it with on every scene. */
    for (int c = 0; c < 8; c++) {
        rto_vec3 p = {(c & 1) ? box->max.x : box->min.x, (c & 2) ? box->max.y : box->min.y,
                      (c & 4) ? box->max.z : box->min.z};
        rto__aabb_grow(&w, rto_mat34_point(m, p));
    }
    return w;
}
