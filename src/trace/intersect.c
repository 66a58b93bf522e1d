/* The two intersection tests of DESIGN.md §6 and the pieces of a hit record, in exactly the contract's operation
 * order: every product, sum and comparison below is one binary32 operation (-ffp-contract=off keeps them apart), so a
 * GPU that evaluates the same expressions without fused multiply-adds gets the same bits, and one that fuses them
 * stays within the §9 tolerances. */
#include "internal.h"
#include "trace_internal.h"

#include <math.h>
#include <string.h>

void rto_ray_inv_dir(const float dir[3], float inv_dir[3]) { rto__ray_inv_dir(dir, inv_dir); }

int rto_slab_test(const float bmin[3], const float bmax[3], const float origin[3], const float inv_dir[3],
                  float t_min, float best_t, float *t_entry)
{
    float t;
    if (!rto__slab(bmin, bmax, origin, inv_dir, t_min, best_t, &t))
        return 0;
    if (t_entry)
        *t_entry = t;
    return 1;
}

int rto_triangle_intersect(const float v0[3], const float v1[3], const float v2[3], const float origin[3],
                           const float dir[3], float t_min, float best_t, rto_tri_hit *hit)
{
    return rto__triangle_intersect(v0, v1, v2, origin, dir, t_min, best_t, hit);
}

void rto_ray_to_object(const rto_mat34 *world_to_obj, const float origin[3], const float dir[3], float obj_origin[3],
                       float obj_dir[3])
{
    rto__ray_to_object(world_to_obj, origin, dir, obj_origin, obj_dir);
}

rto_hit_record rto_hit_record_miss(float t_max)
{
    rto_hit_record h;
    rto__hit_record_store_miss(&h, t_max);
    return h;
}

rto_hit_record rto_hit_record_make(const rto_instance *instance, uint32_t inst, uint32_t prim, const rto_tri_hit *hit)
{
    rto_hit_record h;
    rto__hit_record_store(&h, instance, inst, prim, hit);
    return h;
}

int rto__triangle_culled(uint32_t flags, float det)
{
    return ((flags & RTO_RAY_FLAG_CULL_BACK_FACING) && det < 0.0f) ||
           ((flags & RTO_RAY_FLAG_CULL_FRONT_FACING) && det > 0.0f);
}

int rto__mesh_triangle_hit(const rto_mesh *mesh, uint32_t prim, const float o[3], const float d[3], float t_min,
                           float best_t, uint32_t flags, rto_tri_hit *hit)
{
    const uint32_t *ix = &mesh->indices[3 * (size_t)prim];
    const float *p = mesh->positions;
    return rto__triangle_hit(&p[3 * (size_t)ix[0]], &p[3 * (size_t)ix[1]], &p[3 * (size_t)ix[2]], o, d, t_min, best_t,
                             flags, hit);
}

int rto_instance_triangle_hit(const rto_instance *instance, const rto_mesh *mesh, uint32_t prim,
                              const rto_wf_ray *ray, rto_tri_hit *hit)
{
    if (!instance || !mesh || !ray || prim >= mesh->triangle_count || !(instance->mask & ray->cull_mask))
        return 0;
    float o[3], d[3];
    rto_ray_to_object(&instance->world_to_obj, ray->origin, ray->dir, o, d);
    rto_tri_hit h;
    const int ok = rto__mesh_triangle_hit(mesh, prim, o, d, ray->t_min, ray->t_max, ray->flags, &h);
    if (hit)
        *hit = h;
    return ok;
}

rto_instance rto_instance_from_record(const rto_instance_record *record)
{
    rto_instance in;
    memset(&in, 0, sizeof in);
    memcpy(in.obj_to_world.m, record->obj_to_world, sizeof in.obj_to_world.m);
    memcpy(in.world_to_obj.m, record->world_to_obj, sizeof in.world_to_obj.m);
    in.blas = record->blas;
    in.custom_index = record->custom_index;
    in.mask = record->mask;
    in.sbt_offset = record->sbt_offset;
    in.flags = record->flags;
    return in;
}

/* Whether a ray's first eight floats (origin, tMin, direction, tMax) are finite and tMin <= tMax: an exponent of all
 * ones is an infinity or a NaN. A loop without early exits, which the compiler turns into vector code. */
static int ray_traceable(const rto_wf_ray *r)
{
    uint32_t u[8], bad = 0;
    memcpy(u, r, sizeof u);
    for (int k = 0; k < 8; k++)
        bad |= (u[k] & 0x7f800000u) == 0x7f800000u;
    return !bad && !(r->t_min > r->t_max);
}

rto_status rto__rays_check(const rto_wf_ray *rays, size_t n, rto_msg *msg)
{
    if (n && !rays)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL rays");
    size_t i = 0;
    while (i < n && ray_traceable(&rays[i]))
        i++;
    if (i == n)
        return RTO_OK;
    const rto_wf_ray *r = &rays[i]; /* the first ray that cannot be traced: which check it fails */
    int finite = isfinite(r->t_min) && isfinite(r->t_max);
    for (int a = 0; a < 3; a++)
        finite = finite && isfinite(r->origin[a]) && isfinite(r->dir[a]);
    if (!finite)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "ray %zu has a non-finite origin, direction, tMin or tMax", i);
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "ray %zu has tMin %.9g > tMax %.9g", i, (double)r->t_min,
                     (double)r->t_max);
}
