"""Model functions evaluated at many rows of a run (its samples and the rows at its events) for the results:
the projection onto the closed loops' constraints and the outputs, each row with the run-time values in force
when it was computed.  On the C back end every row in one call (Function.rows in c/mbs_glue.c: no Python per
row); elsewhere a Python loop that does the same."""

from __future__ import annotations

import numpy as np

from .errors import EvaluationError, MbsError
from .workspace import Workspace


def evaluate_rows(data: Workspace, name: str, ps, ts: np.ndarray, xs: np.ndarray, which: np.ndarray,
                  out: np.ndarray):
    """out[i] = f(ts[i], xs[i]) of the model function ``name`` with the run-time values ps[which[i]] in force (a
    run with events: modes, switch flags and parameters change at events, and a sticking friction element is a
    constraint row only while it sticks: compiler/friction_loops.py), in one pass: p is set where it changes, and
    a row that repeats the one before it (same time, state and p) takes its value.  ``ps``: p vectors, or an array
    of them as rows (taken without a copy).  Returns (rows done, None), or at the first failure (its row, the
    MbsError: a model status, or a loop that cannot be closed)."""
    f = data.function(name)
    if hasattr(f, "rows"):  # the C back end: every row in one call (c/mbs_glue.c), the failing one again here
        done = f.rows(*_c_rows_arguments(ts, xs, out, ps, which))
        if done == len(ts):
            return done, None
        saved = data.p.copy()
        data.p[:] = ps[which[done]]
        try:
            f(float(ts[done]), xs[done])
        except MbsError as exc:
            return done, exc
        finally:
            data.p[:] = saved
        return done, EvaluationError(name, 2, float(ts[done]))
    p = data.p  # the workspace's own array: the model functions read it
    saved, current = p.copy(), -1
    try:
        for i, (t, k) in enumerate(zip(ts.tolist(), which.tolist())):
            if k != current:
                p[:] = ps[k]
                current = k
            elif i and t == ts[i - 1] and np.array_equal(xs[i], xs[i - 1]):
                out[i] = out[i - 1]
                continue
            try:
                out[i] = f(t, xs[i])
            except MbsError as exc:  # a model status (EvaluationError), or a loop that cannot be closed
                return i, exc
    finally:
        p[:] = saved
    return len(ts), None


def _c_rows_arguments(ts, xs, out, ps, which) -> tuple:
    """The arguments of a C function's `rows` (c/mbs_glue.c): contiguous arrays of the right types, the p copies as
    rows (an array of them taken without a copy)."""
    return (np.ascontiguousarray(ts, dtype=float), np.ascontiguousarray(xs, dtype=float), out,
            np.ascontiguousarray(ps, dtype=float).reshape(len(ps), -1), np.ascontiguousarray(which, dtype=np.intp))


def project_rows(data: Workspace, ps, ts: np.ndarray, xs: np.ndarray, which: np.ndarray, projected: np.ndarray):
    """projected[i] = the projection of xs[i] onto the closed loops' constraints with ps[which[i]] in force, as
    :func:`evaluate_rows` of ``project``; on the C back end by ``project_row`` (c/mbs_glue.c, c/loops.c
    mbs_loop_project_row), whose rows start their Newton steps from the factors of G the row before left and
    evaluate and factor G once at the projected positions, where ``project`` does both twice (the Iltis over the
    bump: 30,500 instructions a row against 41,000; the same projection to round-off, but that a row whose
    positions lie within 1e-13 of the constraints keeps them, as an accepted step does: c/loops.c
    MBS_LOOP_STEP_KEPT).  Returns (rows done, None), or at the first failure (its row, the MbsError)."""
    name = "project_row" if "project_row" in data.model.functions else "project"
    return evaluate_rows(data, name, ps, ts, xs, which, projected)


def project_and_evaluate_rows(data: Workspace, name: str, ps, ts: np.ndarray, xs: np.ndarray,
                              which: np.ndarray, projected: np.ndarray, out: np.ndarray):
    """projected[i] = the projection of xs[i] onto the closed loops' constraints, out[i] = f(ts[i], projected[i])
    (the model function ``name``, the outputs), each row with ps[which[i]] in force.  On the C back end one pass
    in which the outputs' loop solve starts from the factors the row's projection left (Function.rows with
    ``projected``: c/mbs_glue.c, c/loops.c mbs_loop_rates) instead of projecting the row again; elsewhere the two
    passes of :func:`evaluate_rows`.  Returns (rows done, None, None), or at the first failure (its row, the
    MbsError, "project" or ``name``: which of the two failed there)."""
    f = data.function(name)
    if hasattr(f, "rows"):
        try:
            done = f.rows(*_c_rows_arguments(ts, xs, out, ps, which), projected)
        except ValueError:  # a model whose outputs do not solve the loops in their own work: two passes
            done = None
        if done is not None:
            if done == len(ts):
                return done, None, None
            return (done, *_failure(data, name, ps[which[done]], float(ts[done]), xs[done]))
    done, error = project_rows(data, ps, ts, xs, which, projected)
    if error is not None or done < len(ts):
        return done, error, "project"
    done, error = evaluate_rows(data, name, ps, ts, projected, which, out)
    return done, error, (None if error is None else name)


def _failure(data: Workspace, name: str, p: np.ndarray, t: float, x: np.ndarray):
    """(the MbsError, "project" or ``name``) of the row (t, x) that failed in one pass, evaluated again here."""
    saved = data.p.copy()
    data.p[:] = p
    try:
        stage = "project"
        x = data.function("project")(t, x)
        stage = name
        data.function(name)(t, x)
    except MbsError as exc:
        return exc, stage
    finally:
        data.p[:] = saved
    return EvaluationError(name, 2, t), stage
