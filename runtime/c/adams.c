/* Variable-step, variable-order Adams-Bashforth-Moulton PECE (orders 1 to ADAMS_KMAX) with dense output.
 *
 * The method of L. F. Shampine and M. K. Gordon, Computer Solution of Ordinary Differential Equations: the Initial
 * Value Problem (Freeman 1975), ch. 5 and 6, in the Newton form of E. Hairer, S. P. Norsett, G. Wanner, Solving
 * Ordinary Differential Equations I, III.5 (variable step size Adams methods written with divided differences):
 *
 *   predict   y_p = y_n + integral over [t_n, t_n + h] of P, P interpolating f at t_n, ..., t_{n-k+1} (order k);
 *   evaluate  f_p = f(t_n + h, y_p);
 *   correct   y_{n+1} = y_n + integral of P*, P* interpolating f_p and f at t_n, ..., t_{n-k+1} (order k + 1: the
 *             local extrapolation of Shampine & Gordon);
 *   evaluate  f_{n+1} = f(t_n + h, y_{n+1}): the history's newest value (two right-hand sides per step), at the
 *             accepted state as ode.c projected it onto the loop constraints (with the direct loop rhs at the
 *             integrated states, as first built, the history's values drifted from the projected solution:
 *             40 four-bars through their flat positions, tests/runtime/test_fourbar_chain.py, ended 1.1 rad off at
 *             rtol 1e-6 against 9e-3 so; the projection then cannot reuse the last evaluation's factors of G);
 *             or not (PEC: f_p is the newest value, one right-hand side per step) while the step is small against
 *             the problem's time scale, h L <= ADAMS_PEC_HL = 0.05, and the order at most 6 (ADAMS_PECE 2, below).
 *
 * PEC throughout (-DADAMS_PECE=0) reaches DOPRI5's accuracy at rtol 1e-7 on the Iltis bump at 10 m/s with 0.65 of
 * PECE's right-hand sides (its steps, limited by the 392 events, are hardly more), but at 5 m/s with 1.2-1.3 times
 * them and 2.3 times the steps: its order stays at 4-5 where PECE's climbs to 7-8 (the region of stability of PEC
 * shrinks faster with the order; on the damped oscillator of tests/runtime/test_adams.py its error grows too).  h L
 * tells the two apart (h times ||f(y_{n+1}) - f_p|| / ||y_{n+1} - y_p||, unweighted, at PECE's steps: median 0.18 at
 * 5 m/s, 0.026 at 10 m/s), so the final evaluation is skipped only below ADAMS_PEC_HL, at orders up to 6, L measured
 * again after 20 steps without it and at the first step after every restart (the new branch may be stiffer: the
 * 1e6 N/m stop of tests/runtime/models/handback_stop.mbs).  python bench/adams.py --variants (pece:
 * -DADAMS_PECE_FORMER=1, PECE throughout, the former build; pec: PEC throughout), right-hand sides at DOPRI5's
 * max / median error against PECE's: bump at 10 m/s <= 0.78 / 0.76, at 5 m/s 1.00 / 0.99, the quarter car at 10 m/s
 * 0.80 / 0.78, at 5 m/s 0.86 / 0.96, each step without the final evaluation also saving the chain with f_{n+1} (the
 * corrector's chain with f_p is the new history).  The threshold is a compromise measured, not derived: at 0.03 and
 * at 0.1 the stop above ends 1.5e-4 and 1.9e-4 off (0.7e-4 at 0.05, 2.5e-5 with PECE, 7.0e-5 DOPRI5), with the
 * norm in the step's weights (L underestimated where the weights differ) the damped oscillator 11.6 rtol off.
 *
 * The history is the chain of divided differences D_i = f[t_n, ..., t_{n-i}]: adding a point costs O(k n) and the
 * differences are the same for any next step size, so a rejected step changes nothing.  The error estimate of
 * order j is the difference of the correctors through j + 1 and j points, err_j = |E_j integral(w_j)| (E_j the new
 * chain's differences, w_j its Newton basis polynomial); the step is accepted when err_k <= 1 in the weighted RMS
 * norm of ode.c.  The order follows Shampine & Gordon's policy (DE/STEP): lower it when the estimates of the lower
 * orders are no larger (max(err_{k-1}, err_{k-2}) <= err_k; err_1 <= err_2 / 2 at order 2), raise it when
 * err_{k+1} < err_k after k + 1 steps at order k; on a rejection halve the step, lower the order when
 * err_{k-1} <= err_k, and from the third rejection in a row go on at order 1 with the step cut by sqrt(1/2 / err)
 * (between 1/4 and 1/2).  The start (and a fresh restart) is their phase 1: order 1, the order raised and the step
 * doubled after every step while the doubled step's estimate would pass.  The step after an accepted one is the
 * usual h (ADAMS_SAFE / err)^(1/(k+1)) at the new order, within [1/2, ADAMS_MAX_GROWTH] and held when it would
 * grow by less than ADAMS_HOLD (CVODE's rule); Shampine & Gordon's own (as first built: double when
 * err 2^(k+1) <= 1/2, shrink by (1/2 / err)^(1/(k+1)) within [1/2, 9/10] when err > 1/2, else hold) kept the step
 * at errors far below the tolerance and took 7 % more right-hand sides on the Iltis bump at 10 m/s.  The growth
 * limit ADAMS_MAX_GROWTH = 3 (2 before, Shampine & Gordon's doubling) takes 1-6 % fewer right-hand sides at the
 * accuracy DOPRI5 reaches at rtol 1e-7 on the four Iltis bump cases of python bench/adams.py --variants (the
 * largest gain on the vehicle at 10 m/s, whose 392 restarts each climb back from a small first step).
 *
 * The dense output is the corrector's polynomial, y(t) = y_n + integral from t_n to t of P*: of order k + 1, equal
 * to y_n and to y_{n+1} (before the projection of ode.c) at the step's ends.
 *
 * Events (ode.c restarts the run at a switch with the state continuous, f evaluated afresh at the event with the
 * new branch): the method sees the restart at its next step (t no longer the end of its last step, or t_old = t)
 * and rebuilds its history there by ADAMS_RESTART:
 *   0  forget it: order 1 from the event with a starting step, phase 1 (what CVODE does at a reinitialisation);
 *   1  keep it (the default): the points before the event with their old values of f, the event's f in front, the
 *      order at most ADAMS_RESTART_ORDER = 3 (the kink's contamination of the divided differences is then measured
 *      by the error estimate, and the order climbs back as the new branch's points replace the old ones);
 *   2  re-evaluate it: f of the new branch at the stored states of the points before the event (at most k + 1 of
 *      them), the new branch's smooth continuation, which the solution after the switch follows to the order of
 *      the kink (k + 1 evaluations per restart).
 * Measured on the Iltis (python bench/adams.py --variants): starting afresh costs 15-25 % more right-hand sides at
 * the same error than keeping the history; re-evaluating it is no better than keeping it on the vehicle and costs
 * 15 % more on the quarter car.  The kinks there are mild where they are many: the strut damper's curve is smooth
 * to its first derivative at its breakpoints, so the old branch's values are as good as the new one's; and the new
 * branch continued back in time is a poor history where it is stiff (the leaf spring's hard stop, 1e7 N/m: its
 * extrapolation differs from the solution by the stiffness times the step squared).  Kept at the order it had, the
 * history let the error estimate miss the kink of a stiff stop (1e6 N/m on 2 kg, tests/runtime/models/
 * handback_stop.mbs): 1.7e-3 against dopri5's 7e-5 at rtol 1e-8; with the order at most 3 after the restart 2e-5,
 * for the same right-hand sides on the bump (-DADAMS_RESTART_ORDER=12 builds the uncapped restart).
 * All memory is allocated in mbs_adams_init: a step allocates nothing.
 *
 * Cost of a step beyond its two right-hand sides (the Iltis over the bump at 10 m/s, python bench/adams.py
 * --instructions --former): the projection of the accepted state (ode.c, c/loops.c: 39,000 instructions, fresh,
 * since the last evaluation before it is at the predicted state), the indicators at the step's end (6,000) and the
 * method's own arithmetic, about four passes over the state per unit of order (predictor, the new chain, corrector,
 * the chain with f_{n+1}) and a few more (error estimates, the dense output's copy).  Those passes are vectorized
 * (ADAMS_ELEMENTWISE, ode.c's MBS_ODE_ELEMENTWISE: the same bits), the chains stop at the highest difference a later
 * step reads and the estimate of order k + 1 is computed only when the order may rise: the method's own part
 * 28,200 -> 15,100 instructions an accepted step, the integration 724M -> 672M (-DADAMS_STEP_FORMER=1 builds the
 * former arithmetic).  The sums of the predictor, the corrector and the dense output, and the chains with a new value
 * in front, then went in one pass each with eight elements in registers through every term (am_combine, am_extend,
 * the same bits): at the scene's rtol 2e-7, with PEC steps, the method's own part 10,800 -> 8,900 instructions an
 * accepted step, the integration 406M -> 398M; 22,800 with the former arithmetic (453M).  The integration against
 * the former PECE build at its rtol 5e-7 (python bench/adams.py --instructions --pece-rtols 5e-7): 398M against 464M
 * (0.86; 472M with that build's own arithmetic, as measured before these changes).
 * Then, on bump_10 (the same steps and results to the bit): the error estimates in one pass, each in its own lane of a
 * vector (am_estimates: 6.4M -> 3.1M, and the chain of dependent additions a quarter as long; L's two sums so too);
 * the dense output read where the step left its vectors instead of copied every step (2M); f pushed into the history
 * by exchanging pointers; the passes sixteen elements at a time (am_combine 7.4M -> 5.8M, am_extend 4.5M -> 3.6M); the
 * step's integrals without the powers of theta = 1: the method's own part 8,272 -> 5,705 instructions an accepted
 * step, the integration 235.3M -> 225.4M (python bench/adams.py --instructions --baseline 6555312), the whole
 * simulate 288.8M -> 278.8M (python bench/driver_instructions.py --scenes bump_10 --baseline 6555312; its --cpu 9
 * rounds: 0.975 of the CPU time).  The method's memory on 64-byte boundaries (rows of n rounded up to 8 doubles)
 * measured 0.93 of main's CPU time against 0.99 unaligned in one session, 1.006 of the unaligned in another (12
 * interleaved rounds), and the slower by 3-5 % with the model's work memory moved by a few cache lines: no robust
 * effect, not kept.  Where the run's arrays lie moves its time by several per cent (the model's work memory on a
 * 64-byte boundary: 1.05), which no instruction count shows.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef MBS_ODE_TRACE
#include <stdio.h>
#endif

#include "mbs_runtime.h"

#ifndef ADAMS_KMAX
#define ADAMS_KMAX 12                 /* highest order */
#endif
#define ADAMS_NPOINT (ADAMS_KMAX + 2) /* points kept: k + 1 past points give the order-(k+1) estimate */
#ifndef ADAMS_RESTART
#define ADAMS_RESTART 1
#endif
/* The order the step after a restart with the history kept goes on with, at most (see the head of this file). */
#ifndef ADAMS_RESTART_ORDER
#define ADAMS_RESTART_ORDER 3
#endif
#ifndef ADAMS_SAFE
#define ADAMS_SAFE 0.8
#endif
#ifndef ADAMS_MAX_GROWTH
#define ADAMS_MAX_GROWTH 3.0
#endif
#ifndef ADAMS_HOLD
#define ADAMS_HOLD 1.2
#endif
/* -DADAMS_STEP_FORMER=1 builds the former arithmetic of a step: its loops over the state scalar, the chain with
 * f_{n+1} updated to the oldest point every step and a restart's chain built to it, every estimate computed (the same
 * bits; the same-run baseline of bench/adams.py --instructions). */
