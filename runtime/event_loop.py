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

from .derived import derived, friction_modes_of
from .errors import EvaluationError
from .events import (DEPARTURE_STEP, DIRECTION_NAMES, ZENO_WINDOW, EventRecord, against_motion, apply_events,
                     crossing_rows, crossings, init_switches, is_zeno, resolution_message, zeno_message)
from .friction import is_friction_event, start_friction_modes
from .integrators import FAILED, FINISHED
from .integrators.base import EVENT


@dataclass(frozen=True)
class EventTables:
    """What the event loop reads of a model's events, per indicator, worked out once per model (event_tables)."""

    directions: np.ndarray    # (intc) +1 rising, -1 falling, 0 either
    flags: np.ndarray         # (intp) p index of a switch's branch flag, -1 for other events
    branch_only: tuple        # a switch whose event does nothing but flip its branch
    not_branch_only: np.ndarray  # (bool) its negation, a mask
    smooth: np.ndarray        # (bool) a continuous switch (nothing jumps where it flips)
    names: tuple
    object_names: np.ndarray  # (object) the names again, for gathering by index
    switches: np.ndarray      # (intp) the indicators of switches ...
    switch_flags: np.ndarray  # (intp) ... and their branch flags, when no two share one (else None)
    switch_column: np.ndarray  # (intp) per indicator its place among the switches (-1: no switch)
    can_rise: np.ndarray      # (bool) directions >= 0, and ...
    can_fall: np.ndarray      # (bool) ... directions <= 0: the crossing test's masks, made once
    rough: np.ndarray         # (bool) not smooth
    switch_span: slice | None  # switch_flags as a slice of p, when they are consecutive (else None)
    smooth_list: tuple        # smooth and whether any event does more than flip a branch, as plain Python values
    any_not_branch_only: bool

    @classmethod
    def of(cls, model) -> "EventTables":
        specs = model.events
        branch_only = tuple(s.switch >= 0 and not s.assignments for s in specs)
        arrays = (np.array([s.direction for s in specs], dtype=np.intc),
                  np.array([s.switch for s in specs], dtype=np.intp),
                  np.array([not b for b in branch_only], dtype=bool),
                  np.array([s.continuous for s in specs], dtype=bool))
        for a in arrays:
            a.flags.writeable = False
        directions, flags, not_branch_only, smooth = arrays
        switches = np.flatnonzero(flags >= 0)
        switch_flags = flags[switches] if len(set(flags[switches].tolist())) == switches.size else None
        switch_column = np.full(len(specs), -1, dtype=np.intp)
        switch_column[switches] = np.arange(switches.size)
        names = tuple(s.name for s in specs)
        object_names = np.array(names + (None,), dtype=object)[:-1]  # (None: a 1-D array even of tuples)
        can_rise, can_fall, rough = directions >= 0, directions <= 0, ~smooth
        for a in (switches, switch_column, object_names, can_rise, can_fall, rough):
            a.flags.writeable = False
        consecutive = switch_flags is not None and switch_flags.size and \
            np.array_equal(switch_flags, np.arange(switch_flags[0], switch_flags[0] + switch_flags.size))
        span = slice(int(switch_flags[0]), int(switch_flags[0]) + switch_flags.size) if consecutive else None
        return cls(directions, flags, branch_only, not_branch_only, smooth, names, object_names,
                   switches, switch_flags, switch_column, can_rise, can_fall, rough, span,
                   tuple(smooth.tolist()), bool(not_branch_only.any()))

    def crossings(self, g_old: np.ndarray, g_new: np.ndarray) -> np.ndarray:
        """events.crossing_rows(g_old, g_new, directions) with the directions' masks made once: rows of a log."""
        return ((g_old < 0) & (g_new >= 0) & self.can_rise) | ((g_old > 0) & (g_new <= 0) & self.can_fall)


def event_tables(model) -> EventTables:
    return derived(model, "event_tables", lambda: EventTables.of(model))


