"""Forward sensitivities: the state and its derivatives S = dx/dp with respect to chosen parameters, integrated
together.

    x' = f(t, x, p)                     S' = (df/dx) S + (df/dp) P          S(0) = dx0/dp

df/dx and df/dp are the generated routines mbs_jacobian and mbs_param_jacobian (compiler/jacobian.py: forward
differentiation of the equations' tape, so exact to rounding). P (NP x k) says how every model parameter moves
with the k chosen ones: a parameter whose default is an expression of another (`l2 = 2 * l`) follows it, as it
does in a variant run with `--param l=...`; S(0) is the initial state's dependence (a joint's `init phi = theta0`,
or an equilibrium start). Both come from the caller (mbs.sensitivity: central differences of the start, which is
algebraic and cheap).

The augmented system is integrated by one of scipy's methods (DOP853 by default) with a Python right-hand side
that calls three generated C functions and does one small matrix product per stage: a few microseconds of
Python per evaluation instead of none, which is the price of not writing a second C integrator for the augmented
state; for the model sizes sensitivities are asked of (tens of states, a few parameters) a run takes
milliseconds to seconds. The error control covers S as well as x (like CVODES with errconS), so the sensitivities
are as accurate as the state. Implicit methods (Radau, BDF) get the block-diagonal approximation kron(I, df/dx)
of the augmented Jacobian, which is what their Newton iteration needs (the omitted terms are second derivatives).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SimulationError, UsageError
from .model import CompiledModel
from .workspace import Workspace, check_workspace

#: scipy methods the augmented system may be integrated with.
METHODS = ("DOP853", "RK45", "Radau", "BDF", "LSODA")
IMPLICIT = ("Radau", "BDF", "LSODA")


@dataclass(frozen=True)
class SensitivityRun:
    """A run with its sensitivities: t (n,), x (n, nx), S (n, nx, k) = dx/dp_k at each sample; `dense(t)` the
    augmented state [x; S[:, 0]; S[:, 1]; ...] between samples (the integrator's interpolant)."""

    t: np.ndarray
    x: np.ndarray
    S: np.ndarray
    dense: object
    nfev: int

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(x, S) at any t of the run, from the interpolant."""
        z = self.dense(t)
        nx = self.x.shape[1]
        return z[:nx], z[nx:].reshape(-1, nx).T


def integrate_sensitivities(model: CompiledModel, data: Workspace, t_end: float, directions: np.ndarray,
                            S0: np.ndarray, *, t_eval: np.ndarray, method: str = "DOP853", rtol: float = 1e-8,
                            atol: float = 1e-10, scales=None) -> SensitivityRun:
    """Integrate x and S = dx/dp from the workspace's (t, x, p) to t_end, sampled at t_eval.

    directions: P (np x k), d(model parameters)/d(chosen parameters); S0: dx0/dp (nx x k); scales: a typical size
    of each chosen parameter, so the absolute tolerance of S_k is atol / scale_k (S_k has units of x / p_k)."""
    from scipy.integrate import solve_ivp

    check_workspace(model, data)
    for name in ("jacobian", "param_jacobian"):
        if name not in model.functions:
            raise UsageError(f"model {model.name} has no generated {name.replace('_', ' ')}: sensitivities need "
                             "a tree whose right-hand side can be differentiated (no lookup tables, no closed loops)")
    if method not in METHODS:
        raise UsageError(f"sensitivities integrate with one of {', '.join(METHODS)}, not '{method}'")
    nx = model.nx
    P = np.asarray(directions, dtype=float).reshape(model.np, -1)
    k = P.shape[1]
    S0 = np.asarray(S0, dtype=float).reshape(nx, k)
    rhs, jac, pjac = data.function("rhs"), data.function("jacobian"), data.function("param_jacobian")
    dz = np.empty(nx * (k + 1))

    def augmented(t, z):
        x = z[:nx]
        S = z[nx:].reshape(k, nx).T
        dz[:nx] = rhs(t, x)
        dz[nx:] = (jac(t, x)[:, :nx] @ S + pjac(t, x) @ P).T.reshape(-1)
        return dz.copy()

    def augmented_jacobian(t, z):
        return np.kron(np.eye(k + 1), jac(t, z[:nx])[:, :nx])

    scales = np.ones(k) if scales is None else np.maximum(np.abs(np.asarray(scales, dtype=float)), 1e-300)
    atol_z = np.concatenate([np.full(nx, atol), *(np.full(nx, atol / s) for s in scales)])
    z0 = np.concatenate([data.x, S0.T.reshape(-1)])
    options = {"jac": augmented_jacobian} if method in IMPLICIT else {}
    sol = solve_ivp(augmented, (data.t, t_end), z0, method=method, t_eval=t_eval, rtol=rtol, atol=atol_z,
                    dense_output=True, **options)
    if sol.status != 0:
        t_fail = sol.t[-1] if sol.t.size else data.t
        raise SimulationError(f"sensitivity integration of {model.name} failed at t = {t_fail:g} s: {sol.message}")
    z = sol.y.T
    return SensitivityRun(sol.t, z[:, :nx].copy(), z[:, nx:].reshape(len(sol.t), k, nx).transpose(0, 2, 1).copy(),
                          sol.sol, int(sol.nfev))
