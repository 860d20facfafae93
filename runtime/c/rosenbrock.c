/* The Rosenbrock engine shared by rodasp.c and rodas5p.c: one step of a stiffly accurate Rosenbrock method given
 * by its coefficients, the Jacobian, the iteration matrix and the step-size control.  A method file holds its
 * coefficients (an ro_method), its dense output and its init function, nothing else.
 *
 * The methods are written in the form of E. Hairer and G. Wanner, Solving Ordinary Differential Equations II,
 * IV.7 (the authors' rodas.f), which needs no matrix-vector products:
 *     (1/(h gamma) I - J) k_i = f(t + c_i h, u_i) + sum_{j<i} (C_ij / h) k_j + h d_i df/dt,
 *     u_i = y + sum_{j<i} a_ij k_j for the first `na` stages, u_i = u_{i-1} + k_{i-1} after them,
 *     y1 = u_s + k_s, error estimate k_s (y1 minus the embedded solution u_s).
 * Every RODAS-type method (RODAS, RODASP, RODAS5, Rodas5P) has this shape: its last stages only correct the
 * solution, which makes both y1 and the embedded u_s stiffly accurate (L-stable).
 *
 * The Jacobian J and df/dt come from the generated mbs_jacobian when the model has one (o->jac: exact, one
 * call), else from finite differences (n + 1 calls); refreshed after every accepted step and reused after a
 * rejection.  With closed loops (o->project set) the right-hand side contains the loop solver's Newton
 * iteration, whose stopping tolerance (~1e-12) is noise to a finite difference: one-sided differences with
 * steps of sqrt(eps) then carry Jacobian errors of ~1e-4, and a Rosenbrock method, whose order conditions
 * assume the exact Jacobian, loses its order (RODASP on the Iltis quarter car at rtol 1e-12: 188,550 steps
 * against dopri5's 5,986, 46,000 rejected).  Central differences with steps of 1e-5 (error ~1e-9) restore it
 * (72,090 steps, 1,267 rejected), at 2n + 2 evaluations per Jacobian.  The iteration matrix is factored by
 * dense LU (dense_lu.c).
 *
 * Step control: the error estimate of a method whose embedded solution has order q is O(h^(q+1)), so
 * h_new = h / fac with fac = err^(1/(q+1)) / SAFE, and after an accepted step also Gustafsson's predictive
 * controller (rodas.f's PRED = 1), which looks at the trend of the error between the last two accepted steps.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "mbs_runtime.h"

#define RO_MAX_STAGES 8
#define RO_SAFE 0.9
#define RO_FAC_MIN (1.0 / 6)  /* h_new >= h/6 ... */
#define RO_FAC_MAX 6.0        /* ... and h_new <= 6 h (rodas.f: FAC1 = 0.2, FAC2 = 6) */
#define RO_FAC_SHRINK 5.0     /* a rejected step shrinks by at most 5 */
#define RO_FIRST_REJECT 0.1   /* a rejected first step: the initial guess was far off */
#define RO_SINGULAR_SHRINK 0.5
#define RO_MAX_SINGULAR 5     /* give up after this many singular iteration matrices in a row */

typedef struct ro_mem ro_mem;

/* A stiffly accurate Rosenbrock method in the form above.  Arrays of `stages` (c, d) and stages x stages,
 * row-major, lower triangle used (a: rows 1 .. na - 1; C: rows 1 .. stages - 1). */
typedef struct {
    int stages, na;
    int order;              /* of y1; the embedded solution has order - 1 */
    double gamma;
    const double *c, *d, *a, *C;
    /* dense-output coefficients of the accepted step [t, t + h] into o->cont, from y0 = o->y, f0 = o->f (still
     * those of the step's start), the stages k[0 .. stages), y1 and f1 = f(t + h, y1) */
    void (*cont)(mbs_ode *o, const ro_mem *m, double h, const double *y1, const double *f1);
    int ncont;              /* o->cont holds ncont n + 1 doubles (the last: h) */
    void (*dense)(const mbs_ode *, double t, double *out);  /* the o->dense hook */
} ro_method;

