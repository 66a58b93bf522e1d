/* The scene model (DESIGN.md §5): loading by spec, validation shared by every loader, instance transforms computed in
 * binary64 and rounded once (§2), and object / world bounds in binary32. */
#include "internal.h"
#include "gltf.h"
#include "scene_internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
        /* One line each: a warning quoting file content must not break the CLI's line-per-warning output. */
        for (char *p = w; *p; p++)
            if (*p == '\n' || *p == '\r' || *p == '\t')
                *p = ' ';
    }
    if (scene->warning_count < UINT32_MAX)
        scene->warning_count++;
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
    free(scene);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Transforms and bounds                                                                                            */

rto_status rto_instance_set_transform(rto_instance *inst, const double m[3][4], rto_msg *msg)
{
    if (!inst || !m)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL instance or matrix");
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (!isfinite(m[r][c]))
                return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "transform element [%d][%d] is not finite (%g)", r, c,
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
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "singular transform (determinant %g)", det);
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
                return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                "transform or its inverse overflows binary32 (element [%d][%d]: %g, inverse %g)", r, c,
                                m[r][c], inv[r][c]);
        }
    inst->obj_to_world = o2w;
    inst->world_to_obj = w2o;
    return RTO_OK;
}

rto_vec3 rto_mat34_point(const rto_mat34 *m, rto_vec3 p)
{
    rto_vec3 q;
    q.x = ((m->m[0][0] * p.x + m->m[0][1] * p.y) + m->m[0][2] * p.z) + m->m[0][3];
    q.y = ((m->m[1][0] * p.x + m->m[1][1] * p.y) + m->m[1][2] * p.z) + m->m[1][3];
    q.z = ((m->m[2][0] * p.x + m->m[2][1] * p.y) + m->m[2][2] * p.z) + m->m[2][3];
    return q;
}

static rto_aabb aabb_empty(void)
{
    rto_aabb b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}

static void aabb_grow(rto_aabb *b, rto_vec3 p)
{
    b->min.x = rto_minf(b->min.x, p.x);
    b->min.y = rto_minf(b->min.y, p.y);
    b->min.z = rto_minf(b->min.z, p.z);
    b->max.x = rto_maxf(b->max.x, p.x);
    b->max.y = rto_maxf(b->max.y, p.y);
    b->max.z = rto_maxf(b->max.z, p.z);
}

static int aabb_is_empty(const rto_aabb *b)
{
    return !(b->min.x <= b->max.x && b->min.y <= b->max.y && b->min.z <= b->max.z);
}

rto_aabb rto_mesh_aabb(const rto_mesh *mesh)
{
    rto_aabb b = aabb_empty();
    if (!mesh || !mesh->indices || !mesh->positions)
        return b;
    /* Referenced vertices only, in index order (the order fixes which of +0 / -0 a bound keeps). */
    for (size_t i = 0; i < 3 * (size_t)mesh->triangle_count; i++) {
        uint32_t v = mesh->indices[i];
        if (v >= mesh->vertex_count)
            continue; /* never happens for a validated scene; a raw mesh must not make us read out of bounds */
        const float *p = &mesh->positions[3 * (size_t)v];
        aabb_grow(&b, (rto_vec3){p[0], p[1], p[2]});
    }
    return b;
}

static rto_aabb box_through(const rto_mat34 *m, const rto_aabb *box)
{
    rto_aabb w = aabb_empty();
    if (aabb_is_empty(box))
        return w; /* +-inf corners would give NaN through the matrix */
    /* Corner c takes max on axis a when bit a of c is set: a fixed order, so the result is the same bytes
     * everywhere. */
    for (int c = 0; c < 8; c++) {
        rto_vec3 p = {(c & 1) ? box->max.x : box->min.x, (c & 2) ? box->max.y : box->min.y,
                      (c & 4) ? box->max.z : box->min.z};
        aabb_grow(&w, rto_mat34_point(m, p));
    }
    return w;
}

