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

Events (the switches of comparisons and kinks, `set` of modes and parameters) are located as in a run: the branch
held between crossings, each crossing found on the interpolant (runtime/events.py).  The state is continuous there;
its sensitivity jumps when the right-hand side does and the event time moves with the parameters (Hiskens and Pai,
"Trajectory sensitivity analysis of hybrid systems", IEEE Trans. Circuits Syst. I 47 (2000)):

    S+ = S- + (f- - f+) dtau/dp,    dtau/dp = -(dg/dx S- + dg/dp P) / (dg/dt + dg/dx f-)

(g the indicator, f-/f+ the right-hand side before/after).  A switch of a kink (max, abs: f continuous) or a time
event of fixed time (dtau/dp = 0) leaves S continuous.  The directional derivatives of g are central differences
(g is one scalar expression; step 1e-6 relative).  Events that make the state jump (`reinit`) or end the run are an
error here: their sensitivity rule is not built.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SimulationError, UsageError
from .event_loop import departing, settle_switches
from .events import crossings, init_switches, locate_crossing
from .friction import is_friction_event
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
    if model.events:
        t, z, dense, nfev = _across_events(model, data, augmented, z0, t_end, P, scales,
                                           dict(method=method, rtol=rtol, atol=atol_z, **options), t_eval)
    else:
        sol = solve_ivp(augmented, (data.t, t_end), z0, method=method, t_eval=t_eval, rtol=rtol, atol=atol_z,
                        dense_output=True, **options)
        if sol.status != 0:
            t_fail = sol.t[-1] if sol.t.size else data.t
            raise SimulationError(f"sensitivity integration of {model.name} failed at t = {t_fail:g} s: "
                                  f"{sol.message}")
        t, z, dense, nfev = sol.t, sol.y.T, sol.sol, int(sol.nfev)
    return SensitivityRun(t, z[:, :nx].copy(), z[:, nx:].reshape(len(t), k, nx).transpose(0, 2, 1).copy(),
                          dense, nfev)


#: Relative step of the central differences of an indicator at an event.
EVENT_STEP = 1e-6


def _across_events(model, data, augmented, z0, t_end, P, scales, options, t_eval):
    """(t, z, dense, nfev) of the augmented run with the model's events located and applied (see the module's
    docstring); data.p is left as it was."""
    from scipy.integrate import OdeSolution
    from scipy.integrate._ivp.ivp import METHODS as SCIPY

    blocked = [e.name for e in model.events if e.terminal or any(a == "x" for a, _, _ in e.assignments)
               or is_friction_event(model, e.name)]
    if blocked:
        raise UsageError(f"model {model.name}: event {', '.join(repr(n) for n in blocked)} makes the state jump, "
                         "ends the run or switches friction between stick and slip; sensitivities across such "
                         "events are not built (the rule for the jump of S is not implemented)")
    nx, k = len(data.x), P.shape[1]
    g = data.function("events")
    actions = data.function("event_actions") if "event_actions" in model.functions else None
    directions = np.array([e.direction for e in model.events])
    p_saved = data.p.copy()
    t, z = data.t, z0.copy()
    init_switches(model, data, t, z[:nx])
    ts, interpolants, nfev = [t], [], 0
    out_t, out_z, i = np.asarray(t_eval, dtype=float), [], 0
    try:
        while True:
            g_old = departing(data, g, t, z[:nx])
            if settle_switches(model, data, g_old):
                g_old = departing(data, g, t, z[:nx])
            solver = SCIPY[options["method"]](augmented, t, z, t_end, rtol=options["rtol"], atol=options["atol"],
                                              **({"jac": options["jac"]} if "jac" in options else {}))
            event = None
            while solver.status == "running" and event is None:
                message = solver.step()
                if solver.status == "failed":
                    raise SimulationError(f"sensitivity integration of {model.name} failed at t = {solver.t:g} s: "
                                          f"{message}")
                step = solver.dense_output()
                g_new = np.asarray(g(solver.t, solver.y[:nx]), dtype=float)
                fired = crossings(g_old, g_new, directions)
                t_end_step = solver.t
                if fired.size:
                    times = [locate_crossing(lambda s, j=j: g(s, step(s)[:nx])[j], solver.t_old, solver.t,
                                             g_old[j], g_new[j]) for j in fired]
                    t_end_step = min(times)
                    event = fired[np.array(times) <= t_end_step]
                    rising = g_new > g_old
                g_old = g_new
                ts.append(t_end_step)
                interpolants.append(step)
                while i < out_t.size and out_t[i] <= t_end_step:
                    out_z.append(step(out_t[i]))
                    i += 1
            nfev += solver.nfev
            if event is None:
                break
            t = ts[-1]
            z = _jump(model, data, g, actions, event, rising, t, interpolants[-1](t), nx, k, P, scales)
            if i and out_t[i - 1] == t:
                out_z[-1] = z.copy()  # a sample at the event takes the value from the event on
    finally:
        data.p[:] = p_saved
    out_z = np.array(out_z).reshape(len(out_z), -1)
    return out_t[:len(out_z)], out_z, OdeSolution(ts, interpolants), nfev


def _jump(model, data, g, actions, fired, rising, t, z, nx, k, P, scales):
    """The augmented state after the events ``fired`` at t: x unchanged, the branches and `set` values applied,
    S+ = S- + (f- - f+) dtau/dp (module docstring)."""
    x = z[:nx]
    S = z[nx:].reshape(k, nx).T
    f_before = np.asarray(data.rhs(t, x), dtype=float).copy()
    h = EVENT_STEP * max(1.0, abs(t))
    rate = np.array([(g(t + h, x + h * f_before)[j] - g(t - h, x - h * f_before)[j]) / (2 * h) for j in fired])
    moves = np.empty((len(fired), k))
    p0 = data.p.copy()
    for c in range(k):
        dp = EVENT_STEP * scales[c]
        plus, minus = p0 + dp * P[:, c], p0 - dp * P[:, c]
        data.p[:] = plus
        g_plus = np.asarray(g(t, x + dp * S[:, c]), dtype=float)
        data.p[:] = minus
        g_minus = np.asarray(g(t, x - dp * S[:, c]), dtype=float)
        data.p[:] = p0
        moves[:, c] = (g_plus[fired] - g_minus[fired]) / (2 * dp)
    # the earliest-located event sets the time; simultaneous ones share it (the first indicator's rate rules)
    dtau = -moves[0] / rate[0]
    values = actions(t, x) if actions is not None else ()
    for j in fired:
        spec = model.events[j]
        for array, index, slot in spec.assignments:
            data.p[index] = values[slot]
        if spec.switch >= 0:
            data.p[spec.switch] = 1.0 if rising[j] else 0.0
    f_after = np.asarray(data.rhs(t, x), dtype=float)
    S = S + np.outer(f_before - f_after, dtau)
    return np.concatenate([x, S.T.reshape(-1)])
