"""The mutable run state of one model (MuJoCo's mjData, Pinocchio's Data).

A :class:`Workspace` owns the time, state, parameters and work memory of one run, plus the model
functions bound to them.  Run-time functions take ``(model, data, ...)``; parallel runs use one
workspace each (a workspace is not shared between threads).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .errors import UsageError
from .model import CompiledModel

#: A model function bound to a workspace: f(t, x) -> a new array.
ModelFunction = Callable[[float, np.ndarray], np.ndarray]


class Workspace:
    """Run state of ``model``.

    Attributes:
        t (float): current time [s].
        x (ndarray (nx,)): current state [q; v], SI units; assigning copies into the existing array.
        p (ndarray (np,)): parameters, SI units; assigning copies in place, because the bound model
            functions read this very array (in-place edits such as ``data.p[1] = 2.0`` take effect at once).
        work (ndarray (nwork,)): work memory of the generated code (scratch, no meaning between calls).
        stats (dict): counters of the last run (nfev, nsteps, nreject, ...).

    Model functions are methods: ``data.rhs(t, x)``, ``data.mass_matrix(t, x)``, ``data.outputs(t, x)``
    ... each returns a new array per call and raises EvaluationError on a model status != 0; a function the
    back end lacks is a UsageError naming the ones it has.
    """

    def __init__(self, model: CompiledModel):
        self._init(model, np.zeros(model.nwork))

    def _init(self, model: CompiledModel, work: np.ndarray) -> None:
        self.model = model
        self.t = 0.0
        self._x = np.array(model.x0, dtype=float)
        self._p = np.array(model.p_default, dtype=float)
        self._work = work
        self.stats: dict[str, int] = {}
        # the model functions bound to this workspace, each made at its first use (a run uses about half of
        # them), then the same object at every call
        self._functions: dict = {}
        self._wrap = None

    @classmethod
    def _resumed(cls, model: CompiledModel, p: np.ndarray, x: np.ndarray, work: np.ndarray) -> "Workspace":
        """A workspace of ``model`` at t = 0 with copies of p, x and the work memory ``work`` (a state kept from an
        earlier start, mbs/system.py System._kept_start): as Workspace(model) with p, x and work then assigned, but
        the work memory copied once instead of zeroed and then overwritten (the Iltis: 172 kB a run)."""
        if work.shape != (model.nwork,):
            raise UsageError(f"work needs shape ({model.nwork},), got {work.shape}")
        data = cls.__new__(cls)
        data._init(model, np.array(work, dtype=float))
        data.p, data.x = p, x
        return data

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
        f = self._functions.get(name)
        if f is None:
            if name not in self.model.backend.functions:
                raise UsageError(f"model {self.model.name} has no function '{name}' (it has: "
                                 f"{', '.join(self.model.backend.functions)})")
            f = self.model.backend.function(name, self._p, self._work)
            if self._wrap is not None:
                f = self._wrap(f)
            self._functions[name] = f
        return f

    # -- the model functions, typed: each is the bound function itself, f(t, x) -> new ndarray (the C integrators
    #    recognise a C model's rhs by identity); EvaluationError on a model status != 0
    @property
    def rhs(self) -> ModelFunction:
        """x' = [qdot; vdot] (nx)."""
        return self.function("rhs")

    @property
    def mass_matrix(self) -> ModelFunction:
        """M(q) (nv x nv, row-major flat of nv*nv values), of the spanning tree."""
        return self.function("mass_matrix")

    @property
    def forces(self) -> ModelFunction:
        """f = applied generalized forces minus Coriolis and centrifugal terms (nv): M vdot = f (+ G^T lambda)."""
        return self.function("forces")

    @property
    def qdot(self) -> ModelFunction:
        """qdot(q, v) (nq): v itself, except for quaternions."""
        return self.function("qdot")

    @property
    def outputs(self) -> ModelFunction:
        """The outputs y (ny) in the order of model.y_names."""
        return self.function("outputs")

    @property
    def normalize(self) -> ModelFunction:
        """x with unit quaternions (models with quaternions or loops)."""
        return self.function("normalize")

    @property
    def project(self) -> ModelFunction:
        """x projected onto the loop-closure constraints (models with closed loops)."""
        return self.function("project")

    @property
    def constraint_jacobian(self) -> ModelFunction:
        """G = d(gdot)/dv (nc x nv) of the loop-closure constraints."""
        return self.function("constraint_jacobian")

    def __getattr__(self, name: str):
        """Model functions beyond the typed ones above (generated by later stages: events, jacobian, ...)."""
        model = self.__dict__.get("model")
        if model is not None and name in model.backend.functions:
            return self.function(name)
        raise AttributeError(f"'Workspace' object has no attribute '{name}'")

    def wrap_functions(self, wrap) -> None:
        """Bind every model function through wrap(f) (inputs driven from Python set parameters first): those made
        already now, the others when they are made."""
        self._functions = {name: wrap(f) for name, f in self._functions.items()}
        inner = self._wrap
        self._wrap = wrap if inner is None else (lambda f: wrap(inner(f)))

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
