"""User hooks: NEWSIM's user routines, declared in the model and supplied when running.

    hook friction_law(v: m/s, n: N) -> (f: N) "Coulomb friction with a viscous part"
    force belt = line_force(friction_law(slip.v, normal))     # the single result
    output f_r = friction_law.f(slip.v, normal)                # a result chosen by name

A declaration says only what crosses the boundary: the arguments and results with their units. The model
file never says *how* a hook is computed (nothing in a model file runs code); the implementation is given
to `mbs simulate --hook NAME=file.c` (or `NAME=module.py:function`) or `System.simulate(hooks={...})`
(runtime/hooks.py). Values cross in the declared units (a hook declared with `v: km/h` receives km/h), so
a routine written for a data sheet's units is used as it is; the call site converts and checks dimensions.

A hook name is global: one implementation per name, even when a component declares it (every instance
then calls the same routine). The expression node is `expr.Hook`; the compiler turns it into a call of a
generated helper (compiler/hooks.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from . import expr as X
from . import units as U
from .diagnostics import Span

if TYPE_CHECKING:  # the syntax tree only in annotations: running a model (runtime/hooks.py) loads no parser
    from . import ast


# ------------------------------------------------------------------------------------------ syntax
@dataclass(frozen=True)
class HookSlot:
    """``v: m/s`` (an argument or a result); ``unit`` None: dimensionless."""

    name: ast.Ident
    unit: str | None
    unit_span: Span | None
    span: Span

    def text(self) -> str:
        return f"{self.name.text}: {self.unit}" if self.unit else self.name.text


@dataclass(frozen=True)
class HookDecl:
    """``hook name(arguments) -> (results) "description"`` (a model or component statement)."""

    name: ast.Ident
    args: tuple[HookSlot, ...]
    results: tuple[HookSlot, ...]
    description: str | None
    span: Span

    def text(self) -> str:
        """The declaration as the formatter writes it."""
        results = ", ".join(r.text() for r in self.results)
        desc = f' "{self.description}"' if self.description else ""
        return (f"hook {self.name.text}({', '.join(a.text() for a in self.args)}) -> "
                f"({results}){desc}")


def slots_of(children) -> tuple[HookSlot, ...]:
    """The HookSlots among a rule's children, however lark nested them."""
    out: list[HookSlot] = []
    stack = list(children)
    while stack:
        item = stack.pop(0)
        if isinstance(item, HookSlot):
            out.append(item)
        elif isinstance(item, (list, tuple)):
            stack[:0] = list(item)
    return tuple(out)


#: Names a hook cannot take: its C function would clash with C or the C library (the code generator's list).
C_RESERVED = frozenset("""auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef union unsigned void
volatile while sin cos tan asin acos atan atan2 sinh cosh tanh exp log log10 sqrt pow fabs fmin fmax floor ceil
round trunc fmod hypot isfinite isnan nan abs exit free malloc time clock printf main errno""".split())


#: Relative step of the central difference that stands in for a hook's derivative where the generated Jacobians
#: need one and the implementation gives none: cbrt(DBL_EPSILON), the truncation and rounding errors balanced.
DIFFERENCE_STEP = 6.055454452393343e-06


def derivative_name(name: str, result: int, results: int, argument: int) -> str:
    """The generated helper d(result)/d(argument) of a hook (compiler/hooks.py emits it, runtime/hooks.py
    supplies it to the NumPy back end)."""
    return f"mbs_hookd__{name}__{result}__{results}__{argument}"


# ------------------------------------------------------------------------------------------ data model
@dataclass(frozen=True)
class Slot:
    """An argument or result of a validated hook: its dimension and the factor of its declared unit to SI."""

    name: str
    dimension: U.Dimension
    factor: float
    unit: str   # as declared ('1' when dimensionless)


@dataclass(frozen=True)
class HookSpec:
    """A validated hook declaration (Model.hooks): what an implementation must accept and return."""

    name: str
    args: tuple[Slot, ...]
    results: tuple[Slot, ...]
    description: str | None
    span: Span

    def signature(self) -> str:
        """``friction_law(v: m/s, n: N) -> (f: N)``, for messages and generated comments."""
        args = ", ".join(f"{s.name}: {s.unit}" for s in self.args)
        return f"{self.name}({args}) -> ({', '.join(f'{s.name}: {s.unit}' for s in self.results)})"


@dataclass
class HookEntry:
    """A hook visible in a scope (scope.py looks names up; expressions.py calls `call` for it)."""

    spec: HookSpec | None  # None: the declaration had errors (reported); calls are then not checked further
    decl: HookDecl


def declare(elab, scope, decl: HookDecl) -> HookEntry:
    """The entry of a declaration; the validated spec is registered on the elaborator (one per name)."""
    spec = _validate(elab, scope, decl)
    specs = elab.hook_specs
    if spec is not None and decl.name.text not in scope.entries:  # a repeat in one block: "already declared"
        first = specs.get(spec.name)
        if first is None:
            specs[spec.name] = spec
        elif (first.args, first.results) != (spec.args, spec.results):
            elab.diags.error(f"hook '{spec.name}' is declared twice with different arguments or results "
                             f"({first.signature()} and {spec.signature()}): a hook has one implementation",
                             scope.at(decl.name.span), ("first declared here", first.span))
    return HookEntry(spec, decl)


