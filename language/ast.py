"""Abstract syntax of .mbs files: frozen dataclasses, each carrying the span of text it came from.

The AST is what the user wrote, nothing resolved: names are strings, units are unparsed unit text, numbers
are as written. The validator (validate.py) turns it into the data model (model.py). Keeping the two apart
lets ``mbs fmt`` print exactly the user's structure back and lets tests parse fragments.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from .diagnostics import Span


@dataclass(frozen=True)
class Ident:
    text: str
    span: Span


@dataclass(frozen=True)
class IndexedIdent(Ident):
    """A name with an index, ``link[i]`` or ``j[i - 1]``: ``text`` as written (blanks dropped), ``base`` the
    name before the bracket. The repetition pass (repeat.py) replaces it by the Ident ``link[3]``."""

    base: str = ""
    index: "Expr | None" = None


@dataclass(frozen=True)
class Ref:
    """A dotted name such as ``bob.pivot`` or ``fl.leaf.phi``."""

    parts: tuple[Ident, ...]
    span: Span

    @property
    def dotted(self) -> str:
        return ".".join(p.text for p in self.parts)


# ------------------------------------------------------------------------------------------ expressions
@dataclass(frozen=True)
class Number:
    text: str
    unit: str | None
    span: Span
    unit_span: Span | None = None


@dataclass(frozen=True)
class Name:
    ref: Ref
    span: Span


@dataclass(frozen=True)
class String:
    value: str
    span: Span


@dataclass(frozen=True)
class Call:
    func: Ref
    args: tuple["Expr", ...]
    kwargs: tuple["Kwarg", ...]
    span: Span


@dataclass(frozen=True)
class Kwarg:
    name: Ident
    value: "Expr"
    span: Span


@dataclass(frozen=True)
class Vector:
    items: tuple["Expr", ...]
    span: Span


@dataclass(frozen=True)
class Matrix:
    """``[a, b, ...]``: a list, a matrix row list, or a lookup table."""

    items: tuple["Expr", ...]
    span: Span


@dataclass(frozen=True)
class WithUnit:
    """A parenthesised expression, vector, matrix or call followed by a unit: ``(0, 0, -9.81) m/s^2``."""

    expr: "Expr"
    unit: str
    span: Span
    unit_span: Span


@dataclass(frozen=True)
class Unary:
    op: str  # '-', '+', 'not'
    operand: "Expr"
    span: Span


@dataclass(frozen=True)
class Binary:
    op: str  # + - * / ^ and or == != < <= > >=
    left: "Expr"
    right: "Expr"
    span: Span


Expr = Union[Number, Name, String, Call, Vector, Matrix, WithUnit, Unary, Binary]


# ------------------------------------------------------------------------------------------ declarations
@dataclass(frozen=True)
class Import:
    path: Ref
    alias: Ident | None
    span: Span


@dataclass(frozen=True)
class Param:
    """``param name = value`` or ``mode name = value`` (kind "mode": a discrete value events may switch)."""

    name: Ident
    value: Expr
    description: str | None
    span: Span
    kind: str = "param"


@dataclass(frozen=True)
class Input:
    """A time function the block receives (steering, road); a scene may replace its expression."""

    name: Ident
    value: Expr
    description: str | None
    span: Span


@dataclass(frozen=True)
class Output:
    """An output of the block: ``output name = expr`` or the shorthand ``output hinge.phi``."""

    name: Ref
    value: Expr | None
    description: str | None
    span: Span


@dataclass(frozen=True)
class Func:
    """A pure expression macro, ``func leaf(L) = ...``; inlined at validation, never executed as code."""

    name: Ident
    params: tuple[Ident, ...]
    body: Expr
    description: str | None
    span: Span


@dataclass(frozen=True)
class Setting:
    """``name = value [in frame] [about frame]``: body properties, model settings (gravity), scene settings.
    ``in``: the components are in that frame's axes; ``about``: an inertia is taken about that frame's origin."""

    name: Ident
    value: Expr
    frame: Ref | None
    span: Span
    about: Ref | None = None


@dataclass(frozen=True)
class Frame:
    name: Ident
    at: Expr | None
    rotate: Expr | None
    description: str | None
    span: Span


@dataclass(frozen=True)
class Body:
    settings: tuple[Setting, ...]
    span: Span


@dataclass(frozen=True)
class Part:
    """``part`` (massless, frames only) or ``rigid`` (with a body)."""

    name: Ident
    rigid: bool
    body: Body | None
    frames: tuple[Frame, ...]
    description: str | None
    span: Span


@dataclass(frozen=True)
class Port:
    """A component's attachment point: frames on a part the instantiating model provides."""

    name: Ident
    frames: tuple[Frame, ...]
    description: str | None
    span: Span


