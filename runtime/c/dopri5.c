/* Dormand-Prince 5(4) with Hairer's step-size control and 4th-order dense output (DOPRI5).
 *
 * Follows E. Hairer, S. P. Norsett, G. Wanner, Solving Ordinary Differential Equations I, II.5 and the
 * authors' dopri5.f: FSAL stages, PI ("Lund-stabilised") step control, continuous extension through
 * five coefficient vectors.  All memory is allocated once in mbs_dopri5_init.
 */
#include <math.h>
#include <stdlib.h>
#ifdef MBS_ODE_TRACE
#include <stdio.h>
#endif

#include "mbs_runtime.h"

/* Butcher tableau (Dormand & Prince 1980). */
static const double DP_C2 = 1.0 / 5, DP_C3 = 3.0 / 10, DP_C4 = 4.0 / 5, DP_C5 = 8.0 / 9;
static const double DP_A21 = 1.0 / 5;
static const double DP_A31 = 3.0 / 40, DP_A32 = 9.0 / 40;
static const double DP_A41 = 44.0 / 45, DP_A42 = -56.0 / 15, DP_A43 = 32.0 / 9;
static const double DP_A51 = 19372.0 / 6561, DP_A52 = -25360.0 / 2187, DP_A53 = 64448.0 / 6561,
                    DP_A54 = -212.0 / 729;
static const double DP_A61 = 9017.0 / 3168, DP_A62 = -355.0 / 33, DP_A63 = 46732.0 / 5247,
                    DP_A64 = 49.0 / 176, DP_A65 = -5103.0 / 18656;
static const double DP_A71 = 35.0 / 384, DP_A73 = 500.0 / 1113, DP_A74 = 125.0 / 192,
                    DP_A75 = -2187.0 / 6784, DP_A76 = 11.0 / 84;
/* error estimate: 5th minus embedded 4th order weights */
static const double DP_E1 = 71.0 / 57600, DP_E3 = -71.0 / 16695, DP_E4 = 71.0 / 1920,
                    DP_E5 = -17253.0 / 339200, DP_E6 = 22.0 / 525, DP_E7 = -1.0 / 40;
/* dense output (Shampine's continuous extension as used in dopri5.f) */
static const double DP_D1 = -12715105075.0 / 11282082432.0, DP_D3 = 87487479700.0 / 32700410799.0,
                    DP_D4 = -10690763975.0 / 1880347072.0, DP_D5 = 701980252875.0 / 199316789632.0,
                    DP_D6 = -1453857185.0 / 822651844.0, DP_D7 = 69997945.0 / 29380423.0;

/* Step control (dopri5.f defaults): safety factor, PI exponent beta, bounds on h_new/h. */
#define DP_SAFE 0.9
#define DP_BETA 0.04
#define DP_EXPO1 (0.2 - DP_BETA * 0.75)
#define DP_FAC_MIN 0.2  /* h_new >= 0.2 h */
/* Stiffness test of dopri5.f: h |lambda| ~ h |k7 - k6| / |y1 - ysti| beyond the stability boundary
 * (3.25 on the real axis) on DP_STIFF_STEPS accepted steps without DP_NONSTIFF_STEPS good ones between. */
#define DP_STIFF_HLAMB 3.25
#define DP_STIFF_STEPS 15
#define DP_NONSTIFF_STEPS 6

/* A retry after a rejection shrinks h by err^EXPO1 / SAFE (the 5th-order model of the error) -- at least: after
 * two rejections in a row from the same t the two attempts measure the order q at which the error falls with h,
 * and when it is DP_ORDER_MIN or more but below the method's the retry takes the smaller size that order asks for.
 * Where the solution is smooth q is about 5 and nothing changes; where the right-hand side changes fast at the
 * step's start (the Iltis's tyre just after touch-down: its lateral force law ramps from 0 to full over the first
 * newton of load, a few microseconds, a kink that is no switch) the error falls about like h, and err^0.17 took up
 * to a dozen rejections in a row (six evaluations of f each) where the measured order takes two to four.  An error
 * that hardly falls with h (q < DP_ORDER_MIN: a feature somewhere inside the step, which a step just short of it
 * leaves out at once) keeps the 5th-order shrink: the measured order would overshoot by orders of magnitude there.
 * The error test is the same: only the size of the next attempt differs.  -DMBS_ODE_STEPS_FORMER=1 builds the
 * former retry (bench/restart_steps.py compares the two in one run).  -DMBS_ODE_TRACE=1 writes every attempt to
 * stderr (its analysis: the same bench, --where). */
