"""Events of a model: ``event name when condition { actions }`` -> validated :class:`~mbs.language.model.Event`.

The condition is one scalar zero crossing, as Modelica's ``when`` and SUNDIALS' root functions see it:

    event bounce when drop.z < 0 m          # fires when drop.z - 0 m falls through zero
    event lift when contact.fz > 0 N        # ... rises through zero
    event any when crossing(arm.phi - 1)    # either direction; rising(g) and falling(g) name one

Actions: ``reinit der(j.x) = value`` (a speed jumps: an impact; positions never jump), ``reinit z = value`` (an
extra state, states.py, jumps), ``set name = value`` (a
``mode`` or a ``param`` takes a new value) and ``terminate``.  Action values are evaluated with the state just
before the event.  Events of component instances are prefixed like their outputs (``fl.lift``).
"""

from __future__ import annotations

from . import ast
from . import expr as X
from . import model as M
from . import units as U
from .expressions import ExprResolver, Invalid
from .scope import InstanceEntry, ParamEntry, Scope

#: Condition functions and the direction they select.
DIRECTIONS = {"rising": 1, "falling": -1, "crossing": 0}
#: Comparisons: g = left - right and the direction in which g crosses zero when the comparison becomes true.
COMPARISONS = {"<": -1, "<=": -1, ">": 1, ">=": 1}


def build_events(elab, scope: Scope) -> list[M.Event]:
    """The events of a model and of every component instance in it (in statement order)."""
    out: list[M.Event] = []
    names: set[str] = set()
    for st in scope.block.statements:
        if isinstance(st, ast.Event):
            full = scope.full(st.name.text)
            if full in names:
                elab.diags.error(f"event '{st.name.text}' is already declared", scope.at(st.name.span))
                continue
            names.add(full)
            event = _event(elab, scope, st, full)
            if event is not None:
                out.append(event)
        elif isinstance(st, ast.Use):
            inst = scope.entries.get(st.alias.text)
            if isinstance(inst, InstanceEntry) and inst.decl is st:
                out.extend(build_events(elab, inst.scope))
    return out


def _event(elab, scope: Scope, st: ast.Event, full: str) -> M.Event | None:
    r = ExprResolver(elab, scope, what=f"the condition of event '{st.name.text}'")
    try:
        indicator, direction = _condition(r, st.condition)
    except Invalid:
        return None
    actions: list[M.Action] = []
    terminal = False
    targets: set[str] = set()
    for action in st.actions:
        if isinstance(action, ast.Terminate):
            terminal = True
            continue
        try:
            built = _action(elab, scope, action)
        except Invalid:
            continue
        if built.target in targets:
            elab.diags.error(f"event '{st.name.text}' sets '{built.target}' twice", scope.at(action.span))
        targets.add(built.target)
        actions.append(built)
    return M.Event(full, indicator, direction, tuple(actions), terminal, st.description, scope.at(st.span))


def _condition(r: ExprResolver, node: ast.Expr) -> tuple[X.E, int]:
    """(indicator g, direction) of a condition: a comparison, or rising/falling/crossing(g)."""
    if isinstance(node, ast.Binary) and node.op in COMPARISONS:
        left, ld = r.scalar(node.left)
        right, rd = r.scalar(node.right)
        r.same(ld, rd, node, "compare")
        return X.add(left, X.neg(right)), COMPARISONS[node.op]
    if isinstance(node, ast.Call) and node.func.dotted in DIRECTIONS:
        if len(node.args) != 1 or node.kwargs:
            raise r.error(f"{node.func.dotted}() takes one scalar expression whose zero crossing is the event",
                          node.span)
        return r.scalar(node.args[0])[0], DIRECTIONS[node.func.dotted]
    if isinstance(node, (ast.Vector, ast.Matrix)):
        r.scalar(node)  # reports "expected a single value"
    raise r.error("an event condition is a comparison such as 'drop.z < 0 m', or rising(g), falling(g) or "
                  "crossing(g) of a scalar expression g", node.span)


def _action(elab, scope: Scope, action) -> M.Action:
    r = ExprResolver(elab, scope, what="an event action")
    if isinstance(action, ast.Reinit):
        target = ast.Name(action.target, action.target.span)
        coordinate, dim = r.scalar(target)
        if isinstance(coordinate, X.Sym) and coordinate.kind == "state" and not action.derivative:
            value, vdim = r.scalar(action.value)  # an extra state (states.py) jumps to a new value
            r.expect(vdim, dim, action.value.span, f"the new value of state '{action.target.dotted}'")
            return M.Action("state", coordinate.name, value, scope.at(action.span))
        if not (isinstance(coordinate, X.Sym) and coordinate.kind == "coord"):
            raise r.error(f"'{action.target.dotted}' is not a joint coordinate; reinit takes der(joint.coordinate)",
                          action.target.span)
        if not action.derivative:
            raise r.error(f"a position cannot jump: reinit the speed der({action.target.dotted}) instead "
                          f"(positions stay continuous at an event)", action.span)
        value, vdim = r.scalar(action.value)
        r.expect(vdim, None if dim is None else dim / U.TIME, action.value.span, "the new speed")
        return M.Action("speed", coordinate.name, value, scope.at(action.span))
    entry = scope.lookup(action.target.parts[0].text) if len(action.target.parts) == 1 else None
    if not isinstance(entry, ParamEntry):
        known = sorted(elab.mode_names)
        hint = f" (modes: {', '.join(known)})" if known else " (declare it first: mode name = value)"
        raise r.error(f"'{action.target.dotted}' is not a mode or parameter of this model{hint}", action.target.span)
    entry.used = True
    value, vdim = r.scalar(action.value)
    r.expect(vdim, elab.param_dimension(entry), action.value.span, f"the new value of '{action.target.dotted}'")
    return M.Action("set", entry.full, value, scope.at(action.span))
