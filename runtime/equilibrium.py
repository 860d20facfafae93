"""Static equilibrium: the configuration in which the system rests under gravity and its static forces.

Found by Newton's method on the reduced equations (runtime/equilibrium_newton.py) where it converges to a
stable solution, else by kinetic damping (dynamic relaxation, as in form-finding of structures): integrate from rest and,
whenever the kinetic energy passes a maximum, stop every velocity. The system then slides down into the
nearest minimum of its potential energy without any change to the model, and the constraints of closed
loops stay satisfied because the compiled right-hand side projects onto them. It needs no Jacobian, which
matters where coordinate partitions switch and a Newton step on all coordinates would leave the manifold.
Prescribed motions are frozen at their values at t. The velocities of x0 are put back at the end, so a
vehicle cruising at constant speed starts on its springs at that speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mbs.language.diagnostics import Diagnostic, MbsError

from .equilibrium_newton import newton_equilibrium
from .integrators import get_integrator
from .model import CompiledModel
from .states_equilibrium import equilibrium_with_states, rest_residual
from .workspace import Workspace

ACCELERATION_TOLERANCE = 1e-6  # m/s^2 or rad/s^2: what "at rest" means
MAX_STEPS = 20_000             # integrator steps before giving up (the Iltis vehicle settles in ~1300)


@dataclass(frozen=True)
class Equilibrium:
    x: np.ndarray      # (nx,) the equilibrium configuration, with the velocities given in x0
    residual: float    # max |vdot| there [m/s^2, rad/s^2]
    steps: int
    resets: int        # how often the velocities were stopped
    worst: str         # the velocity with the largest remaining acceleration


def _no_rest(model: CompiledModel, start: np.ndarray, ode) -> str:
    """Why the relaxation ran away: the kinetic energy never peaked, so the coordinate that moved furthest
    is falling (or driven) with nothing to stop it."""
    nq = model.nq
    y = np.asarray(ode.y, dtype=float)
    moved = np.abs(y[:nq] - start[:nq])
    if not moved.size or not np.all(np.isfinite(y)):
        return f"static equilibrium: the relaxation failed at t = {ode.t:.3g} s ({ode.message or 'no finite state'})"
    k = int(np.argmax(moved))
    return (f"no static equilibrium: '{model.q_names[k]}' moved {moved[k]:.3g} from its start and keeps speeding "
            "up with nothing to stop it: a part is free to fall or drift (give it a spring, a stop or a joint that "
            "holds it, or prescribe the coordinate)"
            + (f" [{ode.message}]" if ode.message else ""))


def _acceleration(data: Workspace, t: float, x: np.ndarray, nq: int) -> np.ndarray:
    return data.rhs(t, x)[nq:]


def static_equilibrium(model: CompiledModel, data: Workspace, x0: np.ndarray, t: float = 0.0) -> Equilibrium:
    nq = model.nq
    if model.nz:  # extra differential states rest too: a root of [vdot; zdot] (states_equilibrium.py)
        x = equilibrium_with_states(model, data, x0, t)
        residual, worst = rest_residual(model, data, x, t)
        x[nq:nq + model.nv] = np.asarray(x0, dtype=float)[nq:nq + model.nv]  # as below: the speeds it was given
        if "project" in model.functions:
            x = data.project(t, x)
        return Equilibrium(x, residual, 0, 0, worst)
    x = newton_equilibrium(model, data, x0, t)  # fast and exact where it finds a stable solution
    if x is None:
        x = np.array(x0, dtype=float)
        x[nq:] = 0.0
    frozen = lambda _t, y: data.rhs(t, y)  # noqa: E731  (prescribed motions held at time t)
    solver = get_integrator("RK45")  # driven from Python: this is set-up, not the hot path
    steps = resets = 0
    acc = None  # |vdot| at x, once evaluated there
    while steps < MAX_STEPS:
        acc = np.abs(_acceleration(data, t, x, nq))
        if acc.max() <= ACCELERATION_TOLERANCE:
            break
        ode = solver(frozen, 0.0, x, 1e9, rtol=1e-9, atol=1e-12)
        energy = previous = _kinetic_energy(data, t, x, nq)
        while steps < MAX_STEPS:
            ode.step()
            steps += 1
            if ode.status != "running":
                raise MbsError([Diagnostic("error", _no_rest(model, x, ode), None)])
            energy = _kinetic_energy(data, t, ode.y, nq)
            if energy < previous:  # past the peak: stop everything and start again from rest
                break
            previous = energy
        x = np.array(ode.y)
        x[nq:] = 0.0
        if "project" in model.functions:
            x = data.project(t, x)
        resets += 1
        acc = None  # (x moved)
    if acc is None:  # (else the loop's last check evaluated it at this x: the same call, the same values)
        acc = np.abs(_acceleration(data, t, x, nq))
    worst = model.v_names[int(np.argmax(acc))] if acc.size else ""
    # the run starts from here with the velocities it was given (a vehicle cruising at its speed)
    x[nq:] = np.asarray(x0, dtype=float)[nq:]
    if "project" in model.functions:
        x = data.project(t, x)
    if acc.size and acc.max() > ACCELERATION_TOLERANCE:
        raise MbsError([Diagnostic("error", f"no static equilibrium found after {steps} steps: the acceleration of "
                                            f"'{worst}' is still {acc.max():.3g} at t = {t:g} s (is a part free to "
                                            "fall, or a prescribed motion still moving then, such as a ramp that "
                                            "starts at t = 0? start it later)", None)])
    return Equilibrium(x, float(acc.max()) if acc.size else 0.0, steps, resets, worst)


def _kinetic_energy(data: Workspace, t: float, x: np.ndarray, nq: int) -> float:
    v = x[nq:]
    return 0.5 * float(v @ data.mass_matrix(t, x) @ v)
