/* The Jacobian of a closed mechanism's right-hand side, exact: mbs_jacobian for models with loops.
 *
 * Compiled after loops.c when the model defines MBS_LOOP_JACOBIAN (compiler/jacobian_loops.py), which also
 * generates mbs_loop_partials: the derivatives of the residuals R1 = M a - f - G^T lambda, R2 = G a + gddot0,
 * gdot and g with respect to [q, v, t] at fixed (a, lambda).  The right-hand side is x' = F(P(x)), P the
 * projection by the kept partition (positions: unit quaternions, then Newton steps dq = Q(q) dv with dv_I = 0
 * and G_D dv_D = -g; velocities: v_I kept, G_D v_D = -(G_I v_I + g_t)), F the null-space solve.  Both are
 * implicit functions of those residuals, so at the projected state x_c, for a direction (dx, dt):
 *
 *   dq_n = N dq                                                 N: the tangent map of q / |q| per quaternion
 *   dq_c = dq_n - Q E_D S^-1 (g_q dq_n + g_t dt)                the tangent map of the position projection
 *   dv_c = dv - E_D S^-1 (G dv + gdot_q dq_c + gdot_t dt)       ... and of the velocity projection
 *   d qdot = qdot_q dq_c + Q dv_c + qdot_t dt                   (Q = d qdot / d v)
 *   d vdot = T z + c,  c = -E_D S^-1 dR2,  (T^T M T) z = T^T (-dR1 - M c)
 *
 * with S = G on the pivot rows and dependent columns, T = [I; -S^-1 G_I] the null-space basis, dR = the
 * partials times (dq_c, dv_c, dt).  The column for q_j of a dependent coordinate is zero, as P has it.  No
 * Newton iteration is differenced, so the result has the digits of the residuals, which finite differences
 * of F∘P (the integrators' fallback) lose to the Newton tolerance.  Cost: one projection, one rhs, the
 * multipliers, the generated partials (about one tree function per state) and O(nx nv^2) of linear algebra.
 *
 * Every column needs the partials only as products with one direction at a time (the direction (dx, dt), then
 * the same with dq_c, then with dq_c and dv_c): mbs_lj_along.  With MBS_LOOP_PARTIALS_BY_DIFFERENCES (large
 * mechanisms, lookup tables) these products are central differences of the residuals along the direction
 * (tree functions, smooth, no Newton iteration in them: about 2/3 of the digits), three per column, rather
 * than a table of partials by one difference per state.  Columns the projection undoes (the dependent
 * velocities, and the coordinates whose rate only a dependent velocity drives: N e_j in the range of Q E_D) are
 * zero and not computed, so a mechanism of few degrees of freedom costs a few residuals whatever its size: the
 * chain of 40 four-bars (162 states, one degree of freedom) 3 columns, 6 residuals (and a few g, gdot), where the table took 163
 * (172 ms per Jacobian; python bench/loop_jacobian.py).
 *
 * Status: 0 ok, 1 singular factors or a singular position (the loop solver's limit rows are not
 * differentiated here: the integrators then keep the Jacobian of an earlier step, rosenbrock.c), 2 non-finite,
 * 3 not assembled.
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "dense_lu.c"  /* the factors of S and T^T M T: mbs_lu_factor, mbs_lu_solve */

#define MBS_LJ_W (MBS_NX + 1)  /* columns of the partials and of the result */
#define MBS_LJ_ROWS (MBS_NV + 3 * MBS_NC + MBS_NQ)  /* of the partials: R1, R2, gdot, g, qdot */
#define MBS_LJ_QDOT (MBS_NV + 3 * MBS_NC)  /* first row of qdot */
#define MBS_LJ_NEEDED (MBS_LJ_ROWS * MBS_LJ_W + 4 * MBS_NV * MBS_NV + 4 * MBS_NX + 9 * MBS_NV \
                       + 4 * MBS_NC + 2 + MBS_NV * MBS_NV + MBS_NC * MBS_NV + 2 * MBS_LJ_ROWS + MBS_NX)
#if MBS_LOOP_JACOBIAN_NWORK < MBS_LJ_NEEDED
#error "MBS_LOOP_JACOBIAN_NWORK is too small for runtime/c/loop_jacobian.c"
#endif

typedef struct {
    double *xin, *xdot, *part, *D, *M, *T, *A, *S, *dx, *h1, *h2, *c, *z, *s, *u, *dn;
    double *Mfd, *Gfd, *r0, *r1, *xt;  /* the partials by differences: scratch */
    int *pivS, *pivA;  /* NV each, in the room of NV doubles each: the row exchanges of S's and A's factors */
    double *dr;  /* MBS_LJ_ROWS: the partials times w->dx (mbs_lj_along) */
    double *zero;  /* MBS_NX: 1 for the columns the projection undoes (mbs_lj_zero_columns) */
    int r, d;
} mbs_lj_work;

