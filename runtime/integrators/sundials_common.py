"""The shared driver of the SUNDIALS integrators (CVODE, IDA) through scikit-sundae.

SUNDIALS is the reference implementation of variable-order multistep methods (Adams 1-12, BDF 1-5) and of
the DAE solver IDA (Hindmarsh et al., ACM TOMS 31, 2005); scikit-sundae ships its libraries as a wheel, so
nothing is compiled here. The model's compiled right-hand side (and, when the model has one, the generated
Jacobian, compiler/jacobian.py) are called from SUNDIALS through Python callbacks.

Stepping: one internal SUNDIALS step per ``step()`` ("onestep" mode, never past t_bound), so the step
counter is exact; samples inside the last step come from SUNDIALS' own interpolation of its Nordsieck
history (CVodeGetDky / IDAGetDky through a "normal" call behind the current time), which has the method's
order, not a cubic of ours.

Events: ``events=(g, directions[, g_start])`` as for every integrator (base.py): after each internal step the
crossings of the model's indicators are located on SUNDIALS' interpolant by the shared root finder
(runtime/events.py), to the round-off of t, and the events module's loop restarts SUNDIALS after each.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..errors import EvaluationError, UsageError, status_text
from .base import EVENT, DenseOutput, OdeSolver


class _SundialsDense(DenseOutput):
    """SUNDIALS' interpolant of its last step (valid until the next step)."""

    def __init__(self, owner):
        super().__init__(owner.t_old, owner.t)
        self._owner = owner

    def _call_impl(self, t):
        values = [self._owner._interpolate(float(s)) for s in np.atleast_1d(t)]
        return np.array(values).T if t.ndim else values[0]


class SundialsSolver(OdeSolver):
    """Base of cvode_adams, cvode_bdf and ida: builds the scikit-sundae solver (``_make``) and steps it."""

    stiff: ClassVar[bool] = True

    def __init__(self, fun, t0, y0, t_bound, **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        self._error: EvaluationError | None = None
        self._solver = None
        self.last = None  # the last result of scikit-sundae (events found, message)
        if self.status != "running":
            return
        settings = {"rtol": self.rtol, "atol": self.atol if self.atol.ndim else float(self.atol),
                    "max_num_steps": 1_000_000_000, "max_step": 0.0 if not np.isfinite(self.max_step) else
                    self.max_step, "min_step": self.min_step}
        if self.first_step is not None:
            settings["first_step"] = self.first_step
        try:
            self._solver = self._make(settings)
        except EvaluationError as exc:
            self._fail(f"the model returned {status_text(exc.status)} at the initial state")
        except ModuleNotFoundError as exc:  # a dependency of the package, but an install may have skipped it
            raise UsageError(f"integrator '{self.name}' needs scikit-sundae (SUNDIALS), which is not installed "
                             f"({exc}); pip install scikit-sundae, or choose dopri5, rodasp or a scipy method") \
                from None

    # -- for the subclasses -----------------------------------------------------------------------------

    def _make(self, settings: dict):
        """The initialised scikit-sundae solver (init_step done)."""
        raise NotImplementedError

    def _f(self, t, y, out) -> None:
        """out = f(t, y); a model failure is remembered and answered with NaN, which SUNDIALS rejects."""
        try:
            out[:] = self.fun(t, y)
        except EvaluationError as exc:
            self._error = exc
            out[:] = np.nan

    # -- stepping -------------------------------------------------------------------------------------------

    def _step_impl(self):
        result = self._solver.step(self.t_bound, method="onestep", tstop=self.t_bound)
        if result.success and float(result.t) == self.t:  # the first call after an interpolation returns at once
            result = self._solver.step(self.t_bound, method="onestep", tstop=self.t_bound)
        self.last = result
        self.nfev, self.njev = int(result.nfev), int(result.njev)
        if not result.success or result.status < 0:
            if self._error is not None:
                exc = self._error
                return False, f"the model returned {status_text(exc.status)} at t = {exc.t:.6g} s"
            return False, f"{self.name}: {result.message}"
        self.t_old, self.t = self.t, float(result.t)
        self.y = np.array(result.y)
        self.nsteps += 1
        if self.t >= self.t_bound * (1 - 1e-15) and self.t >= self.t_bound - 1e-12 * max(1.0, abs(self.t_bound)):
            self.t = self.t_bound
        return True, None

    def _interpolate(self, t: float) -> np.ndarray:
        if t == self.t:
            return self.y.copy()
        return np.array(self._solver.step(t).y)  # behind the current time: interpolation, no stepping

    def _dense_output_impl(self):
        return _SundialsDense(self)

    def sample(self, t_eval, out, start=0):
        i, n = start, len(t_eval)
        while i < n:
            if t_eval[i] == self.t and self.status != EVENT:  # at an event: a row of the next solver
                out[i] = self.y
                i += 1
            elif t_eval[i] < self.t and self.t_old is not None and t_eval[i] >= self.t_old:
                out[i] = self._interpolate(float(t_eval[i]))
                i += 1
            elif self.status == "running" and t_eval[i] > self.t:
                self.step()
            else:
                return super().sample(t_eval, out, i)  # the base class's checks and messages
        return i
