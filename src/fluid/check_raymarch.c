/* check-raymarch (DESIGN.md §12.7): a GPU's raymarch dump against the reference recomputed from the bundle. Faults,
 * by priority at a pixel: "shape" (wrong dimensions), "skip" (a skipping GPU's crossing differs from its own
 * non-skipping one; or it took fewer primary-march steps than the samples of its first entry search that read a
 * non-zero texel (their cells are required, §12.3), which no lossless skipper can pass over; or its crossing is inadmissible after fewer steps than the reference's
 * skipping took), "crossing" (the first crossing's step outside the admissible set),
 * "image" (a certain pixel beyond its tolerance, or not finite). The first wrong pixel in row-major order is named. */
#include "fluid/raymarch_internal.h"
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define RM_NONE 0xFFFFFFFFu

static int admissible(uint32_t g, uint32_t lo, uint32_t hi)
{
    if (lo == RM_NONE)
        return g == RM_NONE;
    if (hi == RM_NONE)
        return g == RM_NONE || g >= lo;
    return g >= lo && g <= hi;
}

static void fmt_step(char *buf, size_t cap, uint32_t k)
{
    if (k == RM_NONE)
        snprintf(buf, cap, "none");
    else
        snprintf(buf, cap, "%u", k);
}

/* The largest channel deviation of GPU pixel q from e (*dev, channel *ch; inf for a non-finite channel); 1 when some
 * channel is not finite or beyond tol. */
static int pixel_deviation(const float *q, const float *e, float tol, double *dev, int *ch)
{
    int bad = 0;
    *dev = 0;
    *ch = 0;
    for (int k = 0; k < 4; k++) {
        const double d = fabs((double)q[k] - e[k]);
        if (!isfinite(q[k]) || !(d <= tol))
            bad = 1;
        if (!isfinite(q[k]) || d > *dev) {
            *dev = isfinite(q[k]) ? d : INFINITY;
            *ch = k;
        }
    }
    return bad;
}