static mbs_lj_work mbs_lj_layout(double *work)
{
    mbs_lj_work w;
    double *s = work + MBS_NWORK - MBS_LOOP_JACOBIAN_NWORK;
    w.xin = s; s += MBS_NX + MBS_NV + MBS_NC;
    w.xdot = s; s += MBS_NX;
    w.part = s; s += 1 + MBS_NV + MBS_NC + MBS_NX;
    w.D = s; s += MBS_LJ_ROWS * MBS_LJ_W;
    w.M = s; s += MBS_NV * MBS_NV;
    w.T = s; s += MBS_NV * MBS_NV;
    w.A = s; s += MBS_NV * MBS_NV;
    w.S = s; s += MBS_NV * MBS_NV;
    w.pivS = (int *)s; s += MBS_NV;
    w.pivA = (int *)s; s += MBS_NV;
    w.dx = s; s += MBS_LJ_W;
    w.h1 = s; s += MBS_NV;
    w.h2 = s; s += MBS_NC;
    w.c = s; s += MBS_NV;
    w.z = s; s += MBS_NV;
    w.s = s; s += MBS_NV;
    w.dn = s; s += MBS_NV;
    w.Mfd = s; s += MBS_NV * MBS_NV;
    w.Gfd = s; s += MBS_NC * MBS_NV;
    w.r0 = s; s += MBS_LJ_ROWS;
    w.r1 = s; s += MBS_LJ_ROWS;
    w.xt = s; s += MBS_NX;
    w.u = s;
    w.r = w.d = 0;
#ifdef MBS_LOOP_PARTIALS_BY_DIFFERENCES
    w.dr = w.D;  /* no table of partials: its room holds the products */
#else
    w.dr = w.r0;  /* the table in D; r0 and r1 are the differences' scratch */
#endif
    w.zero = w.xdot;  /* the right-hand side there is read once, before the columns */
    return w;
}

static int mbs_lj_col(const mbs_lj_work *w, int k) { return (int)w->part[1 + k]; }
static int mbs_lj_row(const mbs_lj_work *w, int k) { return (int)w->part[1 + MBS_NV + k]; }

#ifndef MBS_LOOP_PARTIALS_BY_DIFFERENCES
/* The row `row` of the partials (R1: 0.., R2: NV.., gdot: NV + NC.., g: NV + 2 NC..) times (dx, dt). */
static double mbs_lj_dot(const mbs_lj_work *w, int row, const double *dx)
{
    const double *d = w->D + row * MBS_LJ_W;
    double sum = 0.0;
    int j;
    for (j = 0; j < MBS_LJ_W; j++) sum += d[j] * dx[j];
    return sum;
}
#endif

/* vec -= E_D S^-1 h[pivot rows]: the dependent components that make the pivot rows of h vanish. */
static void mbs_lj_dependent(const mbs_lj_work *w, const double *h, double *vec)
{
    int k;
    for (k = 0; k < w->r; k++) w->u[k] = h[mbs_lj_row(w, k)];
    mbs_lu_solve(w->r, w->S, w->pivS, w->u);
    for (k = 0; k < w->r; k++) vec[mbs_lj_col(w, k)] -= w->u[k];
}

/* S, T and T^T M T factored at the projected state.  1: singular. */
static int mbs_lj_factors(mbs_lj_work *w, const double *G, int stride)
{
    int i, j, k, l, r = w->r, d = w->d;
    for (k = 0; k < r; k++)
        for (l = 0; l < r; l++) w->S[k * r + l] = G[mbs_lj_row(w, k) * stride + mbs_lj_col(w, l)];
    if (mbs_lu_factor(r, w->S, w->pivS)) return 1;
    memset(w->T, 0, MBS_NV * MBS_NV * sizeof(double));
    for (k = 0; k < d; k++) {  /* T e_k = e_I - E_D S^-1 G e_I, I the k-th independent column */
        int c = mbs_lj_col(w, r + k);
        for (i = 0; i < MBS_NV; i++) w->s[i] = i == c;
        for (i = 0; i < MBS_NC; i++) w->h2[i] = G[i * stride + c];
        mbs_lj_dependent(w, w->h2, w->s);
        for (i = 0; i < MBS_NV; i++) w->T[i * d + k] = w->s[i];
    }
    for (k = 0; k < d; k++)
        for (l = 0; l < d; l++) {
            double sum = 0.0;
            for (i = 0; i < MBS_NV; i++) {
                double mt = 0.0;
                for (j = 0; j < MBS_NV; j++) mt += w->M[i * MBS_NV + j] * w->T[j * d + l];
                sum += w->T[i * d + k] * mt;
            }
            w->A[k * d + l] = sum;
        }
    return mbs_lu_factor(d, w->A, w->pivA) != 0;
}

