"""Events in the equations: the model's own events, and the switches hidden inside its expressions.

**Switches.** A comparison inside ``if(...)``, the kinks of ``min``, ``max``, ``abs``, ``sign`` and the breakpoints
of a linear ``lookup`` table make the right-hand side discontinuous (or its slope).  An integrator that steps
across such a point sees a function that is not smooth within the step and shrinks the step until it collapses
(a stiff PD motor with a stepped set
point: "step size collapsed to 5e-16 s").  As Modelica does, each comparison whose operands depend on the
motion or on time becomes a *switch*: a run-time value ``switch.k`` (a slot of the parameter vector) that holds
the branch while the integrator steps, and an event indicator ``g_k`` whose located zero crossing flips it.
The flag ``switch.frozen`` (0 outside a simulation: equilibrium, linearisation and direct calls evaluate the
comparison itself) tells the generated code which of the two to use::

    cond_k = (frozen != 0 && switch_k != 0) || (frozen == 0 && g_k > 0)

**Events.** Indicators of the model's events come first in ``mbs_events``, the switches' after them; the values
the actions assign come out of ``mbs_event_actions``, evaluated before the event (the runtime applies them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from mbs.language import model as M

#: Linear tables with more breakpoints than this are evaluated as written (not one switch per breakpoint).
MAX_TABLE_SWITCHES = 32
#: The run-time flag: 1 while a simulation holds the switches' branches, 0 elsewhere.
FROZEN = sp.Symbol("switch.frozen")
_RELATIONS = {"<": sp.Lt, "<=": sp.Le, ">": sp.Gt, ">=": sp.Ge}


@dataclass(frozen=True)
class Switch:
    """Branch flag ``symbol`` is 1 while ``indicator`` > 0 (>= 0 when ``inclusive``)."""

    symbol: sp.Symbol
    indicator: sp.Expr
    inclusive: bool
    origin: str  # what the switch came from, for the event log ("max", "<", ...)


@dataclass
class SwitchRegistry:
    """The switches met while converting expressions; ``parameters`` are the names that are not motion."""

    parameters: frozenset[str]
    switches: list[Switch] = field(default_factory=list)
    context: str = ""  # the element being converted ("fl.tyre"), named in the switch's log entries

    def depends_on_motion(self, *exprs) -> bool:
        return any(s.name not in self.parameters for e in exprs for s in sp.sympify(e).free_symbols)

    def relation(self, op: str, a, b, origin: str = ""):
        """a op b (op one of < <= > >=) as a switched condition, or as it is when it depends on constants only."""
        if not self.depends_on_motion(a, b):
            return _RELATIONS[op](a, b)
        g = b - a if op in ("<", "<=") else a - b
        inclusive = op in ("<=", ">=")
        flag = self._switch(g, inclusive, origin or op)
        return sp.Or(sp.And(sp.Ne(FROZEN, 0), sp.Ne(flag, 0)), sp.And(sp.Eq(FROZEN, 0), _RELATIONS[op](a, b)))

    def function(self, name: str, args):
        """min, max, abs, sign with their kinks switched; None when they do not depend on the motion."""
        if not self.depends_on_motion(*args):
            return None
        if name == "min":
            a, b = args
            return sp.Piecewise((a, self.relation("<=", a, b, "min")), (b, True))
        if name == "max":
            a, b = args
            return sp.Piecewise((a, self.relation(">=", a, b, "max")), (b, True))
        (x,) = args
        if name == "abs":
            return sp.Piecewise((x, self.relation(">=", x, 0, "abs")), (-x, True))
        if name == "sign":
            return sp.Piecewise((1, self.relation(">", x, 0, "sign")), (-1, self.relation("<", x, 0, "sign")),
                                (0, True))
        return None

    def table(self, table, x):
        """A linear lookup table of the motion with a switch at each breakpoint (its slope jumps there): the
        segment is held between located crossings, each segment's straight line extended up to its switch; None
        for a smooth table (its slope is continuous), a table of parameters, or one of more than
        MAX_TABLE_SWITCHES breakpoints (evaluated as written: one indicator per breakpoint costs every step)."""
        xs, ys = table.xs, table.ys
        if table.method != "linear" or len(xs) > MAX_TABLE_SWITCHES or not self.depends_on_motion(x):
            return None
        pieces = [(sp.Float(ys[-1]), self.relation(">=", x, sp.Float(xs[-1]), "table"))]
        for i in range(len(xs) - 2, -1, -1):
            slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
            line = sp.Float(ys[i]) + sp.Float(slope) * (x - sp.Float(xs[i]))
            pieces.append((line, self.relation(">=", x, sp.Float(xs[i]), "table")))
        return sp.Piecewise(*pieces, (sp.Float(ys[0]), True))

    def _switch(self, g, inclusive: bool, origin: str) -> sp.Symbol:
        g = sp.sympify(g)
        for s in self.switches:  # the same comparison written twice is one switch
            if s.inclusive == inclusive and s.indicator == g:
                return s.symbol
        symbol = sp.Symbol(f"switch.{len(self.switches) + 1}")
        self.switches.append(Switch(symbol, g, inclusive, f"{origin} in {self.context}" if self.context else origin))
        return symbol


@dataclass(frozen=True)
class LoweredEvent:
    """An event ready for code: indicator expression, direction, terminal flag and (kind, target, value)s."""

    name: str
    indicator: sp.Expr
    direction: int
    terminal: bool
    actions: tuple[tuple[str, str, sp.Expr], ...]
    span: object = None


def lower_events(events: tuple[M.Event, ...], convert) -> tuple[LoweredEvent, ...]:
    """The model's events with their expressions converted (``convert``: model expression -> sympy)."""
    return tuple(LoweredEvent(e.name, convert(e.indicator), e.direction, e.terminal,
                              tuple((a.kind, a.target, convert(a.value)) for a in e.actions), e.span)
                 for e in events)


def event_code(lowered_events, switches, state_names: tuple[str, ...], nq: int, p_names: tuple[str, ...]):
    """(indicators, action values, table) for the code generator and the runtime.

    indicators: (name, g) of mbs_events, the model's events then one per switch; action values: (label, value)
    of mbs_event_actions; table: per indicator a dict with name, direction, terminal, assignments
    ((array "x" or "p", index, slot of mbs_event_actions), ...), switch (p index of the branch flag or -1)."""
    indicators, values, table = [], [], []
    for e in lowered_events:
        assignments = []
        for kind, target, value in e.actions:
            if kind == "speed":
                array, index = "x", state_names.index(f"der({target})", nq)
            elif kind == "state":  # an extra differential state (language/states.py), after q and v
                array, index = "x", state_names.index(target, nq)
            else:
                array, index = "p", p_names.index(target)
            assignments.append((array, index, len(values)))
            values.append((f"{e.name}: {target}", value))
        indicators.append((e.name, e.indicator))
        table.append(dict(name=e.name, direction=e.direction, terminal=e.terminal,
                          assignments=tuple(assignments), switch=-1))
    for s in switches:
        indicators.append((s.symbol.name, s.indicator))
        table.append(dict(name=f"{s.symbol.name} ({s.origin})", direction=0, terminal=False, assignments=(),
                          switch=p_names.index(s.symbol.name), inclusive=s.inclusive))
    return tuple(indicators), tuple(values), tuple(table)