#ifdef ADAMS_STEP_FORMER
#define ADAMS_ELEMENTWISE
#define ADAMS_FULL_CHAIN 1
#else
#define ADAMS_ELEMENTWISE MBS_ODE_ELEMENTWISE
#define ADAMS_FULL_CHAIN 0
#endif
/* The final evaluation (see the head of this file): ADAMS_PECE 2 (the default) evaluates f_{n+1} at the accepted state
 * unless h L <= ADAMS_PEC_HL (h the next step, L measured by am_measure_lip at the last step that evaluated it) and
 * the next order is at most ADAMS_PEC_ORDER (PEC then); it does after ADAMS_PEC_REFRESH steps in a row without it and
 * at the first step after a restart (L measured again).  ADAMS_PECE 1 is PECE throughout (-DADAMS_PECE_FORMER=1, the
 * former build: the same bits), 0 PEC throughout. */
#ifdef ADAMS_PECE_FORMER
#define ADAMS_PECE 1
#endif
#ifndef ADAMS_PECE
#define ADAMS_PECE 2
#endif
#ifndef ADAMS_PEC_HL
#define ADAMS_PEC_HL 0.05
#endif
#ifndef ADAMS_PEC_ORDER
#define ADAMS_PEC_ORDER 6
#endif
#ifndef ADAMS_PEC_REFRESH
#define ADAMS_PEC_REFRESH 20
#endif
/* A point of the history closer to the restart than this fraction of the next step is dropped (the divided
 * differences would divide the old branch's values by a vanishing distance). */
#define ADAMS_RESTART_GAP 1e-3

