"""The simulation driver: integrate a model from its workspace's state and sample the result.

    res = simulate(model, data, t_end=10.0, sample=0.01)          # dopri5 in C by default
    res = simulate(model, data, 2.0, integrator="rodasp", rtol=1e-8)

A failed run does not raise: the results keep every sample up to the failure time, and
``res.message`` says what happened ("integration failed at t = 1.234 s: step size collapsed to ...").
"""

from __future__ import annotations

import math
import time
from typing import Callable

import numpy as np

from mbs.language.catalog import DEFAULT_ATOL, DEFAULT_RTOL

from .errors import EvaluationError, UsageError, status_text
from .derived import derived
from .diagnose import explain_failure
from .fallback import runnable_integrator
from .guard import STALL_TIME, RunGuard
from .event_loop import run_with_events
from .integrators import FAILED, FINISHED
from .model import CompiledModel
from .results import TIME, Results
from .rows import evaluate_rows, project_and_evaluate_rows, project_rows
from .stiffness import stiffness_warnings
from .workspace import Workspace, check_workspace

#: Samples when neither t_eval nor sample is given.
DEFAULT_SAMPLES = 501
#: With a progress callback, C integrates this many output chunks between calls (at least).
PROGRESS_CHUNKS = 100
#: More output samples than this would not fit in memory (states and outputs of a large model).
MAX_SAMPLES = 10_000_000

Progress = Callable[[float, float], "bool | None"]


def default_integrator(model: CompiledModel) -> str:
    """"dopri5" (in C) when the back end has it, else scipy's "RK45"."""
    return "dopri5" if "dopri5" in model.backend.native_methods else "RK45"


def output_times(t0: float, t_end: float, t_eval=None, sample: float | None = None) -> np.ndarray:
    """Output times: ``t_eval`` as given (checked), or every ``sample`` seconds from t0 with t_end
    appended when it is off the grid, or DEFAULT_SAMPLES evenly spaced times."""
    if t_eval is not None and sample is not None:
        raise UsageError("give t_eval or sample, not both")
    if t_eval is not None:
        times = np.array(t_eval, dtype=float).reshape(-1)
        if times.size and (np.any(np.diff(times) < 0) or times[0] < t0 or times[-1] > t_end):
            raise UsageError(f"t_eval must be non-decreasing within [{t0:g}, {t_end:g}] s")
        return times
    if sample is not None:
        if not sample > 0:
            raise UsageError(f"sample interval must be positive, got {sample}")
        n = math.floor((t_end - t0) / sample * (1 + 1e-12)) + 1
        if n > MAX_SAMPLES:
            raise UsageError(f"sampling every {sample:g} s from {t0:g} to {t_end:g} s gives {n:.3g} samples, more "
                             f"than the {MAX_SAMPLES:.0e} that fit in memory: choose a larger sample interval")
        times = t0 + sample * np.arange(n)
        if times[-1] < t_end - 1e-9 * sample:
            times = np.append(times, t_end)
        times[-1] = min(times[-1], t_end)
        return times
    return np.linspace(t0, t_end, DEFAULT_SAMPLES)


