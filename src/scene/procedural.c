/* Procedural scenes named on the command line where a path would go: the seeds' VulkanTriangle and RTStress samples,
 * N small boxes on a named centroid distribution (DESIGN.md §3), so TLAS keys come from real instances, a closed
 * icosphere (optionally with seeded radial bumps) for watertightness tests, and a seeded random scene of instanced
 * triangle soups for comparisons with a brute-force tracer. */
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

/* Strict decimal u32: digits only, at most 10 of them, value <= 2^32 - 1. */
static int parse_u32(const char *text, uint32_t *out)
{
    size_t len = strlen(text);
    if (len == 0 || len > 10)
        return 0;
    uint64_t v = 0;
    for (size_t i = 0; i < len; i++) {
        if (text[i] < '0' || text[i] > '9')
            return 0;
        v = v * 10u + (uint64_t)(text[i] - '0');
    }
    if (v > UINT32_MAX)
        return 0;
    *out = (uint32_t)v;
    return 1;
}

/* Names mesh m and allocates its arrays (material none). */
static rto_mesh *mesh_init(rto_mesh *m, const char *name, uint32_t vertices, uint32_t triangles)
{
    snprintf(m->name, sizeof m->name, "%s", name);
    m->material = -1;
    m->positions = rto__alloc(3 * (size_t)vertices, sizeof(float));
    m->indices = rto__alloc(3 * (size_t)triangles, sizeof(uint32_t));
    if (!m->positions || !m->indices)
        return NULL;
    m->vertex_count = vertices;
    m->triangle_count = triangles;
    return m;
}

static rto_mesh *add_mesh(rto_scene *s, const char *name, uint32_t vertices, uint32_t triangles)
{
    s->meshes = calloc(1, sizeof *s->meshes);
    if (!s->meshes)
        return NULL;
    s->mesh_count = 1;
    return mesh_init(&s->meshes[0], name, vertices, triangles);
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
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory for %u instances", n);
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
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
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
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
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
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': N must be an integer 1 .. %u", spec, RTSTRESS_MAX_N);
    if (!add_cube(s))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_status st = alloc_instances(s, n * n * n, msg);
    /* Instance i = ix + N (iy + N iz) at (2 ix - (N-1), ...): unit cubes with unit gaps, centred on the origin. */
    for (uint32_t i = 0; !st && i < n * n * n; i++) {
        const uint32_t ix = i % n, iy = (i / n) % n, iz = i / (n * n);
        st = set_instance(&s->instances[i], i, 1.0, 2.0 * ix - (n - 1.0), 2.0 * iy - (n - 1.0), 2.0 * iz - (n - 1.0),
                          msg);
    }
    if (!st && add_framing_camera(s, "rtstress", 0.0, 0.0, 0.0, sqrt(3.0) * n))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return st;
}

static rto_status load_instances(const char *spec, const char *arg, rto_scene *s, rto_msg *msg)
{
    const char *colon = strchr(arg, ':');
    if (!colon)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': expected instances:DIST:N", spec);
    char dist[64];
    size_t len = (size_t)(colon - arg);
    if (len == 0 || len >= sizeof dist)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': expected instances:DIST:N", spec);
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
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': '%s' is %s; centroid distributions: %s", spec, dist,
                        d ? "not a centroid distribution" : "an unknown distribution", names);
    }
    uint32_t n;
    if (!parse_count(colon + 1, RTO_TLAS_MAX_INSTANCES, &n))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': N must be an integer 0 .. %u", spec,
                        RTO_TLAS_MAX_INSTANCES);
    if (!add_cube(s))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_vec3 *c = rto__alloc(n, sizeof *c);
    if (!c)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    rto_status st = rto_centroids_generate(dist, 1, n, c, msg);
    if (!st)
        st = alloc_instances(s, n, msg);
    /* Boxes of half-size 1e-4: smaller than the 1e-3 clusters of the clustered distributions, so boxes stay apart. */
    for (uint32_t i = 0; !st && i < n; i++)
        st = set_instance(&s->instances[i], i, 2e-4, c[i].x, c[i].y, c[i].z, msg);
    free(c);
    if (!st && add_framing_camera(s, "instances", 0.5, 0.5, 0.5, 0.5 * sqrt(3.0)))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return st;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* sphere:L[:SEED]                                                                                                  */