#ifdef MBS_LOOP_PARTIALS_BY_DIFFERENCES
/* r = [R1; R2; gdot; g; qdot] at (t, x), a and lambda from w->xin: the tree functions, no loop solve. */
static int mbs_lj_residuals(double t, const double *x, const double *p, mbs_lj_work *w, double *r, double *work)
{
    const double *a = w->xin + MBS_NX, *lam = w->xin + MBS_NX + MBS_NV;
    double *R1 = r, *R2 = r + MBS_NV, *gd = R2 + MBS_NC, *g = gd + MBS_NC, *qd = g + MBS_NC;
    int i, j, k, s;
    if (mbs_mass_matrix(t, x, p, w->Mfd, work) == 2) return 2;  /* status 1: only semi-definite, as above */
    if ((s = mbs_forces(t, x, p, R1, work)) != 0) return s;
    if ((s = mbs_loop_jacobian(t, x, p, w->Gfd, work)) != 0) return s;
    if ((s = mbs_constraint_acceleration(t, x, p, R2, work)) != 0) return s;
    if ((s = mbs_constraint_velocity(t, x, p, gd, work)) != 0) return s;
    if ((s = mbs_constraints(t, x, p, g, work)) != 0) return s;
    if ((s = mbs_qdot(t, x, p, qd, work)) != 0) return s;
    for (i = 0; i < MBS_NV; i++) {
        double sum = -R1[i];
        for (j = 0; j < MBS_NV; j++) sum += w->Mfd[i * MBS_NV + j] * a[j];
        for (k = 0; k < MBS_NC; k++) sum -= w->Gfd[k * MBS_NV + i] * lam[k];
        R1[i] = sum;
    }
    for (k = 0; k < MBS_NC; k++)
        for (j = 0; j < MBS_NV; j++) R2[k] += w->Gfd[k * MBS_NV + j] * a[j];
    return 0;
}
#endif

/* The blocks of residual rows mbs_lj_along differentiates: g alone, gdot alone, or all of them. */
#define MBS_LJ_ALONG_G 0
#define MBS_LJ_ALONG_GDOT 1
#define MBS_LJ_ALONG_ALL 2

/* w->dr = the partials of the rows of `block` times the direction w->dx (dx, dt): products with the generated
 * table, or (MBS_LOOP_PARTIALS_BY_DIFFERENCES) central differences of those residuals along the direction,
 * with a step of about the cube root of the round-off (truncation and cancellation balanced) in the largest
 * component.  Returns a model status. */
static int mbs_lj_along(double t, const double *p, mbs_lj_work *w, int block, double *work)
{
    const int first = block == MBS_LJ_ALONG_G ? MBS_NV + 2 * MBS_NC : block == MBS_LJ_ALONG_GDOT ? MBS_NV + MBS_NC : 0;
    const int count = block == MBS_LJ_ALONG_ALL ? MBS_LJ_ROWS : MBS_NC;
    int i;
#ifdef MBS_LOOP_PARTIALS_BY_DIFFERENCES
    const double *dx = w->dx;
    double size = 0.0, scale = 1.0, delta;
    int side, s;
    (void)p;
    for (i = 0; i < MBS_LJ_W; i++)
        if (dx[i] != 0.0) {
            size = fmax(size, fabs(dx[i]));
            scale = fmax(scale, fabs(i < MBS_NX ? w->xin[i] : t));
        }
    if (!(size > 0.0)) {
        memset(w->dr + first, 0, count * sizeof(double));
        return 0;
    }
    delta = 6e-6 * scale / size;
    for (side = 0; side < 2; side++) {
        const double h = side == 0 ? delta : -delta, th = t + h * dx[MBS_NX];
        double *r = side == 0 ? w->r1 : w->r0;
        for (i = 0; i < MBS_NX; i++) w->xt[i] = w->xin[i] + h * dx[i];
        if (block == MBS_LJ_ALONG_G) s = mbs_constraints(th, w->xt, p, r + first, work);
        else if (block == MBS_LJ_ALONG_GDOT) s = mbs_constraint_velocity(th, w->xt, p, r + first, work);
        else s = mbs_lj_residuals(th, w->xt, p, w, r, work);
        if (s != 0) return s;
    }
    for (i = first; i < first + count; i++) w->dr[i] = (w->r1[i] - w->r0[i]) / (2.0 * delta);
#else
    (void)t; (void)p; (void)work;
    for (i = first; i < first + count; i++) w->dr[i] = mbs_lj_dot(w, i, w->dx);
#endif
    return 0;
}

