"""The whole pipeline as pure functions of the previous stage's output:

    text -> (language) validated Model -> (compiler) Lowered -> Equations -> C / NumPy source
         -> (runtime) CompiledModel -> simulate -> Results

plus what connects them: run-time parameter values (defaults may be expressions of other parameters,
so overriding one re-evaluates the rest) and the initial state (joint init values, scene overrides,
quaternions normalised).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import sympy as sp

from mbs.compiler.ccode import generate_c
from mbs.compiler.constraints import Constraints, derive_constraints
from mbs.compiler.equations import Equations, derive_equations
from mbs.compiler.lower import Lowered, lower
from mbs.compiler.pycode import generate_numpy
from mbs.compiler.symbolic import parameter_symbol
from mbs.language import expr as X
from mbs.language import model as M
from mbs.language import units as U
from mbs.language.diagnostics import Diagnostic, MbsError


@dataclass(frozen=True)
class Generated:
    """The code generator's output and what the runtime needs to know about it."""

    model: M.Model
    scene: M.Scene | None
    lowered: Lowered
    equations: Equations
    c_source: str
    numpy_source: str   # the same functions for machines without a C compiler
    q_names: tuple[str, ...]
    v_names: tuple[str, ...]
    p_names: tuple[str, ...]
    y_names: tuple[str, ...]
    constraints: Constraints | None = None   # loop-closure constraints of the cut joints (None: a tree)


def display_name(symbol_name: str) -> str:
    """'hinge.der(phi)' -> 'der(hinge.phi)', the language's own spelling of a speed."""
    if symbol_name.endswith(")") and ".der(" in symbol_name:
        head, local = symbol_name[:-1].split(".der(")
        return f"der({head}.{local})"
    return symbol_name


def structurally_singular(lowered, text: str) -> Diagnostic:
    """The joint whose articulated-body pivot ('iD<body><coordinate>' in `text`) is zero whatever the parameters:
    nothing it carries has mass or inertia along one of its free directions."""
    import re
    joints = lowered.topology.joints
    digits = (re.search(r"iD(\d+)", text) or re.search(r"(\d+)", text + "0")).group(1)
    for candidate in (digits, digits[:-1]):
        if candidate and 1 <= int(candidate) <= len(joints):
            inter = joints[int(candidate) - 1].interaction
            free = ", ".join(c.name for c in inter.joint.coordinates if c.prescribed is None) or inter.name
            return Diagnostic("error", f"no mass or inertia determines the motion of {free}: nothing joint "
                                       f"'{inter.name}' moves ({joints[int(candidate) - 1].child} and what it "
                                       "carries) has mass or inertia along one of its free directions (a point "
                                       "mass turning about itself?); give it inertia or prescribe the coordinate",
                              inter.joint.span)
    return Diagnostic("error", f"the mass matrix is singular for every parameter value ({text})", lowered.model.span)


def generate(model: M.Model, scene: M.Scene | None = None) -> Generated:
    """Validated model -> generated source (symbolic derivation included)."""
    lowered = lower(model, scene)
    constraints = derive_constraints(lowered.kinematics, lowered.cuts) if lowered.cuts else None
    if constraints is not None and not constraints.nc:  # a free joint closing a "loop" constrains nothing
        constraints = None
    # with loops the articulated-body vdot is not used (and divides by zero for massless parts)
    try:
        equations = derive_equations(lowered.kinematics, forward_dynamics=constraints is None)
    except ZeroDivisionError as exc:  # a pivot of the articulated-body algorithm is zero for every parameter
        raise MbsError([structurally_singular(lowered, str(exc))]) from None
    parameters = [parameter_symbol(p.name) for p in model.parameters]
    used = list(equations.parameters()) + list(constraints.parameters() if constraints is not None else ())
    extra = [s for s in used if s not in set(parameters)]
    if extra:
        raise MbsError([Diagnostic("error", f"internal: symbols without a parameter: {extra}", model.span)])
    outputs = lowered.outputs
    origin = f"{model.span.source.path}" + (f", scene {scene.name}" if scene is not None else "")
    options = dict(outputs=outputs, tables=lowered.tables, origin=origin, run_time_inputs=lowered.run_time_inputs)
    tree = lowered.tree
    # closed loops need the loop solver in C (runtime/c/loops.c): no NumPy module for them
    numpy_source = generate_numpy(equations, parameters, model.name, **options) if constraints is None else ""
    return Generated(model, scene, lowered, equations,
                     generate_c(equations, parameters, model.name, constraints=constraints, **options),
                     numpy_source,
                     tuple(display_name(s.name) for s in tree.q_symbols),
                     tuple(display_name(s.name) for s in tree.v_symbols),
                     tuple(p.name for p in model.parameters), tuple(name for name, _ in outputs), constraints)


