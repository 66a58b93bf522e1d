/* One option parser for every rtoracle command: each command describes its options in a table (long name, short
 * name, kind, limits, target, help line), and opts_parse reads argv against it, checks every value and writes the
 * targets, so a limit such as --radix-bits is stated once and every command reports a bad value the same way:
 *
 *   rtoracle sort: --radix-bits 5: expected 4 or 8
 *   rtoracle build: unknown option '--frob' (rtoracle build --help)
 *
 * Syntax: --name VALUE, --name=VALUE, -o VALUE, -oVALUE; options and positional arguments may be interleaved;
 * "--" ends the options. Long names must be spelled out (no prefixes). A repeated option keeps its last value. */
#ifndef RTO_OPTS_H
#define RTO_OPTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

typedef enum opt_kind {
    OPT_KIND_FLAG, /* no value; sets a bool */
    OPT_KIND_UINT, /* unsigned integer: decimal, or hexadecimal with 0x; within [min, max], or one of names' values */
    OPT_KIND_ENUM, /* one of a table of names; the target gets the name's value */
    OPT_KIND_PATH, /* a non-empty string (a file or directory); the target is a const char * */
    OPT_KIND_LIST, /* comma-separated non-empty items, optionally from a table of names; duplicates dropped */
    OPT_KIND_REAL, /* a finite decimal number >= 0 (0.004, 1e-6), at most max when max > 0; the target is a double */
} opt_kind;

/** A name and its value for OPT_ENUM and OPT_LIST; tables end with {NULL, 0}. */
typedef struct opt_name {
    const char *name;
    int value;
} opt_name;

/* The most items an OPT_LIST holds, and the longest list text it accepts. */
#define OPT_LIST_MAX 256
#define OPT_LIST_CHARS 4096

/** Target of an OPT_LIST: the distinct items in the order first given (values set when the list has names). */
typedef struct opt_list {
    size_t count;
    const char *item[OPT_LIST_MAX];
    int value[OPT_LIST_MAX];
    char buf[OPT_LIST_CHARS];
} opt_list;

/** One option; tables are written with the OPT_* macros below and end with OPT_END. */
typedef struct opt_spec {
    const char *name; /* long name without "--"; NULL ends a table */
    char short_name;  /* e.g. 'o' for -o; 0 for none */
    opt_kind kind;
    void *target;
    size_t target_size;
    uint64_t min, max;      /* OPT_UINT */
    const opt_name *names;  /* ENUM; LIST (NULL: any items); UINT (NULL: any in [min, max], else these values) */
    const char *metavar;    /* the value's name in --help */
    const char *help;       /* one line; the accepted values and the default are appended */
    const char *def;        /* default as shown in --help, or NULL */
} opt_spec;

/* Table entries. ptr is the target: bool * (FLAG), an unsigned integer or enum (UINT, CHOICE, ENUM), const char **
 * (PATH, STRING), opt_list * (LIST), double * (REAL: hi 0 for no upper bound). CHOICE is a number that must be one of the table's values (--radix-bits).
 * text is the help line; dflt the default as --help shows it (NULL for none). */
#define OPT_FLAG(lname, ptr, text) {lname, 0, OPT_KIND_FLAG, (ptr), sizeof *(ptr), 0, 0, NULL, NULL, text, NULL}
#define OPT_UINT(lname, ptr, lo, hi, meta, text, dflt)                                                             \
    {lname, 0, OPT_KIND_UINT, (ptr), sizeof *(ptr), (lo), (hi), NULL, meta, text, dflt}
#define OPT_CHOICE(lname, ptr, table, meta, text, dflt)                                                            \
    {lname, 0, OPT_KIND_UINT, (ptr), sizeof *(ptr), 0, 0, table, meta, text, dflt}
#define OPT_ENUM(lname, ptr, table, meta, text, dflt)                                                              \
    {lname, 0, OPT_KIND_ENUM, (ptr), sizeof *(ptr), 0, 0, table, meta, text, dflt}
#define OPT_PATH(lname, sname, ptr, meta, text)                                                                    \
    {lname, sname, OPT_KIND_PATH, (ptr), sizeof *(ptr), 0, 0, NULL, meta, text, NULL}
#define OPT_STRING(lname, ptr, meta, text) OPT_PATH(lname, 0, ptr, meta, text)
#define OPT_LIST(lname, ptr, table, text, dflt)                                                                    \
    {lname, 0, OPT_KIND_LIST, (ptr), sizeof *(ptr), 0, 0, table, "LIST", text, dflt}
#define OPT_REAL(lname, ptr, hi, meta, text, dflt)                                                                 \
    {lname, 0, OPT_KIND_REAL, (ptr), sizeof *(ptr), 0, (hi), NULL, meta, text, dflt}
#define OPT_END {NULL, 0, OPT_KIND_FLAG, NULL, 0, 0, 0, NULL, NULL, NULL, NULL}

/** A command: its name in messages, its usage and descriptive help, its option table and positional arguments. */
typedef struct opt_command {
    const char *name;    /* "sort": messages read "rtoracle sort: ..." */
    const char *usage;   /* usage lines and descriptive paragraphs, printed before the options */
    const char *epilog;  /* printed after the options (fault classes, exit status), or NULL */
    const opt_spec *opts;
    size_t min_args, max_args; /* positional arguments */
    const char *args_name;     /* the positional arguments as named in messages ("one input keys.npy") */
} opt_command;

#define OPT_MAX_ARGS 4
#define OPT_MAX_SPECS 32

/** What opts_parse found besides the targets: positional arguments and which options were given. */
typedef struct opt_args {
    size_t count;
    const char *arg[OPT_MAX_ARGS];
    bool given[OPT_MAX_SPECS]; /* by index in the table */
} opt_args;

/** Parses argv[1..argc-1] (argv[0] is the command's name). Returns -1 to go on, or the exit status to return now:
 * 0 after printing --help to stdout, 2 after one line on stderr for an unknown option, a missing or bad value, or a
 * wrong number of positional arguments. */
int opts_parse(const opt_command *c, int argc, char **argv, opt_args *out);

/** Whether option NAME (long name) was given. */
bool opts_given(const opt_command *c, const opt_args *a, const char *name);

/** Returns 0 when every named option was given, else prints "rtoracle CMD: --NAME is required (...)" and returns 2.
 * names is a NULL-terminated list of long names. */
int opts_require(const opt_command *c, const opt_args *a, const char *const *names);

/** Prints the command's help: usage, the option table, the epilog. */
void opts_help(const opt_command *c, FILE *to);

/** Strict unsigned number: decimal digits (leading zeros are decimal: "010" is 10), or 0x / 0X and hexadecimal
 * digits; no sign, space, exponent or suffix; false on overflow or a value above max. */
bool opts_parse_uint(const char *text, uint64_t max, uint64_t *out);

/** Strict non-negative real: decimal digits with an optional fraction and exponent ("0.004", "1e-6", ".5"); no sign,
 * space, "inf", "nan" or hexadecimal; false when it does not round to a finite double. */
bool opts_parse_real(const char *text, double *out);

/**
 * The request text of a parsed command line, for up-to-date checks (rto_bundle_check): the command's name, its
 * positional arguments and the value of every option in table order (given or default), except those named in skip
 * (a NULL-terminated list: the output path, thread counts, --force). The same command line, however spelled
 * (--n=8 or --n 0x8, options in any order), gives the same text. malloc'ed; NULL when out of memory.
 */
char *opts_request(const opt_command *c, const opt_args *a, const char *const *skip);

#endif