#define SPHERE_MAX_LEVEL 7u

/* Draws of the PRNG (§3) in sequence from one stream: the n-th call returns rng(stream, n). Each draw is its own
 * statement, so the order never rests on C's unspecified order of evaluation. */
typedef struct draws {
    uint32_t stream, next;
} draws;

/* Stream p of a seed, as dist.c and the ray sets derive theirs (seed + p * golden ratio, u32); numbers 0x200 and up
 * belong to procedural scenes. */
static draws draws_start(uint32_t seed, uint32_t p)
{
    draws d = {(uint32_t)(seed + p * UINT32_C(0x9E3779B9)), 0};
    return d;
}

static uint32_t draw_u32(draws *d) { return rto_rng(d->stream, d->next++); }
/* rto_unit of the next counter: 24 random bits in [0, 1). */
static double draw_unit(draws *d) { return (double)rto_unit(d->stream, d->next++); }
/* floor(u * n) without float rounding: the high word of rng * n. */
static uint32_t draw_below(draws *d, uint32_t n) { return (uint32_t)(((uint64_t)draw_u32(d) * n) >> 32); }
static double draw_range(draws *d, double lo, double hi) { return lo + draw_unit(d) * (hi - lo); }

/* An edge of the subdivision and the midpoint vertex made for it; open addressing, key (lo << 32 | hi) + 1 so 0 is
 * a free slot. */
typedef struct edge_slot {
    uint64_t key;
    uint32_t mid;
} edge_slot;

static void normalize_d(double v[3])
{
    const double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
}

/* The midpoint vertex of edge (a, b), made on first use and projected onto the unit sphere. */
static uint32_t edge_mid(edge_slot *tab, size_t mask, double *pos, uint32_t *vcount, uint32_t a, uint32_t b)
{
    const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    const uint64_t key = (((uint64_t)lo << 32) | hi) + 1u;
    size_t h = (size_t)((key * UINT64_C(0x9E3779B97F4A7C15)) >> 32) & mask;
    while (tab[h].key && tab[h].key != key)
        h = (h + 1) & mask;
    if (tab[h].key)
        return tab[h].mid;
    const uint32_t v = (*vcount)++;
    for (int k = 0; k < 3; k++)
        pos[3 * (size_t)v + (size_t)k] = (pos[3 * (size_t)a + (size_t)k] + pos[3 * (size_t)b + (size_t)k]) * 0.5;
    normalize_d(&pos[3 * (size_t)v]);
    tab[h].key = key;
    tab[h].mid = v;
    return v;
}

/* The unit icosphere of level L in binary64: the icosahedron (vertices (+-1, +-phi, 0) and their cyclic
 * permutations, normalised; faces counter-clockwise seen from outside), each level splitting every triangle into
 * four at its edge midpoints, pushed out onto the sphere. Midpoints are shared through the edge table, so the mesh
 * is closed: V = 10 * 4^L + 2 vertices, T = 20 * 4^L triangles, every edge in exactly two triangles. */