@dataclass
class Segments:
    """Rows of the run: times, states, and per row the index of the p copy in force.  Blocks of sample rows and
    single rows at events are kept as they come (views, no copies), and so are replay's blocks, as the places of
    their pieces within the block (index arithmetic, no rows copied); `arrays` writes every row once into the
    joined arrays.  The p copies likewise (blocks of rows: replay adds one per log, `values` joins them)."""

    times: list = field(default_factory=list)
    states: list = field(default_factory=list)
    counts: list = field(default_factory=list)  # (rows, index of the p copy, twin) per added block
    p_blocks: list = field(default_factory=list)  # (copies, np) arrays, the copies in order
    p_count: int = 0

    def add(self, times, states: np.ndarray, p: np.ndarray) -> None:
        if len(times):
            self.append(times, states, self.in_force(p))

    def in_force(self, p: np.ndarray) -> int:
        """The index of the p copy equal to ``p``, the last one or a new copy."""
        if not self.p_blocks or not (self.p_blocks[-1][-1] == p).all():  # (np.array_equal's test, without its wrapper)
            self.add_values(p[None, :].copy())
        return self.p_count - 1

    def add_values(self, copies: np.ndarray) -> int:
        """Appends p copies (rows, kept as they are); returns the index of the first."""
        if len(copies):
            self.p_blocks.append(copies)
            self.p_count += len(copies)
        return self.p_count - len(copies)

    def values(self) -> np.ndarray:
        """(copies, np): every p copy, by index."""
        return self.p_blocks[0] if len(self.p_blocks) == 1 else np.concatenate(self.p_blocks)

    def append(self, times, states: np.ndarray, which, twin=False) -> None:
        """Rows in the p copy ``which`` (from in_force; or one per row): ``times`` a sequence, ``states`` one row
        or rows.  ``twin`` (a flag, or one per row): the row just after an event where nothing jumps (a
        continuous switch: compiler/events.py), whose projection and outputs are those of the row before it
        (computed once, copied)."""
        if len(times):
            self.times.append(times)
            self.states.append(states)
            self.counts.append((len(times), which, twin))

    def append_scattered(self, rows: int, pieces: tuple) -> None:
        """A block of ``rows`` rows given as pieces (places within the block, times, states, p copy per row, twin
        flags or None), which together fill each of its rows once: placed by `arrays` straight into the joined
        arrays."""
        if rows:
            self.times.append(None)
            self.states.append(pieces)
            self.counts.append((rows, None, None))

    def arrays(self, nx: int):
        """(times, states, index of the p copy, twin mask) of every row: each block written once in its place."""
        rows = sum(n for n, _, _ in self.counts)
        times, states = np.empty(rows), np.empty((rows, nx))
        which, twin = np.empty(rows, dtype=int), np.zeros(rows, dtype=bool)
        i = 0
        for block_times, block_states, (n, k, same) in zip(self.times, self.states, self.counts):
            if block_times is None:  # a scattered block (append_scattered)
                t_view, x_view, which_view, twin_view = times[i:i + n], states[i:i + n], which[i:i + n], twin[i:i + n]
                for place, t, x, copy, flags in block_states:
                    t_view[place], x_view[place], which_view[place] = t, x, copy
                    if flags is not None:
                        twin_view[place] = flags
            else:
                times[i:i + n], states[i:i + n], which[i:i + n] = block_times, block_states, k
                if isinstance(same, np.ndarray):
                    twin[i:i + n] = same
                elif same:
                    twin[i] = same  # a single row
            i += n
        return times, states, which, twin


