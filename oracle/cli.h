/* Shared plumbing of the rtoracle command: exit codes, messages, option tables, key files. The command is a user of
 * the library like any other: it sees only the public header. */
#ifndef RTO_CLI_H
#define RTO_CLI_H

#include "opts.h"
#include "rtoracle.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

/* Exit statuses of every command. */
enum { EXIT_PASS = 0, EXIT_MISMATCH = 1, EXIT_BAD_INPUT = 2 };

/** Prints "rtoracle CMD: message" to stderr and returns EXIT_BAD_INPUT. */
int cli_fail(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/** malloc of count * size bytes with an overflow check; count 0 gives a 1-byte block so NULL always means failure. */
void *cli_alloc(size_t count, size_t size);
/** Maps a library status to an exit status, printing msg for failures. */
int cli_status(const char *cmd, rto_status s, const rto_msg *msg);

/** Writes a failure report's JSON text next to the GPU dump as <gpu>.<command>.json, atomically (rto_file_write).
 * Returns EXIT_PASS, or EXIT_BAD_INPUT after one line on stderr (text NULL, out of memory, a path that is not a
 * file). */
int cli_write_report(const char *gpu_path, const char *command, const char *text);
/** Writes a failure report's JSON text to path, atomically (rto_file_write), and says so on stderr. Returns
 * EXIT_PASS, or EXIT_BAD_INPUT after one line on stderr. */
int cli_write_report_at(const char *path, const char *command, const char *text);
/**
 * Prints a validator's report to stdout (text, or JSON with json) and, when it records a fault and artifacts is
 * set, writes its JSON next to the GPU dump (cli_write_report). Returns EXIT_PASS or EXIT_MISMATCH, or
 * EXIT_BAD_INPUT after one line on stderr when the report could not be written out.
 */
int cli_report(const char *cmd, const rto_report *r, bool json, bool artifacts, const char *gpu_path);
/** cli_report with the failure report's JSON written to report_path (NULL: nowhere), for validators whose GPU dump
 * is a directory (check-frame writes DIR/check-frame.json). */
int cli_report_at(const char *cmd, const rto_report *r, bool json, const char *report_path);
/** A JSON string of text that may not be UTF-8 (a path): repaired first (rto_utf8_repair), as jansson requires.
 * NULL when out of memory. */
struct json_t *cli_json_text(const char *text);
/**
 * Whether the bundle at out is already what this request would write (rto_bundle_check): then prints one line,
 * "CMD: OUT is up to date (...); not rewritten", and returns 1, and the command does nothing more. A bundle whose files
 * were modified or removed after it was written gets a note on stderr naming the file, and 0: it is written again.
 * force (--force) or a NULL request (out of memory): 0.
 */
int cli_up_to_date(const char *cmd, const char *out, const char *request, bool force);
/** What a bundle directory holds, as "N files, X MiB" (its plain files, not descending), for the line a command
 * prints after writing one. */
const char *cli_dir_summary(const char *dir, char *buf, size_t cap);
/** Records request for the bundle's stamp (rto_bundle_set_request), with the scene's source files (sc may be NULL)
 * and one more input file (extra: a plugin, a ray file; NULL for none). A NULL request does nothing. */
rto_status cli_set_request(rto_bundle *b, const char *request, const rto_scene *sc, const char *extra, rto_msg *msg);
/** Removes the temporaries of unfinished outputs on SIGINT / SIGTERM / SIGHUP, then exits by that signal. */
void cli_cleanup_on_signals(void);
/* Scenes on the command line (scene_cli.c). */

/** Parses exactly n comma-separated finite numbers (|v| <= 3e38). */
bool cli_parse_floats(const char *text, float *out, size_t n);
/** A camera given as 10 numbers EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY (degrees), named "command line"; false if spec is
 * not that. */
bool cli_camera_numbers(const char *spec, rto_camera *cam);
/** The camera --camera names (scene, auto, an index, or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOVY; NULL = scene) into *cam,
 * the automatic framing resolved for an image of the given aspect. false after one line on a bad value. */
bool cli_pick_camera(const char *cmd, const char *spec, const rto_scene *sc, float aspect, rto_camera *cam);
/** A scene loaded for tracing (trace, render): the scene, its trees (self-checked) and the camera --camera names. */
typedef struct cli_traced_scene {
    rto_scene *scene;
    rto_accel *accel;
    rto_camera camera;
} cli_traced_scene;
/** Loads spec within the texture budget (MiB), prints its warnings, picks the camera for an image of width x height
 * (warning when a scene camera's aspect stretches the image), builds the trees (--tlas karras when karras) and checks
 * them. EXIT_PASS, or EXIT_BAD_INPUT after one line (nothing then to free). */
int cli_load_traced_scene(const char *cmd, const char *spec, uint64_t texture_budget_mb, const char *camera_arg,
                          uint32_t width, uint32_t height, unsigned karras, uint32_t threads, cli_traced_scene *out);
void cli_traced_scene_free(cli_traced_scene *t);
/** The camera of the stage2 scene: its default, or --camera's 10 numbers. EXIT_PASS, or EXIT_BAD_INPUT after one
 * line. */
int cli_stage2_camera(const char *cmd, const char *camera_arg, rto_camera *cam);

/* Frames on the command line (frame_cli.c): programs, the memory plan, progress, the bundle, the summary. */
/** --param NAME=V[,V..][:NAME=V..] into values (at most RTO_PROGRAM_PARAMS_MAX); false after one line. */
bool cli_parse_params(const char *text, rto_param_value *out, uint32_t *n);
/** Prints each built-in program with its parameters (render --program list). */
void cli_list_programs(void);
/** The program --program names: a built-in one, or with is_plugin the plugin loaded into *plugin (unload it with
 * rto_plugin_unload). NULL after one line. */
const rto_program *cli_pick_program(const char *name, bool is_plugin, rto_plugin **plugin);
/** A progress bar on stderr, only on a terminal, redrawn at most every 0.1 s: the state cli_progress takes. */
typedef struct cli_progress_bar {
    bool on;
    double last;
    int drawn;
} cli_progress_bar;
/** A frame's progress callback (arg: a cli_progress_bar). */
void cli_progress(void *arg, double fraction);
/** Monotonic seconds. */
double cli_now(void);
/** Whether the frame fd describes (program, size, depth, keep) fits the memory budget (MiB; 0: the default), by
 * rto_frame_memory_bound, before any work; false after one line naming the frame and --stages. */
bool cli_frame_within_budget(const rto_frame_desc *fd, uint64_t memory_mb, const char *stages);
/** render's line after a bundle is written: rays traced, hits, emitted, dropped, conflicts, seconds, the bundle. */
void cli_frame_summary(const char *spec, const rto_frame *frame, double seconds, const char *out);
/** Writes a frame's bundle to out (atomically): with ts (a mesh scene) the build and geometry files first, then the
 * frame's (rto_frame_bundle_write, with the wall times when timings), frame.scene_kind, and the up-to-date record of
 * request with the scene's and the plugin's files as sources. */
rto_status cli_frame_bundle(const char *out, const char *request, const cli_traced_scene *ts, const char *plugin,
                            const rto_frame *frame, bool timings, rto_msg *msg);

/* Names of the key formats and sort algorithms, for option tables and manifests. */
extern const opt_name cli_format_names[];
extern const opt_name cli_algo_names[];
bool cli_parse_format(const char *text, rto_key_format *f);
bool cli_parse_algo(const char *text, rto_sort_algo *a);

/* Limits shared by the commands' option tables. */
#define CLI_SEED_MAX UINT32_MAX
#define CLI_TILE_MAX (UINT32_C(1) << 24)
/* --texture-budget MB (info, build): up to 1 TiB of decoded textures. */
#define CLI_TEXTURE_BUDGET_MAX_MB (UINT64_C(1) << 20)
/* --memory-budget MiB (render, keys): up to 1 PiB; 0 is the default (rto_memory_budget_default). */
#define CLI_MEMORY_BUDGET_MAX_MB (UINT64_C(1) << 30)
#define CLI_MEMORY_BUDGET_HELP "memory (MiB) the command may hold; 0: half the memory this process may use"
/** Whether `need` bytes (what `what` may hold at once) fit the memory budget of budget_mb MiB (0: the default);
 * refuses with the two figures, in one line, when not. */
bool cli_within_budget(const char *cmd, uint64_t need, uint64_t budget_mb, const char *what);
/* --radix-bits: the digit widths the radix reference implements. */
extern const opt_name cli_radix_bits_names[];

/** Options shared by the sort-producing commands. */
typedef struct sort_params {
    rto_sort_algo algo;
    uint32_t radix_bits;
    uint32_t tile;
    bool checkpoints; /* bitonic passes and radix intermediates */
} sort_params;

/** Manifest description of where the keys came from. */
typedef struct key_origin {
    const char *case_id; /* "sort:bitonic:fmt=u32:dist=uniform:n=4097" or NULL */
    const char *dist;    /* NULL when the keys came from a file */
    uint32_t seed;
    const char *file; /* source path for a file */
    const char *request; /* the up-to-date record's request (rto_bundle_set_request), or NULL for none */
} key_origin;

/* The lists of `suite sort` (suite_lists.c). */
#define CLI_SUITE_SIZES_MAX (4 * RTO_SIZE_CLASS_MAX + OPT_LIST_MAX)
#define CLI_SUITE_DISTS_MAX 256
/** --sizes: size classes and numbers, deduplicated and ascending (all when none given). EXIT_PASS, or EXIT_BAD_INPUT
 * after one line. */
int cli_suite_sizes(const opt_list *sizes_opt, size_t sizes[CLI_SUITE_SIZES_MAX], size_t *count);
/** --dists: distributions in the order first named; a group (all, centroid, raw) adds its members not named before.
 * EXIT_PASS, or EXIT_BAD_INPUT after one line. */
int cli_suite_dists(const opt_list *dists_opt, const rto_dist_info *dists[CLI_SUITE_DISTS_MAX], size_t *count);
/* A GPU's sort dump (sort_dump.c). */
typedef struct cli_sort_dump {
    rto_npy gpu, values, passes;
} cli_sort_dump;
/** Reads --gpu (keys, or {key, value} records split into keys and values), --gpu-values and --gpu-passes (each may
 * be NULL but gpu) and points d's gpu_* fields at them; d->format must be the input's. EXIT_PASS, or EXIT_BAD_INPUT
 * after one line. */
int cli_sort_dump_load(const char *gpu, const char *values, const char *passes, cli_sort_dump *dump,
                       rto_sort_check_desc *d);
void cli_sort_dump_free(cli_sort_dump *dump);
/** Sorts keys with p and writes a sort bundle to outdir (atomically). share: NULL, or the table of shared arrays
 * (rto_bundle_set_share) the bundle links identical arrays of earlier bundles from. */
rto_status sort_bundle_write(const char *outdir, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                             const key_origin *origin, rto_bundle_share *share, rto_msg *msg);

int cmd_keys(int argc, char **argv);
int cmd_sort(int argc, char **argv);
int cmd_check_sort(int argc, char **argv);
int cmd_suite(int argc, char **argv);
int cmd_build(int argc, char **argv);
int cmd_check_bvh(int argc, char **argv);
int cmd_check_hits(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_trace(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_crosscheck(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_check_frame(int argc, char **argv);
int cmd_vbuffer(int argc, char **argv);
int cmd_check_vbuffer(int argc, char **argv);
int cmd_splat(int argc, char **argv);
int cmd_check_volume(int argc, char **argv);
int cmd_raymarch(int argc, char **argv);
int cmd_check_raymarch(int argc, char **argv);

#endif