#ifdef MBS_ODE_STEPS_FORMER
#define DP_MEASURED_ORDER 0
#else
#define DP_MEASURED_ORDER 1
#endif
/* The least order taken as measured.  A jump of f just after the step's start makes the error estimate proportional
 * to h (order 1); the Iltis's touch-downs measured 0.8 to 1 (the ramp is not yet negligible against the step) and
 * errors that hardly fall (below 0.8) are mostly a feature inside the step.  Over the bump scenes at their speeds and
 * +-0.3, +-0.6 m/s, 0.8 took 0.2 % fewer rhs calls than 1.0 and as many as 0.6 (bench/restart_steps.py --speeds). */
#define DP_ORDER_MIN 0.8

/* The stages' combinations, the error estimate and the dense output's coefficients are elementwise loops over the
 * state, vectorized (MBS_ODE_ELEMENTWISE, c/ode.c: the same bits; the Iltis over the bump at 10 m/s: dp_step's own
 * instructions 21.7 M of the integration's 681 M before, 15.0 M after). */
typedef struct {
    double facold;  /* previous accepted error, for the PI controller */
    int reject;     /* the last attempt was rejected: do not grow h on the next accepted step */
    double rejected_t, rejected_h, rejected_err;  /* the last rejected attempt (t NaN: none to compare with) */
    int iasti, nonsti;  /* stiffness test: steps at the stability boundary, ordinary steps since */
    double *k2, *k3, *k4, *k5, *k6, *k7, *y1, *ysti;
} dp_mem;

/* h |lambda| estimated from the last two stages, both at t + h: |k7 - k6| / |y1 - ysti| (dopri5.f). */
static double dp_hlamb(int n, double h, const dp_mem *m)
{
    double num = 0.0, den = 0.0;
    int i;
    for (i = 0; i < n; i++) {
        double a = m->k7[i] - m->k6[i], b = m->y1[i] - m->ysti[i];
        num += a * a;
        den += b * b;
    }
    return den > 0.0 ? h * sqrt(num / den) : 0.0;
}

/* Record stiffness once: the step has sat at the stability boundary for DP_STIFF_STEPS accepted steps. */
static void dp_stiffness(mbs_ode *o, dp_mem *m, double h, double hlamb)
{
    if (hlamb > DP_STIFF_HLAMB) {
        m->nonsti = 0;
        if (++m->iasti == DP_STIFF_STEPS && !o->stiff) {
            o->stiff = 1;
            o->stiff_t = o->t + h;
            o->stiff_h = h;
            o->stiff_hlamb = hlamb;
        }
    } else if (++m->nonsti == DP_NONSTIFF_STEPS) {
        m->iasti = 0;
    }
}

/* The factor a rejected attempt (t, h, err) divides h by, at least `shrink` (the 5th-order model's); remembers the
 * attempt for the next rejection.  See DP_MEASURED_ORDER. */
static double dp_retry_shrink(dp_mem *m, double t, double h, double err, double shrink)
{
    if (DP_MEASURED_ORDER && m->reject && m->rejected_t == t && h < m->rejected_h && isfinite(err)
        && isfinite(m->rejected_err)) {
        double q = log(m->rejected_err / err) / log(m->rejected_h / h);
        if (q >= DP_ORDER_MIN) shrink = fmax(shrink, pow(err, 1.0 / fmin(q, 1.0 / DP_EXPO1)) / DP_SAFE);
    }
    m->rejected_t = t;
    m->rejected_h = h;
    m->rejected_err = err;
    return shrink;
}

