/* rtoracle compare: two images (PNG, OpenEXR) compared with OpenImageIO's ImageBufAlgo::compare, with idiff's
 * thresholds, report and exit statuses, so that it replaces idiff in a script unchanged but for the option names. */
#include "cli.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
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

static const char *type_name(rto_pixel_type t) { return t == RTO_PIXEL_U8 ? "8-bit" : "float"; }

static const char *channel_name(uint32_t channels, uint32_t c)
{
    static const char *const names[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    return channels >= 1 && channels <= 4 && c < channels ? names[channels - 1][c] : "?";
}

static const char *verdict_word(rto_image_verdict v)
{
    return v == RTO_IMAGE_PASS ? "PASS" : v == RTO_IMAGE_WARN ? "WARNING" : "FAILURE";
}

static double percent_of(uint64_t count, uint64_t pixels) { return pixels ? 100.0 * (double)count / (double)pixels : 0; }

/* JSON has no infinities or NaN: those are the strings "inf", "-inf", "nan", as in manifests (DESIGN.md §8). */
static json_t *jreal(double v)
{
    if (isnan(v))
        return json_string("nan");
    if (isinf(v))
        return json_string(v > 0 ? "inf" : "-inf");
    return json_real(v);
}

typedef struct compare_run {
    const char *expected_path, *actual_path;
    const rto_image *expected, *actual;
    const rto_image_compare_desc *desc;
    const rto_image_compare_result *r;
} compare_run;

static int print_json(const compare_run *c)
{
    const rto_image_compare_result *r = c->r;
    const rto_image_compare_desc *d = c->desc;
    json_t *root = json_object(), *at = json_object(), *th = json_object();
    int bad = !root || !at || !th;
    bad |= json_object_set_new(root, "command", json_string("compare"));
    bad |= json_object_set_new(root, "expected", cli_json_text(c->expected_path));
    bad |= json_object_set_new(root, "actual", cli_json_text(c->actual_path));
    bad |= json_object_set_new(root, "width", json_integer(c->expected->width));
    bad |= json_object_set_new(root, "height", json_integer(c->expected->height));
    bad |= json_object_set_new(root, "channels", json_integer(c->expected->channels));
    bad |= json_object_set_new(root, "expected_type", json_string(c->expected->type == RTO_PIXEL_U8 ? "u8" : "f32"));
    bad |= json_object_set_new(root, "actual_type", json_string(c->actual->type == RTO_PIXEL_U8 ? "u8" : "f32"));
    bad |= json_object_set_new(root, "mean_error", jreal(r->mean_error));
    bad |= json_object_set_new(root, "rms_error", jreal(r->rms_error));
    bad |= json_object_set_new(root, "psnr", jreal(r->psnr));
    bad |= json_object_set_new(root, "max_error", jreal(r->max_error));
    bad |= json_object_set_new(at, "x", json_integer(r->max_x));
    bad |= json_object_set_new(at, "y", json_integer(r->max_y));
    bad |= json_object_set_new(at, "channel", json_integer(r->max_c));
    bad |= json_object_set_new(at, "channel_name", json_string(channel_name(c->expected->channels, r->max_c)));
    bad |= json_object_set_new(root, "max_error_at", at);
    bad |= json_object_set_new(root, "pixels", json_integer((json_int_t)r->pixels));
    bad |= json_object_set_new(root, "fail_count", json_integer((json_int_t)r->fail_count));
    bad |= json_object_set_new(root, "warn_count", json_integer((json_int_t)r->warn_count));
    bad |= json_object_set_new(th, "fail", jreal(d->fail));
    bad |= json_object_set_new(th, "fail_percent", jreal(d->fail_percent));
    bad |= json_object_set_new(th, "hard_fail", d->hard_fail_set ? jreal(d->hard_fail) : json_null());
    bad |= json_object_set_new(th, "warn", jreal(d->warn));
    bad |= json_object_set_new(th, "warn_percent", jreal(d->warn_percent));
    bad |= json_object_set_new(th, "hard_warn", d->hard_warn_set ? jreal(d->hard_warn) : json_null());
    bad |= json_object_set_new(root, "thresholds", th);
    bad |= json_object_set_new(root, "diff", d->diff_path ? cli_json_text(d->diff_path) : json_null());
    bad |= json_object_set_new(root, "diff_scale", jreal(d->diff_scale));
    bad |= json_object_set_new(root, "verdict",
                               json_string(r->verdict == RTO_IMAGE_PASS   ? "pass"
                                           : r->verdict == RTO_IMAGE_WARN ? "warn"
                                                                          : "fail"));
    bad |= json_object_set_new(root, "exit_status", json_integer((json_int_t)r->verdict));
    char *text = bad ? NULL : json_dumps(root, JSON_INDENT(2));
    json_decref(root);
    if (!text)
        return cli_fail("compare", "out of memory");
    int rc = EXIT_PASS;
    errno = 0;
    if (puts(text) < 0 || fflush(stdout) != 0)
        rc = cli_fail("compare", "cannot write to stdout: %s", strerror(errno ? errno : EIO));
    free(text);
    return rc;
}

/* A pixel's channels in [0, 1] units, as idiff prints them ("none" outside the image). */
static void pixel_values(const rto_image *im, uint32_t x, uint32_t y)
{
    if (x >= im->width || y >= im->height) {
        printf("none");
        return;
    }
    const size_t at = ((size_t)y * im->width + x) * im->channels;
    for (uint32_t c = 0; c < im->channels; c++) {
        const double v = im->type == RTO_PIXEL_U8 ? ((const uint8_t *)im->pixels)[at + c] / 255.0
                                                  : (double)((const float *)im->pixels)[at + c];
        printf("%s%.7g", c ? ", " : "", v);
    }
}

static int print_text(const compare_run *c)
{
    const rto_image_compare_result *r = c->r;
    const rto_image_compare_desc *d = c->desc;
    const rto_image *e = c->expected;
    printf("compare %s (%s) with %s (%s): %ux%u, %u channel%s\n", c->expected_path, type_name(e->type),
           c->actual_path, type_name(c->actual->type), e->width, e->height, e->channels, e->channels == 1 ? "" : "s");
    printf("  mean error  %.6g\n", r->mean_error);
    printf("  RMS error   %.6g\n", r->rms_error);
    printf("  PSNR        %.6g dB\n", r->psnr);
    printf("  max error   %.6g", r->max_error);
    if (r->max_error != 0) {
        const uint32_t nc = e->channels > c->actual->channels ? e->channels : c->actual->channels;
        printf(" at pixel (%u, %u), channel %u (%s); values are ", r->max_x, r->max_y, r->max_c,
               channel_name(nc, r->max_c));
        pixel_values(c->expected, r->max_x, r->max_y);
        printf(" vs ");
        pixel_values(c->actual, r->max_x, r->max_y);
    }
    printf("\n");
    printf("  %llu pixels (%.3g %%) over the fail threshold %g\n", (unsigned long long)r->fail_count,
           percent_of(r->fail_count, r->pixels), d->fail);
    printf("  %llu pixels (%.3g %%) over the warn threshold %g\n", (unsigned long long)r->warn_count,
           percent_of(r->warn_count, r->pixels), d->warn);
    if (d->diff_path)
        printf("  diff image  %s (|expected - actual| x %g)\n", d->diff_path, d->diff_scale);
    printf("%s\n", verdict_word(r->verdict));
    errno = 0;
    if (fflush(stdout) != 0 || ferror(stdout))
        return cli_fail("compare", "cannot write to stdout: %s", strerror(errno ? errno : EIO));
    return EXIT_PASS;
}

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
        rc = json ? print_json(&run) : print_text(&run);
        rc = rc == EXIT_PASS ? (int)r.verdict /* 0 PASS, 1 WARNING, 2 FAILURE, as idiff */ : could_not_compare(rc);
    }
    rto_image_free(&expected);
    rto_image_free(&actual);
    return rc;
}
