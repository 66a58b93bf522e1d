/* rtoracle crosscheck's parts (oracle/cmd_crosscheck.c): one run's state and tally (crosscheck_run.c: tracing the
 * rays through both tracers and classifying each disagreement) and its table (crosscheck_print.c: text or JSON). */
#ifndef RTO_CROSSCHECK_RUN_H
#define RTO_CROSSCHECK_RUN_H

#include "cli.h"
#include "embree_module.h"
#include "trace/crosscheck.h"

/* Rays one run may trace (each costs 64 bytes of ray and two 96-byte records). */
#define XC_MAX_RAYS (UINT64_C(1) << 24)
/* Unexplained rays printed in full. */
#define XC_DETAIL 5
/* Ray kinds given their own row; a file's rays of further kinds share the last. */
#define XC_MAX_ROWS 16

typedef struct row {
    uint32_t kind;
    bool other; /* the row of every kind beyond XC_MAX_ROWS - 1 */
    uint64_t rays, oracle_hits, count[XC_CLASS_COUNT];
    double max_rel_dt;
} row;

typedef struct detail {
    char set[24];
    size_t index;
    rto_wf_ray ray;
    rto_hit_record oracle, embree;
    xc_result res;
} detail;

typedef struct run {
    const emb_module *E; /* Embree, loaded on demand (embree_module.h) */
    const rto_scene *scene;
    const rto_accel *accel;
    emb_device *dev;
    emb_scene *mirror, *robust; /* robust: only for --embree default, made on the first disagreement */
    cf_scene model;             /* the conformance model's view of the scene (DESIGN.md §9) */
    bool robust_mode, culling;
    uint32_t threads;
    row rows[XC_MAX_ROWS];
    size_t nrows;
    detail details[XC_DETAIL];
    size_t ndetails;
    uint64_t unexplained;
} run;

/** The ray kind's name ("primary", or "kind 9"). Returns buf. */
const char *xc_kind_name(uint32_t kind, char *buf, size_t cap);
/** --rays: the generated sets in the order given (duplicates dropped), or false for a bad name. */
bool xc_parse_sets(const char *text, rto_ray_set *sets, size_t *n);
/** Traces and compares a WfRay file's rays; an exit status. */
int xc_run_file(run *r, const char *path, rto_msg *msg);
/** Generates, traces and compares each set; an exit status. */
int xc_run_sets(run *r, const rto_ray_set *sets, size_t nsets, uint32_t seed, uint32_t width, uint32_t height,
                uint32_t count, rto_msg *msg);
/** The table as text on stdout. */
void xc_print_text(const run *r, const char *scene_name, const char *mode);
/** The table as JSON on stdout; an exit status. */
int xc_print_json(const run *r, const char *scene_name, const char *mode);

#endif
