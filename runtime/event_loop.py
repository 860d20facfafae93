"""The integration loop of a model with events: integrate to the next located event, apply its actions, log it,
restart the integrator from the new state; stop at the end, at a terminal event, at a failure or at chattering.

Every segment between events keeps its own copy of the run-time values p (modes, switch flags, parameters an
event changed), so that outputs are evaluated afterwards with the values that were in force.  The state just
before and just after each event are both rows of the results (a jump shows as a jump).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import EvaluationError
from .events import DEPARTURE_STEP, EventRecord, apply_events, crossings, init_switches, is_zeno, zeno_message
from .friction import start_friction_modes
from .integrators import FAILED, FINISHED
from .integrators.base import EVENT


@dataclass
class Segments:
    """Rows of the run: times, states, and per row the index of the p copy in force."""

    times: list = field(default_factory=list)
    states: list = field(default_factory=list)
    counts: list = field(default_factory=list)  # (rows, index of the p copy) per added block
    p: list = field(default_factory=list)

    def add(self, times, states: np.ndarray, p: np.ndarray) -> None:
        if len(times) == 0:
            return
        if not self.p or not (self.p[-1] == p).all():
            self.p.append(p.copy())
        self.times.append(np.asarray(times, dtype=float).reshape(-1))
        self.states.append(np.asarray(states, dtype=float).reshape(len(self.times[-1]), -1))
        self.counts.append((len(self.times[-1]), len(self.p) - 1))

    def arrays(self, nx: int):
        if not self.times:
            return np.empty(0), np.empty((0, nx)), np.empty(0, dtype=int)
        rows, which = zip(*self.counts)
        return np.concatenate(self.times), np.vstack(self.states), np.repeat(which, rows)


def run_with_events(model, data, make_solver, times: np.ndarray, t_end: float, progress=None, chunks: int = 100):
    """Integrate over ``times`` from (data.t, data.x) with events; ``make_solver(t0, y0, events, first_step)``
    starts an integrator (first_step None: its own choice).  Returns (Segments, status, message, event records, counters summed over the segments); data.t
    and data.x are left at the last state reached."""
    g = data.function("events")
    directions = np.array([e.direction for e in model.events], dtype=np.intc)
    names = model.x_names
    t, x = float(data.t), data.x.copy()
    frozen = init_switches(model, data, t, x)
    records = start_friction_modes(model, data, t, x)  # stick or slip from the start state (runtime/friction.py)
    segments, fired_times = Segments(), []
    states = np.empty((times.size, model.nx))
    i, status, message = 0, FINISHED, ""
    chunk = max(1, math.ceil(times.size / chunks)) if progress is not None else times.size
    solver, stats, hint = None, {}, None
    try:
        while True:
            g_start = departing(data, g, t, x)
            if settle_switches(model, data, g_start):  # a branch at its kink takes the side the motion leaves to
                g_start = departing(data, g, t, x)
            solver = make_solver(t, x, (g, directions, g_start), hint)
            start = i
            while i < times.size and solver.status not in (FAILED, EVENT):
                stop = min(times.size, i + chunk) if progress is not None else times.size
                i = solver.sample(times[:stop], states[:stop], i)
                if progress is not None and i > 0 and progress(float(times[i - 1]), t_end) is False \
                        and i < times.size and solver.status != EVENT:
                    status = "stopped"
                    message = f"stopped by the progress callback at t = {solver.t:.6g} s"
                    break
            if solver.status == EVENT and i < times.size:  # samples past the chunk that still lie before the event
                i = solver.sample(times, states, i)
            segments.add(times[start:i], states[start:i], data.p)
            for key, value in solver.stats.items():
                stats[key] = stats.get(key, 0) + value
            if status == "stopped":
                break
            if solver.status == FAILED:
                status, message = FAILED, solver.message
                break
            if solver.status != EVENT:
                break
            t_event, y_event = float(solver.t), np.asarray(solver.y, dtype=float)
            g_event = g(t_event, y_event)
            fired = crossings(solver.g_old, g_event, directions)
            segments.add([t_event], y_event[None, :], data.p)
            x, new = apply_events(model, data, fired, solver.g_old, g_event, t_event, y_event, names)
            if "project" in model.functions:  # closed loops: new speeds consistent with the constraints
                x = data.project(t_event, x)
            # a restart without a jump of the state (a switch or a mode changed) starts at the step size the
            # integrator had; after a jump (an impact) it chooses its own first step
            jumped = any(array == "x" for k in fired for array, _, _ in model.events[k].assignments)
            hint = None if jumped else solver.step_hint
            new += start_friction_modes(model, data, t_event, x, moving=False)  # held beyond the limit: let go
            records += new
            fired_times += [t_event] * len(new)
            t = t_event
            if i >= times.size or times[i] != t_event:
                segments.add([t_event], x[None, :], data.p)
            terminal = [model.events[k].name for k in fired if model.events[k].terminal]
            if terminal:
                message = f"terminated by event '{terminal[0]}' at t = {t_event:.9g} s"
                break
            if is_zeno(fired_times):
                status = "zeno"
                message = zeno_message([r.event for r in records], fired_times, t_event, x, names)
                break
            if t_event >= t_end and i >= times.size:
                break
    finally:
        if frozen >= 0:
            data.p[frozen] = 0.0  # outside a run the comparisons are evaluated as written
    data.t, data.x = t, x
    if solver is not None and solver.status not in (EVENT,) and status != "zeno":
        data.t, data.x = solver.t, solver.y
    stats["nevents"] = len(records)
    return segments, status, message, records, stats


def departing(data, g, t: float, x: np.ndarray) -> np.ndarray:
    """Indicators at the start of a segment, an indicator within round-off of zero replaced by its value a moment
    later (an Euler step of DEPARTURE_STEP): a ball restarted at s = -1e-20 m rising at 1e-3 m/s counts as above
    the ground, so that its next fall is seen even if its whole flight fits in one integrator step."""
    g0 = np.asarray(g(t, x), dtype=float)
    dt = DEPARTURE_STEP * max(1.0, abs(t))
    try:
        g1 = np.asarray(g(t + dt, x + dt * data.rhs(t, x)), dtype=float)
    except EvaluationError:
        return g0
    return np.where((np.sign(g1) != np.sign(g0)) & np.isfinite(g1), g1, g0)


def settle_switches(model, data, g_start: np.ndarray) -> bool:
    """Put every switch on the side its indicator is leaving to at a restart (a friction law's sign(v) when the
    sliding starts at v = 0, where no crossing will ever be seen); True when a branch changed."""
    changed = False
    for k, spec in enumerate(model.events):
        if spec.switch >= 0 and g_start[k] != 0:
            flag = 1.0 if g_start[k] > 0 else 0.0
            changed |= bool(data.p[spec.switch] != flag)
            data.p[spec.switch] = flag
    return changed


def event_rows(records: list[EventRecord]) -> list[dict]:
    return [r.as_row() for r in records]