typedef struct {
    int k;             /* order of the next step */
    int nh;            /* points in the history (the newest, t_n, first) */
    int nconst;        /* accepted steps at the current order */
    int phase1;        /* start: raise the order and double the step after every step while the estimates allow */
    int nfail;         /* rejections in a row */
    double lip;        /* ADAMS_PECE 2: L measured at the last PECE step (+inf: none yet) */
    int pec_age;       /* ADAMS_PECE 2: steps since */
    double t_hist;     /* the time of the newest point (o->t after the method's own step; NaN: rebuild) */
    double tt[ADAMS_NPOINT];    /* times of the points, newest first */
    double *d[ADAMS_NPOINT];    /* divided differences D_i = f[tt[0], ..., tt[i]] */
    double *e[ADAMS_NPOINT + 1];/* the new chain of a step (f_p, then f_{n+1}, in front) */
    double *fv[ADAMS_NPOINT];   /* f at the points (for a restart's rebuild) */
    double *yv[ADAMS_NPOINT];   /* y at the points (integrated, before projection) */
    double *spare[ADAMS_NPOINT];/* PECE: the chain with f_{n+1} is built here (e keeps the dense output's) */
    double *yp, *fp, *yc, *w, *scratch, *fnew;
    /* the dense output of the last accepted step: y_n and the corrector's chain E_0 .. E_k, read where the step left
     * them (see the dense output in am_step) */
    const double *dense_y, *dense_e[ADAMS_KMAX + 2];
} am_mem;

/* out[i] = h^(i+1) times the integral from 0 to theta of prod_{j<i} (u - r[j]) du, i = 0 .. m (the Newton basis in
 * the unit of the step, expanded in powers of u; m <= ADAMS_KMAX + 1). */
static void am_integrals(const double *r, int m, double theta, double h, double *out)
{
    double c[ADAMS_KMAX + 3], hi = h;  /* coefficients of the product so far, c[p] of u^p */
    int i, p;
    c[0] = 1.0;
    for (i = 0; i <= m; i++, hi *= h) {
        double s = 0.0, tp = theta;
        for (p = 0; p <= i; p++) { s += c[p] * tp / (p + 1); tp *= theta; }
        out[i] = s * hi;
        if (i == m) break;
        c[i + 1] = c[i];
        for (p = i; p > 0; p--) c[p] = c[p - 1] - r[i] * c[p];
        c[0] = -r[i] * c[0];
    }
}

/* am_integrals at theta = 1 (the predictor's and the corrector's: the powers of theta all 1, so that each term is
 * c[p] / (p + 1), the same bits without the products). */
static void am_step_integrals(const double *r, int m, double h, double *out)
{
    double c[ADAMS_KMAX + 3], hi = h;
    int i, p;
    c[0] = 1.0;
    for (i = 0; i <= m; i++, hi *= h) {
        double s = 0.0;
        for (p = 0; p <= i; p++) s += c[p] / (p + 1);
        out[i] = s * hi;
        if (i == m) break;
        c[i + 1] = c[i];
        for (p = i; p > 0; p--) c[p] = c[p - 1] - r[i] * c[p];
        c[0] = -r[i] * c[0];
    }
}

/* The weights of ode.c's error norm (mbs_ode_error_norm) between y0 and y1: w = 1 / (atol + rtol max(|y0|, |y1|)). */
ADAMS_ELEMENTWISE static void am_weights(const mbs_ode *o, const double *y0, const double *y1, double *w)
{
    const double rtol = o->rtol, *atol = o->atol;
    const int n = o->n;
    int i;
    for (i = 0; i < n; i++) {  /* fmax(a, b) written out (as ode.c's error norm) so that the loop vectorizes */
        const double a = fabs(y0[i]), b = fabs(y1[i]);
        w[i] = 1.0 / (atol[i] + rtol * (a >= b || b != b ? a : b));
    }
}

/* |c| times the weighted RMS norm of v (a non-finite norm: +inf, so the step is rejected).  The squares are
 * computed in chunks elementwise (vectorized) and summed in the order of the elements: the same sum to the bit. */
ADAMS_ELEMENTWISE static double am_norm(int n, double c, const double *v, const double *w)
{
    double sum = 0.0, squares[MBS_ODE_NORM_CHUNK];
    int i, j;
    for (i = 0; i < n; i += MBS_ODE_NORM_CHUNK) {
        const int m = n - i < MBS_ODE_NORM_CHUNK ? n - i : MBS_ODE_NORM_CHUNK;
        for (j = 0; j < m; j++) {
            const double r = v[i + j] * w[i + j];
            squares[j] = r * r;
        }
        for (j = 0; j < m; j++) sum += squares[j];
    }
    sum = n > 0 ? fabs(c) * sqrt(sum / n) : 0.0;
    return sum == sum && sum < HUGE_VAL ? sum : HUGE_VAL;
}

/* The error estimates of a step in one pass: err[i] = am_norm(n, a[i], e[i], w) for i = lo .. hi (at most
 * ADAMS_ESTIMATES of them: k - 2 .. k + 1), w = am_weights(y0, y1), the same bits.  Each estimate's squares are summed
 * in its own accumulator in the order of the elements, as am_norm sums them; the weights are computed on the way
 * and not stored.  With GCC the four accumulators are the lanes of one vector: four elements of each estimate
 * squared elementwise, the 4 x 4 block transposed by shuffles and added element after element (one addition of a
 * vector per element for all the estimates, where am_norm added each estimate's squares one by one, a chain of n
 * dependent additions per estimate); elsewhere the accumulators are four scalars. */
#define ADAMS_ESTIMATES 4
#ifndef ADAMS_LANES  /* -DADAMS_LANES=0: the scalar accumulators (the same bits) */
#if defined(__GNUC__) && !defined(__clang__)
#define ADAMS_LANES 1
#else
#define ADAMS_LANES 0
#endif
#endif
#if ADAMS_LANES
/* out of line: its return clears the vectors' upper halves (vzeroupper), which inlined into am_step stayed dirty into
 * the model's code (the Iltis's rhs then ran 4 % slower) */
#define ADAMS_LANES_CALL __attribute__((noinline))
typedef double am_v4 __attribute__((vector_size(32)));
typedef long long am_m4 __attribute__((vector_size(32)));
/* v = p[0 .. 4), unaligned (a macro: a function returning a vector warns of its ABI without AVX) */
#define AM_LOAD4(v, p) memcpy(&(v), (p), sizeof(am_v4))
#else
#define ADAMS_LANES_CALL
#endif

/* 1 / (atol + rtol max(|a|, |b|)), max as am_weights takes it (a NaN b gives a) */
static double am_weight(double atol, double rtol, double y0, double y1)
{
    const double a = fabs(y0), b = fabs(y1);
    return 1.0 / (atol + rtol * (a >= b || b != b ? a : b));
}

