/* rtoracle compare: two images (PNG, OpenEXR) compared with OpenImageIO's ImageBufAlgo::compare, with idiff's
 * thresholds, report and exit statuses, so that it replaces idiff in a script unchanged but for the option names. */
#include "compare_print.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static const char compare_usage[] =
    "usage: rtoracle compare EXPECTED ACTUAL [--diff diff.png] [--diff-scale S] [--fail T] [--fail-percent P]\n"
    "                        [--hard-fail T] [--warn T] [--warn-percent P] [--hard-warn T] [--json]\n\n"
    "Compares two images (PNG, OpenEXR, or any format OpenImageIO reads) as Debian's idiff 2.4.7 does, with\n"
    "OpenImageIO's ImageBufAlgo::compare, in [0, 1] units (8-bit values are divided by 255, so an 8-bit image\n"
    "and a float one compare directly), and prints the mean, RMS and largest error (with its pixel, channel and\n"
    "both pixels' values), the PSNR (OpenImageIO's: 20 log10(peak / RMS), peak 1 unless a value is larger; inf\n"
    "for identical images), the pixels over the fail and warn thresholds and the verdict. Images of different\n"
    "sizes or channel counts are compared over the union of the two, a pixel or channel one lacks reading as 0\n"
    "(percentages are of EXPECTED's pixels), as idiff does: they fail unless the extra values are 0.\n"
    "A pixel fails when any of its channels differs by more than --fail. The comparison FAILS when more than\n"
    "--fail-percent % of the pixels fail or a channel differs by more than --hard-fail; otherwise it WARNS when\n"
    "some pixel failed and more than --warn-percent % of the pixels differ by more than --warn or a channel by\n"
    "more than --hard-warn; otherwise it PASSES. That is idiff 2.4.7's behaviour and defaults (its\n"
    "documentation leaves out \"some pixel failed\": differences under --fail everywhere pass).\n"
    "--diff writes |EXPECTED - ACTUAL| x --diff-scale per channel (an alpha channel is written opaque) as an\n"
    "8-bit PNG or a float OpenEXR, chosen by the file's extension, atomically.\n";

static const char compare_epilog[] =
    "idiff equivalents: -fail, -failpercent, -hardfail, -warn, -warnpercent, -hardwarn, -o, -scale (with -abs:\n"
    "the diff image is always absolute).\n"
    "Exit status, as idiff's: 0 PASS, 1 WARNING, 2 FAILURE, 4 the images could not be compared (a missing,\n"
    "corrupt or truncated file, a FIFO, a directory, an image over the memory budget, a bad option), after one\n"
    "line on stderr. compare is the one rtoracle command whose bad input exits 4 and not 2: 2 is FAILURE. idiff\n"
    "2.4.7 never exits 3 (its code for different sizes): it compares them as above, and so does compare.\n"
    "Where compare and idiff 2.4.7 differ: idiff reads a PNG with alpha as premultiplied (OpenImageIO's\n"
    "default), compare reads the stored values (the same wherever alpha is 1, as in every image rtoracle\n"
    "writes); idiff compares what libpng left of a truncated PNG, compare refuses the file (4).\n"
    "tests/cli_compare.sh checks the exit statuses against idiff's where openimageio-tools is installed.\n";

/* Exit status 4 for everything that is not a verdict (idiff's code for a file it cannot read): compare's 2 is
 * FAILURE. */
#define EXIT_COULD_NOT_COMPARE 4
static int could_not_compare(int rc) { return rc == EXIT_PASS ? rc : EXIT_COULD_NOT_COMPARE; }

