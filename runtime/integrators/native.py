"""Integrators that run inside the compiled C library (c/ode.c and one C file per method).

The Python class only drives C: ``sample()`` hands C a whole array of output times and C integrates
across all of them without calling back into Python or allocating (the hot path of a simulation);
``step()`` takes one step in C, for callers that need step-by-step control.  The GIL is released while
C runs, so runs in separate threads (one workspace each) proceed in parallel.
"""

from __future__ import annotations

import math
import sys
from typing import ClassVar

import numpy as np

from ..errors import UsageError, status_text
from .base import EVENT, FAILED, FINISHED, DenseOutput, OdeSolver

# outcome codes of c/mbs_runtime.h (MBS_ODE_*)
_C_RUNNING, _C_FINISHED, _C_COLLAPSED, _C_TOO_MANY = 0, 101, 102, 103
_C_MODEL, _C_SINGULAR, _C_BAD_SAMPLE, _C_STIFF, _C_EVENT = 104, 105, 106, 107, 108
#: status of a run that stopped because it found stiffness (only when asked to: stop_on_stiff)
STIFF = "stiff"


def native_module(fun):
    """The compiled model module a C model function belongs to, or None."""
    module = sys.modules.get(type(fun).__module__)
    if module is not None and isinstance(getattr(module, "Function", None), type) \
            and isinstance(fun, module.Function) and hasattr(module, "Solver"):
        return module
    return None


class CoefficientDense(DenseOutput):
    """The dense output of a C method: ``rows`` coefficient vectors of n and the step size h, as the method's
    cont array holds them; a subclass evaluates them in ``_call_impl``, as the method's dense hook in C."""

    rows: ClassVar[int]

    def __init__(self, t_old, t, cont, n):
        super().__init__(t_old, t)
        self.c = np.asarray(cont[:self.rows * n]).reshape(self.rows, n)
        self.h = float(cont[self.rows * n])

    def coefficients(self, t):
        """(s, the coefficient vectors) at the times t (columns for an array of times)."""
        return (t - self.t_old) / self.h, [ci[:, None] if t.ndim else ci for ci in self.c]


class NativeSolver(OdeSolver):
    """Base of the C integrators: ``native_method`` names the entry in the C method table, and
    ``dense_class`` turns the C dense-output coefficients into a DenseOutput."""

    native_method: ClassVar[str]
    dense_class: ClassVar[type[DenseOutput]]

    def __init__(self, fun, t0, y0, t_bound, **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        module = native_module(fun)
        if module is None or self.native_method not in module.METHODS:
            raise UsageError(f"integrator '{self.name}' runs in C and needs the right-hand side of a model "
                             "built with the C back end; use 'RK45' or 'Radau' with the NumPy back end")
        #: {"t", "h", "h_lambda"} once an explicit method has found the problem stiff (c/dopri5.c), else None
        self.stiffness = None
        self._c = module.Solver(self.native_method, fun, self.t0, self.y, self.t_bound, self.rtol,
                                float(self.atol) if self.atol.ndim == 0 else self.atol,
                                first_step=self.first_step or 0.0,
                                max_step=0.0 if not math.isfinite(self.max_step) else self.max_step,
                                min_step=self.min_step, max_steps=self.max_steps)
        if self.events is not None:  # the C loop locates the crossings itself (c/ode.c)
            g, directions = self.events
            if native_module(g) is not module:
                raise UsageError("the event indicators must come from the same compiled model as the right-hand side")
            self._c.set_events(g, np.ascontiguousarray(directions, dtype=np.intc), self.g_old)
        self._sync()

    def _sync(self) -> None:
        c = self._c
        stats = c.stats
        self.t, self.y = c.t, c.y
        if stats["naccept"] > 0:
            self.t_old = c.t_old
        self.nfev, self.njev, self.nlu = stats["nfev"], stats["njev"], stats["nlu"]
        self.nsteps, self.nreject = stats["nsteps"], stats["nreject"]
        if c.stiff and self.stiffness is None:
            self.stiffness = {"t": c.stiff_t, "h": c.stiff_h, "h_lambda": c.stiff_hlamb}
        if c.status == _C_FINISHED:
            self.status = FINISHED
        elif c.status == _C_STIFF:
            self.status = STIFF
        elif c.status == _C_EVENT:
            self.status, self.g_old = EVENT, c.g_old
        elif c.status == _C_BAD_SAMPLE:
            raise UsageError("output times must increase and lie within [t0, t_bound]")
        elif c.status != _C_RUNNING:
            self._fail(self._reason(c))

    def _reason(self, c) -> str:
        model = f" (the model returned {status_text(c.model_status)})" if c.model_status else ""
        if c.status == _C_COLLAPSED:
            return f"step size collapsed to {c.fail_h:.3g} s{model}"
        if c.status == _C_TOO_MANY:
            return f"too many steps (max_steps = {self.max_steps}){model}"
        if c.status == _C_MODEL:
            return f"the model returned {status_text(c.model_status)} at t = {c.t:.6g} s"
        if c.status == _C_SINGULAR:
            return f"the iteration matrix is singular at every step size tried{model}"
        return f"unknown integrator status {c.status}"

    def stop_on_stiffness(self) -> None:
        """End the run (status STIFF) as soon as stiffness is detected, for a caller that switches method."""
        self._c.stop_on_stiff = 1
    @property
    def step_hint(self):
        return self._c.h if self._c.h > 0 else None

    def _find_event(self):
        """C has looked for events after its step already (c/ode.c)."""

    def restart_events_in_c(self, actions, tables, capacity: int, window: float) -> None:
        """Apply the events ``tables`` marks (runtime/event_loop.c_restart_tables) and restart inside the C
        sampling loop; ``take_event_log()`` returns what happened there."""
        self._c.set_restarts(actions, *tables, capacity, window)

    def take_over(self, old, g_before, g_event) -> None:
        """Before the first step: go on from the event ``old`` (a solver of the same events) handed back without a
        jump of the state, with what it had learned, as a restart in C would (c/mbs_python.c, mbs_ode_take_over):
        the first-step fractions per indicator and direction, the indicators' last events, the step a restart in C
        takes and DOPRI5's controller memory.  ``g_before``, ``g_event``: the indicators at the start of the step
        that found the event and at it (the ones that fired cross between them)."""
        if isinstance(old, NativeSolver) and type(old._c) is type(self._c):
            self._c.take_over(old._c, np.ascontiguousarray(g_before, dtype=float),
                              np.ascontiguousarray(g_event, dtype=float))

    def take_event_log(self) -> np.ndarray:
        return self._c.take_event_log()

    def _step_impl(self):
        self._c.step()
        self._sync()  # a failure is recorded here, with the reason from C
        return self.status != FAILED, self.message

    def _fail(self, reason: str) -> str:
        if self.status == FAILED:  # already failed in _sync; keep the first message
            return self.status
        return super()._fail(reason)

    def sample(self, t_eval, out, start=0):
        t_eval = np.ascontiguousarray(t_eval, dtype=float)
        status, index = self._c.sample(t_eval, out, int(start))
        self._sync()
        return index

    def _dense_output_impl(self):
        return self.dense_class(self.t_old, self.t, self._c.cont, self.n)