# ------------------------------------------------------------------------------------------ parameters
def parameter_values(model: M.Model, overrides: Mapping[str, float | X.E] | None = None) -> dict[str, float]:
    """Every parameter's value: overrides as given, the rest from their default expressions (which may use
    overridden parameters: `l2 = 2 * l` follows a new `l`)."""
    overrides = dict(overrides or {})
    unknown = [name for name in overrides if name not in model.parameter_map]
    if unknown:
        raise MbsError([Diagnostic("error", f"model '{model.name}' has no parameter '{unknown[0]}'", None)])
    values: dict[str, float] = {}

    def value(name: str, depth: int = 0) -> float:
        if name in values:
            return values[name]
        if depth > len(model.parameters):
            raise MbsError([Diagnostic("error", f"parameter '{name}' depends on itself", None)])
        given = overrides.get(name, model.parameter_map[name].default)
        if isinstance(given, (int, float)):
            result = float(given)
        else:
            env = {s.name: value(s.name, depth + 1) for s in X.symbols(given) if s.kind == "param"}
            result = X.evaluate(given, env)
        values[name] = result
        return result

    for p in model.parameters:
        value(p.name)
    return values


def scene_overrides(scene: M.Scene | None) -> dict[str, X.E]:
    return dict(scene.params) if scene is not None else {}


# ------------------------------------------------------------------------------------------ initial state
def initial_state(generated: Generated, params: Mapping[str, float]) -> np.ndarray:
    """x0 = [q0; v0] in state order: joint init values, then the scene's init statements."""
    model, scene, tree = generated.model, generated.scene, generated.lowered.tree
    env = dict(params)
    coords = {c.name: c for c in model.coordinates}
    inits: dict[tuple[str, bool], float] = {}
    for c in coords.values():
        inits[(c.name, False)] = X.evaluate(c.init, env)
        inits[(c.name, True)] = X.evaluate(c.init_speed, env)
    if scene is not None:
        for name, is_speed, value in scene.inits:
            inits[(name, is_speed)] = X.evaluate(value, env)
    q0 = [inits[(s.name, False)] for s in tree.q_symbols]
    v0 = []
    for s in tree.v_symbols:
        name = s.name
        if name.endswith(")") and ".der(" in name:
            head, local = name[:-1].split(".der(")
            v0.append(inits[(f"{head}.{local}", True)])
        else:  # quaternion joint: wx, wy, wz are stored as the speeds of qx, qy, qz
            head, local = name.rsplit(".", 1)
            v0.append(inits[(f"{head}.q{local[1]}", True)])
    return _normalise_quaternions(np.array(q0 + v0, dtype=float), tree)


def fixed_state_names(generated: Generated) -> list[str]:
    """Names (as in the compiled model: "j.phi", "der(j.phi)", "j.wx") of the coordinates and speeds the user
    gave initial values, in the joint or the scene: assembling the loops keeps them. (A joint's init statement
    makes a new expression; the defaults are the shared X.ZERO and X.ONE.)"""
    def speed(name: str) -> str:
        head, local = name.rsplit(".", 1)
        return f"{head}.w{local[1]}" if local in ("qx", "qy", "qz") else f"der({name})"
    names = []
    for c in generated.model.coordinates:
        if c.init is not (X.ONE if c.local == "qw" else X.ZERO):
            names.append(c.name)
        if c.init_speed is not X.ZERO:
            names.append(speed(c.name))
    if generated.scene is not None:
        names += [speed(name) if is_speed else name for name, is_speed, _ in generated.scene.inits]
    return names


def _normalise_quaternions(x: np.ndarray, tree) -> np.ndarray:
    for i, body in enumerate(tree.bodies):
        if body.joint.uses_quaternion:
            slots = [s for s in tree.q_slots[i][-4:]]
            q = x[slots]
            norm = math.sqrt(float(q @ q))
            if norm == 0:
                raise MbsError([Diagnostic("error", f"the initial quaternion of joint '{body.name}' is zero", None)])
            x[slots] = q / norm
    return x


def units_of(generated: Generated) -> dict[str, str]:
    """Unit text of every state and parameter name, for result files and plots."""
    units: dict[str, str] = {}
    for c in generated.model.coordinates:
        units[c.name] = _unit(c.dimension)
        units[f"der({c.name})"] = _unit(c.dimension / U.TIME)
    for p in generated.model.parameters:
        if p.dimension is not None:
            units[p.name] = _unit(p.dimension)
    return units


def _unit(dim: U.Dimension) -> str:
    if dim.is_dimensionless:
        return "rad"
    if dim == U.FREQUENCY:
        return "rad/s"
    if dim == U.FREQUENCY / U.TIME:
        return "rad/s^2"
    return str(dim)


__all__ = ["Generated", "generate", "parameter_values", "initial_state", "display_name", "units_of", "sp"]
