/* Shared helpers for the cmocka tests: independent references (qsort, literal schedules), seeds, the tests' own
 * random stream and scene loading. */
#ifndef RTO_TESTUTIL_H
#define RTO_TESTUTIL_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <dirent.h>

#include "rtoracle.h"

/* Under AddressSanitizer (about 5-10x slower) the largest property sweeps run smaller instances of every case class:
 * TU_SIZED(full, sanitized). scripts/test.sh runs the same tests at full size in the optimised build, so nothing is
 * left untested; the sanitizer build still sees every code path (each size class, path, thread count and shape). */
#if defined(__SANITIZE_ADDRESS__)
#define TU_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TU_SANITIZED 1
#endif
#endif
#ifndef TU_SANITIZED
#define TU_SANITIZED 0
#endif
#define TU_SIZED(full, sanitized) (TU_SANITIZED ? (sanitized) : (full))

/* Under the sanitizer, key-array sweeps above 4097 keys (where every shape has already run) keep four shapes: distinct
 * keys, few unique keys, sentinels and one bucket. */
static inline int tu_sanitized_skip(const char *dist, size_t n)
{
    return TU_SANITIZED && n > 4097 && strcmp(dist, "random") && strcmp(dist, "few-unique") &&
           strcmp(dist, "sentinel-heavy") && strcmp(dist, "one-bucket");
}

/* Under the sanitizer, a case swept over n_threads thread counts runs the first (one thread) and one other, which
 * rotates with the case number: every thread count still runs across the sweep, each case twice instead of n times. */
static inline int tu_sanitized_thread_skip(size_t case_no, size_t ti, size_t n_threads)
{
    return TU_SANITIZED && n_threads > 2 && ti != 0 && ti != 1 + case_no % (n_threads - 1);
}

static inline int tu_cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static inline uint64_t tu_get(rto_key_format f, const void *k, size_t i)
{
    return f == RTO_KEY_U32 ? ((const uint32_t *)k)[i] : ((const uint64_t *)k)[i];
}

static inline void tu_put(rto_key_format f, void *k, size_t i, uint64_t v)
{
    if (f == RTO_KEY_U32)
        ((uint32_t *)k)[i] = (uint32_t)v;
    else
        ((uint64_t *)k)[i] = v;
}

/* The keys widened to u64 and sorted by the C library's qsort: the independent reference order. */
static inline uint64_t *tu_qsorted(rto_key_format f, const void *keys, size_t n)
{
    uint64_t *e = malloc((n ? n : 1) * sizeof *e);
    assert_non_null(e);
    for (size_t i = 0; i < n; i++)
        e[i] = tu_get(f, keys, i);
    qsort(e, n, sizeof *e, tu_cmp_u64);
    return e;
}

static inline int tu_cmp_pair(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    if (x[0] != y[0])
        return (x[0] > y[0]) - (x[0] < y[0]);
    return (x[1] > y[1]) - (x[1] < y[1]);
}

/* The correct stable key/value dump of gn slots (gn >= n), by qsort of (key, source index) pairs: the input's n keys,
 * then sentinels whose padding slot p carries n + p; keys into out (format f), indices into values. */
static inline void tu_stable_dump(rto_key_format f, const void *input, size_t n, size_t gn, uint64_t sentinel,
                                  void *out, uint32_t *values)
{
    uint64_t *pairs = malloc((gn ? gn : 1) * 16);
    assert_non_null(pairs);
    for (size_t i = 0; i < gn; i++) {
        pairs[2 * i] = i < n ? tu_get(f, input, i) : sentinel;
        pairs[2 * i + 1] = i;
    }
    qsort(pairs, gn, 16, tu_cmp_pair);
    for (size_t i = 0; i < gn; i++) {
        tu_put(f, out, i, pairs[2 * i]);
        values[i] = (uint32_t)pairs[2 * i + 1];
    }
    free(pairs);
}

