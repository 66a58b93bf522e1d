/* DESIGN.md §9's tolerances for floats, each rule in one place (core/tolerance.c): the t rule (hit records, and the
 * ray fields of check-frame's queues held to it), the barycentric rule, the queue's origin rule and the accum rule.
 * check-hits (its records rule), crosscheck and check-frame call these; none spells a rule out again. */
#ifndef RTO_CORE_TOLERANCE_H
#define RTO_CORE_TOLERANCE_H

/* Library-private: not exported from librtoracle.so. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#define RTO__TOL_T_REL 1e-5     /* t: |dt| <= 1e-5 max(1, |t|) */
#define RTO__TOL_BARY 1e-4      /* u, v: |du| <= 1e-4 */
#define RTO__TOL_ACCUM_REL 1e-4 /* accum: |d| <= 1e-4 |e| + abs, per channel */
#define RTO__TOL_ACCUM_ABS 1e-6 /* ... with this absolute part */
/* The accum rule's absolute part for a program whose colours are barycentrics (the built-in `triangle`, whose red is
 * (1 - u) - v): twice the barycentric rule, since a GPU's u and v may each be off by 1e-4. */
#define RTO__TOL_ACCUM_ABS_BARY 2e-4

/** max(1, |t|): the scale of the t rule (NaN gives 1). */
double rto__tol_t_scale(double t);
/** The t rule's bound at t: 1e-5 max(1, |t|). */
double rto__tol_t(double t);
/** Whether a lies within the t rule of e: |a - e| <= 1e-5 max(1, |e|). A NaN is never within it, nor is an infinite a
 * of a finite e, nor an infinity of itself (inf - inf is NaN: callers accept values equal bit for bit first); an
 * infinite e has an infinite bound, which every finite a meets (no caller's e is infinite: hit t are finite). */
int rto__tol_t_close(double e, double a);
/** Whether a lies within the barycentric rule of e: |a - e| <= 1e-4 (NaN and infinities never). */
int rto__tol_bary_close(double e, double a);
/** The origin rule of a queue's ray (check-frame): 1e-5 max(4 M, |o|), M the scene's scale (a secondary origin is a
 * hit point, off by |dt| |d| when t is off by the t rule; a t inside the scene is under 4 M). */
double rto__tol_origin(double o, double scale);
/** The accum rule's bound at e with absolute part abs (RTO__TOL_ACCUM_ABS, or RTO__TOL_ACCUM_ABS_BARY): 1e-4 |e| +
 * abs. */
double rto__tol_accum(double e, double abs);
/** The accum rule for one channel: a NaN matches only a NaN, an infinity only the same infinity, anything else is
 * within rto__tol_accum(e, abs) of e. */
int rto__tol_accum_close(float e, float a, double abs);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