int cmd_compare(int argc, char **argv)
{
    rto_image_compare_desc desc = {0};
    desc.fail = desc.warn = 1e-6;
    desc.diff_scale = 1;
    bool json = false;
    const char *diff = NULL;
    uint32_t budget_mib = (uint32_t)(RTO_IMAGE_BUDGET_DEFAULT >> 20);
    const opt_spec opts[] = {
        OPT_PATH("diff", 0, &diff, "FILE", "write the difference image here (.png: 8-bit, .exr: float)"),
        OPT_REAL("diff-scale", &desc.diff_scale, 0, "S", "multiply the difference image by S", "1"),
        OPT_REAL("fail", &desc.fail, 0, "T", "a pixel fails when a channel differs by more than T (0 means 1e-6)",
                 "1e-6"),
        OPT_REAL("fail-percent", &desc.fail_percent, 100, "P", "FAIL when more than P % of the pixels fail", "0"),
        OPT_REAL("hard-fail", &desc.hard_fail, 0, "T", "FAIL when any channel differs by more than T", "infinite"),
        OPT_REAL("warn", &desc.warn, 0, "T", "a pixel warns when a channel differs by more than T (0 means 1e-6)",
                 "1e-6"),
        OPT_REAL("warn-percent", &desc.warn_percent, 100, "P", "WARN when more than P % of the pixels warn", "0"),
        OPT_REAL("hard-warn", &desc.hard_warn, 0, "T", "WARN when any channel differs by more than T", "infinite"),
        OPT_FLAG("json", &json, "one JSON object on stdout instead of text"),
        OPT_UINT("memory-budget", &budget_mib, 1, 1u << 20, "MIB",
                 "refuse an image whose decoded pixels would take more than MIB MiB (read from its header)", "256"),
        OPT_END,
    };
    const opt_command cmd = {"compare", compare_usage, compare_epilog, opts, 2, 2, "two images, EXPECTED and ACTUAL"};
    opt_args args;
    int rc = opts_parse(&cmd, argc, argv, &args);
    if (rc >= 0)
        return could_not_compare(rc); /* --help: 0; a bad option: 4 */
    desc.hard_fail_set = opts_given(&cmd, &args, "hard-fail");
    desc.hard_warn_set = opts_given(&cmd, &args, "hard-warn");
    desc.diff_path = diff;
    if (desc.diff_scale == 0)
        desc.diff_scale = 1;
    if (desc.fail == 0)
        desc.fail = 1e-6;
    if (desc.warn == 0)
        desc.warn = 1e-6;

    rto_msg msg = {{0}};
    if (diff && rto_output_check(diff, 0, (const char *const[]){args.arg[0], args.arg[1]}, 2, &msg))
        return could_not_compare(cli_status("compare", RTO_ERR_INVALID_ARGUMENT, &msg));
    rto_image expected = {0}, actual = {0};
    const size_t budget = (size_t)budget_mib << 20;
    rto_status s = rto_image_read_budget(args.arg[0], budget, &expected, &msg);
    if (!s)
        s = rto_image_read_budget(args.arg[1], budget, &actual, &msg);
    if (s) {
        rto_image_free(&expected);
        return could_not_compare(cli_status("compare", s, &msg));
    }
    const bool same_geometry = expected.width == actual.width && expected.height == actual.height &&
                               expected.channels == actual.channels;
    if (!same_geometry)
        fprintf(stderr, "rtoracle compare: the images differ in size (%ux%u with %u channel%s, %ux%u with %u "
                "channel%s): compared over both, a missing value reading as 0, as idiff does%s\n", expected.width,
                expected.height, expected.channels, expected.channels == 1 ? "" : "s", actual.width, actual.height,
                actual.channels, actual.channels == 1 ? "" : "s", diff ? "; no diff image" : "");
    rto_image_compare_result r;
    s = rto_image_compare(&expected, &actual, &desc, &r, &msg);
    if (s) {
        rc = could_not_compare(cli_status("compare", s, &msg));
    } else {
        rto_image_compare_desc shown = desc;
        if (!same_geometry)
            shown.diff_path = NULL;
        const compare_run run = {args.arg[0], args.arg[1], &expected, &actual, &shown, &r};
        rc = json ? compare_print_json(&run) : compare_print_text(&run);
        rc = rc == EXIT_PASS ? (int)r.verdict /* 0 PASS, 1 WARNING, 2 FAILURE, as idiff */ : could_not_compare(rc);
    }
    rto_image_free(&expected);
    rto_image_free(&actual);
    return rc;
}
