"""Static equilibrium by Newton's method on the reduced equations: the accelerations at rest as functions of the
independent coordinates of the loop solver's partition (all coordinates for a tree).

At rest (v = 0) the accelerations are vdot = T a with a the accelerations of the independent velocities, so the
equilibrium is a = 0 in the independent coordinates alone; the dependent ones follow by the projection onto the
loop-closure constraints. The Jacobian (the reduced stiffness over the reduced mass) is taken by forward
differences, one column per independent velocity, moving the positions along that velocity (q += qdot(q, e_j) h,
which handles quaternions) and projecting, afresh at every step (chord steps, keeping it while the residual falls
fast, saved a third of the evaluations on the Iltis but moved the steady run of tests/mbs/models/flat_car.mbs so
that its modes no longer separated: left out). Directions without stiffness (a wheel's spin, the chassis' position and
heading on level ground) span the null space of J: the step holds as many coordinates exactly where they are, those
that null space moves most (subset selection: QR with column pivoting of its basis, Golub and Van Loan, Matrix
Computations, section 5.5), and solves for the others, as the kinetic damping leaves them where they are. The
minimum-norm step does not: where a free direction's column is not zero but lies in the span of the stiff ones (the
Iltis' heading, its front wheels at the start of the bump: yaw moves one contact onto it, the other off), the null
vector is that direction plus a little of the stiff ones, and the minimum-norm step moves the free direction by that
little times the step, noise included: the heading by 9e-10 rad, at 10 m/s a slip angle whose lateral forces rolled
the car over the in-phase bump by 5e-9 rad (its mirror-symmetric start rolls by 1e-15 rad).

Newton finds any stationary point; a solution is accepted only if it is stable (no eigenvalue of the reduced
Jacobian d a / d q_I with a positive real part), so a start near an unstable position falls back to the kinetic
damping of runtime/equilibrium.py, which slides into the nearest minimum.
"""

from __future__ import annotations

import math

import numpy as np

from .rows import evaluate_rows

#: Newton iterations before giving up (a converging run takes 3-6).
MAX_ITERATIONS = 30
#: Forward-difference step along one independent velocity [m or rad].
DIFFERENCE_STEP = 1e-7
#: Converged when max |vdot| at rest falls below this [m/s^2 or rad/s^2] (well inside the kinetic damping's 1e-6).
TOLERANCE = 1e-9
#: Singular values of J below this fraction of the largest count as zero (a direction without stiffness): a cut
#: above the columns' noise (the loop solver's tolerance over DIFFERENCE_STEP, ~1e-5 of a stiffness entry), so
#: that the Iltis' free directions (yaw, fore-aft) are held exactly instead of moved by noise (which broke the
#: in-phase bump's left-right symmetry: roll 2e-7 rad). A real direction softer than this cannot be told from
#: noise by these columns either; Newton then stops reducing its residual and the kinetic damping takes over.
RCOND = 1e-4
#: Eigenvalues of d a / d q_I above this fraction of the largest magnitude count as unstable.
UNSTABLE = 1e-8


def newton_equilibrium(model, data, x0: np.ndarray, t: float = 0.0) -> np.ndarray | None:
    """The stable equilibrium near x0 with zero velocities, or None (no convergence, or an unstable one)."""
    nq, nv = model.nq, model.nv
    loops = "project" in model.functions
    qdot = data.function("qdot")
    x = np.array(x0, dtype=float)
    x[nq:] = 0.0
    try:
        if loops:
            x = data.project(t, x)
            report = data.loop_report(t, x)
            rank = int(report[5])
            free = np.sort(report[8:8 + nv].astype(int)[rank:])
        else:
            free = np.arange(nv)

        def move(state: np.ndarray, dv: np.ndarray) -> np.ndarray:
            probe = state.copy()
            probe[nq:] = dv
            moved = state.copy()
            moved[:nq] += qdot(t, probe)
            moved[nq:] = 0.0
            return data.project(t, moved) if loops else moved

        rhs = data.function("rhs")

        def accelerations(state: np.ndarray) -> np.ndarray:
            return rhs(t, state)[nq:]

        rows = _Rows(data, t, free.size)
        speeds = np.zeros((free.size, x.size - nq))  # the probes' speeds: e_j DIFFERENCE_STEP per free column j
        speeds[np.arange(free.size), free] = DIFFERENCE_STEP

        def jacobian(state: np.ndarray, acc: np.ndarray) -> np.ndarray:
            """The forward differences of every independent column, as move and accelerations give them column
            by column, in one pass per function over all the probes (qdot, project, rhs: on the C back end one
            call each, runtime/rows.py) instead of three Python calls per column."""
            probes = np.empty((free.size, state.size))
            probes[:, :nq] = state[:nq]
            probes[:, nq:] = speeds
            moved = np.empty_like(probes)
            np.add(state[:nq], rows("qdot", probes, nq), out=moved[:, :nq])
            moved[:, nq:] = 0.0
            if loops:
                moved = rows("project", moved, moved.shape[1])
            return ((rows("rhs", moved, moved.shape[1])[:, nq:] - acc) / DIFFERENCE_STEP).T

        acc = accelerations(x)
        largest = _largest(acc)
        J = np.zeros((nv, free.size))
        for _ in range(MAX_ITERATIONS):
            if largest <= TOLERANCE:
                return x if _stable(J, free) else None
            if free.size:
                J = jacobian(x, acc)
            dv = np.zeros(nv)
            dv[free] = _step(J, acc)
            for _ in range(8):  # halve a step that makes things worse (far from the solution)
                trial = move(x, dv)
                trial_acc = accelerations(trial)
                trial_largest = _largest(trial_acc)
                if trial_largest < largest:
                    break
                dv *= 0.5
            else:
                return None
            x, acc, largest = trial, trial_acc, trial_largest
    except Exception:  # a failing evaluation far from the start: leave it to the kinetic damping
        return None
    return None