class EventLog:
    """The run's event log as it is booked: the EventRecords the Python loop makes, and the entries of a C log whose
    events only flip switches' branches as columns (times, event names, directions, changes: replay's
    _book_branches), without an object per entry: bump_10 books 390, and an EventRecord each, then a row each for
    res.events, cost 2.0 M of the 16.9 M instructions of its Python (bench/driver_instructions.py).  ``rows()``:
    res.events, a dict per entry in the order booked, as EventRecord.as_row makes them, made when res.events is first
    read (runtime/results.py: the results keep the log itself)."""

    __slots__ = ("_blocks", "_size")

    def __init__(self, records=()):
        self._blocks: list = []  # lists of EventRecords, and (times, events, directions, changes) tuples of lists
        self._size = 0
        self += records

    def __iadd__(self, records) -> "EventLog":
        records = list(records)
        if records:
            if self._blocks and isinstance(self._blocks[-1], list):
                self._blocks[-1] += records
            else:
                self._blocks.append(records)
            self._size += len(records)
        return self

    def append(self, record: EventRecord) -> None:
        self += (record,)

    def add_columns(self, times: list, events: list, directions: list, changes: list) -> None:
        """Entries given as columns (lists of equal length)."""
        if times:
            self._blocks.append((times, events, directions, changes))
            self._size += len(times)

    def __len__(self) -> int:
        return self._size

    def events(self) -> list[str]:
        """The event name of every entry, in order."""
        names: list[str] = []
        for block in self._blocks:
            names += [r.event for r in block] if isinstance(block, list) else block[1]
        return names

    def rows(self) -> list[dict]:
        rows: list[dict] = []
        for block in self._blocks:
            if isinstance(block, list):
                rows += [r.as_row() for r in block]
            else:
                rows += [{"time": time, "event": event, "direction": direction, "changes": change}
                         for time, event, direction, change in zip(*block)]
        return rows


def run_with_events(model, data, make_solver, times: np.ndarray, t_end: float, progress=None, chunks=100):
    """Integrate over ``times`` from (data.t, data.x) with events; ``make_solver(t0, y0, events, first_step)``
    starts an integrator (first_step None: its own choice); ``progress`` is called after each of ``chunks`` parts
    of the samples (a number, or a function of none that tells it once the first integrator is made).  Returns
    (Segments, status, message, the EventLog, counters summed over the segments); data.t and data.x are left at the
    last state reached."""
    g = data.function("events")
    directions = event_tables(model).directions
    friction = bool(friction_modes_of(model))  # (without switched friction elements nothing to check)
    names = model.x_names
    t, x = float(data.t), data.x.copy()
    frozen = init_switches(model, data, t, x)
    # stick or slip from the start state (runtime/friction.py)
    records = EventLog(start_friction_modes(model, data, t, x) if friction else ())
    segments, fired_times = Segments(), []
    states = np.empty((times.size, model.nx))
    i, status, message = 0, FINISHED, ""
    solver, stats, hint = None, {}, None
    handed = None  # (the solver that handed back an event without a jump of x, g before it, g at it)
    tables = c_restart_tables(model)
    actions = data.function("event_actions") if "event_actions" in model.functions else None
    try:
        while True:
            g_start = departing(data, g, t, x)
            if settle_switches(model, data, g_start):  # a branch at its kink takes the side the motion leaves to
                g_start = departing(data, g, t, x)
            solver = make_solver(t, x, (g, directions, g_start), hint)
            parts = chunks() if callable(chunks) else chunks
            chunk = max(1, math.ceil(times.size / parts)) if progress is not None else times.size
            in_c = tables is not None and hasattr(solver, "restart_events_in_c")
            if in_c:
                solver.restart_events_in_c(actions, tables, C_LOG_CAPACITY, ZENO_WINDOW)
                p_now = data.p.copy()
                if handed is not None and hasattr(solver, "take_over"):  # what the old solver learned goes on
                    solver.take_over(*handed)
            handed = None
            start = i
            while i < times.size and solver.status not in (FAILED, EVENT):
                stop = min(times.size, i + chunk) if progress is not None else times.size
                i = solver.sample(times[:stop], states[:stop], i)
                if in_c:
                    start = replay(model, data, solver.take_event_log(), p_now, times, states, start, segments,
                                   records, fired_times)
                if progress is not None and i > 0 and progress(float(times[i - 1]), t_end) is False \
                        and i < times.size and solver.status != EVENT:
                    status = "stopped"
                    message = f"stopped by the progress callback at t = {solver.t:.6g} s"
                    break
            if solver.status == EVENT and i < times.size:  # samples past the chunk that still lie before the event
                i = solver.sample(times, states, i)
                if in_c:
                    start = replay(model, data, solver.take_event_log(), p_now, times, states, start, segments,
                                   records, fired_times)
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
            # a switch crossing within the departure step of this event is this event too (the mirror-image wheels
            # of a symmetric vehicle cross 1e-14 s apart): else the restart's look-ahead (departing,
            # settle_switches) would take its flag over without an event, as c/ode.c mbs_ode_find_event says
            g_ahead = departing(data, g, t_event, y_event)
            twins = [k for k in crossings(solver.g_old, g_ahead, directions)
                     if k not in fired and not any(a == "x" for a, _, _ in model.events[k].assignments)]
            if twins:
                g_event[twins] = g_ahead[twins]
                fired = np.union1d(fired, twins)
            segments.add([t_event], y_event[None, :], data.p)
            noise = against_motion(model, data, g, fired, t_event, y_event, solver.g_old)
            if noise:
                name = model.events[noise[0]].name
                status, t = "zeno", t_event
                message = resolution_message(name, records.events().count(name), fired_times, t_event,
                                             y_event, names)
                x = y_event
                break
            x, new = apply_events(model, data, fired, solver.g_old, g_event, t_event, y_event, names)
            # closed loops: new speeds consistent with the constraints, unless only continuous switches fired (nothing
            # jumped, no constraint changed): projecting the located state then moved indicators within round-off of
            # zero across it, whose switches the restart's look-ahead took over unlogged (the Iltis over the bump at
            # 10 m/s with ida, Radau, BDF: 21, 12, 42 such flips a run, 3, 4, 10 without the projection); c/ode.c's
            # restarts do not project either
            if "project" in model.functions and not continuous(model, fired):
                x = data.project(t_event, x)
            jumped = any(array == "x" for k in fired for array, _, _ in model.events[k].assignments)
            # a restart without a jump of the state (a switch or a mode changed) starts at the step size the
            # integrator had; after a jump (an impact) it chooses its own first step
            hint = None if jumped else solver.step_hint
            handed = None if jumped else (solver, solver.g_old, g_event)  # (after a jump: afresh, as the FMU)
            if friction:  # held beyond the limit: let go
                new += start_friction_modes(model, data, t_event, x, moving=False,
                                            fired=tuple(model.events[k].name for k in fired))
            records += new
            fired_times += [t_event] * len(new)
            t = t_event
            if i >= times.size or times[i] != t_event:
                twin = not jumped and len(new) == len(fired) and continuous(model, fired)
                segments.append([t_event], x[None, :], segments.in_force(data.p), twin)
            terminal = [model.events[k].name for k in fired if model.events[k].terminal]
            if terminal:
                message = f"terminated by event '{terminal[0]}' at t = {t_event:.9g} s"
                break
            if is_zeno(fired_times):
                status = "zeno"
                message = zeno_message(records.events(), fired_times, t_event, x, names)
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


