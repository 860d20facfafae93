"""The start of a run with switched friction elements (compiler/friction.py): each element's mode from the state.

An element's events only see transitions (the static limit exceeded, the slip speed through zero), so a run that
starts sliding, or sticking under a load beyond the static limit, would keep the wrong mode forever. Before the
first step every element still in its default stick mode is therefore let go as its slip event would do it, when it
slides (in its joint or at its contact) or its holding force exceeds the limit; the new mode is that event's own
action value (the sign of the slip speed, or the direction the system accelerates in). After every event the
sticking elements are checked again (held beyond the limit only): in a model with closed loops a grip always
sticks first (compiler/friction_loops.py), and an event that jumps the loads can break a stick. Elements let go
from rest at the same moment get directions that agree with the motion they start together (_settle_directions).
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from .events import EventRecord

#: Names the compiler gives an element's events and mode (compiler/friction.py, language/friction.py).
SLIP, GRIP, MODE_SUFFIX = ".slip", ".grip", ".mode"
#: Time step [s] (relative to t beyond 1 s) of the look ahead that tells which way elements let go together move.
SETTLE_STEP = 1e-9
#: Slip speed [m/s] below which an element counts as at rest after an event (round-off of a projection, or the
#: location tolerance of an event times an acceleration; a slide is far faster).
STOPPED_SPEED = 1e-9


def friction_modes(model) -> list[int]:
    """Indices in p of the switched friction elements' modes (an element: a mode with a slip and a grip event)."""
    events = {spec.name for spec in model.events}
    return [i for i, name in enumerate(model.p_names) if name.endswith(MODE_SUFFIX)
            and name[:-len(MODE_SUFFIX)] + SLIP in events and name[:-len(MODE_SUFFIX)] + GRIP in events]


@contextmanager
def stick_rows_released(model, data):
    """Within: every sticking friction element of data.p slips (+1), as far as the loop functions see it. In a
    model with closed loops a sticking element is a constraint row (compiler/friction_loops.py); assembling the
    loops with those rows would lock the joints they hold, so that positions given a little off the loops could
    not be closed and initial speeds along them would be taken away. The loops are assembled without them, and
    the run then decides each element's mode from the assembled state (start_friction_modes)."""
    held = [i for i in friction_modes(model) if data.p[i] == 0]
    for i in held:
        data.p[i] = 1.0
    try:
        yield
    finally:
        for i in held:
            data.p[i] = 0.0


def is_friction_event(model, name: str) -> bool:
    """Whether an event is the slip or grip of a switched friction element: after it the Python loop checks the
    held forces (start_friction_modes with moving=False), so the C sampling loop must not apply it itself."""
    for suffix in (SLIP, GRIP):
        if name.endswith(suffix) and name[:-len(suffix)] + MODE_SUFFIX in model.p_names:
            return True
    return False


def start_friction_modes(model, data, t: float, x: np.ndarray, moving: bool = True,
                         fired: tuple = ()) -> list[EventRecord]:
    """Set data.p's friction modes for the state (t, x); returns the log entries of the elements let go (their
    slip event with the direction 'start'). moving=False: the check right after an event: a slipping element
    that the event brought to rest as well grips (`_grip_stopped`), and elements held beyond their limit are let
    go (a grip in a loop model, which sticks first, or a jump of the loads), again while letting one go loads
    another beyond its limit (two locks of one loop share its load). fired: the names of the events just
    applied (their elements' modes are as those events set them)."""
    records = [] if moving else _grip_stopped(model, data, t, x, fired)
    for _ in range(len(friction_modes(model)) + 1):
        new = _let_go(model, data, t, x, moving)
        records += new
        if not new:
            break
        moving = False
    return records


