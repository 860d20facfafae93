"""The Jacobian of the right-hand side, generated: the routine `mbs_jacobian` for the stiff integrators.

    int mbs_jacobian(double t, const double *x, const double *p, double *out, double *work);
    out = J: MBS_NX rows of MBS_NX + 1 columns, row-major: J[i][j] = d xdot_i / d x_j, the last column d xdot_i / d t.

The implicit integrators (rodasp, Radau, BDF, CVODE) need d f / d x at every step or so; by finite
differences that is nx + 1 evaluations of the right-hand side and only half the digits. Here the derivatives
are taken once, symbolically, by forward differentiation of the tape the right-hand side is evaluated on
(compiler/differentiate.py), so they are exact and cost about one right-hand side per state they depend on.
The time column is there because a Rosenbrock method needs d f / d t as well when the model is driven by
t (a road profile, a prescribed motion).

Only trees: with closed loops the right-hand side is the run-time loop solver's (runtime/c/loops.c), not a
tape result, and the integrators keep their checked finite differences.
"""

from __future__ import annotations

import copy
import dataclasses

from .differentiate import NotDifferentiable, forward_derivatives
from .equations import Equations
from .integrator_names import JACOBIAN_INTEGRATORS  # noqa: F401  (where it was defined before)
from .tree import t


def jacobian_or_none(equations: Equations) -> tuple[Equations, tuple | None]:
    """`jacobian_routine`, or (equations, None) when the right-hand side has no printable derivative (a lookup
    table): the integrators then use their finite differences."""
    try:
        return jacobian_routine(equations)
    except NotDifferentiable:
        return equations, None


def parameter_jacobian_or_none(equations: Equations, parameters) -> tuple[Equations, tuple | None]:
    """`parameter_jacobian_routine`, or (equations, None) without a printable derivative (a lookup table)."""
    try:
        return parameter_jacobian_routine(equations, parameters)
    except NotDifferentiable:
        return equations, None


def jacobian_routine(equations: Equations) -> tuple[Equations, tuple]:
    """(equations on a tape that also holds the derivatives, the routine in emit_common's format)."""
    tree = equations.tree
    states = tree.x_symbols
    nx = len(states)
    fork, rows = forward_derivatives(equations.tape, equations.rhs, [*states, t],
                                     labels=[s.name for s in states] + ["t"])
    results = [(i * (nx + 1) + k, d) for i, row in enumerate(rows) for k, d in enumerate(row)]
    kinematics = copy.copy(equations.kinematics)
    kinematics.tape = fork
    routine = ("mbs_jacobian", "out", "J = [d xdot/d x | d xdot/d t] (nx rows, nx + 1 columns, row-major) by forward "
               "differentiation of the tape", (nx, nx + 1), results, False)
    return dataclasses.replace(equations, kinematics=kinematics), routine


def parameter_jacobian_routine(equations: Equations, parameters) -> tuple[Equations, tuple]:
    """(equations on a tape that also holds d xdot / d p, the routine `mbs_param_jacobian`):

        int mbs_param_jacobian(double t, const double *x, const double *p, double *out, double *work);
        out = MBS_NX rows of MBS_NP columns, row-major: d xdot_i / d p_k at fixed (t, x).

    The forcing term of the forward sensitivity equations S' = (df/dx) S + df/dp (mbs.runtime.sensitivity).
    Raises NotDifferentiable when a parameter reaches the right-hand side through a lookup table."""
    parameters = list(parameters)
    npar = len(parameters)
    fork, rows = forward_derivatives(equations.tape, equations.rhs, parameters,
                                     labels=[s.name for s in parameters])
    results = [(i * npar + k, d) for i, row in enumerate(rows) for k, d in enumerate(row)]
    kinematics = copy.copy(equations.kinematics)
    kinematics.tape = fork
    doc = "d xdot/d p (nx rows, np columns, row-major) by forward differentiation of the tape"
    routine = ("mbs_param_jacobian", "out", doc, (len(rows), npar), results, False)
    return dataclasses.replace(equations, kinematics=kinematics), routine
