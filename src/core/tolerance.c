/* DESIGN.md §9's tolerances for floats (tolerance.h): the one home of each rule. The arithmetic is binary64 in the
 * order written (the build has no contraction), so every caller gets the same bounds bit for bit. */
#include "tolerance.h"

#include <math.h>

double rto__tol_t_scale(double t)
{
    const double a = fabs(t);
    return a > 1.0 ? a : 1.0;
}

double rto__tol_t(double t) { return RTO__TOL_T_REL * rto__tol_t_scale(t); }

int rto__tol_t_close(double e, double a) { return fabs(a - e) <= rto__tol_t(e); }

int rto__tol_bary_close(double e, double a) { return fabs(a - e) <= RTO__TOL_BARY; }

double rto__tol_origin(double o, double scale)
{
    const double a = fabs(o), m = 4.0 * scale;
    return RTO__TOL_T_REL * (a > m ? a : m);
}

double rto__tol_accum(double e, double abs) { return RTO__TOL_ACCUM_REL * fabs(e) + abs; }

int rto__tol_accum_close(float e, float a, double abs)
{
    if (isnan(e) || isnan(a))
        return isnan(e) && isnan(a);
    if (isinf(e) || isinf(a))
        return e == a;
    return fabs((double)a - (double)e) <= rto__tol_accum(e, abs);
}
