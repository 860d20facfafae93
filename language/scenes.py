"""Scenes: named runs of a model, written in the same language and checked against that model.

A scene names only what it needs (outputs, overrides, settings); everything it leaves out takes the
defaults in catalog.SCENE_DEFAULTS, and later stages generate code only for the outputs it asks for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import ast, catalog
from . import expr as X
from . import model as M
from . import units as U
from .expressions import ExprResolver, Invalid
from .scope import InputEntry, Scope, did_you_mean

if TYPE_CHECKING:
    from .elaborate import Elaborator

START_CHOICES = ("initial", "equilibrium")


def build_scene(elab: "Elaborator", root: Scope, model: M.Model, st: ast.Scene) -> M.Scene | None:
    diags = elab.diags
    settings = dict(catalog.SCENE_DEFAULTS)
    sample = None
    params, inputs, inits, outputs = [], [], [], []
    coords = {c.name: c for c in model.coordinates}
    speeds = {}
    for inter in model.interactions:
        if inter.joint is not None:
            for c in inter.joint.coordinates:
                speeds[c.name] = c
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
                name = s.target.dotted
                is_speed = s.derivative
                table = speeds if is_speed else coords
                if name not in table:
                    diags.error(f"the model has no joint coordinate '{name}'{did_you_mean(name, table)}", s.target.span)
                    ok = False
                    continue
                coord = table[name]
                r = ExprResolver(elab, root, allow_state=False, what="an initial value")
                value, dim = r.scalar(s.value)
                r.expect(dim, coord.dimension / U.TIME if is_speed else coord.dimension, s.value.span,
                         f"the initial value of '{name}'")
                inits.append((name, is_speed, value))
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
    return M.Scene(st.name.text, model.name, tuple(params), tuple(inputs), tuple(inits), tuple(outputs),
                   settings["t_end"], sample, settings["integrator"], settings["rtol"], settings["atol"],
                   settings["start"], st.description, st.span)


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


__all__ = ["build_scene", "scene_model_name", "InputEntry"]
