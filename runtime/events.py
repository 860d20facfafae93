"""Events at run time: what an indicator is, where it crosses zero, what happens there, and the log.

The generated ``mbs_events(t, x, p, g, work)`` returns the indicators g (MBS_NEV of them); an event happens
where g_k crosses zero in its direction.  The integrators look for sign changes after every accepted step
and locate the crossing on their dense output (:func:`locate_crossing` here for scipy's methods; c/ode.c for
the C ones, the same Illinois and bisection to adjacent doubles, started from the bracket the trial points of the
step's other crossings give and first probing the double nearest the secant's root) -- the step size is never
shrunk to find it.  The driver
(:func:`run_with_events`) then applies the actions, logs them and restarts the integrator from the new state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .derived import derived

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
    the p index of its branch flag (-1 otherwise), whether g = 0 counts as the true side, whether the switch
    is continuous (nothing jumps where it flips: compiler/events.py), and whether a prescribed motion reads it
    (its speed may step there)."""

    name: str
    direction: int
    terminal: bool = False
    assignments: tuple[tuple[str, int, int], ...] = ()
    switch: int = -1
    inclusive: bool = False
    continuous: bool = False
    prescribed: bool = False   # a switch a prescribed motion reads: the speeds the constraints allow may step

    @classmethod
    def of(cls, value) -> "EventSpec":
        return value if isinstance(value, EventSpec) else cls(**value)


def crossings(g_old: np.ndarray, g_new: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Indices whose indicator left its old sign in an allowed direction (zero counts as arrived; a value that
    starts at zero has not left yet).  crossing_rows's comparisons in plain Python: for one pair of a model's few
    dozen indicators (once per step or event) a tenth of the instructions of numpy's eleven calls."""
    return np.array([k for k, (a, b, d) in enumerate(zip(np.asarray(g_old).tolist(), np.asarray(g_new).tolist(),
                                                         np.asarray(directions).tolist()))
                     if (a < 0 and b >= 0 and d >= 0) or (a > 0 and b <= 0 and d <= 0)], dtype=np.intp)


def crossing_rows(g_old: np.ndarray, g_new: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """:func:`crossings` as a mask, for one pair of indicator vectors or for rows of them (a log of events)."""
    rising = (g_old < 0) & (g_new >= 0) & (directions >= 0)
    falling = (g_old > 0) & (g_new <= 0) & (directions <= 0)
    return rising | falling


def locate_crossing(f: Callable[[float], float], a: float, b: float, fa: float, fb: float) -> float:
    """The first time in (a, b] at which f has left the sign of fa (to the round-off of t): Illinois
    (a secant that halves the stale end's value) down to BISECT_BELOW, then two probes either side of the
    secant's root and bisection to adjacent doubles.  A trial point where f is exactly 0 is the crossing once f
    has fa's sign four doubles below it (else the bracket goes on from there: halving an end kept at 0 would only
    bisect).

    fa may be the value an indicator at zero is leaving with (DEPARTURE_STEP after a, see event_loop.departing)
    rather than f(a) itself; so the bracket first moves its left end there when f has fa's sign at that point."""
    probe = a + DEPARTURE_STEP * max(1.0, abs(a))
    if probe < b:
        fp = f(probe)
        if fp * fa > 0:
            a, fa = probe, fp
    retained, straddled = 0, False
    while True:
        width = b - a
        if width <= BISECT_BELOW * max(1.0, abs(b)) and not straddled:
            # f is linear to round-off here: probe a few doubles either side of the secant's root (the bracket
            # closes to ~8 doubles in two evaluations instead of a dozen halvings)
            straddled = True
            s = b - fb * width / (fb - fa)
            s = min(max(s, a), b) if s == s else a  # a root at an end to round-off: the probe inside closes it
            e = 4.0 * (math.nextafter(s, math.inf) - s)
            for probe in (s - e, s + e):
                if a < probe < b:
                    fp = f(probe)
                    if fp * fa > 0:
                        a, fa = probe, fp
                    else:
                        b, fb = probe, fp
            continue
        if width <= BISECT_BELOW * max(1.0, abs(b)):
            c = a + 0.5 * width
        else:  # the secant, kept half the goal width inside the bracket (a root at an end is closed, not bisected to)
            margin = 0.5 * BISECT_BELOW * max(1.0, abs(b))
            c = b - fb * width / (fb - fa)
            c = min(max(c, a + margin), b - margin) if a <= c <= b else a + 0.5 * width
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
            if fc == 0:  # on the crossing to the last bit (a linear indicator): close the bracket just below it
                below = c - 4.0 * (math.nextafter(c, math.inf) - c)
                fp = f(below) if a < below else fa
                if fp * fa > 0:
                    return c
                b, fb = below, fp
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
    table = _switch_table(model)
    if table is None:
        return -1
    indicators, flags, inclusive, frozen, shared = table
    data.p[frozen] = 0.0
    g = data.function("events")(t, x)[indicators]
    taken = np.where((g > 0) | (inclusive & (g == 0)), 1.0, 0.0)
    if shared:  # two switches on one flag: the later one's branch wins, as it did one switch at a time
        for flag, value in zip(flags.tolist(), taken.tolist()):
            data.p[flag] = value
    else:
        data.p[flags] = taken
    data.p[frozen] = 1.0
    return frozen


def _switch_table(model):
    """(the switches' indicators, their branch flags, their inclusive comparisons (bool), the p index of the frozen
    flag, whether two switches share a flag), once per model; None without switches.  init_switches reads and
    writes them as arrays at once: one numpy call each, not two scalar reads and a write per switch (the Iltis:
    30 switches)."""
    def build():
        switches = [(k, s) for k, s in enumerate(model.events) if s.switch >= 0]
        if not switches:
            return None
        indicators = np.array([k for k, _ in switches], dtype=np.intp)
        flags = np.array([s.switch for _, s in switches], dtype=np.intp)
        inclusive = np.array([bool(s.inclusive) for _, s in switches], dtype=bool)
        for a in (indicators, flags, inclusive):
            a.flags.writeable = False
        shared = len(set(flags.tolist())) < flags.size
        return indicators, flags, inclusive, model.p_names.index("switch.frozen"), shared
    return derived(model, "switch_table", build)


def apply_events(model, data, fired, g_old, g_event, t: float, y: np.ndarray, names, values=None,
                 p: np.ndarray | None = None) -> tuple[np.ndarray, list]:
    """The state after the events ``fired`` at (t, y) and their log records; the run-time values ``p`` (data.p
    unless given) are changed in place.  Every action value is computed first, from the state before the event
    (Modelica's pre()); ``values`` are those values when C computed them already."""
    if values is None:
        values = data.function("event_actions")(t, y) if "event_actions" in model.functions else ()
    p = data.p if p is None else p
    x = y.copy()
    records = []
    for k in fired:
        spec = model.events[k]
        direction = 1 if g_event[k] > g_old[k] else -1
        changes = []
        for array, index, slot in spec.assignments:
            target = x if array == "x" else p
            name = names[index] if array == "x" else model.p_names[index]
            changes.append(f"{name}: {target[index]:.6g} -> {values[slot]:.6g}")
            target[index] = values[slot]
        if spec.switch >= 0:
            new = 1.0 if direction > 0 else 0.0
            if p[spec.switch] != new:
                changes.append(f"branch {p[spec.switch]:g} -> {new:g}")
            p[spec.switch] = new
        records.append(EventRecord(t, spec.name, DIRECTION_NAMES[direction], "; ".join(changes)))
    return x, records


def zeno_message(events: list[str], times: list[float], t: float, x: np.ndarray, names) -> str:
    """Names the events of the last ZENO_EVENTS, the time and the state."""
    state = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, x))
    which = ", ".join(f"'{e}'" for e in dict.fromkeys(events[-ZENO_EVENTS:]))
    return (f"chattering (Zeno behaviour) at t = {t:.12g} s: event {which} fired {ZENO_EVENTS} times within "
            f"{times[-1] - times[-ZENO_EVENTS]:.3g} s; the run stops here with its results; state: {state}")


