/* rtoracle info: what a scene spec loads as (DESIGN.md §5): counts, bounds, materials, textures, cameras, warnings. */
#include "cli.h"

#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Meshes listed in the text output; --json lists all of them. */
#define INFO_TEXT_MESHES 40

static void info_help(FILE *to)
{
    fprintf(to,
            "usage: rtoracle info SCENE [--json] [--texture-budget MB]\n\n"
            "Loads SCENE and prints what was loaded: mesh (BLAS) count, instance count, triangles (unique, i.e.\n"
            "summed over the BLAS, and instanced, i.e. summed over the instances' BLAS), vertices, materials,\n"
            "textures with their sizes, cameras, the scene's world bounds and the loader's warnings.\n\n"
            "SCENE is a .gltf / .glb path or a procedural scene:\n"
            "  triangle            the VulkanTriangle sample: one triangle, one identity instance, its camera\n"
            "  rtstress:N          N x N x N instances of one unit cube, 2 units apart (1 <= N <= 40)\n"
            "  instances:DIST:N    N boxes of half-size 1e-4 on a centroid distribution (rtoracle keys --list),\n"
            "                      0 <= N <= 65536, seed 1\n\n"
            "options:\n"
            "  --json                one JSON object on stdout instead of text (meshes, materials, textures, cameras\n"
            "                        listed)\n"
            "  --texture-budget MB   decoded texture memory (RGBA8) the scene may take; a scene that needs more is\n"
            "                        refused (default 256 MiB)\n\n"
            "Exit status: 0 loaded, 2 bad usage or a refused scene (one line on stderr says why).\n");
}

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

static json_t *vec3_json(rto_vec3 v)
{
    return json_pack("[fff]", (double)v.x, (double)v.y, (double)v.z);
}

static json_t *floats_json(const float *v, int n)
{
    json_t *a = json_array();
    for (int i = 0; i < n; i++)
        json_array_append_new(a, json_real((double)v[i]));
    return a;
}

static void print_json(const rto_scene *s, const scene_counts *c, const rto_aabb *box)
{
    json_t *root = json_object();
    json_object_set_new(root, "source", json_string(s->source));
    json_object_set_new(root, "counts",
                        json_pack("{sIsIsIsIsIsIsIsIsI}", "meshes", (json_int_t)s->mesh_count, "instances",
                                  (json_int_t)s->instance_count, "vertices", (json_int_t)c->vertices,
                                  "triangles_unique", (json_int_t)c->unique_tris, "triangles_instanced",
                                  (json_int_t)c->instanced_tris, "materials", (json_int_t)s->material_count,
                                  "textures", (json_int_t)s->texture_count, "cameras", (json_int_t)s->camera_count,
                                  "warnings", (json_int_t)s->warning_count));
    json_object_set_new(root, "bounds",
                        box_empty(box) ? json_null()
                                       : json_pack("{soso}", "min", vec3_json(box->min), "max", vec3_json(box->max)));
    json_t *meshes = json_array();
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rto_mesh *me = &s->meshes[m];
        json_array_append_new(meshes, json_pack("{sssIsIsisIsbsb}", "name", me->name, "vertices",
                                                (json_int_t)me->vertex_count, "triangles",
                                                (json_int_t)me->triangle_count, "material", (int)me->material,
                                                "instances", (json_int_t)c->mesh_instances[m], "normals",
                                                me->normals != NULL, "uvs", me->uvs != NULL));
    }
    json_object_set_new(root, "meshes", meshes);
    json_t *mats = json_array();
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rto_material *ma = &s->materials[i];
        json_array_append_new(mats, json_pack("{sosiso}", "base_color", floats_json(ma->base_color, 4),
                                              "base_color_texture", (int)ma->base_color_texture, "emissive",
                                              floats_json(ma->emissive, 3)));
    }
    json_object_set_new(root, "materials", mats);
    json_t *texs = json_array();
    for (uint32_t i = 0; i < s->texture_count; i++)
        json_array_append_new(texs, json_pack("{sssIsI}", "name", s->textures[i].name, "width",
                                              (json_int_t)s->textures[i].width, "height",
                                              (json_int_t)s->textures[i].height));
    json_object_set_new(root, "textures", texs);
    json_t *cams = json_array();
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rto_camera *ca = &s->cameras[i];
        json_array_append_new(cams, json_pack("{sssosososfsfsfsf}", "name", ca->name, "position",
                                              vec3_json(ca->position), "target", vec3_json(ca->target), "up",
                                              vec3_json(ca->up), "fov_y", (double)ca->fov_y, "aspect",
                                              (double)ca->aspect, "znear", (double)ca->znear, "zfar",
                                              (double)ca->zfar));
    }
    json_object_set_new(root, "cameras", cams);
    json_t *warns = json_array();
    for (uint32_t i = 0; i < s->warning_count && i < RTO_SCENE_MAX_WARNINGS; i++)
        json_array_append_new(warns, json_string(s->warnings[i]));
    json_object_set_new(root, "warnings", warns);
    json_dumpf(root, stdout, JSON_INDENT(2));
    fputc('\n', stdout);
    json_decref(root);
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
    static const struct option opts[] = {{"json", no_argument, 0, 'j'},
                                         {"texture-budget", required_argument, 0, 'B'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    bool as_json = false;
    rto_scene_load_desc load = {0};
    uint64_t mb = 0;
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, "h", opts, NULL)) != -1;) {
        switch (c) {
        case 'j': as_json = true; break;
        case 'B':
            if (!cli_parse_u64(optarg, UINT64_C(1) << 20, &mb) || mb == 0)
                return cli_fail("info", "--texture-budget '%s': expected MiB, 1 .. 1048576", optarg);
            load.texture_budget_bytes = (size_t)(mb << 20);
            break;
        case 'h': info_help(stdout); return EXIT_PASS;
        default: info_help(stderr); return cli_fail("info", "unknown or incomplete option '%s'", argv[optind - 1]);
        }
    }
    if (optind >= argc)
        return cli_fail("info", "a SCENE is required (rtoracle info --help)");
    if (optind + 1 < argc)
        return cli_fail("info", "unexpected argument '%s'", argv[optind + 1]);
    rto_msg msg = {{0}};
    rto_scene *s = NULL;
    rto_status st = rto_scene_load_ex(argv[optind], &load, &s, &msg);
    if (st)
        return cli_status("info", st, &msg);
    scene_counts c;
    if (!count_scene(s, &c)) {
        rto_scene_destroy(s);
        return cli_fail("info", "out of memory");
    }
    rto_aabb box = rto_scene_aabb(s);
    if (as_json)
        print_json(s, &c, &box);
    else
        print_text(s, &c, &box);
    free(c.mesh_instances);
    rto_scene_destroy(s);
    return EXIT_PASS;
}