/* dq += Q dn, Q = d qdot / d v at the projected state (dn = w->dn). */
static int mbs_lj_add_rates(double t, const double *p, mbs_lj_work *w, double *dq, double *work)
{
    int i, l;
#ifdef MBS_LOOP_PARTIALS_BY_DIFFERENCES
    int s;  /* qdot is affine in v (the position Newton maps its steps by it): Q dn = qdot(q, dn) - qdot(q, 0) */
    memcpy(w->xt, w->xin, MBS_NX * sizeof(double));
    memcpy(w->xt + MBS_NQ, w->dn, MBS_NV * sizeof(double));
    if ((s = mbs_qdot(t, w->xt, p, w->r0, work)) != 0) return s;
    memset(w->xt + MBS_NQ, 0, MBS_NV * sizeof(double));
    if ((s = mbs_qdot(t, w->xt, p, w->r1, work)) != 0) return s;
    for (i = 0; i < MBS_NQ; i++) dq[i] += w->r0[i] - w->r1[i];
    (void)l;
#else
    (void)t; (void)p; (void)work;
    for (i = 0; i < MBS_NQ; i++) {
        const double *Q = w->D + (MBS_LJ_QDOT + i) * MBS_LJ_W + MBS_NQ;
        double sum = 0.0;
        for (l = 0; l < MBS_NV; l++) sum += Q[l] * w->dn[l];
        dq[i] += sum;
    }
#endif
    return 0;
}

/* w->zero[j] = 1 for the columns the projection undoes, whose derivative is 0 exactly: the dependent velocities
 * (dv_c = e_D - E_D S^-1 S e_D), and the coordinates q_j with Q e_D = alpha e_j for a dependent velocity (a
 * revolute or prismatic joint's angle or travel: then dq_c = 0 as well, since g_q Q = G).  Coordinates in a
 * quaternion are always computed (the normalisation's tangent map N mixes them). */
static int mbs_lj_zero_columns(double t, const double *p, mbs_lj_work *w, double *work)
{
    int i, k, s;
    memset(w->zero, 0, MBS_NX * sizeof(double));
    memcpy(w->xt, w->xin, MBS_NX * sizeof(double));
    memset(w->xt + MBS_NQ, 0, MBS_NV * sizeof(double));
    if ((s = mbs_qdot(t, w->xt, p, w->r1, work)) != 0) return s;
    for (k = 0; k < w->r; k++) {
        const int c = mbs_lj_col(w, k);
        int only = -1, nonzero = 0;
        w->zero[MBS_NQ + c] = 1.0;
        w->xt[MBS_NQ + c] = 1.0;
        s = mbs_qdot(t, w->xt, p, w->r0, work);
        w->xt[MBS_NQ + c] = 0.0;
        if (s != 0) return s;
        for (i = 0; i < MBS_NQ; i++)
            if (w->r0[i] != w->r1[i]) { only = i; nonzero++; }
        for (i = 0; i < MBS_NQUAT && nonzero == 1; i++)
            if (only >= mbs_quaternion_slots[i] && only < mbs_quaternion_slots[i] + 4) nonzero = 0;
        if (nonzero == 1) w->zero[only] = 1.0;
    }
    return 0;
}

