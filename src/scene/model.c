/* The scene model (DESIGN.md §5) shared by every loader: warnings, UTF-8-safe names, instance transforms computed in
 * binary64 and rounded once (§2), object / world bounds in binary32, and the validation every loaded scene passes. */
#include "core/aabb.h"
#include "internal.h"
#include "model.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rto__load_desc_resolve(const rto_scene_load_desc *desc, rto_scene_load_desc *out)
{
    memset(out, 0, sizeof *out);
    if (desc)
        *out = *desc;
    if (!out->texture_budget_bytes)
        out->texture_budget_bytes = RTO_SCENE_TEXTURE_BUDGET_DEFAULT;
}

rto_camera rto_camera_default(void)
{
    rto_camera c;
    memset(&c, 0, sizeof c);
    snprintf(c.name, sizeof c.name, "default");
    c.position = (rto_vec3){0.0f, 2.0f, 5.0f};
    c.target = (rto_vec3){0.0f, 0.0f, 0.0f};
    c.up = (rto_vec3){0.0f, 1.0f, 0.0f};
    c.fov_y = (float)(3.14159265358979323846 / 3.0); /* 60 degrees, seed 002 §2.2 */
    c.aspect = 0.0f;
    /* The seed's mat4Perspective takes near / far but does not give the Stage-2 values; these are the conventional
     * ones. They do not change ray directions beyond rounding. */
    c.znear = 0.1f;
    c.zfar = 100.0f;
    return c;
}

void rto__scene_warn(rto_scene *scene, const char *fmt, ...)
{
    if (scene->warning_count < RTO_SCENE_MAX_WARNINGS) {
        char *w = scene->warnings[scene->warning_count];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(w, sizeof scene->warnings[0], fmt, ap);
        va_end(ap);
        /* One line each, valid UTF-8: a warning quoting file content must not break the CLI's line-per-warning
         * output, and vsnprintf or a "%.60s" may have cut a character. */
        for (char *p = w; *p; p++)
            if (*p == '\n' || *p == '\r' || *p == '\t')
                *p = ' ';
        rto__utf8_fix(w, sizeof scene->warnings[0]);
    }
    if (scene->warning_count < UINT32_MAX)
        scene->warning_count++;
}

int rto__scene_add_source(rto_scene *scene, const char *path)
{
    if (scene->source_count == UINT32_MAX)
        return 0;
    char **grown = realloc(scene->sources, (scene->source_count + 1u) * sizeof *grown);
    if (!grown)
        return 0;
    scene->sources = grown;
    if (!(grown[scene->source_count] = strdup(path)))
        return 0;
    scene->source_count++;
    return 1;
}

void rto_scene_destroy(rto_scene *scene)
{
    if (!scene)
        return;
    for (uint32_t i = 0; scene->meshes && i < scene->mesh_count; i++) {
        free(scene->meshes[i].positions);
        free(scene->meshes[i].normals);
        free(scene->meshes[i].uvs);
        free(scene->meshes[i].indices);
    }
    for (uint32_t i = 0; scene->textures && i < scene->texture_count; i++)
        free(scene->textures[i].rgba);
    free(scene->meshes);
    free(scene->instances);
    free(scene->materials);
    free(scene->textures);
    free(scene->cameras);
    for (uint32_t i = 0; scene->sources && i < scene->source_count; i++)
        free(scene->sources[i]);
    free(scene->sources);
    free(scene);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Transforms and bounds                                                                                            */

rto_status rto_instance_set_transform(rto_instance *inst, const double m[3][4], rto_msg *msg)
{
    if (!inst || !m)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL instance or matrix");
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (!isfinite(m[r][c]))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "transform element [%d][%d] is not finite (%g)", r, c,
                                m[r][c]);
    /* Inverse of the linear part through the adjugate: inv = adj(A) / det, adj(A)[r][c] = cofactor(A)[c][r]. */
    double cof[3][3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            const int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            /* The cyclic index order gives the signed cofactor directly. */
            cof[r][c] = m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
        }
    const double det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    /* Hadamard: |det| <= product of the row lengths, with equality for orthogonal rows. Their ratio measures how
     * close the rows are to dependent, independently of scale, so a legitimate tiny uniform scale is accepted while
     * a collapsed (or numerically collapsed) axis is refused. */
    double rows = 1.0;
    for (int r = 0; r < 3; r++)
        rows *= sqrt(m[r][0] * m[r][0] + m[r][1] * m[r][1] + m[r][2] * m[r][2]);
    if (det == 0.0 || !isfinite(det) || !(fabs(det) > 1e-12 * rows))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "singular transform (determinant %g)", det);
    double inv[3][4];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            inv[r][c] = cof[c][r] / det;
    /* 0 - x rather than -x: the same value, but +0 (not -0) for a zero translation, so an identity transform
     * inverts to the identity's exact bytes. */
    for (int r = 0; r < 3; r++)
        inv[r][3] = 0.0 - ((inv[r][0] * m[0][3] + inv[r][1] * m[1][3]) + inv[r][2] * m[2][3]);
    rto_mat34 o2w, w2o;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++) {
            o2w.m[r][c] = (float)m[r][c];
            w2o.m[r][c] = (float)inv[r][c];
            if (!isfinite(o2w.m[r][c]) || !isfinite(w2o.m[r][c]))
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "transform or its inverse overflows binary32 (element [%d][%d]: %g, inverse %g)", r, c,
                                m[r][c], inv[r][c]);
        }
    inst->obj_to_world = o2w;
    inst->world_to_obj = w2o;
    return RTO_OK;
}