#: Rows of the C event log to start with (it grows as needed until Python takes it, c/ode.c).  Each solver's log
#: is allocated zeroed (a row: the time, x and xdot, the indicators twice, the action values; the Iltis: 210
#: doubles): 64 rows zeroed 108 kB per solver (set_restarts: 340 k instructions of a bump_5 run's three solvers);
#: 16 rows cost bump_5 237 k instructions less a run, and bump_10 (392 events, the log doubling to hold them)
#: 20 k less (8 rows: 276 k less, 7 k more).
C_LOG_CAPACITY = 16


def c_restart_tables(model):
    """_restart_tables(model), once per model (read-only arrays: C copies them)."""
    return derived(model, "c_restart_tables", lambda: _restart_tables(model))


def _restart_tables(model):
    """Which events the C sampling loop may apply and restart from itself (c/ode.c, mbs_ode_restart): those whose
    actions are generated C that assigns run-time values only (switch branches, modes, parameters), not a jump
    of the state and not the end of the run.  On a model with loops a switch of a prescribed motion is marked 2
    (c/ode.c MBS_ODE_HANDLED_PROJECT): its speed steps there, and the loops' speeds with it, so C projects the state
    onto the constraints after it, as this loop does after an event handed back.  Returns (handled, flag, first,
    index, slot) as C wants them, or None when no event qualifies."""
    handled, flag, first, index, slot = [], [], [0], [], []
    loops = "project" in model.functions
    for spec in model.events:
        ok = (not spec.terminal and all(array == "p" for array, _, _ in spec.assignments)
              and not is_friction_event(model, spec.name))  # Python checks the held forces after those
        handled.append(2 if ok and loops and spec.prescribed else int(ok))
        flag.append(spec.switch)
        for _, target, value_slot in (spec.assignments if ok else ()):
            index.append(target)
            slot.append(value_slot)
        first.append(len(index))
    if not any(handled):
        return None
    arrays = tuple(np.array(a, dtype=np.intc) for a in (handled, flag, first, index, slot))
    for a in arrays:
        a.flags.writeable = False
    return arrays


