/* Shared plumbing of the rtoracle command: exit codes, argument parsing, key files. */
#ifndef RTO_CLI_H
#define RTO_CLI_H

#include "internal.h"

#include <jansson.h>
#include <stdbool.h>
#include <stdio.h>

/* Exit statuses of every command. */
enum { EXIT_PASS = 0, EXIT_MISMATCH = 1, EXIT_BAD_INPUT = 2 };

/** Prints "rtoracle CMD: message" to stderr and returns EXIT_BAD_INPUT. */
int cli_fail(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/** Maps a library status to an exit status, printing msg for failures. */
int cli_status(const char *cmd, rto_status s, const rto_msg *msg);

/** Writes a failure report next to the GPU dump as <gpu>.<command>.json, through a temporary file. */
void cli_write_report(const char *gpu_path, const char *command, const json_t *report);
/** Strict unsigned parse (decimal or 0x hex) with an upper bound; false on junk, sign or overflow. */
bool cli_parse_u64(const char *text, uint64_t max, uint64_t *out);
bool cli_parse_format(const char *text, rto_key_format *f);
bool cli_parse_algo(const char *text, rto_sort_algo *a);

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
} key_origin;

/** Sorts keys with p and writes a sort bundle to outdir (atomically). */
rto_status sort_bundle_write(const char *outdir, rto_key_format f, const void *keys, size_t n, const sort_params *p,
                             const key_origin *origin, rto_msg *msg);

int cmd_keys(int argc, char **argv);
int cmd_sort(int argc, char **argv);
int cmd_check_sort(int argc, char **argv);
int cmd_suite(int argc, char **argv);
int cmd_build(int argc, char **argv);
int cmd_check_bvh(int argc, char **argv);
int cmd_info(int argc, char **argv);

#endif
