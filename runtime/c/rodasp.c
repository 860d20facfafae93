/* RODASP: L-stable, stiffly accurate Rosenbrock method of order 4(3) with six stages, for stiff models
 * (tyre contact, stiff bushings).
 *
 * The scheme and step control are those of RODAS (E. Hairer, G. Wanner, Solving Ordinary Differential
 * Equations II, IV.7, and the authors' rodas.f), in the form that needs no matrix-vector products:
 *     (1/(h gamma) I - J) k_i = f(t + c_i h, y + sum_j a_ij k_j) + sum_j (c_ij / h) k_j + h d_i df/dt
 *     y1 = y + sum_j a_5j k_j + k_5 + k_6,   error estimate k_6.
 * The coefficients are G. Steinebach's RODASP (1995), transformed to that form.  RODASP keeps order 4
 * on stiff problems driven by a time-dependent input (Prothero-Robinson type), where RODAS's original
 * coefficients lose order: on tests/runtime/fixtures/quarter_car.c (a stiff tyre on a road profile)
 * RODAS needed 30 times more steps than RODASP at rtol = 1e-6.
 *
 * The Jacobian J and df/dt come from the generated mbs_jacobian when the model has one (o->jac: exact,
 * one call), else from finite differences (n + 1 calls); refreshed after every accepted step and reused
 * after a rejection.  With closed loops (o->project set) the right-hand side contains the loop solver's
 * Newton iteration, whose stopping tolerance (~1e-12) is noise to a finite difference: one-sided differences
 * with steps of sqrt(eps) then carry Jacobian errors of ~1e-4, and a Rosenbrock method, whose order
 * conditions assume the exact Jacobian, loses its order (on the Iltis quarter car at rtol 1e-12: 188,550
 * steps against dopri5's 5,986, 46,000 rejected).  Central differences with steps of 1e-5 (error ~1e-9)
 * restore it (72,090 steps, 1,267 rejected), at 2n + 2 evaluations per Jacobian.  The iteration matrix
 * is factored by dense LU (dense_lu.c).  Dense output is the cubic Hermite interpolant through (y0, f0)
 * and (y1, f1): order 3, C1 across steps, and f1 is needed by the next step anyway.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "mbs_runtime.h"

static const double RO_GAMMA = 0.25;
static const double RO_C2 = 0.75, RO_C3 = 0.21, RO_C4 = 0.63;
static const double RO_D1 = 0.25, RO_D2 = -0.5, RO_D3 = -0.023504, RO_D4 = -0.0362;
static const double RO_A21 = 3.0;
static const double RO_A31 = 1.831036793486783, RO_A32 = 0.4955183967433913;
static const double RO_A41 = 2.304376582692643, RO_A42 = -0.0524927524574442, RO_A43 = -1.1767987618327667;
static const double RO_A51 = -7.170454962423416, RO_A52 = -4.741636671481976, RO_A53 = -16.310026313309727,
                    RO_A54 = -1.0620040441113985;
static const double RO_C21 = -12.0;
static const double RO_C31 = -8.791795173947135, RO_C32 = -2.2078655869735657;
static const double RO_C41 = 10.81793056857202, RO_C42 = 6.780270611428506, RO_C43 = 19.534859446424054;
static const double RO_C51 = 34.19095006749805, RO_C52 = 15.49671153726025, RO_C53 = 54.74760875964147,
                    RO_C54 = 14.16005392148532;
static const double RO_C61 = 34.626058309306686, RO_C62 = 15.300849761145368, RO_C63 = 56.99955578662688,
                    RO_C64 = 18.408070097930906, RO_C65 = -40.0 / 7;

#define RO_SAFE 0.9
#define RO_FAC_MIN (1.0 / 6)  /* h_new >= h/6 ... */
#define RO_FAC_MAX 6.0        /* ... and h_new <= 6 h (rodas.f: FAC1 = 0.2, FAC2 = 6) */
#define RO_FAC_SHRINK 5.0     /* a rejected step shrinks by at most 5 */
#define RO_FIRST_REJECT 0.1   /* a rejected first step: the initial guess was far off */
#define RO_SINGULAR_SHRINK 0.5
#define RO_MAX_SINGULAR 5     /* give up after this many singular iteration matrices in a row */