#: Entries of a C log from which replay books switch-only events at once (_book_branches): its numpy calls cost a
#: fixed 50 us or so per log and a few us per entry, the entry-by-entry loop about 12 us per entry (the best of 300
#: on bump_10's first log cut to 4, 8 and 19 entries: 62, 99 and 144 us at once against 36, 104 and 234 us by the
#: loop; its logs of 36 and 122 entries: 141 and 315 us against 296 and 917 us).
BOOK_AT_ONCE = 8


def replay(model, data, log: np.ndarray, p_now: np.ndarray, times, states, start: int, segments: Segments,
           records: EventLog, fired_times: list) -> int:
    """Book the events C handled (rows of its log: t, y before, x after, g before the step, g at the event,
    action values) as the Python loop books its own: the sample rows before each in the run-time values in force
    then (``p_now``, brought up to date in place), the rows at the event before and after, the log records.
    Returns the first sample row not yet booked.  The rows go in as one block (placed by index arithmetic, no
    Python per row), and so do the values in force and the log's entries (as columns) when every event only flips
    a switch's branch; other actions are applied event by event."""
    m = len(log)
    if m == 0:
        return start
    nx, nev = model.nx, len(model.events)
    events = event_tables(model)
    t_event = log[:, 0]
    g_old, g_event = log[:, 1 + 2 * nx:1 + 2 * nx + nev], log[:, 1 + 2 * nx + nev:1 + 2 * nx + 2 * nev]
    before = segments.in_force(p_now)
    fired = events.crossings(g_old, g_event)  # the indicators that fired, per entry
    if m >= BOOK_AT_ONCE and not (events.any_not_branch_only and fired[:, events.not_branch_only].any()):
        copies, twin = _book_branches(model, fired, g_old, g_event, t_event, p_now, records, fired_times)
    else:  # a short log, or an event that does more than flip a switch's branch: entry by entry
        copies, twin = _book_each(model, data, log, fired, p_now, records, fired_times)
    first_copy = segments.add_values(copies)  # the values after event e are copy first_copy + e
    return _place_rows(log, times, states, start, segments, t_event, twin, before, first_copy, nx, m)


def _book_each(model, data, log, fired_mask, p_now, records, fired_times):
    """replay's actions and records entry by entry: (the values in force after each entry, twin flags).
    ``fired_mask``: the crossings, a mask of entries by indicators."""
    m, nx, nev = len(log), model.nx, len(model.events)
    t_event = log[:, 0]
    g_old, g_event = log[:, 1 + 2 * nx:1 + 2 * nx + nev], log[:, 1 + 2 * nx + nev:1 + 2 * nx + 2 * nev]
    values = log[:, 1 + 2 * nx + 2 * nev:]
    fired_lists = [[] for _ in range(m)]
    for entry, k in zip(*(a.tolist() for a in np.nonzero(fired_mask))):
        fired_lists[entry].append(k)
    twin = np.zeros(m, dtype=bool)
    copies = np.empty((m, p_now.size))
    specs = model.events
    events = event_tables(model)
    branch_only, smooth = events.branch_only, events.smooth_list  # plain Python from here on: per event
    before_values, at_values = g_old.tolist(), g_event.tolist()
    for e, (fired, t) in enumerate(zip(fired_lists, t_event.tolist())):
        if all(branch_only[k] for k in fired):
            for k in fired:  # a switch's branch, as apply_events books it (without its copy of the state)
                flag, rising = specs[k].switch, at_values[e][k] > before_values[e][k]
                old, new = float(p_now[flag]), 1.0 if rising else 0.0
                records.append(EventRecord(t, specs[k].name, DIRECTION_NAMES[1 if rising else -1],
                                           f"branch {old:g} -> {new:g}" if old != new else ""))
                p_now[flag] = new
            fired_times += [t] * len(fired)
            twin[e] = bool(fired) and all(smooth[k] for k in fired)
        else:
            _, new_records = apply_events(model, data, fired, g_old[e], g_event[e], t, log[e, 1:1 + nx],
                                          model.x_names, values=values[e], p=p_now)
            records += new_records
            fired_times += [t] * len(new_records)
        copies[e] = p_now  # an event always changes one
    return copies, twin