def _step(J: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """The least-squares Newton step in the independent coordinates (columns of J), exactly zero in those the null
    space of J (singular values below RCOND times the largest) moves most: one held per null direction."""
    step = np.zeros(J.shape[1])
    if not J.size or not J.any():
        return step
    # numpy's public wrappers (about 30 k instructions a call around the LAPACK routine, a few hundredths of a ms
    # per Newton step): numpy.linalg's private gufuncs would skip them, but a private module is no interface to
    # build on
    _, s, vt = np.linalg.svd(J, full_matrices=False)
    rank = int(np.count_nonzero(s > RCOND * s[0]))
    # the kept columns by a mask: np.setdiff1d would import numpy.ma (30 ms of a warm command line)
    kept = np.ones(J.shape[1], dtype=bool)
    kept[_pivot_columns(vt[rank:], J.shape[1] - rank)] = False
    kept = np.flatnonzero(kept)
    step[kept] = np.linalg.lstsq(J[:, kept], -acc, rcond=RCOND)[0]
    return step


class _Rows:
    """The model function ``name`` at each of n states (rows) at time t (runtime/rows.py), raising its error: the
    times, the p in force and the row's p index made once for the whole iteration."""

    def __init__(self, data, t: float, n: int):
        self.data, self.ts, self.which = data, np.full(n, t), np.zeros(n, dtype=np.intp)
        self.ps = data.p.reshape(1, -1).copy()

    def __call__(self, name: str, states: np.ndarray, size: int) -> np.ndarray:
        out = np.empty((len(states), size))
        f = self.data.function(name)
        # the C back end's rows straight away (the arrays are made for it: contiguous, of its types); the rows'
        # pass of runtime/rows.py when a row fails there (its error) or on another back end
        if hasattr(f, "rows") and states.flags.c_contiguous and \
                f.rows(self.ts, states, out, self.ps, self.which) == len(states):
            return out
        done, error = evaluate_rows(self.data, name, self.ps, self.ts, states, self.which, out)
        if error is not None:
            raise error
        return out


def _largest(a: np.ndarray) -> float:
    """max |a| (0 for none), as np.max(np.abs(a), initial=0.0) without its Python dispatch."""
    return abs(a).max(initial=0.0)


def _pivot_columns(A: np.ndarray, k: int) -> list[int]:
    """The first k column pivots of QR with column pivoting of A (Businger and Golub; Golub and Van Loan 5.4.2):
    each time the column of largest remaining norm, the others then made orthogonal to it. In NumPy, so that the
    equilibrium of a warm run imports no scipy (tests/mbs/test_model_cache.py)."""
    R = np.array(A, dtype=float)
    chosen: list[int] = []
    for _ in range(k):
        norms = np.einsum("ij,ij->j", R, R)
        for taken in chosen:  # (one by one: an index list costs numpy more than these few)
            norms[taken] = -1.0
        j = int(norms.argmax())
        largest = norms.item(j)
        if not largest > 0.0:
            break
        chosen.append(j)
        if len(chosen) == k:  # (the last pivot: nothing left to make orthogonal to it)
            break
        q = R[:, j] / math.sqrt(largest)  # (both correctly rounded: the same bits as np.sqrt)
        R -= q[:, None] * (q @ R)  # np.outer(q, q @ R), as it computes it
    return chosen


def _stable(J: np.ndarray, free: np.ndarray) -> bool:
    """No growing motion about the solution: the eigenvalues of d a / d q_I (a = vdot at the independent
    velocities) have no positive real part."""
    if free.size == 0 or not np.any(J):
        return True
    eig = np.linalg.eigvals(J[free, :])
    return bool(np.max(eig.real) <= UNSTABLE * np.max(np.abs(eig)))


__all__ = ["newton_equilibrium"]
