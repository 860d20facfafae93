"""The state-space model of a linearisation: x' = A x + B u, y = C x + D u, with names and units, for control
design in scipy.signal or python-control.

    ss = system.linearize("hover")                  # a Linearization with A, B, C, D filled
    ss.to_scipy()                                   # scipy.signal.StateSpace
    ss.to_control()                                 # control.StateSpace (python-control, when installed)

States are the full state x = [q; v] of the compiled model (A as in Linearization.A); inputs are the model's
declared inputs (their run-time parameters u.NAME, see mbs.inputs); outputs the model's (or scene's) outputs
and the requested coordinates. Derivatives by central differences with the step of runtime.linearize.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .linearize import STEP
from .model import CompiledModel
from .workspace import Workspace


@dataclass(frozen=True)
class StateSpace:
    """A (nx, nx), B (nx, nu), C (ny, nx), D (ny, nu) with the names of x, u, y and their units."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    units: dict = field(default_factory=dict)

    def to_scipy(self):
        """scipy.signal.StateSpace (continuous time)."""
        from scipy import signal
        return signal.StateSpace(self.A, self.B, self.C, self.D)

    def to_control(self):
        """control.StateSpace with the signal names (python-control; ImportError when it is not installed)."""
        import control
        return control.ss(self.A, self.B, self.C, self.D, states=list(self.states), inputs=list(self.inputs),
                          outputs=list(self.outputs))

    def transfer_function(self, input: str, output: str):
        """(numerator, denominator) polynomial coefficients of output/input (scipy.signal.ss2tf)."""
        from scipy import signal
        j, i = self.inputs.index(input), self.outputs.index(output)
        num, den = signal.ss2tf(self.A, self.B, self.C, self.D, input=j)
        return num[i], den

    def table(self) -> str:
        """Inputs and outputs with their units (the matrices themselves are best read in numpy)."""
        def names(seq):
            return ", ".join(f"{n} [{self.units[n]}]" if n in self.units else n for n in seq) or "none"
        return (f"state space: {len(self.states)} states, {len(self.inputs)} inputs, {len(self.outputs)} outputs\n"
                f"  inputs:  {names(self.inputs)}\n  outputs: {names(self.outputs)}")


def state_space(model: CompiledModel, data: Workspace, t: float, x: np.ndarray, A: np.ndarray,
                inputs: dict[str, int], outputs: tuple[str, ...], step: float = STEP) -> StateSpace:
    """B, C, D about (t, x) for the inputs ({name: parameter index}) and outputs (names of model outputs or
    states), A given (the linearisation's full-state Jacobian)."""
    x = np.asarray(x, dtype=float)
    has_outputs = model.ny and "outputs" in model.functions
    y_index = {n: i for i, n in enumerate(model.y_names)} if has_outputs else {}
    x_index = {n: i for i, n in enumerate(model.x_names)}
    outputs = tuple(n for n in outputs if n in y_index or n in x_index)

    def y_of(xx: np.ndarray) -> np.ndarray:
        ys = data.outputs(t, xx) if y_index else np.zeros(0)
        return np.array([ys[y_index[n]] if n in y_index else xx[x_index[n]] for n in outputs])

    nx, nu, ny = x.size, len(inputs), len(outputs)
    B, C, D = np.zeros((nx, nu)), np.zeros((ny, nx)), np.zeros((ny, nu))
    for i in range(nx):
        h = step * max(1.0, abs(x[i]))
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        C[:, i] = (y_of(xp) - y_of(xm)) / (2 * h)
    p = data.p
    for j, k in enumerate(inputs.values()):
        u0 = p[k]
        h = step * max(1.0, abs(u0))
        try:
            p[k] = u0 + h
            rhs_p, y_p = data.rhs(t, x), y_of(x)
            p[k] = u0 - h
            rhs_m, y_m = data.rhs(t, x), y_of(x)
        finally:
            p[k] = u0
        B[:, j] = (rhs_p - rhs_m) / (2 * h)
        D[:, j] = (y_p - y_m) / (2 * h)
    units = {n: u for n, u in model.units.items() if n in set(model.x_names) | set(outputs)}
    units.update({name: model.units[f"u.{name}"] for name in inputs if f"u.{name}" in model.units})
    return StateSpace(A, B, C, D, tuple(model.x_names), tuple(inputs), outputs, units)
