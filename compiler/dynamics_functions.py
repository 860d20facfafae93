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

from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError

from . import dynamics
from .kinematics import Kinematics
from .symbolic import ToSympy

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
        ("mbs_inverse_dynamics", "mbs_tau", "tau = M a + k - q at x = [q; v; a]: the joint forces that give the "
         "accelerations a under every load of the model", (nv,), list(enumerate(tau)), False),
        ("mbs_bias_forces", "mbs_bias", "b = k - q_gravity: Coriolis, centrifugal, gyroscopic forces and weights",
         (nv,), list(enumerate(bias)), False),
        ("mbs_gravity_forces", "mbs_gravity", "g = -q_gravity: the generalized weights", (nv,),
         list(enumerate(gravity)),
         False),
    ]
    inputs = tuple((s, "x", nx + k) for k, s in enumerate(acc))
    return routines, inputs


def frame_routines(kin: Kinematics, frames) -> list:
    """Routine tuples of the named frames' kinematics, world components, frames in the order given:

    mbs_frame_positions   (NF x 12) origin x y z [m], then the rotation frame -> world, row-major
    mbs_frame_velocities  (NF x 6)  velocity of the origin [m/s], then the angular velocity [rad/s]
    mbs_frame_jacobians   (6 NF x NV) d(velocities)/dv: velocities = J v (+ prescribed-motion terms)

    frames: (name, body index, position in the body frame, rotation in the body frame) per frame."""
    tape, nv = kin.tape, kin.tree.nv
    positions, velocities = [], []
    for name, body, p_local, R_local in frames:
        tape.section(f"frame {name}")
        R = kin.frame_rotation(body, R_local)
        positions += [*kin.frame_position(body, p_local), *(R[i][j] for i in range(3) for j in range(3))]
        velocities += [*kin.frame_velocity(body, p_local), *kin.body_angular_velocity(body)]
    jacobian = tape_jacobian(tape, velocities, kin.tree.v_symbols, "J")
    n = len(frames)
    return [
        ("mbs_frame_positions", "mbs_pose", "per named frame: origin (world) and rotation frame -> world, row-major",
         (n, 12), list(enumerate(positions)), False),
        ("mbs_frame_velocities", "mbs_twist", "per named frame: origin velocity and angular velocity (world)",
         (n, 6), list(enumerate(velocities)), False),
        ("mbs_frame_jacobians", "mbs_jac", "per named frame: the 6 x NV Jacobian of its velocities (world), stacked",
         (6 * n, nv), [(r * nv + c, x) for r, row in enumerate(jacobian) for c, x in enumerate(row)], False),
    ]


def named_frames(lowered, names) -> list:
    """(name, body index, position, rotation in the body frame) of frames named "part.frame" (or "part" for
    its origin), for frame_routines; an unknown name is an error that lists the part's frames."""
    model = lowered.model

    def constant_only(sym):
        raise MbsError([Diagnostic("error", f"frame geometry uses '{sym.name}', which is not a parameter", None)])
    geometry = ToSympy(constant_only)
    out = []
    for name in names:
        part_name, _, frame_name = name.rpartition(".") if "." in name else (name, "", M.ORIGIN)
        part = model.part_map.get(part_name)
        if part is None or frame_name not in part.frame_map:
            known = ", ".join(f"{p.name}.{f.name}" for p in model.parts for f in p.frames)
            raise MbsError([Diagnostic("error", f"model '{model.name}' has no frame '{name}' (frames: {known})",
                                       None)])
        frame = part.frame_map[frame_name]
        body = -1 if part_name == M.INERTIAL else lowered.topology.bodies.index(part_name)
        origin = (0, 0, 0) if body < 0 else lowered.body_origins[body]   # (the body frame's, compiler/lower.py)
        out.append((name, body, [geometry(c) - o for c, o in zip(frame.position, origin)],
                    tuple(tuple(geometry(c) for c in row) for row in frame.rotation)))
    return out


def tape_jacobian(tape, outputs, variables, name: str) -> list[list]:
    """d outputs / d variables by forward differentiation along the tape (each derivative a temporary), rows
    per output. Only the entries that depend on a variable get derivatives, so the cost follows the velocity
    part of the kinematics, not the whole tape."""
    variables = tuple(variables)
    index = {v: j for j, v in enumerate(variables)}
    derivative: dict = {}

    def differentiate(expr, label):
        row = [sp.S.Zero] * len(variables)
        for s in expr.free_symbols:
            if s in index:
                row[index[s]] += sp.diff(expr, s)
            elif s in derivative:
                partial = sp.diff(expr, s)
                for j, d in enumerate(derivative[s]):
                    if d != 0:
                        row[j] += partial * d
        return [tape.temp(x, f"{label}_{j}") for j, x in enumerate(row)]

    for entry in tape.entries_for(outputs):
        if any(s in index or s in derivative for s in entry.expr.free_symbols):
            derivative[entry.symbol] = differentiate(entry.expr, f"d{entry.name}")
    return [differentiate(sp.sympify(e), f"{name}{k}") for k, e in enumerate(outputs)]


__all__ = ["DYNAMICS_FUNCTIONS", "acceleration_symbols", "dynamics_routines", "frame_routines", "tape_jacobian",
           "named_frames"]
