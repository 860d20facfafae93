"""Repetition: ``for`` blocks unrolled and indexed names resolved, on the AST, before validation.

    for i in range(2, 41) {
        rigid link[i] { ... }
        interact j[i] {
            connect link[i - 1].tip -> link[i]
        }
    }

Why on the AST. The structure of a model (which parts and joints exist) must be known before the topology is
built, so the loop bounds are numbers fixed in the text, and unrolling is a pure text-level expansion: every
later stage sees ordinary statements named ``link[2]`` ... ``link[40]``, and every message about one of them
points at the statement inside the loop (the name in the message says which iteration). ``mbs fmt`` prints
the loop itself (it formats the AST before this pass).

Values: ``range(first, stop)`` or ``range(first, stop, step)`` as in Python (stop excluded), or a vector of
integers ``(1, 3, 5)``. Index and bound expressions are integer arithmetic (+ - * /, parentheses) of numbers
and the variables of the enclosing loops; the loop variable used anywhere else in an expression is that
number (``init phi = 0.1 * i deg``).
"""

from __future__ import annotations

import dataclasses

from . import ast
from .diagnostics import Diagnostics

#: Most statements one file may unroll to: a typo such as range(1, 1e9) stops here, not in the memory.
MAX_ITERATIONS = 100_000


class _Invalid(Exception):
    pass


def expand(file: ast.File, diags: Diagnostics) -> ast.File:
    """The file with every for block unrolled and every indexed name made plain; errors go to diags."""
    text = file.span.source.text if file.span is not None else ""
    if "for" not in text and "[" not in text:
        return file  # nothing to do (most files): no walk
    return _Expander(diags).node(file, {})


class _Expander:
    def __init__(self, diags: Diagnostics):
        self.diags = diags
        self.count = 0
        self.sites: list[tuple[str, object]] = []  # enclosing iterations, outermost first: ("in the loop ...", span)

    def span(self, span):
        """A span inside an iteration: a message there also says which iteration (a note at the loop)."""
        for label, site in reversed(self.sites):
            span = span.instantiated(label, site)
        return span

    def node(self, node, env: dict):
        if isinstance(node, tuple):
            out = []
            for item in node:
                if isinstance(item, ast.For):
                    out.extend(self.unroll(item, env))
                else:
                    out.append(self.node(item, env))
            return tuple(out)
        if isinstance(node, ast.IndexedIdent):
            try:
                return ast.Ident(f"{node.base}[{self.integer(node.index, env)}]", self.span(node.span))
            except _Invalid:
                return ast.Ident(node.text, self.span(node.span))
        if isinstance(node, ast.Name) and len(node.ref.parts) == 1 and node.ref.parts[0].text in env \
                and type(node.ref.parts[0]) is ast.Ident:
            return ast.Number(str(env[node.ref.parts[0].text]), None, self.span(node.span))
        if not dataclasses.is_dataclass(node) or type(node).__module__ != ast.__name__:
            return node  # spans, strings, numbers as text
        changes = {}
        for f in dataclasses.fields(node):
            value = getattr(node, f.name)
            if value is None or isinstance(value, (str, bool)):
                continue
            if f.name in ("span", "unit_span"):
                new = self.span(value) if self.sites else value
            else:
                new = self.node(value, env)
            if new is not value:
                changes[f.name] = new
        return dataclasses.replace(node, **changes) if changes else node

    def unroll(self, loop: ast.For, env: dict) -> list:
        name = loop.var.text
        if name in env:
            self.diags.error(f"loop variable '{name}' is already the variable of an enclosing loop", loop.var.span)
            return []
        try:
            values = self.values(loop.values, env)
        except _Invalid:
            return []
        self.count += len(values) * len(loop.statements)
        if self.count > MAX_ITERATIONS:
            self.diags.error(f"this loop unrolls to more than {MAX_ITERATIONS} statements in the file",
                             loop.values.span)
            return []
        out = []
        for value in values:
            self.sites.append((f"in the iteration {name} = {value} of this loop", loop.values.span))
            try:
                out.extend(self.node(loop.statements, {**env, name: value}))
            finally:
                self.sites.pop()
        return out

    def values(self, e, env: dict) -> list[int]:
        if isinstance(e, ast.Call) and e.func.dotted == "range" and not e.kwargs and 1 <= len(e.args) <= 3:
            bounds = [self.integer(a, env) for a in e.args]
            if len(bounds) == 3 and bounds[2] == 0:
                self.diags.error("the step of a range cannot be 0", e.args[2].span)
                raise _Invalid()
            if len(range(*bounds)) > MAX_ITERATIONS:
                self.diags.error(f"this range has more than {MAX_ITERATIONS} values", e.span)
                raise _Invalid()
            return list(range(*bounds))
        if isinstance(e, ast.Vector):
            return [self.integer(item, env) for item in e.items]
        self.diags.error("a loop runs over range(first, stop[, step]) or a vector of integers such as (1, 3, 5)",
                         e.span)
        raise _Invalid()

    def integer(self, e, env: dict) -> int:
        """An integer expression of numbers and loop variables; anything else is a located error."""
        value = self.number(e, env)
        if value != int(value):
            self.diags.error(f"an index or loop bound must be a whole number, this is {value:g}", e.span)
            raise _Invalid()
        return int(value)

    def number(self, e, env: dict) -> float:
        if isinstance(e, ast.Number) and e.unit is None:
            return float(e.text)
        if isinstance(e, ast.Name) and len(e.ref.parts) == 1 and e.ref.parts[0].text in env:
            return float(env[e.ref.parts[0].text])
        if isinstance(e, ast.Unary) and e.op in "+-":
            value = self.number(e.operand, env)
            return -value if e.op == "-" else value
        if isinstance(e, ast.Binary) and e.op in ("+", "-", "*", "/"):
            a, b = self.number(e.left, env), self.number(e.right, env)
            if e.op == "/" and b == 0:
                self.diags.error("division by zero in an index", e.span)
                raise _Invalid()
            return {"+": a + b, "-": a - b, "*": a * b, "/": a / b if b else 0.0}[e.op]
        if isinstance(e, ast.Name):
            self.diags.error(f"'{e.ref.dotted}' is not a loop variable here: indices and loop bounds are fixed "
                             "in the text (numbers and the variables of enclosing loops)", e.span)
        else:
            self.diags.error("indices and loop bounds are whole numbers: +, -, *, / of numbers and loop "
                             "variables", e.span)
        raise _Invalid()
