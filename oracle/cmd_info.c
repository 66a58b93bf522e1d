/* rtoracle info: what a scene spec loads as (DESIGN.md §5): counts, bounds, materials, textures, cameras, warnings. */
#include "cli.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Meshes listed in the text output; --json lists all of them. */
#define INFO_TEXT_MESHES 40

static const char info_usage[] =
    "usage: rtoracle info SCENE [--json] [--texture-budget MB]\n\n"
    "Loads SCENE and prints what was loaded: mesh (BLAS) count, instance count, triangles (unique, i.e.\n"
    "summed over the BLAS, and instanced, i.e. summed over the instances' BLAS), vertices, materials,\n"
    "textures with their sizes, cameras, the scene's world bounds and the loader's warnings.\n\n"
    "SCENE is a .gltf / .glb path or a procedural scene:\n"
    "  triangle            the VulkanTriangle sample: one triangle, one identity instance, its camera\n"
    "  rtstress:N          N x N x N instances of one unit cube, 2 units apart (1 <= N <= 40)\n"
    "  instances:DIST:N    N boxes of half-size 1e-4 on a centroid distribution (rtoracle keys --list),\n"
    "                      0 <= N <= 65536, seed 1\n";

static const char info_epilog[] =
    "Exit status: 0 loaded, 2 bad usage or a refused scene (one line on stderr says why).\n";

typedef struct scene_counts {
    uint64_t vertices, unique_tris, instanced_tris;
    uint32_t *mesh_instances; /* instances per mesh */
} scene_counts;

static int count_scene(const rto_scene *s, scene_counts *c)
{
    memset(c, 0, sizeof *c);
    c->mesh_instances = calloc(s->mesh_count ? s->mesh_count : 1, sizeof *c->mesh_instances);
    if (!c->mesh_instances)
        return 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        c->vertices += s->meshes[m].vertex_count;
        c->unique_tris += s->meshes[m].triangle_count;
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        c->instanced_tris += s->meshes[s->instances[i].blas].triangle_count;
        c->mesh_instances[s->instances[i].blas]++;
    }
    return 1;
}

static int box_empty(const rto_aabb *b)
{
    return !(b->min.x <= b->max.x && b->min.y <= b->max.y && b->min.z <= b->max.z);
}

/* Every jansson call below can fail (out of memory), and a failure must fail the command rather than drop a field:
 * set / push count failures in *bad; values come from cli_json_string / cli_json_real, which encode what JSON cannot
 * hold (names that are not UTF-8, non-finite numbers) instead of failing on it. */
static void set(int *bad, json_t *o, const char *key, json_t *v) { *bad |= json_object_set_new(o, key, v) != 0; }
static void push(int *bad, json_t *a, json_t *v) { *bad |= json_array_append_new(a, v) != 0; }

static json_t *vec3_json(int *bad, rto_vec3 v)
{
    json_t *a = json_array();
    *bad |= !a;
    push(bad, a, cli_json_real((double)v.x));
    push(bad, a, cli_json_real((double)v.y));
    push(bad, a, cli_json_real((double)v.z));
    return a;
}

static json_t *floats_json(int *bad, const float *v, int n)
{
    json_t *a = json_array();
    *bad |= !a;
    for (int i = 0; i < n; i++)
        push(bad, a, cli_json_real((double)v[i]));
    return a;
}