def model_hooks(elab) -> tuple[HookSpec, ...]:
    """Every hook the elaborated model declares (in the elaborator's registry ``hook_specs``, name -> spec)."""
    return tuple(elab.hook_specs.values())


def _validate(elab, scope, decl: HookDecl) -> HookSpec | None:
    ok = True
    if decl.name.text.lower().startswith("mbs_"):
        elab.diags.error("a hook name may not start with 'mbs_' (the generated code's own names)",
                         scope.at(decl.name.span))
        ok = False
    elif decl.name.text in C_RESERVED:
        elab.diags.error(f"'{decl.name.text}' is a name of C or its math library, and a hook's name is the name of "
                         "its C function: choose another", scope.at(decl.name.span))
        ok = False
    if not decl.results:
        elab.diags.error(f"hook '{decl.name.text}' needs at least one result: -> (name: unit)",
                         scope.at(decl.span))
        ok = False
    seen: dict[str, HookSlot] = {}
    slots = []
    for slot in (*decl.args, *decl.results):
        if slot.name.text in seen:
            elab.diags.error(f"'{slot.name.text}' appears twice in hook '{decl.name.text}'",
                             scope.at(slot.name.span), ("first here", scope.at(seen[slot.name.text].span)))
            ok = False
            continue
        seen[slot.name.text] = slot
        factor, dim = 1.0, U.DIMENSIONLESS
        if slot.unit is not None:
            try:
                factor, dim = U.parse_unit(slot.unit)
            except U.UnitError as exc:
                start = slot.unit_span.start + exc.offset
                elab.diags.error(exc.message, scope.at(Span.at(slot.unit_span.source, start,
                                                               start + max(1, exc.length))))
                ok = False
                continue
        slots.append(Slot(slot.name.text, dim, factor, slot.unit or "1"))
    if not ok:
        return None
    n = len(decl.args)
    return HookSpec(decl.name.text, tuple(slots[:n]), tuple(slots[n:]), decl.description, scope.at(decl.span))


# ------------------------------------------------------------------------------------------ calls
def call(resolver, node: ast.Call, entry: HookEntry):
    """(expression, dimension) of ``hook(args)`` or ``hook.result(args)`` in an expression: every argument
    checked against the declared unit and converted to it; the result converted back to SI."""
    decl, spec = entry.decl, entry.spec
    parts = node.func.parts
    resolver.state_used(node.func)  # a hook's value exists only while running: never in a constant
    if node.kwargs:
        raise resolver.error(f"hook {decl.name.text}() takes its arguments by position", node.kwargs[0].span)
    if spec is None:
        raise resolver.error(f"hook '{decl.name.text}' has errors in its declaration", node.func.span)
    if len(parts) > 2:
        raise resolver.error(f"'{node.func.dotted}': a hook call is {spec.name}(...) or {spec.name}.RESULT(...)",
                             node.func.span)
    if len(parts) == 2:
        names = [r.name for r in spec.results]
        if parts[1].text not in names:
            from .scope import did_you_mean
            raise resolver.error(f"hook '{spec.name}' has no result '{parts[1].text}'"
                                 f"{did_you_mean(parts[1].text, names)} (results: {', '.join(names)})",
                                 parts[1].span)
        k = names.index(parts[1].text)
    elif len(spec.results) == 1:
        k = 0
    else:
        names = ", ".join(f"{spec.name}.{r.name}(...)" for r in spec.results)
        raise resolver.error(f"hook '{spec.name}' has {len(spec.results)} results: choose one, {names}",
                             node.func.span)
    if len(node.args) != len(spec.args):
        raise resolver.error(f"hook {spec.signature()} takes {len(spec.args)} argument"
                             f"{'s' if len(spec.args) != 1 else ''}, got {len(node.args)}", node.span)
    args = []
    for slot, arg_node in zip(spec.args, node.args):
        value, dim = resolver.scalar(arg_node)
        if dim is not None and dim != slot.dimension:
            raise resolver.error(f"argument '{slot.name}' of hook '{spec.name}' must be {_wanted(slot)}, but this "
                                 f"is {U.describe(dim)}", arg_node.span)
        args.append(value if slot.factor == 1.0 else X.Op("/", (value, X.const(slot.factor))))
    result = spec.results[k]
    value = X.Hook(spec.name, k, len(spec.results), tuple(args))
    return X.mul(value, X.const(result.factor)), result.dimension


def _wanted(slot: Slot) -> str:
    return "dimensionless" if slot.dimension.is_dimensionless else f"{U.describe(slot.dimension)} (declared " \
                                                                    f"in {slot.unit})"