ADAMS_LANES_CALL static void am_estimates(const mbs_ode *o, const double *y0, const double *y1, int lo, int hi, const double *a,
                         double *const *e, double *err)
{
    const int n = o->n, count = hi - lo + 1;
    const double rtol = o->rtol, *atol = o->atol, *v[ADAMS_ESTIMATES];
    double sum[ADAMS_ESTIMATES] = {0.0, 0.0, 0.0, 0.0};
    int i, j = 0;
    for (i = 0; i < ADAMS_ESTIMATES; i++) v[i] = e[i < count ? lo + i : lo];  /* lanes beyond hi: ignored */
#if ADAMS_LANES
    {
        const am_m4 magnitude = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL,
                                 0x7fffffffffffffffLL};
        const am_m4 low = {0, 4, 2, 6}, high = {1, 5, 3, 7}, front = {0, 1, 4, 5}, back = {2, 3, 6, 7};
        const am_v4 r4 = {rtol, rtol, rtol, rtol}, one = {1.0, 1.0, 1.0, 1.0};
        am_v4 s = {0.0, 0.0, 0.0, 0.0};
        for (; j + 4 <= n; j += 4) {
            am_v4 p, q, w, q0, q1, q2, q3, t0, t1, t2, t3;
            am_m4 take_p;
            AM_LOAD4(p, y0 + j); AM_LOAD4(q, y1 + j); AM_LOAD4(w, atol + j);
            p = (am_v4)((am_m4)p & magnitude);
            q = (am_v4)((am_m4)q & magnitude);
            take_p = (p >= q) | (q != q);
            w = one / (w + r4 * (am_v4)((take_p & (am_m4)p) | (~take_p & (am_m4)q)));
            AM_LOAD4(q0, v[0] + j); AM_LOAD4(q1, v[1] + j); AM_LOAD4(q2, v[2] + j); AM_LOAD4(q3, v[3] + j);
            q0 *= w; q1 *= w; q2 *= w; q3 *= w;
            q0 *= q0; q1 *= q1; q2 *= q2; q3 *= q3;
            /* transpose: lane i of the vector of element j + c holds estimate i's square */
            t0 = __builtin_shuffle(q0, q1, low); t1 = __builtin_shuffle(q0, q1, high);
            t2 = __builtin_shuffle(q2, q3, low); t3 = __builtin_shuffle(q2, q3, high);
            s += __builtin_shuffle(t0, t2, front);
            s += __builtin_shuffle(t1, t3, front);
            s += __builtin_shuffle(t0, t2, back);
            s += __builtin_shuffle(t1, t3, back);
        }
        memcpy(sum, &s, sizeof sum);
    }
#endif
    for (; j < n; j++) {
        const double w = am_weight(atol[j], rtol, y0[j], y1[j]);
        for (i = 0; i < ADAMS_ESTIMATES; i++) {
            const double r = v[i][j] * w;
            sum[i] += r * r;
        }
    }
    for (i = 0; i < count; i++) {
        const double norm = n > 0 ? fabs(a[lo + i]) * sqrt(sum[i] / n) : 0.0;
        err[lo + i] = norm == norm && norm < HUGE_VAL ? norm : HUGE_VAL;
    }
}

/* y += a x */
ADAMS_ELEMENTWISE static void am_axpy(int n, double a, const double *restrict x, double *restrict y)
{
    int i;
    for (i = 0; i < n; i++) y[i] += a * x[i];
}

/* out = y0 + a[m] v[m] + a[m-1] v[m-1] + ... + a[0] v[0], added in that order (the same bits as y0 and m + 1 am_axpy
 * passes from i = m down to 0) in one pass: sixteen elements at a time through every term, in registers (four
 * vectors: a term's coefficient and pointer loaded once for them; eight at a time took 1.3 times the instructions),
 * then eight, where the passes loaded and stored the sum once per term (out may be y0). */
ADAMS_ELEMENTWISE static void am_combine(int n, const double *y0, int m, const double *a, const double *const *v,
                                         double *out)
{
    int i, j;
    for (j = 0; j + 16 <= n; j += 16) {
        double s0 = y0[j], s1 = y0[j + 1], s2 = y0[j + 2], s3 = y0[j + 3];
        double s4 = y0[j + 4], s5 = y0[j + 5], s6 = y0[j + 6], s7 = y0[j + 7];
        double s8 = y0[j + 8], s9 = y0[j + 9], s10 = y0[j + 10], s11 = y0[j + 11];
        double s12 = y0[j + 12], s13 = y0[j + 13], s14 = y0[j + 14], s15 = y0[j + 15];
        for (i = m; i >= 0; i--) {
            const double c = a[i], *x = v[i] + j;
            s0 += c * x[0]; s1 += c * x[1]; s2 += c * x[2]; s3 += c * x[3];
            s4 += c * x[4]; s5 += c * x[5]; s6 += c * x[6]; s7 += c * x[7];
            s8 += c * x[8]; s9 += c * x[9]; s10 += c * x[10]; s11 += c * x[11];
            s12 += c * x[12]; s13 += c * x[13]; s14 += c * x[14]; s15 += c * x[15];
        }
        out[j] = s0; out[j + 1] = s1; out[j + 2] = s2; out[j + 3] = s3;
        out[j + 4] = s4; out[j + 5] = s5; out[j + 6] = s6; out[j + 7] = s7;
        out[j + 8] = s8; out[j + 9] = s9; out[j + 10] = s10; out[j + 11] = s11;
        out[j + 12] = s12; out[j + 13] = s13; out[j + 14] = s14; out[j + 15] = s15;
    }
    for (; j + 8 <= n; j += 8) {
        double s0 = y0[j], s1 = y0[j + 1], s2 = y0[j + 2], s3 = y0[j + 3];
        double s4 = y0[j + 4], s5 = y0[j + 5], s6 = y0[j + 6], s7 = y0[j + 7];
        for (i = m; i >= 0; i--) {
            const double c = a[i], *x = v[i] + j;
            s0 += c * x[0]; s1 += c * x[1]; s2 += c * x[2]; s3 += c * x[3];
            s4 += c * x[4]; s5 += c * x[5]; s6 += c * x[6]; s7 += c * x[7];
        }
        out[j] = s0; out[j + 1] = s1; out[j + 2] = s2; out[j + 3] = s3;
        out[j + 4] = s4; out[j + 5] = s5; out[j + 6] = s6; out[j + 7] = s7;
    }
    for (; j < n; j++) {
        double sj = y0[j];
        for (i = m; i >= 0; i--) sj += a[i] * v[i][j];
        out[j] = sj;
    }
}

