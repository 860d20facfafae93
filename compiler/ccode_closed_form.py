"""C code of loops that close in closed form (compiler/closed_form_loops.py): minimal coordinates at run time.

Three functions of the one model signature, printed into the model's file next to the loop solver's:

    int mbs_closed_form(t, x, p, out, work)          generated: [q_D; J (nd x ni); Jdot v_I; guards; A; b;
                                                     sin, cos of the dependent angles]
    int mbs_closed_form_rhs(t, x, p, xdot, work)     x' at the state mapped onto the branch (NX)
    int mbs_closed_form_project(t, x, p, out, work)  x mapped onto the branch: q_D(q_I), v_D = J v_I (NX)

The right-hand side is the reduced dynamics in the independent coordinates, (J^T M J) a = J^T (f - M Jdot v_I)
with J stacked under the identity of the independent coordinates, and vdot = [a; J a + Jdot v_I]: A = J^T M J and
b = J^T (f - M Jdot v_I) written out from the tree's mass matrix and forces at the mapped state (their zeros drop
out at compile time), an L D L^T factorisation of the ni x ni matrix A at run time, and no Newton iteration,
partitioning or factorisation of G. A dependent angle is defined modulo 2 pi: the map takes
the representative nearest the state's own value, so a continuous motion stays continuous.

Each returns 0 on success and otherwise a status that makes the loop solver (runtime/c/loops.c, which calls them
first) take over with its numeric path: 2 a value not finite, 4 the state is not on the branch (an acos argument
within MBS_CF_BAND of 1: near a singular position; a dependent angle further than MBS_CF_BRANCH_TOL from the
branch's value: another assembly of the mechanism). Their scratch lies in the loop solver's work beyond its
kept partition (MBS_CF_SCRATCH), which the numeric path rewrites anyway before it reads it.
"""

from __future__ import annotations

import copy
import dataclasses

import sympy as sp

from .closed_form_loops import ClosedForm
from .emit_common import CodegenError
from .equations import Equations

#: The generated function of the map and its derivatives.
CLOSED_FORM = "mbs_closed_form"
#: |guard| above 1 - this: near a singular position of the branch, the numeric path takes over.
BAND = 1e-6
#: A dependent angle of the state further than this from the branch's value [rad]: not this branch.
BRANCH_TOL = 0.1