def _book_branches(model, fired_mask, g_old, g_event, t_event, p_now, records, fired_times):
    """replay's actions and records for a log whose events only flip switches' branches, as _book_each books
    them but with the flags' values after each entry filled forward by numpy (no Python per entry or per switch;
    bump_10 books 390 crossings): (the values in force after each entry, twin flags); p_now ends as the last entry
    left it."""
    events = event_tables(model)
    m, nev = fired_mask.shape
    crossed = np.flatnonzero(fired_mask)  # the crossings in the order of the loop: by entry, then by indicator
    entry = crossed // nev
    k = crossed - entry * nev
    new = (g_event[entry, k] > g_old[entry, k]).astype(float)  # rising: the branch 1, falling: 0
    if events.switch_flags is not None:  # each switch its own flag: one crossing per flag and entry at most
        old, copies = _filled_forward(events, k, entry, new, p_now, m)
    else:
        flag = events.flags[k]
        old, copies = np.empty_like(new), np.repeat(p_now[None, :], m, axis=0)
        for f in np.unique(flag).tolist():
            on = np.flatnonzero(flag == f)  # its crossings in order (entries non-decreasing)
            old[on] = np.concatenate(([p_now[f]], new[on][:-1]))  # each finds what the one before it set
            last = np.searchsorted(entry[on], np.arange(m), side="right") - 1  # its last crossing up to each entry
            copies[last >= 0, f] = new[on][last[last >= 0]]
    if m:
        p_now[:] = copies[-1]
    if np.all((old == 1.0) | ((old == 0.0) & ~np.signbit(old))):  # the branches' own values: texts by table
        changes = _BRANCH_TEXTS[(2 * old + new).astype(np.intp)].tolist()
    else:
        changes = [f"branch {was:g} -> {now:g}" if was != now else "" for was, now in zip(old.tolist(), new.tolist())]
    times = t_event[entry].tolist()
    records.add_columns(times, events.object_names[k].tolist(), _DIRECTIONS[new.astype(np.intp)].tolist(), changes)
    fired_times += times
    # an entry whose crossings are all of continuous switches (and that has one)
    twin = (np.bincount(entry, minlength=m) > 0) & (np.bincount(entry, weights=events.rough[k], minlength=m) == 0)
    return copies, twin


def _filled_forward(events: EventTables, k: np.ndarray, entry: np.ndarray, new: np.ndarray, p_now: np.ndarray,
                    m: int):
    """(each crossing's flag value before it, the run-time values after each of m entries) for the crossings of
    switches k in entry order (each switch its own flag), their flags set to ``new``: a crossing finds what the
    crossing of its switch before it set (the first finds p_now), an entry the values the last crossing of each
    switch up to it set (no crossing yet: p_now)."""
    flags = events.switch_flags
    size = flags.size
    # the values a crossing can find: the crossings' own, then the flags' values in p_now, which the negative
    # indices -size .. -1 reach (a switch's column c at c - size: below every crossing's index, so that the
    # running maximum below keeps them only until the switch's first crossing)
    found = np.concatenate((new, p_now[flags]))
    last = np.empty((m + 1, size), dtype=np.intp)  # row e + 1: the last crossing of each switch up to entry e
    last[:] = np.arange(-size, 0)
    column = events.switch_column[k]
    last[entry + 1, column] = np.arange(entry.size)  # a crossing's index grows with its entry:
    np.maximum.accumulate(last, axis=0, out=last)  # the last crossing of each switch up to each entry
    old = found[last[entry, column]]  # the crossing of its switch before it (row entry: up to the entry before)
    copies = np.empty((m, p_now.size))
    copies[:] = p_now
    if events.switch_span is not None:  # (the flags side by side in p: a slice, no index per value)
        copies[:, events.switch_span] = found[last[1:]]
    else:
        copies[:, flags] = found[last[1:]]
    return old, copies


