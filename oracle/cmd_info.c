/* rtoracle info: what a scene spec loads as (DESIGN.md §5): counts, bounds, materials, textures, cameras, warnings. */
#include "cli.h"

#include <errno.h>
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
    "                      0 <= N <= 65536, seed 1\n"
    "  sphere:L            a closed unit icosphere, subdivision level L (0 <= L <= 7): 20 * 4^L triangles\n"
    "  sphere:L:SEED       the same with each vertex moved along its radius to a seeded 0.6 .. 1.4 of it\n"
    "  random:SEED         a seeded random scene: 1-4 meshes of 1-300 triangles, 1-40 transformed instances\n";

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

static void print_text(const rto_scene *s, const scene_counts *c, const rto_aabb *box)
{
    printf("scene:      %s\n", s->source);
    printf("meshes:     %u (BLAS)\n", s->mesh_count);
    printf("instances:  %u\n", s->instance_count);
    printf("triangles:  %llu unique (summed over the BLAS), %llu instanced (summed over the instances)\n",
           (unsigned long long)c->unique_tris, (unsigned long long)c->instanced_tris);
    printf("vertices:   %llu\n", (unsigned long long)c->vertices);
    if (rto_aabb_is_empty(box))
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
        /* All or nothing: the whole description is built before the first byte goes out, and a failed write (a
         * full disk, a closed pipe) is reported rather than taken for success. */
        size_t len = 0;
        char *text = NULL;
        rto_scene_json(s, NULL, 0, &len, &msg);
        if (!(text = malloc(len + 1)) || (st = rto_scene_json(s, text, len + 1, &len, &msg)) != RTO_OK)
            rc = cli_fail("info", "%s", text ? msg.text : "out of memory");
        else if ((errno = 0, fputs(text, stdout) < 0 || fflush(stdout) != 0))
            rc = cli_fail("info", "cannot write the JSON description to stdout: %s", strerror(errno ? errno : EIO));
        free(text);
    } else {
        print_text(s, &c, &box);
        if (fflush(stdout) != 0 || ferror(stdout))
            rc = cli_fail("info", "cannot write to stdout: %s", strerror(errno ? errno : EIO));
    }
    free(c.mesh_instances);
    rto_scene_destroy(s);
    return rc;
}
