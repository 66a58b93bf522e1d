/* Procedural scenes named on the command line where a path would go: the seeds' VulkanTriangle and RTStress samples,
 * and N small boxes on a named centroid distribution (DESIGN.md §3), so TLAS keys come from real instances. */
#include "internal.h"
#include "model.h"
#include "procedural.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RTSTRESS_MAX_N 40u

/* Strict decimal: digits only (no sign, space or junk), at most 9 of them, value <= max. */
static int parse_count(const char *text, uint32_t max, uint32_t *out)
{
    size_t len = strlen(text);
    if (len == 0 || len > 9)
        return 0;
    uint32_t v = 0;
    for (size_t i = 0; i < len; i++) {
        if (text[i] < '0' || text[i] > '9')
            return 0;
        v = v * 10u + (uint32_t)(text[i] - '0');
    }
    if (v > max)
        return 0;
    *out = v;
    return 1;
}

static rto_mesh *add_mesh(rto_scene *s, const char *name, uint32_t vertices, uint32_t triangles)
{
    s->meshes = calloc(1, sizeof *s->meshes);
    if (!s->meshes)
        return NULL;
    s->mesh_count = 1;
    rto_mesh *m = &s->meshes[0];
    snprintf(m->name, sizeof m->name, "%s", name);
    m->material = -1;
    m->positions = rto_alloc(3 * (size_t)vertices, sizeof(float));
    m->indices = rto_alloc(3 * (size_t)triangles, sizeof(uint32_t));
    if (!m->positions || !m->indices)
        return NULL;
    m->vertex_count = vertices;
    m->triangle_count = triangles;
    return m;
}

/* The axis-aligned cube [-0.5, 0.5]^3: vertex v has x = bit 0, y = bit 1, z = bit 2 of v (0 -> -0.5, 1 -> +0.5);
 * two counter-clockwise triangles per face as seen from outside (det > 0 for a ray from outside, DESIGN.md §6). */
static rto_mesh *add_cube(rto_scene *s)
{
    static const uint32_t tri[36] = {
        0, 4, 6, 0, 6, 2, /* -x */
        1, 3, 7, 1, 7, 5, /* +x */
        0, 1, 5, 0, 5, 4, /* -y */
        2, 6, 7, 2, 7, 3, /* +y */
        0, 2, 3, 0, 3, 1, /* -z */
        4, 5, 7, 4, 7, 6, /* +z */
    };
    rto_mesh *m = add_mesh(s, "cube", 8, 12);
    if (!m)
        return NULL;
    for (uint32_t v = 0; v < 8; v++) {
        m->positions[3 * v + 0] = (v & 1) ? 0.5f : -0.5f;
        m->positions[3 * v + 1] = (v & 2) ? 0.5f : -0.5f;
        m->positions[3 * v + 2] = (v & 4) ? 0.5f : -0.5f;
    }
    memcpy(m->indices, tri, sizeof tri);
    return m;
}

static rto_status alloc_instances(rto_scene *s, uint32_t n, rto_msg *msg)
{
    s->instances = calloc(n ? n : 1, sizeof *s->instances);
    if (!s->instances)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u instances", n);
    s->instance_count = n;
    return RTO_OK;
}

/* An instance of BLAS 0 with obj_to_world = scale * I + translation; mask 0xFF, sbtOffset 0, flags 0. */
static rto_status set_instance(rto_instance *in, uint32_t custom, double scale, double tx, double ty, double tz,
                               rto_msg *msg)
{
    const double m[3][4] = {{scale, 0, 0, tx}, {0, scale, 0, ty}, {0, 0, scale, tz}};
    in->blas = 0;
    in->custom_index = custom & RTO_INSTANCE_CUSTOM_INDEX_MASK;
    in->mask = 0xFFu;
    in->sbt_offset = 0;
    in->flags = 0;
    return rto_instance_set_transform(in, m, msg);
}

/* A camera looking at centre from above and in front (direction (0, 1, 2) / sqrt 5), far enough that a sphere of
 * radius r around centre fits the 60 degree field of view: distance r / sin(30 deg) = 2r. */
static rto_status add_framing_camera(rto_scene *s, const char *name, double cx, double cy, double cz, double r)
{
    s->cameras = calloc(1, sizeof *s->cameras);
    if (!s->cameras)
        return RTO_ERR_OUT_OF_MEMORY;
    s->camera_count = 1;
    rto_camera c = rto_camera_default();
    snprintf(c.name, sizeof c.name, "%s", name);
    const double d = 2.0 * r / sqrt(5.0);
    c.position = (rto_vec3){(float)cx, (float)(cy + d), (float)(cz + 2.0 * d)};
    c.target = (rto_vec3){(float)cx, (float)cy, (float)cz};
    c.znear = (float)(r * 1e-3);
    c.zfar = (float)(r * 10.0);
    s->cameras[0] = c;
    return RTO_OK;
}