def simulate(model: CompiledModel, data: Workspace, t_end: float, *, t_eval=None, sample: float | None = None,
             integrator=None, rtol: float = DEFAULT_RTOL, atol=DEFAULT_ATOL, first_step: float | None = None,
             max_step: float = np.inf, min_step: float = 0.0, max_steps: int = 1_000_000,
             outputs: bool = True, progress: Progress | None = None, max_wall_time: float | None = None,
             stall_time: float | None = STALL_TIME, owners=None) -> Results:
    """Integrate from (data.t, data.x) to t_end [s] and return sampled results.

    Columns: "time", the state names (q then v), then the model outputs (when ``outputs`` and the model
    has them).  ``progress(t, t_end)`` is called about PROGRESS_CHUNKS times; returning False stops the
    run (status "stopped").  On return data.t, data.x hold the last state reached and data.stats the
    integrator's counters.  Ctrl-C, SIGTERM, ``max_wall_time`` [s] and a stall (``stall_time`` [s] without
    progress; None: never) end the run early with the samples so far (guard.py).
    metadata["warnings"] holds a diagnosis when dopri5 found the model stiff
    (runtime/stiffness.py; ``owners`` maps coordinates to the interactions named in it).
    """
    check_workspace(model, data)
    t0 = float(data.t)
    t_end = float(t_end)
    if not math.isfinite(t_end):
        raise UsageError(f"t_end must be a finite time, got {t_end}")
    if not t_end >= t0:
        raise UsageError(f"t_end = {t_end:g} s lies before the workspace time t = {t0:g} s")
    times = output_times(t0, t_end, t_eval, sample)
    cls, note = runnable_integrator(model, integrator or default_integrator(model))
    started = time.perf_counter()
    options = dict(rtol=rtol, atol=atol, first_step=first_step, max_step=max_step, min_step=min_step,
                   max_steps=max_steps, jac=state_jacobian(data))
    if getattr(cls, "uses_workspace", False):  # a DAE form needs the model's functions (integrators/ida.py)
        options["workspace"] = data
    guard = RunGuard(t0, t_end, progress, max_wall_time, stall_time)
    if model.events:
        with guard:
            res = _simulate_events(model, data, cls, times, t_end, options, outputs, guard, started)
        res.metadata["notes"] = [note] if note else []
        return res
    solver = cls(data.function("rhs"), t0, data.x.copy(), t_end, **options)
    guard.watch(solver)
    states = np.empty((times.size, model.nx))
    with guard:
        status, filled = _run(solver, times, states, guard.progress, t_end, guard.chunks or PROGRESS_CHUNKS)
    message = explain_failure(model, data, solver.message, solver.t, solver.y) if status == FAILED else ""
    loops = "project" in model.functions
    with_outputs = bool(outputs and model.ny and "outputs" in model.functions)
    ys = None
    if loops and with_outputs:  # one pass: each sample projected, its outputs solved from its projection's factors
        ys, projected = np.empty((filled, model.ny)), np.empty((filled, model.nx))
        done, error, stage = project_and_evaluate_rows(data, "outputs", [data.p], times[:filled], states[:filled],
                                                       np.zeros(filled, dtype=np.intp), projected, ys)
        states[:done] = projected[:done]
        ys = ys[:done]
        projected = done if stage == "project" else filled
        if stage != "outputs":
            error = None
    elif loops:  # closed loops: store the samples projected onto the constraints
        projected_states = np.empty((filled, model.nx))
        projected, _ = project_rows(data, [data.p], times[:filled], states[:filled], np.zeros(filled, dtype=np.intp),
                                    projected_states)
        states[:projected] = projected_states[:projected]
    if loops:
        if projected < filled:
            filled, status = projected, FAILED
            message = f"the closed loops cannot be closed at t = {times[projected]:.6g} s (see loop_report)"
    if status == "stopped":
        message = guard.stop_message(solver.t)
        status = "interrupted" if guard.interrupted else status
    columns = [times[:filled, None], states[:filled]]
    names = [TIME, *model.x_names]
    if with_outputs:
        if ys is None:
            ys, error = _outputs(data, times[:filled], states[:filled], model.ny)
        if error is not None:  # keep the rows before the failing one
            filled = ys.shape[0]
            columns = [c[:filled] for c in columns]
            status = FAILED
            message = explain_failure(model, data, f"output evaluation failed at t = {error.t:.6g} s: the model "
                                      f"returned {status_text(error.status)}", error.t, states[filled])
        columns.append(ys)
        names += list(model.y_names)
    data.t, data.x = solver.t, solver.y
    if loops and status != FAILED:
        data.x = data.project(data.t, data.x)
    data.stats = dict(solver.stats)
    warnings = stiffness_warnings(model, data, solver, times[:filled], states[:filled], t_end, owners)
    metadata = {
        "model": model.name, "backend": model.backend.kind, "integrator": cls.name, "rtol": rtol,
        "atol": atol, "t0": t0, "t_end": t_end, "status": status, "message": message,
        "stats": data.stats, "wall_time": time.perf_counter() - started, "units": units_of(model),
        "notes": [note] if note else [],
        "warnings": warnings,
    }
    return Results.of_blocks(tuple(names), columns, metadata)  # (the run's own arrays: joined only if read)


