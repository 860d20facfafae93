"""The equations of motion of a tree in minimal coordinates, as named results on one tape.

    qdot = G(q) v                        (kinematic map; G = identity except for quaternion joints)
    M(q, t) vdot = f(q, v, t),  f = q - k  (Leister/Schiehlen eq. (5), with q the applied and k the
                                            Coriolis, centrifugal, gyroscopic and rheonomic forces)

`derive_equations` runs the O(n) algorithms once on a shared tape: CRBA for M, RNEA for f, ABA for vdot (the
right-hand side used by the simulator), and collects qdot. `display_equations` writes M, k and q out in full for
small models, for `mbs eom`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from . import dynamics
from .kinematics import Kinematics
from .tape import Tape
from .tree import Tree, natural_key, t


@dataclass(frozen=True)
class Equations:
    """Named results on `kinematics.tape` (expressions of temporaries, state symbols, parameters and t).

    mass_matrix: nv x nv symmetric (tuple of rows) [kg, kg*m, kg*m^2].
    forces: f = q - k, length nv [N, N*m]; M vdot = f.
    qdot: time derivatives of the free coordinates, length nq.
    vdot: accelerations from the articulated-body algorithm, length nv (None if not derived).
    zdot: right-hand sides of the extra states (tree.states), length nz.
    """

    kinematics: Kinematics
    mass_matrix: tuple
    forces: tuple
    qdot: tuple
    vdot: tuple | None
    zdot: tuple = ()

    @property
    def tree(self) -> Tree:
        return self.kinematics.tree

    @property
    def tape(self) -> Tape:
        return self.kinematics.tape

    @property
    def rhs(self) -> tuple:
        """xdot = [qdot; vdot; zdot]."""
        return self.qdot + self.vdot + self.zdot

    def outputs(self) -> list:
        """Every result expression (for slicing the tape)."""
        out = [x for row in self.mass_matrix for x in row] + list(self.forces) + list(self.qdot)
        return out + list(self.vdot or ()) + list(self.zdot)

    def parameters(self) -> tuple:
        """Symbols the results depend on other than the state and t, in `natural_key` order: the run-time
        parameters (a default order for the emitter)."""
        return self._parameters

    @cached_property
    def _parameters(self) -> tuple:
        """(found once: the pipeline and the emitter both ask, and the walk over the tape is a tenth of the
        derivation of a long chain; the tape only grows at its end, which the results do not read)"""
        states = set(self.tree.x_symbols) | {t}
        found = self.tape.free_symbols(self.outputs()) - states
        return tuple(sorted(found, key=natural_key))


def derive_equations(kinematics: Kinematics, *, forward_dynamics: bool = True, state_rates: tuple = ()) -> Equations:
    """Mass matrix, forces and kinematic map (and ABA accelerations unless `forward_dynamics` is False) of the tree
    with the loads attached to `kinematics` so far; `state_rates` are the extra states' right-hand sides."""
    M = dynamics.mass_matrix(kinematics)
    tau = dynamics.inverse_dynamics(kinematics)
    forces = tuple(-x for x in tau)
    vdot = dynamics.forward_dynamics(kinematics) if forward_dynamics else None
    return Equations(kinematics, M, forces, kinematics.qdot, vdot, tuple(state_rates))


def display_equations(kinematics: Kinematics, *, simplify: bool = True) -> tuple:
    """(M, k, q) written out in full as sympy matrices (nv x nv, nv x 1, nv x 1) such that M vdot + k = q.

    Substitutes the tape back: the size of the result grows quickly with the number of bodies, so this is meant
    for small models (a few bodies). `simplify` applies trigsimp/simplify to every entry.
    """
    M = dynamics.mass_matrix(kinematics)
    k = dynamics.inverse_dynamics(kinematics, gravity=False, loads=False, name="k")
    q = dynamics.inverse_dynamics(kinematics, inertial=False, name="mq")
    nv = kinematics.tree.nv
    flat = kinematics.tape.expand([x for row in M for x in row] + list(k) + list(q))
    Mx = sp.Matrix(nv, nv, flat[:nv * nv])
    kx = sp.Matrix(flat[nv * nv:nv * nv + nv])
    qx = -sp.Matrix(flat[nv * nv + nv:])
    if simplify:
        Mx, kx, qx = (m.applyfunc(_simplify) for m in (Mx, kx, qx))
    return Mx, kx, qx


def _simplify(e: sp.Expr) -> sp.Expr:
    return sp.simplify(sp.trigsimp(sp.expand(e)))
