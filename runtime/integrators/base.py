"""The one small base class of every integrator (after scipy's ``_ivp/base.py``).

Contract for a method (a subclass):

* ``__init__(fun, t0, y0, t_bound, *, rtol, atol, first_step, max_step, min_step, max_steps, jac)`` calls
  ``super().__init__`` first, then sets up its own state.  ``fun(t, y)`` returns a NEW array each call.
* ``_step_impl()`` advances ``self.t, self.y`` by one accepted step and sets ``self.t_old`` to the start
  of that step; it never passes ``t_bound``.  It returns ``(True, None)``, or ``(False, reason)`` for a
  numerical failure, where reason is a phrase such as ``"step size collapsed to 1e-14 s"``.  It may
  raise :class:`EvaluationError` (the model failed); ``step()`` turns that into a failure too.
* ``_dense_output_impl()`` returns a :class:`DenseOutput` valid on ``[t_old, t]``.
* Counters ``nfev, njev, nlu, nsteps, nreject`` are kept up to date by the method.

``step()`` does the bookkeeping: it refuses to run after the end, enforces ``max_steps`` and turns
failures into ``status = "failed"`` with ``message = "integration failed at t = ... s: reason"``.
Numerical failure never raises.  ``sample()`` fills output rows at given times from the dense output;
a method that can do that faster (in C) overrides it.  Integration runs forward only.
"""

from __future__ import annotations

from typing import Callable, ClassVar

import numpy as np

from mbs.language.catalog import DEFAULT_ATOL, DEFAULT_RTOL

from ..errors import EvaluationError, UsageError, status_text

RUNNING, FINISHED, FAILED = "running", "finished", "failed"
#: An event was located: t, y are the state at it (the step's end lies beyond); a new solver continues.
EVENT = "event"