/* The next divided difference: out = (a - b) / dt (out may be b) */
ADAMS_ELEMENTWISE static void am_divide(int n, const double *a, const double *b, double dt, double *out)
{
    double inv = 1.0 / dt;
    int i;
    for (i = 0; i < n; i++) out[i] = (a[i] - b[i]) * inv;
}

/* The chain with a new value in front: e[0] = front, e[i] = (e[i-1] - d[i-1]) / (x0 - tt[i-1]), i = 1 .. m (the same
 * bits as a copy and m am_divide passes) in one pass: sixteen elements at a time through the chain, in registers
 * (as am_combine), then eight. */
ADAMS_ELEMENTWISE static void am_extend(int n, const double *front, int m, double *const *d, const double *tt, double x0,
                                        double *const *e)
{
    double inv[ADAMS_NPOINT + 1];
    int i, j;
    for (i = 1; i <= m; i++) inv[i] = 1.0 / (x0 - tt[i - 1]);
    for (j = 0; j + 16 <= n; j += 16) {
        double p0 = front[j], p1 = front[j + 1], p2 = front[j + 2], p3 = front[j + 3];
        double p4 = front[j + 4], p5 = front[j + 5], p6 = front[j + 6], p7 = front[j + 7];
        double p8 = front[j + 8], p9 = front[j + 9], p10 = front[j + 10], p11 = front[j + 11];
        double p12 = front[j + 12], p13 = front[j + 13], p14 = front[j + 14], p15 = front[j + 15];
        double *o = e[0] + j;
        o[0] = p0; o[1] = p1; o[2] = p2; o[3] = p3; o[4] = p4; o[5] = p5; o[6] = p6; o[7] = p7;
        o[8] = p8; o[9] = p9; o[10] = p10; o[11] = p11; o[12] = p12; o[13] = p13; o[14] = p14; o[15] = p15;
        for (i = 1; i <= m; i++) {
            const double c = inv[i], *b = d[i - 1] + j;
            p0 = (p0 - b[0]) * c; p1 = (p1 - b[1]) * c; p2 = (p2 - b[2]) * c; p3 = (p3 - b[3]) * c;
            p4 = (p4 - b[4]) * c; p5 = (p5 - b[5]) * c; p6 = (p6 - b[6]) * c; p7 = (p7 - b[7]) * c;
            p8 = (p8 - b[8]) * c; p9 = (p9 - b[9]) * c; p10 = (p10 - b[10]) * c; p11 = (p11 - b[11]) * c;
            p12 = (p12 - b[12]) * c; p13 = (p13 - b[13]) * c; p14 = (p14 - b[14]) * c; p15 = (p15 - b[15]) * c;
            o = e[i] + j;
            o[0] = p0; o[1] = p1; o[2] = p2; o[3] = p3; o[4] = p4; o[5] = p5; o[6] = p6; o[7] = p7;
            o[8] = p8; o[9] = p9; o[10] = p10; o[11] = p11; o[12] = p12; o[13] = p13; o[14] = p14; o[15] = p15;
        }
    }
    for (; j + 8 <= n; j += 8) {
        double p0 = front[j], p1 = front[j + 1], p2 = front[j + 2], p3 = front[j + 3];
        double p4 = front[j + 4], p5 = front[j + 5], p6 = front[j + 6], p7 = front[j + 7];
        double *o = e[0] + j;
        o[0] = p0; o[1] = p1; o[2] = p2; o[3] = p3; o[4] = p4; o[5] = p5; o[6] = p6; o[7] = p7;
        for (i = 1; i <= m; i++) {
            const double c = inv[i], *b = d[i - 1] + j;
            p0 = (p0 - b[0]) * c; p1 = (p1 - b[1]) * c; p2 = (p2 - b[2]) * c; p3 = (p3 - b[3]) * c;
            p4 = (p4 - b[4]) * c; p5 = (p5 - b[5]) * c; p6 = (p6 - b[6]) * c; p7 = (p7 - b[7]) * c;
            o = e[i] + j;
            o[0] = p0; o[1] = p1; o[2] = p2; o[3] = p3; o[4] = p4; o[5] = p5; o[6] = p6; o[7] = p7;
        }
    }
    for (; j < n; j++) {
        double pj = front[j];
        e[0][j] = pj;
        for (i = 1; i <= m; i++) {
            pj = (pj - d[i - 1][j]) * inv[i];
            e[i][j] = pj;
        }
    }
}

/* The chain of divided differences of the points tt[0..nh) with values fv, into d[0 .. top] (top < nh: the higher
 * ones are not read before the chain is built again, see the chain with f_{n+1} in am_step). */
static void am_chain(am_mem *m, int n, int top)
{
    int i, j;
    for (i = 0; i <= top; i++) memcpy(m->d[i], m->fv[i], (size_t)n * sizeof(double));
    /* in place, column by column: after pass j, d[i] (j <= i <= top) holds f[tt[i-j], ..., tt[i]] */
    for (j = 1; j <= top; j++)
        for (i = top; i >= j; i--) {
            double dt = m->tt[i - j] - m->tt[i];
            am_divide(n, m->d[i - 1], m->d[i], dt, m->d[i]);
        }
}

/* Move the point arrays one place back (the oldest's memory to the front) and take (t, y, f) as the newest (f NULL:
 * the oldest's f holds it already, am_push_own). */
static void am_push(am_mem *m, int n, double t, const double *y, const double *f)
{
    double *fl = m->fv[ADAMS_NPOINT - 1], *yl = m->yv[ADAMS_NPOINT - 1];
    memmove(m->fv + 1, m->fv, (ADAMS_NPOINT - 1) * sizeof(double *));
    memmove(m->yv + 1, m->yv, (ADAMS_NPOINT - 1) * sizeof(double *));
    memmove(m->tt + 1, m->tt, (ADAMS_NPOINT - 1) * sizeof(double));
    m->fv[0] = fl; m->yv[0] = yl; m->tt[0] = t;
    if (f) memcpy(fl, f, (size_t)n * sizeof(double));
    memcpy(yl, y, (size_t)n * sizeof(double));
    if (m->nh < ADAMS_NPOINT) m->nh++;
}

/* am_push of an f the method evaluated into its own buffer *f: the buffer becomes the newest point's f, the oldest
 * point's memory the buffer (pointers exchanged instead of a copy). */
static void am_push_own(am_mem *m, int n, double t, const double *y, double **f)
{
    double *oldest = m->fv[ADAMS_NPOINT - 1];
    m->fv[ADAMS_NPOINT - 1] = *f;
    *f = oldest;
    am_push(m, n, t, y, NULL);
}

