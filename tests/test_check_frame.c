/* The frame validator (rto_frame_check): its names, its argument checks, and both sides of the accum tolerance of
 * DESIGN.md §9 (1e-4 |e| + 1e-6 per channel; + 2e-4 for `triangle`), with the boundary values computed here in binary64 from the rule as
 * §9 states it: the largest float within the bound passes, the next one up fails and is reported at its pixel.
 * The frames are rendered in-process (sun-shadow and triangle on rtstress:2) and written as a bundle; the "GPU dump" holds only
 * accum.npy, so everything else is "not dumped". The command-line test (cli.check_frame) covers every stage. */
#define _GNU_SOURCE
#include "testutil.h"

#include "core/tolerance.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void test_names(void **state)
{
    (void)state;
    static const char *const names[] = {"none", "emit-count", "indirect-args", "queue", "payload", "hits", "accum",
                                        "image"};
    for (int f = RTO_FRAME_OK; f <= RTO_FRAME_IMAGE; f++)
        assert_string_equal(rto_frame_fault_name((rto_frame_fault)f), names[f]);
    assert_string_equal(rto_frame_fault_name((rto_frame_fault)99), "unknown");
    assert_string_equal(rto_frame_artifact_name(RTO_FRAME_ARTIFACT_ACCUM_DIFF), "check-frame.accum_diff.exr");
    assert_string_equal(rto_frame_artifact_name(RTO_FRAME_ARTIFACT_IMAGE_DIFF), "check-frame.image_diff.png");
    assert_string_equal(rto_frame_artifact_name(RTO_FRAME_ARTIFACT_LISTING), "check-frame.diffs.json");
    assert_null(rto_frame_artifact_name(0));
    assert_null(rto_frame_artifact_name(RTO_FRAME_ARTIFACT_ACCUM_DIFF | RTO_FRAME_ARTIFACT_LISTING));
}

static void test_arguments(void **state)
{
    (void)state;
    rto_report r;
    rto_msg msg = {{0}};
    rto_frame_check_desc d;
    memset(&d, 0, sizeof d);
    assert_int_equal(rto_frame_check(NULL, &r, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_frame_check(&d, NULL, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(msg.text, "expected"));
    d.expected_dir = "/nonexistent-bundle";
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.gpu_dir = "/nonexistent-dump";
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_IO);
    d.gpu_dir = "/dev/null"; /* not a directory */
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_IO);
    assert_non_null(strstr(msg.text, "not a directory"));
    d.gpu_dir = "/tmp";
    d.image_fail_percent_set = 1;
    d.image_fail_percent = 100.5;
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.image_fail_percent = NAN;
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_INVALID_ARGUMENT);
    d.image_fail_percent = 0;
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_IO); /* 0 % is allowed: the bundle is missing */
}

/* The accum bound of §9 at expected value e (absolute part abs), and the largest float within it above e. */
static float largest_within(float e, double abs)
{
    const double bound = 1e-4 * fabs((double)e) + abs;
    float a = (float)((double)e + bound);
    while ((double)a - (double)e > bound)
        a = nextafterf(a, -INFINITY);
    while ((double)nextafterf(a, INFINITY) - (double)e <= bound)
        a = nextafterf(a, INFINITY);
    return a;
}

/* Both sides of the accum bound of a frame of program, whose absolute part is abs: 1e-6, or for `triangle` (whose
 * colours are barycentrics; red is (1 - u) - v) twice the barycentric rule's 1e-4. */