class DenseOutput:
    """Interpolant of the last step on ``[t_old, t]``: ``d(t)`` is (n,) for a scalar t, (n, m) for m times
    (scipy's convention)."""

    def __init__(self, t_old: float, t: float):
        self.t_old, self.t = float(t_old), float(t)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        if t.ndim > 1:
            raise ValueError("t must be a scalar or a 1-D array")
        return self._call_impl(t)

    def _call_impl(self, t: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class OdeSolver:
    """Base of all integrators; see the module docstring for the contract with a method."""

    #: registry name, e.g. "dopri5" (set by subclasses)
    name: ClassVar[str] = ""
    #: one line for listings
    description: ClassVar[str] = ""

    def __init__(self, fun: Callable[[float, np.ndarray], np.ndarray], t0: float, y0, t_bound: float, *,
                 rtol: float = DEFAULT_RTOL, atol=DEFAULT_ATOL, first_step: float | None = None,
                 max_step: float = np.inf, min_step: float = 0.0, max_steps: int = 1_000_000,
                 jac: Callable[[float, np.ndarray], np.ndarray] | None = None, events=None):
        y0 = np.array(y0, dtype=float)
        if y0.ndim != 1:
            raise UsageError(f"y0 must be a vector, got shape {y0.shape}")
        if not t_bound >= t0:
            raise UsageError(f"t_bound = {t_bound} lies before t0 = {t0}; integration runs forward")
        if not rtol > 0:
            raise UsageError(f"rtol must be positive, got {rtol}")
        atol_arr = np.asarray(atol, dtype=float)
        if atol_arr.ndim > 1 or (atol_arr.ndim == 1 and atol_arr.shape != y0.shape) or (atol_arr < 0).any():
            raise UsageError("atol must be a non-negative scalar or one value per state")
        if first_step is not None and not first_step > 0:
            raise UsageError(f"first_step must be positive, got {first_step}")
        if not max_step > 0:
            raise UsageError(f"max_step must be positive, got {max_step}")
        self.fun = fun
        self.t, self.y = float(t0), y0
        self.t0, self.t_bound = float(t0), float(t_bound)
        self.t_old: float | None = None
        self.rtol, self.atol = float(rtol), atol_arr
        self.first_step, self.max_step, self.min_step = first_step, float(max_step), float(min_step)
        self.max_steps = int(max_steps)
        #: jac(t, y) -> d f/d y, (n, n), or None: the implicit methods then difference f themselves
        self.jac = jac
        self.n = y0.size
        self.status = FINISHED if self.t >= self.t_bound else RUNNING
        self.message = ""
        self.nfev = self.njev = self.nlu = self.nsteps = self.nreject = 0
        # events = (g(t, y) -> indicators, directions[, g at the start]): after each step the solver looks for
        # zero crossings (the start values may be given: the sign an indicator at zero is leaving with)
        self.events = events[:2] if events is not None else None
        self.g_old = None
        if events is not None:
            self.g_old = np.asarray(events[2] if len(events) > 2 else events[0](self.t, self.y), dtype=float)

    # -- public ------------------------------------------------------------------------------------

    def step(self) -> str:
        """Take one accepted step; returns the new status ("running", "finished" or "failed")."""
        if self.status != RUNNING:
            raise RuntimeError(f"step() on a {self.status} solver")
        if self.nsteps >= self.max_steps:
            return self._fail(f"too many steps (max_steps = {self.max_steps})")
        self._y_previous = self.y
        try:
            ok, reason = self._step_impl()
        except EvaluationError as exc:
            ok, reason = False, f"the model returned {status_text(exc.status)} at t = {exc.t:.6g} s"
        if not ok:
            return self._fail(reason or "unknown failure")
        if not np.all(np.isfinite(self.y)):  # some methods step on through NaN (scipy's BDF, LSODA)
            self.y = self._y_previous
            self.t = self.t_old if self.t_old is not None else self.t0
            return self._fail("the state became non-finite (NaN or inf)")
        if self.status == RUNNING and self.t >= self.t_bound:
            self.status = FINISHED
        if self.events is not None and self.status in (RUNNING, FINISHED):
            self._find_event()
        return self.status

    def _find_event(self) -> None:
        """After an accepted step: locate the earliest zero crossing on the dense output and stop there."""
        from ..events import crossings, locate_crossing
        g, directions = self.events
        if self.t == self.t_old:  # a step below the round-off of t (IDA's first after a restart): nothing crossed
            return
        g_new = np.asarray(g(self.t, self.y), dtype=float)
        crossed = crossings(self.g_old, g_new, directions)
        if crossed.size == 0:
            self.g_old = g_new
            return
        dense = self.dense_output()
        t_event = min(locate_crossing(lambda s, k=k: float(g(s, dense(s))[k]), self.t_old, self.t,
                                      float(self.g_old[k]), float(g_new[k])) for k in crossed)
        self.t, self.y, self.status = t_event, dense(t_event), EVENT

    def dense_output(self) -> DenseOutput:
        """Interpolant of the last accepted step."""
        if self.t_old is None:
            raise RuntimeError("dense_output() before the first step")
        return self._dense_output_impl()

    def sample(self, t_eval: np.ndarray, out: np.ndarray, start: int = 0) -> int:
        """Fill ``out[i] = y(t_eval[i])`` for i from ``start`` on, stepping as needed; ``t_eval`` must be
        increasing within [t0, t_bound].  Returns the index of the first row not filled: ``len(t_eval)``
        on success, less when the run failed (status and message tell why)."""
        i, n = start, len(t_eval)
        while i < n:
            if t_eval[i] == self.t and self.status != EVENT:  # the current point, also t0 before any step
                out[i] = self.y
                i += 1
            elif t_eval[i] < self.t:
                if self.t_old is None or t_eval[i] < self.t_old:
                    raise UsageError(f"output time {t_eval[i]:g} s lies before the current step")
                j = i + int(np.searchsorted(t_eval[i:], self.t, side="left"))
                out[i:j] = self.dense_output()(t_eval[i:j]).T
                i = j
            elif self.status == RUNNING:
                self.step()
            elif self.status == EVENT:  # samples from the event time on belong to the state after it
                break
            elif self.status == FINISHED:
                raise UsageError(f"output time {t_eval[i]:g} s lies beyond t_bound = {self.t_bound:g} s")
            else:
                break
        return i

    @property
    def step_hint(self) -> float | None:
        """The step size the method would try next, or None (then a restart chooses its own first step)."""
        return None

    @property
    def stats(self) -> dict[str, int]:
        return {"nfev": self.nfev, "njev": self.njev, "nlu": self.nlu, "nsteps": self.nsteps,
                "nreject": self.nreject}

    # -- for methods ---------------------------------------------------------------------------------

    def _step_impl(self) -> tuple[bool, str | None]:
        raise NotImplementedError

    def _dense_output_impl(self) -> DenseOutput:
        raise NotImplementedError

    def _fail(self, reason: str) -> str:
        self.status = FAILED
        self.message = f"integration failed at t = {self.t:.6g} s: {reason}"
        return self.status

