/* Rodas5P: L-stable, stiffly accurate Rosenbrock method of order 5(4) with eight stages and a dense output of
 * order 4, for stiff models and for tight tolerances.  The coefficients for the engine in rosenbrock.c (the
 * form, the Jacobian, the step control) and the dense output.
 *
 * Coefficients: G. Steinebach, "Construction of Rosenbrock-Wanner method Rodas5P and numerical benchmarks
 * within the Julia Differential Equations package", BIT Numerical Mathematics 63, 27 (2023),
 * doi:10.1007/s10543-023-00967-x, in the transformed form (a, C, c, d and the dense-output weights h) of the
 * author's implementation in DifferentialEquations.jl (OrdinaryDiffEq, rosenbrock_tableaus.jl).  Rodas5P keeps
 * its order on stiff problems driven by a time-dependent input (Prothero-Robinson) like RODASP, and was built
 * for better local error constants than Di Marzo's RODAS5 (1993).  Its orders are checked here, not taken on
 * trust: tests/runtime/test_rodas5p.py measures 5 on a linear system with a closed-form solution and on the
 * pendulum, 4 for the dense output, and the stiff order on Prothero-Robinson.
 *
 * Cost per step: one Jacobian, one LU, 8 right-hand sides (7 stages after the first, which reuses f of the
 * last step, and f at the new point); RODASP takes 6.  Dense output: with s = (t - t0) / h, s1 = 1 - s,
 *     y(t) = s1 y0 + s (y1 + s1 (w1 + s (w2 + s w3))),   w_r = sum_j H_rj k_j.
 */
#include "mbs_runtime.h"

/* 8 stages (rows and columns from 0): a for the inputs of stages 1-5, stage 6's is u5 + k5, stage 7's u6 + k6;
 * C: rows 1-7. */
static const double R5P_C[8] = {0.0, 0.6358126895828704, 0.4095798393397535, 0.9769306725060716,
                                0.4288403609558664, 1.0, 1.0, 1.0};
static const double R5P_D[8] = {0.21193756319429014, -0.42387512638858027, -0.3384627126235924,
                                1.8046452872882734, 2.325825639765069, 0.0, 0.0, 0.0};
static const double R5P_A[64] = {
    0, 0, 0, 0, 0, 0, 0, 0,
    3.0, 0, 0, 0, 0, 0, 0, 0,
    2.849394379747939, 0.45842242204463923, 0, 0, 0, 0, 0, 0,
    -6.954028509809101, 2.489845061869568, -10.358996098473584, 0, 0, 0, 0, 0,
    2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641, 0, 0, 0, 0,
    -7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256, 0.030198172008377946,
    0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0};
static const double R5P_CC[64] = {
    0, 0, 0, 0, 0, 0, 0, 0,
    -14.155112264123755, 0, 0, 0, 0, 0, 0, 0,
    -17.97296035885952, -2.859693295451294, 0, 0, 0, 0, 0, 0,
    147.12150275711716, -1.41221402718213, 71.68940251302358, 0, 0, 0, 0, 0,
    165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306, 0, 0, 0, 0,
    24.854864614690072, -3.0009227002832186, 47.4931110020768, 5.5814197821558125, -0.6610691825249471,
    0, 0, 0,
    30.91273214028599, -3.1208243349937974, 77.79954646070892, 34.28646028294783, -19.097331116725623,
    -28.087943162872662, 0, 0,
    37.80277123390563, -3.2571969029072276, 112.26918849496327, 66.9347231244047, -40.06618937091002,
    -54.66780262877968, -9.48861652309627, 0};
/* dense output: w_r = sum_j R5P_H[r][j] k_j */
static const double R5P_H[3][8] = {
    {25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204, 0.524948541321073,
     1.1241088310450404, 0.4272876194431874, -0.17202221070155493},
    {-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796, 20.176138334709044,
     15.98066361424651, -6.789040303419874, -6.710236069923372},
    {11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643, -52.072871366152654,
     -59.78993625266729, -0.15582684282751913, 4.883087185713722}};

/* Dense output: y0, y1, w1, w2, w3 and h. */
static void rodas5p_cont(mbs_ode *o, const ro_mem *m, double h, const double *y1, const double *f1)
{
    double *c = o->cont;
    const int n = o->n;
    int i, r, j;
    (void)f1;
    for (i = 0; i < n; i++) {
        c[i] = o->y[i];
        c[n + i] = y1[i];
        for (r = 0; r < 3; r++) {
            double w = 0.0;
            for (j = 0; j < 8; j++) w += R5P_H[r][j] * m->k[j][i];
            c[(2 + r) * n + i] = w;
        }
    }
    c[5 * n] = h;
}

static void rodas5p_dense(const mbs_ode *o, double t, double *out)
{
    const double *c = o->cont;
    const int n = o->n;
    double s = (t - o->t_old) / c[5 * n], s1 = 1.0 - s;
    int i;
    for (i = 0; i < n; i++)
        out[i] = s1 * c[i] + s * (c[n + i] + s1 * (c[2 * n + i] + s * (c[3 * n + i] + s * c[4 * n + i])));
}

static const ro_method RODAS5P = {8, 6, 5, 0.21193756319429014, R5P_C, R5P_D, R5P_A, R5P_CC, rodas5p_cont, 5,
                                  rodas5p_dense};

/* Set up a Rodas5P run; h0 <= 0 chooses the first step automatically.  Returns 0 or -1 (no memory). */
static int mbs_rodas5p_init(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0,
                            const double *y0, double t_bound, double rtol, const double *atol, int natol,
                            double h0, double h_max, double h_min, long max_steps)
{
    return ro_init(o, &RODAS5P, n, fn, p, work, t0, y0, t_bound, rtol, atol, natol, h0, h_max, h_min, max_steps);
}
