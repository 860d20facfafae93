"""The dynamics functions robotics and control users call one by one, generated only when asked for.

Derived on the tape of the equations (sharing its temporaries) and emitted as extra functions of the same C file
and NumPy module, with the contract's signature f(t, x, p, out, work) -> status:

    mbs_inverse_dynamics  x = [q; v; a] (MBS_NXA = MBS_NX + MBS_NV)  tau = M(q) a + k(q, v) - q(q, v): the joint
                          forces that give the accelerations a with every load of the model acting (weights,
                          springs, dampers, point and joint forces); Pinocchio's rnea with its external forces
    mbs_bias_forces       x = [q; v]     b = k - q_gravity: Coriolis, centrifugal, gyroscopic forces and weights
                          (Pinocchio's nonLinearEffects); tau = M a + b - q_applied
    mbs_gravity_forces    x = [q; v]     g = -q_gravity: the generalized weights (computeGeneralizedGravity)

The mass matrix is the contract's mbs_mass_matrix. Signs follow docs/equations.md: M v' + k = q, a
generalized force positive when its power on a positive speed is positive; tau is what a drive must add to q.
"""

from __future__ import annotations

import sympy as sp

from . import dynamics
from .kinematics import Kinematics

#: the dynamics functions by the name callers use, in file order
DYNAMICS_FUNCTIONS = ("inverse_dynamics", "bias_forces", "gravity_forces")


def acceleration_symbols(kin: Kinematics) -> tuple[sp.Symbol, ...]:
    """One symbol per free velocity: the accelerations a that mbs_inverse_dynamics reads after [q; v]."""
    return tuple(sp.Symbol(f"acc({s.name})") for s in kin.tree.v_symbols)


def dynamics_routines(kin: Kinematics) -> tuple[list, tuple]:
    """(routines, inputs): the emitter's routine tuples (name, out, doc, shape, results, check_positive) of the
    dynamics functions, derived on `kin.tape`, and the (symbol, array, index) of the accelerations they read
    (array x, after the state). Call after the equations are derived and before the emitter is built."""
    nv, nx = kin.tree.nv, kin.tree.nx
    acc = acceleration_symbols(kin)
    tau = dynamics.inverse_dynamics(kin, acc, name="id")
    bias = dynamics.inverse_dynamics(kin, None, loads=False, name="nle")
    gravity = dynamics.inverse_dynamics(kin, None, inertial=False, loads=False, name="grav")
    routines = [
        ("mbs_inverse_dynamics", "tau", "tau = M a + k - q at x = [q; v; a]: the joint forces that give the "
         "accelerations a under every load of the model", (nv,), list(enumerate(tau)), False),
        ("mbs_bias_forces", "b", "b = k - q_gravity: Coriolis, centrifugal, gyroscopic forces and weights",
         (nv,), list(enumerate(bias)), False),
        ("mbs_gravity_forces", "g", "g = -q_gravity: the generalized weights", (nv,), list(enumerate(gravity)),
         False),
    ]
    inputs = tuple((s, "x", nx + k) for k, s in enumerate(acc))
    return routines, inputs


__all__ = ["DYNAMICS_FUNCTIONS", "acceleration_symbols", "dynamics_routines"]
