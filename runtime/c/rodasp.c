/* RODASP: L-stable, stiffly accurate Rosenbrock method of order 4(3) with six stages, for stiff models
 * (tyre contact, stiff bushings).  The coefficients for the engine in rosenbrock.c (the form, the Jacobian,
 * the step control) and the dense output.
 *
 * The coefficients are G. Steinebach's RODASP (1995), transformed to the form of RODAS (E. Hairer, G. Wanner,
 * Solving Ordinary Differential Equations II, IV.7, and the authors' rodas.f).  RODASP keeps order 4 on stiff
 * problems driven by a time-dependent input (Prothero-Robinson type), where RODAS's original coefficients
 * lose order: on tests/runtime/fixtures/quarter_car.c (a stiff tyre on a road profile) RODAS needed 30 times
 * more steps than RODASP at rtol = 1e-6.  Dense output is the cubic Hermite interpolant through (y0, f0) and
 * (y1, f1): order 3, C1 across steps, and f1 is needed by the next step anyway.
 */
#include "mbs_runtime.h"

/* 6 stages (rows and columns from 0): a for the inputs of stages 1-4, stage 5's is u4 + k4; C: rows 1-5. */
static const double RO_P_C[6] = {0.0, 0.75, 0.21, 0.63, 1.0, 1.0};
static const double RO_P_D[6] = {0.25, -0.5, -0.023504, -0.0362, 0.0, 0.0};
static const double RO_P_A[36] = {
    0, 0, 0, 0, 0, 0,
    3.0, 0, 0, 0, 0, 0,
    1.831036793486783, 0.4955183967433913, 0, 0, 0, 0,
    2.304376582692643, -0.0524927524574442, -1.1767987618327667, 0, 0, 0,
    -7.170454962423416, -4.741636671481976, -16.310026313309727, -1.0620040441113985, 0, 0,
    0, 0, 0, 0, 0, 0};
static const double RO_P_CC[36] = {
    0, 0, 0, 0, 0, 0,
    -12.0, 0, 0, 0, 0, 0,
    -8.791795173947135, -2.2078655869735657, 0, 0, 0, 0,
    10.81793056857202, 6.780270611428506, 19.534859446424054, 0, 0, 0,
    34.19095006749805, 15.49671153726025, 54.74760875964147, 14.16005392148532, 0, 0,
    34.626058309306686, 15.300849761145368, 56.99955578662688, 18.408070097930906, -40.0 / 7, 0};

/* Dense output: y0, y1, h f0, h f1 and h (the cubic Hermite interpolant below). */
static void rodasp_cont(mbs_ode *o, const ro_mem *m, double h, const double *y1, const double *f1)
{
    double *c = o->cont;
    const int n = o->n;
    int i;
    (void)m;
    for (i = 0; i < n; i++) {
        c[i] = o->y[i];
        c[n + i] = y1[i];
        c[2 * n + i] = h * o->f[i];
        c[3 * n + i] = h * f1[i];
    }
    c[4 * n] = h;
}

/* Cubic Hermite interpolation through (y0, h f0) and (y1, h f1). */
static void rodasp_dense(const mbs_ode *o, double t, double *out)
{
    const double *c = o->cont;
    const int n = o->n;
    double s = (t - o->t_old) / c[4 * n], s2 = s * s, s3 = s2 * s;
    double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
    int i;
    for (i = 0; i < n; i++) out[i] = h00 * c[i] + h01 * c[n + i] + h10 * c[2 * n + i] + h11 * c[3 * n + i];
}

static const ro_method RODASP = {6, 5, 4, 0.25, RO_P_C, RO_P_D, RO_P_A, RO_P_CC, rodasp_cont, 4, rodasp_dense};

/* Set up a RODASP run; h0 <= 0 chooses the first step automatically.  Returns 0 or -1 (no memory). */
static int mbs_rodasp_init(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0,
                           const double *y0, double t_bound, double rtol, const double *atol, int natol,
                           double h0, double h_max, double h_min, long max_steps)
{
    return ro_init(o, &RODASP, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps);
}