/* Column j of the result (j < MBS_NX: d/d x_j; j == MBS_NX: d/d t) into out.  Returns a model status. */
static int mbs_lj_column(double t, const double *p, mbs_lj_work *w, int j, double *out, double *work)
{
    double *dx = w->dx, *dq = dx, *dv = dx + MBS_NQ, *dr = w->dr;
    int i, k, l, s, d = w->d;
    memset(dx, 0, MBS_LJ_W * sizeof(double));
    dx[j] = 1.0;
    if (j < MBS_NQ || j == MBS_NX) {  /* positions: unit quaternions, then back onto g = 0 along Q E_D */
        for (k = 0; k < MBS_NQUAT; k++) {
            const double *qc = w->xin + mbs_quaternion_slots[k];
            double *e = dq + mbs_quaternion_slots[k];
            double along = qc[0] * e[0] + qc[1] * e[1] + qc[2] * e[2] + qc[3] * e[3];
            for (l = 0; l < 4; l++) e[l] -= along * qc[l];
        }
        if ((s = mbs_lj_along(t, p, w, MBS_LJ_ALONG_G, work)) != 0) return s;
        for (i = 0; i < MBS_NC; i++) w->h2[i] = dr[MBS_NV + 2 * MBS_NC + i];
        memset(w->dn, 0, MBS_NV * sizeof(double));
        mbs_lj_dependent(w, w->h2, w->dn);
        if ((s = mbs_lj_add_rates(t, p, w, dq, work)) != 0) return s;
    }
    if ((s = mbs_lj_along(t, p, w, MBS_LJ_ALONG_GDOT, work)) != 0) return s;  /* velocities onto gdot = 0 */
    for (i = 0; i < MBS_NC; i++) w->h2[i] = dr[MBS_NV + MBS_NC + i];
    mbs_lj_dependent(w, w->h2, dv);
    if ((s = mbs_lj_along(t, p, w, MBS_LJ_ALONG_ALL, work)) != 0) return s;
    for (i = 0; i < MBS_NQ; i++) out[i * MBS_LJ_W + j] = dr[MBS_LJ_QDOT + i];
    /* accelerations: c from the constraint rows, z from the reduced equations */
    for (i = 0; i < MBS_NV; i++) { w->h1[i] = -dr[i]; w->c[i] = 0.0; }
    for (i = 0; i < MBS_NC; i++) w->h2[i] = dr[MBS_NV + i];
    mbs_lj_dependent(w, w->h2, w->c);
    for (i = 0; i < MBS_NV; i++) {
        double mc = 0.0;
        for (l = 0; l < MBS_NV; l++) mc += w->M[i * MBS_NV + l] * w->c[l];
        w->s[i] = w->h1[i] - mc;
    }
    for (k = 0; k < d; k++) {
        double sum = 0.0;
        for (i = 0; i < MBS_NV; i++) sum += w->T[i * d + k] * w->s[i];
        w->z[k] = sum;
    }
    mbs_lu_solve(d, w->A, w->pivA, w->z);
    for (i = 0; i < MBS_NV; i++) {
        double sum = w->c[i];
        for (k = 0; k < d; k++) sum += w->T[i * d + k] * w->z[k];
        out[(MBS_NQ + i) * MBS_LJ_W + j] = sum;
    }
    return 0;
}

int mbs_jacobian(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_lj_work w = mbs_lj_layout(work);
    const double *xc = w.part + 1 + MBS_NV + MBS_NC;
    int i, j, s = mbs_loop_partition_at(t, x, p, w.part, work);
    if (s != 0) return s;
    w.r = (int)w.part[0];
    w.d = MBS_NV - w.r;
    if ((s = mbs_loop_rhs_direct(t, xc, p, w.xdot, work)) != 0) return s;
    memcpy(w.xin, xc, MBS_NX * sizeof(double));
    memcpy(w.xin + MBS_NX, w.xdot + MBS_NQ, MBS_NV * sizeof(double));
    if ((s = mbs_loop_multipliers(t, xc, p, w.xin + MBS_NX + MBS_NV, work)) != 0) return s;
    /* M may be only semi-definite (massless parts; status 1): T^T M T is what must be regular */
    if (mbs_mass_matrix(t, xc, p, w.M, work) == 2) return 2;
#ifdef MBS_LOOP_PARTIALS_BY_DIFFERENCES
    if ((s = mbs_loop_jacobian(t, xc, p, w.Gfd, work)) != 0) return s;
    if (mbs_lj_factors(&w, w.Gfd, MBS_NV)) return 1;
#else
    if ((s = mbs_loop_partials(t, w.xin, p, w.D, work)) != 0) return s;
    if (mbs_lj_factors(&w, w.D + (MBS_NV + MBS_NC) * MBS_LJ_W + MBS_NQ, MBS_LJ_W)) return 1;  /* d gdot / d v */
#endif
    if ((s = mbs_lj_zero_columns(t, p, &w, work)) != 0) return s;
    for (j = 0; j < MBS_LJ_W; j++) {
        if (j < MBS_NX && w.zero[j] != 0.0) {
            for (i = 0; i < MBS_NX; i++) out[i * MBS_LJ_W + j] = 0.0;
        } else if ((s = mbs_lj_column(t, p, &w, j, out, work)) != 0) {
            return s;
        }
    }
    return isfinite(mbs_loop_maxabs(out, MBS_NX * MBS_LJ_W, NULL)) ? 0 : 2;
}
