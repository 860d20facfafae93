"""Assembly of a mechanism with closed loops: a consistent initial state near the user's approximate one.

    result = assemble(model, data, x0, fixed=["crank_pin.phi", "guide.s", "der(main_bearing.phi)"],
                      row_names=gen.constraint_names, spans={"wrist_pin": span})
    data.x = result.x                       # g(q) = 0 and G(q) v + g_t = 0 to MBS_LOOP_TOL
    for name, before, after in result.changed: ...

Positions: Gauss-Newton on the coordinates the user did not fix, each step the least change (minimum norm
in the velocity coordinates, dq = qdot(q, dv), quaternions renormalised), with step halving when the residual
does not fall; redundant constraints are handled by the least-squares solve. Velocities: the least change of the
free speeds that satisfies G v + g_t = 0. When the fixed values leave no solution (or Newton does not converge),
`AssemblyError` names the loop (cut joint) with the largest residual and the residual, at the joint's source span
when `spans` gives it.

Needs the loop functions of a C model (`constraints`, `constraint_velocity`, `constraint_jacobian`, `qdot`,
`normalize`); see runtime/c/loops.c.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from mbs.language.diagnostics import Diagnostic, MbsError

from .derived import friction_modes_of
from .errors import UsageError
from .friction import stick_rows_released
from .model import CompiledModel
from .workspace import Workspace, check_workspace

#: Residual tolerance [m or rad] (the run-time projection's MBS_LOOP_TOL), and the round-off floor below which
#: a residual that no step reduces counts as converged (MBS_LOOP_FLOOR).
TOLERANCE = 1e-12
FLOOR = 1e-9
#: Velocity residual tolerance relative to 1 + max |G| max |v| (a linear solve: round-off only).
VELOCITY_TOLERANCE = 1e-10
#: Gauss-Newton iteration cap (each iteration halves its step at most HALVINGS times).
MAX_ITERATIONS = 60
HALVINGS = 12
#: Singular values below this fraction of the largest count as zero (redundant constraints).
RCOND = 1e-10
#: Labels of the constraint rows that are distances [m] (compiler/constraints.py ROWS); the others are
#: dimensionless (small angles, rad).
TRANSLATION_ROWS = frozenset({"x", "y", "z", "shift_u", "shift_w", "normal"})
#: Changes smaller than this (relative to 1 + |value|) are not reported as changes.
REPORT_THRESHOLD = 1e-12
_REQUIRED = ("constraints", "constraint_velocity", "constraint_jacobian", "qdot", "normalize")


@dataclass(frozen=True)
class Assembly:
    """A consistent state and how it was found.

    x: (nx,) the assembled state [q; v]; changed: (name, given, assembled) of every state that moved;
    residual: max |g| [m or -]; velocity_residual: max |G v + g_t|; iterations: Gauss-Newton iterations;
    rank: of G at x; dof: nv - rank (the mechanism's degrees of freedom there); redundant: names of the rows
    that depend on other rows (each takes part in a vanishing combination of non-zero rows of G: an
    overconstrained but mobile mechanism such as a parallelogram with a third crank); idle: rows whose G row
    vanishes, which the geometry satisfies by itself (the out-of-plane rows of a planar mechanism's joints)."""

    x: np.ndarray
    changed: tuple[tuple[str, float, float], ...]
    residual: float
    velocity_residual: float
    iterations: int
    rank: int
    dof: int
    redundant: tuple[str, ...] = ()
    idle: tuple[str, ...] = ()

    def describe(self) -> str:
        """One line per changed state, for a log or a note."""
        return "\n".join(f"{name}: {given:.6g} -> {after:.6g}" for name, given, after in self.changed)


class AssemblyError(MbsError):
    """The closed loops cannot be assembled with the given fixed values.

    row: index of the constraint row with the largest residual; constraint: its name ("<joint>.<label>");
    loop: the cut joint's name; residual: max |g| (or max |G v + g_t| when `stage` is "velocity")."""

    def __init__(self, message: str, span, row: int, constraint: str, loop: str, residual: float, stage: str):
        self.message, self.row, self.constraint, self.loop = message, row, constraint, loop
        self.residual, self.stage = residual, stage
        super().__init__([Diagnostic("error", message, span)])


def held_columns(v_names: Iterable[str], fixed: Iterable[str]) -> tuple[np.ndarray, np.ndarray]:
    """(positions, speeds): boolean masks over the velocity coordinates. A velocity column is held in the
    position stage when its coordinate is in `fixed` ("der(j.phi)" <- "j.phi"; a quaternion's "j.wx", "j.wy",
    "j.wz" <- any of "j.qw" .. "j.qz"), and in the velocity stage when its own name is in `fixed`."""
    fixed = set(fixed)
    positions, speeds = [], []
    for name in v_names:
        if name.startswith("der(") and name.endswith(")"):
            positions.append(name[4:-1] in fixed)
        else:
            head = name.rsplit(".", 1)[0]
            positions.append(any(f"{head}.q{c}" in fixed for c in "wxyz"))
        speeds.append(name in fixed)
    return np.array(positions, dtype=bool), np.array(speeds, dtype=bool)


@functools.lru_cache(maxsize=64)
def _held(v_names: tuple[str, ...], fixed: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """held_columns, once per model's speeds and fixed names (read-only masks): every run of a scene holds the
    same ones."""
    masks = held_columns(v_names, fixed)
    for mask in masks:
        mask.flags.writeable = False
    return masks


def assemble(model: CompiledModel, data: Workspace, x0=None, *, t: float | None = None, fixed: Iterable[str] = (),
             row_names: Iterable[str] | None = None, spans: Mapping[str, object] | None = None,
             tolerance: float = TOLERANCE) -> Assembly:
    """A state satisfying the loop-closure constraints near x0 (default data.x) at time t (default data.t),
    holding the coordinates and speeds named in `fixed` (as in the model's state names: "j.phi",
    "der(j.phi)", "j.qw", "j.wx"). Raises AssemblyError (an MbsError) when that is impossible."""
    _check_loops(model, data)
    with _released(model, data):  # friction's locks are no part of the loops' geometry
        return _assemble(model, data, x0, t, fixed, row_names, spans, tolerance)


def assembled_state(model: CompiledModel, data: Workspace, x0=None, *, t: float | None = None,
                    fixed: Iterable[str] = (), row_names: Iterable[str] | None = None,
                    spans: Mapping[str, object] | None = None, tolerance: float = TOLERANCE) -> np.ndarray:
    """assemble(...).x, the same to the bit, without the report (the rank of G and its redundant rows by an SVD,
    the states that changed): what a run's start needs."""
    _check_loops(model, data)
    with _released(model, data):
        return _closed(model, data, x0, t, fixed, row_names, spans, tolerance)[1]


def _released(model, data):
    """stick_rows_released, entered only for a model with switched friction elements (nothing to release else)."""
    return stick_rows_released(model, data) if friction_modes_of(model) else contextlib.nullcontext()


def _check_loops(model, data) -> None:
    check_workspace(model, data)
    missing = [name for name in _REQUIRED if name not in model.functions]
    if missing:
        raise UsageError(f"model {model.name} has no loop functions ({', '.join(missing)}): it has no closed "
                         "loops, or it was built with the NumPy back end")


def _assemble(model, data, x0, t, fixed, row_names, spans, tolerance) -> Assembly:
    given, x, residual, velocity_residual, iterations, G, names = _closed(model, data, x0, t, fixed, row_names,
                                                                          spans, tolerance)
    rank, dependent, idle = _rank_and_dependent_rows(G)
    changed = tuple((name, float(a), float(b)) for name, a, b in zip(model.x_names, given, x)
                    if abs(b - a) > REPORT_THRESHOLD * (1.0 + abs(a)))
    return Assembly(x, changed, residual, velocity_residual, iterations, rank, model.nv - rank,
                    tuple(names[i] for i in dependent), tuple(names[i] for i in idle))


def _closed(model, data, x0, t, fixed, row_names, spans, tolerance):
    """(the state given, the state closed, position residual, velocity residual, iterations, G there, row names)."""
    t = float(data.t if t is None else t)
    fixed = tuple(fixed)
    given = np.array(data.x if x0 is None else x0, dtype=float)
    x = data.normalize(t, given)
    nq, nv = model.nq, model.nv
    names = list(row_names) if row_names is not None else [f"constraint {k}" for k in
                                                            range(model.backend.functions["constraints"][0])]
    hold_q, hold_v = _held(model.v_names, fixed)
    # positions: Gauss-Newton with the least change of the free coordinates
    g = data.constraints(t, x)
    iterations, stalled = 0, False
    while np.max(np.abs(g), initial=0.0) > tolerance and iterations < MAX_ITERATIONS:
        if np.all(hold_q):
            break  # nothing may move
        iterations += 1
        G = data.constraint_jacobian(t, x)
        step = np.zeros(nv)
        step[~hold_q] = -np.linalg.lstsq(G[:, ~hold_q], g, rcond=RCOND)[0]
        norm, scale = np.max(np.abs(g)), 1.0
        for _ in range(HALVINGS):
            trial = _moved(data, t, x, scale * step)
            g_trial = data.constraints(t, trial)
            if np.max(np.abs(g_trial)) < norm:
                break
            scale *= 0.5
        else:
            stalled = True  # no descent: the fixed values leave no solution, or round-off is reached
            break
        x, g = trial, g_trial
    residual = float(np.max(np.abs(g), initial=0.0))
    if not (residual <= tolerance or (stalled and residual <= FLOOR)):
        raise _failure("position", names, spans, g, iterations, fixed)

    # velocities: the least change of the free speeds
    G = data.constraint_jacobian(t, x)
    v = x[nq:nq + nv]  # a view: the extra states z after it stay as given
    gd = data.constraint_velocity(t, x)
    if np.any(~hold_v):
        v[~hold_v] -= np.linalg.lstsq(G[:, ~hold_v], gd, rcond=RCOND)[0]
    gd = data.constraint_velocity(t, x)
    scale_v = 1.0 + np.max(np.abs(v), initial=0.0) * max(1.0, float(np.max(np.abs(G), initial=0.0)))
    velocity_residual = float(np.max(np.abs(gd), initial=0.0))
    if not velocity_residual <= VELOCITY_TOLERANCE * scale_v:
        raise _failure("velocity", names, spans, gd, iterations, fixed)
    return given, x, residual, velocity_residual, iterations, G, names


#: A row takes part in a dependency when its weight in a unit left null vector of G exceeds this (round-off
#: leaves the rows outside any dependency at ~1e-15).
DEPENDENT_ROW_WEIGHT = 1e-6


def _rank_and_dependent_rows(G: np.ndarray) -> tuple[int, list[int], list[int]]:
    """(rank of G, dependent rows, idle rows): the non-zero rows spanned by the left null space of G (the rows
    that are redundant together) and the rows of G that vanish."""
    if not G.size:
        return 0, [], []
    scale = float(np.max(np.abs(G)))
    idle = [i for i in range(G.shape[0]) if not np.max(np.abs(G[i]), initial=0.0) > RCOND * scale]
    active = [i for i in range(G.shape[0]) if i not in idle]
    if not active:
        return 0, [], idle
    U, s, _ = np.linalg.svd(G[active])
    rank = int(np.sum(s > RCOND * s[0]))
    weights = np.linalg.norm(U[:, rank:], axis=1)
    return rank, [active[k] for k, w in enumerate(weights) if w > DEPENDENT_ROW_WEIGHT], idle


def _moved(data: Workspace, t: float, x: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """x with q moved by qdot(q, dv) (a first-order step along the velocity coordinates), quaternions unit;
    the extra states z stay."""
    nq = data.model.nq
    probe = np.concatenate([x[:nq], dv, x[nq + dv.size:]])
    out = x.copy()
    out[:nq] += data.qdot(t, probe)
    return data.normalize(t, out)


def _failure(stage: str, names, spans, residuals: np.ndarray, iterations: int, fixed) -> AssemblyError:
    row = int(np.argmax(np.abs(residuals)))
    constraint = names[row]
    loop = constraint.rsplit(".", 1)[0] if "." in constraint else constraint
    value = float(abs(residuals[row]))
    held = ", ".join(sorted(fixed)) or "nothing"
    unit = "m" if constraint.rsplit(".", 1)[-1] in TRANSLATION_ROWS else "rad"
    unit += "" if stage == "position" else "/s"
    message = (f"the closed loop through joint '{loop}' cannot be assembled: its {stage} constraint "
               f"'{constraint}' is off by {value:.3g} {unit} after {iterations} iteration(s) holding {held}")
    span = (spans or {}).get(loop)
    return AssemblyError(message, span, row, constraint, loop, value, stage)


def project_samples(data: Workspace, times: np.ndarray, states: np.ndarray) -> int:
    """Replace every sampled state (row of `states`) by its projection onto the constraints, in place; returns
    the number of rows projected (fewer when a projection fails: the rows after it are left as they were).
    For the simulation driver: the integrator's dense output is only near the constraint manifold."""
    from .rows import evaluate_rows
    projected = np.empty_like(states)
    done, _ = evaluate_rows(data, "project", [data.p], times, states, np.zeros(len(times), dtype=np.intp), projected)
    states[:done] = projected[:done]
    return done
