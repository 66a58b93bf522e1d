/* rtoracle: a CPU reference ("oracle") for GPU software ray tracers.
 *
 * Reference
 * ---------
 * Every stage of a wavefront GPU tracer is re-implemented here in deterministic scalar C, and its output is written
 * as the expected value a GPU harness compares against (DESIGN.md §1):
 *
 *     keys      rto_keys_generate / rto_tlas_keys / rto_blas_keys          Morton keys and named distributions (§3)
 *               rto_tlas_keys_from_boxes / rto_mesh_keys                   keys of instance and triangle boxes
 *     sort      rto_bitonic_sort (+ checkpoints) / rto_radix_sort          the canonical network and LSD radix (§4)
 *               rto_fast_radix_sort                                        the sort builds use for real keys
 *     check     rto_sort_check                                             sorted / permutation / stable / passes (§9)
 *     scene     rto_scene_load / rto_scene_destroy                         glTF and procedural scenes (§5)
 *     build     rto_accel_build / rto_accel_destroy                        every tree of a scene (§5), read through
 *               rto_accel_get_tlas / rto_accel_get_blas                    views of its arrays, counts and stats
 *               rto_tlas_build_sweep / rto_karras_build                    one tree from sorted keys
 *     check     rto_accel_check, rto_tlas_check / rto_karras_check         trees: structure, links, boxes (§9)
 *     report    rto_report, rto_report_text / rto_report_json              one report shape for every validator
 *     layouts   rto_layout_desc / rto_layout_accept                        GPU structs as .npy dtypes (§5-§7)
 *     files     rto_npy_read / rto_npy_write, rto_bundle_*                 .npy arrays and manifest.json (§8)
 *     bundles   rto_<stage>_bundle_write / _read / _free                   each stage's golden files (sort, scene,
 *                                                                          bvh, trace, frame)
 *               rto_file_write, rto_temporaries_remove                     atomic output, cleanup on SIGINT / SIGTERM
 *
 * A build, start to end:
 *
 *     rto_msg msg = {{0}};
 *     rto_scene *scene = NULL;
 *     rto_accel *accel = NULL;
 *     rto_accel_desc desc = {RTO_TLAS_SWEEP, 0};                  // zero-initialised = the defaults
 *     if (rto_scene_load("bunny.gltf", &scene, &msg) || rto_accel_build(scene, &desc, &accel, &msg))
 *         fprintf(stderr, "%s\n", msg.text);                      // ... and stop
 *     const rto_accel_tlas *tlas = rto_accel_get_tlas(accel);     // tlas->sweep_nodes[0 .. tlas->node_count - 1]
 *     const rto_accel_blas *blas = rto_accel_get_blas(accel, 0);  // blas->nodes, blas->order, ...
 *     rto_accel_destroy(accel);                                   // before the scene it borrows
 *     rto_scene_destroy(scene);
 *
 * Conventions: fallible calls return rto_status and, when given a non-NULL rto_msg, write a one-line
 * reason into it; outputs are caller-allocated and sized by the documented bound; inputs first, outputs last;
 * every *_free / *_destroy accepts NULL. Keys are passed as `const void *` with an rto_key_format saying whether
 * they are uint32_t or uint64_t. The header is clean C11 and C++.
 */
#ifndef RTORACLE_H
#define RTORACLE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define RTO_VERSION_STRING "0.1.0"
/* Bundle layout version written into every manifest.json; readers refuse any other value (§8). */
#define RTO_BUNDLE_FORMAT_VERSION 1

/* Compile-time checks of the GPU struct layouts, in C11 and in C++ alike. */
#ifdef __cplusplus
#define RTO_STATIC_ASSERT(cond, what) static_assert(cond, what)
#else
#define RTO_STATIC_ASSERT(cond, what) _Static_assert(cond, what)
#endif

/* ---------------------------------------------------------------------------------------------------------------- */
/* Status                                                                                                           */

typedef enum rto_status {
    RTO_OK = 0,
    RTO_ERR_INVALID_ARGUMENT = 1,
    RTO_ERR_OUT_OF_MEMORY = 2,
    RTO_ERR_BUFFER_TOO_SMALL = 3,
    RTO_ERR_IO = 4,
    RTO_ERR_PARSE = 5,
    RTO_ERR_UNSUPPORTED = 6,
    RTO_ERR_MISMATCH = 7
} rto_status;

/** Names a status ("ok", "invalid argument", ...). Never returns NULL. */
const char *rto_status_string(rto_status s);

/** The detail of a failure: one line, no trailing newline. Zero-initialise before use. */
typedef struct rto_msg {
    char text[512];
} rto_msg;

/** Writes a formatted one-line reason into msg (when non-NULL) and returns s: how every fallible call reports, and
 * how a harness or program of its own reports through the same channel. */
rto_status rto_msg_set(rto_msg *msg, rto_status s, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---------------------------------------------------------------------------------------------------------------- */
/* PRNG (DESIGN.md §3): counter-based, reproducible in C, JS and WGSL                                               */

/** The 32-bit finaliser h(x): x ^= x >> 16; x *= 0x7feb352d; x ^= x >> 15; x *= 0x846ca68b; x ^= x >> 16. */
uint32_t rto_hash32(uint32_t x);
/** rng(seed, i) = h(i ^ h(seed)). */
uint32_t rto_rng(uint32_t seed, uint32_t i);
/** unit(seed, i) = (rng(seed, i) >> 8) * 2^-24, in [0, 1). */
float rto_unit(uint32_t seed, uint32_t i);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Morton keys (DESIGN.md §3)                                                                                        */

typedef enum rto_key_format {
    RTO_KEY_U32 = 0, /* TLAS keys and generic 32-bit keys; sentinel 0xFFFFFFFF */
    RTO_KEY_U64 = 1  /* BLAS keys and generic 64-bit keys; sentinel 0xFFFFFFFFFFFFFFFF */
} rto_key_format;

#define RTO_SENTINEL_U32 UINT32_C(0xFFFFFFFF)
#define RTO_SENTINEL_U64 UINT64_C(0xFFFFFFFFFFFFFFFF)
/** Largest key array any call accepts (2^28 keys: 1 GiB of u32, 2 GiB of u64). */
#define RTO_MAX_KEYS (UINT64_C(1) << 28)
/** Most instances a TLAS key can index (16-bit index field). */
#define RTO_TLAS_MAX_INSTANCES 65536u

typedef struct rto_vec3 {
    float x, y, z;
} rto_vec3;

/** An axis-aligned box. The empty box is (+inf, -inf) on every axis, the identity of the union. */
typedef struct rto_aabb {
    rto_vec3 min, max;
} rto_aabb;
RTO_STATIC_ASSERT(sizeof(rto_aabb) == 24, "Aabb is 24 bytes");

/** A triangle mesh of a scene and a row-major 3x4 transform (defined with the scenes below). */
typedef struct rto_mesh rto_mesh;
typedef struct rto_mat34 rto_mat34;

/** Bytes per key of a format (4 or 8). */
size_t rto_key_size(rto_key_format f);
/** The padding sentinel of a format, widened to 64 bits. */
uint64_t rto_key_sentinel(rto_key_format f);

/** Interleaves three 5-bit coordinates, x in the highest position of each triple (bits 14, 11, ... for x). */
uint32_t rto_morton15(uint32_t qx, uint32_t qy, uint32_t qz);
/** Interleaves three 10-bit coordinates, x highest in each triple. */
uint32_t rto_morton30(uint32_t qx, uint32_t qy, uint32_t qz);

/**
 * TLAS keys from instance centroids: (morton15 << 16) | index, quantised over the centroids' bounds in binary32.
 * keys must hold n entries; n <= RTO_TLAS_MAX_INSTANCES; centroids must be finite.
 */
rto_status rto_tlas_keys(const rto_vec3 *centroids, size_t n, uint32_t *keys, rto_msg *msg);
/** BLAS keys from triangle centroids: (morton30 << 32) | index, 10 bits per axis. n < 2^32; finite centroids. */
rto_status rto_blas_keys(const rto_vec3 *centroids, size_t n, uint64_t *keys, rto_msg *msg);
/** Primitive index of a sorted key: the low 16 bits of a TLAS key, the low 32 bits of a BLAS key. */
uint32_t rto_key_prim(rto_key_format f, uint64_t key);

/* Keys of scene boxes (docs/bvh.md "Primitive boxes"): what the builders key their trees by. */

/* Boxes (src/core/aabb.c, the one home of these rules for the library and the command). */

/** The empty box, min (+inf, +inf, +inf) and max (-inf, -inf, -inf): what every writer stores for "no geometry" (an
 * empty mesh's object box, the world box of an instance of an empty BLAS, an empty tree node). */
rto_aabb rto_aabb_empty(void);
/** 1 if min > max on some axis (the empty box, or any inverted box), else 0. A NaN bound makes a box invalid, not
 * empty (0): the finite checks after it refuse it. */
int rto_aabb_is_empty(const rto_aabb *box);
/** 1 if the six bounds are equal as numbers (+0 == -0: which zero a min keeps depends on the vertex order). */
int rto_aabb_equal(const rto_aabb *a, const rto_aabb *b);
/** 1 if every bound is finite and min <= max on every axis (a box that holds a point and no infinity), else 0. */
int rto_aabb_is_finite(const rto_aabb *box);
/** The point a key is built from: the box centroid (min + max) * 0.5 in binary32. */
rto_vec3 rto_aabb_centroid(const rto_aabb *box);
/** Bounds of triangle t of a mesh (exact min / max of its three vertices). t < triangle_count. */
rto_aabb rto_mesh_triangle_aabb(const rto_mesh *mesh, uint32_t t);
/**
 * A box through a transform: its 8 corners through rto_mat34_point (corner c takes max on axis a when bit a of c is
 * set, c = 0 .. 7), then min / max; a box that is empty (or NaN) stays the empty box. An instance's world box is its
 * mesh's rto_mesh_aabb through objToWorld: the same bytes as rto_instance_aabb.
 */
rto_aabb rto_aabb_transform(const rto_mat34 *m, const rto_aabb *box);
/** BLAS keys of n primitive boxes: rto_blas_keys of their centroids. keys holds n entries. */
rto_status rto_blas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint64_t *keys, rto_msg *msg);
/** BLAS keys of a mesh: (morton30 << 32) | triangle, from each triangle's box centroid. keys: triangle_count. */
rto_status rto_mesh_keys(const rto_mesh *mesh, uint64_t *keys, rto_msg *msg);
/**
 * TLAS keys of n instance world boxes (DESIGN.md §3, §5). An empty box gets no key; the others get
 * (morton15 << 16) | instance index, quantised over the bounds of the non-empty boxes' centroids. keys (n entries of
 * room) receives them in instance order, *key_count their number. n <= RTO_TLAS_MAX_INSTANCES.
 */
