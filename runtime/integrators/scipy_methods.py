"""scipy's solve_ivp methods behind our base class: RK45, DOP853, Radau, BDF, LSODA.

The adapter drives one scipy OdeSolver with the model's right-hand side (a C function called from
Python, or the NumPy back end) and translates its status into ours.  Each method is one line of data.
scipy.integrate (a third of a second to import) loads when a scipy method first runs, not with the registry.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..errors import EvaluationError, status_text
from .base import DenseOutput, OdeSolver
from .registry import register

_SCIPY_TOO_SMALL = "Required step size is less than spacing between numbers."
#: f where the model failed at a trial point: squared in the error norms without overflowing to inf - inf
_FAILED_VALUE = 1e100


class _ScipyDense(DenseOutput):
    def __init__(self, inner):
        super().__init__(inner.t_old, inner.t)
        self._inner = inner

    def _call_impl(self, t):
        return self._inner(t)


class ScipyMethod(OdeSolver):
    """Adapter for one scipy.integrate OdeSolver class (named ``scipy_name``; ``scipy_class`` once running)."""

    scipy_name: ClassVar[str]

    def __init__(self, fun, t0, y0, t_bound, **options):
        from scipy import integrate
        super().__init__(fun, t0, y0, t_bound, **options)
        self.scipy_class = getattr(integrate, self.scipy_name)
        kwargs = {"rtol": self.rtol, "atol": self.atol, "max_step": self.max_step}
        if self.first_step is not None:
            kwargs["first_step"] = min(self.first_step, max(t_bound - t0, 1e-300))
        if self.jac is not None and self.scipy_class in (integrate.Radau, integrate.BDF, integrate.LSODA):
            kwargs["jac"] = self.jac
        if self.min_step > 0 and self.scipy_class is integrate.LSODA:
            kwargs["min_step"] = self.min_step
        self._solver = None
        self._model_error: EvaluationError | None = None
        if self.status != "running":
            return
        try:
            self._solver = self.scipy_class(self._guarded(fun), t0, self.y, t_bound, **kwargs)
        except EvaluationError as exc:  # scipy evaluates f(t0, y0) while setting up
            self._fail(f"the model returned {status_text(exc.status)} at the initial state")

    def _guarded(self, fun):
        """f for scipy: after the first evaluation a model failure at a trial point (a Newton iterate or an
        error estimate of Radau far off, where a closed loop cannot be closed) answers a huge finite value,
        which scipy's methods see as an error far beyond the tolerance and reject with a smaller step (NaN would
        not do: Radau takes a NaN error norm for a passed test); the failure is named if the step collapses."""
        def f(t, y):
            if self._solver is None:
                return fun(t, y)  # the initial state: a failure there is final
            try:
                return fun(t, y)
            except EvaluationError as exc:
                self._model_error = exc
                return np.full(self.n, _FAILED_VALUE)
        return f

    def _step_impl(self):
        s = self._solver
        try:
            message = s.step()
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            if isinstance(exc, EvaluationError):
                raise
            # scipy's implicit methods raise from their linear algebra on NaN/inf (e.g. BDF's lu_factor)
            return False, f"{self.name} could not continue: {exc}"
        self.t, self.y, self.t_old = s.t, s.y, s.t_old
        self.nfev, self.njev, self.nlu = int(s.nfev), int(s.njev), int(s.nlu)
        self.nsteps += 1
        if s.status == "failed":
            exc = self._model_error
            model = f" (the model returned {status_text(exc.status)} at t = {exc.t:.6g} s)" if exc else ""
            if message == _SCIPY_TOO_SMALL:
                return False, f"step size collapsed to {_step_size(s):.3g} s{model}"
            return False, str(message) + model
        h = s.t - s.t_old
        if h < self.min_step and s.t < self.t_bound:  # only LSODA knows min_step itself
            return False, f"step size collapsed to {h:.3g} s (min_step = {self.min_step:g} s)"
        return True, None

    def _dense_output_impl(self):
        return _ScipyDense(self._solver.dense_output())


def _step_size(s) -> float:
    h = getattr(s, "h_abs", None) or s.step_size or 0.0
    return float(np.abs(h))


def _adapter(scipy_name: str, name: str, description: str) -> type[ScipyMethod]:
    cls = type(name, (ScipyMethod,), {"scipy_name": scipy_name, "name": name, "description": description,
                                      "__doc__": f"scipy's {name} through the common interface: {description}."})
    cls.__module__ = __name__
    return register(cls)


RK45 = _adapter("RK45", "RK45", "explicit Runge-Kutta 5(4), Python loop")
DOP853 = _adapter("DOP853", "DOP853", "explicit Runge-Kutta 8(5,3), Python loop")
Radau = _adapter("Radau", "Radau", "implicit Runge-Kutta Radau IIA order 5, stiff")
BDF = _adapter("BDF", "BDF", "backward differentiation formulas, stiff")
LSODA = _adapter("LSODA", "LSODA", "Adams/BDF with automatic stiffness switching")
