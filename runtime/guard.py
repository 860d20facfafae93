"""Interruption and guards of a run: nothing computed is lost, and nothing stalls silently.

A run ends early, keeping every sample computed so far, when
- the user interrupts it: Ctrl-C (SIGINT) or SIGTERM while it integrates (a second Ctrl-C aborts at once);
- the progress callback returns False;
- the wall time exceeds the user's limit (``max_wall_time``);
- it stalls: over ``stall_time`` seconds of wall time the simulated time advanced by less than STALL_FRACTION
  of the interval while steps went on. The message names the time, the step size, what the integrator was
  doing (steps, rejections, factorisations) and the likely cause.

The C integrators run in budgets of steps (``Solver.budget``) so that control returns to Python between them
to look at signals, the clock and the progress; a budget costs one return from C, nothing on the hot path. A
budget holds about SLICE_WALL seconds of steps at the rate measured so far (FIRST_SLICE steps first, at most
SLICE_STEPS): a model whose step costs a tenth of a second (a Jacobian of a large closed mechanism) is checked
every second or so, not every 2000 steps. The scipy methods are checked between output chunks.
"""

from __future__ import annotations

import functools
import signal
import threading
import time
import weakref
from typing import Callable

try:  # signal's C function, which signal.signal wraps (see RunGuard.__enter__); CPython's, so the public one elsewhere
    from _signal import signal as _install_handler
except ImportError:  # pragma: no cover - another Python implementation
    from signal import signal as _install_handler

import numpy as np

#: Most steps a C integrator takes before control comes back to check the guards ...
SLICE_STEPS = 2000
#: ... the first budget of steps (before the cost of a step is known) ...
FIRST_SLICE = 50
#: ... and the wall time [s] a budget aims at.
SLICE_WALL = 0.5
#: A run whose simulated time advanced less than this fraction of its interval ...
STALL_FRACTION = 1e-6
#: ... over this many seconds of wall time is stalled.
STALL_TIME = 60.0

Progress = Callable[[float, float], "bool | None"]
#: The signals a run catches (their numbers: _signal.signal takes no enums).
_SIGNALS = (int(signal.SIGINT), int(signal.SIGTERM))