MBS_ODE_ELEMENTWISE static int dp_step(mbs_ode *o)
{
    dp_mem *m = o->impl;
    const int n = o->n;
    double *y = o->y, *k1 = o->f;
    int i;
    while (o->status == MBS_ODE_RUNNING) {
        double h, err, fac11, fac, hlamb, t = o->t;
        int last, s;
        if (mbs_ode_next_h(o, &h, &last)) break;
        for (i = 0; i < n; i++) m->y1[i] = y[i] + h * DP_A21 * k1[i];
        s = mbs_ode_eval(o, t + DP_C2 * h, m->y1, m->k2);
        if (s == MBS_OK) {
            for (i = 0; i < n; i++) m->y1[i] = y[i] + h * (DP_A31 * k1[i] + DP_A32 * m->k2[i]);
            s = mbs_ode_eval(o, t + DP_C3 * h, m->y1, m->k3);
        }
        if (s == MBS_OK) {
            for (i = 0; i < n; i++)
                m->y1[i] = y[i] + h * (DP_A41 * k1[i] + DP_A42 * m->k2[i] + DP_A43 * m->k3[i]);
            s = mbs_ode_eval(o, t + DP_C4 * h, m->y1, m->k4);
        }
        if (s == MBS_OK) {
            for (i = 0; i < n; i++)
                m->y1[i] = y[i] + h * (DP_A51 * k1[i] + DP_A52 * m->k2[i] + DP_A53 * m->k3[i] + DP_A54 * m->k4[i]);
            s = mbs_ode_eval(o, t + DP_C5 * h, m->y1, m->k5);
        }
        if (s == MBS_OK) {
            for (i = 0; i < n; i++)
                m->ysti[i] = y[i] + h * (DP_A61 * k1[i] + DP_A62 * m->k2[i] + DP_A63 * m->k3[i]
                                         + DP_A64 * m->k4[i] + DP_A65 * m->k5[i]);
            s = mbs_ode_eval(o, t + h, m->ysti, m->k6);
        }
        if (s == MBS_OK) {
            for (i = 0; i < n; i++)
                m->y1[i] = y[i] + h * (DP_A71 * k1[i] + DP_A73 * m->k3[i] + DP_A74 * m->k4[i]
                                       + DP_A75 * m->k5[i] + DP_A76 * m->k6[i]);
            s = mbs_ode_eval(o, t + h, m->y1, m->k7);
        }
        if (s != MBS_OK) {  /* model failed inside the step: retry smaller (it may have left its domain) */
            o->h = h * MBS_ODE_MODEL_FAILURE_SHRINK;
            m->rejected_t = NAN;
            o->nreject++;
            m->reject = 1;
            continue;
        }
        hlamb = dp_hlamb(n, h, m);
        /* error estimate, kept in ysti (no longer needed) */
        for (i = 0; i < n; i++)
            m->ysti[i] = h * (DP_E1 * k1[i] + DP_E3 * m->k3[i] + DP_E4 * m->k4[i] + DP_E5 * m->k5[i]
                              + DP_E6 * m->k6[i] + DP_E7 * m->k7[i]);
        err = mbs_ode_error_norm(o, m->ysti, y, m->y1);
#ifdef MBS_ODE_TRACE
        fprintf(stderr, "STEP %.17g %.17g %.6g %d %.6g %d\n", t, h, err, err <= 1.0, m->facold, m->reject);
#endif
        fac11 = pow(err, DP_EXPO1);
        fac = fac11 / pow(m->facold, DP_BETA);
        fac = fmax(1.0 / MBS_ODE_MAX_GROWTH, fmin(1.0 / DP_FAC_MIN, fac / DP_SAFE));
        if (err <= 1.0) {
            double *c = o->cont, h_new = h / fac;
            m->facold = fmax(err, 1e-4);
            for (i = 0; i < n; i++) {
                double ydiff = m->y1[i] - y[i], bspl = h * k1[i] - ydiff;
                c[i] = y[i];
                c[n + i] = ydiff;
                c[2 * n + i] = bspl;
                c[3 * n + i] = ydiff - h * m->k7[i] - bspl;
                c[4 * n + i] = h * (DP_D1 * k1[i] + DP_D3 * m->k3[i] + DP_D4 * m->k4[i] + DP_D5 * m->k5[i]
                                    + DP_D6 * m->k6[i] + DP_D7 * m->k7[i]);
                k1[i] = m->k7[i];  /* first same as last */
                y[i] = m->y1[i];
            }
            c[5 * n] = h;
            if (m->reject) h_new = fmin(h_new, h);
            m->reject = 0;
            o->h = h_new;
            dp_stiffness(o, m, h, hlamb);
            mbs_ode_accept(o, h, last);
            if (o->stiff && o->stop_on_stiff && o->status == MBS_ODE_RUNNING) o->status = MBS_ODE_STIFF;
            break;
        }
        /* rejected (err > 1 or non-finite) */
        /* err = inf gives the full shrink */
        o->h = h / fmin(1.0 / DP_FAC_MIN, dp_retry_shrink(m, t, h, err, fac11 / DP_SAFE));
        o->nreject++;
        m->reject = 1;
    }
    return o->status;
}

