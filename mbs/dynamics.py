"""The dynamics functions of a model, one call each, as robotics and control code uses them.

    import mbs
    from mbs.dynamics import dynamics_functions
    dyn = dynamics_functions(mbs.load("tests/compiler/models/spatial_arm.mbs"))
    tau = dyn.inverse_dynamics(q, v, a)     # M(q) a + k(q, v) - q(q, v): the drive forces for accelerations a
    b = dyn.bias_forces(q, v)              # k - q_gravity (Pinocchio's nonLinearEffects)
    g = dyn.gravity_forces(q)              # -q_gravity (computeGeneralizedGravity)
    M = dyn.mass_matrix(q)
    dyn = dynamics_functions(system, frames=["fore.tip"])
    J = dyn.frame_jacobians(q)[0]          # 6 x nv: (velocity of the tip; angular velocity) = J v, world axes

They are generated only when asked for (this call compiles the model once more, with them; the C file then also
exports mbs_inverse_dynamics, mbs_bias_forces and mbs_gravity_forces, see compiler/dynamics_functions.py), in C
when a compiler runs, else in NumPy. q, v, a in the model's state order (CompiledModel.q_names, v_names); SI.
Signs: M v' + k = q (docs/equations.md); tau is the generalized force a drive adds to q. With closed loops
the functions are those of the spanning tree (the cut joints' constraints act through G^T lambda), and
constraint_jacobian and multipliers are there as well.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from mbs.runtime.model import CompiledModel
from mbs.runtime.workspace import Workspace

from . import pipeline
from .system import System


class DynamicsFunctions:
    """The compiled dynamics functions of one model and a workspace of their own (parameters set once)."""

    def __init__(self, compiled: CompiledModel, params: Mapping[str, float], frames: tuple[str, ...] = ()):
        self.model = compiled
        self.frames = tuple(frames)
        self.data = Workspace(compiled)
        self.data.p = pipeline.parameter_vector(compiled.p_names, params)
        self._x = np.zeros(compiled.nx)
        self._xa = np.zeros(compiled.nx + compiled.nv)
        self._f = {name: self.data.function(name) for name in
                   ("inverse_dynamics", "bias_forces", "gravity_forces", "mass_matrix")}

    def inverse_dynamics(self, q, v, a, t: float = 0.0) -> np.ndarray:
        """tau = M(q) a + k(q, v) - q(q, v) [N or N*m per speed]."""
        nq, nx = self.model.nq, self.model.nx
        self._xa[:nq], self._xa[nq:nx], self._xa[nx:] = q, v, a
        return self._f["inverse_dynamics"](t, self._xa)

    def bias_forces(self, q, v, t: float = 0.0) -> np.ndarray:
        """b = k(q, v) - q_gravity(q): tau at a = 0 without the applied loads other than the weights."""
        return self._f["bias_forces"](t, self._state(q, v))

    def gravity_forces(self, q, t: float = 0.0) -> np.ndarray:
        """g = -q_gravity(q)."""
        return self._f["gravity_forces"](t, self._state(q, 0.0))

    def mass_matrix(self, q, t: float = 0.0) -> np.ndarray:
        return self._f["mass_matrix"](t, self._state(q, 0.0))

    def frame_positions(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(positions (NF x 3) [m], rotations (NF x 3 x 3) frame -> world) of the frames named at compile time."""
        pose = self.data.function("frame_positions")(t, self._state(q, 0.0))
        return pose[:, :3], pose[:, 3:].reshape(-1, 3, 3)

    def frame_velocities(self, q, v, t: float = 0.0) -> np.ndarray:
        """(NF x 6): velocity of each frame's origin [m/s], then its angular velocity [rad/s], world axes."""
        return self.data.function("frame_velocities")(t, self._state(q, v))

    def frame_jacobians(self, q, t: float = 0.0) -> np.ndarray:
        """(NF x 6 x NV): J with frame_velocities = J v (plus the terms of prescribed motion), rows as there."""
        J = self.data.function("frame_jacobians")(t, self._state(q, 0.0))
        return J.reshape(len(self.frames), 6, self.model.nv)

    def constraint_jacobian(self, q, t: float = 0.0) -> np.ndarray:
        """G(q) (NC x NV) of the loop-closure rows of a model with closed loops: G v = 0 on the motion."""
        return self.data.function("constraint_jacobian")(t, self._state(q, 0.0))

    def multipliers(self, q, v, t: float = 0.0) -> np.ndarray:
        """lambda with M v' = f + G^T lambda at a consistent state (closed loops): the inverse dynamics of the
        spanning tree at the actual accelerations is then tau = G^T lambda."""
        return self.data.function("multipliers")(t, self._state(q, v))

    def _state(self, q, v) -> np.ndarray:
        nq = self.model.nq
        self._x[:nq], self._x[nq:] = q, v
        return self._x


def dynamics_functions(system: System, scene: str | None = None, *, frames=(),
                       params: Mapping[str, float] | None = None) -> DynamicsFunctions:
    """Compile (cached) the model with its dynamics functions and the kinematics of `frames` ("part.frame",
    "part" for its origin); parameters from the scene and `params`."""
    compiled = system.compile(scene, dynamics=True, frames=tuple(frames))
    overrides = pipeline.scene_overrides(system.scene(scene))
    overrides.update(params or {})
    return DynamicsFunctions(compiled, pipeline.parameter_values(system.model, overrides), tuple(frames))


__all__ = ["DynamicsFunctions", "dynamics_functions"]