rto_aabb rto_instance_aabb(const rto_scene *scene, uint32_t instance)
{
    if (!scene || instance >= scene->instance_count || scene->instances[instance].blas >= scene->mesh_count)
        return aabb_empty();
    const rto_instance *in = &scene->instances[instance];
    rto_aabb ob = rto_mesh_aabb(&scene->meshes[in->blas]);
    return box_through(&in->obj_to_world, &ob);
}

rto_aabb rto_scene_aabb(const rto_scene *scene)
{
    rto_aabb b = aabb_empty();
    if (!scene || !scene->instance_count)
        return b;
    /* Each mesh's object box once, not once per instance: a scene of 65,536 instances of one mesh stays cheap. */
    rto_aabb *ob = rto_alloc(scene->mesh_count, sizeof *ob);
    for (uint32_t m = 0; ob && m < scene->mesh_count; m++)
        ob[m] = rto_mesh_aabb(&scene->meshes[m]);
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const rto_instance *in = &scene->instances[i];
        if (in->blas >= scene->mesh_count)
            continue;
        rto_aabb mb = ob ? ob[in->blas] : rto_mesh_aabb(&scene->meshes[in->blas]);
        rto_aabb w = box_through(&in->obj_to_world, &mb);
        if (aabb_is_empty(&w))
            continue;
        aabb_grow(&b, w.min);
        aabb_grow(&b, w.max);
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
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "mesh %u ('%s'): missing positions or indices", i, me->name);
    if (!all_finite(me->positions, 3 * (size_t)me->vertex_count, &bad)) {
        const float *p = &me->positions[bad / 3 * 3];
        return rto_fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite position (%g, %g, %g)", i,
                        me->name, bad / 3, (double)p[0], (double)p[1], (double)p[2]);
    }
    if (me->normals && !all_finite(me->normals, 3 * (size_t)me->vertex_count, &bad))
        return rto_fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite normal", i, me->name, bad / 3);
    if (me->uvs && !all_finite(me->uvs, 2 * (size_t)me->vertex_count, &bad))
        return rto_fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): vertex %zu has a non-finite texture coordinate", i,
                        me->name, bad / 2);
    for (size_t k = 0; k < 3 * (size_t)me->triangle_count; k++)
        if (me->indices[k] >= me->vertex_count)
            return rto_fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): triangle %zu has vertex index %u >= vertex count %u",
                            i, me->name, k / 3, me->indices[k], me->vertex_count);
    if (me->material < -1 || (me->material >= 0 && (uint32_t)me->material >= s->material_count))
        return rto_fail(msg, RTO_ERR_PARSE, "mesh %u ('%s'): material %d out of range (%u materials)", i, me->name,
                        (int)me->material, s->material_count);
    return RTO_OK;
}