/* The take_over hook (c/ode.c mbs_ode_take_over, both solvers DOPRI5): the controller memory a restart in C keeps
 * and a new solver would start afresh, the PI controller's last accepted error and the stiffness test's counts. */
static void dp_take_over(mbs_ode *to, const mbs_ode *from)
{
    dp_mem *m = to->impl;
    const dp_mem *was = from->impl;
    m->facold = was->facold;
    m->iasti = was->iasti;
    m->nonsti = was->nonsti;
}

/* y(t) = c0 + s (c1 + (1-s) (c2 + s (c3 + (1-s) c4))), s = (t - t_old) / h */
MBS_ODE_ELEMENTWISE static void dp_dense(const mbs_ode *o, double t, double *out)
{
    const double *c = o->cont;
    const int n = o->n;
    double s = (t - o->t_old) / c[5 * n], s1 = 1.0 - s;
    int i;
    for (i = 0; i < n; i++)
        out[i] = c[i] + s * (c[n + i] + s1 * (c[2 * n + i] + s * (c[3 * n + i] + s1 * c[4 * n + i])));
}

/* Set up a DOPRI5 run; h0 <= 0 chooses the first step automatically.  Returns 0 or -1 (no memory). */
static int mbs_dopri5_init(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0,
                           const double *y0, double t_bound, double rtol, const double *atol, int natol,
                           double h0, double h_max, double h_min, long max_steps)
{
    dp_mem *m;
    double *a;
    /* cont: 5 coefficient vectors and the step size */
    if (mbs_ode_setup(o, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps,
                      5 * (size_t)n + 1)) return -1;
    m = calloc(1, sizeof(dp_mem) + (8 * (size_t)n + 1) * sizeof(double));
    if (!m) return -1;
    o->impl = m;
    a = (double *)(m + 1);
    m->k2 = a; m->k3 = a + n; m->k4 = a + 2 * n; m->k5 = a + 3 * n; m->k6 = a + 4 * n; m->k7 = a + 5 * n;
    m->y1 = a + 6 * n; m->ysti = a + 7 * n;
    m->facold = 1e-4;
    m->rejected_t = NAN;
    o->step = dp_step;
    o->dense = dp_dense;
    o->take_over = dp_take_over;
    if (o->h <= 0 && o->status == MBS_ODE_RUNNING) o->h = mbs_ode_initial_step(o, 5, m->y1);
#ifdef MBS_ODE_TRACE
    fprintf(stderr, "INIT %.17g h %.17g\n", t0, o->h);
#endif
    return 0;
}