typedef struct {
    double hacc, erracc;  /* last accepted step and error, for Gustafsson's predictive controller */
    int reject, need_jac, nsing;
    int *piv;
    double *jac, *lu, *k1, *k2, *k3, *k4, *k5, *k6, *ynew, *dy, *fx;
} ro_mem;

/* f at the projection of y (closed loops): the Jacobian by differences is then that of f after the projection,
 * as the generated one (runtime/c/loop_jacobian.c).  f itself, which the stages evaluate without projection,
 * bends off the constraints by the inverse square of the distance from a singular position (a four-bar near
 * flat), so that its own differences there would be of no use to the method. */
static int ro_eval_projected(mbs_ode *o, double t, const double *y, double *out)
{
    if (o->project(t, y, o->p, o->yproj, o->work) != MBS_OK) return -1;
    return mbs_ode_eval(o, t, o->yproj, out);
}

/* J = d f/d y (n x n) and fx = d f/d t at (t, y), into m->jac (rows of n + 1: the time derivative is the last
 * column, the layout of the generated mbs_jacobian).  The generated Jacobian when the model has one; finite
 * differences when it has none or it fails (its status is then remembered for the failure message). */
static int ro_jacobian(mbs_ode *o, ro_mem *m)
{
    const int n = o->n, w = n + 1;
    double *y = o->y;
    double delt;
    int i, j;
    o->njev++;
    if (o->jac && o->jac(o->t, y, o->p, m->jac, o->work) == MBS_OK) {
        for (i = 0; i < n; i++) m->fx[i] = m->jac[i * w + n];
        return 0;
    }
    if (o->project) {  /* closed loops: central differences, see the file comment */
        for (j = 0; j < n; j++) {
            double ysafe = y[j];
            delt = 1e-5 * fmax(1.0, fabs(ysafe));
            y[j] = ysafe + delt;
            if (ro_eval_projected(o, o->t, y, m->dy) != MBS_OK) { y[j] = ysafe; return -1; }
            y[j] = ysafe - delt;
            if (ro_eval_projected(o, o->t, y, m->k6) != MBS_OK) { y[j] = ysafe; return -1; }
            y[j] = ysafe;
            for (i = 0; i < n; i++) m->jac[i * w + j] = (m->dy[i] - m->k6[i]) / (2 * delt);
        }
    } else
    for (j = 0; j < n; j++) {
        double ysafe = y[j];
        delt = sqrt(DBL_EPSILON * fmax(1e-5, fabs(ysafe)));
        y[j] = ysafe + delt;
        if (mbs_ode_eval(o, o->t, y, m->dy) != MBS_OK) {  /* try the other side of y_j */
            delt = -delt;
            y[j] = ysafe + delt;
            if (mbs_ode_eval(o, o->t, y, m->dy) != MBS_OK) { y[j] = ysafe; return -1; }
        }
        y[j] = ysafe;
        for (i = 0; i < n; i++) m->jac[i * w + j] = (m->dy[i] - o->f[i]) / delt;
    }
    if (o->project) {
        delt = 1e-5 * fmax(1.0, fabs(o->t));
        if (mbs_ode_eval(o, o->t + delt, y, m->dy) != MBS_OK) return -1;
        if (mbs_ode_eval(o, o->t - delt, y, m->k6) != MBS_OK) return -1;
        for (i = 0; i < n; i++) m->fx[i] = (m->dy[i] - m->k6[i]) / (2 * delt);
        return 0;
    }
    delt = sqrt(DBL_EPSILON * fmax(1e-5, fabs(o->t)));
    if (mbs_ode_eval(o, o->t + delt, y, m->dy) != MBS_OK) {
        delt = -delt;
        if (mbs_ode_eval(o, o->t + delt, y, m->dy) != MBS_OK) return -1;
    }
    for (i = 0; i < n; i++) m->fx[i] = (m->dy[i] - o->f[i]) / delt;
    return 0;
}

