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

**Continuity.** A switch is *continuous* when every expression that reads its flag takes the same value on both
branches where its indicator is zero: the kinks of ``min``, ``max``, ``abs`` and a linear table's breakpoints by
construction, an ``if(c, a, b)`` when a - b vanishes on the surface g = 0 of each comparison in c (checked here at
compile time, conservatively: see :func:`vanishes_on`).  At such a switch's event nothing jumps (state, outputs,
constraints), so the runtime evaluates the rows at its two sides once (runtime/event_loop.py).  ``sign``, a
comparison used outside an ``if`` and every ``if`` whose branches differ on the surface are not continuous.

**Events.** Indicators of the model's events come first in ``mbs_events``, the switches' after them; the values
the actions assign come out of ``mbs_event_actions``, evaluated before the event (the runtime applies them).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field, replace

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
    continuous: bool = False  # every expression reading the flag is continuous where the indicator is zero
    prescribed: bool = False  # a prescribed motion reads the flag: its speed may step at the event


@dataclass
class SwitchRegistry:
    """The switches met while converting expressions; ``parameters`` are the names that are not motion."""

    parameters: frozenset[str]
    switches: list[Switch] = field(default_factory=list)
    context: str = ""  # the element being converted ("fl.tyre"), named in the switch's log entries
    _open: dict = field(default_factory=dict)  # flag -> comparisons converted and not yet shown continuous
    _jumps: set = field(default_factory=set)  # flags read by an expression that may jump at the switch
    _indicators: dict = field(default_factory=dict)  # flag -> its indicator g
    _prescribed: set = field(default_factory=set)  # flags a prescribed motion reads

    def final(self) -> tuple[Switch, ...]:
        """The switches with their continuity as far as the expressions converted so far tell."""
        return tuple(replace(s, continuous=s.symbol not in self._jumps and self._open.get(s.symbol, 0) <= 0,
                             prescribed=s.symbol in self._prescribed)
                     for s in self.switches)

    def prescribed_motion(self, expr) -> None:
        """Note the flags a prescribed motion reads: where one flips, the motion's position is continuous but its
        speed may step (a ramp that starts), so the switch is not continuous, and on a model with loops the
        run projects the speeds onto the constraints there (runtime/event_loop.py c_restart_tables)."""
        flags = {f for f in sp.sympify(expr).free_symbols if f in self._indicators}
        self._prescribed |= flags
        self._jumps |= flags

    def depends_on_motion(self, *exprs) -> bool:
        return any(s.name not in self.parameters for e in exprs for s in sp.sympify(e).free_symbols)

    def relation(self, op: str, a, b, origin: str = ""):
        """a op b (op one of < <= > >=) as a switched condition, or as it is when it depends on constants only.
        A comparison written in the model: its switch counts as continuous only once an ``if`` (:meth:`branch`)
        shows its use continuous."""
        condition = self._relation(op, a, b, origin)
        for flag in self._flags(condition):
            self._open[flag] = self._open.get(flag, 0) + 1
        return condition

    def branch(self, condition, a, b):
        """if(condition, a, b) as a Piecewise; each switch of the condition whose surface g = 0 the two branches
        agree on is shown continuous for this use (crossing it either leaves the condition as it is or changes
        between a and b), every other one marked as jumping."""
        for flag in self._flags(condition):
            if vanishes_on(a, b, self._indicators[flag]):
                self._open[flag] = self._open.get(flag, 0) - 1
            else:
                self._jumps.add(flag)
        return sp.Piecewise((a, condition), (b, True))

    def _flags(self, condition) -> list:
        """The switches a condition tests itself (its ``Ne(switch.k, 0)``), not those inside the expressions it
        compares (a tyre's deflection over a road that has switches of its own)."""
        found, todo = set(), [condition]
        while todo:
            e = todo.pop()
            if isinstance(e, (sp.And, sp.Or, sp.Not)):
                todo.extend(e.args)
            elif isinstance(e, sp.Ne) and e.args[0] in self._indicators and e.args[1] == 0:
                found.add(e.args[0])
        return sorted(found, key=str)

    def _relation(self, op: str, a, b, origin: str = ""):
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
            return sp.Piecewise((a, self._relation("<=", a, b, "min")), (b, True))
        if name == "max":
            a, b = args
            return sp.Piecewise((a, self._relation(">=", a, b, "max")), (b, True))
        (x,) = args
        if name == "abs":
            return sp.Piecewise((x, self._relation(">=", x, 0, "abs")), (-x, True))
        if name == "sign":
            positive, negative = self._relation(">", x, 0, "sign"), self._relation("<", x, 0, "sign")
            self._jumps.update(self._flags(positive) + self._flags(negative))  # a step: never continuous
            return sp.Piecewise((1, positive), (-1, negative), (0, True))
        return None

    def table(self, table, x):
        """A linear lookup table of the motion with a switch at each breakpoint (its slope jumps there): the
        segment is held between located crossings, each segment's straight line extended up to its switch; None
        for a smooth table (its slope is continuous), a table of parameters, or one of more than
        MAX_TABLE_SWITCHES breakpoints (evaluated as written: one indicator per breakpoint costs every step)."""
        xs, ys = table.xs, table.ys
        if table.method != "linear" or len(xs) > MAX_TABLE_SWITCHES or not self.depends_on_motion(x):
            return None
        pieces = [(sp.Float(ys[-1]), self._relation(">=", x, sp.Float(xs[-1]), "table"))]
        for i in range(len(xs) - 2, -1, -1):
            slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
            line = sp.Float(ys[i]) + sp.Float(slope) * (x - sp.Float(xs[i]))
            pieces.append((line, self._relation(">=", x, sp.Float(xs[i]), "table")))
        return sp.Piecewise(*pieces, (sp.Float(ys[0]), True))

    def _switch(self, g, inclusive: bool, origin: str) -> sp.Symbol:
        g = sp.sympify(g)
        for s in self.switches:  # the same comparison written twice is one switch
            if s.inclusive == inclusive and s.indicator == g:
                return s.symbol
        symbol = sp.Symbol(f"switch.{len(self.switches) + 1}")
        self._indicators[symbol] = g
        self.switches.append(Switch(symbol, g, inclusive, f"{origin} in {self.context}" if self.context else origin))
        return symbol