/* A fresh start from (o->t, o->y, o->f): order 1, phase 1. */
static void am_fresh(mbs_ode *o, am_mem *m)
{
    m->nh = 0;
    am_push(m, o->n, o->t, o->y, o->f);
    memcpy(m->d[0], o->f, (size_t)o->n * sizeof(double));
    m->k = 1; m->nconst = 0; m->phase1 = 1; m->nfail = 0;
    m->lip = HUGE_VAL; m->pec_age = 0;
    m->t_hist = o->t;
}

/* ode.c restarted the run at an event (o->t inside the last step or at its end, f of the new branch evaluated):
 * rebuild the history there as ADAMS_RESTART says (see the head of this file). */
static void am_restart(mbs_ode *o, am_mem *m)
{
    const int n = o->n;
    double te = o->t, gap = ADAMS_RESTART_GAP * o->h;
    int j, kept = 0, keep = ADAMS_RESTART == 2 ? m->k + 1 : ADAMS_NPOINT - 1;
    if (ADAMS_RESTART == 0 || !(m->nh > 0)) {
        double h = mbs_ode_initial_step(o, 2, m->scratch);
        am_fresh(o, m);
        if (h < o->h) o->h = h;
        return;
    }
    /* make place 0 free (the oldest point's memory goes there), then move the past points well before the event to
     * the places 1, 2, ..., newest first */
    {
        double *fl = m->fv[ADAMS_NPOINT - 1], *yl = m->yv[ADAMS_NPOINT - 1];
        int nh = m->nh < ADAMS_NPOINT ? m->nh : ADAMS_NPOINT - 1;
        memmove(m->fv + 1, m->fv, (ADAMS_NPOINT - 1) * sizeof(double *));
        memmove(m->yv + 1, m->yv, (ADAMS_NPOINT - 1) * sizeof(double *));
        memmove(m->tt + 1, m->tt, (ADAMS_NPOINT - 1) * sizeof(double));
        m->fv[0] = fl; m->yv[0] = yl;
        for (j = 1; j <= nh && kept < keep; j++) {
            double *fs, *ys;
            if (!(m->tt[j] < te - gap)) continue;
            kept++;  /* kept <= j: swap point j into place kept */
            fs = m->fv[kept]; ys = m->yv[kept];
            m->fv[kept] = m->fv[j]; m->yv[kept] = m->yv[j]; m->tt[kept] = m->tt[j];
            m->fv[j] = fs; m->yv[j] = ys;
            if (ADAMS_RESTART == 2 && mbs_ode_eval(o, m->tt[kept], m->yv[kept], m->fv[kept]) != MBS_OK) {
                kept--;  /* the new branch fails there: keep the points after it only */
                break;
            }
        }
    }
    m->tt[0] = te;
    memcpy(m->fv[0], o->f, (size_t)n * sizeof(double));
    memcpy(m->yv[0], o->y, (size_t)n * sizeof(double));
    m->nh = kept + 1;
    if (m->k > ADAMS_RESTART_ORDER) m->k = ADAMS_RESTART_ORDER;
    if (m->k > m->nh) m->k = m->nh;
    if (m->k < 1) m->k = 1;
    /* the first step reads D_0 .. D_k (D_k: its estimate of order k + 1) */
    am_chain(m, n, ADAMS_FULL_CHAIN || m->k > m->nh - 1 ? m->nh - 1 : m->k);
    m->nconst = 0;
    m->nfail = 0;
    m->phase1 = m->nh == 1;
    m->t_hist = te;
    m->lip = HUGE_VAL;  /* the new branch's L unknown: measured at the first step */
#ifdef MBS_ODE_TRACE
    fprintf(stderr, "AREST %.17g h %.17g k %d nh %d\n", te, o->h, m->k, m->nh);
#endif
}

/* ADAMS_PECE 2: evaluate f again at the accepted state? (see ADAMS_PEC_HL) */
static int am_wants_final(am_mem *m, double h_next, int k_next)
{
    if (h_next * m->lip > ADAMS_PEC_HL || k_next > ADAMS_PEC_ORDER || m->pec_age >= ADAMS_PEC_REFRESH) return 1;
    m->pec_age++;
    return 0;
}

/* L = ||f(y) - f_p|| / ||y - y_p||, unweighted (fnew: f(y); fp at yp): the Lipschitz constant along the
 * correction (the step's weights, unequal between the states, underestimated it on the damped oscillator) */
ADAMS_LANES_CALL static void am_measure_lip(am_mem *m, int n, const double *y)
{
    double num = 0.0, den = 0.0;
    int i = 0;
#if ADAMS_LANES
    {   /* four elements at a time, the two sums in lanes 0 and 1 of one vector, added element after element (the same
         * bits; lanes 2 and 3 repeat them) */
        const am_m4 front = {0, 4, 1, 5}, back = {2, 6, 3, 7}, first = {0, 1, 0, 1}, second = {2, 3, 2, 3};
        am_v4 s = {0.0, 0.0, 0.0, 0.0};
        for (; i + 4 <= n; i += 4) {
            am_v4 f1, f0, y1, y0, lo, hi;
            AM_LOAD4(f1, m->fnew + i); AM_LOAD4(f0, m->fp + i); AM_LOAD4(y1, y + i); AM_LOAD4(y0, m->yp + i);
            f1 -= f0; y1 -= y0;
            f1 *= f1; y1 *= y1;
            lo = __builtin_shuffle(f1, y1, front);  /* df0^2, dy0^2, df1^2, dy1^2 */
            hi = __builtin_shuffle(f1, y1, back);
            s += __builtin_shuffle(lo, first);
            s += __builtin_shuffle(lo, second);
            s += __builtin_shuffle(hi, first);
            s += __builtin_shuffle(hi, second);
        }
        num = s[0];
        den = s[1];
    }
#endif
    for (; i < n; i++) {
        const double df = m->fnew[i] - m->fp[i], dy = y[i] - m->yp[i];
        num += df * df;
        den += dy * dy;
    }
    m->lip = sqrt(num / den);
    if (!(m->lip <= HUGE_VAL)) m->lip = HUGE_VAL;  /* 0 / 0 */
#ifdef MBS_ODE_TRACE
    fprintf(stderr, "ALIP %.6g\n", m->lip);
#endif
    m->pec_age = 0;
}