/* One stage: k = (1/(h gamma) I - J)^-1 (dy + sum_j cs[j]/h k_j + h d fx). */
static void ro_stage(const mbs_ode *o, ro_mem *m, double h, double d, int nk, const double *cs,
                     double *const *ks, double *k)
{
    int i, j;
    for (i = 0; i < o->n; i++) {
        double s = m->dy[i] + h * d * m->fx[i];
        for (j = 0; j < nk; j++) s += cs[j] / h * ks[j][i];
        k[i] = s;
    }
    mbs_lu_solve(o->n, m->lu, m->piv, k);
}

static int ro_step(mbs_ode *o)
{
    ro_mem *m = o->impl;
    const int n = o->n;
    double *y = o->y;
    double *const ks[5] = {m->k1, m->k2, m->k3, m->k4, m->k5};
    int i, j;
    while (o->status == MBS_ODE_RUNNING) {
        double h, t = o->t, err, fac, h_new;
        int last, s = MBS_OK;
        if (m->need_jac) {
            if (ro_jacobian(o, m)) { o->fail_h = o->h; o->status = MBS_ODE_MODEL_FAILED; break; }
            m->need_jac = 0;
        }
        if (mbs_ode_next_h(o, &h, &last)) break;
        for (i = 0; i < n; i++) {
            for (j = 0; j < n; j++) m->lu[i * n + j] = -m->jac[i * (n + 1) + j];
            m->lu[i * n + i] += 1.0 / (h * RO_GAMMA);
        }
        o->nlu++;
        if (mbs_lu_factor(n, m->lu, m->piv)) {
            o->h = h * RO_SINGULAR_SHRINK;
            o->nreject++;
            m->reject = 1;
            if (++m->nsing >= RO_MAX_SINGULAR) { o->fail_h = h; o->status = MBS_ODE_SINGULAR; }
            continue;
        }
        m->nsing = 0;
        {
            const double c2[] = {RO_C21}, c3[] = {RO_C31, RO_C32}, c4[] = {RO_C41, RO_C42, RO_C43},
                                c5[] = {RO_C51, RO_C52, RO_C53, RO_C54},
                                c6[] = {RO_C61, RO_C62, RO_C63, RO_C64, RO_C65};
            for (i = 0; i < n; i++) m->dy[i] = o->f[i];
            ro_stage(o, m, h, RO_D1, 0, NULL, ks, m->k1);
            for (i = 0; i < n; i++) m->ynew[i] = y[i] + RO_A21 * m->k1[i];
            s = mbs_ode_eval(o, t + RO_C2 * h, m->ynew, m->dy);
            if (s == MBS_OK) {
                ro_stage(o, m, h, RO_D2, 1, c2, ks, m->k2);
                for (i = 0; i < n; i++) m->ynew[i] = y[i] + RO_A31 * m->k1[i] + RO_A32 * m->k2[i];
                s = mbs_ode_eval(o, t + RO_C3 * h, m->ynew, m->dy);
            }
            if (s == MBS_OK) {
                ro_stage(o, m, h, RO_D3, 2, c3, ks, m->k3);
                for (i = 0; i < n; i++)
                    m->ynew[i] = y[i] + RO_A41 * m->k1[i] + RO_A42 * m->k2[i] + RO_A43 * m->k3[i];
                s = mbs_ode_eval(o, t + RO_C4 * h, m->ynew, m->dy);
            }
            if (s == MBS_OK) {
                ro_stage(o, m, h, RO_D4, 3, c4, ks, m->k4);
                for (i = 0; i < n; i++)
                    m->ynew[i] = y[i] + RO_A51 * m->k1[i] + RO_A52 * m->k2[i] + RO_A53 * m->k3[i]
                                 + RO_A54 * m->k4[i];
                s = mbs_ode_eval(o, t + h, m->ynew, m->dy);
            }
            if (s == MBS_OK) {
                ro_stage(o, m, h, 0.0, 4, c5, ks, m->k5);
                for (i = 0; i < n; i++) m->ynew[i] += m->k5[i];  /* embedded 3rd-order solution */
                s = mbs_ode_eval(o, t + h, m->ynew, m->dy);
            }
            if (s == MBS_OK) {
                ro_stage(o, m, h, 0.0, 5, c6, ks, m->k6);
                for (i = 0; i < n; i++) m->ynew[i] += m->k6[i];
                /* f at the new point: the interpolant needs it and so does the next step.  It is
                 * not part of the error estimate, so check here that it is finite. */
                s = mbs_ode_eval(o, t + h, m->ynew, m->dy);
                for (i = 0; i < n && s == MBS_OK; i++)
                    if (!isfinite(m->dy[i])) s = -1;
            }
        }
        if (s != MBS_OK) {
            o->h = h * MBS_ODE_MODEL_FAILURE_SHRINK;
            o->nreject++;
            m->reject = 1;
            continue;
        }
        err = mbs_ode_error_norm(o, m->k6, y, m->ynew);
        fac = fmax(1.0 / RO_FAC_MAX, fmin(RO_FAC_SHRINK, pow(err, 0.25) / RO_SAFE));
        h_new = h / fac;
        if (err <= 1.0) {
            double *c = o->cont;
            if (o->naccept > 0) {  /* Gustafsson: also look at the trend of the error */
                double facgus = (m->hacc / h) * pow(err * err / m->erracc, 0.25) / RO_SAFE;
                facgus = fmax(1.0 / RO_FAC_MAX, fmin(RO_FAC_SHRINK, facgus));
                h_new = h / fmax(fac, facgus);
            }
            m->hacc = h;
            m->erracc = fmax(1e-2, err);
            for (i = 0; i < n; i++) {
                c[i] = y[i];
                c[n + i] = m->ynew[i];
                c[2 * n + i] = h * o->f[i];
                c[3 * n + i] = h * m->dy[i];
                y[i] = m->ynew[i];
                o->f[i] = m->dy[i];
            }
            c[4 * n] = h;
            if (m->reject) h_new = fmin(h_new, h);
            m->reject = 0;
            m->need_jac = 1;
            o->h = h_new;
            mbs_ode_accept(o, h, last);
            break;
        }
        o->h = o->naccept == 0 ? h * RO_FIRST_REJECT : h_new;
        o->nreject++;
        m->reject = 1;
    }
    return o->status;
}