#: Points on the surface g = 0 at which vanishes_on evaluates the difference of two branches, and the relative
#: size of a difference that still counts as none: published piecewise laws are continuous only to the digits
#: printed (the Iltis damper's polynomial meets its straight lines to 2.5e-7 of the force there).
CONTINUITY_POINTS = 12
CONTINUITY_RTOL = 1e-6
#: Expressions larger than this (operations) are not examined: their switch counts as jumping.
CONTINUITY_MAX_OPS = 400


def vanishes_on(a, b, g) -> bool:
    """Whether a - b is zero wherever ``g`` is, conservatively: False unless it can tell.  g is solved for a symbol
    it is linear in (t, a coordinate, a parameter); a - b there is then zero as it stands, or at CONTINUITY_POINTS
    seeded random points of the other symbols (of either sign; the switches' flags and the frozen flag 0, so that
    inner comparisons are evaluated as written) to CONTINUITY_RTOL of the branches' size.  A point where a branch
    cannot be evaluated (a root of a negative number, a division by zero) answers False."""
    a, b, g = sp.sympify(a), sp.sympify(b), sp.sympify(g)
    if a - b == 0:
        return True
    if sp.count_ops(a) + sp.count_ops(b) > CONTINUITY_MAX_OPS:
        return False
    for s in sorted(g.free_symbols, key=str):
        slope = sp.diff(g, s)
        if slope == 0 or slope.has(s):
            continue
        root = s - g / slope
        a_on, b_on = a.subs(s, root), b.subs(s, root)
        return a_on - b_on == 0 or _equal_at_points(a_on, b_on)
    return False


def _equal_at_points(a, b) -> bool:
    symbols = sorted(a.free_symbols | b.free_symbols, key=str)
    rng = random.Random(len(symbols))  # seeded: the compiled model must not depend on chance
    for _ in range(CONTINUITY_POINTS):
        values = {s: sp.Float(0.0 if s.name.startswith("switch.") else rng.choice((-1, 1)) * rng.uniform(0.3, 1.7))
                  for s in symbols}
        try:  # xreplace: numbers in, sympy evaluates as it builds (subs and evalf would simplify on the way)
            va, vb = complex(a.xreplace(values)), complex(b.xreplace(values))
        except (TypeError, ValueError, ZeroDivisionError):
            return False
        if not all(math.isfinite(v.real) and math.isfinite(v.imag) and v.imag == 0 for v in (va, vb)):
            return False
        if abs(va - vb) > CONTINUITY_RTOL * max(abs(va), abs(vb)) + 1e-12:
            return False
    return True


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
                          switch=p_names.index(s.symbol.name), inclusive=s.inclusive, continuous=s.continuous,
                          prescribed=s.prescribed))
    return tuple(indicators), tuple(values), tuple(table)

