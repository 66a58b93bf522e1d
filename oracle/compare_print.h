/* rtoracle compare's report (oracle/cmd_compare.c): the comparison printed as idiff's text or as one JSON object. */
#ifndef RTO_COMPARE_PRINT_H
#define RTO_COMPARE_PRINT_H

#include "cli.h"

/** One comparison, for its report. */
typedef struct compare_run {
    const char *expected_path, *actual_path;
    const rto_image *expected, *actual;
    const rto_image_compare_desc *desc;
    const rto_image_compare_result *r;
} compare_run;

/** Prints the report as text / as JSON on stdout; EXIT_PASS, or EXIT_BAD_INPUT after one line when stdout fails. */
int compare_print_text(const compare_run *c);
int compare_print_json(const compare_run *c);

#endif
