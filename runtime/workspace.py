"""The mutable run state of one model (MuJoCo's mjData, Pinocchio's Data).

A :class:`Workspace` owns the time, state, parameters and work memory of one run, plus the model
functions bound to them.  Run-time functions take ``(model, data, ...)``; parallel runs use one
workspace each (a workspace is not shared between threads).
"""

from __future__ import annotations

import numpy as np

from .errors import UsageError
from .model import CompiledModel


class Workspace:
    """Run state of ``model``.

    Attributes:
        t (float): current time [s].
        x (ndarray (nx,)): current state [q; v], SI units; assigning copies into the existing array.
        p (ndarray (np,)): parameters, SI units; assigning copies in place, because the bound model
            functions read this very array (in-place edits such as ``data.p[1] = 2.0`` take effect at once).
        work (ndarray (nwork,)): work memory of the generated code (scratch, no meaning between calls).
        stats (dict): counters of the last run (nfev, nsteps, nreject, ...).

    Model functions are attributes: ``data.rhs(t, x)``, ``data.mass_matrix(t, x)``, ``data.outputs(t, x)``
    ... each returns a new array per call and raises EvaluationError on a model status != 0.
    """

    def __init__(self, model: CompiledModel):
        self.model = model
        self.t = 0.0
        self._x = np.array(model.x0, dtype=float)
        self._p = np.array(model.p_default, dtype=float)
        self._work = np.zeros(model.nwork)
        self.stats: dict[str, int] = {}
        self._functions = {name: model.backend.function(name, self._p, self._work)
                           for name in model.backend.functions}

    @property
    def x(self) -> np.ndarray:
        return self._x

    @x.setter
    def x(self, value) -> None:
        self._x[...] = self._checked(value, self.model.nx, "x")

    @property
    def p(self) -> np.ndarray:
        return self._p

    @p.setter
    def p(self, value) -> None:
        self._p[...] = self._checked(value, self.model.np, "p")

    @property
    def work(self) -> np.ndarray:
        return self._work

    @staticmethod
    def _checked(value, size: int, what: str) -> np.ndarray:
        a = np.asarray(value, dtype=float)
        if a.shape != (size,):
            raise UsageError(f"{what} needs shape ({size},), got {a.shape}")
        return a

    def function(self, name: str):
        """The model function ``name`` bound to this workspace: ``f(t, x) -> new ndarray``."""
        try:
            return self._functions[name]
        except KeyError:
            raise UsageError(f"model {self.model.name} has no function '{name}' (it has: "
                             f"{', '.join(self._functions)})") from None

    def __getattr__(self, name: str):
        functions = self.__dict__.get("_functions", {})
        if name in functions:
            return functions[name]
        raise AttributeError(f"'Workspace' object has no attribute '{name}'")

    def wrap_functions(self, wrap) -> None:
        """Bind every model function through wrap(f) (inputs driven from Python set parameters first)."""
        self._functions = {name: wrap(f) for name, f in self._functions.items()}

    def set_param(self, name: str, value: float) -> None:
        """Set one parameter by name (SI units)."""
        self._p[self.model.parameter_index(name)] = value

    def reset(self) -> None:
        """Back to t = 0, the model's initial state and default parameters; counters cleared."""
        self.t = 0.0
        self._x[...] = self.model.x0
        self._p[...] = self.model.p_default
        self._work[...] = 0.0
        self.stats = {}

    def time_rhs(self, x=None, n: int = 10000, t: float | None = None) -> float:
        """Seconds per call of the right-hand side, n calls timed inside the back end (inside C for
        the C back end: no Python in the loop).  Defaults to the current t and x."""
        x = self._x if x is None else self._checked(x, self.model.nx, "x")
        return self.model.backend.time_call(self.function("rhs"), x, n, self.t if t is None else t)

    def __repr__(self) -> str:
        return f"Workspace(model={self.model.name!r}, t={self.t:g})"


def check_workspace(model: CompiledModel, data: Workspace) -> None:
    """Raise UsageError unless ``data`` is a workspace of ``model``."""
    if not isinstance(data, Workspace) or data.model is not model:
        raise UsageError(f"the workspace does not belong to model {model.name} (make one with Workspace(model))")


def evaluate(model: CompiledModel, data: Workspace, name: str = "rhs") -> np.ndarray:
    """Evaluate model function ``name`` at the workspace's current (t, x)."""
    check_workspace(model, data)
    return data.function(name)(data.t, data.x)