static json_t *scene_json(const rto_scene *s, const scene_counts *c, const rto_aabb *box)
{
    int bad = 0;
    json_t *root = json_object(), *counts = json_object();
    bad |= !root || !counts;
    set(&bad, root, "source", cli_json_string(s->source));
    set(&bad, counts, "meshes", json_integer((json_int_t)s->mesh_count));
    set(&bad, counts, "instances", json_integer((json_int_t)s->instance_count));
    set(&bad, counts, "vertices", json_integer((json_int_t)c->vertices));
    set(&bad, counts, "triangles_unique", json_integer((json_int_t)c->unique_tris));
    set(&bad, counts, "triangles_instanced", json_integer((json_int_t)c->instanced_tris));
    set(&bad, counts, "materials", json_integer((json_int_t)s->material_count));
    set(&bad, counts, "textures", json_integer((json_int_t)s->texture_count));
    set(&bad, counts, "cameras", json_integer((json_int_t)s->camera_count));
    set(&bad, counts, "warnings", json_integer((json_int_t)s->warning_count));
    set(&bad, root, "counts", counts);
    json_t *bounds = box_empty(box) ? json_null() : json_object();
    if (!box_empty(box)) {
        set(&bad, bounds, "min", vec3_json(&bad, box->min));
        set(&bad, bounds, "max", vec3_json(&bad, box->max));
    }
    set(&bad, root, "bounds", bounds);
    json_t *meshes = json_array();
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rto_mesh *me = &s->meshes[m];
        json_t *o = json_object();
        set(&bad, o, "name", cli_json_string(me->name));
        set(&bad, o, "vertices", json_integer((json_int_t)me->vertex_count));
        set(&bad, o, "triangles", json_integer((json_int_t)me->triangle_count));
        set(&bad, o, "material", json_integer((json_int_t)me->material));
        set(&bad, o, "instances", json_integer((json_int_t)c->mesh_instances[m]));
        set(&bad, o, "normals", json_boolean(me->normals != NULL));
        set(&bad, o, "uvs", json_boolean(me->uvs != NULL));
        push(&bad, meshes, o);
    }
    set(&bad, root, "meshes", meshes);
    json_t *mats = json_array();
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rto_material *ma = &s->materials[i];
        json_t *o = json_object();
        set(&bad, o, "base_color", floats_json(&bad, ma->base_color, 4));
        set(&bad, o, "base_color_texture", json_integer((json_int_t)ma->base_color_texture));
        set(&bad, o, "emissive", floats_json(&bad, ma->emissive, 3));
        push(&bad, mats, o);
    }
    set(&bad, root, "materials", mats);
    json_t *texs = json_array();
    for (uint32_t i = 0; i < s->texture_count; i++) {
        json_t *o = json_object();
        set(&bad, o, "name", cli_json_string(s->textures[i].name));
        set(&bad, o, "width", json_integer((json_int_t)s->textures[i].width));
        set(&bad, o, "height", json_integer((json_int_t)s->textures[i].height));
        push(&bad, texs, o);
    }
    set(&bad, root, "textures", texs);
    json_t *cams = json_array();
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *ca = &s->cameras[i];
        json_t *o = json_object();
        set(&bad, o, "name", cli_json_string(ca->name));
        set(&bad, o, "position", vec3_json(&bad, ca->position));
        set(&bad, o, "target", vec3_json(&bad, ca->target));
        set(&bad, o, "up", vec3_json(&bad, ca->up));
        set(&bad, o, "fov_y", cli_json_real((double)ca->fov_y));
        set(&bad, o, "aspect", cli_json_real((double)ca->aspect));
        set(&bad, o, "znear", cli_json_real((double)ca->znear));
        set(&bad, o, "zfar", cli_json_real((double)ca->zfar));
        push(&bad, cams, o);
    }
    set(&bad, root, "cameras", cams);
    json_t *warns = json_array();
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        push(&bad, warns, cli_json_string(s->warnings[i]));
    set(&bad, root, "warnings", warns);
    if (bad) {
        json_decref(root);
        return NULL;
    }
    return root;
}