rto_aabb rto_mesh_aabb(const rto_mesh *mesh)
{
    rto_aabb b = rto_aabb_empty();
    if (!mesh || !mesh->indices || !mesh->positions)
        return b;
    /* Referenced vertices only, in index order (the order fixes which of +0 / -0 a bound keeps). */
    for (size_t i = 0; i < 3 * (size_t)mesh->triangle_count; i++) {
        uint32_t v = mesh->indices[i];
        if (v >= mesh->vertex_count)
            continue; /* never happens for a validated scene; a raw mesh must not make us read out of bounds */
        const float *p = &mesh->positions[3 * (size_t)v];
        rto__aabb_grow(&b, (rto_vec3){p[0], p[1], p[2]});
    }
    return b;
}

static int coord_ok(float v)
{
    return fabsf(v) <= RTO_SCENE_MAX_COORD; /* false for NaN */
}

int rto__aabb_in_range(const rto_aabb *b)
{
    const float v[6] = {b->min.x, b->min.y, b->min.z, b->max.x, b->max.y, b->max.z};
    for (int i = 0; i < 6; i++)
        if (isnan(v[i]))
            return 0;
    if (rto_aabb_is_empty(b))
        return 1; /* +inf / -inf: no triangles, nothing to key */
    for (int i = 0; i < 6; i++)
        if (!coord_ok(v[i]))
            return 0;
    return 1;
}

rto_aabb rto_instance_aabb(const rto_scene *scene, uint32_t instance)
{
    if (!scene || instance >= scene->instance_count || scene->instances[instance].blas >= scene->mesh_count)
        return rto_aabb_empty();
    const rto_instance *in = &scene->instances[instance];
    rto_aabb ob = rto_mesh_aabb(&scene->meshes[in->blas]);
    return rto_aabb_transform(&in->obj_to_world, &ob);
}

rto_aabb rto_scene_aabb(const rto_scene *scene)
{
    rto_aabb b = rto_aabb_empty();
    if (!scene || !scene->instance_count)
        return b;
    /* Each mesh's object box once, not once per instance: a scene of 65,536 instances of one mesh stays cheap. */
    rto_aabb *ob = rto__alloc(scene->mesh_count, sizeof *ob);
    for (uint32_t m = 0; ob && m < scene->mesh_count; m++)
        ob[m] = rto_mesh_aabb(&scene->meshes[m]);
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const rto_instance *in = &scene->instances[i];
        if (in->blas >= scene->mesh_count)
            continue;
        rto_aabb mb = ob ? ob[in->blas] : rto_mesh_aabb(&scene->meshes[in->blas]);
        rto_aabb w = rto_aabb_transform(&in->obj_to_world, &mb);
        if (rto_aabb_is_empty(&w) || rto__aabb_has_nan(&w))
            continue;
        rto__aabb_grow(&b, w.min);
        rto__aabb_grow(&b, w.max);
    }
    free(ob);
    return b;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Validation shared by every loader                                                                                */

static int all_finite(const float *v, size_t n, size_t *bad)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) {
            *bad = i;
            return 0;
        }
    return 1;
}

static int mat_finite(const rto_mat34 *m)
{
    size_t bad;
    return all_finite(&m->m[0][0], 12, &bad);
}

static rto_status validate_mesh(const rto_scene *s, uint32_t i, rto_msg *msg)
{
    const rto_mesh *me = &s->meshes[i];
    size_t bad;
    if ((me->vertex_count && !me->positions) || (me->triangle_count && !me->indices))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u ('%s'): missing positions or indices", i, me->name);
    if (!all_finite(me->positions, 3 * (size_t)me->vertex_count, &bad)) {
        const float *p = &me->positions[bad / 3 * 3];
        return rto__fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite position (%g, %g, %g)", i,
                        me->name, bad / 3, (double)p[0], (double)p[1], (double)p[2]);
    }
    for (size_t k = 0; k < 3 * (size_t)me->vertex_count; k++)
        if (!coord_ok(me->positions[k]))
            return rto__fail(msg, RTO_ERR_UNSUPPORTED,
                            "mesh %u ('%s'): vertex %zu has coordinate %g, beyond +-%g (box centroids would overflow "
                            "binary32)",
                            i, me->name, k / 3, (double)me->positions[k], (double)RTO_SCENE_MAX_COORD);
    if (me->normals && !all_finite(me->normals, 3 * (size_t)me->vertex_count, &bad))
        return rto__fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite normal", i, me->name, bad / 3);
    if (me->uvs && !all_finite(me->uvs, 2 * (size_t)me->vertex_count, &bad))
        return rto__fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite texture coordinate", i,
                        me->name, bad / 2);
    for (size_t k = 0; k < 3 * (size_t)me->triangle_count; k++)
        if (me->indices[k] >= me->vertex_count)
            return rto__fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): triangle %zu has vertex index %u >= vertex count %u",
                            i, me->name, k / 3, me->indices[k], me->vertex_count);
    if (me->material < -1 || (me->material >= 0 && (uint32_t)me->material >= s->material_count))
        return rto__fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): material %d out of range (%u materials)", i, me->name,
                        (int)me->material, s->material_count);
    return RTO_OK;
}

