/* rto_scene_json: the description `rtoracle info --json` prints, built here so that harnesses get the same object and
 * so that its text can never come out cut short or drop a field (core/json.h). */
#include "internal.h"
#include "core/json.h"

#include <stdlib.h>
#include <string.h>

/* Every jansson call below can fail (out of memory), and a failure must fail the call rather than drop a field:
 * set / push count failures in *bad. Names go through rto__json_string (repaired to UTF-8), numbers through
 * rto__json_real (non-finite values as strings). */
static void set(int *bad, json_t *o, const char *key, json_t *v) { *bad |= json_object_set_new(o, key, v) != 0; }
static void push(int *bad, json_t *a, json_t *v) { *bad |= json_array_append_new(a, v) != 0; }

static json_t *floats_json(int *bad, const float *v, int n)
{
    json_t *a = json_array();
    *bad |= !a;
    for (int i = 0; i < n; i++)
        push(bad, a, rto__json_real((double)v[i]));
    return a;
}

static json_t *vec3_json(int *bad, rto_vec3 v)
{
    const float f[3] = {v.x, v.y, v.z};
    return floats_json(bad, f, 3);
}

static json_t *scene_object(const rto_scene *s, const uint32_t *mesh_instances, int *bad)
{
    uint64_t vertices = 0, unique_tris = 0, instanced_tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        vertices += s->meshes[m].vertex_count;
        unique_tris += s->meshes[m].triangle_count;
    }
    for (uint32_t i = 0; i < s->instance_count; i++)
        instanced_tris += s->meshes[s->instances[i].blas].triangle_count;
    json_t *root = json_object(), *counts = json_object();
    *bad |= !root || !counts;
    set(bad, root, "source", rto__json_string(s->source));
    set(bad, counts, "meshes", json_integer((json_int_t)s->mesh_count));
    set(bad, counts, "instances", json_integer((json_int_t)s->instance_count));
    set(bad, counts, "vertices", json_integer((json_int_t)vertices));
    set(bad, counts, "triangles_unique", json_integer((json_int_t)unique_tris));
    set(bad, counts, "triangles_instanced", json_integer((json_int_t)instanced_tris));
    set(bad, counts, "materials", json_integer((json_int_t)s->material_count));
    set(bad, counts, "textures", json_integer((json_int_t)s->texture_count));
    set(bad, counts, "cameras", json_integer((json_int_t)s->camera_count));
    set(bad, counts, "warnings", json_integer((json_int_t)s->warning_count));
    set(bad, root, "counts", counts);
    rto_aabb box = rto_scene_aabb(s);
    const int empty = rto_aabb_is_empty(&box);
    json_t *bounds = empty ? json_null() : json_object();
    if (!empty) {
        set(bad, bounds, "min", vec3_json(bad, box.min));
        set(bad, bounds, "max", vec3_json(bad, box.max));
    }
    set(bad, root, "bounds", bounds);
    json_t *meshes = json_array();
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rto_mesh *me = &s->meshes[m];
        json_t *o = json_object();
        set(bad, o, "name", rto__json_string(me->name));
        set(bad, o, "vertices", json_integer((json_int_t)me->vertex_count));
        set(bad, o, "triangles", json_integer((json_int_t)me->triangle_count));
        set(bad, o, "material", json_integer((json_int_t)me->material));
        set(bad, o, "instances", json_integer((json_int_t)mesh_instances[m]));
        set(bad, o, "normals", json_boolean(me->normals != NULL));
        set(bad, o, "uvs", json_boolean(me->uvs != NULL));
        push(bad, meshes, o);
    }
    set(bad, root, "meshes", meshes);
    json_t *mats = json_array();
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rto_material *ma = &s->materials[i];
        json_t *o = json_object();
        set(bad, o, "base_color", floats_json(bad, ma->base_color, 4));
        set(bad, o, "base_color_texture", json_integer((json_int_t)ma->base_color_texture));
        set(bad, o, "emissive", floats_json(bad, ma->emissive, 3));
        push(bad, mats, o);
    }
    set(bad, root, "materials", mats);
    json_t *texs = json_array();
    for (uint32_t i = 0; i < s->texture_count; i++) {
        json_t *o = json_object();
        set(bad, o, "name", rto__json_string(s->textures[i].name));
        set(bad, o, "width", json_integer((json_int_t)s->textures[i].width));
        set(bad, o, "height", json_integer((json_int_t)s->textures[i].height));
        push(bad, texs, o);
    }
    set(bad, root, "textures", texs);
    json_t *cams = json_array();
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *ca = &s->cameras[i];
        json_t *o = json_object();
        set(bad, o, "name", rto__json_string(ca->name));
        set(bad, o, "position", vec3_json(bad, ca->position));
        set(bad, o, "target", vec3_json(bad, ca->target));
        set(bad, o, "up", vec3_json(bad, ca->up));
        set(bad, o, "fov_y", rto__json_real((double)ca->fov_y));
        set(bad, o, "aspect", rto__json_real((double)ca->aspect));
        set(bad, o, "znear", rto__json_real((double)ca->znear));
        set(bad, o, "zfar", rto__json_real((double)ca->zfar));
        push(bad, cams, o);
    }
    set(bad, root, "cameras", cams);
    json_t *warns = json_array();
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        push(bad, warns, rto__json_string(s->warnings[i]));
    set(bad, root, "warnings", warns);
    return root;
}

rto_status rto_scene_json(const rto_scene *scene, char *buf, size_t cap, size_t *len, rto_msg *msg)
{
    if (len)
        *len = 0;
    if (!scene || (cap && !buf))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene or buffer");
    /* One counter even for a scene without meshes (a glTF may have none): the buffer is never of size 0. */
    const size_t counters = scene->mesh_count ? scene->mesh_count : 1;
    uint32_t *mesh_instances = rto__alloc(counters, sizeof *mesh_instances);
    if (!mesh_instances)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory describing %s", scene->source);
    memset(mesh_instances, 0, counters * sizeof *mesh_instances);
    for (uint32_t i = 0; i < scene->instance_count; i++)
        mesh_instances[scene->instances[i].blas]++;
    int bad = 0;
    json_t *root = scene_object(scene, mesh_instances, &bad);
    free(mesh_instances);
    char *text = bad ? NULL : rto__json_text(root, JSON_INDENT(2));
    json_decref(root);
    if (!text)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory describing %s as JSON", scene->source);
    size_t n = strlen(text);
    if (len)
        *len = n;
    if (cap) {
        size_t k = n < cap ? n : cap - 1;
        memcpy(buf, text, k);
        buf[k] = '\0';
    }
    rto_status st = n < cap ? RTO_OK : RTO_ERR_BUFFER_TOO_SMALL;
    free(text);
    return st;
}