#: Step of the central differences that stand in for the generated Jacobian where it fails [relative, at least
#: absolute]: as rodasp's for closed loops (runtime/c/rodasp.c): the projection's Newton tolerance is noise
#: to a finite difference, and 1e-5 keeps its error near 1e-9.
JACOBIAN_DIFFERENCE_STEP = 1e-5
#: The status of mbs_jacobian at and near a singular position of the loops (c/mbs_runtime.h MBS_SINGULAR_MASS).
SINGULAR_STATUS = 1


def state_jacobian(data: Workspace):
    """jac(t, x) -> d xdot/d x from the generated mbs_jacobian (compiler/jacobian.py), or None without one.
    Where it fails (a closed loop at or near a singular position, whose limit rows it does not differentiate:
    runtime/c/loop_jacobian.c) the last one it gave answers, as rosenbrock.c does: the implicit methods use it
    only for their Newton iterations, which converge with a Jacobian of a step before, whereas differences of
    the projecting right-hand side there may project perturbed states onto the other branch of the motion
    through the singular position (and cost 2 nx right-hand sides).  Central differences answer only when
    there is no earlier one (a run that starts there)."""
    if "jacobian" not in data.model.functions:
        return None
    full, rhs = data.function("jacobian"), data.function("rhs")
    last = []

    def jac(t, x):
        try:
            last[:] = [full(t, x)[:, :-1].copy()]
        except EvaluationError as exc:
            if not last or exc.status != SINGULAR_STATUS:
                return central_differences(rhs, t, x)
        return last[0]
    return jac


def central_differences(f, t: float, x: np.ndarray) -> np.ndarray:
    """d f/d x at (t, x) by central differences, column by column (a model failure propagates)."""
    x = np.array(x, dtype=float)
    columns = []
    for j in range(len(x)):
        step = JACOBIAN_DIFFERENCE_STEP * max(1.0, abs(x[j]))
        keep = x[j]
        x[j] = keep + step
        plus = f(t, x)
        x[j] = keep - step
        minus = f(t, x)
        x[j] = keep
        columns.append((plus - minus) / (2 * step))
    return np.column_stack(columns)


def _simulate_events(model, data, cls, times, t_end, options, outputs, guard, started) -> Results:
    """simulate() for a model with events (runtime/event_loop.py): rows at both sides of every event, outputs
    evaluated with the modes and parameters in force, the event log in ``res.events``."""
    t0 = float(data.t)

    def make_solver(t, y, events, step=None):
        settings = options if step is None or options["first_step"] is not None else \
            {**options, "first_step": min(step, t_end - t) if t_end > t else None}
        solver = cls(data.function("rhs"), t, y, t_end, events=events, **settings)
        guard.watch(solver)
        return solver

    # one call into C for all samples when the guard watches the C integrator between its budgets of steps
    segments, status, message, records, stats = run_with_events(model, data, make_solver, times, t_end, guard.progress,
                                                                lambda: guard.chunks or PROGRESS_CHUNKS)
    ts, xs, which, twin = segments.arrays(model.nx)
    ps = segments.values()
    # the joined arrays are all the rest needs: the sampling buffer and the blocks at events go now, and the memory
    # they held serves the tables below (the heap of a run grows less: fewer fresh pages touched each run)
    del segments
    if status == "stopped":
        message = guard.stop_message(float(ts[-1]) if len(ts) else t0)
        status = "interrupted" if guard.interrupted else status
    _as_predecessors(xs, which, twin)  # computed once: the rows' pass copies a row that repeats the one before it
    rows = len(ts)
    with_outputs = bool(outputs and model.ny and "outputs" in model.functions)
    ys, fused = None, None
    if "project" in model.functions and rows:
        unprojected, xs = xs, np.empty_like(xs)
        if with_outputs:  # one pass: each row projected, its outputs solved from the factors of its projection
            ys = np.empty((rows, model.ny))
            done, error, stage = project_and_evaluate_rows(data, "outputs", ps, ts, unprojected, which, xs, ys)
            projected = done if stage == "project" else rows
            fused = (done, error) if stage == "outputs" else None
        else:
            projected, _ = project_rows(data, ps, ts, unprojected, which, xs)
        del unprojected  # (as the segments above)
        if projected < rows:  # the failing row's time, as the path without events says (and no row may be left)
            failed_at, ts = float(ts[projected]), ts[:projected]
            status, message = FAILED, f"the closed loops cannot be closed at t = {failed_at:.6g} s (see loop_report)"
    names = [TIME, *model.x_names]
    if with_outputs:
        if ys is None:
            ys = np.empty((rows, model.ny))
            done, error = evaluate_rows(data, "outputs", ps, ts, xs[:len(ts)], which[:len(ts)], ys[:len(ts)])
        else:
            done, error = fused or (len(ts), None)
        if error is not None:
            failed_at, ts = float(ts[done]), ts[:done]  # keep the rows before the failing one
            status = FAILED
            message = (f"output evaluation failed at t = {failed_at:.6g} s: the model returned "
                       f"{status_text(error.status)}" if isinstance(error, EvaluationError) else str(error))
        names += model.y_names
    del ps  # (the run-time values' copies: done with)
    # the results' columns in the blocks they were computed in (Results.of_blocks: joined only if the table is read)
    blocks = (ts[:, None], xs[:len(ts)], *((ys[:len(ts)],) if with_outputs else ()))
    data.stats = stats
    metadata = {
        "model": model.name, "backend": model.backend.kind, "integrator": cls.name, "rtol": options["rtol"],
        "atol": options["atol"], "t0": t0, "t_end": t_end, "status": status, "message": message,
        "stats": data.stats, "wall_time": time.perf_counter() - started, "units": units_of(model),
    }
    return Results.of_blocks(tuple(names), blocks, metadata, events=records)  # (the log's rows made when read)


