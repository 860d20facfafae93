/* Dense LU factorisation with partial pivoting, row-major, in place (for the stiff integrators and the loop
 * Jacobian, runtime/c/loop_jacobian.c, which includes it too). */
#ifndef MBS_DENSE_LU_C
#define MBS_DENSE_LU_C
#include <math.h>

/* Factor the n x n matrix a (row-major) as P a = L U; piv[k] is the row swapped with row k.
 * Returns 0, or k + 1 if the k-th pivot is zero or not finite (the matrix is singular). */
static int mbs_lu_factor(int n, double *a, int *piv)
{
    int i, j, k;
    for (k = 0; k < n; k++) {
        int p = k;
        double amax = fabs(a[k * n + k]);
        for (i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > amax) { amax = fabs(a[i * n + k]); p = i; }
        piv[k] = p;
        if (!(amax > 0.0) || !isfinite(amax)) return k + 1;
        if (p != k)
            for (j = 0; j < n; j++) { double t = a[k * n + j]; a[k * n + j] = a[p * n + j]; a[p * n + j] = t; }
        for (i = k + 1; i < n; i++) {
            double l = a[i * n + k] / a[k * n + k];
            a[i * n + k] = l;
            if (l != 0.0)
                for (j = k + 1; j < n; j++) a[i * n + j] -= l * a[k * n + j];
        }
    }
    return 0;
}

/* Solve a x = b in place (b becomes x) with the factors from mbs_lu_factor.  Its row exchanges move whole rows,
 * multipliers included, so L is in the final row order: the forward substitution goes row by row, exchanging
 * b[i] just before row i (all later exchanges touch rows after i only); column by column, the exchanges would
 * have to come first (runtime/c/loop_jacobian.c once paired multipliers with the wrong rows so). */
static void mbs_lu_solve(int n, const double *lu, const int *piv, double *b)
{
    int i, j;
    for (i = 0; i < n; i++) {
        double s;
        if (piv[i] != i) { double t = b[i]; b[i] = b[piv[i]]; b[piv[i]] = t; }
        s = b[i];
        for (j = 0; j < i; j++) s -= lu[i * n + j] * b[j];
        b[i] = s;
    }
    for (i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (j = i + 1; j < n; j++) s -= lu[i * n + j] * b[j];
        b[i] = s / lu[i * n + i];
    }
}
#endif