static int am_step(mbs_ode *o)
{
    am_mem *m = o->impl;
    const int n = o->n;
    double *y = o->y;
    int i;
    if (o->t != m->t_hist || (o->t_old == o->t && o->naccept > 0)) am_restart(o, m);
    while (o->status == MBS_ODE_RUNNING) {
        double h, t = o->t, x0, r[ADAMS_KMAX + 3], a[ADAMS_KMAX + 3], err[ADAMS_KMAX + 3];
        int last, k, kmax_est, kmax_err, knew, s, final;
        if (mbs_ode_next_h(o, &h, &last)) break;
        k = m->k < m->nh ? m->k : m->nh;
        x0 = last ? o->t_bound : t + h;
        /* predict: the nodes t_n, t_{n-1}, ... in the unit of the step from t_n */
        for (i = 0; i < k; i++) r[i] = (m->tt[i] - t) / h;
        if (ADAMS_FULL_CHAIN) {
            am_integrals(r, k - 1, 1.0, h, a);
        } else {
            am_step_integrals(r, k - 1, h, a);
        }
        if (ADAMS_FULL_CHAIN) {
            memcpy(m->yp, y, (size_t)n * sizeof(double));
            for (i = k - 1; i >= 0; i--) am_axpy(n, a[i], m->d[i], m->yp);
        } else {
            am_combine(n, y, k - 1, a, (const double *const *)m->d, m->yp);
        }
        s = mbs_ode_eval(o, x0, m->yp, m->fp);
        /* the new chain with f_p: E_0 = f_p, E_i = (E_{i-1} - D_{i-1}) / (x0 - tt[i-1]), up to the estimate of order
         * k + 1 when the history has its k + 1 points */
        kmax_est = k + 1 <= m->nh ? k + 1 : k;
        if (s == MBS_OK) {
            if (ADAMS_FULL_CHAIN) {
                memcpy(m->e[0], m->fp, (size_t)n * sizeof(double));
                for (i = 1; i <= kmax_est; i++) am_divide(n, m->e[i - 1], m->d[i - 1], x0 - m->tt[i - 1], m->e[i]);
            } else {
                am_extend(n, m->fp, kmax_est, m->d, m->tt, x0, m->e);
            }
            /* correct: the nodes x0, t_n, t_{n-1}, ... */
            r[0] = 1.0;
            for (i = 1; i <= kmax_est; i++) r[i] = (m->tt[i - 1] - t) / h;
            if (ADAMS_FULL_CHAIN) {
                am_integrals(r, kmax_est, 1.0, h, a);
            } else {
                am_step_integrals(r, kmax_est, h, a);
            }
            if (ADAMS_FULL_CHAIN) {
                memcpy(m->yc, y, (size_t)n * sizeof(double));
                for (i = k; i >= 0; i--) am_axpy(n, a[i], m->e[i], m->yc);
            } else {
                am_combine(n, y, k, a, (const double *const *)m->e, m->yc);
            }
            /* the estimates the order control reads: k - 2 .. k, and k + 1 once the order may rise */
            kmax_err = ADAMS_FULL_CHAIN || (k < ADAMS_KMAX && kmax_est > k && m->nconst + 1 >= k + 1) ? kmax_est : k;
            if (ADAMS_FULL_CHAIN) {
                am_weights(o, y, m->yc, m->w);
                for (i = k >= 3 ? k - 2 : 1; i <= kmax_err; i++) err[i] = am_norm(n, a[i], m->e[i], m->w);
            } else {
                am_estimates(o, y, m->yc, k >= 3 ? k - 2 : 1, kmax_err, a, m->e, err);
            }
        }
        if (s != MBS_OK) {  /* the model failed inside the step: retry smaller (it may have left its domain) */
            o->h = h * MBS_ODE_MODEL_FAILURE_SHRINK;
            o->nreject++;
            m->nfail++;
            continue;
        }
#ifdef MBS_ODE_TRACE
        fprintf(stderr, "ADAMS %.17g %.17g %d %.6g %d nh %d\n", t, h, k, err[k], err[k] <= 1.0, m->nh);
#endif
        if (!(err[k] <= 1.0)) {  /* rejected */
            double fac = 0.5;
            o->nreject++;
            m->nfail++;
            m->phase1 = 0;
            if (k > 1 && err[k - 1] <= err[k]) { m->k = k - 1; m->nconst = 0; }
            if (m->nfail >= 3) {
                fac = fmin(0.5, fmax(0.25, sqrt(0.5 / err[k])));
                m->k = 1;
                m->nconst = 0;
            }
            o->h = h * fac;
            continue;
        }
        /* accepted: the dense output (the corrector's polynomial), then the history with f_{n+1}.  Its vectors are
         * read where the step leaves them, for the dense output is read (at the samples in the step, at its crossings)
         * before the next step only: y_n in the newest point's memory (yv[0] = y: am_push, am_restart), E_0 .. E_k in
         * the memory of the step's chain, which the next step's overwrites first (kept so below: the chain with
         * f_{n+1} goes to other memory).  Only one step in five or so needs it (the Iltis bump at 10 m/s); copied
         * into cont, the k + 2 vectors were 0.6 % of the whole simulate's instructions. */
        {
            double *c = o->cont;
            c[0] = k; c[1] = t; c[2] = h;
            for (i = 0; i <= k; i++) c[3 + i] = r[i];
            if (ADAMS_FULL_CHAIN) {  /* the former build: copied */
                c += 3 + ADAMS_KMAX + 2;
                memcpy(c, y, (size_t)n * sizeof(double));
                for (i = 0; i <= k; i++) memcpy(c + (size_t)(i + 1) * n, m->e[i], (size_t)n * sizeof(double));
                m->dense_y = c;
                for (i = 0; i <= k; i++) m->dense_e[i] = c + (size_t)(i + 1) * n;
            } else {
                m->dense_y = m->yv[0];
                for (i = 0; i <= k; i++) m->dense_e[i] = m->e[i];
            }
        }
        /* order and step of the next step (Shampine & Gordon) */
        knew = k;
        if (m->phase1) {
            if (err[k] * ldexp(1.0, k + 1) <= 0.5) {
                if (k < ADAMS_KMAX) knew = k + 1;
                o->h = 2.0 * h;
            } else {
                m->phase1 = 0;
            }
        }
        if (!m->phase1) {
            double ek, eta;
            if (k > 2 && fmax(err[k - 1], err[k - 2]) <= err[k]) knew = k - 1;
            else if (k == 2 && err[1] <= 0.5 * err[2]) knew = 1;
            else if (k < ADAMS_KMAX && kmax_est > k && m->nconst + 1 >= k + 1
                     && err[k + 1] < (k == 1 ? 0.5 : 1.0) * err[k]) knew = k + 1;
            ek = err[knew];
            eta = ADAMS_SAFE * pow(fmax(ek, 1e-10), -1.0 / (knew + 1));
            eta = fmin(ADAMS_MAX_GROWTH, fmax(0.5, eta));
            o->h = eta >= 1.0 && eta < ADAMS_HOLD ? h : h * eta;
        }
        if (knew != k) m->nconst = 0;
        else m->nconst++;
        m->k = knew;
        m->nfail = 0;
        /* f_{n+1} at the accepted state as projected (PECE), or f_p (PEC) */
        memcpy(y, m->yc, (size_t)n * sizeof(double));
        mbs_ode_accept(o, h, last);
        final = ADAMS_PECE == 1 || (ADAMS_PECE == 2 && am_wants_final(m, o->h, knew));
        if (final && mbs_ode_eval(o, o->t, y, m->fnew) != MBS_OK) {
            o->status = MBS_ODE_MODEL_FAILED;
            o->fail_h = h;
            break;
        }
        if (ADAMS_PECE == 2 && final) am_measure_lip(m, n, y);
        /* the chain with f_{n+1} in front: D'_0 = f_{n+1}, D'_i = (D'_{i-1} - D_{i-1}) / (x0 - tt[i-1]), up to the
         * highest difference the next step reads: it goes on at order knew at most, reading D_0 .. D_knew (the
         * predictor D_0 .. D_(knew-1), the estimate of order knew + 1 D_knew), and its own chain then needs the
         * differences below its new order, at most knew + 1; the differences above, stale, are never read (a restart
         * builds the chain afresh from the points, am_chain; tests/runtime/test_adams.py checks the bits) */
        {
            int top = m->nh < ADAMS_NPOINT ? m->nh : ADAMS_NPOINT - 1;
            if (!ADAMS_FULL_CHAIN && top > knew) top = knew;
            /* PEC: the step's chain with f_p is the new one, E_0 .. E_kmax_est built already (top <= kmax_est but
             * for the full chain); PECE: the chain with f_{n+1} built in the spare memory, the step's chain kept for
             * the dense output */
            double **chain = final && !ADAMS_FULL_CHAIN ? m->spare : m->e;
            if (final && !ADAMS_FULL_CHAIN) {
                am_extend(n, m->fnew, top, m->d, m->tt, x0, m->spare);
            } else {
                if (final) memcpy(m->e[0], m->fnew, (size_t)n * sizeof(double));
                for (i = final ? 1 : kmax_est + 1; i <= top; i++)
                    am_divide(n, m->e[i - 1], m->d[i - 1], x0 - m->tt[i - 1], m->e[i]);
            }
            for (i = 0; i <= top && i < ADAMS_NPOINT; i++) {
                double *tmp = m->d[i];
                m->d[i] = chain[i];
                chain[i] = tmp;
            }
        }
        if (ADAMS_FULL_CHAIN) am_push(m, n, x0, y, final ? m->fnew : m->fp);
        else am_push_own(m, n, x0, y, final ? &m->fnew : &m->fp);
        memcpy(o->f, m->fv[0], (size_t)n * sizeof(double));
        m->tt[0] = o->t;
        m->t_hist = o->t;
        break;
    }
    return o->status;
}

