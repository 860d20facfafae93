"""Inputs driven from Python: `system.simulate(..., inputs={"torque": lambda t: ...})` closes a controller
around a model, and `system.linearize` differentiates with respect to the declared inputs (the B and D of a
state-space model).

Why two extra parameters per input. A model's input is an expression of time compiled into the equations.
The driven variant of the model (compiled once, on first use, as its own cached build) reads each input as

    input = if(driven.NAME > 0.5, u.NAME, <the model's or scene's expression>)

so with the parameter driven.NAME = 0 it is the model as written, and with driven.NAME = 1 the input is the
run-time parameter u.NAME: a constant (no Python in the integration, the C integrators run as usual), a
value a Python callable sets before every evaluation (a controller, a table), or the perturbation of a
finite difference. The parameters live in the parameter vector the generated code already reads, so the
generated code and the hot path stay as they are.
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Mapping

import numpy as np

from mbs.language import expr as X
from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError

from mbs.compiler.tyre_relaxation import structural_inputs

from .quantities import parameter_overrides, quantity

DRIVEN, VALUE = "driven.", "u."


def drivable_inputs(model: M.Model) -> tuple[str, ...]:
    """Names of the inputs that can be run-time values: all but the ones that decide the compiled code (a tyre's
    relaxation length, compiler/tyre_relaxation.py)."""
    fixed = structural_inputs(model)
    return tuple(i.name for i in model.inputs if i.name not in fixed)


def with_driven_inputs(model: M.Model) -> M.Model:
    """The model whose every drivable input can be switched to a run-time parameter (module docstring)."""
    driven = set(drivable_inputs(model))
    if not driven:
        return model
    extra = []
    for i in model.inputs:
        if i.name not in driven:
            continue
        extra.append(M.Parameter(DRIVEN + i.name, X.ZERO, 0.0, None, f"1: input {i.name} is u.{i.name}",
                                 i.span, None))
        extra.append(M.Parameter(VALUE + i.name, X.ZERO, 0.0, i.dimension, f"value of input {i.name} when driven",
                                 i.span, _unit(i.dimension)))
    inputs = tuple(dataclasses.replace(i, value=_switch(i.name, i.value)) if i.name in driven else i
                   for i in model.inputs)
    scenes = tuple(dataclasses.replace(s, inputs=tuple((n, _switch(n, e) if n in driven else e) for n, e in s.inputs))
                   for s in model.scenes)
    return dataclasses.replace(model, parameters=model.parameters + tuple(extra), inputs=inputs, scenes=scenes)


def _switch(name: str, value: X.E) -> X.E:
    flag = X.Op(">", (X.Sym("param", DRIVEN + name), X.Const(0.5)))
    return X.Op("if", (flag, X.Sym("param", VALUE + name), value))


def _unit(dim):
    from mbs.language.units import unit_text
    return unit_text(dim)


def input_values(model: M.Model, scene: M.Scene | None, params: Mapping[str, float], t: float) -> dict[str, float]:
    """Every input's value at time t as the model (or scene) defines it: the operating point of a linearisation.
    An input that reads the state (a road under a moving tyre) has no such value and is left out: it stays the
    model's expression, and the state space has no column for it."""
    exprs = {i.name: i.value for i in model.inputs}
    if scene is not None:
        exprs.update(dict(scene.inputs))
    values: dict[str, float] = {}

    def value(name: str, depth: int = 0) -> float:
        if name not in values:
            if depth > len(exprs):
                raise MbsError([Diagnostic("error", f"input '{name}' depends on itself", None)])
            env = dict(params, t=t)
            env.update({s.name: value(s.name, depth + 1) for s in X.symbols(exprs[name]) if s.kind == "input"})
            values[name] = X.evaluate(exprs[name], env)
        return values[name]

    out = {}
    for name in exprs:
        try:
            out[name] = value(name)
        except (X.EvaluationError, KeyError):
            continue
    return out


# ------------------------------------------------------------------------------------------ driving a run
Source = Callable[[float], float]


def input_sources(model: M.Model, inputs: Mapping[str, object]) -> tuple[dict[str, float], dict[str, Source]]:
    """(constant values in SI, {name: u}) from what the caller gave: a number, a quantity ('2 N*m'), a
    callable u(t) or u(t, x) -> value in SI (x: the state, for feedback), or a table (times, values)
    interpolated linearly and held at its ends."""
    declared = {i.name: i for i in model.inputs}
    fixed = structural_inputs(model)
    constants, callables = {}, {}
    for name, given in inputs.items():
        if name not in declared:
            from mbs.language.scope import did_you_mean
            names = ", ".join(declared) or "none"
            raise MbsError([Diagnostic("error", f"model '{model.name}' has no input '{name}'"
                                                f"{did_you_mean(name, declared)} (inputs: {names})", None)])
        if name in fixed:
            raise MbsError([Diagnostic("error", f"input '{name}' is a tyre's relaxation length: its value decides "
                                                "the compiled code (a state per relaxed slip, or none), so it is set "
                                                "in a scene (input NAME = VALUE), not given at run time", None)])
        if isinstance(given, str):
            constants[name] = quantity(given, declared[name].dimension, f"input {name}")
        elif isinstance(given, (int, float, np.number)):
            constants[name] = float(given)
        elif callable(given):
            callables[name] = given
        else:
            callables[name] = _table(name, given)
    return constants, callables