static int icosphere(uint32_t level, double **pos_out, uint32_t **idx_out)
{
    static const uint32_t faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                          {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                          {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                          {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    const uint32_t vmax = 10u * (1u << (2 * level)) + 2u, tmax = 20u * (1u << (2 * level));
    double *pos = rto__alloc(3 * (size_t)vmax, sizeof *pos);
    uint32_t *idx = rto__alloc(3 * (size_t)tmax, sizeof *idx);
    uint32_t *tmp = rto__alloc(3 * (size_t)tmax, sizeof *tmp);
    /* A level splits 3 / 2 edges per input triangle, at most 3 T / 8 for the final T: a table of 2 T slots stays
     * under a fifth full, so probes are short. */
    const size_t slots = rto_next_pow2(2 * (size_t)tmax);
    edge_slot *tab = rto__alloc(slots, sizeof *tab);
    if (!pos || !idx || !tmp || !tab) {
        free(pos);
        free(idx);
        free(tmp);
        free(tab);
        return 0;
    }
    const double g = (1.0 + sqrt(5.0)) * 0.5; /* the golden ratio */
    const double ico[12][3] = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                               {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
    for (uint32_t v = 0; v < 12; v++) {
        double p[3] = {ico[v][0], ico[v][1], ico[v][2]};
        normalize_d(p);
        memcpy(&pos[3 * v], p, sizeof p);
    }
    memcpy(idx, faces, sizeof faces);
    uint32_t vcount = 12, tcount = 20;
    for (uint32_t l = 0; l < level; l++) {
        memset(tab, 0, slots * sizeof *tab);
        uint32_t n = 0;
        for (uint32_t t = 0; t < tcount; t++) {
            const uint32_t a = idx[3 * t], b = idx[3 * t + 1], c = idx[3 * t + 2];
            const uint32_t ab = edge_mid(tab, slots - 1, pos, &vcount, a, b);
            const uint32_t bc = edge_mid(tab, slots - 1, pos, &vcount, b, c);
            const uint32_t ca = edge_mid(tab, slots - 1, pos, &vcount, c, a);
            /* The four children keep the parent's winding. */
            const uint32_t kids[12] = {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca};
            memcpy(&tmp[3 * (size_t)n], kids, sizeof kids);
            n += 4;
        }
        memcpy(idx, tmp, 3 * (size_t)n * sizeof *idx);
        tcount = n;
    }
    free(tmp);
    free(tab);
    *pos_out = pos;
    *idx_out = idx;
    return 1;
}

static rto_status load_sphere(const char *spec, const char *arg, rto_scene *s, rto_msg *msg)
{
    char level_text[16];
    const char *colon = strchr(arg, ':');
    const size_t len = colon ? (size_t)(colon - arg) : strlen(arg);
    uint32_t level, seed = 0;
    if (len >= sizeof level_text)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': L must be an integer 0 .. %u", spec,
                        SPHERE_MAX_LEVEL);
    memcpy(level_text, arg, len);
    level_text[len] = '\0';
    if (!parse_count(level_text, SPHERE_MAX_LEVEL, &level))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': L must be an integer 0 .. %u", spec,
                        SPHERE_MAX_LEVEL);
    if (colon && !parse_u32(colon + 1, &seed))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': SEED must be an integer 0 .. 4294967295", spec);
    double *pos;
    uint32_t *idx;
    if (!icosphere(level, &pos, &idx))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    const uint32_t nv = 10u * (1u << (2 * level)) + 2u, nt = 20u * (1u << (2 * level));
    rto_mesh *m = add_mesh(s, colon ? "icosphere-bumpy" : "icosphere", nv, nt);
    if (!m) {
        free(pos);
        free(idx);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    /* With a seed, vertex v moves along its radius to 0.6 + 0.8 unit(v) of it: still closed, and star-shaped about
     * the origin (every triangle keeps det[a, b, c] > 0 seen from the centre), so it stays free of self-crossings and
     * its faces keep pointing out. */
    draws d = draws_start(seed, 0x200u);
    for (uint32_t v = 0; v < nv; v++) {
        const double f = colon ? 0.6 + 0.8 * draw_unit(&d) : 1.0;
        for (int k = 0; k < 3; k++)
            m->positions[3 * (size_t)v + (size_t)k] = (float)(pos[3 * (size_t)v + (size_t)k] * f);
    }
    memcpy(m->indices, idx, 3 * (size_t)nt * sizeof *idx);
    free(pos);
    free(idx);
    rto_status st = alloc_instances(s, 1, msg);
    if (!st)
        st = set_instance(&s->instances[0], 0, 1.0, 0.0, 0.0, 0.0, msg);
    if (!st && add_framing_camera(s, "sphere", 0.0, 0.0, 0.0, colon ? 1.4 : 1.0))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return st;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* random:SEED                                                                                                      */

#define RANDOM_MAX_MESHES 4u
#define RANDOM_MAX_TRIANGLES 300u
#define RANDOM_MAX_INSTANCES 40u

static void random_point(draws *d, double lo, double hi, double p[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = draw_range(d, lo, hi);
}

static uint32_t put_vertex(rto_mesh *m, uint32_t *nv, const double p[3])
{
    for (int k = 0; k < 3; k++)
        m->positions[3 * (size_t)*nv + (size_t)k] = (float)p[k];
    return (*nv)++;
}

/* A triangle soup in about [-1, 1]^3 for brute-force comparisons. Per triangle (the ratios of a 32-way draw): 10 in
 * 32 share an edge of an earlier triangle, run the other way as in a consistently wound mesh, with a third vertex
 * near it (ties on shared edges); 4 in 32 are slivers, the third vertex 1e-4 of the edge length off the line
 * through the other two; 1 in 32 is degenerate (a repeated vertex: det = 0 for every ray); the rest are ordinary
 * triangles of size 0.1 .. 1. Every vertex is binary64 rounded once. */
static rto_status random_mesh(draws *d, rto_mesh *m, uint32_t index)
{
    char name[32];
    snprintf(name, sizeof name, "random-%u", index);
    const uint32_t nt = 1 + draw_below(d, RANDOM_MAX_TRIANGLES);
    if (!mesh_init(m, name, 3 * nt, nt))
        return RTO_ERR_OUT_OF_MEMORY;
    uint32_t nv = 0;
    for (uint32_t t = 0; t < nt; t++) {
        const uint32_t kind = draw_below(d, 32);
        uint32_t *tri = &m->indices[3 * (size_t)t];
        double a[3], b[3], c[3], off[3];
        if (t > 0 && kind < 10) {
            const uint32_t p = draw_below(d, t), e = draw_below(d, 3);
            const uint32_t ia = m->indices[3 * (size_t)p + e], ib = m->indices[3 * (size_t)p + (e + 1) % 3];
            double len2 = 0;
            for (int k = 0; k < 3; k++) {
                a[k] = m->positions[3 * (size_t)ia + (size_t)k];
                b[k] = m->positions[3 * (size_t)ib + (size_t)k];
                len2 += (b[k] - a[k]) * (b[k] - a[k]);
            }
            random_point(d, -1.0, 1.0, off);
            const double len = sqrt(len2) > 0 ? sqrt(len2) : 0.1;
            for (int k = 0; k < 3; k++)
                c[k] = (a[k] + b[k]) * 0.5 + off[k] * len;
            tri[0] = ib;
            tri[1] = ia;
            tri[2] = put_vertex(m, &nv, c);
            continue;
        }
        random_point(d, -1.0, 1.0, a);
        const double size = draw_range(d, 0.1, 1.0);
        random_point(d, -1.0, 1.0, off);
        for (int k = 0; k < 3; k++)
            b[k] = a[k] + off[k] * size;
        tri[0] = put_vertex(m, &nv, a);
        tri[1] = put_vertex(m, &nv, b);
        if (kind == 14) {
            tri[2] = tri[0];
            continue;
        }
        random_point(d, -1.0, 1.0, off);
        if (kind >= 10 && kind < 14) {
            const double lambda = draw_range(d, -0.5, 1.5);
            double len2 = 0;
            for (int k = 0; k < 3; k++)
                len2 += (b[k] - a[k]) * (b[k] - a[k]);
            for (int k = 0; k < 3; k++)
                c[k] = a[k] + lambda * (b[k] - a[k]) + off[k] * 1e-4 * sqrt(len2);
        } else {
            for (int k = 0; k < 3; k++)
                c[k] = a[k] + off[k] * size;
        }
        tri[2] = put_vertex(m, &nv, c);
    }
    m->vertex_count = nv;
    return RTO_OK;
}

/* A random rotation (Shoemake's uniform unit quaternion), a scale of 0.3 .. 2 per axis (x negated for a mirroring
 * instance), a translation in [-3, 3]^3: objToWorld = [R diag(s) | t], in binary64. */
static void random_transform(draws *d, int mirror, double m[3][4])
{
    const double u1 = draw_unit(d), u2 = draw_unit(d), u3 = draw_unit(d);
    const double tau = 2.0 * 3.14159265358979323846;
    const double x = sqrt(1.0 - u1) * sin(tau * u2), y = sqrt(1.0 - u1) * cos(tau * u2);
    const double z = sqrt(u1) * sin(tau * u3), w = sqrt(u1) * cos(tau * u3);
    const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    double s[3];
    for (int k = 0; k < 3; k++)
        s[k] = draw_range(d, 0.3, 2.0);
    if (mirror)
        s[0] = -s[0];
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            m[row][col] = r[row][col] * s[col];
        m[row][3] = draw_range(d, -3.0, 3.0);
    }
}

static rto_status load_random(const char *spec, const char *arg, rto_scene *s, rto_msg *msg)
{
    uint32_t seed;
    if (!parse_u32(arg, &seed))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "'%.100s': SEED must be an integer 0 .. 4294967295", spec);
    draws d = draws_start(seed, 0x201u);
    const uint32_t nm = 1 + draw_below(&d, RANDOM_MAX_MESHES);
    s->meshes = calloc(nm, sizeof *s->meshes);
    if (!s->meshes)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    s->mesh_count = nm;
    for (uint32_t i = 0; i < nm; i++)
        if (random_mesh(&d, &s->meshes[i], i))
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    const uint32_t ni = 1 + draw_below(&d, RANDOM_MAX_INSTANCES);
    rto_status st = alloc_instances(s, ni, msg);
    if (st)
        return st;
    /* One instance always mirrors (det < 0: facing flips in object space), others with probability 1/4; with three
     * or more instances one has mask 0, which no cullMask 0xFF ray may visit. */
    const uint32_t mirrored = draw_below(&d, ni);
    const uint32_t masked = ni >= 3 ? draw_below(&d, ni) : UINT32_MAX;
    for (uint32_t i = 0; i < ni; i++) {
        rto_instance *in = &s->instances[i];
        in->blas = draw_below(&d, nm);
        const int mirror = i == mirrored || draw_below(&d, 4) == 0;
        double m[3][4];
        random_transform(&d, mirror, m);
        in->custom_index = draw_u32(&d) & RTO_INSTANCE_CUSTOM_INDEX_MASK;
        in->sbt_offset = draw_below(&d, 8);
        in->mask = i == masked ? 0u : 1u + draw_below(&d, 255);
        in->flags = 0;
        st = rto_instance_set_transform(in, (const double(*)[4])m, msg);
        if (st)
            return st;
    }
    const rto_aabb b = rto_scene_aabb(s);
    const double c[3] = {((double)b.min.x + b.max.x) * 0.5, ((double)b.min.y + b.max.y) * 0.5,
                         ((double)b.min.z + b.max.z) * 0.5};
    const double dx = (double)b.max.x - b.min.x, dy = (double)b.max.y - b.min.y, dz = (double)b.max.z - b.min.z;
    const double r = 0.5 * sqrt(dx * dx + dy * dy + dz * dz);
    if (add_framing_camera(s, "random", c[0], c[1], c[2], r > 0 ? r : 1.0))
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    return RTO_OK;
}

int rto__procedural_is(const char *spec)
{
    return !strcmp(spec, "triangle") || !strncmp(spec, "rtstress:", 9) || !strncmp(spec, "instances:", 10) ||
           !strncmp(spec, "sphere:", 7) || !strncmp(spec, "random:", 7);
}

rto_status rto__procedural_load(const char *spec, rto_scene *scene, rto_msg *msg)
{
    if (!strcmp(spec, "triangle"))
        return load_triangle(scene, msg);
    if (!strncmp(spec, "rtstress:", 9))
        return load_rtstress(spec, spec + 9, scene, msg);
    if (!strncmp(spec, "instances:", 10))
        return load_instances(spec, spec + 10, scene, msg);
    if (!strncmp(spec, "sphere:", 7))
        return load_sphere(spec, spec + 7, scene, msg);
    if (!strncmp(spec, "random:", 7))
        return load_random(spec, spec + 7, scene, msg);
    return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                    "unknown procedural scene '%.100s' (triangle, rtstress:N, instances:DIST:N, sphere:L[:SEED], "
                    "random:SEED)",
                    spec);
}
