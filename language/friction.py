"""Dry friction elements of a model: ``force f = coulomb(mu_k = .., mu_s = .., normal = .., ...)`` -> checked, and one
discrete ``mode`` per element that the compiler's stick/slip events switch (compiler/friction.py).

The element sits in an interaction whose joint has one free coordinate, prismatic or revolute, and acts on it as a
generalized force; or, with ``tangent = axis`` (``surface_normal = axis``: sliding in a plane, two tangential
directions), in an interaction without a joint: a point contact. Its mode is an
ordinary run-time mode named ``<force>.mode``: 0 while the joint sticks, +1 or -1 while it slips (the sign of the
slip speed); the event log shows its changes, and ``--param inter.friction.mode=1`` starts a run sliding. A
tanh-smoothed element (``smoothing = ..``) has no mode: it is one expression of the slip speed. A plane contact's
mode is 0 (sticks) or 1 (slips), and it has two more run-time values ``<force>.e1``, ``<force>.e2``: the slip
direction its stick event watches (compiler/friction_plane.py).
"""

from __future__ import annotations

from dataclasses import replace

from . import expr as X
from . import model as M
from . import units as U

#: Joints a friction element can act in (one free coordinate each).
FRICTION_JOINTS = ("prismatic", "revolute")
#: Suffix of an element's mode parameter (the runtime finds the element's events by it: runtime/friction.py).
MODE_SUFFIX = ".mode"


def mode_name(force_name: str) -> str:
    return force_name + MODE_SUFFIX


def direction_names(force_name: str) -> tuple[str, str]:
    """The parameters holding a plane contact's slip direction (its components along the two tangents)."""
    return force_name + ".e1", force_name + ".e2"


def is_contact(force: M.Force) -> bool:
    """A point contact (no joint): along one tangent, or in a plane (two tangential directions)."""
    return force.arg("tangent") is not None or force.arg("surface_normal") is not None


def is_switched(force: M.Force) -> bool:
    """An exact stick/slip element (as opposed to the smoothed tanh law)."""
    return force.kind == "coulomb" and force.arg("smoothing") is None


def uses_reaction(force: M.Force) -> bool:
    return any(s == X.Sym("local", "reaction") for s in X.symbols(force.arg("normal")))


def check_friction(model: M.Model, diags) -> M.Model:
    """The model with a mode per switched friction element; errors for elements the compiler cannot lower."""
    modes = []
    for inter in model.interactions:
        for force in inter.forces:
            if force.kind != "coulomb":
                continue
            joint = inter.joint
            if is_contact(force):
                if joint is not None or force.arg("radius") is not None or uses_reaction(force):
                    diags.error("a point contact (tangent = .. or surface_normal = ..) is an interaction without a "
                                "joint, and its normal force is given (no radius, no reaction)", force.span)
                    continue
                if force.arg("tangent") is not None and force.arg("surface_normal") is not None:
                    diags.error("a point contact slides along one 'tangent' or in the plane of a 'surface_normal', "
                                "not both", force.span)
                    continue
            elif joint is None or joint.kind not in FRICTION_JOINTS:
                diags.error(f"a coulomb friction element acts in a prismatic or revolute joint (or at a point contact: "
                            f"tangent = ..); interaction "
                            f"'{inter.name}' has {'no joint' if joint is None else 'a ' + joint.kind + ' joint'}",
                            force.span)
                continue
            elif joint.coordinates[0].prescribed is not None:
                diags.error(f"the motion of '{joint.coordinates[0].name}' is prescribed: friction in its joint "
                            "cannot change it (put the friction in the joint that slides)", force.span)
                continue
            elif joint.kind == "revolute" and force.arg("radius") is None:
                diags.error("friction in a revolute joint needs its radius: the torque is mu * normal * radius",
                            force.span)
                continue
            elif joint.kind == "prismatic" and force.arg("radius") is not None:
                diags.error("'radius' belongs to friction in a revolute joint; a prismatic joint's friction force "
                            "is mu * normal", force.span)
                continue
            if is_switched(force) and force.arg("surface_normal") is not None:
                modes.append(M.Parameter(mode_name(force.name), X.const(0.0), 0.0, U.DIMENSIONLESS,
                                         "friction state: 0 sticks, 1 slips", force.span, kind="mode"))
                modes += [M.Parameter(name, X.const(0.0), 0.0, U.DIMENSIONLESS, "slip direction at the last slip "
                                      "onset (tangential component)", force.span, kind="mode")
                          for name in direction_names(force.name)]
            elif is_switched(force):
                modes.append(M.Parameter(mode_name(force.name), X.const(0.0), 0.0, U.DIMENSIONLESS,
                                         "friction state: 0 sticks, +1/-1 slips (sign of the slip speed)",
                                         force.span, kind="mode"))
    if not modes:
        return model
    return replace(model, parameters=model.parameters + tuple(modes))


__all__ = ["FRICTION_JOINTS", "MODE_SUFFIX", "check_friction", "direction_names", "is_contact", "is_switched",
           "mode_name", "uses_reaction"]