static rto_status load_triangle(rto_scene *s, rto_msg *msg)
{
    /* The VulkanTriangle sample (Sascha Willems' raytracingbasic): one triangle, identity instance. */
    static const float pos[9] = {1.0f, 1.0f, 0.0f, -1.0f, 1.0f, 0.0f, 0.0f, -1.0f, 0.0f};
    rto_mesh *m = add_mesh(s, "triangle", 3, 1);
    if (!m)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(m->positions, pos, sizeof pos);
    m->indices[0] = 0;
    m->indices[1] = 1;
    m->indices[2] = 2;
    rto_status st = alloc_instances(s, 1, msg);
    if (!st)
        st = set_instance(&s->instances[0], 0, 1.0, 0.0, 0.0, 0.0, msg);
    if (st)
        return st;
    s->cameras = calloc(1, sizeof *s->cameras);
    if (!s->cameras)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    s->camera_count = 1;
    rto_camera c = rto_camera_default();
    snprintf(c.name, sizeof c.name, "triangle");
    c.position = (rto_vec3){0.0f, 0.0f, 2.5f}; /* the sample's camera.setTranslation(0, 0, -2.5) view */
    c.zfar = 512.0f;                           /* and its setPerspective(60, aspect, 0.1, 512) */
    s->cameras[0] = c;
    return RTO_OK;
}

static rto_status load_rtstress(const char *spec, const char *arg, rto_scene *s, rto_msg *msg)
{
    uint32_t n;
    if (!parse_count(arg, UINT32_MAX, &n) || n < 1 || n > RTSTRESS_MAX_N)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': N must be an integer 1 .. %u", spec, RTSTRESS_MAX_N);
    if (!add_cube(s))
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_status st = alloc_instances(s, n * n * n, msg);
    /* Instance i = ix + N (iy + N iz) at (2 ix - (N-1), ...): unit cubes with unit gaps, centred on the origin. */
    for (uint32_t i = 0; !st && i < n * n * n; i++) {
        const uint32_t ix = i % n, iy = (i / n) % n, iz = i / (n * n);
        st = set_instance(&s->instances[i], i, 1.0, 2.0 * ix - (n - 1.0), 2.0 * iy - (n - 1.0), 2.0 * iz - (n - 1.0),
                          msg);
    }
    if (!st && add_framing_camera(s, "rtstress", 0.0, 0.0, 0.0, sqrt(3.0) * n))
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return st;
}

static rto_status load_instances(const char *spec, const char *arg, rto_scene *s, rto_msg *msg)
{
    const char *colon = strchr(arg, ':');
    if (!colon)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': expected instances:DIST:N", spec);
    char dist[64];
    size_t len = (size_t)(colon - arg);
    if (len == 0 || len >= sizeof dist)
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': expected instances:DIST:N", spec);
    memcpy(dist, arg, len);
    dist[len] = '\0';
    const rto_dist_info *d = rto_dist_find(dist);
    if (!d || d->kind != RTO_DIST_CENTROID) {
        char names[256] = "";
        for (size_t i = 0, at = 0; i < rto_dist_count(); i++)
            if (rto_dist_at(i)->kind == RTO_DIST_CENTROID && at < sizeof names) {
                int w = snprintf(names + at, sizeof names - at, "%s%s", at ? ", " : "", rto_dist_at(i)->name);
                at += w > 0 ? (size_t)w : 0;
            }
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': '%s' is %s; centroid distributions: %s", spec, dist,
                        d ? "not a centroid distribution" : "an unknown distribution", names);
    }
    uint32_t n;
    if (!parse_count(colon + 1, RTO_TLAS_MAX_INSTANCES, &n))
        return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': N must be an integer 0 .. %u", spec,
                        RTO_TLAS_MAX_INSTANCES);
    if (!add_cube(s))
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_vec3 *c = rto_alloc(n, sizeof *c);
    if (!c)
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_status st = rto_centroids_generate(dist, 1, n, c, msg);
    if (!st)
        st = alloc_instances(s, n, msg);
    /* Boxes of half-size 1e-4: smaller than the 1e-3 clusters of the clustered distributions, so boxes stay apart. */
    for (uint32_t i = 0; !st && i < n; i++)
        st = set_instance(&s->instances[i], i, 2e-4, c[i].x, c[i].y, c[i].z, msg);
    free(c);
    if (!st && add_framing_camera(s, "instances", 0.5, 0.5, 0.5, 0.5 * sqrt(3.0)))
        return rto_fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return st;
}

int rto__procedural_is(const char *spec)
{
    return !strcmp(spec, "triangle") || !strncmp(spec, "rtstress:", 9) || !strncmp(spec, "instances:", 10);
}

rto_status rto__procedural_load(const char *spec, rto_scene *scene, rto_msg *msg)
{
    if (!strcmp(spec, "triangle"))
        return load_triangle(scene, msg);
    if (!strncmp(spec, "rtstress:", 9))
        return load_rtstress(spec, spec + 9, scene, msg);
    if (!strncmp(spec, "instances:", 10))
        return load_instances(spec, spec + 10, scene, msg);
    return rto_fail(msg, RTO_ERR_INVALID_ARGUMENT,
                    "unknown procedural scene '%.100s' (triangle, rtstress:N, instances:DIST:N)", spec);
}
