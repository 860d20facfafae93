"""Extra differential states of a model: ``state z = value`` and ``der(z) = expr`` -> validated
:class:`~mbs.language.model.State`.

A model's motion is second order in its joint coordinates; what is not a rigid body but still has a memory
(an actuator that lags its command, a controller's integrator, a hydraulic damper's pressure, the bristle
deflection of LuGre friction) is a first-order equation beside it, as Modelica writes it::

    state y = 0 m "actuator position"     # the initial value fixes the unit (a plain number: no unit)
    der(y) = (command - y) / T            # must be m/s: the state's unit per second

The initial value is an expression of parameters; the equation may use the state itself, other states,
coordinates, speeds, sensors, inputs and time.  Forces, outputs and event conditions use the state by name and
its rate as ``der(y)``; an event may ``reinit y = value``.  States of component instances are prefixed like
their outputs (``fl.lag.y``).  Every state needs exactly one equation.
"""

from __future__ import annotations

from . import ast
from . import expr as X
from . import model as M
from . import units as U
from .expressions import ExprResolver, Invalid, state_value
from .scope import InstanceEntry, Scope, StateEntry


def build_states(elab, scope: Scope) -> list[M.State]:
    """The states of a model and of every component instance in it (in declaration order), each with its one
    equation; reports states without an equation, second equations and equations of what is not a state."""
    rates: dict[str, tuple[X.E, ast.Rate, Scope]] = {}
    declared: list[StateEntry] = []
    _collect(elab, scope, rates, declared)
    out = []
    for entry in declared:
        init, dim = state_value(elab, entry)
        found = rates.get(entry.full)
        if found is None:
            local = entry.decl.name.text
            elab.diags.error(f"state '{entry.full}' has no equation: add 'der({local}) = ...' beside it",
                             entry.scope.at(entry.decl.name.span))
            continue
        if init is not None:
            out.append(M.State(entry.full, init, dim, found[0], entry.decl.description,
                               entry.scope.at(entry.decl.span)))
    return out


def _collect(elab, scope: Scope, rates: dict, declared: list) -> None:
    for st in scope.block.statements:
        if isinstance(st, ast.State):
            entry = scope.entries.get(st.name.text)
            if isinstance(entry, StateEntry) and entry.decl is st:
                declared.append(entry)
        elif isinstance(st, ast.Rate):
            _rate(elab, scope, st, rates)
        elif isinstance(st, ast.Use):
            inst = scope.entries.get(st.alias.text)
            if isinstance(inst, InstanceEntry) and inst.decl is st:
                _collect(elab, inst.scope, rates, declared)


def _rate(elab, scope: Scope, st: ast.Rate, rates: dict) -> None:
    r = ExprResolver(elab, scope, what=f"the equation of der({st.target.dotted})")
    try:
        target, dim = r.scalar(ast.Name(st.target, st.target.span))
    except Invalid:
        return
    if not (isinstance(target, X.Sym) and target.kind == "state"):
        what = "a joint coordinate: its motion follows from the forces" if isinstance(target, X.Sym) \
            and target.kind == "coord" else "not a declared state"
        elab.diags.error(f"'{st.target.dotted}' is {what}; only a 'state' takes an equation "
                         f"(declare it: state {st.target.parts[-1].text} = initial value)",
                         scope.at(st.target.span))
        return
    if target.name in rates:
        elab.diags.error(f"state '{target.name}' has a second equation", scope.at(st.span),
                         ("first equation here", rates[target.name][2].at(rates[target.name][1].span)))
        return
    try:
        value, vdim = r.scalar(st.value)
    except Invalid:
        rates[target.name] = (X.ZERO, st, scope)  # reported; keeps 'has no equation' quiet
        return
    if _uses_rate(value):
        elab.diags.error(f"the equation of der({st.target.dotted}) cannot use der() of a state: write that "
                         "state's right-hand side instead", scope.at(st.value.span))
    if dim is not None and vdim is not None and vdim != dim / U.TIME:  # a bare number (None) takes any unit
        unit = U.unit_text(dim)
        elab.diags.error(f"der({st.target.dotted}) must be in {unit}/s (state '{target.name}' is in {unit}), but "
                         f"this is {U.describe(vdim)}", scope.at(st.value.span))
    rates[target.name] = (value, st, scope)


def _uses_rate(e: X.E) -> bool:
    if isinstance(e, X.Sym):
        return e.kind == "rate"
    return any(_uses_rate(a) for a in getattr(e, "args", ()))