def _as_predecessors(xs: np.ndarray, which: np.ndarray, twin: np.ndarray) -> None:
    """The rows just after an event where nothing jumps (``twin``: a continuous switch, runtime/event_loop.py) are
    their predecessors' twins, whose projection and outputs they take: each is given the state and the run-time
    values of the last row before it that is not a twin (its time is already the same), so that the rows' pass
    (runtime/rows.py: a row that repeats the one before it takes its values) copies that row's instead of computing
    it, in place."""
    twins = np.flatnonzero(twin)
    if twins.size:
        computed = np.flatnonzero(~twin)
        of = computed[np.cumsum(~twin)[twins] - 1]
        xs[twins], which[twins] = xs[of], which[of]


def units_of(model: CompiledModel) -> dict:
    """A fresh dict of the model's units (the results' metadata), a copy of one made once per model: dict() of the
    model's read-only view reads it key by key (the Iltis' 295 units: 16 us warm, about 45 us after a run's C),
    a dict's copy() copies its table (0.5 us).  The kept dict is never handed out."""
    return derived(model, "units_dict", lambda: dict(model.units)).copy()


def _run(solver, times: np.ndarray, states: np.ndarray, progress: Progress | None, t_end: float,
         chunks: int = PROGRESS_CHUNKS):
    """Sample all times (in chunks when reporting progress).  Returns (status, rows filled)."""
    if progress is None:
        filled = solver.sample(times, states, 0)
        return (FINISHED if filled == times.size and solver.status != FAILED else solver.status), filled
    filled = 0
    chunk = max(1, math.ceil(times.size / chunks))
    while filled < times.size:
        stop = min(times.size, filled + chunk)
        filled = solver.sample(times[:stop], states[:stop], filled)
        if solver.status == FAILED:
            return FAILED, filled
        if progress(float(times[filled - 1]), t_end) is False and filled < times.size:
            return "stopped", filled
    return FINISHED, filled


def _outputs(data: Workspace, times: np.ndarray, states: np.ndarray, ny: int):
    """Model outputs per sample; stops at the first failure and returns it."""
    ys = np.empty((times.size, ny))
    done, error = evaluate_rows(data, "outputs", [data.p], times, states, np.zeros(times.size, dtype=np.intp), ys)
    return ys[:done], error