def _grip_stopped(model, data, t: float, x: np.ndarray, fired) -> list[EventRecord]:
    """Slipping elements (along a line) whose slip speed the event made zero (below STOPPED_SPEED: another
    element's grip locked the motion they slide with, as two bearings of one loop stop together) grip as their
    own grip event would have: they stick, and the check that follows lets them go if they cannot hold."""
    index = {spec.name: k for k, spec in enumerate(model.events)}
    records = []
    for mode in friction_modes(model):
        base = model.p_names[mode][:-len(MODE_SUFFIX)]
        if data.p[mode] == 0 or base + ".e1" in model.p_names or base + SLIP in fired or base + GRIP in fired:
            continue  # sticking, a plane contact, or its own event just set its mode (a slip from rest)
        old = data.p[mode]
        if abs(_slip_speed(model, data, t, x, mode, index[base + GRIP])) <= STOPPED_SPEED:
            records.append(EventRecord(t, base + GRIP, "with the event", f"{model.p_names[mode]}: {old:.6g} -> 0"))
            continue  # _slip_speed leaves the mode at 0
        data.p[mode] = old
    return records


def _let_go(model, data, t: float, x: np.ndarray, moving: bool) -> list[EventRecord]:
    """One pass of start_friction_modes: the sticking elements that move (when `moving`) or are held beyond
    their limit are let go, as their slip event would."""
    index = {spec.name: k for k, spec in enumerate(model.events)}
    starting, g, at_rest, changes = [], None, [], {}
    for k, spec in enumerate(model.events):
        base = spec.name[:-len(SLIP)] if spec.name.endswith(SLIP) else None
        if base is None or base + GRIP not in index or base + MODE_SUFFIX not in model.p_names:
            continue
        mode = model.p_names.index(base + MODE_SUFFIX)
        if data.p[mode] != 0:
            continue  # the user started it sliding
        g = np.asarray(data.function("events")(t, x), dtype=float) if g is None else g
        speed = _slip_speed(model, data, t, x, mode, index[base + GRIP])
        if g[k] > 0 or (moving and speed != 0):
            starting.append(k)
            if abs(speed) <= STOPPED_SPEED and base + ".e1" not in model.p_names:  # from rest, along a line
                at_rest.append((index[base + GRIP], mode))
    records = []
    if starting:
        values = data.function("event_actions")(t, x)
        for k in starting:
            for array, i, slot in model.events[k].assignments:
                if array == "p":
                    changes.setdefault(k, []).append((i, data.p[i]))
                    data.p[i] = values[slot]
        if len(at_rest) > 1 or (at_rest and not moving):  # (the direction of one let go after an event: its
            _settle_directions(data, t, x, at_rest)        # slip speed is zero up to the projection's round-off)
        for k in starting:
            text = "; ".join(f"{model.p_names[i]}: {old:.6g} -> {data.p[i]:.6g}" for i, old in changes.get(k, ()))
            records.append(EventRecord(t, model.events[k].name, "start", text))
    return records


def _settle_directions(data, t: float, x: np.ndarray, at_rest: list) -> None:
    """Several elements let go from rest at once: each one's direction was chosen with the others held, but
    together they may move otherwise (a double pendulum's two pins). An element whose slip speed departs against
    its mode would be driven by its own friction force, so its mode is flipped, one at a time, until every one
    departs along its mode (at most twice per element: the directions are a finite set)."""
    step = SETTLE_STEP * max(1.0, abs(t))
    for _ in range(2 * len(at_rest)):
        x1 = x + step * np.asarray(data.rhs(t, x), dtype=float)
        g1 = np.asarray(data.function("events")(t + step, x1), dtype=float)
        wrong = [mode for grip, mode in at_rest if g1[grip] < 0]  # the grip indicator reads mode * w
        if not wrong:
            return
        data.p[wrong[0]] = -data.p[wrong[0]]


def _slip_speed(model, data, t: float, x: np.ndarray, mode: int, grip: int) -> float:
    """The element's slip speed: its grip indicator reads mode * w while slipping, so with the mode set to +1 for
    a moment it is w itself (of a joint or of a point contact alike); a plane contact's reads |w| while its slip
    direction (the values after the mode, compiler/friction_plane.py) is unset."""
    names = model.p_names
    direction = [mode + k for k in (1, 2) if mode + k < len(names) and names[mode + k] in
                 (names[mode][:-len(MODE_SUFFIX)] + ".e1", names[mode][:-len(MODE_SUFFIX)] + ".e2")]
    kept = [data.p[i] for i in direction]
    data.p[mode] = 1.0
    data.p[direction] = 0.0
    try:
        return float(data.function("events")(t, x)[grip])
    finally:
        data.p[mode] = 0.0
        data.p[direction] = kept