rto_status rto__scene_validate(const rto_scene *s, rto_msg *msg)
{
    if ((s->mesh_count && !s->meshes) || (s->instance_count && !s->instances) ||
        (s->material_count && !s->materials) || (s->texture_count && !s->textures) || (s->camera_count && !s->cameras))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "scene arrays missing");
    if (s->mesh_count > RTO_SCENE_MAX_MESHES)
        return rto_fail(msg, RTO_ERR_UNSUPPORTED, "%u meshes: at most %u are supported", s->mesh_count,
                        RTO_SCENE_MAX_MESHES);
    if (s->instance_count > RTO_SCENE_MAX_INSTANCES)
        return rto_fail(msg, RTO_ERR_UNSUPPORTED, "%u instances: at most %u are supported", s->instance_count,
                        RTO_SCENE_MAX_INSTANCES);
    uint64_t tris = 0, verts = 0;
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        tris += s->meshes[i].triangle_count;
        verts += s->meshes[i].vertex_count;
        if (tris > RTO_SCENE_MAX_TRIANGLES || verts > RTO_SCENE_MAX_VERTICES)
            return rto_fail(msg, RTO_ERR_UNSUPPORTED,
                            "more than %u triangles or %u vertices in the meshes: too large for this oracle",
                            RTO_SCENE_MAX_TRIANGLES, RTO_SCENE_MAX_VERTICES);
        rto_status st = validate_mesh(s, i, msg);
        if (st)
            return st;
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rto_instance *in = &s->instances[i];
        if (in->blas >= s->mesh_count)
            return rto_fail(msg, RTO_ERR_PARSE, "instance %u: BLAS %u out of range (%u meshes)", i, in->blas,
                            s->mesh_count);
        if (!mat_finite(&in->obj_to_world) || !mat_finite(&in->world_to_obj))
            return rto_fail(msg, RTO_ERR_PARSE, "instance %u: non-finite transform", i);
        if (in->custom_index > RTO_INSTANCE_CUSTOM_INDEX_MASK || in->mask > 0xFFu)
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "instance %u: customIndex or mask wider than 24 / 8 bits",
                            i);
    }
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rto_material *ma = &s->materials[i];
        size_t bad;
        if (!all_finite(ma->base_color, 4, &bad) || !all_finite(ma->emissive, 3, &bad))
            return rto_fail(msg, RTO_ERR_PARSE, "material %u: non-finite colour factor", i);
        if (ma->base_color_texture < -1 ||
            (ma->base_color_texture >= 0 && (uint32_t)ma->base_color_texture >= s->texture_count))
            return rto_fail(msg, RTO_ERR_PARSE, "material %u: texture %d out of range (%u textures)", i,
                            (int)ma->base_color_texture, s->texture_count);
    }
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const rto_texture *t = &s->textures[i];
        if ((uint64_t)t->width * t->height > RTO_SCENE_MAX_TEXELS || (t->width && t->height && !t->rgba))
            return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "texture %u ('%s'): bad size %ux%u", i, t->name, t->width,
                            t->height);
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *c = &s->cameras[i];
        const float v[12] = {c->position.x, c->position.y, c->position.z, c->target.x, c->target.y, c->target.z,
                             c->up.x,       c->up.y,       c->up.z,       c->fov_y,    c->aspect,   c->znear};
        size_t bad;
        if (!all_finite(v, 12, &bad) || !(c->fov_y > 0.0f) || !(c->aspect >= 0.0f) || !(c->zfar >= 0.0f))
            return rto_fail(msg, RTO_ERR_PARSE, "camera %u ('%s'): non-finite or out-of-range parameters", i, c->name);
    }
    return RTO_OK;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Loading                                                                                                          */

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (n < k)
        return 0;
    for (size_t i = 0; i < k; i++)
        if (tolower((unsigned char)s[n - k + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

static int is_procedural(const char *spec)
{
    return !strcmp(spec, "triangle") || !strncmp(spec, "rtstress:", 9) || !strncmp(spec, "instances:", 10);
}

rto_status rto_scene_load(const char *spec, rto_scene **out, rto_msg *msg)
{
    if (out)
        *out = NULL;
    if (!spec || !out)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene spec or output");
    if (!*spec)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "empty scene spec");
    rto_scene *s = calloc(1, sizeof *s);
    if (!s)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    snprintf(s->source, sizeof s->source, "%s", spec);
    rto_status st;
    /* Procedural names first, so that a directory with ':' in its name still loads its .gltf; a ':' spec that names
     * no known procedural scene goes to the procedural loader for its one-line refusal. */
    if (is_procedural(spec))
        st = rto__procedural_load(spec, s, msg);
    else if (ends_with_ci(spec, ".gltf") || ends_with_ci(spec, ".glb"))
        st = rto__gltf_load(spec, s, msg);
    else if (strchr(spec, ':'))
        st = rto__procedural_load(spec, s, msg);
    else
        st = rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                      "'%.200s' is neither a .gltf / .glb path nor a procedural scene (triangle, rtstress:N, "
                      "instances:DIST:N)",
                      spec);
    if (!st)
        st = rto__scene_validate(s, msg);
    if (st) {
        rto_scene_destroy(s);
        return st;
    }
    *out = s;
    return RTO_OK;
}