/* Generates keys or fails the test with the library's message. */
static inline void *tu_keys(const char *dist, rto_key_format f, uint32_t seed, size_t n)
{
    void *k = malloc(n ? n * (f == RTO_KEY_U32 ? 4 : 8) : 1);
    assert_non_null(k);
    rto_msg msg = {{0}};
    rto_status s = rto_keys_generate(dist, f, seed, n, k, &msg);
    if (s)
        fail_msg("rto_keys_generate(%s, n=%zu): %s", dist, n, msg.text);
    return k;
}

/* Whether a distribution exists for (format, n): the same rule the suite applies. */
static inline int tu_dist_applies(const rto_dist_info *d, rto_key_format f, size_t n)
{
    if (d->u64_only && f == RTO_KEY_U32)
        return 0;
    if (d->kind == RTO_DIST_CENTROID && f == RTO_KEY_U32 && n > RTO_TLAS_MAX_INSTANCES)
        return 0;
    return 1;
}

/* splitmix64: a test's own random stream, not the library's generators, so a bug there cannot hide one here. */
static inline uint64_t tu_rng_next(uint64_t *s)
{
    uint64_t z = (*s += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double tu_rng_unit(uint64_t *s) { return (double)(tu_rng_next(s) >> 11) * 0x1.0p-53; }

/* A direction uniform on the unit sphere, in binary64: z uniform in [-1, 1), then an angle around the z axis. */
static inline void tu_rng_dir(uint64_t *s, double d[3])
{
    const double z = 2.0 * tu_rng_unit(s) - 1.0, phi = 6.283185307179586 * tu_rng_unit(s), r = sqrt(1.0 - z * z);
    d[0] = r * cos(phi);
    d[1] = r * sin(phi);
    d[2] = z;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Vectors in binary64, for references computed independently of the library's binary32 code                       */

static inline void tu_sub3(const double a[3], const double b[3], double o[3])
{
    for (int k = 0; k < 3; k++)
        o[k] = a[k] - b[k];
}
static inline double tu_dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void tu_cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static inline void tu_unit3(double v[3])
{
    const double l = sqrt(tu_dot3(v, v));
    for (int k = 0; k < 3; k++)
        v[k] /= l;
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Scratch directories and files                                                                                    */

/* A fresh directory /tmp/rto_<name>_XXXXXX in dir (a cmocka setup's work): 0, or -1 when it cannot be made. */
static inline int tu_tmpdir_make(char *dir, size_t cap, const char *name)
{
    snprintf(dir, cap, "/tmp/rto_%s_XXXXXX", name);
    return mkdtemp(dir) ? 0 : -1;
}

/* Removes a scratch directory and everything in it (a cmocka teardown's work): 0, or -1 on failure. */
static inline int tu_tmpdir_remove(const char *dir)
{
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* How many entries a directory holds, "." and ".." not counted: what an atomic writer left behind. */
static inline size_t tu_dir_entries(const char *dir)
{
    DIR *d = opendir(dir);
    size_t n = 0;
    for (struct dirent *e; d && (e = readdir(d));)
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    if (d)
        closedir(d);
    return n;
}

/* The CRC-32 of a PNG chunk (PNG spec §5.5, ISO 3309), bit by bit: the tests write their own PNG files. */
static inline uint32_t tu_crc32_png(const unsigned char *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++)
            c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    }
    return c ^ 0xFFFFFFFFu;
}

/* Loads a scene or fails the test with the library's message. A spec naming a relative path is taken under
 * $RTO_FIXTURES, so the tests run from any directory. */
static inline rto_scene *tu_load(const char *spec)
{
    char path[1024];
    const char *fx = getenv("RTO_FIXTURES");
    if (strchr(spec, '/') && fx && spec[0] != '/') {
        snprintf(path, sizeof path, "%s/%s", fx, spec);
        spec = path;
    }
    rto_scene *s = NULL;
    rto_msg msg = {{0}};
    if (rto_scene_load(spec, &s, &msg))
        fail_msg("load %s: %s", spec, msg.text);
    return s;
}

/* The accel of a scene with a TLAS of the given kind, or the test fails with the library's message. */
static inline rto_accel *tu_accel(const rto_scene *s, rto_tlas_kind kind)
{
    rto_accel_desc d = {kind, 0};
    rto_accel *a = NULL;
    rto_msg msg = {{0}};
    if (rto_accel_build(s, &d, &a, &msg))
        fail_msg("rto_accel_build(%s): %s", s->source, msg.text);
    return a;
}

/* Vertex c (0..2) of triangle p of instance k in world space: objToWorld applied in binary64. */
static inline void tu_world_vertex(const rto_scene *s, uint32_t k, uint32_t p, int c, double out[3])
{
    const rto_instance *in = &s->instances[k];
    const rto_mesh *m = &s->meshes[in->blas];
    const float *v = &m->positions[3 * (size_t)m->indices[3 * (size_t)p + (size_t)c]];
    for (int r = 0; r < 3; r++)
        out[r] = (double)in->obj_to_world.m[r][0] * v[0] + (double)in->obj_to_world.m[r][1] * v[1] +
                 (double)in->obj_to_world.m[r][2] * v[2] + (double)in->obj_to_world.m[r][3];
}

/* The hit record a correct GPU writes for triangle p of instance k (with its instance in), from the scene alone:
 * objToWorld as WGSL's column-major mat4x3 (column c holds row-major column c), padding 0. */
static inline rto_hit_record tu_hit_record(const rto_instance *in, uint32_t k, uint32_t p, float t, float u, float v)
{
    rto_hit_record h;
    memset(&h, 0, sizeof h);
    h.t = t;
    h.instance_id = k;
    h.prim_id = p;
    h.hit_group = in->sbt_offset;
    h.bary[0] = u;
    h.bary[1] = v;
    h.custom_index = in->custom_index;
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            h.obj_to_world[c][r] = in->obj_to_world.m[r][c];
    return h;
}

/* A ray from binary64 origin and direction (rounded to binary32), cull mask 0xFF, the other fields 0. */
static inline rto_wf_ray tu_ray(const double o[3], const double d[3], float t_min, float t_max, uint32_t flags)
{
    rto_wf_ray r;
    memset(&r, 0, sizeof r);
    for (int a = 0; a < 3; a++) {
        r.origin[a] = (float)o[a];
        r.dir[a] = (float)d[a];
    }
    r.t_min = t_min;
    r.t_max = t_max;
    r.flags = flags;
    r.cull_mask = 0xFF;
    return r;
}

/* The miss record of a ray: t = tMax, the four IDs 0xFFFFFFFF, the rest 0. */
static inline rto_hit_record tu_miss_record(float t_max)
{
    rto_hit_record h;
    memset(&h, 0, sizeof h);
    h.t = t_max;
    h.instance_id = h.prim_id = h.hit_group = h.custom_index = UINT32_MAX;
    h.miss_flag = 1;
    return h;
}

/* A scene of one mesh (the caller's positions and indices, not copied) and one instance of it through xf, mask
 * 0xFF. The scene points into the struct: make it where it stays. */
typedef struct tu_scene1 {
    rto_mesh mesh;
    rto_instance inst;
    rto_scene scene;
} tu_scene1;

static inline void tu_scene1_make(tu_scene1 *s, float *pos, uint32_t nv, uint32_t *idx, uint32_t nt,
                                  const double xf[3][4])
{
    memset(s, 0, sizeof *s);
    s->mesh.vertex_count = nv;
    s->mesh.positions = pos;
    s->mesh.triangle_count = nt;
    s->mesh.indices = idx;
    s->mesh.material = -1;
    rto_msg msg = {{0}};
    if (rto_instance_set_transform(&s->inst, xf, &msg))
        fail_msg("tu_scene1_make: %s", msg.text);
    s->inst.mask = 0xFF;
    s->scene.meshes = &s->mesh;
    s->scene.mesh_count = 1;
    s->scene.instances = &s->inst;
    s->scene.instance_count = 1;
}

#endif
