/* The brute-force reference of DESIGN.md §6 for tests and cross-checks: every triangle of every instance, in index
 * order, with no tree in between. It shares only the per-triangle test with the tracer (the object-space ray and
 * Möller–Trumbore are the contract itself), so a tree that loses a hit, visits in the wrong order or prunes with the
 * wrong t shows up as a different answer; the same primitive gives the same t bit for bit. */
#include "internal.h"
#include "trace_internal.h"

typedef struct brute_job {
    const rto_scene *scene;
    const rto_wf_ray *rays;
    rto_hit_record *hits;
} brute_job;

static void brute_range(void *ctx, uint32_t worker, size_t begin, size_t end)
{
    const brute_job *job = ctx;
    const rto_scene *sc = job->scene;
    for (size_t i = begin; i < end; i++) {
        const rto_wf_ray *ray = &job->rays[i];
        const int first_hit = (ray->flags & RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0;
        float best_t = ray->t_max;
        rto_hit_record hit = rto_hit_record_miss(ray->t_max);
        for (uint32_t k = 0; k < sc->instance_count; k++) {
            const rto_instance *in = &sc->instances[k];
            const rto_mesh *mesh = &sc->meshes[in->blas];
            if (!(in->mask & ray->cull_mask) || !mesh->triangle_count)
                continue;
            float o[3], d[3];
            rto_ray_to_object(&in->world_to_obj, ray->origin, ray->dir, o, d);
            for (uint32_t p = 0; p < mesh->triangle_count; p++) {
                rto_tri_hit h;
                if (rto__mesh_triangle_hit(mesh, p, o, d, ray->t_min, best_t, ray->flags, &h)) {
                    best_t = h.t;
                    hit = rto_hit_record_make(in, k, p, &h);
                    if (first_hit)
                        goto done;
                }
            }
        }
    done:
        job->hits[i] = hit;
    }
}

rto_status rto_trace_brute(const rto_scene *scene, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                           rto_hit_record *hits, rto_msg *msg)
{
    if (!scene)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene");
    if (n && !hits)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL hit output");
    rto_status s = rto__rays_check(rays, n, msg);
    if (s)
        return s;
    brute_job job = {scene, rays, hits};
    rto__parallel_ranges(n, desc ? desc->threads : 0, brute_range, &job);
    return RTO_OK;
}
