"""Events at run time: what an indicator is, where it crosses zero, what happens there, and the log.

The generated ``mbs_events(t, x, p, g, work)`` returns the indicators g (MBS_NEV of them); an event happens
where g_k crosses zero in its direction.  The integrators look for sign changes after every accepted step
and locate the crossing on their dense output (:func:`locate_crossing` here for scipy's methods, the same
algorithm in c/ode.c for the C ones) -- the step size is never shrunk to find it.  The driver
(:func:`run_with_events`) then applies the actions, logs them and restarts the integrator from the new state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

#: Chattering: this many events within ZENO_WINDOW seconds stop the run (a ball at its accumulation point).
ZENO_EVENTS = 10
ZENO_WINDOW = 1e-9
#: Illinois iterations give way to bisection when the bracket is this narrow: the last steps go to round-off.
BISECT_BELOW = 1e-12
#: The look ahead that tells which side an indicator at zero is leaving to [s, relative to max(1, |t|)].
DEPARTURE_STEP = 1e-12

DIRECTION_NAMES = {1: "rising", -1: "falling", 0: "either"}


@dataclass(frozen=True)
class EventSpec:
    """One indicator of mbs_events: its name, direction (+1 rising, -1 falling, 0 either), whether it ends the
    run, what its actions assign ((array "x" or "p", index, slot of mbs_event_actions), ...), and for a switch
    the p index of its branch flag (-1 otherwise) and whether g = 0 counts as the true side."""

    name: str
    direction: int
    terminal: bool = False
    assignments: tuple[tuple[str, int, int], ...] = ()
    switch: int = -1
    inclusive: bool = False

    @classmethod
    def of(cls, value) -> "EventSpec":
        return value if isinstance(value, EventSpec) else cls(**value)


def crossings(g_old: np.ndarray, g_new: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Indices whose indicator left its old sign in an allowed direction (zero counts as arrived; a value that
    starts at zero has not left yet)."""
    rising = (g_old < 0) & (g_new >= 0) & (directions >= 0)
    falling = (g_old > 0) & (g_new <= 0) & (directions <= 0)
    return np.flatnonzero(rising | falling)


def locate_crossing(f: Callable[[float], float], a: float, b: float, fa: float, fb: float) -> float:
    """The first time in (a, b] at which f has left the sign of fa (to the round-off of t): Illinois
    (a secant that halves the stale end's value) down to BISECT_BELOW, then bisection to adjacent doubles.

    fa may be the value an indicator at zero is leaving with (DEPARTURE_STEP after a, see event_loop.departing)
    rather than f(a) itself; so the bracket first moves its left end there when f has fa's sign at that point."""
    probe = a + DEPARTURE_STEP * max(1.0, abs(a))
    if probe < b:
        fp = f(probe)
        if fp * fa > 0:
            a, fa = probe, fp
    retained = 0
    while True:
        width = b - a
        if width <= BISECT_BELOW * max(1.0, abs(b)):
            c = a + 0.5 * width
        else:
            c = b - fb * width / (fb - fa)
            if not (a < c < b):
                c = a + 0.5 * width
        if not (a < c < b):  # a and b are adjacent doubles
            return b
        fc = f(c)
        if fc * fa > 0:  # still on the old side
            a, fa = c, fc
            if retained == 1:
                fb *= 0.5
            retained = 1
        else:
            b, fb = c, fc
            if retained == -1:
                fa *= 0.5
            retained = -1


@dataclass(frozen=True)
class EventRecord:
    """One entry of ``res.events``."""

    time: float
    event: str
    direction: str
    changes: str

    def as_row(self) -> dict:
        return {"time": self.time, "event": self.event, "direction": self.direction, "changes": self.changes}


def init_switches(model, data, t: float, x: np.ndarray) -> int:
    """Set each switch's branch flag from its comparison at the start, then freeze them; returns the p index of
    the frozen flag (-1 when the model has no switches)."""
    switches = [(k, s) for k, s in enumerate(model.events) if s.switch >= 0]
    if not switches:
        return -1
    frozen = model.p_names.index("switch.frozen")
    data.p[frozen] = 0.0
    g = data.function("events")(t, x)
    for k, s in switches:
        data.p[s.switch] = 1.0 if (g[k] > 0 or (s.inclusive and g[k] == 0)) else 0.0
    data.p[frozen] = 1.0
    return frozen


def apply_events(model, data, fired, g_old, g_event, t: float, y: np.ndarray, names) -> tuple[np.ndarray, list]:
    """The state after the events ``fired`` at (t, y) and their log records; data.p is changed in place.  Every
    action value is computed first, from the state before the event (Modelica's pre())."""
    values = data.function("event_actions")(t, y) if "event_actions" in model.functions else ()
    x = y.copy()
    records = []
    for k in fired:
        spec = model.events[k]
        direction = 1 if g_event[k] > g_old[k] else -1
        changes = []
        for array, index, slot in spec.assignments:
            target = x if array == "x" else data.p
            name = names[index] if array == "x" else model.p_names[index]
            changes.append(f"{name}: {target[index]:.6g} -> {values[slot]:.6g}")
            target[index] = values[slot]
        if spec.switch >= 0:
            new = 1.0 if direction > 0 else 0.0
            if data.p[spec.switch] != new:
                changes.append(f"branch {data.p[spec.switch]:g} -> {new:g}")
            data.p[spec.switch] = new
        records.append(EventRecord(t, spec.name, DIRECTION_NAMES[direction], "; ".join(changes)))
    return x, records


def zeno_message(events: list[str], times: list[float], t: float, x: np.ndarray, names) -> str:
    """Names the events of the last ZENO_EVENTS, the time and the state."""
    state = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, x))
    which = ", ".join(f"'{e}'" for e in dict.fromkeys(events[-ZENO_EVENTS:]))
    return (f"chattering (Zeno behaviour) at t = {t:.12g} s: event {which} fired {ZENO_EVENTS} times within "
            f"{times[-1] - times[-ZENO_EVENTS]:.3g} s; the run stops here with its results; state: {state}")


def is_zeno(times: list[float]) -> bool:
    return len(times) >= ZENO_EVENTS and times[-1] - times[-ZENO_EVENTS] <= ZENO_WINDOW * max(1.0, abs(times[-1]))


def finite(x) -> bool:
    return all(math.isfinite(v) for v in x)
