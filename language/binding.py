"""Binding parameter values: every parameter's number, and whether the bodies are still physical with them.

`mbs check` checks masses and inertias with the parameters' defaults. A scene, `--param` or a Python call may
bind other values (a negative mass, an inertia that violates the triangle inequality); without a check here
the run fails much later as "singular mass matrix". So every binding checks the bodies again, and a problem
is reported at the body and at the parameter that made it so. A mass bound to zero is accepted: parameter
studies take parts to their massless limit (the mass matrix of the whole may stay regular).
"""

from __future__ import annotations

from typing import Mapping

from . import expr as X
from . import model as M
from .diagnostics import Diagnostic, MbsError, Span
from .rules import body_problems


def parameter_values(model: M.Model, overrides: Mapping[str, float | X.E] | None = None) -> dict[str, float]:
    """Every parameter's value: overrides as given, the rest from their default expressions (which may use
    overridden parameters: `l2 = 2 * l` follows a new `l`)."""
    overrides = dict(overrides or {})
    unknown = [name for name in overrides if name not in model.parameter_map]
    if unknown:
        raise MbsError([Diagnostic("error", f"model '{model.name}' has no parameter '{unknown[0]}'", None)])
    values: dict[str, float] = {}
    defaults_use = _derived(model, "defaults_use", lambda: {
        p.name: _parameters_in(p.default) for p in model.parameters if not isinstance(p.default, (int, float))})

    def value(name: str, depth: int = 0) -> float:
        if name in values:
            return values[name]
        if depth > len(model.parameters):
            raise MbsError([Diagnostic("error", f"parameter '{name}' depends on itself", None)])
        given = overrides.get(name, model.parameter_map[name].default)
        if isinstance(given, (int, float)):
            result = float(given)
        else:
            uses = defaults_use.get(name) if name not in overrides else None
            if uses is None:
                uses = _parameters_in(given)
            env = {used: value(used, depth + 1) for used in uses}
            result = X.evaluate(given, env)
        values[name] = result
        return result

    for p in model.parameters:
        value(p.name)
    return values


def bound_body_problems(model: M.Model, values: Mapping[str, float], overridden: Mapping[str, Span | None],
                        how: str = "bound") -> list[Diagnostic]:
    """Errors for the bodies that the bound values make unphysical, each at the body, with a note at every
    overridden parameter it depends on (at the place that set it when known, else at its declaration).

    overridden: name -> where its value was set (a scene's param statement) or None (--param, Python)."""
    out = []
    defaults = {p.name: p.value for p in model.parameters}
    for part in model.parts:
        if part.body is None or not any(name in overridden for quantity in ("mass", "inertia")
                                        for name in _parameters_of(part, quantity, model)):
            continue  # nothing set here reaches this body: what it has, `mbs check` reported from the defaults
        problems = body_problems(part, values, massless_ok=True)
        if not problems or body_problems(part, defaults, massless_ok=True) == problems:
            continue  # none, or reported by `mbs check` already
        for quantity, message in problems:
            culprits = [name for name in _parameters_of(part, quantity, model) if name in overridden]
            if not culprits:
                continue
            notes = tuple((f"parameter '{name}' is {_shown(values[name], model.parameter_map[name])} here ({how})",
                           overridden[name] or model.parameter_map[name].span) for name in culprits)
            out.append(Diagnostic("error", message, part.body.span, notes))
    return out


def check_bound_values(model: M.Model, values: Mapping[str, float], overridden: Mapping[str, Span | None],
                       how: str = "bound") -> None:
    problems = bound_body_problems(model, values, overridden, how)
    if problems:
        raise MbsError(problems)


def _derived(model: M.Model, key: str, compute):
    """What ``compute()`` derives from the (immutable) model, computed once per model object: kept in its
    __dict__ as its cached_property values are (the model cache's snapshot holds the dataclass fields only).
    Every run binds the parameters again; their expressions' symbols need not be walked again each time."""
    kept = model.__dict__.get("_binding_" + key)
    if kept is None:
        kept = model.__dict__["_binding_" + key] = compute()
    return kept


def _parameters_in(expression: X.E) -> tuple[str, ...]:
    """The parameters an expression reads, in the order X.symbols finds them."""
    return tuple(s.name for s in X.symbols(expression) if s.kind == "param")


def _parameters_of(part: M.Part, quantity: str, model: M.Model) -> tuple[str, ...]:
    """The parameters the part's body's mass or inertia depends on, directly or through other parameters'
    defaults (an inertia given 'about' a frame depends on the mass and the centre of mass too); computed once per
    part, kept by its name (the table travels with a pickled model, whose objects are new ones)."""
    kept = _derived(model, "body_parameters", dict)
    key = (part.name, quantity)
    if key not in kept:
        kept[key] = tuple(_walk_parameters_of(part.body, quantity, model))
    return kept[key]


def _walk_parameters_of(body: M.Body, quantity: str, model: M.Model) -> list[str]:
    found: list[str] = []
    todo = [body.mass] if quantity == "mass" else [c for row in body.inertia for c in row]
    while todo:
        for sym in X.symbols(todo.pop()):
            if sym.kind == "param" and sym.name not in found:
                found.append(sym.name)
                todo.append(model.parameter_map[sym.name].default)
    return sorted(found)


def _shown(value: float, parameter: M.Parameter) -> str:
    dim = parameter.dimension
    if dim is None or dim.is_dimensionless:
        return f"{value:g}"
    return f"{value:g} {dim}"


__all__ = ["parameter_values", "bound_body_problems", "check_bound_values"]