@dataclass(frozen=True)
class Connect:
    a: Ref
    b: Ref
    span: Span


@dataclass(frozen=True)
class Init:
    target: Ref
    derivative: bool
    value: Expr
    span: Span


@dataclass(frozen=True)
class Prescribe:
    target: Ref
    value: Expr
    span: Span


@dataclass(frozen=True)
class Joint:
    kind: Ident
    args: tuple[Expr | Kwarg, ...]
    statements: tuple[Init | Prescribe, ...]
    has_block: bool
    span: Span


@dataclass(frozen=True)
class Force:
    name: Ident | None
    kind: Ident
    args: tuple[Expr | Kwarg, ...]
    span: Span


@dataclass(frozen=True)
class Sensor:
    name: Ident
    kind: Ident
    args: tuple[Expr | Kwarg, ...]
    span: Span


@dataclass(frozen=True)
class Interact:
    name: Ident
    description: str | None
    members: tuple[Connect | Joint | Force | Sensor, ...]
    span: Span


@dataclass(frozen=True)
class Binding:
    port: Ident
    target: Ref
    span: Span


@dataclass(frozen=True)
class Use:
    """Instantiate a component: ``use lib.susp as fl(k = 3 N/m, mirror = xz) { chassis = car.origin }``."""

    component: Ref
    alias: Ident
    args: tuple[Expr | Kwarg, ...]
    bindings: tuple[Binding, ...]
    span: Span


@dataclass(frozen=True)
class For:
    """``for i in range(1, 5) { ... }``: the statements once per value of ``var`` (repeat.py unrolls it before
    validation, so later stages see plain statements named ``link[1]``, ``link[2]`` ...)."""

    var: Ident
    values: "Expr"
    statements: tuple["ModelStatement", ...]
    span: Span


@dataclass(frozen=True)
class Reinit:
    """``reinit der(j.x) = value`` inside an event (``derivative`` False: a position, which is refused)."""

    target: Ref
    derivative: bool
    value: Expr
    span: Span


@dataclass(frozen=True)
class Set:
    """``set name = value`` inside an event: a mode or a parameter takes a new value."""

    target: Ref
    value: Expr
    span: Span


@dataclass(frozen=True)
class Terminate:
    span: Span


@dataclass(frozen=True)
class Event:
    """``event name when condition { actions }``: a zero crossing and what happens at it."""

    name: Ident
    condition: Expr
    description: str | None
    actions: tuple[Reinit | Set | Terminate, ...]
    span: Span


@dataclass(frozen=True)
class State:
    """``state name = initial value``: an extra differential state (states.py)."""

    name: Ident
    value: Expr
    description: str | None
    span: Span


@dataclass(frozen=True)
class Rate:
    """``der(name) = value``: the differential equation of a declared state."""

    target: Ref
    value: Expr
    description: str | None
    span: Span


ModelStatement = Union[Import, Param, Input, Output, Func, Setting, Part, Port, Interact, Use, For, Event, State,
                       Rate]


@dataclass(frozen=True)
class Model:
    """``model`` (a complete system with the inertial part) or ``component`` (a reusable group)."""

    kind: str  # 'model' | 'component'
    name: Ident
    description: str | None
    statements: tuple[ModelStatement, ...]
    span: Span


@dataclass(frozen=True)
class Scene:
    name: Ident
    description: str | None
    statements: tuple[Setting | Param | Input | Output | Init | Import, ...]
    span: Span


@dataclass(frozen=True)
class File:
    path: str
    items: tuple[Import | Param | Input | Output | Func | Model | Scene, ...]
    span: Span