rto_status rto_raymarch_check(const rto_raymarch *ref, const rto_raymarch_dump *dump, rto_raymarch_check_result *res,
                              rto_msg *msg)
{
    if (!ref || !dump || !res)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "check-raymarch: missing argument");
    memset(res, 0, sizeof *res);
    const uint32_t W = ref->params.width, H = ref->params.height;
    if (dump->width != W || dump->height != H || !dump->image || !dump->crossing) {
        snprintf(res->fault, sizeof res->fault, "shape");
        snprintf(res->detail, sizeof res->detail, "the dump is %ux%u (image %s, crossing %s); the bundle is %ux%u",
                 dump->width, dump->height, dump->image ? "present" : "missing",
                 dump->crossing ? "present" : "missing", W, H);
        res->faults = 1;
        return RTO_OK;
    }
    const size_t n = (size_t)W * H;
    for (size_t i = 0; i < n; i++) {
        const uint32_t g = dump->crossing[i], lo = ref->crossing_lo[i], hi = ref->crossing_hi[i];
        const char *fault = NULL;
        char detail[320] = "";
        char a[16], b[16], c[16];
        const int certain = ref->certain[i] != 0;
        const int adm = admissible(g, lo, hi);
        /* A GPU whose first entry search went at least as far as the reference's passed every sample of it that reads
         * a non-zero texel, and a lossless skipper takes each of those (§12.3 requires their cells set). */
        const uint32_t rc = ref->crossing[i];
        const int as_far = rc == RM_NONE ? g == RM_NONE : (g == RM_NONE || g >= rc);
        const int fewer = dump->steps_skip && certain && as_far && dump->steps_skip[i] < ref->steps_min[i];
        if (fewer) {
            fault = "skip";
            fmt_step(a, sizeof a, g);
            fmt_step(b, sizeof b, lo);
            fmt_step(c, sizeof c, hi);
            snprintf(detail, sizeof detail,
                     "%u steps with skipping (the reference's skipping takes %u; %u samples before its first crossing "
                     "read non-zero texels, so their cells are occupied); crossing step %s, admissible [%s, %s]",
                     dump->steps_skip[i], ref->steps_skip[i], ref->steps_min[i], a, b, c);
            if (dump->crossing_noskip && dump->crossing_noskip[i] != g) {
                const size_t len = strlen(detail);
                fmt_step(a, sizeof a, dump->crossing_noskip[i]);
                snprintf(detail + len, sizeof detail - len, "; %s without skipping", a);
            }
        } else if (dump->crossing_noskip && dump->crossing_noskip[i] != g) {
            fault = "skip";
            fmt_step(a, sizeof a, g);
            fmt_step(b, sizeof b, dump->crossing_noskip[i]);
            if (dump->steps_skip && dump->steps)
                snprintf(detail, sizeof detail, "%u steps with skipping to crossing step %s; %u steps to %s without",
                         dump->steps_skip[i], a, dump->steps[i], b);
            else
                snprintf(detail, sizeof detail, "crossing step %s with skipping, %s without", a, b);
        } else if (!adm && dump->steps_skip && dump->steps_skip[i] < ref->steps_skip[i]) {
            fault = "skip";
            fmt_step(a, sizeof a, g);
            fmt_step(b, sizeof b, lo);
            fmt_step(c, sizeof c, hi);
            snprintf(detail, sizeof detail,
                     "%u steps with skipping, fewer than the reference's skipping takes (%u), and crossing step %s "
                     "outside the admissible [%s, %s]",
                     dump->steps_skip[i], ref->steps_skip[i], a, b, c);
        } else if (!adm) {
            fault = "crossing";
            fmt_step(a, sizeof a, g);
            fmt_step(b, sizeof b, lo);
            fmt_step(c, sizeof c, hi);
            snprintf(detail, sizeof detail, "first crossing step %s, admissible [%s, %s%s] (reference %u)", a, b, c,
                     hi == RM_NONE && lo != RM_NONE ? " or none" : "", ref->crossing[i]);
        }
        if (fault) {
            if (!strcmp(fault, "skip"))
                res->skip_faults++;
            else
                res->crossing_faults++;
        }
        if (!certain) {
            res->uncertain++;
        } else {
            res->compared++;
            const float *e = ref->image + 4 * i, *q = dump->image + 4 * i;
            double dev;
            int ch;
            int bad = pixel_deviation(q, e, ref->tolerance[i], &dev, &ch);
            double ex = ref->tolerance[i] > 0 ? dev / ref->tolerance[i] : INFINITY;
            const float tw = ref->tolerance_wall ? ref->tolerance_wall[i] : NAN;
            if (tw == tw) {
                /* the other admissible image of a wall event (§12.5.1): the pixel passes when either matches, and
                 * its excess is the closer one's */
                double dw;
                int cw;
                const int bw = pixel_deviation(q, ref->image_wall + 4 * i, tw, &dw, &cw);
                const double exw = tw > 0 ? dw / tw : INFINITY;
                ex = exw < ex ? exw : ex;
                bad = bad && bw;
            }
            res->max_excess = ex > res->max_excess ? ex : res->max_excess;
            if (bad) {
                res->image_faults++;
                if (!fault) {
                    fault = "image";
                    snprintf(detail, sizeof detail,
                             "channel %d: GPU %.9g, reference %.9g (|difference| %.3g > tolerance %.3g)", ch,
                             (double)q[ch], (double)e[ch], dev, (double)ref->tolerance[i]);
                    if (tw == tw) {
                        const size_t len = strlen(detail);
                        snprintf(detail + len, sizeof detail - len, "; nor its wall event's other outcome %.9g "
                                 "(tolerance %.3g)", (double)ref->image_wall[4 * i + ch], (double)tw);
                    }
                }
            }
        }
        if (fault) {
            res->faults++;
            if (!res->fault[0]) {
                snprintf(res->fault, sizeof res->fault, "%s", fault);
                res->x = (uint32_t)(i % W);
                res->y = (uint32_t)(i / W);
                snprintf(res->detail, sizeof res->detail, "%s", detail);
            }
        }
    }
    return RTO_OK;
}