struct ro_mem {
    const ro_method *method;
    double hacc, erracc;  /* last accepted step and error, for Gustafsson's predictive controller */
    int reject, need_jac, nsing;
    int *piv;
    double *jac, *lu, *k[RO_MAX_STAGES], *ynew, *dy, *fx, *tmp;
    double *jac_try;      /* where the generated Jacobian is written: swapped with jac when it succeeds */
    int have_exact;       /* jac holds a generated Jacobian (of an earlier step when the last call failed) */
};

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
    if (o->jac) {
        int status = o->jac(o->t, y, o->p, m->jac_try, o->work);
        if (status == MBS_OK) {
            double *swap = m->jac;
            m->jac = m->jac_try;
            m->jac_try = swap;
            m->have_exact = 1;
            for (i = 0; i < n; i++) m->fx[i] = m->jac[i * w + n];
            return 0;
        }
        /* closed loops near a singular position (the generated Jacobian does not differentiate the limit rows
         * there): the last generated Jacobian, of an accepted state a step before, rather than differences of
         * the projecting f, whose perturbed states may be projected onto the other branch of the motion through
         * the position (the 40-four-bar chain: rodas5p stalled at a flat crossing, step 4.5e-9 s) */
        if (status == MBS_SINGULAR_MASS && o->project && m->have_exact) return 0;
    }
    if (o->project) {  /* closed loops: central differences, see the file comment */
        for (j = 0; j < n; j++) {
            double ysafe = y[j];
            delt = 1e-5 * fmax(1.0, fabs(ysafe));
            y[j] = ysafe + delt;
            if (mbs_ode_eval(o, o->t, y, m->dy) != MBS_OK) { y[j] = ysafe; return -1; }
            y[j] = ysafe - delt;
            if (mbs_ode_eval(o, o->t, y, m->tmp) != MBS_OK) { y[j] = ysafe; return -1; }
            y[j] = ysafe;
            for (i = 0; i < n; i++) m->jac[i * w + j] = (m->dy[i] - m->tmp[i]) / (2 * delt);
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
        if (mbs_ode_eval(o, o->t - delt, y, m->tmp) != MBS_OK) return -1;
        for (i = 0; i < n; i++) m->fx[i] = (m->dy[i] - m->tmp[i]) / (2 * delt);
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

/* Stage i: k_i = (1/(h gamma) I - J)^-1 (dy + sum_{j<i} C_ij/h k_j + h d_i fx). */
static void ro_stage(const mbs_ode *o, ro_mem *m, double h, int i)
{
    const ro_method *r = m->method;
    const double *C = r->C + i * r->stages;
    double *k = m->k[i], hd = h * r->d[i];
    int l, j;
    for (l = 0; l < o->n; l++) {
        double s = m->dy[l] + hd * m->fx[l];
        for (j = 0; j < i; j++) s += C[j] / h * m->k[j][l];
        k[l] = s;
    }
    mbs_lu_solve(o->n, m->lu, m->piv, k);
}

/* The stages of one attempt of size h from (t, y): ynew = y1, dy = f(t + h, y1), k[stages - 1] the error
 * estimate.  Returns MBS_OK or the model's status (a failure inside the step; non-finite f1 counts). */
static int ro_stages(mbs_ode *o, ro_mem *m, double h)
{
    const ro_method *r = m->method;
    const int n = o->n, s = r->stages;
    const double *y = o->y, t = o->t;
    int i, j, l, st = MBS_OK;
    for (l = 0; l < n; l++) m->dy[l] = o->f[l];
    ro_stage(o, m, h, 0);
    for (i = 1; i < s; i++) {
        if (i < r->na) {
            const double *a = r->a + i * s;
            for (l = 0; l < n; l++) {
                double u = y[l];
                for (j = 0; j < i; j++) u += a[j] * m->k[j][l];
                m->ynew[l] = u;
            }
        } else {
            for (l = 0; l < n; l++) m->ynew[l] += m->k[i - 1][l];
        }
        if ((st = mbs_ode_eval(o, t + r->c[i] * h, m->ynew, m->dy)) != MBS_OK) return st;
        ro_stage(o, m, h, i);
    }
    for (l = 0; l < n; l++) m->ynew[l] += m->k[s - 1][l];
    /* f at the new point: the next step starts with it and the dense output may use it.  It is not part of
     * the error estimate, so check here that it is finite. */
    if ((st = mbs_ode_eval(o, t + h, m->ynew, m->dy)) != MBS_OK) return st;
    for (l = 0; l < n; l++)
        if (!isfinite(m->dy[l])) return MBS_NONFINITE;
    return MBS_OK;
}

/* One accepted step (or a failure): the o->step hook of every method built on this engine. */
static int ro_step(mbs_ode *o)
{
    ro_mem *m = o->impl;
    const ro_method *r = m->method;
    const int n = o->n;
    const double expo = 1.0 / r->order;  /* the error estimate is O(h^order) */
    int i, j;
    while (o->status == MBS_ODE_RUNNING) {
        double h, err, fac, h_new;
        int last;
        if (m->need_jac) {
            if (ro_jacobian(o, m)) { o->fail_h = o->h; o->status = MBS_ODE_MODEL_FAILED; break; }
            m->need_jac = 0;
        }
        if (mbs_ode_next_h(o, &h, &last)) break;
        for (i = 0; i < n; i++) {
            for (j = 0; j < n; j++) m->lu[i * n + j] = -m->jac[i * (n + 1) + j];
            m->lu[i * n + i] += 1.0 / (h * r->gamma);
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
        if (ro_stages(o, m, h) != MBS_OK) {
            o->h = h * MBS_ODE_MODEL_FAILURE_SHRINK;
            o->nreject++;
            m->reject = 1;
            continue;
        }
        err = mbs_ode_error_norm(o, m->k[r->stages - 1], o->y, m->ynew);
        fac = fmax(1.0 / RO_FAC_MAX, fmin(RO_FAC_SHRINK, pow(err, expo) / RO_SAFE));
        h_new = h / fac;
        if (err <= 1.0) {
            if (o->naccept > 0) {  /* Gustafsson: also look at the trend of the error */
                double facgus = (m->hacc / h) * pow(err * err / m->erracc, expo) / RO_SAFE;
                facgus = fmax(1.0 / RO_FAC_MAX, fmin(RO_FAC_SHRINK, facgus));
                h_new = h / fmax(fac, facgus);
            }
            m->hacc = h;
            m->erracc = fmax(1e-2, err);
            r->cont(o, m, h, m->ynew, m->dy);
            for (i = 0; i < n; i++) {
                o->y[i] = m->ynew[i];
                o->f[i] = m->dy[i];
            }
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

/* Set up a run of `method`: the shared arrays (mbs_ode_setup) with its dense output, the engine's memory, and
 * the first step when h0 <= 0.  Returns 0 or -1 (no memory). */
static int ro_init(mbs_ode *o, const ro_method *method, int n, mbs_fn fn, const double *p, double *work, double t0,
                   const double *y0, double t_bound, double rtol, const double *atol, int natol, double h0,
                   double h_max, double h_min, long max_steps)
{
    ro_mem *m;
    double *a;
    size_t nn = (size_t)n * (size_t)n, nk = (size_t)method->stages * (size_t)n;
    int i;
    if (mbs_ode_setup(o, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps,
                      (size_t)method->ncont * (size_t)n + 1)) return -1;
    m = calloc(1, sizeof(ro_mem) + (3 * nn + nk + 6 * (size_t)n + 1) * sizeof(double)
                  + ((size_t)n + 1) * sizeof(int));
    if (!m) return -1;
    o->impl = m;
    m->method = method;
    a = (double *)(m + 1);
    m->jac = a; m->lu = a + nn + n; a += 2 * nn + n;  /* jac: n rows of n + 1 */
    m->jac_try = a; a += nn + n;
    for (i = 0; i < method->stages; i++) m->k[i] = a + (size_t)i * n;
    a += nk;
    m->ynew = a; m->dy = a + n; m->fx = a + 2 * n; m->tmp = a + 3 * n;
    m->piv = (int *)(a + 4 * n);
    m->need_jac = 1;
    o->step = ro_step;
    o->dense = method->dense;
    if (o->h <= 0 && o->status == MBS_ODE_RUNNING) o->h = mbs_ode_initial_step(o, method->order, m->k[0]);
    return 0;
}
