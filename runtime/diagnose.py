"""Why a run failed, in the model's own names: which coordinates a singular mass matrix leaves undetermined.

The generated code only knows that a pivot of the mass matrix was not positive; the user needs to know which
coordinates have no mass or inertia to move them, at which time and state, and which parameters made it so.
This runs once, after a failure, on the mass matrix evaluated in the failing state (never on the hot path).
"""

from __future__ import annotations

import numpy as np

from .errors import EvaluationError
from .model import CompiledModel
from .workspace import Workspace

SINGULAR = "singular mass matrix"
#: An eigenvalue of M below this fraction of the largest counts as zero.
RELATIVE_ZERO = 1e-12
#: A coordinate takes part in a null direction when its component is at least this (of a unit vector).
INVOLVED = 0.1
#: State values shown in a message (the rest are counted).
SHOWN = 8


def explain_failure(model: CompiledModel, data: Workspace, message: str, t: float, x) -> str:
    """`message`, with the coordinates, time and state of a singular mass matrix added when it says so."""
    if SINGULAR not in message or "mass_matrix" not in model.functions:
        return message
    try:
        return f"{message}: {singular_mass_matrix(model, data, t, np.asarray(x, dtype=float))}"
    except Exception:  # noqa: BLE001 - a diagnosis must never hide the failure it explains
        return message


def singular_mass_matrix(model: CompiledModel, data: Workspace, t: float, x: np.ndarray) -> str:
    """Which coordinates have no (or negative) mass or inertia in state x at time t, and the state."""
    try:
        m = data.function("mass_matrix")(t, x)
    except EvaluationError as exc:  # the matrix is there, only its factorisation failed
        if exc.values is None:
            raise
        m = exc.values
    m = np.asarray(m, dtype=float).reshape(model.nv, model.nv)
    speeds = [_coordinate(name) for name in model.v_names]
    if not np.all(np.isfinite(m)):
        bad = sorted({speeds[i] for i, j in zip(*np.nonzero(~np.isfinite(m)))})
        what = f"the mass matrix is not finite in the rows of {', '.join(bad)}"
    else:
        values, vectors = np.linalg.eigh((m + m.T) / 2)
        scale = max(np.abs(values).max(), 1e-300)
        weak = [k for k, v in enumerate(values) if v <= RELATIVE_ZERO * scale]
        involved = sorted({speeds[i] for k in weak for i in np.nonzero(np.abs(vectors[:, k]) >= INVOLVED)[0]})
        negative = any(values[k] < -RELATIVE_ZERO * scale for k in weak)
        if negative:
            what = (f"the mass matrix is not positive definite along {', '.join(involved)} (a negative mass or "
                    "inertia?)")
        else:
            what = f"no mass or inertia determines the motion of {', '.join(involved) or 'some coordinate'}"
    state = ", ".join(f"{name} = {value:.6g}" for name, value in zip(model.x_names[:SHOWN], x))
    more = f" (and {model.nx - SHOWN} more)" if model.nx > SHOWN else ""
    return f"{what}, at t = {t:.6g} s in the state {state}{more}{_suspect_parameters(model, data)}"


def _coordinate(speed_name: str) -> str:
    """'der(hinge.phi)' -> 'hinge.phi'; a quaternion joint's angular speed 'j.wx' stays as it is."""
    return speed_name[4:-1] if speed_name.startswith("der(") and speed_name.endswith(")") else speed_name


def _suspect_parameters(model: CompiledModel, data: Workspace) -> str:
    """Parameters that are zero, negative or not finite (a mass or inertia among them is the likely cause)."""
    suspects = [f"{name} = {value:g}" for name, value in zip(model.p_names, data.p)
                if not np.isfinite(value) or value <= 0]
    return f"; parameters that are zero, negative or not finite: {', '.join(suspects)}" if suspects else ""