/* y(t) = y_n + sum_i E_i h^(i+1) integral from 0 to (t - t_n)/h of prod_{j<i} (u - r_j) du */
static void am_dense(const mbs_ode *o, double t, double *out)
{
    const am_mem *m = o->impl;
    const double *c = o->cont;
    const int n = o->n, k = (int)c[0];
    double h = c[2], a[ADAMS_KMAX + 3];
    int i;
    am_integrals(c + 3, k, (t - c[1]) / h, h, a);
    if (ADAMS_FULL_CHAIN) {
        memcpy(out, m->dense_y, (size_t)n * sizeof(double));
        for (i = k; i >= 0; i--) am_axpy(n, a[i], m->dense_e[i], out);
    } else {
        am_combine(n, m->dense_y, k, a, m->dense_e, out);
    }
}

/* The fill_cont hook: the dense output's vectors, read by am_dense where the step left them, copied after the
 * scalars into cont for a reader outside (runtime/integrators/adams.py AdamsDense), in cont's layout: y_n, E_0 .. E_k
 * (valid until the next step, as am_dense's). */
static void am_fill_cont(mbs_ode *o)
{
    const am_mem *m = o->impl;
    double *c = o->cont + 3 + ADAMS_KMAX + 2;
    const int n = o->n, k = (int)o->cont[0];
    int i;
    if (ADAMS_FULL_CHAIN || o->naccept == 0) return;  /* copied by the step already; no step yet */
    memcpy(c, m->dense_y, (size_t)n * sizeof(double));
    for (i = 0; i <= k; i++) memcpy(c + (size_t)(i + 1) * n, m->dense_e[i], (size_t)n * sizeof(double));
}

/* The take_over hook (ode.c mbs_ode_take_over): the history of the solver that handed its event back, rebuilt at the
 * event by the first step as after a restart in C. */
static void am_take_over(mbs_ode *to, const mbs_ode *from)
{
    am_mem *m = to->impl;
    const am_mem *was = from->impl;
    int j;
    for (j = 0; j < was->nh; j++) {
        memcpy(m->fv[j], was->fv[j], (size_t)to->n * sizeof(double));
        memcpy(m->yv[j], was->yv[j], (size_t)to->n * sizeof(double));
        m->tt[j] = was->tt[j];
    }
    m->nh = was->nh;
    m->k = was->k;
    m->t_hist = NAN;
}

/* Set up an Adams run; h0 <= 0 chooses the first step automatically.  Returns 0 or -1 (no memory). */
static int mbs_adams_init(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0, const double *y0,
                          double t_bound, double rtol, const double *atol, int natol, double h0, double h_max,
                          double h_min, long max_steps)
{
    am_mem *m;
    double *a;
    int j;
    /* cont: order, t_n, h, the nodes (up to KMAX + 2), y_n and up to KMAX + 2 difference vectors (those written by
     * am_fill_cont when read from outside, see the dense output in am_step) */
    if (mbs_ode_setup(o, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps,
                      3 + ADAMS_KMAX + 2 + (size_t)(ADAMS_KMAX + 3) * (size_t)n)) return -1;
    m = calloc(1, sizeof(am_mem) + ((5 * ADAMS_NPOINT + 1 + 7) * (size_t)n + 1) * sizeof(double));
    if (!m) return -1;
    o->impl = m;
    a = (double *)(m + 1);
    for (j = 0; j < ADAMS_NPOINT; j++) {
        m->d[j] = a; a += n;
        m->fv[j] = a; a += n;
        m->yv[j] = a; a += n;
        m->spare[j] = a; a += n;
    }
    for (j = 0; j <= ADAMS_NPOINT; j++) { m->e[j] = a; a += n; }
    m->yp = a; a += n;
    m->fp = a; a += n;
    m->yc = a; a += n;
    m->w = a; a += n;
    m->fnew = a; a += n;  /* f_{n+1} */
    m->scratch = a;  /* 2n: the initial step's scratch */
    o->step = am_step;
    o->dense = am_dense;
    o->take_over = am_take_over;
    o->fill_cont = am_fill_cont;
    am_fresh(o, m);
    if (o->h <= 0 && o->status == MBS_ODE_RUNNING) o->h = mbs_ode_initial_step(o, 2, m->scratch);
    return 0;
}