static void print_text(const rto_scene *s, const scene_counts *c, const rto_aabb *box)
{
    printf("scene:      %s\n", s->source);
    printf("meshes:     %u (BLAS)\n", s->mesh_count);
    printf("instances:  %u\n", s->instance_count);
    printf("triangles:  %llu unique (summed over the BLAS), %llu instanced (summed over the instances)\n",
           (unsigned long long)c->unique_tris, (unsigned long long)c->instanced_tris);
    printf("vertices:   %llu\n", (unsigned long long)c->vertices);
    if (box_empty(box))
        printf("bounds:     empty\n");
    else
        printf("bounds:     min (%.9g, %.9g, %.9g) max (%.9g, %.9g, %.9g)\n", (double)box->min.x, (double)box->min.y,
               (double)box->min.z, (double)box->max.x, (double)box->max.y, (double)box->max.z);
    for (uint32_t m = 0; m < s->mesh_count && m < INFO_TEXT_MESHES; m++) {
        const rto_mesh *me = &s->meshes[m];
        printf("  mesh %-4u %-28s %8u triangles %8u vertices  material %3d  %u instance%s%s%s\n", m, me->name,
               me->triangle_count, me->vertex_count, (int)me->material, c->mesh_instances[m],
               c->mesh_instances[m] == 1 ? "" : "s", me->normals ? "  normals" : "", me->uvs ? "  uvs" : "");
    }
    if (s->mesh_count > INFO_TEXT_MESHES)
        printf("  ... %u more meshes (--json lists all)\n", s->mesh_count - INFO_TEXT_MESHES);
    printf("materials:  %u\n", s->material_count);
    for (uint32_t i = 0; i < s->material_count && i < INFO_TEXT_MESHES; i++) {
        const rto_material *ma = &s->materials[i];
        printf("  material %-3u base colour (%.4g, %.4g, %.4g, %.4g)  texture %d  emissive (%.4g, %.4g, %.4g)\n", i,
               (double)ma->base_color[0], (double)ma->base_color[1], (double)ma->base_color[2],
               (double)ma->base_color[3], (int)ma->base_color_texture, (double)ma->emissive[0],
               (double)ma->emissive[1], (double)ma->emissive[2]);
    }
    printf("textures:   %u\n", s->texture_count);
    for (uint32_t i = 0; i < s->texture_count; i++)
        printf("  texture %-3u %ux%u RGBA8  %s\n", i, s->textures[i].width, s->textures[i].height,
               s->textures[i].name);
    printf("cameras:    %u\n", s->camera_count);
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *ca = &s->cameras[i];
        printf("  camera %-3u '%s' position (%.6g, %.6g, %.6g) target (%.6g, %.6g, %.6g) up (%.6g, %.6g, %.6g) "
               "fovY %.4g deg aspect %.4g near %.4g far %.4g\n",
               i, ca->name, (double)ca->position.x, (double)ca->position.y, (double)ca->position.z,
               (double)ca->target.x, (double)ca->target.y, (double)ca->target.z, (double)ca->up.x, (double)ca->up.y,
               (double)ca->up.z, (double)ca->fov_y * (180.0 / 3.14159265358979323846), (double)ca->aspect,
               (double)ca->znear, (double)ca->zfar);
    }
    printf("warnings:   %u\n", s->warning_count);
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        printf("  - %s\n", s->warnings[i]);
    if (s->warning_count > RTO_SCENE_MAX_WARNINGS)
        printf("  ... %u more\n", s->warning_count - RTO_SCENE_MAX_WARNINGS);
}

int cmd_info(int argc, char **argv)
{
    bool as_json = false;
    uint64_t budget_mb = 0;
    const opt_spec opts[] = {
        OPT_FLAG("json", &as_json, "one JSON object on stdout instead of text (meshes, materials, textures, cameras "
                 "listed)"),
        OPT_UINT("texture-budget", &budget_mb, 1, CLI_TEXTURE_BUDGET_MAX_MB, "MB",
                 "decoded texture memory (RGBA8, MiB) the scene may take; a scene that needs more is refused", "256"),
        OPT_END,
    };
    const opt_command cmd = {"info", info_usage, info_epilog, opts, 1, 1, "a SCENE"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return rc;
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_scene_load_desc load = {0};
    load.texture_budget_bytes = (size_t)(budget_mb << 20); /* 0 (not given): the default */
    rto_status st = rto_scene_load_ex(args.arg[0], &load, &s, &msg);
    if (st)
        return cli_status("info", st, &msg);
    scene_counts c;
    if (!count_scene(s, &c)) {
        rto_scene_destroy(s);
        return cli_fail("info", "out of memory");
    }
    rto_aabb box = rto_scene_aabb(s);
    rc = EXIT_PASS;
    if (as_json) {
        json_t *root = scene_json(s, &c, &box);
        if (!root)
            rc = cli_fail("info", "cannot build the JSON description of %s: out of memory", args.arg[0]);
        else if (!cli_json_print(root))
            rc = cli_fail("info", "cannot write the JSON description to stdout: %s", strerror(errno ? errno : EIO));
        json_decref(root);
    } else {
        print_text(s, &c, &box);
        if (fflush(stdout) != 0 || ferror(stdout))
            rc = cli_fail("info", "cannot write to stdout: %s", strerror(errno ? errno : EIO));
    }
    free(c.mesh_instances);
    rto_scene_destroy(s);
    return rc;
}
