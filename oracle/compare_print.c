/* rtoracle compare's report: the mean, RMS and largest error with both pixels' values, the PSNR, the pixels over
 * the thresholds and the verdict, as idiff 2.4.7 words them, or the same as one JSON object (compare_print.h). */
#include "compare_print.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

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


int compare_print_json(const compare_run *c)
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

int compare_print_text(const compare_run *c)
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

