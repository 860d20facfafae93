"""A run-time warning for spherical and free joints in Cardan angles that come near their gimbal singularity.

Cardan angles x-y-z (alpha, beta, gamma) describe every rotation, but at beta = +-90 deg the axes of alpha and
gamma coincide: the kinematic map from the angular velocity to the angle rates divides by cos(beta), the rates
grow without bound, and the integrator crawls or fails. The quaternion form has no such point. A run that comes
within GIMBAL_MARGIN of it is told so, with the joint and the first time, and pointed at `rotation = quaternion`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from mbs.language import model as M

#: how close to beta = +-90 deg a sample must come to be reported [rad]: the angle rates are then more than
#: 1 / sin(10 deg) ~ 6 times the angular velocity, and grow as 1 / (distance to the singularity)
GIMBAL_MARGIN = math.radians(10.0)


class GimbalWarning(RuntimeWarning):
    """A joint in Cardan angles came near its gimbal singularity."""


def cardan_joints(model: M.Model) -> tuple[str, ...]:
    """The names of the interactions whose joint is spherical or free in Cardan angles (those gimbal_warnings
    looks at)."""
    return tuple(inter.name for inter in model.interactions if inter.joint is not None
                 and inter.joint.kind in ("spherical", "free") and inter.joint.rotation == "cardan")


def gimbal_warnings(model: M.Model, results, joints: tuple[str, ...] | None = None) -> list[str]:
    """One message per Cardan joint whose beta came within GIMBAL_MARGIN of +-90 deg in the sampled results;
    joints: cardan_joints(model), when the caller keeps them."""
    messages = []
    for joint_name in cardan_joints(model) if joints is None else joints:
        name = f"{joint_name}.beta"
        if name not in results:
            continue
        beta = np.asarray(results[name])
        distance = np.abs(np.cos(beta))  # = sin(angular distance to the singularity)
        near = np.nonzero(distance < math.sin(GIMBAL_MARGIN))[0]
        if near.size == 0:
            continue
        k = int(near[0])
        closest = math.degrees(math.asin(min(1.0, float(distance.min()))))  # over the whole run
        messages.append(f"joint '{joint_name}' (rotation = cardan) comes within {closest:.3g} deg of its gimbal "
                        f"singularity (beta = +-90 deg), first at t = {float(results.t[k]):.6g} s: the angle rates "
                        "grow without bound there; use rotation = quaternion for this motion")
    return messages


def warn_gimbal(model: M.Model, results, joints: tuple[str, ...] | None = None) -> None:
    """Add the messages to results.metadata["warnings"] and issue them as GimbalWarning (joints: as for
    gimbal_warnings)."""
    for text in gimbal_warnings(model, results, joints):
        results.metadata.setdefault("warnings", []).append(text)
        warnings.warn(text, GimbalWarning, stacklevel=3)


__all__ = ["GIMBAL_MARGIN", "GimbalWarning", "cardan_joints", "gimbal_warnings", "warn_gimbal"]
