"""The Jacobian of a closed mechanism's right-hand side, assembled from generated partial derivatives.

With closed loops x' = F(P(x)): P projects the tree state onto the loop-closure constraints (Newton on the
dependent coordinates), F solves the constrained accelerations by the null-space method (runtime/c/loops.c).
Neither is a tape result, so differencing F∘P by finite differences meets the Newton tolerance as noise and
costs the Rosenbrock method its order. Both are implicit functions of smooth residuals, though, and their
derivatives follow exactly from the derivatives of those residuals and the factorisations the solver has:

    R1(q, v, t; a, lambda) = M(q) a - f(q, v, t) - G(q)^T lambda     (= 0 at the solution a = vdot)
    R2(q, v, t; a)         = G(q) a + gddot0(q, v, t)                (= 0)
    gdot(q, v, t)          = G(q) v + g_t(q, t),   g(q, t)           (the projection's conditions)

This module generates their partial derivatives with respect to [q, v, t] at fixed (a, lambda), by forward
differentiation of the tape (compiler/differentiate.py), as one routine

    int mbs_loop_partials(double t, const double *x, const double *p, double *out, double *work);
    x = [q; v; a; lambda] (MBS_NX + MBS_NV + MBS_NC), out = the rows [R1; R2; gdot; g; qdot] (MBS_NV + 3 MBS_NC +
    MBS_NQ) by the columns [q, v, t] (MBS_NX + 1), row-major;

and runtime/c/loop_jacobian.c turns them into mbs_jacobian, the contract's [d x'/d x | d x'/d t]: the
tangent map of the projection by the kept partition, then the differentiated null-space solve.

Beyond MAX_STATES states (the table of partials grows as nx^2) and for equations with lookup tables, the same
assembly takes the partials by forward differences of the residuals, which are smooth tree functions without
the Newton iteration: half the digits, like a tree's finite differences, and no generation time.
"""

from __future__ import annotations

import copy
import dataclasses

import sympy as sp

from .constraints import Constraints
from .differentiate import NotDifferentiable, forward_derivatives
from .equations import Equations
from .tree import t

PARTIALS = "mbs_loop_partials"
#: Largest state for which the partials are generated. Their table grows as nx^2 (about 200,000 entries for the
#: 40-four-bar chain): beyond this the generation and the C compiler take minutes, more than exact partials
#: save, and the same assembly takes them by differences of the residuals (partials_by_differences).
MAX_STATES = 40


@dataclasses.dataclass(frozen=True)
class LoopJacobian:
    """What the C emitter needs: the routine tuple (emit_common's format), the inputs the routine reads after
    the state (symbol, array, index), and the definitions that switch runtime/c/loop_jacobian.c on."""

    routine: tuple | None  # None: the partials by differences (partials_by_differences)
    inputs: tuple
    definitions: str


def loop_jacobian_or_none(equations: Equations, constraints: Constraints
                          ) -> tuple[Equations, LoopJacobian | None]:
    """`loop_jacobian`; for mechanisms of more than MAX_STATES states and for equations without a printable
    derivative (a lookup table) the same assembly with the partials by differences of the residuals."""
    if equations.tree.nx <= MAX_STATES:
        try:
            return loop_jacobian(equations, constraints)
        except NotDifferentiable:
            pass
    return equations, partials_by_differences(equations, constraints)


def partials_by_differences(equations: Equations, constraints: Constraints) -> LoopJacobian:
    """runtime/c/loop_jacobian.c with the partials from forward differences of the residuals (tree functions,
    smooth, no Newton iteration in them): half the digits, but no generation time."""
    tree = equations.tree
    return LoopJacobian(None, (), _definitions(tree.nq, tree.nv, constraints.nc, generated=False))


def _definitions(nq: int, nv: int, nc: int, *, generated: bool) -> str:
    how = "from mbs_loop_partials" if generated else "partials by differences of the residuals"
    lines = [f"#define MBS_JACOBIAN 1   /* mbs_jacobian exists (runtime/c/loop_jacobian.c, {how}) */",
             "#define MBS_LOOP_JACOBIAN 1",
             f"#define MBS_LOOP_JACOBIAN_NWORK {loop_jacobian_work_size(nq, nv, nc)}   /* doubles of work it needs */"]
    if generated:
        lines.append("int mbs_loop_partials(double t, const double *x, const double *p, double *out, double *work);")
    else:
        lines.append("#define MBS_LOOP_PARTIALS_BY_DIFFERENCES 1")
    lines.append("int mbs_jacobian(double t, const double *x, const double *p, double *out, double *work);")
    return "\n".join(lines)


def loop_jacobian(equations: Equations, constraints: Constraints) -> tuple[Equations, LoopJacobian]:
    """(equations on a tape that also holds the partial derivatives, the routine and its inputs)."""
    tree = equations.tree
    nq, nv, nc = tree.nq, tree.nv, constraints.nc
    nx = nq + nv
    q, v = tuple(tree.q_symbols), tuple(tree.v_symbols)
    a = tuple(sp.Symbol(f"jac_acc({s.name})") for s in v)
    lam = tuple(sp.Symbol(f"jac_lambda_{i}") for i in range(nc))
    # G = d gdot / d v on a first fork; its entries are temporaries the second differentiation reads
    fork, G = forward_derivatives(equations.tape, constraints.velocity, v, labels=[s.name for s in v])
    M, f = equations.mass_matrix, equations.forces
    r1 = [sum((M[i][j] * a[j] for j in range(nv)), sp.S.Zero) - f[i]
          - sum((G[k][i] * lam[k] for k in range(nc)), sp.S.Zero) for i in range(nv)]
    r2 = [sum((G[k][j] * a[j] for j in range(nv)), sp.S.Zero) + constraints.acceleration[k] for k in range(nc)]
    rows_of = r1 + r2 + list(constraints.velocity) + list(constraints.position) + list(equations.qdot)
    fork, rows = forward_derivatives(fork, rows_of, [*q, *v, t], labels=[s.name for s in q + v] + ["t"])
    results = [(i * (nx + 1) + k, d) for i, row in enumerate(rows) for k, d in enumerate(row)]
    kinematics = copy.copy(equations.kinematics)
    kinematics.tape = fork
    doc = ("[d R1; d R2; d gdot; d g; d qdot] / d [q, v, t] at x = [q; v; a; lambda], R1 = M a - f - G^T lambda, "
           "R2 = G a + gddot0 (rows MBS_NV + 3 MBS_NC + MBS_NQ, columns MBS_NX + 1, row-major; "
           "runtime/c/loop_jacobian.c)")
    routine = (PARTIALS, "out", doc, (nv + 3 * nc + nq, nx + 1), results, False)
    inputs = tuple((s, "x", nx + k) for k, s in enumerate(a)) + tuple((s, "x", nx + nv + k) for k, s in enumerate(lam))
    definitions = _definitions(nq, nv, nc, generated=True)
    return dataclasses.replace(equations, kinematics=kinematics), LoopJacobian(routine, inputs, definitions)


def loop_jacobian_work_size(nq: int, nv: int, nc: int) -> int:
    """Doubles of work runtime/c/loop_jacobian.c needs at the end of the work area (its MBS_LJ_NEEDED)."""
    nx = nq + nv
    rows = nv + 3 * nc + nq
    return rows * (nx + 1) + 4 * nv * nv + 4 * nx + 9 * nv + 4 * nc + 2 + nv * nv + nc * nv + 2 * rows + nx + 8
