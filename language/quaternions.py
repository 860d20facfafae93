"""The starting quaternion of a spherical or free joint: its length is checked, never fixed silently.

The runtime normalises every starting quaternion (a rotation is a unit quaternion). A length a little off 1
is a rounded input and only earns a note with the norm; a length far from 1 is a mistake (components swapped,
an angle written where a component belongs) and is an error, at check time for values known then and at run
time for values that depend on overridden parameters.
"""

from __future__ import annotations

import math

from . import expr as X
from . import model as M
from .diagnostics import Diagnostics

QUATERNION_COMPONENTS = ("qw", "qx", "qy", "qz")
#: the speed of a quaternion joint that stands where der(qx) would: the angular velocity in frame b
QUATERNION_SPEED_OF = {"qx": "wx", "qy": "wy", "qz": "wz"}
#: |norm - 1| above which a starting quaternion is an error: components rounded by hand, such as
#: (0.7, 0.7, 0, 0) for 90 deg about x (norm 0.99), stay inside; (1, 1, 0, 0) (norm 1.41) does not.
FAR_FROM_UNIT = 0.05
#: |norm - 1| above which the normalisation earns a note (below: round-off of exactly written components)
NOTE_FROM_UNIT = 1e-9


def norm_problem(norm: float, joint: str) -> tuple[str, str] | None:
    """(severity, message) for a starting quaternion of this norm, or None when it is unit."""
    if not math.isfinite(norm) or abs(norm - 1.0) > FAR_FROM_UNIT:
        return "error", (f"the starting quaternion of joint '{joint}' has norm {norm:.6g}, far from 1: a rotation "
                         "is a unit quaternion (qw, qx, qy, qz) = (cos(a/2), sin(a/2) * axis)")
    if abs(norm - 1.0) > NOTE_FROM_UNIT:
        return "note", f"the starting quaternion of joint '{joint}' has norm {norm:.10g}; it is normalised"
    return None


def check_start_quaternions(diags: Diagnostics, model: M.Model, scene_inits=(), scene_spans=None) -> None:
    """Report starting quaternions (joint inits, overridden by a scene's) that are not of unit length.

    Values are evaluated with the parameter defaults; one that cannot be evaluated is left to run time."""
    values = {p.name: p.value for p in model.parameters}
    given = {(name, is_speed): value for name, is_speed, value in scene_inits}
    spans = scene_spans or {}
    for inter in model.interactions:
        joint = inter.joint
        if joint is None or joint.rotation != "quaternion" or joint.kind not in ("spherical", "free"):
            continue
        coords = {c.local: c for c in joint.coordinates}
        names = [coords[k].name for k in QUATERNION_COMPONENTS]
        if scene_inits and not any((n, False) in given for n in names):
            continue  # the model's own check reported this joint already
        try:
            q = [X.evaluate(given.get((n, False), coords[k].init), values)
                 for n, k in zip(names, QUATERNION_COMPONENTS)]
        except X.EvaluationError:
            continue
        problem = norm_problem(math.sqrt(sum(c * c for c in q)), inter.name)
        if problem is None:
            continue
        span = next((spans[(n, False)] for n in reversed(names) if (n, False) in spans), None)
        severity, message = problem
        (diags.error if severity == "error" else diags.note)(message, span or coords["qw"].span)


__all__ = ["QUATERNION_COMPONENTS", "QUATERNION_SPEED_OF", "FAR_FROM_UNIT", "norm_problem",
           "check_start_quaternions"]