class RunGuard:
    """One run's guards. Use as a context manager around the integration (it installs the signal handlers
    in the main thread and restores them after), pass ``progress`` to the driver and ``watch(solver)``."""

    def __init__(self, t0: float, t_end: float, progress: Progress | None = None,
                 max_wall_time: float | None = None, stall_time: float | None = STALL_TIME):
        if max_wall_time is not None and not max_wall_time > 0:
            from .errors import UsageError
            raise UsageError(f"max_wall_time must be a positive number of seconds, got {max_wall_time}")
        self.t0, self.t_end = t0, t_end
        self.user_progress = progress
        self.max_wall_time, self.stall_time = max_wall_time, stall_time
        self.reason = ""        # why the run was stopped ('' while it runs)
        self.detail = ""        # what the integrator was doing then, and the likely cause (a stall)
        self.interrupted = ""   # the signal's name, when a signal stopped it
        self.started = time.monotonic()
        self._mark = (self.started, t0, 0, 0)  # (wall time, t, steps, rejected) where the stall window began
        self._previous: dict = {}
        self.watched = False    # a C integrator checked between budgets of steps (watch)

    @property
    def chunks(self) -> int | None:
        """How many output chunks the driver should run between progress checks (None: its default). A watched C
        integrator is checked between its budgets of steps already (signals, wall time, stalls), so it runs the
        samples in one call unless the user asked for progress reports."""
        return 1 if (self.watched and self.user_progress is None) else None

    # -- signals: installed and restored by _install_handler (_signal.signal, the C function signal.signal wraps: the
    #    wrapper turns numbers into enums and back, and for a handler that is a function (Python's Ctrl-C handler,
    #    ours) finds none by raising and catching a ValueError: 110 k of the 113 k instructions of a run's four calls)
    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in _SIGNALS:
                try:
                    self._previous[sig] = _install_handler(sig, self._on_signal)
                except (ValueError, OSError):  # not allowed here (an embedding host): keep the default
                    pass
        return self

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            _install_handler(sig, handler)
        self._previous.clear()
        return False

    def _on_signal(self, signum, frame):
        if self.interrupted and signum == signal.SIGINT:
            raise KeyboardInterrupt  # the second Ctrl-C: stop now
        self.interrupted = signal.Signals(signum).name
        self.reason = self.reason or f"interrupted ({'Ctrl-C' if signum == signal.SIGINT else self.interrupted})"

    # -- checks
    def progress(self, t: float, t_end: float):
        """The progress callback the driver calls between output chunks: False stops the run."""
        if self.user_progress is not None and self.user_progress(t, t_end) is False and not self.reason:
            self.reason = "stopped by the progress callback"
        self._check_wall_time()
        return False if self.reason else None

    def _check_wall_time(self) -> None:
        if self.max_wall_time is not None and not self.reason:
            elapsed = time.monotonic() - self.started
            if elapsed > self.max_wall_time:
                self.reason = f"wall-time limit of {self.max_wall_time:g} s reached ({elapsed:.3g} s)"

    def _check_stall(self, solver, probe) -> None:
        """`probe`: where the live time and counters are (the C solver object inside a budget)."""
        if self.stall_time is None or self.reason:
            return
        now = time.monotonic()
        began, t_began, steps_began, rejected_began = self._mark
        if now - began < self.stall_time:
            return
        stats = probe.stats
        steps, rejected = stats.get("nsteps", 0), stats.get("nreject", 0)
        advanced = probe.t - t_began
        if advanced < STALL_FRACTION * max(self.t_end - self.t0, 1e-300) and steps > steps_began:
            self.reason = "stalled"
            self.detail = stall_message(solver, probe, advanced, now - began, steps - steps_began,
                                        rejected - rejected_began, stats)
        self._mark = (now, probe.t, steps, rejected)

    def stop_message(self, t: float) -> str:
        if self.interrupted:
            how = "Ctrl-C" if self.interrupted == "SIGINT" else self.interrupted
            return f"interrupted at t = {t:.6g} s ({how}); the samples up to then are kept"
        detail = f": {self.detail}" if self.detail else ""
        return f"{self.reason} at t = {t:.6g} s{detail}; the samples up to then are kept"

    # -- C integrators in budgets of steps
    def watch(self, solver) -> None:
        """Let a C integrator run in budgets of SLICE_STEPS steps, checking the guards between them."""
        c = getattr(solver, "_c", None)
        if c is None or not hasattr(c, "budget"):
            return
        self.watched = True
        limit = solver.max_steps
        too_many = _too_many_status()
        # the sampling function is kept on the solver: it reaches the solver through a weak reference, so that the
        # two make no reference cycle and the solver (its C memory) goes when its last user drops it, not at the
        # cycle collector's next pass
        owner = weakref.ref(solver)

        def sample(t_eval, out, start=0):
            t_eval = np.ascontiguousarray(t_eval, dtype=float)
            index, budget = start, FIRST_SLICE
            taken = c.stats["nsteps"]  # (a dict built per read: once per budget, the last one's count carried on)
            while True:
                steps, began = taken, time.monotonic()
                c.budget(max(0, min(budget, limit - steps)))
                status, index = c.sample(t_eval, out, int(index))
                taken = c.stats["nsteps"]
                budget = _next_budget(taken - steps, time.monotonic() - began)
                if status != too_many or taken >= limit:
                    break  # done, failed, or the user's own step limit: the solver reports it
                self._check_wall_time()
                self._check_stall(owner(), c)
                if self.reason:
                    break
            if c.status != too_many or taken < limit:  # at the user's limit the run has failed
                c.budget(max(0, limit - taken))  # the user's limit again (resumes a paused run)
            owner()._sync()
            return index

        solver.sample = sample


@functools.lru_cache(maxsize=None)
def _too_many_status() -> int:
    """The C integrators' status of a paused budget (imported when first asked for: an import statement per watched
    solver cost more than the rest of watch)."""
    from .integrators import native
    return native._C_TOO_MANY


def _next_budget(steps: int, wall: float) -> int:
    """Steps for about SLICE_WALL seconds at the rate of the last budget (steps in wall seconds)."""
    if steps <= 0 or wall <= 0.0:
        return SLICE_STEPS
    return max(1, min(SLICE_STEPS, int(SLICE_WALL * steps / wall)))


def stall_message(solver, probe, advanced: float, wall: float, steps: int, rejected: int, stats: dict) -> str:
    """What the integrator did while the simulated time stood still, and the likely cause."""
    h = getattr(probe, "h", None) or getattr(solver, "h_abs", None) or 0.0
    share = rejected / steps if steps else 0.0
    doing = f"{steps} steps in {wall:.3g} s of wall time, {100 * share:.0f} % rejected"
    if stats.get("nlu"):
        doing += f", {stats['nlu']} factorisations so far"
    t = float(probe.t)
    if h and h <= 1e3 * abs(t) * 2.2e-16:
        cause = "the step size is at the resolution of double precision at this time (a discontinuity the " \
                "error control cannot pass: make the force or the input continuous, or smooth the switch)"
    elif share > 0.5:
        cause = "most steps are rejected: a discontinuity or a kink in a force, an input or a table here " \
                "(smooth it), or loop closure failing to converge"
    elif not getattr(solver, "implicit", False) and solver.name in ("dopri5", "adams", "RK45", "DOP853"):
        cause = f"the model is stiff here and the explicit method '{solver.name}' needs tiny steps for " \
                "stability: use 'rodasp' (or 'Radau'), or loosen rtol"
    else:
        cause = "very fast dynamics for the tolerances asked (loosen rtol/atol, or check for a very stiff " \
                "spring or a tiny mass)"
    return (f"the simulated time advanced only {advanced:.3g} s ({doing}; step size {h:.3g} s, integrator "
            f"{solver.name}); likely cause: {cause}")