static void accum_boundary(const char *program, double abs)
{
    char root[64];
    assert_int_equal(tu_tmpdir_make(root, sizeof root, "check_frame"), 0);
    char bundle[4200], gpu[4200], path[4300];
    snprintf(bundle, sizeof bundle, "%s/e", root);
    snprintf(gpu, sizeof gpu, "%s/g", root);
    assert_int_equal(mkdir(gpu, 0777), 0);

    rto_msg msg = {{0}};
    rto_scene *scene = tu_load("rtstress:2");
    rto_accel *accel = NULL;
    assert_int_equal(rto_accel_build(scene, NULL, &accel, &msg), RTO_OK);
    rto_frame_desc fd;
    memset(&fd, 0, sizeof fd);
    fd.program = rto_program_builtin(program);
    fd.accel = accel;
    fd.width = 16;
    fd.height = 12;
    fd.keep = RTO_FRAME_KEEP_ALL;
    fd.threads = 1;
    rto_frame *frame = NULL;
    assert_int_equal(rto_frame_render(&fd, &frame, &msg), RTO_OK);
    rto_bundle *b = NULL;
    assert_int_equal(rto_bundle_begin(bundle, "frame", &b, &msg), RTO_OK);
    assert_int_equal(rto_bvh_bundle_write(accel, b, &msg), RTO_OK);
    assert_int_equal(rto_frame_bundle_write(frame, 0, b, &msg), RTO_OK);
    assert_int_equal(rto_bundle_set_str(b, "frame", "scene_kind", "mesh"), RTO_OK);
    assert_int_equal(rto_bundle_commit(b, &msg), RTO_OK);

    /* the "GPU" accum: the oracle's, with pixel p's green channel moved to the edge of the bound and past it */
    const uint32_t p = 7 * 16 + 9;
    const size_t n = 4 * (size_t)16 * 12;
    float *accum = malloc(n * sizeof *accum);
    assert_non_null(accum);
    memcpy(accum, frame->accum, n * sizeof *accum);
    assert_int_equal(frame->not_comparable[p], 0);
    const float e = frame->accum[4 * p + 1];
    const rto_npy_desc ad = rto_npy_desc_array(RTO_DTYPE_F32, 3, 12, 16, 4);
    snprintf(path, sizeof path, "%s/accum.npy", gpu);
    rto_frame_check_desc d;
    memset(&d, 0, sizeof d);
    d.expected_dir = bundle;
    d.gpu_dir = gpu;
    rto_report r;
    uint32_t written = 99;

    accum[4 * p + 1] = largest_within(e, abs);
    assert_true(accum[4 * p + 1] > e);
    assert_int_equal(rto_npy_write(path, &ad, accum, &msg), RTO_OK);
    assert_int_equal(rto_frame_check(&d, &r, &written, &msg), RTO_OK);
    assert_int_equal(written, 0);
    assert_int_equal(rto_report_check_state(&r, "accum"), RTO_CHECK_PASSED);
    assert_int_equal(rto_report_check_state(&r, "queues"), RTO_CHECK_NOT_RUN);
    assert_non_null(strstr(r.summary, "not dumped: emit_counts.npy"));

    accum[4 * p + 1] = nextafterf(largest_within(e, abs), INFINITY);
    assert_int_equal(rto_npy_write(path, &ad, accum, &msg), RTO_OK);
    assert_int_equal(rto_frame_check(&d, &r, &written, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_FRAME_ACCUM);
    assert_string_equal(r.fault, "accum");
    int64_t v = -1;
    assert_true(rto_report_where(&r, "pixel", &v) && v == p);
    assert_true(rto_report_where(&r, "x", &v) && v == 9);
    assert_true(rto_report_where(&r, "y", &v) && v == 7);
    assert_int_equal(r.nrows, 1);
    assert_string_equal(r.rows[0].field, "g");
    assert_int_equal(written, 0); /* no artifact_dir: nothing written */

    /* the same below e */
    memcpy(accum, frame->accum, n * sizeof *accum);
    const float below = (float)((double)e - (1e-4 * fabs((double)e) + abs));
    accum[4 * p + 1] = nextafterf(below, -INFINITY);
    assert_true((double)e - (double)accum[4 * p + 1] > 1e-4 * fabs((double)e) + abs);
    assert_int_equal(rto_npy_write(path, &ad, accum, &msg), RTO_OK);
    assert_int_equal(rto_frame_check(&d, &r, NULL, &msg), RTO_ERR_MISMATCH);
    assert_int_equal(r.code, RTO_FRAME_ACCUM);

    free(accum);
    rto_frame_destroy(frame);
    rto_accel_destroy(accel);
    rto_scene_destroy(scene);
    assert_int_equal(tu_tmpdir_remove(root), 0);
}

static void test_accum_boundary(void **state)
{
    (void)state;
    accum_boundary("sun-shadow", 1e-6);
}

static void test_accum_boundary_barycentric(void **state)
{
    (void)state;
    accum_boundary("triangle", 2e-4);
}

/* The accum rule and the queue's origin rule of §9 as core/tolerance.c states them, on boundaries computed here by
 * hand: at e = 0 only the absolute part counts (the largest float within 1e-6 passes, the next float up fails; with an
 * absolute part a float holds, 2^-20, exactly at the bound passes and one float over fails); the relative part is
 * 1e-4 |e| (0.100001 at e = +-1000 with 1e-6, margins far above binary32's 6e-5 spacing there); a NaN matches only a
 * NaN, an infinity only itself; the sign of zero does not matter. */
static void test_tolerance_rules(void **state)
{
    (void)state;
    assert_true(rto__tol_accum(0.0, 1e-6) == 1e-6 && rto__tol_accum(-0.0, 2e-4) == 2e-4);
    assert_true(fabs(rto__tol_accum(-1000.0, 1e-6) - 0.100001) < 1e-15);
    float in = (float)1e-6;
    if ((double)in > 1e-6)
        in = nextafterf(in, 0.0f);
    const float out = nextafterf(in, 1.0f);
    assert_true((double)in <= 1e-6 && (double)out > 1e-6);
    assert_true(rto__tol_accum_close(0.0f, in, 1e-6) && rto__tol_accum_close(0.0f, -in, 1e-6) &&
                rto__tol_accum_close(-0.0f, in, 1e-6));
    assert_false(rto__tol_accum_close(0.0f, out, 1e-6) || rto__tol_accum_close(0.0f, -out, 1e-6));
    assert_true(rto__tol_accum_close(0.0f, 0x1p-20f, 0x1p-20) && rto__tol_accum_close(0.0f, -0x1p-20f, 0x1p-20));
    assert_false(rto__tol_accum_close(0.0f, nextafterf(0x1p-20f, 1.0f), 0x1p-20));
    assert_true(rto__tol_accum_close(1000.0f, 1000.098f, 1e-6) && rto__tol_accum_close(-1000.0f, -999.902f, 1e-6));
    assert_false(rto__tol_accum_close(1000.0f, 1000.102f, 1e-6) || rto__tol_accum_close(-1000.0f, -999.898f, 1e-6));
    /* `triangle`'s absolute part: 1e-4 0.5 + 2e-4 = 2.5e-4 at 0.5 */
    assert_true(rto__tol_accum_close(0.5f, 0.50024f, 2e-4) && rto__tol_accum_close(0.5f, 0.49976f, 2e-4));
    assert_false(rto__tol_accum_close(0.5f, 0.50026f, 2e-4) || rto__tol_accum_close(0.5f, 0.49974f, 2e-4));
    assert_true(rto__tol_accum_close(0.0f, -0.0f, 1e-6) && rto__tol_accum_close(-0.0f, 0.0f, 0.0));
    assert_true(rto__tol_accum_close(NAN, NAN, 1e-6) && rto__tol_accum_close(NAN, -NAN, 0.0));
    assert_false(rto__tol_accum_close(NAN, 0.0f, 1e-6) || rto__tol_accum_close(0.0f, NAN, 1e-6) ||
                 rto__tol_accum_close(NAN, INFINITY, 1e-6));
    assert_true(rto__tol_accum_close(INFINITY, INFINITY, 1e-6) && rto__tol_accum_close(-INFINITY, -INFINITY, 1e-6));
    assert_false(rto__tol_accum_close(INFINITY, -INFINITY, 1e-6) || rto__tol_accum_close(INFINITY, FLT_MAX, 1e-6) ||
                 rto__tol_accum_close(FLT_MAX, INFINITY, 1e-6) || rto__tol_accum_close(1.0f, INFINITY, 1e-6));

    /* the origin rule, 1e-5 max(4 M, |o|): 4e-5 below |o| = 4 M, 1e-3 at |o| = 100 (M = 1) or M = 25 */
    assert_true(rto__tol_origin(0.0, 1.0) == 4 * 1e-5 && rto__tol_origin(-3.0, 1.0) == 4 * 1e-5);
    assert_true(fabs(rto__tol_origin(-100.0, 1.0) - 1e-3) < 1e-18 && fabs(rto__tol_origin(1.0, 25.0) - 1e-3) < 1e-18);
    assert_true(rto__tol_origin(NAN, 1.0) == 4 * 1e-5 && rto__tol_origin(-INFINITY, 1.0) == INFINITY);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_arguments),
        cmocka_unit_test(test_accum_boundary),
        cmocka_unit_test(test_accum_boundary_barycentric),
        cmocka_unit_test(test_tolerance_rules),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
