"""What to tell the user when an explicit integrator finds the model stiff.

DOPRI5 (c/dopri5.c) only knows that its step has sat at the stability boundary for a while. This module turns
that into a diagnosis an engineer can act on, from the state where it happened:

* how stiff: the step DOPRI5 was held to, against the step accuracy alone would allow there (measured by
  letting RODASP, which is L-stable, take a few steps from the same state at the same tolerances);
* which motion: the fastest eigenvalue of the linearisation there and the coordinate that dominates its
  shape, with the interaction (and its force elements) that coordinate belongs to when the caller knows them;
* what to do instead: a stiff integrator.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .errors import EvaluationError
from .model import CompiledModel
from .workspace import Workspace

#: Steps RODASP takes to measure the accuracy-limited step size.
PROBE_STEPS = 20
#: What to use instead of an explicit method on a stiff model.
STIFF_INTEGRATORS = "rodas5p or rodasp (or auto, which switches by itself; Radau, BDF)"


def fastest_mode(data: Workspace, t: float, x) -> tuple[complex, str]:
    """(eigenvalue of largest modulus of d xdot / d x at (t, x), the coordinate that participates most in it).

    Participation factors |v_i w_i| (right and left eigenvector, Perez-Arriaga, Verghese and Schweppe 1982)
    rather than the shape alone: they measure how much the eigenvalue depends on the dynamics of each state,
    independent of units, so a stiff mount is named by its own coordinate, not by the relative coordinate of
    a body above it that moves along with it."""
    A = data.jacobian(t, x)[:, :-1] if "jacobian" in data.model.functions else _jacobian(data, t, x)
    values, right = np.linalg.eig(A)
    k = int(np.argmax(np.abs(values)))
    left = np.linalg.inv(right)[k]
    participation = np.abs(right[:, k] * left)
    from .linearize import position_names
    model = data.model
    # a coordinate and its speed move together in a mode: rank them as one, under the coordinate's name
    names = list(model.q_names) + list(position_names(model.v_names))
    strength: dict = {}
    for name, amount in zip(names, participation):
        strength[name] = strength.get(name, 0.0) + float(amount)
    return complex(values[k]), max(strength, key=strength.get)


def accuracy_limited_step(model: CompiledModel, data: Workspace, t: float, x, t_end: float, rtol: float, atol,
                          h: float) -> float:
    """The median of the last steps RODASP takes in PROBE_STEPS from (t, x), starting with h (NaN if it cannot)."""
    from .integrators import Rodasp
    if "rodasp" not in model.backend.native_methods:
        return float("nan")
    solver = Rodasp(data.function("rhs"), t, np.array(x, dtype=float), t_end, rtol=rtol, atol=atol,
                    first_step=min(h, t_end - t) if t_end > t else None)
    steps = []
    for _ in range(PROBE_STEPS):
        if solver.status != "running":
            break
        t_old = solver.t
        solver.step()
        steps.append(solver.t - t_old)
    # the first steps grow from a cautious guess: judge by the later ones
    return float(np.median(steps[-4:])) if steps else float("nan")


def describe_stiffness(model: CompiledModel, data: Workspace, integrator: str, stiffness: Mapping, t: float, x,
                       t_end: float, rtol: float, atol, owners: Mapping[str, str] | None = None) -> str:
    """One paragraph: when, how stiff, which motion, what to use instead (see the module docstring).

    stiffness: {"t", "h", "h_lambda"} of the explicit method; (t, x): a state near stiffness["t"];
    owners: coordinate name -> what it belongs to (e.g. "interaction mount_guide: force mount")."""
    h = stiffness["h"]
    text = [f"{integrator} found the model stiff at t = {stiffness['t']:.6g} s: its steps of {h:.3g} s are held "
            f"by stability (h |lambda| = {stiffness['h_lambda']:.3g}), not by accuracy"]
    try:
        h_acc = accuracy_limited_step(model, data, t, x, t_end, rtol, atol, h)
        if np.isfinite(h_acc) and h_acc > 0:
            text.append(f"; accuracy alone allows steps of {h_acc:.3g} s there ({h_acc / h:.3g} times larger)")
        lam, coordinate = fastest_mode(data, t, x)
        owner = (owners or {}).get(coordinate)
        text.append(f". The fastest motion, eigenvalue {_complex(lam)} 1/s (time constant {1 / abs(lam):.3g} s), "
                    f"is dominated by {coordinate}" + (f" ({owner})" if owner else ""))
    except (EvaluationError, np.linalg.LinAlgError, ValueError):
        text.append(". (The linearisation there failed, so the fast motion cannot be named.)")
    text.append(f". Use integrator {STIFF_INTEGRATORS}.")
    return "".join(text)


def _complex(z: complex) -> str:
    return f"{z.real:.4g}" if abs(z.imag) <= 1e-9 * abs(z) else f"{z.real:.4g} {'+' if z.imag >= 0 else '-'} " \
                                                                  f"{abs(z.imag):.4g}j"


def _jacobian(data: Workspace, t: float, x) -> np.ndarray:
    from .linearize import jacobian
    return jacobian(data, t, np.asarray(x, dtype=float))


def stiffness_warnings(model: CompiledModel, data: Workspace, solver, times: np.ndarray, states: np.ndarray,
                       t_end: float, owners: Mapping[str, str] | None = None) -> list[str]:
    """The run's stiffness warning (a list of zero or one paragraph) from a finished or failed solver."""
    found = getattr(solver, "stiffness", None)
    if not found:
        return []
    probe = Workspace(model)  # the diagnosis must not disturb the caller's workspace
    probe.p = data.p
    t, x = _stiff_state(probe, times, states, found["t"], t_end, solver)
    text = describe_stiffness(model, probe, solver.name, found, t, x, t_end, solver.rtol, solver.atol, owners)
    switched = getattr(solver, "switched_at", None)
    if switched is not None:
        text = text.replace(f". Use integrator {STIFF_INTEGRATORS}.", f"; auto switched to rodas5p at "
                                                                      f"t = {switched:.6g} s.")
    return [text]


def _stiff_state(data: Workspace, times: np.ndarray, states: np.ndarray, t_stiff: float, t_end: float, solver):
    """A state in the stiff regime: DOPRI5 rerun from the last sample before t_stiff until its test fires again
    (a few dozen steps), since the samples themselves may lie far from where stiffness set in."""
    from .integrators import Dopri5
    from .integrators.native import STIFF
    before = np.flatnonzero(times <= t_stiff)
    if before.size == 0:
        return solver.t, solver.y
    k = int(before[-1])
    if "dopri5" not in data.model.backend.native_methods:
        return float(times[k]), states[k]
    probe = Dopri5(data.function("rhs"), float(times[k]), states[k].copy(), t_end, rtol=solver.rtol,
                   atol=solver.atol, max_steps=100_000)
    probe.stop_on_stiffness()
    probe.sample(np.array([t_end]), np.empty((1, states.shape[1])))
    return (probe.t, probe.y) if probe.status == STIFF else (float(times[k]), states[k])