/* Cubic Hermite interpolation through (y0, h f0) and (y1, h f1). */
static void ro_dense(const mbs_ode *o, double t, double *out)
{
    const double *c = o->cont;
    const int n = o->n;
    double s = (t - o->t_old) / c[4 * n], s2 = s * s, s3 = s2 * s;
    double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
    int i;
    for (i = 0; i < n; i++) out[i] = h00 * c[i] + h01 * c[n + i] + h10 * c[2 * n + i] + h11 * c[3 * n + i];
}

/* Set up a RODASP run; h0 <= 0 chooses the first step automatically.  Returns 0 or -1 (no memory). */
static int mbs_rodasp_init(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0,
                           const double *y0, double t_bound, double rtol, const double *atol, int natol,
                           double h0, double h_max, double h_min, long max_steps)
{
    ro_mem *m;
    double *a;
    size_t nn = (size_t)n * (size_t)n;
    if (mbs_ode_setup(o, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps,
                      4 * (size_t)n + 1)) return -1;
    m = calloc(1, sizeof(ro_mem) + (2 * nn + 10 * (size_t)n + 1) * sizeof(double) + ((size_t)n + 1) * sizeof(int));
    if (!m) return -1;
    o->impl = m;
    a = (double *)(m + 1);
    m->jac = a; m->lu = a + nn + n; a += 2 * nn + n;  /* jac: n rows of n + 1 */
    m->k1 = a; m->k2 = a + n; m->k3 = a + 2 * n; m->k4 = a + 3 * n; m->k5 = a + 4 * n; m->k6 = a + 5 * n;
    m->ynew = a + 6 * n; m->dy = a + 7 * n; m->fx = a + 8 * n;
    m->piv = (int *)(a + 9 * n);
    m->need_jac = 1;
    o->step = ro_step;
    o->dense = ro_dense;
    if (o->h <= 0 && o->status == MBS_ODE_RUNNING) o->h = mbs_ode_initial_step(o, 4, m->k1);
    return 0;
}