def _table(name: str, given) -> Source:
    try:
        times, values = (np.asarray(a, dtype=float) for a in given)
    except (TypeError, ValueError):
        raise MbsError([Diagnostic("error", f"input {name}: expected a number, a quantity such as '2 N*m', a "
                                            "callable u(t), or a table (times, values)", None)]) from None
    if times.ndim != 1 or times.shape != values.shape or times.size < 1 or np.any(np.diff(times) < 0):
        raise MbsError([Diagnostic("error", f"input {name}: a table needs equally long 1-D times and values, "
                                            "times non-decreasing", None)])
    return lambda t: float(np.interp(t, times, values))


class DrivenFunctions:
    """Model functions that set u.NAME = source(t) (or source(t, x): a state feedback, x = [q; v] in the order
    of model.x_names) in the parameter vector before every call."""

    def __init__(self, data, callables: Mapping[str, Callable]):
        self.data = data
        self.slots = [(data.model.parameter_index(VALUE + name), source, _takes_state(source))
                      for name, source in callables.items()]

    def wrap(self, f):
        p = self.data.p

        def driven(t, x):
            for k, source, feedback in self.slots:
                p[k] = source(t, x) if feedback else source(t)
            return f(t, x)
        return driven


def _takes_state(source: Callable) -> bool:
    """u(t) or u(t, x): by the number of positional parameters it accepts."""
    import inspect
    try:
        params = inspect.signature(source).parameters.values()
    except (TypeError, ValueError):  # a builtin without a signature: u(t)
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def driven_system(system):
    """The system compiled with switchable inputs (cached on the system; the plain model when it has none)."""
    if not drivable_inputs(system.model):
        return system
    key = ("driven-system", None)
    if key not in system._compiled:
        system._compiled[key] = type(system)(with_driven_inputs(system.model), cache_dir=system.cache_dir,
                                             backend=system.backend)
    return system._compiled[key]


def driven_run(system, scene: str | None, inputs: Mapping[str, object], params, integrator):
    """(driven system, parameters with the inputs switched on, how to bind the callables, integrator) of a
    run with inputs from Python. Callables need an integrator that calls Python (scipy's DOP853 by default):
    the C integrators call the generated right-hand side without leaving C."""
    from mbs.runtime.integrators import NativeSolver, get_integrator
    constants, callables = input_sources(system.model, inputs)
    params = dict(params or {})
    for name in inputs:
        params[DRIVEN + name] = 1.0
    for name, value in constants.items():
        params[VALUE + name] = value
    if callables:
        chosen = integrator
        if chosen is None:
            sc = system.scene(scene)
            chosen = sc.integrator if sc is not None else None
        if chosen is None or issubclass(get_integrator(chosen), NativeSolver):
            if integrator is not None:
                raise MbsError([Diagnostic("error", f"integrator '{integrator}' runs in C and cannot call the "
                                                    f"Python inputs {', '.join(callables)}; use DOP853, RK45, "
                                                    "Radau, BDF or LSODA, or give the inputs as constants", None)])
            integrator = "DOP853"

    def drive(data) -> None:
        if callables:
            data.wrap_functions(DrivenFunctions(data, callables).wrap)
    return driven_system(system), params, drive, integrator


# ------------------------------------------------------------------------------------------ linearising
def linearization_system(system, scene: str | None, params, t: float):
    """(driven system, parameters) whose inputs are the run-time parameters u.NAME held at the values the
    model's expressions have at time t: the same operating point, now differentiable by u."""
    from mbs import pipeline
    overrides = pipeline.scene_overrides(system.scene(scene))
    overrides.update(parameter_overrides(system.model, params))
    values = pipeline.parameter_values(system.model, overrides)
    params = dict(params or {})
    driven = set(drivable_inputs(system.model))
    for name, value in input_values(system.model, system.scene(scene), values, t).items():
        if name not in driven:  # a relaxation length: part of the compiled code, not an input of the linear model
            continue
        params[DRIVEN + name] = 1.0
        params[VALUE + name] = value
    return driven_system(system), params


def is_driven(model: M.Model) -> bool:
    """Whether the model is already the variant with switchable inputs."""
    return any(p.name.startswith(DRIVEN) for p in model.parameters)


def state_space_of(system, scene: str | None, compiled, data, lin):
    """The linearisation with B, C, D: inputs are the switched-on u.NAME, outputs the scene's requested
    outputs (coordinates included), else the model's outputs."""
    from mbs.runtime.statespace import state_space
    driven = {n[len(DRIVEN):] for n, v in zip(compiled.p_names, data.p) if n.startswith(DRIVEN) and v > 0.5}
    inputs = {i.name: compiled.parameter_index(VALUE + i.name) for i in system.model.inputs if i.name in driven}
    sc = system.scene(scene)
    wanted = [o.name for o in sc.outputs] if sc is not None and sc.outputs else [o.name for o in system.model.outputs]
    outputs = tuple(dict.fromkeys(wanted + list(compiled.y_names)))
    ss = state_space(compiled, data, lin.t, lin.x, lin.A, inputs, outputs)
    return dataclasses.replace(lin, state_space=ss)
