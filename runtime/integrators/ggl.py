"""The closed loops as a stabilised index-2 DAE (Gear, Gupta and Leimkuhler 1985), for IDA.

The other integrators see a closed mechanism as the ODE x' = f(P(x)) of its projected tree state (the loop
solver, runtime/c/loops.c). A DAE solver can take the constraints as equations instead, with the multipliers
among the unknowns, y = [q, v, lambda, mu]:

    q' = qdot(q, v + G^T mu)          (the GGL term G^T mu keeps q on g = 0; mu = 0 on the exact solution)
    M(q) v' = f(q, v, t) + G^T lambda
    0 = G(q) v + g_t(q, t)            (velocity constraints: index 2 with lambda)
    0 = g(q, t)                       (position constraints: index 2 with mu)

so neither drift nor projection: the position and the velocity constraints hold to the Newton tolerance at
every step. Constraint rows that are redundant (a planar loop closed by spatial joints has three of five) make
the iteration matrix singular, so the rows kept are an independent set chosen at the start by QR with column
pivoting of G^T; they stay fixed for the run (a singular position, where the rank drops, is the ODE form's
business). lambda and mu are algebraic; scikit-sundae offers no IDASetSuppressAlg, so they are kept out of
the error test the equivalent way, by an absolute tolerance far above their size.
"""

from __future__ import annotations

import numpy as np

#: Rank tolerance of the row choice, relative to the largest |G_ij| (the loop solver's MBS_LOOP_RANK_TOL).
RANK_TOL = 1e-9
#: Absolute tolerance on the multipliers: out of the error test (index-2 variables converge with lower order).
ALGEBRAIC_ATOL = 1e30
#: The kept rows are near a singular position when the smallest pivot of their QR falls below this fraction of
#: the largest: ten times the loop solver's band (runtime/c/loops.c, MBS_LOOP_BAND_TOL), where the multipliers
#: still stay moderate and the states accurate.
SINGULAR_PIVOT = 1e-2


class GGL:
    """Residual and consistent start of the index-2 GGL form of a closed mechanism (a C workspace with loops)."""

    def __init__(self, data, t0: float, x0: np.ndarray):
        model = data.model
        self.nq, self.nv, self.nx = model.nq, model.nv, model.nx
        self._qdot, self._mass, self._forces = data.function("qdot"), data.function("mass_matrix"), data.function("forces")
        self._g, self._gdot = data.function("constraints"), data.function("constraint_velocity")
        self._G = data.function("constraint_jacobian")
        x0 = data.function("project")(t0, np.asarray(x0, dtype=float))
        G = self._G(t0, x0).reshape(-1, self.nv)
        import scipy.linalg  # loaded by the first GGL run, not by every command line start
        _, r, pivots = scipy.linalg.qr(G.T, pivoting=True, mode="economic")
        diagonal = np.abs(np.diag(r))
        rank = int(np.count_nonzero(diagonal > RANK_TOL * max(np.abs(G).max(), 1e-300)))
        self.rows = np.sort(pivots[:rank])
        self.nc = rank
        self.n = self.nx + 2 * rank
        # consistent start: lambda from M vdot - f = G^T lambda on the kept rows, mu = 0
        xdot = data.function("rhs")(t0, x0)
        M = self._mass(t0, x0).reshape(self.nv, self.nv)
        b = M @ xdot[self.nq:] - self._forces(t0, x0)
        lam = np.linalg.lstsq(G[self.rows].T, b, rcond=None)[0]
        self.y0 = np.concatenate([x0, lam, np.zeros(rank)])
        self.yp0 = np.concatenate([xdot, np.zeros(2 * rank)])
        self._x = np.empty(self.nx)

    def near_singular(self, t: float, y: np.ndarray) -> bool:
        """Whether the kept rows are close to losing rank at the state y (a singular position ahead, where this
        form's multipliers grow without bound and its Newton iteration fails)."""
        import scipy.linalg
        G = self._G(t, y[:self.nx]).reshape(-1, self.nv)[self.rows]
        r = scipy.linalg.qr(G.T, mode="r", pivoting=True)[0]
        diagonal = np.abs(np.diag(r))
        return bool(diagonal.min() < SINGULAR_PIVOT * diagonal.max())

    @property
    def algebraic(self) -> list[int]:
        return list(range(self.nx, self.n))

    def atol(self, atol) -> np.ndarray:
        """The integrator's atol for the states, the multipliers out of the error test."""
        out = np.full(self.n, ALGEBRAIC_ATOL)
        out[:self.nx] = atol
        return out

    def residual(self, t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
        nq, nv, nx, nc = self.nq, self.nv, self.nx, self.nc
        x = y[:nx]
        lam, mu = y[nx:nx + nc], y[nx + nc:]
        G = self._G(t, x).reshape(-1, nv)[self.rows]
        shifted = self._x
        shifted[:nq] = x[:nq]
        shifted[nq:] = x[nq:] + G.T @ mu
        res[:nq] = yp[:nq] - self._qdot(t, shifted)
        M = self._mass(t, x).reshape(nv, nv)
        res[nq:nx] = M @ yp[nq:nx] - self._forces(t, x) - G.T @ lam
        res[nx:nx + nc] = self._gdot(t, x)[self.rows]
        res[nx + nc:] = self._g(t, x)[self.rows]
