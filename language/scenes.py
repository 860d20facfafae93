"""Scenes: named runs of a model, written in the same language and checked against that model.

A scene names only what it needs (outputs, overrides, settings); everything it leaves out takes the
defaults in catalog.SCENE_DEFAULTS, and later stages generate code only for the outputs it asks for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import ast, binding, catalog
from . import expr as X
from . import model as M
from . import units as U
from .diagnostics import MbsError
from .expressions import ExprResolver, Invalid
from .quaternions import QUATERNION_SPEED_OF, check_start_quaternions
from .scope import InputEntry, Scope, did_you_mean

if TYPE_CHECKING:
    from .context import ElaborationContext

START_CHOICES = ("initial", "equilibrium")


def build_scene(elab: "ElaborationContext", root: Scope, model: M.Model, st: ast.Scene) -> M.Scene | None:
    diags = elab.diags
    settings = dict(catalog.SCENE_DEFAULTS)
    sample = None
    params, inputs, inits, outputs = [], [], [], []
    init_spans, param_spans = {}, {}
    coords = {c.name: c for c in model.coordinates}
    coords.update({z.name: z for z in model.states})  # `init z = value` sets an extra state's initial value
    speeds = speed_table(model)
    param_names = model.parameter_map
    ok = True
    for s in st.statements:
        try:
            if isinstance(s, ast.Setting):
                name = s.name.text
                if name not in catalog.SCENE_SETTINGS:
                    diags.error(f"unknown scene setting '{name}'{did_you_mean(name, catalog.SCENE_SETTINGS)}",
                                s.name.span)
                    ok = False
                    continue
                kind = catalog.SCENE_SETTINGS[name]
                if name == "model":
                    continue  # resolved by the caller
                if kind == "word":
                    word = _word(s.value)
                    choices = START_CHOICES if name == "start" else catalog.INTEGRATORS
                    if word not in choices:
                        diags.error(f"'{name}' must be one of {', '.join(choices)}{did_you_mean(str(word), choices)}",
                                    s.value.span)
                        ok = False
                        continue
                    settings[name] = word
                    continue
                r = ExprResolver(elab, root, allow_state=False, what=f"'{name}'")
                value, dim = r.scalar(s.value)
                r.expect(dim, kind, s.value.span, f"'{name}'")
                number = elab.constant(value, root, s.value.span)
                if not number > 0:
                    diags.error(f"'{name}' must be positive", s.value.span)
                    ok = False
                    continue
                if name == "sample":
                    sample = number
                else:
                    settings[name] = number
            elif isinstance(s, ast.Param):
                if s.name.text not in param_names:
                    diags.error(f"the model has no parameter '{s.name.text}'{did_you_mean(s.name.text, param_names)}",
                                s.name.span)
                    ok = False
                    continue
                r = ExprResolver(elab, root, allow_state=False, what="a parameter")
                value, dim = r.scalar(s.value)
                r.expect(dim, param_names[s.name.text].dimension, s.value.span, f"parameter '{s.name.text}'")
                params.append((s.name.text, value))
                param_spans[s.name.text] = s.span
            elif isinstance(s, ast.Input):
                known = {i.name: i for i in model.inputs}
                if s.name.text not in known:
                    diags.error(f"the model has no input '{s.name.text}'{did_you_mean(s.name.text, known)}", s.name.span)
                    ok = False
                    continue
                r = ExprResolver(elab, root, what="an input")
                value, dim = r.scalar(s.value)
                bad = [sym for sym in X.symbols(value) if sym.kind in ("coord", "speed", "sensor")]
                if bad:
                    diags.error("an input is a function of time and parameters only", s.value.span)
                    ok = False
                    continue
                r.expect(dim, known[s.name.text].dimension, s.value.span, f"input '{s.name.text}'")
                inputs.append((s.name.text, value))
            elif isinstance(s, ast.Init):
                target = _init_target(diags, s, coords, speeds)
                if target is None:
                    ok = False
                    continue
                name, is_speed, dim = target
                r = ExprResolver(elab, root, allow_state=False, what="an initial value")
                value, got = r.scalar(s.value)
                r.expect(got, dim, s.value.span, f"the initial value of '{_written(s)}'")
                inits.append((name, is_speed, value))
                init_spans[(name, is_speed)] = s.span
            elif isinstance(s, ast.Output):
                built = elab.output(root, s)
                if built is None:
                    ok = False
                else:
                    outputs.extend(built)
            elif isinstance(s, ast.Import):
                diags.error("imports belong at the top of the file, not in a scene", s.span)
        except Invalid:
            ok = False
    if not ok:
        return None
    check_start_quaternions(diags, model, inits, init_spans)
    if params:
        _check_bound_bodies(diags, model, params, param_spans)
    return M.Scene(st.name.text, model.name, tuple(params), tuple(inputs), tuple(inits), tuple(outputs),
                   settings["t_end"], sample, settings["integrator"], settings["rtol"], settings["atol"],
                   settings["start"], st.description, st.span)


def speed_table(model: M.Model) -> dict[str, tuple[str, U.Dimension]]:
    """Every speed by the name a scene writes it, -> (coordinate it belongs to, dimension): `der(j.phi)` for
    ordinary coordinates, `j.wx` (angular velocity in frame b) for quaternion joints."""
    table = {}
    for c in model.coordinates:
        if c.local == "qw":
            continue
        if c.local in QUATERNION_SPEED_OF:
            head = c.name[: -len(c.local)]
            table[head + QUATERNION_SPEED_OF[c.local]] = (c.name, U.ANGULAR_VELOCITY)
        else:
            table[f"der({c.name})"] = (c.name, c.dimension / U.TIME)
    return table


def _init_target(diags, s: ast.Init, coords, speeds):
    """(coordinate name, is_speed, dimension) an init statement sets, or None after reporting why not."""
    name = s.target.dotted
    written = _written(s)
    if written in speeds:
        coordinate, dim = speeds[written]
        return coordinate, True, dim
    if not s.derivative and name in coords:
        return name, False, coords[name].dimension
    local = name.rsplit(".", 1)[-1]
    if s.derivative and name in coords and local in ("qw", *QUATERNION_SPEED_OF):
        head = name[: -len(local)]
        diags.error(f"der({name}) is not a speed of a quaternion joint: the derivative of a quaternion component "
                    f"is not an angular velocity; set the angular velocity in frame b: "
                    f"{head}wx, {head}wy, {head}wz", s.target.span)
        return None
    if s.derivative and name in speeds:
        diags.error(f"'{name}' is a speed already: init {name} = ...", s.target.span)
        return None
    what = "speed" if s.derivative else "joint coordinate or speed"
    candidates = list(speeds) if s.derivative else [*coords, *speeds]
    diags.error(f"the model has no {what} '{written}'{did_you_mean(written, candidates)}", s.target.span)
    return None


def _check_bound_bodies(diags, model: M.Model, params, spans) -> None:
    """Masses and inertias with the scene's parameter values (mbs check checked them with the defaults)."""
    try:
        values = binding.parameter_values(model, dict(params))
    except (MbsError, X.EvaluationError):
        return  # a parameter that cannot be evaluated is reported where it is used
    diags.extend(binding.bound_body_problems(model, values, spans, how="set by this scene"))


def _written(s: ast.Init) -> str:
    return f"der({s.target.dotted})" if s.derivative else s.target.dotted


def _word(node) -> str | None:
    if isinstance(node, ast.Name):
        return node.ref.dotted
    if isinstance(node, ast.String):
        return node.value
    return None


def scene_model_name(st: ast.Scene) -> tuple[str | None, object]:
    for s in st.statements:
        if isinstance(s, ast.Setting) and s.name.text == "model":
            return _word(s.value), s.value
    return None, st.name


__all__ = ["build_scene", "scene_model_name", "speed_table", "InputEntry"]