#: The texts of the records of switches' branches by 2 * before + after (the flags' values 0 and 1), and their
#: directions by after (rising to 1, falling to 0): as apply_events writes them.
_BRANCH_TEXTS = np.array(["", "branch 0 -> 1", "branch 1 -> 0", ""], dtype=object)
_DIRECTIONS = np.array([DIRECTION_NAMES[-1], DIRECTION_NAMES[1]], dtype=object)


def _place_rows(log, times, states, start, segments, t_event, twin, before, first_copy, nx, m) -> int:
    """replay's rows, appended to the segments as one block (the places of its pieces: Segments.append_scattered, no
    rows copied here): returns the first sample row not yet booked."""
    # rows: per event its sample rows from the previous event on, the row before it, the row after it unless a
    # sample falls on its time (that sample, filled by C after the restart, is the row after it)
    split = np.maximum(np.searchsorted(times, t_event, side="left"), start)  # first sample row at or after it
    after = (split >= times.size) | (times[np.minimum(split, times.size - 1)] != t_event)
    if m < BOOK_AT_ONCE:  # a short log: its pieces appended as they are (views), no block
        row = start
        for e, (stop, t, has_after) in enumerate(zip(split.tolist(), t_event.tolist(), after.tolist())):
            copy = before if e == 0 else first_copy + e - 1  # in force before event e
            if stop > row:
                segments.append(times[row:stop], states[row:stop], copy)
            segments.append([t], log[e:e + 1, 1:1 + nx], copy)
            if has_after:
                segments.append([t], log[e:e + 1, 1 + nx:1 + 2 * nx], first_copy + e, bool(twin[e]))
            row = max(row, stop)
        return int(split[-1])
    afters_before = np.concatenate(([0], np.cumsum(after)))  # after rows of the events before event e
    copy_of = np.concatenate(([before], first_copy + np.arange(m)))  # the p copy in force after e events
    at = split - start + np.arange(m) + afters_before[:m]  # the row before event e within the block
    samples = np.arange(start, split[-1])
    passed = np.searchsorted(split, samples, side="right")  # events before each sample row
    place = samples - start + passed + afters_before[passed]
    afters = int(afters_before[-1])
    rows = len(samples) + m + afters
    if afters == m:  # every event has its row after it (no sample on an event's time): the log's columns as they are
        after_rows = (at + 1, t_event, log[:, 1 + nx:1 + 2 * nx], copy_of[1:], twin)
    else:
        has = np.flatnonzero(after)
        after_rows = (at[has] + 1, t_event[has], log[has, 1 + nx:1 + 2 * nx], first_copy + has, twin[has])
    segments.append_scattered(rows, ((place, times[start:split[-1]], states[start:split[-1]], copy_of[passed], None),
                                     (at, t_event, log[:, 1:1 + nx], copy_of[:m], None), after_rows))
    return int(split[-1])


def continuous(model, fired) -> bool:
    """Whether nothing jumps at an event where the indicators ``fired`` crossed: all are continuous switches (the
    state stays, and every expression reading their flags takes the same value on both sides)."""
    return bool(len(fired)) and all(model.events[k].continuous for k in fired)


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
    events = event_tables(model)
    if events.switch_flags is not None:  # each switch its own flag: all at once
        g = np.asarray(g_start)[events.switches]
        leaving = g != 0
        flags, new = events.switch_flags[leaving], np.where(g[leaving] > 0, 1.0, 0.0)
        changed = bool(np.any(data.p[flags] != new))
        data.p[flags] = new
        return changed
    changed = False
    for k, spec in enumerate(model.events):
        if spec.switch >= 0 and g_start[k] != 0:
            flag = 1.0 if g_start[k] > 0 else 0.0
            changed |= bool(data.p[spec.switch] != flag)
            data.p[spec.switch] = flag
    return changed


def event_rows(records) -> list[dict]:
    """res.events of records: an EventLog or EventRecords."""
    return records.rows() if isinstance(records, EventLog) else [r.as_row() for r in records]