def closed_form_routine(equations: Equations, form: ClosedForm) -> tuple[Equations, tuple]:
    """(equations on a tape fork that also holds the closed form and the tree's mass matrix and forces at the
    mapped state, the routine `mbs_closed_form` in the emitter's format). One function computes them all, so the
    trigonometry of the independent coordinates is shared and the tree functions are not called besides; the
    tree's temporaries read the closed form's q_D and v_D = J v_I instead of the state's (an angle's turns do not
    matter there: the tree reads joint angles through their sine and cosine).

    Raises CodegenError when the tree's functions divide with a guard (the articulated-body algorithm does; the
    mass matrix and the forces do not)."""
    tree = equations.tree
    q, v = tree.q_symbols, tree.v_symbols
    tape = equations.tape.fork()
    tape.section("loops closed in closed form (compiler/closed_form_loops.py)")
    roots: dict = {}
    state: dict = {}  # the dependent coordinates and speeds -> their temporaries
    positions, trig = [], []
    for d, value, sin_cos in zip(form.dependent, form.positions, _sin_cos(form)):
        if sin_cos is None:
            state[q[d]] = tape.temp(_with_roots(value.xreplace(state), tape, roots), "cf_q")
            positions.append(state[q[d]])
            continue
        # an angle by its sine and cosine, algebra; its value (an atan2) only where a state is projected
        sine, cosine = (tape.temp(_with_roots(e.xreplace(state), tape, roots), "cf_trig") for e in sin_cos)
        state[sp.sin(q[d])], state[sp.cos(q[d])] = sine, cosine
        positions.append(sp.S.Zero)
        trig += [sine, cosine]
    # J, then the bias and the guards with v_D = J v_I written out: one common-subexpression pass over them all
    # (J's subexpressions recur in the bias, its divisions among them)
    ni, nd = len(form.independent), len(form.dependent)
    J = [e.xreplace(state) for row in form.jacobian for e in row]
    speeds = {v[d]: sum(J[i * ni + k] * v[c] for k, c in enumerate(form.independent))
              for i, d in enumerate(form.dependent)}
    rest = [e.xreplace(state).xreplace(speeds) for e in list(form.bias) + list(form.guards)]
    replacements, reduced = sp.cse(J + rest, symbols=sp.numbered_symbols("cf"))
    temps: dict = {}
    for symbol, expr in replacements:
        temps[symbol] = tape.temp(_with_roots(expr.xreplace(temps), tape, roots), "cf")
    reduced = [_with_roots(e.xreplace(temps), tape, roots) for e in reduced]
    J = [tape.temp(e, "cf_J") for e in reduced[:len(J)]]
    for i, d in enumerate(form.dependent):
        state[v[d]] = tape.temp(sum(J[i * ni + k] * v[c] for k, c in enumerate(form.independent)), "cf_v")
    bias = [tape.temp(e, "cf_bias") for e in reduced[len(J):len(J) + nd]]
    values = positions + J + bias + reduced[len(J) + nd:]
    tree_outputs = [m for row in equations.mass_matrix for m in row] + list(equations.forces)
    tape.section("the tree's mass matrix and forces at the state mapped onto the closed form")
    for entry in equations.tape.entries_for(tree_outputs):
        if entry.guard is not None:
            raise CodegenError(f"closed form: the tree functions divide by a guarded pivot ({entry.name})")
        state[entry.symbol] = tape.temp(entry.expr.xreplace(state), entry.name)
    nv = tree.nv
    M = [[tape.temp(sp.sympify(equations.mass_matrix[i][j]).xreplace(state), "cf_M") for j in range(nv)]
         for i in range(nv)]
    f = [sp.sympify(e).xreplace(state) for e in equations.forces]
    # the reduced dynamics (J^T M J) a = J^T (f - M Jdot v_I) with T = [I; J] written out: the zeros of M and T
    # drop out here, not in loops at run time
    T = [[sp.S.Zero] * ni for _ in range(nv)]
    for k, c in enumerate(form.independent):
        T[c][k] = sp.S.One
    for i, d in enumerate(form.dependent):
        for k in range(ni):
            T[d][k] = J[i * ni + k]
    shift = [sp.S.Zero] * nv  # Jdot v_I in the rows of the dependent speeds
    for i, d in enumerate(form.dependent):
        shift[d] = bias[i]
    tape.section("the reduced dynamics in the independent coordinates")
    MT = [[tape.temp(sum(M[j][m] * T[m][k] for m in range(nv)), "cf_MT") for k in range(ni)] for j in range(nv)]
    r = [tape.temp(f[j] - sum(M[j][m] * shift[m] for m in range(nv)), "cf_r") for j in range(nv)]
    values += [sum(T[j][k] * MT[j][l] for j in range(nv)) for k in range(ni) for l in range(ni)]
    values += [sum(T[j][k] * r[j] for j in range(nv)) for k in range(ni)] + trig
    kinematics = copy.copy(equations.kinematics)
    kinematics.tape = tape
    routine = (CLOSED_FORM, "out", "the loops closed in closed form: [q_D (0 for an angle of the last block); "
               "J = d q_D / d q_I (row-major); Jdot v_I; guards (|.| < 1 off the singular positions); J^T M J "
               "(ni x ni); J^T (f - M Jdot v_I) at the mapped state; sin and cos of the dependent angles]",
               (len(values),), list(enumerate(values)), False)
    return dataclasses.replace(equations, kinematics=kinematics), routine


def _sin_cos(form: ClosedForm) -> tuple:
    """Per dependent coordinate: (sin, cos) of an angle as algebra, or None (a length, or an angle without)."""
    return tuple(sc if angle else None
                 for sc, angle in zip(form.sin_cos or (None,) * len(form.dependent), form.angle))