#: The look ahead that gives an indicator's rate at a located crossing [s, relative to max(1, |t|)].
RATE_STEP = 1e-8


def against_motion(model, data, g, fired, t: float, y: np.ndarray, g_old: np.ndarray) -> list[int]:
    """The fired events with a jump of the state whose indicator, at the located crossing, moves back to the side
    it came from: a crossing in the integrator's noise, not of the motion.  A bouncing ball near its
    accumulation point gets there when its flights become shorter than the integrator resolves (scipy's BDF and
    LSODA long before 1e-9 s): the impact would send the ball into the ground.  The rate is g's change along the
    tangent (an Euler step of RATE_STEP: positions move by v dt, so g = height gives exactly v)."""
    jumps = [k for k in fired if any(array == "x" for array, _, _ in model.events[k].assignments)]
    if not jumps:
        return []
    dt = RATE_STEP * max(1.0, abs(t))
    g0 = np.asarray(g(t, y), dtype=float)
    g1 = np.asarray(g(t + dt, y + dt * data.rhs(t, y)), dtype=float)
    return [k for k in jumps if (g1[k] - g0[k]) * (0.0 - g_old[k]) < 0]


def resolution_message(event: str, count: int, times: list[float], t: float, x: np.ndarray, names) -> str:
    """Chattering that reached the integrator's resolution before the Zeno window (against_motion)."""
    state = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, x))
    span = times[-1] - times[-min(ZENO_EVENTS, len(times))] if times else 0.0
    return (f"chattering (Zeno behaviour) at t = {t:.12g} s: event '{event}' (fired {count} times, the last "
            f"{min(ZENO_EVENTS, len(times))} within {span:.3g} s) now crosses against the motion: the motion has "
            f"come to rest at its threshold below the integrator's resolution; the run stops here with its "
            f"results; state: {state}")


def is_zeno(times: list[float]) -> bool:
    return len(times) >= ZENO_EVENTS and times[-1] - times[-ZENO_EVENTS] <= ZENO_WINDOW * max(1.0, abs(times[-1]))


def finite(x) -> bool:
    return all(math.isfinite(v) for v in x)