rto_status rto_tlas_keys_from_boxes(const rto_aabb *boxes, size_t n, uint32_t *keys, size_t *key_count,
                                    rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Distributions and size classes (DESIGN.md §3)                                                                    */

typedef enum rto_dist_kind {
    RTO_DIST_CENTROID = 0, /* generates centroids; keys are Morton keys of those centroids */
    RTO_DIST_RAW = 1       /* generates keys directly */
} rto_dist_kind;

typedef struct rto_dist_info {
    const char *name;    /* "uniform", "entropy-3", "digit-2-one-bucket", ... */
    rto_dist_kind kind;
    int u64_only;        /* 1 for digit-D-one-bucket with D >= 4 */
    const char *summary; /* one line for --help */
} rto_dist_info;

/** Number of named distributions; rto_dist_at(i) for i < count lists them in a fixed order. */
size_t rto_dist_count(void);
const rto_dist_info *rto_dist_at(size_t i);
/** Looks a distribution up by name; NULL if unknown. */
const rto_dist_info *rto_dist_find(const char *name);

/** Centroids of a centroid distribution (kind RTO_DIST_CENTROID). out holds n entries. */
rto_status rto_centroids_generate(const char *dist, uint32_t seed, size_t n, rto_vec3 *out, rto_msg *msg);
/**
 * n keys of distribution dist in format f: Morton keys (TLAS u32 / BLAS u64) of the generated centroids for a
 * centroid distribution, raw keys otherwise. keys holds n * rto_key_size(f) bytes.
 */
rto_status rto_keys_generate(const char *dist, rto_key_format f, uint32_t seed, size_t n, void *keys, rto_msg *msg);
/**
 * The most bytes rto_keys_generate may allocate besides keys for n keys of dist in format f: the C library's sort
 * buffer for "sorted" and "reversed" (n keys), the centroids of a centroid distribution (generated in chunks of
 * 2^16 for u64 keys, whole for the at most 65,536 of u32). The caller adds the n * rto_key_size(f) of keys.
 */
uint64_t rto_keys_memory_bound(const char *dist, rto_key_format f, size_t n);

/** Named size classes: "tiny", "tile", "pow2", "large", "all" (the union, ascending, unique). */
#define RTO_SIZE_CLASS_MAX 128
/** Writes the sizes of a class into sizes (capacity RTO_SIZE_CLASS_MAX) and their count into count. */
rto_status rto_size_class(const char *name, size_t *sizes, size_t *count, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Sorting (DESIGN.md §4)                                                                                            */

/** N_PADDED: next power of two >= n (0 for 0, 1 for 1). */
size_t rto_next_pow2(size_t n);
/** Passes of the canonical network over n_padded slots: L(L+1)/2 with L = log2(n_padded); 0 for n_padded <= 1. */
uint32_t rto_bitonic_pass_count(size_t n_padded);
/** The (k, j) of pass p of the canonical schedule (independent of n). */
void rto_bitonic_pass_kj(uint32_t pass, uint32_t *k, uint32_t *j);

/**
 * Runs the canonical bitonic network (DESIGN.md §4) on the n keys padded with the sentinel to n_padded slots.
 *   sorted       n_padded keys (the whole padded buffer a GPU dump holds).
 *   perm         NULL or n_padded uint32: the source index carried through the network with each key; padding
 *                element p carries n + p, so perm is a permutation of 0 .. n_padded-1.
 *   checkpoints  NULL or rto_bitonic_pass_count(n_padded) * n_padded keys: the buffer after every pass.
 */
rto_status rto_bitonic_sort(rto_key_format f, const void *keys, size_t n, void *sorted, uint32_t *perm,
                            void *checkpoints, rto_msg *msg);

/** Passes of an LSD radix sort: key bits / digit bits. */
uint32_t rto_radix_pass_count(rto_key_format f, uint32_t bits);
/** Tiles of T keys covering n keys (ceil(n / T)). */
size_t rto_radix_tile_count(size_t n, uint32_t tile);

/**
 * Per-pass intermediates of the LSD radix reference. Each pointer may be NULL; the sizes are, with P passes,
 * R = 2^bits digits and M tiles:
 *   hist    P * M * R   digit histogram of each tile, in input order of that pass
 *   prefix  P * R       exclusive prefix over all tiles' histograms (first slot of each digit)
 *   base    P * M * R   each tile's scatter base per digit: prefix[d] + sum of hist[t'][d] for t' < t
 *   scatter P * n keys  the array after the stable scatter of each pass
 *   perm    P * n       source index carried with each key after each pass
 */
typedef struct rto_radix_trace {
    uint32_t *hist;
    uint32_t *prefix;
    uint32_t *base;
    void *scatter;
    uint32_t *perm;
} rto_radix_trace;

/**
 * Stable LSD radix sort with digit width bits (4 or 8) and tile size tile (>= 1): sorted (n keys), perm (n source
 * indices, may be NULL) and, when trace is non-NULL, the per-pass intermediates above.
 */
rto_status rto_radix_sort(rto_key_format f, const void *keys, size_t n, uint32_t bits, uint32_t tile, void *sorted,
                          uint32_t *perm, const rto_radix_trace *trace, rto_msg *msg);

/**
 * Sorts n keys ascending into sorted (n keys, no sentinel tail; must not overlap keys) with a fast LSD radix sort:
 * the sort the builds use for real TLAS / BLAS keys (§4: they are unique, so any correct sort gives the same array as
 * the canonical network). Correct for any keys; fastest for keys whose low index field (16 bits of a u32 key, 32 of a
 * u64 key) grows with the input position, as rto_tlas_keys / rto_blas_keys make them: only the bits above it are
 * sorted. No permutation or checkpoints: use rto_bitonic_sort / rto_radix_sort where those are outputs.
 */
rto_status rto_fast_radix_sort(rto_key_format f, const void *keys, size_t n, void *sorted, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Validation reports (DESIGN.md §9): one shape for every check-* validator                                        */

/** How a report value is typed, so that keys print as hex, indices as integers and coordinates as floats. */
typedef enum rto_value_type {
    RTO_VALUE_NONE = 0,  /* absent: "-" in text, null in JSON */
    RTO_VALUE_HEX32 = 1, /* a u32 bit pattern (TLAS keys, items, links): 0x%08x, a JSON string */
    RTO_VALUE_HEX64 = 2, /* a u64 bit pattern (BLAS keys): 0x%016x, a JSON string */
    RTO_VALUE_UINT = 3,  /* an unsigned count or index: decimal */
    RTO_VALUE_INT = 4,   /* a signed difference: decimal with its sign */
    RTO_VALUE_F32 = 5,   /* a binary32 value (coordinates, t): 9 significant digits, which round-trip */
    RTO_VALUE_F64 = 6    /* a binary64 value (float differences, tolerances): 9 significant digits */
} rto_value_type;

/** A typed value: u for HEX32 / HEX64 / UINT, i for INT, f for F32 / F64. */
typedef struct rto_value {
    rto_value_type type;
    union {
        uint64_t u;
        int64_t i;
        double f;
    } v;
} rto_value;

/** State of one property a validator checks ("sorted", "permutation", "boxes", ...). */
typedef enum rto_check_state {
    RTO_CHECK_NOT_RUN = 0, /* "n/a" */
    RTO_CHECK_PASSED = 1,  /* "ok" */
    RTO_CHECK_FAILED = 2   /* "FAIL" */
} rto_check_state;

#define RTO_REPORT_NAME_MAX 24
#define RTO_REPORT_MAX_FIELDS 16
#define RTO_REPORT_MAX_CHECKS 8
#define RTO_REPORT_MAX_FAULTS 12
#define RTO_REPORT_MAX_ROWS 16

/** A named integer: a location ("node" 5, "slot" 2048, "pass" 45) or a size ("n" 4097, "nodes" 255). */
typedef struct rto_report_field {
    char name[RTO_REPORT_NAME_MAX];
    int64_t value;
} rto_report_field;

typedef struct rto_report_check {
    char name[RTO_REPORT_NAME_MAX];
    rto_check_state state;
} rto_report_check;

/** One row of the table of first differing elements: the element (index, and which field of a record), the
 * expected and actual values, their difference (xor for bit patterns, actual - expected otherwise) and the
 * tolerance that applied to it (NONE where the comparison is exact). */
typedef struct rto_report_row {
    uint64_t index;
    char field[RTO_REPORT_NAME_MAX]; /* "" for a scalar element, else "item", "left", "min.x", ... */
    rto_value expected, actual, diff, tolerance;
} rto_report_row;

/**
 * The result of a validator (check-sort, check-bvh, check-hits, check-frame). Filled by the validator;
 * rto_report_text and rto_report_json write it out. All strings are NUL-terminated.
 */
typedef struct rto_report {
    char validator[RTO_REPORT_NAME_MAX]; /* "check-sort", "check-bvh" */
    char what[96];     /* the thing checked: a case id, "TLAS (sweep)", "BLAS 0"; "" when unnamed */
    char context[160]; /* one line on what was compared: "4097 keys (u32), GPU dump of 4097 slots (n_padded 8192)" */
    char mode[RTO_REPORT_NAME_MAX]; /* "exact", "structure-only"; "" for validators with one mode */
    int code;                          /* the validator's fault enum (rto_fault, rto_bvh_fault); 0 = passed */
    char fault[RTO_REPORT_NAME_MAX];   /* its stable name; "none" when passed */
    char faults_seen[RTO_REPORT_MAX_FAULTS][RTO_REPORT_NAME_MAX]; /* every fault class found, the primary first */
    uint32_t nfaults_seen;
    rto_report_check checks[RTO_REPORT_MAX_CHECKS]; /* the properties checked, in a fixed order */
    uint32_t nchecks;
    rto_report_field where[RTO_REPORT_MAX_FIELDS]; /* location of the primary fault: node, leaf, slot, pass, k, j */
    uint32_t nwhere;
    rto_report_field facts[RTO_REPORT_MAX_FIELDS]; /* sizes of what was compared: n, gpu_n, nodes, leaves */
    uint32_t nfacts;
    char tolerance[224];    /* the comparison rule applied, with its DESIGN.md §9 source */
    double tolerance_bound; /* the absolute bound at the reported element; 0 when exact */
    char table_title[48];   /* what the rows compare: "keys", "source indices", "boxes", "items", "links" */
    char index_name[RTO_REPORT_NAME_MAX]; /* what a row's index counts: "slot", "node" */
    uint32_t nrows;
    rto_report_row rows[RTO_REPORT_MAX_ROWS]; /* the first differing elements of the primary fault */
    char summary[512]; /* one line: "<fault>: what failed, where, and why" ("ok: ..." when passed) */
} rto_report;

/** Whether a report records a pass (code 0). */
int rto_report_passed(const rto_report *r);
/** Looks up a location field ("node", "slot", ...): returns 1 and sets *value, or 0 when absent. */
int rto_report_where(const rto_report *r, const char *name, int64_t *value);
/** The state of a named check; RTO_CHECK_NOT_RUN when the report has no such check. */
rto_check_state rto_report_check_state(const rto_report *r, const char *name);

/**
 * Writes the report as text: a header line "<validator> <what>: <context>", "PASS|FAIL <summary>", then one item
 * per line: the mode, the checks ("ok", "FAIL", "n/a"), for a fault its location ("where") and the other fault
 * classes seen, the tolerance rule, for a fault the bound at the reported element and the table of first differing
 * elements.
 * buf receives up to cap bytes including the NUL; *len is set to the full length without the NUL. Returns
 * RTO_ERR_BUFFER_TOO_SMALL (buf then holds a truncated prefix when cap > 0) when cap <= *len: call with
 * buf = NULL, cap = 0 to size the buffer.
 */
rto_status rto_report_text(const rto_report *r, char *buf, size_t cap, size_t *len);
/**
 * Writes the report as one JSON object (indented by two spaces; keys: command, what, context, mode, result, fault,
 * faults, location, checks, facts, tolerance, diffs, message). Hex values are strings, non-finite floats the
 * strings "inf", "-inf", "nan"; text that is not well-formed UTF-8 (a name cut inside a character) is written
 * repaired by rto_utf8_repair. Same buffer contract as rto_report_text.
 */
rto_status rto_report_json(const rto_report *r, char *buf, size_t cap, size_t *len, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Sort validation (DESIGN.md §4, §9)                                                                                */

typedef enum rto_sort_algo { RTO_SORT_BITONIC = 0, RTO_SORT_RADIX = 1 } rto_sort_algo;

/** Fault classes, in diagnosis priority order. Names are stable strings (rto_fault_name). */
typedef enum rto_fault {
    RTO_FAULT_NONE = 0,      /* "none" */
    RTO_FAULT_SIZE = 1,      /* "size": the dump holds neither n nor n_padded keys, or a wrong pass count */
    RTO_FAULT_LOST = 2,      /* "lost-key": a key vanished and a sentinel took its place */
    RTO_FAULT_CORRUPT = 3,   /* "corrupt-key": a slot holds a value that is not in the input */
    RTO_FAULT_DUPLICATE = 4, /* "duplicate-key": a key appears more often than in the input */
    RTO_FAULT_ORDER = 5,     /* "order": a permutation of the input, but not sorted */
    RTO_FAULT_TAIL = 6,      /* "tail": a padded dump with a non-sentinel after slot n */
    RTO_FAULT_VALUE = 7,     /* "value": a value does not name a source index holding that key */
    RTO_FAULT_STABILITY = 8, /* "stability": equal keys whose values are out of input order */
    RTO_FAULT_PASS = 9       /* "pass": a checkpoint pass diverges from the oracle's */
} rto_fault;

const char *rto_fault_name(rto_fault f);

typedef struct rto_sort_check_desc {
    rto_key_format format;
    const void *input; /* the n unsorted input keys */
    size_t n;
    const void *gpu_keys;       /* the GPU's sorted buffer */
    size_t gpu_n;               /* n or rto_next_pow2(n) */
    const uint32_t *gpu_values; /* NULL, or gpu_n source indices carried with the keys: padding element p carries
                                 * n + p, which may land in the first n slots when real keys equal the sentinel */
    int require_stable;         /* values of equal keys must ascend */
    /* Checkpoints: NULL, or gpu_pass_count arrays of gpu_pass_len keys (bitonic: n_padded slots per pass; radix:
     * n keys per pass). The oracle side is recomputed from input with algo / radix_bits / radix_tile. */
    const void *gpu_passes;
    uint32_t gpu_pass_count;
    size_t gpu_pass_len;
    rto_sort_algo algo;
    uint32_t radix_bits;
    uint32_t radix_tile;
    /* NULL, or the n input keys in ascending order (a sort bundle's sorted.npy): the dump is then compared with them
     * directly instead of with the input sorted here. Refused (RTO_ERR_INVALID_ARGUMENT) unless they ascend and hold
     * the input's keys (compared by a multiset hash). */
    const void *expected_keys;
    uint32_t threads; /* 0: one per online CPU; the verdict and the report never depend on it */
} rto_sort_check_desc;

/**
 * Validates a GPU sort. Returns RTO_OK when all checks pass, RTO_ERR_MISMATCH when a fault was found (report says
 * which: code is an rto_fault; checks "sorted", "permutation", "tail", "values", "stable", "passes"; location
 * "slot" and, for a checkpoint fault, "pass" with "k" / "j" (bitonic) or "digit_bit" (radix)), other statuses for
 * unusable input (msg says why). Independent of rto_bitonic_sort and rto_radix_sort for the final array: the dump is
 * compared with expected_keys (a pass over memory) or, with only the input, with the input as an MSD radix partition
 * sorts it bucket by bucket in cache (about two passes over memory; desc->threads workers from 2^17 keys); only a
 * dump that differs is analysed further (sorted and merged against the input) to name the fault and its first bad
 * slot.
 * Carried values are checked in one pass without sorting. report->what is left empty for the caller (e.g. the case
 * id).
 */
rto_status rto_sort_check(const rto_sort_check_desc *desc, rto_report *report, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Scenes (DESIGN.md §5): meshes in object space, instances, materials, textures, cameras                          */

/** Row-major 3x4 affine transform: p' = M[r][0]*x + M[r][1]*y + M[r][2]*z + M[r][3] (§5 instance record). */
typedef struct rto_mat34 {
    float m[3][4];
} rto_mat34;

/** A triangle mesh in object space: one BLAS. Arrays are owned by the scene. */
typedef struct rto_mesh {
    char name[64];
    uint32_t vertex_count;
    float *positions; /* 3 * vertex_count */
    float *normals;   /* 3 * vertex_count, or NULL */
    float *uvs;       /* 2 * vertex_count, or NULL */
    uint32_t triangle_count;
    uint32_t *indices; /* 3 * triangle_count, each < vertex_count */
    int32_t material;  /* index into materials, -1 for none */
} rto_mesh;

#define RTO_INSTANCE_CUSTOM_INDEX_MASK 0x00FFFFFFu

/** One instance of a BLAS (§5): both transforms computed in binary64 and rounded once to binary32. */
typedef struct rto_instance {
    rto_mat34 obj_to_world;
    rto_mat34 world_to_obj;
    uint32_t blas;         /* mesh index */
    uint32_t custom_index; /* 24 bits */
    uint32_t mask;         /* 8 bits */
    uint32_t sbt_offset;
    uint32_t flags;
} rto_instance;

typedef struct rto_material {
    float base_color[4];
    int32_t base_color_texture; /* index into textures, -1 for none */
    float emissive[3];
} rto_material;

/** A decoded texture: 8-bit RGBA rows, top row first, as stored in the image file (no colour conversion). */
typedef struct rto_texture {
    char name[64];
    uint32_t width, height;
    uint8_t *rgba; /* 4 * width * height */
} rto_texture;

/** A pinhole camera: the Stage-2 look-at camera (seed 002 §2.2), or a glTF perspective camera's node pose. */
typedef struct rto_camera {
    char name[64];
    rto_vec3 position;
    rto_vec3 target;
    rto_vec3 up;
    float fov_y;  /* radians */
    float aspect; /* width / height; 0 = take it from the image size */
    float znear, zfar;
} rto_camera;

#define RTO_SCENE_MAX_WARNINGS 16

typedef struct rto_scene {
    char source[256]; /* the path or procedural spec it came from */
    rto_mesh *meshes;
    uint32_t mesh_count;
    rto_instance *instances;
    uint32_t instance_count;
    rto_material *materials;
    uint32_t material_count;
    rto_texture *textures;
    uint32_t texture_count;
    rto_camera *cameras;
    uint32_t camera_count;
    uint32_t warning_count; /* warnings issued (may exceed RTO_SCENE_MAX_WARNINGS; the first ones are kept) */
    char warnings[RTO_SCENE_MAX_WARNINGS][256];
    /* The files the loader opened, or tried to, in order: the scene file, its external buffers and the external
     * images its materials use, as paths it opened them by (the inputs of an up-to-date check, rto_bundle_check).
     * None for a procedural scene. */
    char **sources;
    uint32_t source_count;
} rto_scene;

/** The Stage-2 default camera: position (0, 2, 5), target origin, up +y, fovY 60 degrees. */
rto_camera rto_camera_default(void);

/* Default cap on the decoded texture memory of one scene: 256 MiB of RGBA8 (4 bytes a texel). */
#define RTO_SCENE_TEXTURE_BUDGET_DEFAULT ((size_t)256 << 20)

/** Options of rto_scene_load_ex. A zero-initialised description means the defaults. */
typedef struct rto_scene_load_desc {
    /* Most bytes the scene's decoded textures may take together (4 * width * height each; an image shared by
     * several textures counts once); 0 means RTO_SCENE_TEXTURE_BUDGET_DEFAULT. Checked from each image's header,
     * before any pixel is decoded: a scene over the budget is refused (RTO_ERR_UNSUPPORTED). An external image file
     * larger than the budget is refused too. */
    size_t texture_budget_bytes;
    /* Nonzero: read no file but the scene file itself. A buffer or image URI that is not a data: URI is refused
     * (RTO_ERR_UNSUPPORTED), so an untrusted .gltf cannot make the loader open other files. */
    int embedded_only;
} rto_scene_load_desc;

/**
 * Loads a scene: a .gltf / .glb path, or a procedural spec: "triangle", "rtstress:N" (N x N x N cube instances,
 * 1 <= N <= 40), "instances:DIST:N" (N small boxes whose centroids follow centroid distribution DIST, N <= 65536),
 * "sphere:L" (a closed unit icosphere of subdivision level L, 0 <= L <= 7: 10 * 4^L + 2 shared vertices,
 * 20 * 4^L triangles, counter-clockwise seen from outside), "sphere:L:SEED" (the same with every vertex moved along
 * its radius to a seeded 0.6 .. 1.4 of it: still closed), "random:SEED" (a seeded random scene: 1-4 meshes of
 * 1-300 triangles with shared edges, slivers and degenerate ones, 1-40 instances with rotations, non-uniform and
 * mirroring scales, varied customIndex and sbtOffset, and one mask-0 instance when there are 3 or more). SEED is a
 * decimal u32.
 * desc may be NULL (the defaults). Malformed, unsupported or non-finite input is refused with RTO_ERR_PARSE /
 * RTO_ERR_UNSUPPORTED / RTO_ERR_INVALID_ARGUMENT, and a file that cannot be read (missing, or not a regular file:
 * a FIFO, a directory, a device) with RTO_ERR_IO; msg gets one line of valid UTF-8 that names the file once. glTF 1.0
 * is refused ("glTF 1.0 is not supported"). Non-triangle primitives are skipped with a warning; a mesh without
 * triangles loads as an empty BLAS. Vertices and instance world bounds must lie within +-1.7e38 (FLT_MAX / 2), so
 * that box centroids and spans stay finite. Names, warnings and source are valid UTF-8, cut at character boundaries.
 */
rto_status rto_scene_load_ex(const char *spec, const rto_scene_load_desc *desc, rto_scene **out, rto_msg *msg);
/** rto_scene_load_ex with the default options. */
rto_status rto_scene_load(const char *spec, rto_scene **out, rto_msg *msg);
void rto_scene_destroy(rto_scene *scene);

/** Sets both transforms of an instance from a binary64 row-major 3x4: world_to_obj is inverted in binary64, then
 * both are rounded once. Fails (RTO_ERR_INVALID_ARGUMENT) for a singular or non-finite matrix. */
rto_status rto_instance_set_transform(rto_instance *inst, const double obj_to_world[3][4], rto_msg *msg);

/** Transforms a point by M in binary32 with the dot order ((m0*x + m1*y) + m2*z) + m3. */
rto_vec3 rto_mat34_point(const rto_mat34 *m, rto_vec3 p);
/** Object-space bounds of a mesh (exact: min/max of its referenced vertices). Empty mesh: +inf / -inf. */
rto_aabb rto_mesh_aabb(const rto_mesh *mesh);
/** World bounds of an instance: its mesh's object AABB's 8 corners through obj_to_world (rto_mat34_point). */
rto_aabb rto_instance_aabb(const rto_scene *scene, uint32_t instance);
/** Union of all instance world bounds. */
rto_aabb rto_scene_aabb(const rto_scene *scene);
/**
 * Describes a scene as one JSON object (what `rtoracle info --json` prints; indented by two spaces, final newline):
 * source, counts, world bounds (null when empty), meshes, materials, textures, cameras, warnings. Names are repaired
 * to UTF-8 (U+FFFD), non-finite numbers written as the strings "inf", "-inf", "nan". Same buffer contract as
 * rto_report_text: *len is the full length without the NUL; RTO_ERR_BUFFER_TOO_SMALL when cap <= *len (call with
 * buf = NULL, cap = 0 to size the buffer).
 */
rto_status rto_scene_json(const rto_scene *scene, char *buf, size_t cap, size_t *len, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Acceleration structures (DESIGN.md §5): the TLAS sweep tree and Karras radix trees, in their GPU layouts         */

#define RTO_TLAS_INTERNAL UINT32_C(0xFFFFFFFF) /* item of an internal node with a real leaf below */
#define RTO_TLAS_EMPTY UINT32_C(0xFFFFFFFE)    /* item of a sentinel leaf or an internal node with none */
#define RTO_BVH_LEAF_BIT UINT32_C(0x80000000)  /* set in left/right: the low bits are a sorted leaf index */
#define RTO_BVH_NO_PARENT UINT32_C(0xFFFFFFFF) /* parent of the root */

/** struct TlasNode { min: vec3<f32>, item: u32, max: vec3<f32>, pad: u32 } (32 bytes). */
typedef struct rto_tlas_node {
    float min[3];
    uint32_t item;
    float max[3];
    uint32_t pad;
} rto_tlas_node;
RTO_STATIC_ASSERT(sizeof(rto_tlas_node) == 32, "TlasNode is 32 bytes");
RTO_STATIC_ASSERT(offsetof(rto_tlas_node, item) == 12 && offsetof(rto_tlas_node, max) == 16, "TlasNode fields");

/** struct BlasNode { lmin, left, lmax, right, rmin, parent, rmax, pad } (64 bytes): one internal Karras node with
 * both child boxes. Used for BLAS trees and for the Karras TLAS. */
typedef struct rto_bvh_node {
    float lmin[3];
    uint32_t left;
    float lmax[3];
    uint32_t right;
    float rmin[3];
    uint32_t parent;
    float rmax[3];
    uint32_t pad;
} rto_bvh_node;
RTO_STATIC_ASSERT(sizeof(rto_bvh_node) == 64, "BlasNode is 64 bytes");
RTO_STATIC_ASSERT(offsetof(rto_bvh_node, left) == 12 && offsetof(rto_bvh_node, right) == 28 &&
                      offsetof(rto_bvh_node, parent) == 44 && offsetof(rto_bvh_node, rmax) == 48,
                  "BlasNode fields");

/** Nodes of a sweep tree over n leaves: 2 * n_padded - 1, and 1 (one EMPTY root) for n = 0. */
size_t rto_tlas_sweep_node_count(size_t n);

/**
 * Builds the TLAS sweep tree (§5) over n sorted, distinct TLAS keys (rto_tlas_keys_from_boxes, then a sort): leaf j
 * holds the instance of sorted key j with its box from boxes (indexed by instance), leaves n .. n_padded-1 are EMPTY,
 * internal nodes the union of their children. nodes holds rto_tlas_sweep_node_count(n) nodes.
 */
rto_status rto_tlas_build_sweep(const uint32_t *sorted_keys, size_t n, const rto_aabb *boxes, rto_tlas_node *nodes,
                                rto_msg *msg);

/**
 * Karras 2012 radix tree over n sorted, distinct keys (§5): n - 1 internal nodes (none for n <= 1) whose child
 * boxes come from prim_boxes indexed by rto_key_prim of each leaf's key. Internal node 0 is the root.
 */
rto_status rto_karras_build(rto_key_format f, const void *sorted_keys, size_t n, const rto_aabb *prim_boxes,
                            rto_bvh_node *nodes, rto_msg *msg);

/** Tree statistics: depth of the deepest leaf (root at 0) and the SAH cost sum(SA(node)) / SA(root) over
 * internal nodes and leaves (traversal and intersection cost 1). */
typedef struct rto_bvh_stats {
    uint32_t depth;
    double sah;
    uint32_t leaves;
} rto_bvh_stats;

/** Validation and comparison faults for trees. Names are stable strings (rto_bvh_fault_name). */
typedef enum rto_bvh_fault {
    RTO_BVH_OK = 0,           /* "none" */
    RTO_BVH_SIZE = 1,         /* "size": wrong node count */
    RTO_BVH_CYCLE = 2,        /* "cycle": a child link leads back to an ancestor */
    RTO_BVH_SHARED = 3,       /* "shared-node": an internal node reachable from two parents */
    RTO_BVH_BAD_LINK = 4,     /* "bad-link": a child index out of range */
    RTO_BVH_DROPPED_LEAF = 5, /* "dropped-leaf": a primitive is in no leaf */
    RTO_BVH_ITEM = 6,         /* "item": a leaf holds the wrong primitive (another one appears twice, or it is out
                               * of range, or an instance of an empty BLAS) */
    RTO_BVH_SWAPPED = 7,      /* "swapped-children": a node's two children exchanged */
    RTO_BVH_TOPOLOGY = 8,     /* "topology": links differ from the expected tree otherwise */
    RTO_BVH_PARENT = 9,       /* "parent": a parent link disagrees with the child links */
    RTO_BVH_EMPTY = 10,       /* "empty": EMPTY / INTERNAL items wrong, or an EMPTY node's box not (+inf, -inf) */
    RTO_BVH_BOX = 11          /* "box": a box outside its tolerance or not the exact union of its children */
} rto_bvh_fault;

const char *rto_bvh_fault_name(rto_bvh_fault f);

/**
 * The leaf-box tolerance of DESIGN.md §9 for a box obtained by transforming object_box with m: per world coordinate
 * r, 8·2^-24·(|m[r][0]·x| + |m[r][1]·y| + |m[r][2]·z| + |m[r][3]|) maximised over the box's 8 corners — twice the
 * forward error bound γ4 of one transform row, so two evaluations, each with or without fused multiply-add, agree
 * within it. Computed in binary64; an empty object box gives 0.
 */
void rto_transform_box_tolerance(const rto_mat34 *m, const rto_aabb *object_box, double tolerance[3]);

/** What a tree is checked against. Zero-initialise; a NULL pointer means "not given". */
typedef struct rto_bvh_check_desc {
    const void *nodes; /* the tree: rto_tlas_node records (rto_tlas_check) or rto_bvh_node (rto_karras_check) */
    size_t node_count;
    const void *expected; /* NULL: any valid tree over the primitives ("structure-only"); else the oracle's nodes,
                           * as many as the tree must have (read only when node_count is right), whose items and
                           * links must be equal ("exact") */
    const rto_aabb *prim_boxes; /* prim_count primitive boxes (instance world boxes, triangle boxes); an empty
                                 * box (+inf, -inf) marks a primitive that must be in no leaf: an instance of an
                                 * empty BLAS */
    size_t prim_count;
    const double *leaf_tolerance; /* NULL: leaf boxes equal their primitive's box exactly (triangles); else
                                   * 3 * prim_count per-axis bounds (rto_transform_box_tolerance) for TLAS leaves */
    const uint32_t *leaf_prims;   /* Karras trees: the primitive of each sorted leaf, leaf_count entries; must be a
                                   * permutation of the non-empty primitives (a GPU's own order is checked too) */
    size_t leaf_count;
} rto_bvh_check_desc;

/**
 * Checks a sweep TLAS (DESIGN.md §5, §9). The leaves are the non-empty primitives. Structure first (each non-empty
 * primitive in exactly one leaf, none for an empty one), then, with expected, every item equal to the oracle's,
 * then, bottom-up, every node on its own: items consistent with the children (INTERNAL / EMPTY), an EMPTY node's
 * box (+inf, -inf), a leaf box within leaf_tolerance of its primitive's box, every internal box the exact union of
 * the dump's own children. The first fault in that order is reported where it starts (report->code is an
 * rto_bvh_fault; location "node", and "leaf" / "primitive" where one is concerned; checks "size", "leaves",
 * "oracle", "links", "boxes"). Returns RTO_OK, RTO_ERR_MISMATCH, or another status for unusable input.
 */
rto_status rto_tlas_check(const rto_bvh_check_desc *desc, rto_report *report, rto_msg *msg);

/**
 * Checks a Karras-layout tree (BLAS, or a Karras TLAS): leaf_prims a permutation of the non-empty primitives, links
 * in range, no cycle or shared node, parents, every leaf exactly once; with expected, links equal to the oracle's;
 * then, bottom-up (post-order), leaf child boxes within leaf_tolerance of their primitive's box and internal child
 * boxes the exact union of the dump's own child node. Report as rto_tlas_check; a box is reported at the node
 * holding it, with "child" naming the internal child or "leaf" the sorted leaf.
 */
rto_status rto_karras_check(const rto_bvh_check_desc *desc, rto_report *report, rto_msg *msg);

/** Depth, leaves and SAH cost of a sweep TLAS / a Karras tree (n primitives). */
rto_bvh_stats rto_tlas_stats(const rto_tlas_node *nodes, size_t n);
rto_bvh_stats rto_karras_stats(const rto_bvh_node *nodes, size_t n, const rto_aabb *root_box);

/* ---------------------------------------------------------------------------------------------------------------- */
/* .npy files (NumPy format 1.0 / 2.0 / 3.0, little-endian, C order)                                                  */

typedef enum rto_dtype {
    RTO_DTYPE_NONE = 0,
    RTO_DTYPE_U8 = 1,  /* |u1 */
    RTO_DTYPE_U32 = 2, /* <u4 */
    RTO_DTYPE_U64 = 3, /* <u8 */
    RTO_DTYPE_I32 = 4, /* <i4 */
    RTO_DTYPE_F32 = 5, /* <f4 */
    RTO_DTYPE_STRUCT = 6,
    RTO_DTYPE_U16 = 7, /* <u2 */
    RTO_DTYPE_F16 = 8  /* <f2: binary16 (the visibility buffer's planes) */
} rto_dtype;

#define RTO_NPY_MAX_DIMS 4
#define RTO_NPY_MAX_FIELDS 16
#define RTO_NPY_NAME_MAX 32

typedef struct rto_npy_field {
    char name[RTO_NPY_NAME_MAX];
    rto_dtype type;  /* a scalar dtype */
    uint32_t count;  /* elements: 1 for a scalar field, 3 for ('min', '<f4', (3,)) */
    uint32_t offset; /* bytes from the start of the record (packed, in declaration order) */
} rto_npy_field;

/** An array's type and shape. For RTO_DTYPE_STRUCT, fields describes the packed record. */
typedef struct rto_npy_desc {
    rto_dtype dtype;
    uint32_t ndim;
    uint64_t shape[RTO_NPY_MAX_DIMS];
    uint32_t nfields;
    rto_npy_field fields[RTO_NPY_MAX_FIELDS];
} rto_npy_desc;

/** A loaded array: desc plus data (owned; free with rto_npy_free). */
typedef struct rto_npy {
    rto_npy_desc desc;
    void *data;
    size_t nbytes;
} rto_npy;

/** Bytes of one scalar dtype (0 for NONE / STRUCT). */
size_t rto_dtype_size(rto_dtype t);
/** Bytes of one element of desc (the record size for a struct). */
size_t rto_npy_itemsize(const rto_npy_desc *desc);
/** Elements in desc (product of the shape; 1 for ndim 0). Returns 0 on overflow with *ok = 0. */
uint64_t rto_npy_count(const rto_npy_desc *desc, int *ok);
/** The descr string of desc as NumPy writes it ("<u4", "[('key', '<u4'), ('value', '<u4')]"). */
rto_status rto_npy_descr(const rto_npy_desc *desc, char *buf, size_t cap);

/**
 * Parses a whole .npy file held in memory (bounds-checked; safe for untrusted input). Refuses bad magic, an
 * unknown version, a malformed header, big-endian or unknown dtypes, fortran_order, truncated data and trailing
 * bytes. out->data is a fresh copy.
 */
rto_status rto_npy_parse(const void *buf, size_t len, rto_npy *out, rto_msg *msg);
/** Reads and parses path. */
rto_status rto_npy_read(const char *path, rto_npy *out, rto_msg *msg);
/**
 * Serialises desc + data (rto_npy_count * itemsize bytes) as format 1.0 (2.0 if the header needs it), atomically as
 * rto_file_write does; a character device or FIFO (/dev/null, a pipe) is written through instead.
 */
rto_status rto_npy_write(const char *path, const rto_npy_desc *desc, const void *data, rto_msg *msg);
void rto_npy_free(rto_npy *npy);

/** A 1-D array of n keys of format f. */
rto_npy_desc rto_npy_desc_keys(rto_key_format f, uint64_t n);
/** A desc of a scalar dtype with up to four dimensions (unused trailing dims are 0 and ignored). */
rto_npy_desc rto_npy_desc_array(rto_dtype t, uint32_t ndim, uint64_t d0, uint64_t d1, uint64_t d2);
/** Interprets a loaded array as 1-D keys: u32 or u64, shape (n,). */
rto_status rto_npy_as_keys(const rto_npy *npy, rto_key_format *f, size_t *n, rto_msg *msg);
/** Whether have has exactly want's dtype (struct fields included: names, types, counts, offsets) and shape. */
int rto_npy_desc_equal(const rto_npy_desc *have, const rto_npy_desc *want);
/** What an array holds, for messages: "dtype <u4, shape (1,)"; a structured dtype named by layout ("Aabb records,
 * shape (3,)") or, with layout NULL, by its record size. Returns buf. */
const char *rto_npy_desc_text(const rto_npy_desc *desc, const char *layout, char *buf, size_t cap);

/* ---------------------------------------------------------------------------------------------------------------- */
/* GPU layouts (DESIGN.md §5-§7): the structs a GPU reads and writes, and their .npy structured dtypes               */

/** InstanceRecord (128 bytes): both transforms as row-major 3x4, then blas, customIndex, mask, sbtOffset, flags. */
typedef struct rto_instance_record {
    float obj_to_world[3][4];
    float world_to_obj[3][4];
    uint32_t blas;
    uint32_t custom_index;
    uint32_t mask;
    uint32_t sbt_offset;
    uint32_t flags;
    uint32_t pad[3];
} rto_instance_record;
RTO_STATIC_ASSERT(sizeof(rto_instance_record) == 128, "InstanceRecord is 128 bytes");
RTO_STATIC_ASSERT(offsetof(rto_instance_record, world_to_obj) == 48 && offsetof(rto_instance_record, blas) == 96,
                  "InstanceRecord fields");

/**
 * HitRecord, the GPU's HitResult (96 bytes, DESIGN.md §6). obj_to_world is WGSL's column-major mat4x3<f32>: column c
 * is obj_to_world[c][0..2] and obj_to_world[c][3] is the padding that rounds each vec3 column up to 16 bytes (0).
 * A miss: miss_flag 1, t = tMax, instance_id / prim_id / hit_group / custom_index 0xFFFFFFFF, bary and matrix 0.
 */
typedef struct rto_hit_record {
    float t;
    uint32_t instance_id;
    uint32_t prim_id;
    uint32_t hit_group;
    float bary[2];
    uint32_t custom_index;
    uint32_t miss_flag;
    float obj_to_world[4][4];
} rto_hit_record;
RTO_STATIC_ASSERT(sizeof(rto_hit_record) == 96, "HitRecord is 96 bytes");
RTO_STATIC_ASSERT(offsetof(rto_hit_record, bary) == 16 && offsetof(rto_hit_record, custom_index) == 24 &&
                      offsetof(rto_hit_record, obj_to_world) == 32,
                  "HitRecord fields (vec2 at 8-byte, mat4x3 at 16-byte alignment)");

/** WfRay (64 bytes, DESIGN.md §7): one ray of a wavefront queue. */
typedef struct rto_wf_ray {
    float origin[3];
    float t_min;
    float dir[3];
    float t_max;
    uint32_t pixel;
    uint32_t flags;
    uint32_t cull_mask;
    uint32_t miss_index;
    uint32_t sbt_offset;
    uint32_t payload_slot;
    uint32_t kind;
    uint32_t pad;
} rto_wf_ray;
RTO_STATIC_ASSERT(sizeof(rto_wf_ray) == 64, "WfRay is 64 bytes");
RTO_STATIC_ASSERT(offsetof(rto_wf_ray, dir) == 16 && offsetof(rto_wf_ray, t_max) == 28 &&
                      offsetof(rto_wf_ray, pixel) == 32 && offsetof(rto_wf_ray, kind) == 56,
                  "WfRay fields");

/** TraceCounters (16 bytes, DESIGN.md §6): what one ray's traversal did. */
typedef struct rto_trace_counters {
    uint32_t nodes_visited;    /* nodes popped and not skipped (TLAS and BLAS, leaves included) */
    uint32_t box_tests;        /* slab tests run */
    uint32_t triangle_tests;   /* Möller–Trumbore calls */
    uint32_t instance_entries; /* BLAS traversals started */
} rto_trace_counters;
RTO_STATIC_ASSERT(sizeof(rto_trace_counters) == 16, "TraceCounters is 16 bytes");

/** CameraUniforms (144 bytes, seed 002 §2.2, DESIGN.md §7): column-major mat4x4<f32> inverses (element [4c + r] is
 * row r of column c), the camera position and one float of padding (0). */
typedef struct rto_camera_uniforms {
    float inverse_projection[16];
    float inverse_view[16];
    float position[3];
    float pad;
} rto_camera_uniforms;
RTO_STATIC_ASSERT(sizeof(rto_camera_uniforms) == 144, "CameraUniforms is 144 bytes");
RTO_STATIC_ASSERT(offsetof(rto_camera_uniforms, inverse_view) == 64 && offsetof(rto_camera_uniforms, position) == 128,
                  "CameraUniforms fields");

/** FrameCounters (40 bytes, DESIGN.md §7): one row per ray queue of a wavefront frame. Row d describes queue d
 * (filled by GENERATE for d = 0, by the SHADE pass of bounce d - 1 otherwise) and, for d < maxDepth, the TRACE and
 * SHADE passes of bounce d over it; the last row (d = maxDepth) is the queue no bounce traces. */
typedef struct rto_frame_counters {
    uint32_t emitted;     /* emits into the queue: the GPU's atomic emit counter after the pass that filled it */
    uint32_t queued;      /* min(emitted, capacity): the rays stored, PREP's n */
    uint32_t dropped;     /* emitted - queued: emits past the capacity 2 W H */
    uint32_t refused;     /* emits past the per-invocation budget (RTO_FRAME_EMITS_PER_INVOCATION): never counted in
                           * emitted, deterministic on a GPU too */
    uint32_t traced;      /* rays traced at bounce d (= queued; 0 on the last row) */
    uint32_t hits;        /* of the traced rays, hits */
    uint32_t misses;      /* and misses */
    uint32_t shaded;      /* closest-hit and miss calls (a hit of a SKIP_CLOSEST_HIT ray runs neither) */
    uint32_t accumulates; /* accumulate calls in the SHADE pass */
    uint32_t conflicts;   /* pixels accumulated from two or more rays in the SHADE pass (a race on a GPU) */
} rto_frame_counters;
RTO_STATIC_ASSERT(sizeof(rto_frame_counters) == 40, "FrameCounters is 40 bytes");

/** The GPU structs by name. Values never change; new layouts are appended. */
typedef enum rto_layout {
    RTO_LAYOUT_TLAS_NODE = 0,  /* "TlasNode", rto_tlas_node, 32 bytes */
    RTO_LAYOUT_BLAS_NODE = 1,  /* "BlasNode", rto_bvh_node, 64 bytes (BLAS and the Karras TLAS) */
    RTO_LAYOUT_AABB = 2,       /* "Aabb", rto_aabb, 24 bytes */
    RTO_LAYOUT_INSTANCE = 3,   /* "InstanceRecord", rto_instance_record, 128 bytes */
    RTO_LAYOUT_HIT_RECORD = 4, /* "HitRecord", rto_hit_record, 96 bytes; objToWorld as 16 floats (4 padded columns) */
    RTO_LAYOUT_WF_RAY = 5,     /* "WfRay", rto_wf_ray, 64 bytes */
    RTO_LAYOUT_TRACE_COUNTERS = 6, /* "TraceCounters", rto_trace_counters, 16 bytes */
    RTO_LAYOUT_CAMERA = 7,         /* "CameraUniforms", rto_camera_uniforms, 144 bytes */
    RTO_LAYOUT_FRAME_COUNTERS = 8  /* "FrameCounters", rto_frame_counters, 40 bytes */
} rto_layout;
#define RTO_LAYOUT_COUNT 9

/** The layout's name as written into manifests ("TlasNode", ...); NULL for an unknown value. */
const char *rto_layout_name(rto_layout layout);
/** Bytes of one record (the C struct's sizeof); 0 for an unknown value. */
size_t rto_layout_size(rto_layout layout);
/** A 1-D array of n records as a .npy structured dtype (fields in declaration order, packed, named as in WGSL). */
rto_npy_desc rto_layout_desc(rto_layout layout, uint64_t n);
/**
 * Accepts a GPU dump of records of a layout and sets *count: the structured dtype itself (field names may differ;
 * types, counts and offsets must match), a 2-D uint32 / float32 array (count, words), or a flat uint32 / float32
 * buffer of count * words. RTO_ERR_PARSE (msg says why) otherwise.
 */
rto_status rto_layout_accept(rto_layout layout, const rto_npy *npy, size_t *count, rto_msg *msg);
/** The InstanceRecord of a scene instance. */
rto_instance_record rto_instance_record_make(const rto_instance *instance);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Bundles: a directory of .npy files plus manifest.json, written atomically (DESIGN.md §8)                           */

typedef struct rto_bundle rto_bundle;

/**
 * Starts a bundle that will become outdir: files go to a fresh temporary sibling directory `outdir.tmp.PID-XXXXXX`,
 * created with the process umask like mkdir(2) with 0777. outdir must not exist (its parent must), be an empty
 * directory, or be a previous rtoracle bundle, which rto_bundle_commit then replaces atomically. A previous bundle
 * is a directory whose manifest.json has this format name and version and lists every entry of the directory
 * (files by name, suite cases by directory, each case itself such a bundle); anything else, a regular file
 * included, is refused with RTO_ERR_IO before anything is written. A symbolic link is followed: the directory it
 * names is what is replaced, and the link stays. kind is the manifest's "kind" ("sort", "build", "suite").
 */
rto_status rto_bundle_begin(const char *outdir, const char *kind, rto_bundle **out, rto_msg *msg);
/** Writes name (a plain file name) into the bundle and records role, dtype, shape, layout and sha256. */
rto_status rto_bundle_add_npy(rto_bundle *b, const char *name, const char *role, const char *layout,
                              const rto_npy_desc *desc, const void *data, rto_msg *msg);
/** Adds an existing finished bundle directory (a suite case) under name, listed in the manifest's "cases". */
rto_status rto_bundle_add_case(rto_bundle *b, const char *name, const char *case_id, rto_msg *msg);
/** The temporary directory being filled (for nested bundles). */
const char *rto_bundle_tmpdir(const rto_bundle *b);
/**
 * Manifest metadata: section is "" (top level) or an object name such as "input", "params", "stats". A string that is
 * not well-formed UTF-8 is written repaired by rto_utf8_repair (U+FFFD for each ill-formed part). A failure (out of
 * memory, NULL arguments) is returned and also kept: rto_bundle_commit then fails with it, so a caller that ignores
 * the return value still never gets a manifest with a field silently missing.
 */
rto_status rto_bundle_set_str(rto_bundle *b, const char *section, const char *key, const char *value);
rto_status rto_bundle_set_int(rto_bundle *b, const char *section, const char *key, int64_t value);
/**
 * A real number, written with the shortest representation that round-trips (jansson's %.17g); JSON has no
 * infinities or NaN, so those are written as the strings "inf", "-inf" and "nan".
 */
rto_status rto_bundle_set_real(rto_bundle *b, const char *section, const char *key, double value);
/**
 * Writes manifest.json and renames the directory into place (replacing a previous bundle, see rto_bundle_begin, only
 * after checking it again). Frees b on success and failure; on failure nothing of the new bundle remains.
 */
rto_status rto_bundle_commit(rto_bundle *b, rto_msg *msg);
/** Removes the temporary directory and frees b. NULL is fine. */
void rto_bundle_abort(rto_bundle *b);

/**
 * Up-to-date bundles. A command that writes a bundle may first ask whether outdir already holds exactly what it
 * would write, and skip the work: rto_bundle_set_request records, at commit, the request (a text the caller composes
 * from everything its output depends on: command, arguments, option values; not the output path), the content hash
 * of each source file it read (scene, buffers, images, plugins, ray files), this rtoracle build (the build-ids of the
 * program and its libraries) and the identity (inode, size, mtime) of manifest.json and every listed file, suite
 * cases included. The record is an extended attribute of the directory (user.rtoracle.stamp), so the bundle's bytes
 * do not change; where the file system has none, bundles are simply not stamped and never skipped.
 */
typedef enum rto_bundle_state {
    RTO_BUNDLE_ABSENT = 0,  /* no directory there */
    RTO_BUNDLE_CURRENT = 1, /* same build, same request, sources unchanged, no file touched since: nothing to do */
    RTO_BUNDLE_STALE = 2,   /* not stamped, or for another build, request or source content (why says which) */
    RTO_BUNDLE_CHANGED = 3, /* a file of it was modified, replaced or removed after it was written (why names it) */
} rto_bundle_state;
/** What outdir holds for request (see rto_bundle_state). Costs a stat per file and a hash of each source file. */
rto_bundle_state rto_bundle_check(const char *outdir, const char *request, rto_msg *why);
/** Records the request and its source files (hashed now; count may be 0) for rto_bundle_commit to stamp. */
rto_status rto_bundle_set_request(rto_bundle *b, const char *request, const char *const *sources, size_t count,
                                  rto_msg *msg);

/**
 * Shared arrays. Bundles written together often hold the same array (a suite's bitonic and radix cases of one input
 * have the same keys.npy and sorted.npy). With a share table attached (rto_bundle_set_share), rto_bundle_add_npy
 * hashes the array's file bytes in memory first and, where the bundle itself or an earlier bundle committed with the
 * same table wrote a file of the same sha256 and size, makes the new name a hard link (link(2)) to that file instead
 * of a second copy. Manifests and bytes are exactly those of separate copies, and each bundle stays a complete
 * directory of its own. A file is linked to only while it keeps the inode, size and mtime it had when its bundle
 * was committed (a file changed since is left alone and the array written); any link failure (another file system,
 * too many links, no hard links) writes the file. At rto_bundle_commit a bundle registers the arrays it wrote in
 * the table under their final paths. Bundles never write into an existing file, so replacing one bundle later never
 * changes another's linked file; an in-place edit from outside changes every name of it.
 */
typedef struct rto_bundle_share rto_bundle_share;
/** An empty table; NULL when out of memory. */
rto_bundle_share *rto_bundle_share_create(void);
/** Frees the table (NULL is fine); the files it lists are left as they are. */
void rto_bundle_share_destroy(rto_bundle_share *t);
/** Attaches t (NULL: none) to b, before b's arrays are added; t must outlive b's commit or abort. */
void rto_bundle_set_share(rto_bundle *b, rto_bundle_share *t);

/** A bundle opened for reading: manifest parsed, version checked. */
typedef struct rto_bundle_reader rto_bundle_reader;
rto_status rto_bundle_open(const char *dir, rto_bundle_reader **out, rto_msg *msg);
void rto_bundle_close(rto_bundle_reader *r);
/** A string field of the manifest; NULL if absent or not a string. The pointer lives as long as r. */
const char *rto_bundle_get_str(rto_bundle_reader *r, const char *section, const char *key);
/** An integer field of the manifest: returns 1 and sets *value, or 0 if absent or not an integer. */
int rto_bundle_get_int(rto_bundle_reader *r, const char *section, const char *key, int64_t *value);
/** A number field (integer or real; not the strings "inf" and "nan" rto_bundle_set_real writes): 1 and *value, or 0. */
int rto_bundle_get_real(rto_bundle_reader *r, const char *section, const char *key, double *value);
/** Loads the file with the given role, after checking its sha256 against the manifest. RTO_ERR_IO if absent. */
rto_status rto_bundle_read_role(rto_bundle_reader *r, const char *role, rto_npy *out, rto_msg *msg);
/** Loads the file with the given name (e.g. "blas_3_nodes.npy"), after checking its sha256. */
rto_status rto_bundle_read_name(rto_bundle_reader *r, const char *name, rto_npy *out, rto_msg *msg);

/** SHA-256 of a file as 64 lowercase hex digits plus NUL. */
rto_status rto_sha256_file(const char *path, char hex[65], rto_msg *msg);

/** The files of build and trace bundles, named once here for writers and readers. Values never change. */
typedef enum rto_bundle_file {
    RTO_FILE_INSTANCES = 0,        /* instances.npy           role "instances"        InstanceRecord */
    RTO_FILE_INSTANCE_AABBS = 1,   /* instance_aabbs.npy      role "instance-aabbs"   Aabb, instance world boxes */
    RTO_FILE_TLAS_KEYS = 2,        /* tlas_keys.npy           role "tlas-keys"        u32, one per keyed instance */
    RTO_FILE_TLAS_SORTED_KEYS = 3, /* tlas_sorted_keys.npy    role "tlas-sorted-keys" u32, n_padded (sentinel tail) */
    RTO_FILE_TLAS_NODES = 4,       /* tlas_nodes.npy          role "tlas-nodes"       TlasNode, or BlasNode (Karras) */
    RTO_FILE_BLAS_SORTED_KEYS = 5, /* blas_M_sorted_keys.npy  role "blas-sorted-keys" u64, one per triangle */
    RTO_FILE_BLAS_ORDER = 6,       /* blas_M_order.npy        role "blas-order"       u32, triangle of each leaf */
    RTO_FILE_BLAS_NODES = 7,       /* blas_M_nodes.npy        role "blas-nodes"       BlasNode */
    RTO_FILE_BLAS_PRIM_AABBS = 8,  /* blas_M_prim_aabbs.npy   role "blas-prim-aabbs"  Aabb, triangle boxes */
    /* Trace bundles add the geometry a GPU uploads, the rays and what tracing them gives. */
    RTO_FILE_MESH_POSITIONS = 9,   /* mesh_M_positions.npy    role "mesh-positions"   f32 (vertices, 3) */
    RTO_FILE_MESH_INDICES = 10,    /* mesh_M_indices.npy      role "mesh-indices"     u32 (triangles, 3) */
    RTO_FILE_RAYS = 11,            /* rays.npy                role "rays"             WfRay */
    RTO_FILE_HITS = 12,            /* hits.npy                role "hits"             HitRecord, one per ray */
    RTO_FILE_COUNTERS = 13,        /* counters.npy            role "counters"         TraceCounters, one per ray */
    RTO_FILE_CAMERA = 14,          /* camera.npy              role "camera"           CameraUniforms (1,) */
    /* Frame bundles (rtoracle render): per bounce D (the "mesh" argument of rto_bundle_file_name), then the frame. */
    RTO_FILE_BOUNCE_RAYS = 15,     /* bounce_D_rays.npy       role "bounce-rays"      WfRay, the queue traced at D */
    RTO_FILE_BOUNCE_HITS = 16,     /* bounce_D_hits.npy       role "bounce-hits"      HitRecord, one per queued ray */
    RTO_FILE_BOUNCE_TRACE_COUNTERS = 17, /* bounce_D_trace_counters.npy  "bounce-trace-counters"  TraceCounters */
    RTO_FILE_BOUNCE_PAYLOADS = 18, /* bounce_D_payloads.npy   role "bounce-payloads"  u32 (rays, payload words) */
    RTO_FILE_EMIT_COUNTS = 19,     /* emit_counts.npy         role "emit-counts"      u32 (maxDepth + 1,) */
    RTO_FILE_INDIRECT_ARGS = 20,   /* indirect_args.npy       role "indirect-args"    u32 (maxDepth + 1, 3) */
    RTO_FILE_FRAME_COUNTERS = 21,  /* frame_counters.npy      role "frame-counters"   FrameCounters (maxDepth + 1,) */
    RTO_FILE_ACCUM = 22,           /* accum.npy               role "accum"            f32 (H, W, 4), linear */
    RTO_FILE_ACCUM_EXR = 23,       /* accum.exr               role "accum-exr"        RGBA f32 OpenEXR, linear */
    RTO_FILE_IMAGE = 24,           /* image.png               role "image"            RGBA 8-bit PNG, resolved */
    RTO_FILE_NOT_COMPARABLE = 25,  /* not_comparable.npy      role "not-comparable"   u8 (H, W): RTO_PIXEL_* bits */
    /* Visibility-buffer bundles (rtoracle vbuffer, DESIGN.md §11; S samples a pixel). */
    RTO_FILE_VB_CAMERA = 26,       /* vb_camera.npy           role "vb-camera"        f32 (36,): rto_vbuffer_camera */
    RTO_FILE_VB_VISIBILITY = 27,   /* vb_visibility.npy       role "vb-visibility"    u16 (H, W, S, 4) */
    RTO_FILE_VB_BARYCENTRIC = 28,  /* vb_barycentric.npy      role "vb-barycentric"   f16 (H, W, S, 2) */
    RTO_FILE_VB_NORMAL = 29,       /* vb_normal.npy           role "vb-normal"        f16 (H, W, S, 4) */
    RTO_FILE_VB_DERIVATIVES = 30,  /* vb_derivatives.npy      role "vb-derivatives"   f16 (H, W, S, 4) */
    RTO_FILE_VB_DEPTH = 31,        /* vb_depth.npy            role "vb-depth"         f32 (H, W, S) */
    RTO_FILE_VB_DEPTH_UNORM24 = 32, /* vb_depth_unorm24.npy   role "vb-depth-unorm24" u32 (H, W, S) */
    RTO_FILE_VB_ADMISSIBLE_OFFSETS = 33, /* vb_admissible_offsets.npy  "vb-admissible-offsets"  u32 (H W S + 1,) */
    RTO_FILE_VB_ADMISSIBLE = 34,   /* vb_admissible.npy       role "vb-admissible"    u32 (n, 2): (instance, prim) */
    RTO_FILE_VB_EDGE_MASK = 35,    /* vb_edge_mask.npy        role "vb-edge-mask"     u8 (H, W) */
    RTO_FILE_VB_IMAGE = 36,        /* vb_image.npy            role "vb-image"         f16 (H, W, 4) */
    RTO_FILE_VB_BASE_COLORS = 37,  /* vb_base_colors.npy      role "vb-base-colors"   f32 (meshes, 4) */
    /* unlit's textures (§11.5; written for --material unlit): UVs of the meshes that sample one, which texture each
     * mesh samples, and each texture's mip chain as the oracle defines it. */
    RTO_FILE_MESH_UVS = 38,        /* mesh_M_uvs.npy          role "mesh-uvs"         f32 (vertices, 2) */
    RTO_FILE_VB_MESH_TEXTURES = 39, /* vb_mesh_textures.npy   role "vb-mesh-textures" i32 (meshes,): T or -1 */
    RTO_FILE_VB_TEXTURES = 40,     /* vb_textures.npy         role "vb-textures"      u32 (T, 3): width, height, levels */
    RTO_FILE_VB_TEXTURE = 41,      /* vb_texture_T.npy        role "vb-texture"       f16 (texels of every level, 4) */
    /* Fluid bundles (rtoracle splat and raymarch, DESIGN.md §12; volumes are (nz, ny, nx), x fastest). */
    RTO_FILE_FLUID_PARAMS = 42,    /* fluid_params.npy        role "fluid-params"     f32 (16,): rto_fluid_uniforms */
    RTO_FILE_FLUID_PARTICLES = 43, /* particles.npy           role "fluid-particles"  f32 (N, 3) */
    RTO_FILE_FLUID_VOLUME_U32 = 44, /* volume_u32.npy         role "fluid-volume-u32" u32 (nz, ny, nx), mod 2^32 */
    RTO_FILE_FLUID_VOLUME_F16 = 45, /* volume_f16.npy         role "fluid-volume-f16" f16 (nz, ny, nx): resolved */
    RTO_FILE_FLUID_OCCUPANCY = 46, /* occupancy.npy           role "fluid-occupancy"  u32 (words,): every level */
    RTO_FILE_FLUID_OVERFLOW = 47,  /* overflow.npy            role "fluid-overflow"   u64 (K, 2): voxel, true sum */
    RTO_FILE_RM_PARAMS = 48,       /* rm_params.npy           role "rm-params"        f32 (64,): rto_raymarch_uniforms */
    RTO_FILE_RM_IMAGE = 49,        /* rm_image.npy            role "rm-image"         f32 (H, W, 4) */
    RTO_FILE_RM_CROSSING = 50,     /* rm_crossing.npy         role "rm-crossing"      u32 (H, W): first crossing step */
    RTO_FILE_RM_CROSSING_T = 51,   /* rm_crossing_t.npy       role "rm-crossing-t"    f32 (H, W) */
    RTO_FILE_RM_NORMAL_CENTRAL = 52, /* rm_normal_central.npy "rm-normal-central"     f32 (H, W, 3) */
    RTO_FILE_RM_NORMAL_FORWARD = 53, /* rm_normal_forward.npy "rm-normal-forward"     f32 (H, W, 3) */
    RTO_FILE_RM_STEPS = 54,        /* rm_steps.npy            role "rm-steps"         u32 (H, W): without skipping */
    RTO_FILE_RM_STEPS_SKIP = 55,   /* rm_steps_skip.npy       role "rm-steps-skip"    u32 (H, W): with skipping */
    RTO_FILE_RM_CERTAIN = 56,      /* rm_certain.npy          role "rm-certain"       u8 (H, W): decisions certain */
    RTO_FILE_RM_TOLERANCE = 57,    /* rm_tolerance.npy        role "rm-tolerance"     f32 (H, W): image tolerance */
    RTO_FILE_RM_IMAGE_WALL = 58,   /* rm_image_wall.npy       role "rm-image-wall"    f32 (H, W, 4): other outcome */
    RTO_FILE_RM_TOLERANCE_WALL = 59 /* rm_tolerance_wall.npy  role "rm-tolerance-wall" f32 (H, W): its tolerance */
} rto_bundle_file;
#define RTO_BUNDLE_FILE_COUNT 60
/** Room for any bundle file name, NUL included. */
#define RTO_BUNDLE_FILE_NAME_MAX 64

/** Writes the file name of f into name (cap bytes); per-BLAS files take the mesh index M, others ignore it. */
rto_status rto_bundle_file_name(rto_bundle_file f, uint32_t mesh, char *name, size_t cap);
/** The manifest role of f ("tlas-nodes", ...); NULL for an unknown value. */
const char *rto_bundle_file_role(rto_bundle_file f);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Acceleration-structure object (DESIGN.md §5): every tree of a scene, built once, read by the tracer and bundles  */

typedef enum rto_tlas_kind {
    RTO_TLAS_SWEEP = 0, /* the seeds' implicit heap tree (TlasNode) */
    RTO_TLAS_KARRAS = 1 /* a Karras radix tree over the TLAS keys (BlasNode), the seeds' "later refinement" */
} rto_tlas_kind;

/** How to build. Zero-initialised (or a NULL pointer) means the defaults. */
typedef struct rto_accel_desc {
    rto_tlas_kind tlas; /* default RTO_TLAS_SWEEP */
    uint32_t threads;   /* 0: one per online CPU. Work is split statically (many BLAS at once, and each big BLAS in
                         * ranges), so the output bytes do not depend on the thread count. */
} rto_accel_desc;

typedef struct rto_accel rto_accel;

/**
 * The TLAS of an accel. Arrays are owned by the accel and live until rto_accel_destroy. An instance whose world box
 * is empty (its BLAS has no triangles) has no key and no leaf: keys, sorted keys and nodes cover the other
 * key_count instances, whose keys still hold the real instance index.
 */
typedef struct rto_accel_tlas {
    rto_tlas_kind kind;
    uint32_t instance_count;          /* instances of the scene */
    uint32_t key_count;               /* instances with a non-empty world box: keys and leaves */
    uint32_t n_padded;                /* rto_next_pow2(key_count) */
    const rto_aabb *instance_aabbs;   /* instance_count world boxes, instance order (empty ones (+inf, -inf)) */
    const uint32_t *keys;             /* key_count TLAS keys, instance order */
    const uint32_t *sorted_keys;      /* n_padded: the sorted keys, then sentinels */
    const rto_tlas_node *sweep_nodes; /* kind SWEEP: node_count nodes (2 n_padded - 1; 1 EMPTY root if no key) */
    const rto_bvh_node *karras_nodes; /* kind KARRAS: node_count = key_count - 1 nodes (none for key_count <= 1) */
    size_t node_count;
    rto_bvh_stats stats;              /* depth, SAH cost, leaves (= key_count) */
} rto_accel_tlas;

/** The BLAS of one mesh, owned by the accel. A mesh without triangles has an empty BLAS: every array is empty. */
typedef struct rto_accel_blas {
    uint32_t mesh;               /* mesh index (= BLAS index) */
    uint32_t triangle_count;     /* leaves */
    const uint64_t *sorted_keys; /* triangle_count sorted BLAS keys */
    const uint32_t *order;       /* triangle_count: the triangle of each sorted leaf */
    const rto_aabb *prim_aabbs;  /* triangle_count triangle boxes, triangle order */
    const rto_bvh_node *nodes;   /* node_count = triangle_count - 1 internal nodes (none for <= 1 triangle) */
    size_t node_count;
    rto_aabb bounds;             /* object-space bounds of the mesh (rto_mesh_aabb) */
    rto_bvh_stats stats;         /* depth, SAH cost, leaves (= triangle_count) */
} rto_accel_blas;

/**
 * Builds every tree of a scene: instance world boxes, TLAS keys, their radix sort and the TLAS (sweep or Karras);
 * per mesh, triangle boxes, BLAS keys, their radix sort, the leaf order and the Karras BLAS; depth and SAH of each.
 * The accel borrows the scene: keep it alive and unchanged until rto_accel_destroy. Deterministic: the same scene
 * gives the same bytes. The build does not validate its own trees: rto_accel_check does (`rtoracle build` runs it
 * before writing a bundle). At most RTO_TLAS_MAX_INSTANCES instances.
 */
rto_status rto_accel_build(const rto_scene *scene, const rto_accel_desc *desc, rto_accel **out, rto_msg *msg);
/** Frees an accel. NULL is fine. */
void rto_accel_destroy(rto_accel *accel);
/** The scene an accel was built from. */
const rto_scene *rto_accel_scene(const rto_accel *accel);
/** The TLAS (never NULL for a built accel). */
const rto_accel_tlas *rto_accel_get_tlas(const rto_accel *accel);
/** Number of BLAS (= the scene's mesh count). */
uint32_t rto_accel_blas_count(const rto_accel *accel);
/** The BLAS of a mesh; NULL if mesh >= rto_accel_blas_count. */
const rto_accel_blas *rto_accel_get_blas(const rto_accel *accel, uint32_t mesh);
/**
 * Self-check of every tree with the structure-only validators (rto_tlas_check, rto_karras_check), leaf boxes exact:
 * each keyed instance and each triangle in exactly one leaf, no leaf for an instance of an empty BLAS, links,
 * parents, items, EMPTY handling, unions and leaf boxes. RTO_OK, or RTO_ERR_MISMATCH with report filled (its "what"
 * names the tree: "TLAS (sweep)", "BLAS 3") and msg naming it too ("the BLAS of mesh 3: ...").
 */
rto_status rto_accel_check(const rto_accel *accel, rto_report *report, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Tracing (DESIGN.md §6): the slab test, Möller–Trumbore, ordered TLAS -> BLAS traversal, rays, hit validation     */

/* Ray flags (Vulkan / DXR values). With no any-hit programs every triangle is opaque, so OPAQUE changes nothing;
 * SKIP_CLOSEST_HIT is for the shading stage: the hit record is written all the same. */
#define RTO_RAY_FLAG_OPAQUE UINT32_C(0x1)
#define RTO_RAY_FLAG_TERMINATE_ON_FIRST_HIT UINT32_C(0x4)
#define RTO_RAY_FLAG_SKIP_CLOSEST_HIT UINT32_C(0x8)
#define RTO_RAY_FLAG_CULL_BACK_FACING UINT32_C(0x10)
#define RTO_RAY_FLAG_CULL_FRONT_FACING UINT32_C(0x20)

/** The §2 clamp, then 1/d: components with |d| < 1e-20 become copysign(1e-20, d) (+1e-20 for +-0). */
void rto_ray_inv_dir(const float dir[3], float inv_dir[3]);
/**
 * The slab test of §6: t0 = (min - o) * inv_dir, t1 = (max - o) * inv_dir, tNear = max(max3(min(t0, t1)), t_min),
 * tFar = min(min3(max(t0, t1)), best_t); returns 1 and sets *t_entry = tNear iff tNear <= tFar. min / max take the
 * second operand when the two compare equal; max3(a, b, c) = max(max(a, b), c).
 */
int rto_slab_test(const float bmin[3], const float bmax[3], const float origin[3], const float inv_dir[3],
                  float t_min, float best_t, float *t_entry);

/** A Möller–Trumbore result: t, barycentrics (u, v) with p = (1-u-v) v0 + u v1 + v v2, and det (> 0: front face). */
typedef struct rto_tri_hit {
    float t, u, v, det;
} rto_tri_hit;

/**
 * Möller–Trumbore in exactly the §6 operation order. Returns 1 (and fills hit) iff det != 0, u >= 0, v >= 0,
 * u + v <= 1 and t_min <= t < best_t; 0 otherwise (hit then holds what was computed, for diagnostics).
 */
int rto_triangle_intersect(const float v0[3], const float v1[3], const float v2[3], const float origin[3],
                           const float dir[3], float t_min, float best_t, rto_tri_hit *hit);

/** A world-space ray in object space (§6): o' = W2O (o, 1), d' = W2O (d, 0), each row ((m0 x + m1 y) + m2 z) + m3,
 * d' not renormalised. */
void rto_ray_to_object(const rto_mat34 *world_to_obj, const float origin[3], const float dir[3], float obj_origin[3],
                       float obj_dir[3]);

/** The miss record of a ray (§6): missFlag 1, t = t_max, the four IDs 0xFFFFFFFF, bary and objToWorld 0. */
rto_hit_record rto_hit_record_miss(float t_max);
/** The hit record of triangle prim of instance index inst (§6): t, IDs, hitGroup = sbtOffset, bary (u, v), the
 * instance's customIndex and its objToWorld as a column-major mat4x3 (padding 0). */
rto_hit_record rto_hit_record_make(const rto_instance *instance, uint32_t inst, uint32_t prim, const rto_tri_hit *hit);

/**
 * Intersects one triangle of one instance with a ray exactly as traversal does (the ray in object space, the
 * ray's flags for culling, best_t = the ray's tMax): returns 1 and fills hit when the triangle is hit; 0 when it is
 * missed, culled, or the instance's mask does not meet the ray's cull mask.
 */
int rto_instance_triangle_hit(const rto_instance *instance, const rto_mesh *mesh, uint32_t prim,
                              const rto_wf_ray *ray, rto_tri_hit *hit);

/** How to trace. Zero-initialised (or a NULL pointer) means the defaults. */
typedef struct rto_trace_desc {
    uint32_t threads; /* 0: one per online CPU. Rays are split into equal contiguous ranges, one per thread, so the
                       * output does not depend on the thread count. */
} rto_trace_desc;

/**
 * Traces n rays through an accel (ordered traversal, §6) into n hit records and, when counters is not NULL, n counter
 * records. TERMINATE_ON_FIRST_HIT rays stop at the first triangle hit found; CULL_BACK_FACING / CULL_FRONT_FACING skip
 * triangles by the sign of det in object space; an instance is entered only when instance.mask & ray.cullMask. Rays
 * whose origin, direction, tMin or tMax is not finite, or whose tMin > tMax, are refused (RTO_ERR_INVALID_ARGUMENT
 * naming the first such ray) before anything is traced. Each ray takes its own walk, as a GPU thread does; on x86-64 on
 * a copy of the trees laid out for a CPU, made once the calls on the accel have brought threads * slots rays (the
 * copy's 64-byte slots: two per triangle, one per TLAS node) and kept with it (freed by rto_accel_destroy), before that
 * on the accel's own trees (on the copy, neighbouring rays that point alike walk the trees in groups of 16 where the
 * CPU has AVX-512, of 8 where it has AVX2 or where RTO_TRACE_GROUPS=8 in the environment (one at a time with
 * RTO_TRACE_GROUPS=1), and rays that diverge through trees of more than 2 MiB run eight in turn, each ray's walk
 * unchanged); with RTO_TRACE_ISA=scalar in the environment always on the accel's own trees, with sse2
 * on the copy from the first call (where it can be made), with avx2 or avx512 8 or 16 rays in SIMD lanes where the CPU
 * has them. The bytes are the same on every path (docs/trace.md, "Paths").
 * Concurrent calls on one accel are safe.
 */
rto_status rto_trace(const rto_accel *accel, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                     rto_hit_record *hits, rto_trace_counters *counters, rto_msg *msg);

/**
 * The brute-force reference (tests and cross-checks): for each ray, every triangle of every instance in index
 * order, no tree, with the same object-space ray and Möller–Trumbore as rto_trace, so the same primitive gives the
 * same t bit for bit; ties go to the first triangle found in index order. Same flags, masks and refusals.
 */
rto_status rto_trace_brute(const rto_scene *scene, const rto_wf_ray *rays, size_t n, const rto_trace_desc *desc,
                           rto_hit_record *hits, rto_msg *msg);

/* Cameras and rays (seed 002 §2.2-2.3, DESIGN.md §7). */

/**
 * The 144-byte uniform block of a camera for an image of width x height (aspect = width / height unless
 * camera->aspect is set): right-handed lookAt and OpenGL perspective (clip z in [-1, 1]), both inverted in binary64
 * and rounded once. RTO_ERR_INVALID_ARGUMENT for a degenerate camera (target at the eye, up parallel to the view
 * direction, fovY outside (0, pi), near <= 0 or far <= near) or a zero size.
 */
rto_status rto_camera_uniforms_make(const rto_camera *camera, uint32_t width, uint32_t height,
                                    rto_camera_uniforms *out, rto_msg *msg);
/** A camera framing a box: looking at its centre from the Stage-2 direction (0, 2, 5), far enough that the box's
 * bounding sphere fits the vertical and horizontal field of view (fovY 60 degrees, image aspect `aspect`; <= 0 counts
 * as 1), near and far around it; its own aspect is left 0 (the image's). An empty or non-finite box gives
 * rto_camera_default(). docs/trace.md states the formula. */
rto_camera rto_camera_frame(const rto_aabb *bounds, float aspect);

/** The primary ray of pixel (x, y) per the seed's generateRay (pixel centre x + 0.5, y + 0.5; NDC y flipped; row 0
 * at the top): origin the camera position, direction normalize((inverseView * (rayEye.xy, -1, 0)).xyz); tMin 0,
 * tMax RTO_RAY_T_MAX, pixel y * width + x, flags OPAQUE, cullMask 0xFF, kind RTO_RAYS_PRIMARY, payloadSlot pixel. */
rto_wf_ray rto_camera_ray(const rto_camera_uniforms *u, uint32_t width, uint32_t height, uint32_t x, uint32_t y);

/** tMax of every generated ray: finite, so a miss record's t stays comparable. */
#define RTO_RAY_T_MAX 1.0e30f

/** The generated ray sets. A ray's kind holds its set; every set is a pure function of the scene, its size and the
 * seed (the PRNG of §3). */
typedef enum rto_ray_set {
    RTO_RAYS_PRIMARY = 0, /* "primary": one camera ray per pixel, row-major */
    RTO_RAYS_SHADOW = 1,  /* "shadow": from each primary hit towards the light, TERMINATE_ON_FIRST_HIT |
                           * SKIP_CLOSEST_HIT, tMin a small offset from the surface */
    RTO_RAYS_RANDOM = 2,  /* "random": origins uniform in the scene bounds, directions uniform on the sphere */
    RTO_RAYS_GRAZING = 3, /* "grazing": aimed at triangle edges and vertices of random instances */
    RTO_RAYS_AXIS = 4     /* "axis": axis-parallel and zero-component directions (+0 and -0) aimed at triangles */
} rto_ray_set;
#define RTO_RAY_SET_COUNT 5

/** "primary", "shadow", ...; NULL for an unknown value. */
const char *rto_ray_set_name(rto_ray_set set);
/** The set of a name; returns 0 for an unknown one, else 1 and sets *set. */
int rto_ray_set_parse(const char *name, rto_ray_set *set);

/** What to generate. Zero-initialise, then set what the set needs. */
typedef struct rto_rays_desc {
    rto_ray_set set;
    uint32_t seed;
    uint32_t width, height;   /* primary, shadow: the image */
    const rto_camera *camera; /* primary, shadow: NULL frames the scene bounds (rto_camera_frame) */
    size_t count;             /* random, grazing, axis: how many rays */
    float light_dir[3];       /* shadow: direction towards a distant light; 0 0 0 means (0.3, 1, 0.2) normalised */
    uint32_t threads;         /* shadow: for tracing the primary rays (0: all CPUs) */
} rto_rays_desc;

/** The most rays a description can produce (width * height, or count). */
size_t rto_rays_capacity(const rto_rays_desc *desc);
/**
 * Generates a ray set for the scene of an accel into rays (cap records; rto_rays_capacity is enough) and sets *n.
 * Shadow rays trace the primary rays first and keep one ray per primary hit, in pixel order. camera_out (NULL is
 * fine) receives the uniform block of the camera used (primary, shadow; zeros otherwise). A scene without
 * triangles gives 0 random, grazing and axis rays.
 */
rto_status rto_rays_generate(const rto_accel *accel, const rto_rays_desc *desc, rto_wf_ray *rays, size_t cap,
                             size_t *n, rto_camera_uniforms *camera_out, rto_msg *msg);
/**
 * Reads a ray file: WfRay records in any form rto_layout_accept takes (structured, (n, 16) words or flat) into a
 * fresh array (*rays, free with free()) of *n rays. More than max rays is refused (RTO_ERR_UNSUPPORTED) after the
 * header is read. The rays are not checked here: rto_trace refuses what cannot be traced.
 */
rto_status rto_rays_read(const char *path, size_t max, rto_wf_ray **rays, size_t *n, rto_msg *msg);

/* Hit validation (DESIGN.md §9). */

/** Fault classes of rto_hits_check, in diagnosis priority order. Names are stable strings (rto_hit_fault_name). */
typedef enum rto_hit_fault {
    RTO_HIT_OK = 0,           /* "none" */
    RTO_HIT_SIZE = 1,         /* "size": the dump holds another number of records than rays */
    RTO_HIT_MISS_FLAG = 2,    /* "miss-flag": hit where the oracle misses, or the reverse (or a flag not 0 / 1) */
    RTO_HIT_INSTANCE = 3,     /* "instance": another instance, not a tie */
    RTO_HIT_PRIM = 4,         /* "prim": another triangle of the instance, not a tie */
    RTO_HIT_T = 5,            /* "t": t outside |dt| <= 1e-5 max(1, |t|) (a miss: t != tMax) */
    RTO_HIT_BARY = 6,         /* "bary": a barycentric off by more than 1e-4 */
    RTO_HIT_CUSTOM_INDEX = 7, /* "custom-index": not the instance's customIndex */
    RTO_HIT_HIT_GROUP = 8,    /* "hit-group": not the instance's sbtOffset */
    RTO_HIT_TRANSFORM = 9     /* "transform": objToWorld not the instance's (column-major mat4x3) */
} rto_hit_fault;

const char *rto_hit_fault_name(rto_hit_fault f);

/** What a GPU hit dump is checked against. */
typedef struct rto_hits_check_desc {
    const rto_wf_ray *rays; /* the traced rays */
    size_t ray_count;
    const rto_hit_record *expected; /* the oracle's ray_count records (rto_trace) */
    const rto_hit_record *gpu;      /* the GPU's records */
    size_t gpu_count;
    const rto_instance *instances; /* the scene, to re-intersect a GPU's claimed primitive */
    uint32_t instance_count;
    const rto_mesh *meshes;
    uint32_t mesh_count;
} rto_hits_check_desc;

/**
 * Validates a GPU hit dump ray by ray (§9). A different instance or primitive is accepted only when the GPU's
 * claimed primitive, re-intersected with the same ray (rto_instance_triangle_hit), gives a t within the t tolerance
 * of the oracle's: a tie, counted in the facts ("ties") and listed in the rows, after which the record is compared
 * with that primitive's own record. A disagreement on whether or which triangle is hit is accepted as grazing (facts
 * "grazing", rows "grazing.*") when every hit one side found and the other did not lies on an edge of its triangle
 * and no triangle is hit solidly before the GPU's answer (docs/trace.md). For a TERMINATE_ON_FIRST_HIT ray only hit /
 * miss is defined: a claimed hit must re-intersect, at its t. A miss must be exactly the miss record of its ray; objToWorld's padding is not compared.
 * The primary fault is the highest-priority fault of the first wrong ray; faults_seen lists every class found.
 * Returns RTO_OK, RTO_ERR_MISMATCH (report: code an rto_hit_fault, location "ray", checks "size", "miss",
 * "primitive", "t", "bary", "instance-data"; facts "rays", "gpu_records", "hits", "misses", "first_hit_rays",
 * "ties", "grazing", "wrong_rays"), or RTO_ERR_INVALID_ARGUMENT for unusable input: NULL arrays, an instance naming a missing
 * mesh, an index past its mesh's vertices, a ray rto_trace refuses, or an expected record that is neither the miss
 * record of its ray nor the hit record of the primitive it names (msg names it). docs/trace.md has the details.
 */
rto_status rto_hits_check(const rto_hits_check_desc *desc, rto_report *report, rto_msg *msg);

/** The scene instance of an InstanceRecord (what a bundle stores). */
rto_instance rto_instance_from_record(const rto_instance_record *record);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Images (DESIGN.md §8-§9): PNG and OpenEXR through OpenImageIO, compared with ImageBufAlgo                          */

typedef enum rto_pixel_type {
    RTO_PIXEL_U8 = 0, /* 8-bit unsigned normalised (PNG) */
    RTO_PIXEL_F32 = 1 /* binary32, linear (OpenEXR) */
} rto_pixel_type;

/** An image in memory: rows top first, channels interleaved (1 to 4: Y, YA, RGB, RGBA). */
typedef struct rto_image {
    uint32_t width, height, channels;
    rto_pixel_type type;
    void *pixels; /* width * height * channels values of type; owned when filled by rto_image_read */
} rto_image;

/** The decoded bytes rto_image_read allows by default: 256 MiB (an 8192 x 8192 8-bit RGBA image, or 4096 x 4096 float
 * RGBA). */
#define RTO_IMAGE_BUDGET_DEFAULT ((size_t)256 << 20)
/**
 * Reads a PNG, OpenEXR (or any format OpenImageIO reads) file: 8-bit files as RTO_PIXEL_U8, everything else as
 * RTO_PIXEL_F32, without colour conversion. Refuses (RTO_ERR_PARSE / RTO_ERR_IO / RTO_ERR_UNSUPPORTED, one line in
 * msg) a corrupt, truncated or non-regular file, an image over 2^28 pixels, and one whose decoded pixels would take
 * more than RTO_IMAGE_BUDGET_DEFAULT bytes, from its header, before allocating its pixels.
 */
rto_status rto_image_read(const char *path, rto_image *out, rto_msg *msg);
/** rto_image_read with a budget of decoded bytes (0: RTO_IMAGE_BUDGET_DEFAULT). */
rto_status rto_image_read_budget(const char *path, size_t budget_bytes, rto_image *out, rto_msg *msg);
/** Reads only the header of an image file: *out gets width, height, channels and type, pixels NULL (nothing to
 * free). The same refusals as rto_image_read but the budget. */
rto_status rto_image_probe(const char *path, rto_image *out, rto_msg *msg);
/** Writes an image atomically (rto_file_write's rules): ".png" needs RTO_PIXEL_U8, ".exr" RTO_PIXEL_F32 (stored as
 * 32-bit float, ZIP compressed). The bytes depend only on the pixels. */
rto_status rto_image_write(const char *path, const rto_image *image, rto_msg *msg);
/** Frees what rto_image_read allocated and zeroes the struct. NULL is fine. */
void rto_image_free(rto_image *image);

/** Thresholds of rto_image_compare, as idiff's options (-fail, -failpercent, -hardfail, -warn, -warnpercent, -hardwarn):
 * a pixel fails when a channel differs by more than fail; the comparison fails when more than fail_percent % of the
 * pixels fail or any differs by more than hard_fail, and warns likewise with the warn thresholds. Values are compared
 * in [0, 1] units (8-bit values divided by 255). A zero-initialised description means idiff's defaults (fail and
 * warn 1e-6, percents 0, hard thresholds infinite). */
typedef struct rto_image_compare_desc {
    double fail, fail_percent, hard_fail;
    double warn, warn_percent, hard_warn;
    int hard_fail_set, hard_warn_set; /* nonzero: hard_fail / hard_warn apply */
    const char *diff_path;            /* non-NULL: write |expected - actual| * diff_scale there (PNG or EXR) */
    double diff_scale;                /* 0 means 1 */
} rto_image_compare_desc;

typedef enum rto_image_verdict { RTO_IMAGE_PASS = 0, RTO_IMAGE_WARN = 1, RTO_IMAGE_FAIL = 2 } rto_image_verdict;

/** What rto_image_compare measured (OpenImageIO's ImageBufAlgo::compare and PSNR over all channels). */
typedef struct rto_image_compare_result {
    double mean_error, rms_error, psnr, max_error; /* psnr = 20 log10(peak / rms_error), peak = max(1, the largest
                                                    * value of either image): +inf for identical images */
    uint32_t max_x, max_y, max_c;                  /* where max_error is */
    uint64_t pixels, fail_count, warn_count;       /* pixels over the fail / warn threshold */
    rto_image_verdict verdict;
} rto_image_compare_result;

/** Compares two images as Debian's idiff 2.4.7 does: over the union of the two (a pixel or channel one image lacks
 * reads as 0; percentages are of the expected image's pixels), with idiff's verdict (see io/image.c). Returns RTO_OK
 * with the verdict in result; a diff image is written when asked for and both images have one size and channel
 * count. */
rto_status rto_image_compare(const rto_image *expected, const rto_image *actual, const rto_image_compare_desc *desc,
                             rto_image_compare_result *result, rto_msg *msg);

/** Writes an image into a bundle as name (".png" or ".exr") with its role; recorded like an array (sha256, and
 * "image": width, height, channels, type). */
rto_status rto_bundle_add_image(rto_bundle *b, const char *name, const char *role, const rto_image *image,
                                rto_msg *msg);
/** Loads an image of a bundle by name after checking its sha256 (free with rto_image_free). */
rto_status rto_bundle_read_image(rto_bundle_reader *r, const char *name, rto_image *out, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* The wavefront frame (DESIGN.md §7): GENERATE -> PREP -> (TRACE -> SHADE -> PREP) x maxDepth -> RESOLVE          */
/*
 * A program is a set of C callbacks mirroring the seeds' WGSL API: raygen emits primary rays; closest_hit and miss
 * accumulate colour into a pixel and emit rays into the next queue, each with a payload that travels with the ray by
 * value; resolve turns the linear accum into the image. The callbacks reach the frame through ctx->api (inline
 * wrappers below), so a plugin built as a shared library needs this header only, not librtoracle. Callbacks run on
 * several threads at once: they must not write shared state, and their output must depend on their arguments only.
 */

#define RTO_PROGRAM_ABI_VERSION 1
/** The one symbol a plugin exports: `const rto_program *rto_program_entry_v1(void)` (rto_program_entry_fn). */
#define RTO_PROGRAM_ENTRY_SYMBOL "rto_program_entry_v1"
#define RTO_PAYLOAD_MAX 64         /* bytes of payload a ray may carry */
#define RTO_PROGRAM_PARAMS_MAX 16  /* parameters a program may declare */
/** Emits one raygen or shading invocation may make; a further emit is refused (counted in `refused`). Slots: the
 * j-th emit (j = 0, 1) of an invocation for pixel p gets payloadSlot p + j W H, so the payload store of a queue has
 * 2 W H slots, like the queue itself. */
#define RTO_FRAME_EMITS_PER_INVOCATION 2
/** Ray kinds of the built-in programs (a WfRay's kind; a program may use any u32). */
#define RTO_RAY_KIND_PRIMARY 0u
#define RTO_RAY_KIND_SHADOW 1u
/** Bits of not_comparable.npy: why a pixel's accum cannot be compared with a GPU's. */
#define RTO_PIXEL_CONFLICT 0x1u /* two rays accumulated into it in one SHADE pass */
#define RTO_PIXEL_DROPPED 0x2u  /* a ray of it was dropped at capacity (which ray drops is arbitrary on a GPU) */

/** A parameter a program declares, with its default: settable with `rtoracle render --param NAME=V[,V...]`. */
typedef struct rto_program_param {
    const char *name; /* [a-z0-9_]+ */
    uint32_t count;   /* 1 .. 4 floats */
    float value[4];   /* the default */
    const char *help; /* one line */
} rto_program_param;

/** The surface at a hit (rto_frame_api.surface): everything is computed in binary32 in the order DESIGN.md §7 states. */
typedef struct rto_surface {
    float position[3];         /* world: ray origin + t * dir */
    float geometric_normal[3]; /* world, unit: transpose(worldToObj) * cross(v1 - v0, v2 - v0), as wound */
    float normal[3];           /* world, unit: the interpolated vertex normals, else the geometric normal */
    float uv[2];               /* interpolated TEXCOORD_0; (0, 0) without */
    float base_color[4];       /* linear: material base colour * base-colour texture at uv (sRGB-decoded, bilinear,
                                * wrap); (1, 1, 1, 1) without material */
    int32_t material;          /* material index, -1 for none */
} rto_surface;

typedef struct rto_frame_ctx rto_frame_ctx;

/** What a frame gives its program: fixed for the whole frame. */
typedef struct rto_frame_env {
    uint32_t width, height, max_depth;
    const rto_camera_uniforms *camera; /* the 144-byte block the frame's primary rays come from */
    const rto_scene *scene;            /* NULL for the analytic `stage2` scene */
    float ray_offset;                  /* a self-intersection offset for secondary rays' tMin: 1e-4 max(1, M), M the
                                        * largest magnitude of the scene bounds and camera position (as shadow rays) */
    const float (*params)[4];          /* the program's parameters, in its table's order */
    void *user;                        /* what the program's init returned */
} rto_frame_env;

/** The frame's services, called through ctx (use the inline wrappers). */
typedef struct rto_frame_api {
    uint32_t abi_version; /* RTO_PROGRAM_ABI_VERSION */
    /* raygen only: emits a ray for the invocation's pixel (ray->pixel and payloadSlot are set by the frame; the
     * other fields are the program's). payload: the program's payload_size bytes, NULL for zeros. Returns 1 when the
     * emit is accepted (a drop at capacity is known only when the pass's emits are applied in order, and shows in
     * the counters), 0 when it is refused (past the per-invocation budget) or called from the wrong callback. */
    int (*emit_primary_ray)(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload);
    /* closest_hit / miss only: emits a ray into the next queue, for the pixel of the ray being shaded. */
    int (*emit_ray)(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload);
    /* Adds rgb to accum[pixel].rgb (pixel < W H; another value is ignored and counted as an invalid call). */
    void (*accumulate)(rto_frame_ctx *ctx, uint32_t pixel, const float rgb[3]);
    /* The surface at a hit of the scene's triangles (mesh scenes), or of the stage2 primitives (normals by the
     * seed's rules; uv 0, base colour 1). */
    void (*surface)(const rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, rto_surface *out);
    /* Bilinear, wrapped, sRGB-decoded sample of a scene texture (rgba; alpha linear); (1, 1, 1, 1) for index < 0. */
    void (*sample_texture)(const rto_frame_ctx *ctx, int32_t texture, const float uv[2], float rgba[4]);
    /* The frame camera's primary ray of pixel (x, y): rto_camera_ray of env->camera (kind RTO_RAY_KIND_PRIMARY). */
    rto_wf_ray (*camera_ray)(const rto_frame_ctx *ctx, uint32_t x, uint32_t y);
} rto_frame_api;

/** The context of one callback invocation. */
struct rto_frame_ctx {
    const rto_frame_api *api;
    const rto_frame_env *env;
};

static inline int rto_emit_primary_ray(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    return ctx->api->emit_primary_ray(ctx, ray, payload);
}
static inline int rto_emit_ray(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload)
{
    return ctx->api->emit_ray(ctx, ray, payload);
}
static inline void rto_accumulate(rto_frame_ctx *ctx, uint32_t pixel, const float rgb[3])
{
    ctx->api->accumulate(ctx, pixel, rgb);
}
static inline rto_wf_ray rto_frame_camera_ray(const rto_frame_ctx *ctx, uint32_t x, uint32_t y)
{
    return ctx->api->camera_ray(ctx, x, y);
}
static inline void rto_surface_at(const rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit,
                                  rto_surface *out)
{
    ctx->api->surface(ctx, ray, hit, out);
}

/** A program (built in, or a plugin's). All strings and tables live as long as the program. */
typedef struct rto_program {
    uint32_t abi_version;      /* RTO_PROGRAM_ABI_VERSION */
    const char *name;          /* [a-z0-9-]+ */
    const char *description;   /* one line */
    uint32_t payload_size;     /* bytes, a multiple of 4, <= RTO_PAYLOAD_MAX */
    uint32_t max_depth;        /* the default maxDepth (>= 1) */
    const rto_program_param *params;
    uint32_t param_count;      /* <= RTO_PROGRAM_PARAMS_MAX */
    /* Optional: called once before the frame; returns 0 (and a reason in why) to refuse the scene or parameters. */
    int (*init)(const rto_frame_env *env, void **user, char *why, size_t why_cap);
    void (*fini)(void *user); /* optional */
    /* Required: GENERATE, once per pixel (x, y), row-major. */
    void (*raygen)(rto_frame_ctx *ctx, uint32_t x, uint32_t y);
    /* SHADE: hits (unless the ray has SKIP_CLOSEST_HIT) and misses, in queue order. payload: a copy. */
    void (*closest_hit)(rto_frame_ctx *ctx, const rto_wf_ray *ray, const rto_hit_record *hit, const void *payload);
    void (*miss)(rto_frame_ctx *ctx, const rto_wf_ray *ray, const void *payload);
    /* Optional RESOLVE: hdr is accum[pixel] (rgb sums, a = 1); NULL means passthrough. */
    void (*resolve)(const rto_frame_env *env, uint32_t x, uint32_t y, const float hdr[4], float rgba[4]);
} rto_program;

typedef const rto_program *(*rto_program_entry_fn)(void);

/** The built-in programs: "triangle", "sun-shadow", "normals" (DESIGN.md §7); NULL for another name. */
const rto_program *rto_program_builtin(const char *name);
/** The built-in program at index i (0 ..), NULL past the last: for listings. */
const rto_program *rto_program_builtin_at(uint32_t i);

typedef struct rto_plugin rto_plugin;
/** Loads a plugin (dlopen, RTLD_LOCAL) and checks its program: ABI version, name, payload size, parameter table,
 * required callbacks. RTO_ERR_IO / RTO_ERR_UNSUPPORTED with one line in msg otherwise. */
rto_status rto_plugin_load(const char *path, rto_plugin **out, rto_msg *msg);
const rto_program *rto_plugin_program(const rto_plugin *plugin);
/** Unloads a plugin. NULL is fine. */
void rto_plugin_unload(rto_plugin *plugin);
/** Checks a program table (what rto_plugin_load checks); RTO_ERR_UNSUPPORTED naming the first problem. */
rto_status rto_program_validate(const rto_program *program, rto_msg *msg);

/** Which per-bounce buffers a frame keeps (and its bundle writes); counters, indirect args, camera, the image and
 * the not-comparable mask are always kept. */
#define RTO_FRAME_KEEP_RAYS 0x1u           /* bounce_D_rays.npy */
#define RTO_FRAME_KEEP_HITS 0x2u           /* bounce_D_hits.npy */
#define RTO_FRAME_KEEP_TRACE_COUNTERS 0x4u /* bounce_D_trace_counters.npy */
#define RTO_FRAME_KEEP_PAYLOADS 0x8u       /* bounce_D_payloads.npy */
#define RTO_FRAME_KEEP_ACCUM 0x10u         /* accum.npy */
#define RTO_FRAME_KEEP_ACCUM_EXR 0x20u     /* accum.exr: the accum buffer again, as an OpenEXR image for viewers */
#define RTO_FRAME_KEEP_ALL 0x3Fu
/** The lean golden, render's default: what a GPU harness compares of a frame (the image, the accum buffer, every
 * counter and indirect argument, the not-comparable mask), without the per-bounce queues, hits and payloads. */
#define RTO_FRAME_KEEP_LEAN RTO_FRAME_KEEP_ACCUM

/** Parses a --stages list ("rays,hits,trace-counters,payloads,accum,accum-exr", "lean", "all", "none") into
 * RTO_FRAME_KEEP_* bits;
 * 0 for an unknown name (msg names it). */
int rto_frame_keep_parse(const char *list, uint32_t *keep, rto_msg *msg);

/** The analytic scene of seed 002 (two spheres, a box and the ground slab), traced with the seed's own
 * intersection code (its 0.001 epsilon): rto_frame_desc.scene_kind. */
typedef enum rto_frame_scene_kind { RTO_FRAME_SCENE_MESH = 0, RTO_FRAME_SCENE_STAGE2 = 1 } rto_frame_scene_kind;

/** A parameter override by name (the values of --param). */
typedef struct rto_param_value {
    char name[32];
    uint32_t count;
    float value[4];
} rto_param_value;

typedef struct rto_frame_desc {
    const rto_program *program;
    rto_frame_scene_kind scene_kind;
    const rto_accel *accel;       /* RTO_FRAME_SCENE_MESH: the scene to trace */
    uint32_t width, height;
    uint32_t max_depth;           /* 0: the program's default */
    const rto_camera *camera;     /* NULL: rto_camera_frame of the scene bounds (mesh), rto_camera_default (stage2) */
    const rto_param_value *params; /* overrides of the program's defaults; an unknown name or count is refused */
    uint32_t param_count;
    uint32_t keep;                /* RTO_FRAME_KEEP_* */
    uint32_t threads;             /* 0: one per online CPU; output bytes never depend on it */
    /* Optional: called from the calling thread between passes with the fraction done (0 .. 1). */
    void (*progress)(void *arg, double fraction);
    void *progress_arg;
} rto_frame_desc;

/** The buffers of one queue, kept as desc.keep says (NULL otherwise). */
typedef struct rto_frame_queue {
    size_t count;                 /* rays stored (= counters.queued) */
    rto_wf_ray *rays;             /* queue order: emits in the order a serial GPU would make them */
    uint32_t *payloads;           /* count * payload_size / 4 words: each ray's payload */
    rto_hit_record *hits;         /* traced queues only */
    rto_trace_counters *trace_counters;
} rto_frame_queue;

/** Stages timed (wall seconds, summed over bounces). */
typedef enum rto_frame_stage {
    RTO_STAGE_GENERATE = 0,
    RTO_STAGE_PREP = 1,
    RTO_STAGE_TRACE = 2,
    RTO_STAGE_SHADE = 3,
    RTO_STAGE_RESOLVE = 4
} rto_frame_stage;
#define RTO_FRAME_STAGE_COUNT 5
/** "generate", "prep", "trace", "shade", "resolve"; NULL for another value. */
const char *rto_frame_stage_name(rto_frame_stage stage);

typedef struct rto_frame {
    char program[64];
    uint32_t width, height, max_depth, payload_size, keep;
    uint64_t capacity;                  /* 2 W H rays per queue */
    rto_camera camera;                  /* the camera used */
    rto_camera_uniforms camera_uniforms;
    rto_param_value params[RTO_PROGRAM_PARAMS_MAX]; /* every parameter's value used, in the program's order */
    uint32_t param_count;
    rto_frame_counters *counters;       /* max_depth + 1 rows */
    uint32_t (*indirect_args)[3];       /* max_depth + 1: [ceil(queued / 64), 1, 1] */
    rto_frame_queue *queues;            /* max_depth + 1 */
    float *accum;                       /* 4 W H: rgb sums, a = 1; rows top first */
    uint8_t *image;                     /* 4 W H rgba8 */
    uint8_t *not_comparable;            /* W H: RTO_PIXEL_CONFLICT | RTO_PIXEL_DROPPED */
    uint64_t invalid_calls;             /* accumulate with pixel >= W H, emit_ray from raygen, ... */
    double seconds[RTO_FRAME_STAGE_COUNT];
} rto_frame;

/**
 * Renders one frame. Deterministic: queues hold rays in the order a serial run makes them (pixels row-major in
 * GENERATE, rays in queue order in SHADE), accumulates are applied in that order, so every output byte is
 * independent of the thread count. RTO_ERR_INVALID_ARGUMENT for a bad size (0, or W H > 2^26), parameter or camera;
 * RTO_ERR_UNSUPPORTED when the program's init refuses; RTO_ERR_OUT_OF_MEMORY.
 */
rto_status rto_frame_render(const rto_frame_desc *desc, rto_frame **out, rto_msg *msg);
void rto_frame_destroy(rto_frame *frame);
/**
 * The most bytes rto_frame_render and the bundle writer may hold at once for desc (its scene and trees not counted),
 * from its size, depth, program payload and keep bits alone, before any work (DESIGN.md §7, "Memory"): the
 * per-pixel buffers and their encoded copies, the queue being shaded and the queue being filled at their capacity of
 * 2 W H rays, one chunk's hit records and logs, and every kept per-bounce buffer at capacity. A bound, not a
 * forecast: a frame whose program emits one ray per pixel holds about half of the queue part. 0 when desc would be
 * refused (no program, a size of 0 or over 2^26 pixels, a depth over 64).
 */
uint64_t rto_frame_memory_bound(const rto_frame_desc *desc);
/**
 * The default memory budget of the command-line tools: half the physical memory, or half the process's address
 * space limit (RLIMIT_AS) or cgroup memory limit (memory.max) when lower. 0 when none can be read.
 */
uint64_t rto_memory_budget_default(void);
/**
 * Adds a frame's files (rto_bundle_file: camera, emit counts, indirect args, frame counters, the kept per-bounce
 * buffers, accum, image, not-comparable mask) and manifest sections ("frame", "program", "parameters", "camera",
 * "counters", and "timings" when with_timings) to a bundle begun with kind "frame". The caller adds the scene's
 * build and geometry files (mesh scenes) and commits.
 */
rto_status rto_frame_bundle_write(const rto_frame *frame, int with_timings, rto_bundle *bundle, rto_msg *msg);

/**
 * Traces rays through the stage2 scene exactly as seed 002's traceScene: sphere (0,0,0) r 1, sphere (2.5,0,-1) r 1,
 * box centre (-2.5,0,0) half extents 0.75, ground box centre (0,-1.5,0) half extents (10, 0.5, 10), each with the
 * seed's intersectSphere / intersectBox (t < 0.001 rejected), the nearest with t < min(999999, tMax) kept. Hit
 * records: instanceId = customIndex = the primitive (0 .. 3 in that order), primId 0, hitGroup 0, bary 0,
 * objToWorld the translation to the primitive's centre.
 */
void rto_stage2_trace(const rto_wf_ray *rays, size_t n, rto_hit_record *hits);

/* Frame validation (check-frame): a GPU's dump of a frame against a frame bundle. */

/** Fault classes of rto_frame_check, in the order of the pipeline. */
typedef enum rto_frame_fault {
    RTO_FRAME_OK = 0,        /* "none" */
    RTO_FRAME_COUNTS = 1,    /* "emit-count": a queue's emit counter differs */
    RTO_FRAME_INDIRECT = 2,  /* "indirect-args": PREP's dispatch arguments differ */
    RTO_FRAME_QUEUE = 3,     /* "queue": a ray missing, extra, duplicated, or different (as multisets) */
    RTO_FRAME_PAYLOAD = 4,   /* "payload": a ray's payload differs */
    RTO_FRAME_HITS = 5,      /* "hits": a hit record fails the check-hits rules */
    RTO_FRAME_ACCUM = 6,     /* "accum": a pixel outside the accum tolerance */
    RTO_FRAME_IMAGE = 7      /* "image": the 8-bit image outside its tolerance */
} rto_frame_fault;
const char *rto_frame_fault_name(rto_frame_fault f);

/** What rto_frame_check compares, and where its artefacts go. Zero-initialised means the defaults. */
typedef struct rto_frame_check_desc {
    const char *expected_dir;    /* the frame bundle (rtoracle render) */
    const char *gpu_dir;         /* the GPU dump: a directory holding any subset of the bundle's file names */
    const char *artifact_dir;    /* NULL: none; else the diff artefacts of a failing accum / image are written there
                                  * (the directory must exist) */
    double image_fail_percent;   /* % of the compared pixels that may exceed ±1 per channel; default 0.1 (§9) */
    int image_fail_percent_set;  /* nonzero: image_fail_percent applies (so that 0 can be asked for) */
} rto_frame_check_desc;

/** Artefacts rto_frame_check may write into artifact_dir, as bits of its *artifacts output. */
#define RTO_FRAME_ARTIFACT_ACCUM_DIFF 0x1u /* "check-frame.accum_diff.exr": |expected - actual| per channel, f32 */
#define RTO_FRAME_ARTIFACT_IMAGE_DIFF 0x2u /* "check-frame.image_diff.png": |expected - actual| x 16 per channel */
#define RTO_FRAME_ARTIFACT_LISTING 0x4u    /* "check-frame.diffs.json": the rules, counts and first failing pixels */
/** The file name of one RTO_FRAME_ARTIFACT_* bit; NULL for another value. */
const char *rto_frame_artifact_name(uint32_t artifact);

/**
 * Compares a GPU's dump of a frame with the frame bundle, buffer by buffer in pipeline order (docs/frame.md "The GPU
 * dump layout"): per queue d its emit count and FrameCounters row, PREP's indirect args (exact), the queue as a
 * multiset keyed by (pixel, kind, payloadSlot) (integers exact, floats within the documented tolerance), the
 * payloads of matching rays, the hits of matching rays with rto_hits_check's rules; then accum (1e-4 relative +
 * 1e-6 absolute per channel; 2e-4 absolute for `triangle`, whose colours are barycentrics) and the 8-bit image (±1 per channel, at most image_fail_percent % of the pixels over).
 * Pixels the bundle marks not comparable (conflicts, drops) are left out of accum and image and counted; from the
 * first queue with drops on, queues are compared by their counts only. A file absent from the dump is "not
 * dumped", not a fault. The primary fault is the first divergence in pipeline order (report->code an
 * rto_frame_fault; location "bounce" and, as apt, "ray" (the oracle's queue index), "gpu_ray", "pixel", "x", "y",
 * "slot"; checks "counts", "indirect", "queues", "payloads", "hits", "accum", "image"); faults_seen lists every
 * class found and the summary names the later divergences. With artifact_dir, a failing accum or image leaves a
 * diff image and a listing there; *artifacts (NULL is fine) receives the RTO_FRAME_ARTIFACT_* bits written.
 * Returns RTO_OK, RTO_ERR_MISMATCH, or another status with one line in msg for unusable input: a bundle that is
 * not a frame bundle or whose files disagree with its manifest or with each other (sha256, dtype, shape, counts), a
 * dump file that cannot be read or has the wrong dtype, or a dump holding none of the frame's files.
 */
rto_status rto_frame_check(const rto_frame_check_desc *desc, rto_report *report, uint32_t *artifacts, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Output files: atomic writes, interrupted runs, text for JSON                                                     */

/**
 * Writes len bytes to path atomically: into a fresh `path.tmp.PID-XXXXXX` (created with the umask like open(2) with
 * 0666), then renamed over path, so a reader sees the old file or the whole new one and a failure leaves the old
 * one intact. Only a regular file is replaced: a symbolic link is followed (the file it names is replaced, the link
 * stays); a dangling link, a directory or any other kind of file is refused with RTO_ERR_IO, as is a path whose
 * directory does not exist.
 */
rto_status rto_file_write(const char *path, const void *data, size_t len, rto_msg *msg);
/**
 * Removes every temporary file and directory that the writers of this library (rto_file_write, rto_npy_write,
 * rto_bundle_*) have created and not yet renamed or removed. Async-signal-safe. A signal handler should call
 * rto_stop_signal instead, which also waits for an output being put into place.
 */
void rto_temporaries_remove(void);
/**
 * Checks a place an output is about to be written (a file, or with is_dir a directory for files): refused with
 * RTO_ERR_INVALID_ARGUMENT and a one-line message when it is the same file as one of the n inputs (NULL entries are
 * skipped), or when it lies inside an rtoracle bundle (or, with is_dir, is one): a bundle holds exactly the files its
 * manifest lists. A bundle writer's own destination is not checked here (it is replaced whole).
 */
rto_status rto_output_check(const char *path, int is_dir, const char *const *inputs, size_t n, rto_msg *msg);
/**
 * Call from a SIGINT / SIGTERM / SIGHUP handler, on whichever thread the signal arrived: removes every temporary
 * (rto_temporaries_remove) and ends the process by sig's default action (status 128 + sig in a shell). When some
 * thread is in the middle of creating, renaming or exchanging an output, the stop waits for the end of that moment,
 * which carries it out, so a destination is always its old content or its new one, whole; the handler then
 * returns. Async-signal-safe.
 */
void rto_stop_signal(int sig);
/**
 * Call before exiting normally (an atexit handler does): when a stop signal is being carried out or is waiting for
 * a moment on another thread, waits for it to end the process, so that the status is the signal's rather than an
 * error that the stop itself caused (a write into a temporary it removed).
 */
void rto_stop_settle(void);
/**
 * Copies the NUL-terminated string in to out (capacity cap bytes, NUL included) as well-formed UTF-8, as JSON
 * requires: each maximal ill-formed subsequence becomes U+FFFD (The Unicode Standard §3.9, substitution of maximal
 * subparts), so a name cut inside a character ends in one U+FFFD. Only whole characters are written. Returns the
 * length of the whole repaired string without its NUL (out was cut if the result >= cap); cap 0 only measures.
 */
size_t rto_utf8_repair(const char *in, char *out, size_t cap);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Stage bundles (DESIGN.md §8): each stage's golden files, written into a bundle and read back                     */
/*
 * Every stage has one trio, in the stage's own folder of the sources: rto_<stage>_bundle_write adds the stage's files
 * and manifest fields to a bundle the caller began (rto_bundle_begin) and commits; rto_<stage>_bundle_read opens a
 * committed bundle and reads what a check of that stage needs, every array validated like a GPU dump first (dtype and
 * shape as the manifest implies, counts and indices in range, finite floats, sha256 as listed), so a hand-edited bundle
 * is refused with one line naming the directory and file ("DIR: FILE: what", RTO_ERR_PARSE) and never trusted;
 * rto_<stage>_bundle_free releases what a read filled (and accepts a zeroed or already freed struct). The arrays a
 * read gives are the ones the stage's validator takes (rto_sort_check, rto_tlas_check / rto_karras_check,
 * rto_hits_check).
 */

/** What a sort bundle records (src/sort/sort_bundle.c). Zero-initialise; NULL strings are not recorded. */
typedef struct rto_sort_bundle_desc {
    rto_key_format format;
    const void *keys; /* the n input keys */
    size_t n;
    rto_sort_algo algo;
    uint32_t radix_bits; /* radix: 4 or 8 */
    uint32_t radix_tile; /* radix: keys per tile */
    int checkpoints;     /* also every bitonic pass (passes.npy, pass_table.npy) or radix intermediate (radix_*.npy) */
    const char *case_id; /* the suite's case id */
    const char *dist;    /* the distribution the keys were drawn from, with seed */
    uint32_t seed;
    const char *source; /* the file the keys were read from (its base name is recorded) */
} rto_sort_bundle_desc;

/** Sorts desc's keys with its algorithm and adds keys.npy, sorted.npy, perm.npy (and the checkpoints) with the input
 * and params sections. Checkpoints over 4 GiB are refused (RTO_ERR_INVALID_ARGUMENT). */
rto_status rto_sort_bundle_write(const rto_sort_bundle_desc *desc, rto_bundle *bundle, rto_msg *msg);

/** A sort bundle read back: its input, the oracle's sorted keys and the schedule its checkpoints follow. */
typedef struct rto_sort_bundle {
    rto_key_format format;
    size_t n, n_padded;
    rto_sort_algo algo;
    uint32_t radix_bits, radix_tile; /* radix bundles; 8 and 256 for bitonic ones */
    uint32_t passes;                 /* the schedule's pass count (checked against algo, n and radix_bits) */
    char case_id[160];               /* the suite case id, or "" */
    rto_npy keys;                    /* input-keys: n keys of format */
    rto_npy sorted;                  /* sorted-keys: n keys, or data NULL for a bundle that lists none */
} rto_sort_bundle;

/** Reads a sort bundle (kind "sort"): input.format / input.n against keys.npy, params against the schedule, sorted.npy
 * against the input's dtype and size (that it is the input sorted is rto_sort_check's to verify: expected_keys). */
rto_status rto_sort_bundle_read(const char *dir, rto_sort_bundle *out, rto_msg *msg);
void rto_sort_bundle_free(rto_sort_bundle *bundle);

/** Adds a scene's geometry as a GPU uploads it (src/scene/scene_bundle.c): mesh_M_positions.npy (f32 (V, 3)) and
 * mesh_M_indices.npy (u32 (T, 3)) per mesh. The instances are the build bundle's instances.npy. */
rto_status rto_scene_bundle_write(const rto_scene *scene, rto_bundle *bundle, rto_msg *msg);

/** A scene read back from a trace or frame bundle: what the tracer and the hit checks intersect with. */
typedef struct rto_scene_bundle {
    const rto_mesh *meshes; /* counts.meshes meshes, named "mesh M", no materials */
    uint32_t mesh_count;
    const rto_instance *instances; /* counts.instances instances */
    uint32_t instance_count;
    struct rto_scene_bundle_data *data; /* the arrays the views point into */
} rto_scene_bundle;

/** Reads the scene of a bundle of any kind that holds one (trace, frame): counts in range, vertex positions finite,
 * every index below its mesh's vertex count, triangles as blas_M.triangles says, every instance's BLAS present, both
 * transforms finite, customIndex and mask within their 24 and 8 bits. */
rto_status rto_scene_bundle_read(const char *dir, rto_scene_bundle *out, rto_msg *msg);
void rto_scene_bundle_free(rto_scene_bundle *bundle);

/** Adds a build bundle's files (rto_bundle_file) and manifest fields (scene, counts, params.tlas, tlas, blas_M) of an
 * accel (src/bvh/bvh_bundle.c). */
rto_status rto_bvh_bundle_write(const rto_accel *accel, rto_bundle *bundle, rto_msg *msg);

/** One tree of a build bundle read back, as rto_tlas_check / rto_karras_check take it (rto_bvh_check_desc). */
typedef struct rto_bvh_bundle {
    int64_t blas;        /* the tree read: -1 the TLAS, else the BLAS of that mesh */
    int sweep;           /* a sweep TLAS (rto_tlas_check, rto_tlas_node records); else a Karras tree (rto_bvh_node) */
    char tlas_mode[8];   /* params.tlas: "sweep" or "karras" */
    uint32_t mesh_count; /* counts.meshes */
    const void *nodes;   /* the oracle's tree, which has passed the validator itself */
    size_t node_count;
    const rto_aabb *prim_boxes; /* instance world boxes (TLAS) or triangle boxes (BLAS) */
    size_t prim_count;
    const double *leaf_tolerance; /* TLAS: 3 per instance (rto_transform_box_tolerance); NULL for a BLAS */
    const uint32_t *leaf_prims;   /* Karras trees: the primitive of each sorted leaf; NULL for a sweep TLAS */
    size_t leaf_count;
    struct rto_bvh_bundle_data *data; /* the arrays the views point into */
} rto_bvh_bundle;

/** Reads the TLAS (blas < 0) or the BLAS of mesh blas from a build bundle (kind "build"): instance
 * world boxes equal to their BLAS's object box through objToWorld, leaf orders permutations, a Karras TLAS's keys
 * ascending and naming each instance with a leaf once, node counts as the layout implies, and the tree valid over its
 * primitives. A blas the bundle does not have is RTO_ERR_INVALID_ARGUMENT. */
rto_status rto_bvh_bundle_read(const char *dir, int64_t blas, rto_bvh_bundle *out, rto_msg *msg);
void rto_bvh_bundle_free(rto_bvh_bundle *bundle);

/** What a trace bundle records (src/trace/trace_bundle.c). Zero-initialise. */
typedef struct rto_trace_bundle_desc {
    const rto_accel *accel; /* the trees (the build bundle's files) and, through rto_accel_scene, the geometry */
    const rto_wf_ray *rays;
    size_t count;
    const rto_hit_record *hits;         /* count records */
    const rto_trace_counters *counters; /* count records (their statistics go into the manifest) */
    const char *ray_set;                /* trace.rays: the set's name or the ray file */
    int generated;                      /* the rays come from a named set: trace.seed is recorded */
    uint32_t seed;
    const rto_camera *camera; /* camera rays: the camera, with width, height and camera_block; else NULL */
    const rto_camera_uniforms *camera_block;
    uint32_t width, height;
    const char *light; /* shadow rays: trace.light as recorded ("x,y,z" or "default"); else NULL */
} rto_trace_bundle_desc;

/** Adds a trace bundle's files: the build bundle's, the scene's geometry (rto_scene_bundle_write), rays.npy, hits.npy,
 * counters.npy, camera.npy for camera rays, and the trace, camera and counter-statistics sections. */
rto_status rto_trace_bundle_write(const rto_trace_bundle_desc *desc, rto_bundle *bundle, rto_msg *msg);

/** A trace bundle read back: its scene, rays and the oracle's hit records, as rto_hits_check takes them. */
typedef struct rto_trace_bundle {
    rto_scene_bundle scene;
    const rto_wf_ray *rays; /* count rays, each with finite origin, direction, tMin <= tMax */
    const rto_hit_record *hits; /* count records, as many misses as trace.misses */
    size_t count;
    char ray_set[96];       /* trace.rays */
    uint32_t width, height; /* camera rays: the image; else 0 */
    struct rto_trace_bundle_data *data;
} rto_trace_bundle;

rto_status rto_trace_bundle_read(const char *dir, rto_trace_bundle *out, rto_msg *msg);
void rto_trace_bundle_free(rto_trace_bundle *bundle);

/* Frame bundles are written by rto_frame_bundle_write (with the frame, above; src/frame/frame_bundle.c). */

/** A frame bundle read back (src/frame/frame_dump.c): what check-frame reads before any GPU file — the frame's size
 * and depth, its frame-wide arrays, each consistent with the others (emitted counts equal in both files, queued,
 * dropped, traced, hits and misses following from emitted and the capacity 2 W H, indirect args ceil(queued / 64),
 * mask bits defined), and, for a mesh scene, the scene (rto_scene_bundle_read). Per-bounce files stay in the bundle
 * (rto_bundle_read_name). */
typedef struct rto_frame_bundle {
    uint32_t width, height, max_depth;
    uint32_t payload_words;
    int stage2;                               /* frame.scene_kind: the Stage-2 analytic scene (no scene arrays) */
    const uint32_t *emit_counts;              /* max_depth + 1 */
    const uint32_t *indirect_args;            /* 3 (max_depth + 1) */
    const rto_frame_counters *frame_counters; /* max_depth + 1 */
    const uint8_t *not_comparable;            /* width * height RTO_PIXEL_* bits */
    rto_scene_bundle scene;                   /* mesh scenes */
    struct rto_frame_bundle_data *data;
} rto_frame_bundle;

rto_status rto_frame_bundle_read(const char *dir, rto_frame_bundle *out, rto_msg *msg);
void rto_frame_bundle_free(rto_frame_bundle *bundle);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Visibility buffer (seed 004, DESIGN.md §11): the reference rasterizer, its admissible sets, the material pass      */

/** An ID of the visibility plane (primitive index in its mesh, instance index) where no triangle covers a sample. */
#define RTO_VB_BACKGROUND 0xFFFFFFFFu

/** The camera of the visibility pass (§11.1): column-major binary32 matrices, 144 bytes (vb_camera.npy, f32 (36,)). */
typedef struct rto_vbuffer_camera {
    float view_proj[16];          /* clip = view_proj · (world, 1), WebGPU clip space (0 <= z <= w) */
    float inverse_projection[16]; /* of the WebGPU projection: the classifier's view depth */
    float position[3];
    float pad;
} rto_vbuffer_camera;
RTO_STATIC_ASSERT(sizeof(rto_vbuffer_camera) == 144, "rto_vbuffer_camera is 144 bytes");

/** The visibility pass's camera for a width x height image (the checks and aspect of rto_camera_uniforms_make). */
rto_status rto_vbuffer_camera_make(const rto_camera *camera, uint32_t width, uint32_t height, rto_vbuffer_camera *out,
                                   rto_msg *msg);

/** What the visibility pass draws: meshes (object space) and their instances, drawn in instance order. */
typedef struct rto_vbuffer_geometry {
    const rto_mesh *meshes;
    uint32_t mesh_count;
    const rto_instance *instances;
    uint32_t instance_count;
} rto_vbuffer_geometry;

/** The G-buffer (§11.4). Sample s of pixel (x, y) is element (y · width + x) · samples + s of every plane. */
typedef struct rto_vbuffer_planes {
    uint32_t width, height, samples;
    uint16_t *visibility;     /* 4 per sample: primitive lo, hi, instance lo, hi 16 bits; background 0xFFFF x 4 */
    uint16_t *barycentric;    /* 2 per sample, binary16 bits: (b1, b2) at the pixel centre */
    uint16_t *normal;         /* 4 per sample, binary16 bits: octahedral face normal (2), tangent angle, handedness */
    uint16_t *derivatives;    /* 4 per sample, binary16 bits: ddx (b1, b2), ddy (b1, b2) */
    float *depth;             /* 1 per sample: z in [0, 1], 1 where background */
    uint32_t *depth_unorm24;  /* 1 per sample: round(z · (2^24 - 1)); NULL in a GPU dump that has only depth */
} rto_vbuffer_planes;

typedef struct rto_vbuffer_desc {
    uint32_t width, height;
    uint32_t samples; /* 1 or 4 */
    uint32_t threads; /* 0: one per online CPU; the output does not depend on it */
} rto_vbuffer_desc;

/** Admissible-set statistics of a visibility buffer (§11.3). */
typedef struct rto_vbuffer_stats {
    uint64_t samples;          /* width · height · samples */
    uint64_t covered;          /* samples the reference (p = 8) covers */
    uint64_t certain;          /* samples whose admissible set has one member (background included) */
    uint64_t uncertain;        /* samples with two or more admissible answers */
    uint32_t max_set;          /* the largest admissible set */
    uint64_t set_sizes[5];     /* samples with sets of 1, 2, 3, 4 and 5 or more members */
    uint64_t clipped_triangles; /* triangles rasterized from homogeneous edge functions (§11.2) */
} rto_vbuffer_stats;

typedef struct rto_raster rto_raster; /* the rasterizer's setup, kept for evaluations (src/raster/raster.c) */

/** A visibility buffer: the reference planes (p = 8) and each sample's admissible set. */
typedef struct rto_vbuffer {
    rto_vbuffer_planes planes;
    rto_vbuffer_camera camera;
    uint32_t *admissible_offset; /* samples + 1: sample k's set is admissible[2 offset[k] .. 2 offset[k + 1]) */
    uint32_t *admissible;        /* (instance, primitive) pairs, in draw order; background (RTO_VB_BACKGROUND x 2) last */
    rto_vbuffer_stats stats;
    rto_raster *raster;
} rto_vbuffer;

/** Rasterizes geometry through camera (§11.1-11.4). RTO_ERR_INVALID_ARGUMENT for a size of 0, over 16384, or
 * samples other than 1 and 4; RTO_ERR_OUT_OF_MEMORY. */
rto_status rto_vbuffer_make(const rto_vbuffer_geometry *geometry, const rto_vbuffer_camera *camera,
                            const rto_vbuffer_desc *desc, rto_vbuffer *out, rto_msg *msg);
void rto_vbuffer_free(rto_vbuffer *vb);

/** The binary16 bits of a binary32 value, rounded to nearest even (overflow to infinity, NaN kept quiet). */
uint16_t rto_f16_from_f32(float f);
/** The binary32 value of binary16 bits (exact). */
float rto_f16_to_f32(uint16_t h);

/** The material pass's built-in materials (§11.5), and a user's (RTO_VB_PLUGIN: rto_vbuffer_material_desc.custom). */
typedef enum rto_vb_material {
    RTO_VB_NORMALS = 0, /* n · 0.5 + 0.5 */
    RTO_VB_LAMBERT = 1, /* base colour · (ambient + (1 - ambient) max(0, n·L)) */
    RTO_VB_UNLIT = 2,   /* base colour factor times its texture, level of detail from the derivatives */
    RTO_VB_PLUGIN = 3   /* a material plugin's shade callback (below) */
} rto_vb_material;

/*
 * Material plugins: a user ports the WGSL of their own material to one C function, builds it as a shared library
 * exporting RTO_MATERIAL_ENTRY_SYMBOL, and passes it to `rtoracle vbuffer --material lib.so` and `check-vbuffer
 * --material lib.so`. The material pass calls shade once for every covered sample it shades (interior pixels: sample
 * 0; edge pixels: every sample, averaged), from several threads at once: its output must depend on its argument only.
 * Like a program plugin it needs this header alone.
 */
#define RTO_MATERIAL_ABI_VERSION 1
/** The one symbol a material plugin exports: `const rto_material_def *rto_material_entry_v1(void)`. */
#define RTO_MATERIAL_ENTRY_SYMBOL "rto_material_entry_v1"

/** One covered G-buffer sample as a material reads it, decoded from the planes (binary16 widened exactly). */
typedef struct rto_vb_sample {
    uint32_t x, y, sample;
    uint32_t instance, primitive;
    float barycentric[2];    /* (b1, b2) */
    float ddx[2], ddy[2];    /* the derivatives plane */
    float normal[3];         /* the octahedral normal decoded and normalised in binary32 */
    float depth;
    float base_color[4];     /* the instance's mesh's base colour ((1, 1, 1, 1) without a material) */
    const float *sun;        /* the pass's sun direction (normalised) and ambient: sun[0..2], sun[3] */
} rto_vb_sample;

typedef struct rto_material_def {
    uint32_t abi_version;    /* RTO_MATERIAL_ABI_VERSION */
    const char *name;        /* [a-z0-9-]+, recorded in the bundle */
    const char *description; /* one line */
    /* Required: the RGBA colour of one covered sample (written as RGBA16float, rounded to nearest even). */
    void (*shade)(const rto_vb_sample *sample, float rgba[4]);
} rto_material_def;

typedef const rto_material_def *(*rto_material_entry_fn)(void);

typedef struct rto_material_plugin rto_material_plugin;
/** Loads a material plugin (dlopen, RTLD_LOCAL) and checks its table: ABI version, name, shade. RTO_ERR_IO /
 * RTO_ERR_UNSUPPORTED with one line in msg otherwise. */
rto_status rto_material_plugin_load(const char *path, rto_material_plugin **out, rto_msg *msg);
const rto_material_def *rto_material_plugin_def(const rto_material_plugin *plugin);
/** Unloads it. NULL is fine. */
void rto_material_plugin_unload(rto_material_plugin *plugin);

/** The classifier's thresholds (§11.5); RTO_VB_THRESHOLDS_DEFAULT gives the seed's public implementation's. */
typedef struct rto_vb_thresholds {
    float normal;       /* an edge where dot(n, n_neighbour) < normal */
    float depth;        /* ... or |view depth - neighbour's| > depth · |view depth| */
    float sample_depth; /* ... or the samples' view-depth range > sample_depth · |mean of min and max| */
} rto_vb_thresholds;
#define RTO_VB_THRESHOLDS_DEFAULT {0.95f, 0.02f, 0.02f}

typedef struct rto_vbuffer_material_desc {
    rto_vb_material material;
    rto_vb_thresholds thresholds;
    float sun[3];  /* lambert: direction towards the light (normalised by the pass) */
    float ambient; /* lambert */
    const rto_material *materials; /* the scene's, by mesh material index; NULL: white */
    uint32_t material_count;
    const rto_texture *textures;
    uint32_t texture_count;
    const rto_material_def *custom; /* RTO_VB_PLUGIN: the plugin's material */
} rto_vbuffer_material_desc;

/** The classifier (§11.5) on planes: mask[y · width + x] = 1 for an edge pixel, 0 otherwise. */
rto_status rto_vbuffer_classify(const rto_vbuffer_planes *planes, const rto_vbuffer_camera *camera,
                                const rto_vb_thresholds *thresholds, uint8_t *mask, rto_msg *msg);
/** The material pass (§11.5) on planes and a mask: image (width · height · 4 binary16 bits, RGBA). */
rto_status rto_vbuffer_shade(const rto_vbuffer_planes *planes, const uint8_t *mask,
                             const rto_vbuffer_geometry *geometry, const rto_vbuffer_material_desc *desc,
                             uint16_t *image, rto_msg *msg);

/** check-vbuffer's fault classes (§11.6), in the order the check reports the first of them. */
typedef enum rto_vb_fault {
    RTO_VB_PASS = 0,
    RTO_VB_COVERAGE = 1,    /* background where a triangle certainly covers the sample, or a triangle where none may */
    RTO_VB_ID = 2,          /* a triangle outside the sample's admissible set (or a mesh-meta word that is not it) */
    RTO_VB_BARYCENTRIC = 3, /* barycentrics outside the chosen triangle's intervals */
    RTO_VB_NORMAL = 4,      /* the normal plane's encoding */
    RTO_VB_DERIVATIVE = 5,  /* derivatives outside their intervals */
    RTO_VB_DEPTH = 6,       /* depth outside its interval, or a constant offset over the plane */
    RTO_VB_F16_ROUNDING = 7, /* binary16 rounded toward zero over a plane */
    RTO_VB_EDGE_MASK = 8,   /* the edge mask differs from the classifier on the GPU's own planes */
    RTO_VB_SHADING = 9      /* the image differs from the material pass on the GPU's own planes and mask */
} rto_vb_fault;
/** "coverage", "id", "barycentric", "normal", "derivative", "depth", "f16-rounding", "edge-mask", "shading", "pass". */
const char *rto_vb_fault_name(rto_vb_fault fault);

typedef struct rto_vbuffer_check_desc {
    const rto_vbuffer *expected;       /* the oracle's visibility buffer (its raster evaluates the GPU's choices) */
    const rto_vbuffer_geometry *geometry;
    const rto_vbuffer_planes *gpu;     /* the GPU's planes; a NULL plane pointer is "not dumped" */
    const uint8_t *gpu_mask;           /* width · height, or NULL */
    const uint16_t *gpu_image;         /* width · height · 4 binary16, or NULL */
    const rto_vbuffer_material_desc *material; /* for the mask and the image */
    int any_f16_rounding;              /* accept binary16 rounded toward zero (a device's documented choice) */
} rto_vbuffer_check_desc;

typedef struct rto_vbuffer_check_result {
    rto_vb_fault fault;                /* RTO_VB_PASS, or the first fault */
    const char *plane;                 /* the plane of the fault ("visibility", ..., "edge-mask", "image") */
    uint32_t x, y, sample;             /* where (sample 0 for per-pixel planes) */
    char what[512];                    /* one line: expected, actual and why */
    uint64_t compared;                 /* samples compared */
    uint64_t other_admissible;         /* samples whose GPU ID is admissible but not the reference's */
    uint64_t mask_gpu_only, mask_oracle_only, mask_either; /* edge-mask symmetric difference and margin pixels */
    uint32_t planes_checked;           /* bit k: plane k of visibility, barycentric, normal, derivatives, depth, mask,
                                        * image was dumped and compared */
} rto_vbuffer_check_result;

/** Checks a GPU's G-buffer, edge mask and image (§11.6). RTO_OK with result->fault set; an error only for unusable
 * input (sizes that differ from expected's, NULL expected). */
rto_status rto_vbuffer_check(const rto_vbuffer_check_desc *desc, rto_vbuffer_check_result *result, rto_msg *msg);

/** What a visibility-buffer bundle holds (rtoracle vbuffer; src/raster/vbuffer_bundle.c). */
typedef struct rto_vbuffer_bundle_desc {
    const rto_accel *accel;            /* the build bundle's files and the scene (rto_accel_scene): geometry, base
                                        * colours */
    const rto_vbuffer *vbuffer;        /* planes, camera, admissible sets, statistics */
    const rto_vbuffer_material_desc *material;
    const char *material_name;         /* "normals", "lambert", "unlit", or for RTO_VB_PLUGIN the plugin's name */
    const uint8_t *mask;               /* width · height: the material pass's edge mask */
    const uint16_t *image;             /* width · height · 4 binary16: its image */
} rto_vbuffer_bundle_desc;

/** Adds a vbuffer bundle's files: the build bundle's, the scene's geometry, vb_*.npy (rto_bundle_file) and the
 * "vbuffer" manifest section (size, samples, material, thresholds, sun, ambient, admissible-set statistics). */
rto_status rto_vbuffer_bundle_write(const rto_vbuffer_bundle_desc *desc, rto_bundle *bundle, rto_msg *msg);

/** A vbuffer bundle read back: every array checked for dtype and shape, IDs and admissible sets in range. */
typedef struct rto_vbuffer_bundle {
    rto_scene_bundle scene;
    rto_vbuffer_geometry geometry;     /* the scene's meshes (each its own material, by mesh index) and instances */
    rto_vbuffer_camera camera;
    rto_vbuffer_material_desc material; /* materials: one per mesh, the base colours of vb_base_colors.npy; for
                                         * RTO_VB_PLUGIN custom is NULL: the caller loads the plugin */
    char material_name[16];             /* "normals", "lambert", "unlit" or "plugin" */
    char plugin_name[64];               /* RTO_VB_PLUGIN: the plugin material's name as recorded */
    rto_vbuffer_planes planes;         /* the oracle's planes as stored */
    const uint32_t *admissible_offset, *admissible;
    const uint8_t *mask;
    const uint16_t *image;
    struct rto_vbuffer_bundle_data *data;
} rto_vbuffer_bundle;

rto_status rto_vbuffer_bundle_read(const char *dir, rto_vbuffer_bundle *out, rto_msg *msg);
void rto_vbuffer_bundle_free(rto_vbuffer_bundle *bundle);
/** A built-in material by name ("normals", "lambert", "unlit"): 1 and *out, or 0. */
int rto_vb_material_parse(const char *name, rto_vb_material *out);
const char *rto_vb_material_name(rto_vb_material material);

/** The rasterizer beside the tracer (§11, DESIGN.md §6): what rto_vbuffer_crosscheck found. */
typedef struct rto_vbuffer_crosscheck_result {
    uint64_t samples;     /* rays traced: one through every sample position */
    uint64_t agree;       /* the tracer's closest hit (or miss) is in the sample's admissible set */
    uint64_t tie;         /* another triangle, at a t within 1e-5 relative of an admissible member's */
    uint64_t clip_plane;  /* the tracer's hit lies within 1e-4 relative of the near or far plane */
    uint64_t snap;        /* the tracer's triangle (or an admissible one) has an edge within 2^-5 pixel of the sample:
                           * the tracer does not snap vertices, a rasterizer does */
    uint64_t masked;      /* an admissible member's instance has mask 0: drawn by the visibility pass, never met by
                           * a ray (cullMask 0xFF) */
    uint64_t unexplained; /* none of these */
    uint32_t x, y, sample; /* the first unexplained sample */
    char first[256];       /* what the tracer and the rasterizer said there */
} rto_vbuffer_crosscheck_result;

/**
 * Traces a primary ray through every sample position of vb (origin the eye, direction through the sample's window
 * position by the inverse camera matrices in binary64, rounded once; tMin and tMax on the near and far planes) with
 * the reference tracer and compares each closest hit with the sample's admissible set. The two are independent
 * references for each other: accel must be built from the geometry vb was rasterized from, camera the one behind
 * vb's camera block.
 */
rto_status rto_vbuffer_crosscheck(const rto_vbuffer *vb, const rto_accel *accel, const rto_camera *camera,
                                  uint32_t threads, rto_vbuffer_crosscheck_result *out, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Fluid volumes (seed 003, DESIGN.md §12): particles splatted into a fixed-point density volume, resolved to          */
/* binary16, and a conservative occupancy grid with its mip chain                                                    */

/** The splat's parameters. bounds: the volume's box; res: voxels per axis (1..1024); radius: the smoothing radius h
 * (> 0, finite); scale: the fixed-point scale (the seed's 1000); occupancy: occupancy cells per axis (1..1024, the
 * seed's 32). */
typedef struct rto_fluid_params {
    rto_aabb bounds;
    uint32_t res[3];
    float radius;
    float scale;
    uint32_t occupancy;
} rto_fluid_params;

/** The seed's defaults: bounds [-1, 1]^3, 64^3 voxels, h = 0.05, scale 1000, occupancy 32. */
void rto_fluid_params_default(rto_fluid_params *p);

/** What the splat kernels read as their uniform block (fluid_params.npy, f32 (16,)): every value a GPU needs, each
 * rounded once from binary64 where the host computes it (§12.1). */
typedef struct rto_fluid_uniforms {
    float bounds_min[3];
    float radius;        /* h */
    float voxel_size[3]; /* (max - min) / res, per axis */
    float kernel_factor; /* S = 15 / (2 pi h^5) */
    float bounds_max[3];
    float scale;         /* the fixed-point scale */
    float res[3];        /* voxels per axis, as floats */
    float occupancy;     /* occupancy cells per axis */
} rto_fluid_uniforms;
RTO_STATIC_ASSERT(sizeof(rto_fluid_uniforms) == 64, "rto_fluid_uniforms is 64 bytes");

/** Validates p and fills u (§12.1). */
rto_status rto_fluid_uniforms_make(const rto_fluid_params *p, rto_fluid_uniforms *u, rto_msg *msg);

/**
 * Particles from a named generator (§12.1): "dambreak:N", "pool:N", "splash:N", "single", "lattice" (particles on
 * voxel corners, voxel centres and the bounds' faces, where every rounding is on a knife edge). N particles at most
 * 2^24. The positions depend on the spec and p only. *pos (3 floats a particle) is malloc'ed; the caller frees it.
 */
rto_status rto_fluid_generate(const char *spec, const rto_fluid_params *p, float **pos, uint64_t *count, rto_msg *msg);

/** A splat's counters (§12.2). */
typedef struct rto_splat_stats {
    uint64_t particles;
    uint64_t contributions;      /* (particle, voxel) pairs with r < h and a non-zero contribution */
    uint64_t uncertain;          /* contributions the conformance model does not pin to one integer */
    uint64_t voxels_nonzero;
    uint64_t overflow_voxels;    /* voxels whose true sum passes 2^32 - 1 */
    uint64_t first_overflow;     /* the first of them (x fastest), or UINT64_MAX */
    uint64_t max_sum;            /* the largest true sum */
    uint64_t occupied_cells;     /* level 0 of the occupancy grid */
} rto_splat_stats;

/** The splat, the resolve and the occupancy grid (§12.2-§12.3). */
typedef struct rto_splat {
    rto_fluid_params params;
    rto_fluid_uniforms uniforms;
    uint32_t *volume_u32;      /* nx * ny * nz, the true sum mod 2^32 (what an atomicAdd leaves) */
    uint16_t *volume_f16;      /* the resolve: binary16 of f32(u) / scale, round to nearest even */
    uint32_t *occupancy;       /* every level's bits, level 0 first (§12.3) */
    uint64_t occupancy_words;
    uint32_t occupancy_levels;
    uint64_t level_offset[12]; /* first word of each level */
    uint32_t level_res[12];    /* cells per axis of each level */
    uint64_t *overflow;        /* overflow_count pairs (voxel index, true sum), or NULL */
    uint64_t overflow_count;
    rto_splat_stats stats;
} rto_splat;

/** Splats count particles (3 floats each) with threads workers (0 = all cores); the bytes do not depend on threads or
 * on the particles' order. */
rto_status rto_splat_make(const rto_fluid_params *p, const float *pos, uint64_t count, uint32_t threads, rto_splat *out,
                          rto_msg *msg);
void rto_splat_free(rto_splat *s);

/** Whether occupancy cell (x, y, z) of level l is set. */
int rto_occupancy_get(const rto_splat *s, uint32_t level, uint32_t x, uint32_t y, uint32_t z);

/** A splat bundle read back (rto_splat_bundle_read): its particles and the splat this rtoracle computes from them. */
typedef struct rto_splat_bundle {
    float *particles; /* count * 3 floats */
    uint64_t count;
    rto_splat splat;
} rto_splat_bundle;

/** Adds a splat's files to a bundle the caller began (rto_bundle_begin) and commits: fluid_params.npy,
 * particles.npy, volume_u32.npy, volume_f16.npy, occupancy.npy, overflow.npy (only with overflow), and the manifest's
 * "fluid", "occupancy" and "splat" sections (§12). */
rto_status rto_splat_bundle_write(const rto_splat *s, const float *pos, uint64_t count, rto_bundle *b, rto_msg *msg);

/** Reads a splat bundle, checks every array like a GPU dump, recomputes the splat from its particles and parameters
 * (threads workers, 0 = all cores) and requires every file to be exactly that: a tampered bundle is refused
 * (RTO_ERR_PARSE, one line naming the file and the first differing element). Free with rto_splat_bundle_free. */
rto_status rto_splat_bundle_read(const char *dir, uint32_t threads, rto_splat_bundle *out, rto_msg *msg);
void rto_splat_bundle_free(rto_splat_bundle *b);

/** What a GPU's splat passes wrote, for rto_volume_check (§12.6). */
typedef struct rto_volume_dump {
    const uint32_t *volume_u32; /* u32_count words, x fastest (required; nx * ny * nz or a shape fault) */
    uint64_t u32_count;
    const uint16_t *volume_f16; /* NULL, or f16_count binary16 bit patterns: nx * ny * nz (density only) or
                                 * 4 nx * ny * nz (rgba: density, 0, 0, 1) */
    uint64_t f16_count;
    const uint32_t *occupancy;  /* NULL, or occupancy_words words: every level, level 0 first */
    uint64_t occupancy_words;
} rto_volume_dump;

/** check-volume's fault classes, in the order they are claimed (§12.6). */
typedef enum rto_volume_fault {
    RTO_VOLUME_OK = 0,
    RTO_VOLUME_SHAPE = 1,            /* the dump's sizes are not the bundle's */
    RTO_VOLUME_OVERFLOW = 2,         /* a voxel whose true sum passes 2^32 - 1 */
    RTO_VOLUME_RADIUS = 3,           /* mass beyond the kernel radius, or none inside it */
    RTO_VOLUME_CONTRIBUTION = 4,     /* a voxel's value outside its admissible range */
    RTO_VOLUME_RESOLVE = 5,          /* the f16 plane outside the admissible f32 -> f16 range */
    RTO_VOLUME_RESOLVE_ROUNDING = 6, /* with nearest: a resolve that rounds binary16 toward zero */
    RTO_VOLUME_OCCUPANCY = 7         /* a required cell not set, or a level not the OR of its children */
} rto_volume_fault;

/** The stable name of a fault class ("none", "shape", "overflow", "radius", "contribution", "resolve",
 * "resolve-rounding", "occupancy"). */
const char *rto_volume_fault_name(rto_volume_fault f);

/**
 * Checks a GPU's splat (§12.6) against the reference s of the particles pos (count of them): every voxel exact where
 * each of its contributions is certain, else within its admissible range; every overflowing voxel a fault; the f16
 * plane (of the GPU's own u32 values) within the admissible resolve, with f16_nearest binary16 round-to-nearest-even
 * only; the occupancy grid lossless and each level the OR of its children. Fills report (the first fault of the
 * primary class, with the voxel and up to 4 particles reaching it); RTO_OK whether or not a fault was found.
 */
rto_status rto_volume_check(const rto_splat *s, const float *pos, uint64_t count, const rto_volume_dump *gpu,
                            int f16_nearest, uint32_t threads, rto_report *report, rto_msg *msg);

/* ---------------------------------------------------------------------------------------------------------------- */
/* Fluid raymarch (seed 003, DESIGN.md §12.4-§12.7): the reference raymarch of a splatted volume, with and without   */
/* empty-space skipping, and its check                                                                               */

/** What the raymarch kernel reads as its uniform block (rm_params.npy, f32 (64,), 256 bytes; §12.4). Integers are
 * stored as floats (exact below 2^24) except jitter_seed, stored as its u32 bits (bitcast in WGSL). */
typedef struct rto_raymarch_uniforms {
    float inverse_projection[16]; /*  0: the Stage-2 camera block (rto_camera_uniforms), column-major */
    float inverse_view[16];       /* 16 */
    float eye[3];                 /* 32: the camera position */
    float step_size;              /* 35: primary march step */
    float bounds_min[3];          /* 36 */
    float light_step_size;        /* 39: the shadow march steps 2 x this */
    float bounds_max[3];          /* 40 */
    float density_offset;         /* 43 */
    float extinction[3];          /* 44: rgb */
    float density_multiplier;     /* 47 */
    float sun_dir[3];             /* 48: towards the sun, unit (normalised in binary64) */
    float ior;                    /* 51: 1.33 */
    float floor_height;           /* 52 */
    float num_refractions;        /* 53: 4 */
    float jitter_scale;           /* 54: 0.4 (0: no jitter) */
    uint32_t jitter_seed;         /* 55: u32 bits */
    float width, height;          /* 56, 57 */
    float skip;                   /* 58: 1 = empty-space skipping on (only with density_offset > 0) */
    float occupancy;              /* 59: occupancy cells per axis at level 0 */
    float res[3];                 /* 60: voxels per axis */
    float occupancy_levels;       /* 63 */
} rto_raymarch_uniforms;
RTO_STATIC_ASSERT(sizeof(rto_raymarch_uniforms) == 256, "rto_raymarch_uniforms is 256 bytes");

/** A raymarch's parameters (§12.4). */
typedef struct rto_raymarch_params {
    uint32_t width, height;    /* 1..16384 */
    rto_camera camera;         /* the Stage-2 look-at camera */
    float step_size;           /* > 0 */
    float light_step_size;     /* > 0 */
    float density_offset;      /* skipping needs > 0 */
    float density_multiplier;  /* > 0 */
    float extinction[3];       /* >= 0 */
    float sun_dir[3];          /* towards the sun (normalised) */
    float ior;                 /* > 0 */
    uint32_t num_refractions;  /* 0..16 */
    float floor_height;
    float jitter_scale;        /* 0.4; 0 turns the jitter off */
    uint32_t jitter_seed;
    int skip;                  /* empty-space skipping in the skipping pass (1, default) */
    int envelope;              /* compute rm_certain / rm_tolerance (1, default; 0 leaves them 0 / inf) */
    int quantize_weights;      /* test hook, a simulated GPU: 1: trilinear weights rounded to 8 fractional bits; 2:
                                * also the filtered value rounded to binary16 (as an H100 filters rgba16float) */
    int skip_only;             /* test hook: only the skipping pass, its results as the image's (a GPU that skips) */
    /* test hook (NULL: none): called with every sample position a skip passes over, from the worker threads */
    void (*skipped_sample)(void *ctx, uint32_t pixel, const float p[3]);
    void *skipped_ctx;
    uint32_t threads;          /* 0: all cores; the bytes do not depend on it */
} rto_raymarch_params;

/** Defaults for a splat's bounds: 160x120, a camera framing the bounds, step = half the smallest voxel, light step
 * 2 voxels, offset 100, multiplier 0.01, extinction (1.2, 0.6, 0.25), sun normalize(0.3, 1, 0.2), ior 1.33,
 * 4 refractions, floor at bounds_min.y, jitter 0.4, seed 3, skip on, envelope on. */
void rto_raymarch_params_default(const rto_splat *vol, rto_raymarch_params *p);

/** Counters of a raymarch. */
typedef struct rto_raymarch_stats {
    uint64_t pixels, crossings, certain, uncertain;
    uint64_t wall_pixels; /* certain pixels with a wall event's other outcome (image_wall) */
    uint64_t steps_total, steps_skip_total; /* primary-march loop iterations, all bounces */
    uint32_t steps_max, steps_skip_max;
    uint64_t differing_pixels;    /* image bytes that differ between the skipping and non-skipping passes (0) */
    uint64_t differing_crossings; /* crossings (step or t) that differ between them (0) */
    uint64_t skipped_samples;     /* samples the skipping pass did not take */
    double normal_angle_mean, normal_angle_max; /* degrees between central and forward normals at crossings */
    int skip_enabled;
} rto_raymarch_stats;

/** A raymarch: every per-pixel array row-major (H, W). */
typedef struct rto_raymarch {
    rto_raymarch_params params;
    rto_raymarch_uniforms uniforms;
    float *image;            /* (H, W, 4) */
    uint32_t *crossing;      /* first crossing's step index, or 0xFFFFFFFF */
    uint32_t *crossing_lo;   /* admissible first-crossing steps [lo, hi]; hi 0xFFFFFFFF: none also admissible */
    uint32_t *crossing_hi;
    float *crossing_t;       /* t of the first crossing (0 where none) */
    float *normal_central;   /* (H, W, 3) at the first crossing (0 where none) */
    float *normal_forward;
    uint32_t *steps, *steps_skip;
    uint32_t *steps_min; /* primary entry-search samples (to the first crossing) that read a non-zero texel: their
                          * cells are required, so no lossless skipper takes fewer steps */
    uint8_t *certain;
    float *tolerance;        /* per pixel, every channel; +inf where uncertain */
    float *image_wall;       /* (H, W, 4): a certain pixel's other admissible image, where its path meets a wall event
                              * (§12.5.1: an exit search leaving the box in the fluid, or an exit in the box's eps band);
                              * NaN elsewhere */
    float *tolerance_wall;   /* its tolerance; NaN where there is none */
    rto_raymarch_stats stats;
} rto_raymarch;

/** Raymarches vol (its params, uniforms, volume_f16 and occupancy are read) with p: the non-skipping pass, the
 * skipping pass (when p->skip and density_offset > 0) and their comparison, and the envelope (§12.4-§12.5.1). */
rto_status rto_raymarch_make(const rto_splat *vol, const rto_raymarch_params *p, rto_raymarch *out, rto_msg *msg);
void rto_raymarch_free(rto_raymarch *r);

/** The raymarch uniform block of p over vol. */
rto_status rto_raymarch_uniforms_make(const rto_splat *vol, const rto_raymarch_params *p, rto_raymarch_uniforms *u,
                                      rto_msg *msg);

/** The density the reference samples at world point q (§12.4; exposed for tests). */
float rto_raymarch_density(const rto_splat *vol, const rto_raymarch_uniforms *u, const float q[3]);

/** A volume read from a splat (or raymarch) bundle directory: params, uniforms, volume_f16 and the occupancy levels
 * filled (volume_u32 NULL); free with rto_splat_free. */
rto_status rto_raymarch_volume_load(const char *dir, rto_splat *out, rto_msg *msg);

/** Writes a raymarch bundle (§12.4) to outdir atomically: the rm_* arrays, image.png, the splat arrays a GPU needs,
 * and the manifest. request: the up-to-date record (rto_bundle_set_request), or NULL; srcdir: the bundle vol was
 * loaded from, whose fluid_params.npy, volume_f16.npy and occupancy.npy the record hashes as its sources (NULL: none). */
rto_status rto_raymarch_bundle_write(const char *outdir, const char *request, const char *srcdir, const rto_splat *vol,
                                     const rto_raymarch *r, rto_msg *msg);

/** Reads a raymarch bundle (§12.7): its volume (rto_raymarch_volume_load), its parameters (rm_params.npy and the
 * manifest's camera), and recomputes the raymarch into *ref with threads workers; a bundle whose rm_params, rm_image
 * or rm_crossing differ from the recomputation is refused (RTO_ERR_PARSE, one line naming the file). Free vol with
 * rto_splat_free and ref with rto_raymarch_free. */
rto_status rto_raymarch_bundle_read(const char *dir, uint32_t threads, rto_splat *vol, rto_raymarch *ref,
                                    rto_msg *msg);

/** A GPU's raymarch dump (§12.7): image (H, W, 4) and crossing (H, W) required; the rest NULL when absent. */
typedef struct rto_raymarch_dump {
    uint32_t width, height;
    const float *image;
    const uint32_t *crossing;
    const uint32_t *crossing_noskip; /* the same GPU without skipping */
    const uint32_t *steps;
    const uint32_t *steps_skip;
} rto_raymarch_dump;

/** What check-raymarch found: fault "" (pass), "crossing", "skip", "image" or "shape", the first wrong pixel, a
 * one-line detail with expected and GPU values, and counts. */
typedef struct rto_raymarch_check_result {
    char fault[16];
    uint32_t x, y;
    char detail[320];
    uint64_t faults, compared, uncertain, crossing_faults, skip_faults, image_faults;
    double max_excess; /* largest |gpu - ref| / tolerance over the compared pixels */
} rto_raymarch_check_result;

/** Checks dump against ref (§12.7). RTO_OK with res->fault "" or the fault found; errors only for bad arguments. */
rto_status rto_raymarch_check(const rto_raymarch *ref, const rto_raymarch_dump *dump, rto_raymarch_check_result *res,
                              rto_msg *msg);

#ifdef __cplusplus
}
#endif

#endif /* RTORACLE_H */