def _with_roots(expr, tape, roots: dict):
    """expr with every power b^(k/2) written as sqrt(b)^k, sqrt(b) one temporary per b (differentiation of a
    square root gives b^(-3/2), b^(-5/2): pow calls, where one sqrt and products do)."""
    def half(p):
        base = p.base
        if base not in roots:
            roots[base] = tape.temp(sp.sqrt(base), "cf_root")
        return roots[base] ** int(2 * p.exp)
    expr = expr.replace(lambda z: z.is_Pow and z.exp.is_Rational and z.exp.q == 2 and z.exp != sp.Rational(1, 2)
                        or (z.is_Pow and z.exp == sp.Rational(1, 2) and z.base in roots), half)
    return _with_squares(expr, tape)


def _with_squares(expr, tape):
    """expr with every integer power b^n, |n| > 2, by squaring temporaries (b^4 = (b^2)^2 with b^2 one
    temporary): C's pow() of a constant exponent other than 2 stays a library call (about 200 instructions)."""
    def power(base, n):
        if n <= 2:
            return base ** n
        return power(tape.temp(base ** 2, "cf_sq"), n // 2) * base ** (n % 2)
    return expr.replace(lambda z: z.is_Pow and z.exp.is_Integer and abs(int(z.exp)) > 2,
                        lambda z: power(z.base, int(z.exp)) if z.exp > 0 else 1 / power(z.base, -int(z.exp)))


def _ints(values) -> str:
    return ", ".join(str(int(v)) for v in values) or "0"


def closed_form_definitions(form: ClosedForm, nv: int, nc: int) -> str:
    """Sizes, the partition and the declarations (after the loop solver's definitions)."""
    ni, nd, ng = len(form.independent), len(form.dependent), len(form.guards)
    pairs, k = [], 0
    for sc in _sin_cos(form):
        pairs.append(-1 if sc is None else k)
        k += sc is not None
    nout = nd + nd * ni + nd + ng + ni * ni + ni + 2 * k  # [q_D; J; bias; guards; A; b; sin, cos of angles]
    scratch = 4 + nv + nc  # the loop solver's kept partition (runtime/c/loops.c MBS_LOOP_KEEP_SIZE) comes first
    need = nout + nv + nv  # xc
    return "\n".join([
        "/* Loops closed in closed form (compiler/closed_form_loops.py): q_D = q_D(q_I) on one branch. */",
        "#include <string.h>",
        "#define MBS_CLOSED_FORM 1",
        f"#define MBS_CF_NI {ni}   /* independent coordinates */",
        f"#define MBS_CF_ND {nd}   /* dependent coordinates */",
        f"#define MBS_CF_NG {ng}   /* guards */",
        f"#define MBS_CF_NOUT {nout}   /* doubles written by mbs_closed_form */",
        f"#define MBS_CF_GUARDS {nd * (ni + 2)}   /* where the guards start in its output */",
        f"#define MBS_CF_TRIG {nout - 2 * k}   /* where the sines and cosines of the angles start in it */",
        f"#define MBS_CF_BAND {BAND!r}   /* |guard| above 1 - this: the numeric path */",
        f"#define MBS_CF_BRANCH_TOL {BRANCH_TOL!r}   /* [rad] a dependent angle further off: the numeric path */",
        f"#define MBS_CF_SCRATCH (MBS_TREE_NWORK + {scratch})   /* its scratch in work, after the kept partition */",
        f"#define MBS_CF_NWORK {need}   /* doubles of that scratch */",
        "#if MBS_CF_SCRATCH + MBS_CF_NWORK > MBS_TREE_NWORK + MBS_LOOP_NWORK",
        "#error \"the closed form's scratch does not fit the loop solver's work\"",
        "#endif",
        f"static const int mbs_cf_independent[{max(ni, 1)}] = {{{_ints(form.independent)}}};",
        f"static const int mbs_cf_dependent[{max(nd, 1)}] = {{{_ints(form.dependent)}}};",
        "/* 1: the dependent coordinate is an angle (defined modulo 2 pi) */",
        f"static const int mbs_cf_angle[{max(nd, 1)}] = {{{_ints(form.angle)}}};",
        "/* k >= 0: the angle's sine and cosine are pair k of the output's last block (its q_D entry is 0) */",
        f"static const int mbs_cf_trig[{max(nd, 1)}] = {{{_ints(pairs)}}};",
        f"int {CLOSED_FORM}(double t, const double *x, const double *p, double *out, double *work);",
        "double mbs_cf_angle_near(double s, double c);",
        "int mbs_closed_form_at(double t, const double *x, const double *p, double *cf, double *work);",
        "int mbs_closed_form_rhs(double t, const double *x, const double *p, double *xdot, double *work);",
        "int mbs_closed_form_project(double t, const double *x, const double *p, double *out, double *work);",
        ""])


#: The hand-written part: the same text for every model (sizes and tables from the definitions above).
FUNCTIONS = r"""
/* atan2(s, c) to 1e-5 rad (Abramowitz and Stegun 4.4.47 for atan on [0, 1], the octant by the signs): the
 * branch test at every right-hand side, which needs no more; libm's atan2 where a state is projected.  (These
 * helpers are not static: a split build, runtime/translation_units.py, takes static ones only before the
 * contract functions.) */
double mbs_cf_angle_near(double s, double c)
{
    const double as = fabs(s), ac = fabs(c);
    const double z = as <= ac ? as / ac : ac / as, z2 = z * z;
    double a = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))));
    if (as > ac)
        a = 1.5707963267948966 - a;
    if (c < 0.0)
        a = 3.141592653589793 - a;
    return s < 0.0 ? -a : a;
}

/* cf = mbs_closed_form at x; status 4 when x is not on the branch: a guard in the band around a singular
 * position, or a dependent angle further than MBS_CF_BRANCH_TOL (to 1e-5 rad) from the branch's value u modulo
 * 2 pi, u from the sine and cosine the algebra gives (no trigonometric call at every right-hand side). */
int mbs_closed_form_at(double t, const double *x, const double *p, double *cf, double *work)
{
    const double *const trig = cf + MBS_CF_TRIG;
    const double two_pi = 6.283185307179586;
    int i, s = mbs_closed_form(t, x, p, cf, work);
    if (s != 0)
        return s;
    for (i = 0; i < MBS_CF_NG; i++)
        if (!(fabs(cf[MBS_CF_GUARDS + i]) < 1.0 - MBS_CF_BAND))
            return 4;
    for (i = 0; i < MBS_CF_ND; i++) {
        const int k = mbs_cf_trig[i];
        double off, turns;
        if (!mbs_cf_angle[i])
            continue;
        off = x[mbs_cf_dependent[i]] - (k >= 0 ? mbs_cf_angle_near(trig[2 * k], trig[2 * k + 1]) : cf[i]);
        turns = off / two_pi;
        if (!(fabs(turns) < 1e15))
            return 4;
        off -= two_pi * (double)(long long)(turns + (turns < 0.0 ? -0.5 : 0.5));
        if (!(fabs(off) <= MBS_CF_BRANCH_TOL))
            return 4;
    }
    return 0;
}

/* x mapped onto the branch: the projection of the closed form, q_D(q_I) (an angle the representative nearest
 * the state's own value) and v_D = J v_I. */
int mbs_closed_form_project(double t, const double *x, const double *p, double *out, double *work)
{
    double *const cf = work + MBS_CF_SCRATCH, *const xc = cf + MBS_CF_NOUT;
    const double *const J = cf + MBS_CF_ND, *const trig = cf + MBS_CF_TRIG;
    const double two_pi = 6.283185307179586;
    int i, k, s = mbs_closed_form_at(t, x, p, cf, work);
    if (s != 0)
        return s;
    memcpy(xc, x, MBS_NX * sizeof(double));
    for (i = 0; i < MBS_CF_ND; i++) {
        const int d = mbs_cf_dependent[i], j = mbs_cf_trig[i];
        double value = j >= 0 ? atan2(trig[2 * j], trig[2 * j + 1]) : cf[i], speed = 0.0;
        if (mbs_cf_angle[i])
            value += two_pi * floor((x[d] - value) / two_pi + 0.5);
        for (k = 0; k < MBS_CF_NI; k++)
            speed += J[i * MBS_CF_NI + k] * x[MBS_NQ + mbs_cf_independent[k]];
        xc[d] = value;
        xc[MBS_NQ + d] = speed;
    }
    if (!mbs_all_finite(xc, MBS_NX))
        return 2;
    memcpy(out, xc, MBS_NX * sizeof(double));
    return 0;
}

/* x' at x mapped onto the branch, from (J^T M J) a = J^T (f - M Jdot v_I) in the independent coordinates (the
 * matrix A and the right-hand side b as mbs_closed_form writes them, factored and solved in place). */
int mbs_closed_form_rhs(double t, const double *x, const double *p, double *xdot, double *work)
{
    double *const cf = work + MBS_CF_SCRATCH;
    const double *const J = cf + MBS_CF_ND, *const bias = J + MBS_CF_ND * MBS_CF_NI;
    double *const A = cf + MBS_CF_GUARDS + MBS_CF_NG, *const b = A + MBS_CF_NI * MBS_CF_NI;
    double *const vdot = xdot + MBS_NQ;
    const double *const v = x + MBS_NQ;
    int i, k, l;
    const int s = mbs_closed_form_at(t, x, p, cf, work);
    if (s != 0)
        return s;
    /* A = L D L^T in place (L below the diagonal, unit diagonal; D on it), then L D L^T a = b into b */
    for (k = 0; k < MBS_CF_NI; k++) {
        double d = A[k * MBS_CF_NI + k];
        for (l = 0; l < k; l++)
            d -= A[k * MBS_CF_NI + l] * A[k * MBS_CF_NI + l] * A[l * MBS_CF_NI + l];
        if (!(d > 0.0))
            return d <= 0.0 ? 1 : 2;
        A[k * MBS_CF_NI + k] = d;
        for (i = k + 1; i < MBS_CF_NI; i++) {
            double e = A[i * MBS_CF_NI + k];
            for (l = 0; l < k; l++)
                e -= A[i * MBS_CF_NI + l] * A[k * MBS_CF_NI + l] * A[l * MBS_CF_NI + l];
            A[i * MBS_CF_NI + k] = e / d;
        }
    }
    for (k = 0; k < MBS_CF_NI; k++)
        for (l = 0; l < k; l++)
            b[k] -= A[k * MBS_CF_NI + l] * b[l];
    for (k = MBS_CF_NI - 1; k >= 0; k--) {
        b[k] /= A[k * MBS_CF_NI + k];
        for (l = k + 1; l < MBS_CF_NI; l++)
            b[k] -= A[l * MBS_CF_NI + k] * b[l];
    }
    /* qdot = v (closed_form_loops checks it) with v_D = J v_I, vdot = [a; J a + Jdot v_I] */
    memcpy(xdot, v, MBS_NQ * sizeof(double));
    for (k = 0; k < MBS_CF_NI; k++)
        vdot[mbs_cf_independent[k]] = b[k];
    for (i = 0; i < MBS_CF_ND; i++) {
        double a = bias[i], speed = 0.0;
        for (k = 0; k < MBS_CF_NI; k++) {
            a += J[i * MBS_CF_NI + k] * b[k];
            speed += J[i * MBS_CF_NI + k] * v[mbs_cf_independent[k]];
        }
        xdot[mbs_cf_dependent[i]] = speed;
        vdot[mbs_cf_dependent[i]] = a;
    }
    return mbs_all_finite(xdot, MBS_NX) ? 0 : 2;
}
"""


def closed_form_functions() -> str:
    return FUNCTIONS.lstrip("\n")


__all__ = ["CLOSED_FORM", "closed_form_definitions", "closed_form_functions", "closed_form_routine"]