rto_status rto__scene_validate(const rto_scene *s, rto_msg *msg)
{
    if ((s->mesh_count && !s->meshes) || (s->instance_count && !s->instances) ||
        (s->material_count && !s->materials) || (s->texture_count && !s->textures) || (s->camera_count && !s->cameras))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "scene arrays missing");
    if (s->mesh_count > RTO_SCENE_MAX_MESHES)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%u meshes: at most %u are supported", s->mesh_count,
                        RTO_SCENE_MAX_MESHES);
    if (s->instance_count > RTO_SCENE_MAX_INSTANCES)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%u instances: at most %u are supported", s->instance_count,
                        RTO_SCENE_MAX_INSTANCES);
    uint64_t tris = 0, verts = 0;
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        tris += s->meshes[i].triangle_count;
        verts += s->meshes[i].vertex_count;
        if (tris > RTO_SCENE_MAX_TRIANGLES || verts > RTO_SCENE_MAX_VERTICES)
            return rto__fail(msg, RTO_ERR_UNSUPPORTED,
                            "more than %u triangles or %u vertices in the meshes: too large for this oracle",
                            RTO_SCENE_MAX_TRIANGLES, RTO_SCENE_MAX_VERTICES);
        rto_status st = validate_mesh(s, i, msg);
        if (st)
            return st;
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rto_instance *in = &s->instances[i];
        if (in->blas >= s->mesh_count)
            return rto__fail(msg, RTO_ERR_PARSE, "instance %u: BLAS %u out of range (%u meshes)", i, in->blas,
                            s->mesh_count);
        if (!mat_finite(&in->obj_to_world) || !mat_finite(&in->world_to_obj))
            return rto__fail(msg, RTO_ERR_PARSE, "instance %u: non-finite transform", i);
        if (in->custom_index > RTO_INSTANCE_CUSTOM_INDEX_MASK || in->mask > 0xFFu)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %u: customIndex or mask wider than 24 / 8 bits",
                            i);
    }
    /* World bounds: each mesh's object box once, then through every instance (as rto_instance_aabb computes it). */
    rto_aabb *ob = rto__alloc(s->mesh_count, sizeof *ob);
    if (!ob)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t m = 0; m < s->mesh_count; m++)
        ob[m] = rto_mesh_aabb(&s->meshes[m]);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rto_instance *in = &s->instances[i];
        const rto_aabb w = rto_aabb_transform(&in->obj_to_world, &ob[in->blas]);
        if (!rto__aabb_in_range(&w)) {
            const uint32_t m = in->blas;
            free(ob);
            return rto__fail(msg, RTO_ERR_UNSUPPORTED,
                            "instance %u (mesh %u '%s'): world bounds (%g, %g, %g) .. (%g, %g, %g) reach beyond +-%g "
                            "(box centroids would overflow binary32)",
                            i, m, s->meshes[m].name, (double)w.min.x, (double)w.min.y, (double)w.min.z,
                            (double)w.max.x, (double)w.max.y, (double)w.max.z, (double)RTO_SCENE_MAX_COORD);
        }
    }
    free(ob);
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rto_material *ma = &s->materials[i];
        size_t bad;
        if (!all_finite(ma->base_color, 4, &bad) || !all_finite(ma->emissive, 3, &bad))
            return rto__fail(msg, RTO_ERR_PARSE, "material %u: non-finite colour factor", i);
        if (ma->base_color_texture < -1 ||
            (ma->base_color_texture >= 0 && (uint32_t)ma->base_color_texture >= s->texture_count))
            return rto__fail(msg, RTO_ERR_PARSE, "material %u: texture %d out of range (%u textures)", i,
                            (int)ma->base_color_texture, s->texture_count);
    }
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const rto_texture *t = &s->textures[i];
        if ((uint64_t)t->width * t->height > RTO_SCENE_MAX_TEXELS || (t->width && t->height && !t->rgba))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "texture %u ('%s'): bad size %ux%u", i, t->name, t->width,
                            t->height);
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *c = &s->cameras[i];
        const float v[12] = {c->position.x, c->position.y, c->position.z, c->target.x, c->target.y, c->target.z,
                             c->up.x,       c->up.y,       c->up.z,       c->fov_y,    c->aspect,   c->znear};
        size_t bad;
        if (!all_finite(v, 12, &bad) || !(c->fov_y > 0.0f) || !(c->aspect >= 0.0f) || !(c->zfar >= 0.0f))
            return rto__fail(msg, RTO_ERR_PARSE, "camera %u ('%s'): non-finite or out-of-range parameters", i, c->name);
    }
    return RTO_OK;
}

