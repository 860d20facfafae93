"""``mbs fmt``: the canonical layout of a .mbs file, printed from its AST with the comments kept.

Canonical means: four-space indentation, one statement per line, single spaces around binary operators,
none inside brackets, the minimum of parentheses, numbers and units exactly as written. Formatting a
formatted file changes nothing, and the result validates to the same data model (tested on every model).
"""

from __future__ import annotations

from . import ast
from .hooks import HookDecl
from .diagnostics import Source
from .parser import comments_of

INDENT = "    "
_PREC = {"or": 1, "and": 2, "not": 3, "==": 4, "!=": 4, "<": 4, "<=": 4, ">": 4, ">=": 4,
         "+": 5, "-": 5, "*": 6, "/": 6, "unary": 7, "^": 8}
ATOM = 9


def format_source(file: ast.File, source: Source) -> str:
    printer = _Printer(source)
    printer.items(file.items, 0)
    printer.flush_comments(len(source.text) + 1, 0)
    text = "\n".join(printer.lines).rstrip("\n") + "\n"
    return text if text.strip() else ""


class _Printer:
    def __init__(self, source: Source):
        self.source = source
        self.lines: list[str] = []
        self.comments = comments_of(source)  # (offset, line, text), in order
        self.next_comment = 0

    # ------------------------------------------------------------------------------------ comments
    def flush_comments(self, before_offset: int, depth: int) -> None:
        while self.next_comment < len(self.comments) and self.comments[self.next_comment][0] < before_offset:
            _, line, text = self.comments[self.next_comment]
            self.blank_line_before(line)
            self.lines.append(INDENT * depth + text)
            self.next_comment += 1

    def trailing_comment(self, end_offset: int) -> str:
        """A comment on the same line right after a statement stays there."""
        if self.next_comment < len(self.comments):
            offset, _, text = self.comments[self.next_comment]
            line_end = self.source.text.find("\n", end_offset)
            line_end = len(self.source.text) if line_end < 0 else line_end
            if end_offset <= offset < line_end:
                self.next_comment += 1
                return "  " + text
        return ""

    def blank_line_before(self, line: int) -> None:
        """Keep one blank line where the author left one or more (not right after an opening brace)."""
        if line > 1 and not self.source.line_text(line - 1).strip() and self.lines and self.lines[-1].strip() \
                and not self.lines[-1].endswith("{"):
            self.lines.append("")

    def emit(self, node, depth: int, text: str) -> None:
        self.flush_comments(node.span.start, depth)
        self.blank_line_before(node.span.line)
        self.lines.append(INDENT * depth + text + self.trailing_comment(node.span.end))

    def open_block(self, node, depth: int, head: str, children, printer) -> None:
        self.flush_comments(node.span.start, depth)
        brace = self.source.text.find("{", node.span.start, node.span.end)
        self.blank_line_before(node.span.line)
        self.lines.append(INDENT * depth + head + " {" + self.trailing_comment(brace + 1))
        for child in children:
            printer(child, depth + 1)
        self.flush_comments(node.span.end - 1, depth + 1)
        self.lines.append(INDENT * depth + "}" + self.trailing_comment(node.span.end))

    # ------------------------------------------------------------------------------------ items
    def items(self, items, depth: int) -> None:
        previous = None
        for item in items:
            if previous is not None and (isinstance(item, (ast.Model, ast.Scene)) or
                                         isinstance(previous, (ast.Model, ast.Scene))) and self.lines[-1]:
                self.lines.append("")
            self.item(item, depth)
            previous = item

    def item(self, node, depth: int) -> None:
        if isinstance(node, (ast.Model, ast.Scene)):
            keyword = node.kind if isinstance(node, ast.Model) else "scene"
            head = f"{keyword} {node.name.text}{_desc(node.description)}"
            self.open_block(node, depth, head, node.statements, self.statement)
        else:
            self.statement(node, depth)

    def statement(self, node, depth: int) -> None:
        if isinstance(node, ast.Import):
            self.emit(node, depth, f"import {node.path.dotted}" + (f" as {node.alias.text}" if node.alias else ""))
        elif isinstance(node, ast.Param):
            self.emit(node, depth, f"{node.kind} {node.name.text} = {expr(node.value)}{_desc(node.description)}")
        elif isinstance(node, ast.State):
            self.emit(node, depth, f"state {node.name.text} = {expr(node.value)}{_desc(node.description)}")
        elif isinstance(node, ast.Rate):
            self.emit(node, depth, f"der({node.target.dotted}) = {expr(node.value)}{_desc(node.description)}")
        elif isinstance(node, ast.Event):
            head = f"event {node.name.text} when {expr(node.condition)}{_desc(node.description)}"
            if self.source.text.find("{", node.condition.span.end, node.span.end) >= 0:
                self.open_block(node, depth, head, node.actions, self.statement)
            else:
                self.emit(node, depth, head)
        elif isinstance(node, ast.Reinit):
            target = f"der({node.target.dotted})" if node.derivative else node.target.dotted
            self.emit(node, depth, f"reinit {target} = {expr(node.value)}")
        elif isinstance(node, ast.Set):
            self.emit(node, depth, f"set {node.target.dotted} = {expr(node.value)}")
        elif isinstance(node, ast.Terminate):
            self.emit(node, depth, "terminate")
        elif isinstance(node, ast.Input):
            self.emit(node, depth, f"input {node.name.text} = {expr(node.value)}{_desc(node.description)}")
        elif isinstance(node, ast.Output):
            value = f" = {expr(node.value)}" if node.value is not None else ""
            self.emit(node, depth, f"output {node.name.dotted}{value}{_desc(node.description)}")
        elif isinstance(node, ast.Func):
            params = ", ".join(p.text for p in node.params)
            self.emit(node, depth, f"func {node.name.text}({params}) = {expr(node.body)}{_desc(node.description)}")
        elif isinstance(node, HookDecl):
            self.emit(node, depth, node.text())
        elif isinstance(node, ast.Setting):
            where = f" in {node.frame.dotted}" if node.frame else ""
            where += f" about {node.about.dotted}" if node.about else ""
            self.emit(node, depth, f"{node.name.text} = {expr(node.value)}{where}")
        elif isinstance(node, ast.Frame):
            self.emit(node, depth, _frame(node))
        elif isinstance(node, (ast.Part, ast.Port)):
            self.part(node, depth)
        elif isinstance(node, ast.Body):
            self.open_block(node, depth, "body", node.settings, self.statement)
        elif isinstance(node, ast.Interact):
            self.open_block(node, depth, f"interact {node.name.text}{_desc(node.description)}", node.members,
                            self.statement)
        elif isinstance(node, ast.Connect):
            self.emit(node, depth, f"connect {node.a.dotted} -> {node.b.dotted}")
        elif isinstance(node, ast.Joint):
            head = f"joint {node.kind.text}{_args(node.args)}"
            if node.has_block:
                self.open_block(node, depth, head, node.statements, self.statement)
            else:
                self.emit(node, depth, head)
        elif isinstance(node, ast.Init):
            target = f"der({node.target.dotted})" if node.derivative else node.target.dotted
            self.emit(node, depth, f"init {target} = {expr(node.value)}")
        elif isinstance(node, ast.Prescribe):
            self.emit(node, depth, f"prescribe {node.target.dotted} = {expr(node.value)}")
        elif isinstance(node, ast.Force):
            name = f"{node.name.text} = " if node.name else ""
            self.emit(node, depth, f"force {name}{node.kind.text}{_args(node.args, always=True)}")
        elif isinstance(node, ast.Sensor):
            self.emit(node, depth, f"sensor {node.name.text} = {node.kind.text}{_args(node.args, always=True)}")
        elif isinstance(node, ast.Use):
            head = f"use {node.component.dotted} as {node.alias.text}{_args(node.args)}"
            if node.bindings:
                self.open_block(node, depth, head, node.bindings, self.statement)
            else:
                self.emit(node, depth, head)
        elif isinstance(node, ast.For):
            self.open_block(node, depth, f"for {node.var.text} in {expr(node.values)}", node.statements,
                            self.statement)
        elif isinstance(node, ast.Binding):
            self.emit(node, depth, f"{node.port.text} = {node.target.dotted}")
        else:  # pragma: no cover - the grammar has no other statements
            raise TypeError(type(node).__name__)

    def part(self, node, depth: int) -> None:
        keyword = "port" if isinstance(node, ast.Port) else ("rigid" if node.rigid else "part")
        head = f"{keyword} {node.name.text}{_desc(node.description)}"
        children = ([node.body] if getattr(node, "body", None) else []) + list(node.frames)
        has_braces = self.source.text.find("{", node.span.start, node.span.end) >= 0
        if children or has_braces or keyword == "rigid":
            self.open_block(node, depth, head, children, self.statement)
        else:
            self.emit(node, depth, head)


def _desc(description: str | None) -> str:
    if description is None:
        return ""
    return ' "' + description.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _frame(node: ast.Frame) -> str:
    text = f"frame {node.name.text}"
    if node.at is not None:
        text += f" at {expr(node.at)}"
    if node.rotate is not None:
        text += f" rotate {expr(node.rotate)}"
    return text + _desc(node.description)


def _args(args, always: bool = False) -> str:
    if not args and not always:
        return ""
    return "(" + ", ".join(_arg(a) for a in args) + ")"


def _arg(a) -> str:
    if isinstance(a, ast.Kwarg):
        return f"{a.name.text} = {expr(a.value)}"
    return expr(a)


# ------------------------------------------------------------------------------------------ expressions
def _prec(node) -> int:
    if isinstance(node, ast.Binary):
        return _PREC[node.op]
    if isinstance(node, ast.Unary):
        return _PREC["not"] if node.op == "not" else _PREC["unary"]
    return ATOM


def _wrap(node, minimum: int) -> str:
    text = expr(node)
    return f"({text})" if _prec(node) < minimum else text


def expr(node) -> str:
    if isinstance(node, ast.Number):
        return node.text + (f" {node.unit}" if node.unit else "")
    if isinstance(node, ast.Name):
        return node.ref.dotted
    if isinstance(node, ast.String):
        return '"' + node.value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(node, ast.Call):
        return f"{node.func.dotted}({', '.join([expr(a) for a in node.args] + [_arg(k) for k in node.kwargs])})"
    if isinstance(node, ast.Vector):
        return "(" + ", ".join(expr(i) for i in node.items) + ")"
    if isinstance(node, ast.Matrix):
        return "[" + ", ".join(expr(i) for i in node.items) + "]"
    if isinstance(node, ast.WithUnit):
        inner = expr(node.expr)
        if not isinstance(node.expr, (ast.Call, ast.Vector, ast.Matrix)):
            inner = f"({inner})"
        return f"{inner} {node.unit}"
    if isinstance(node, ast.Unary):
        if node.op == "not":
            return f"not {_wrap(node.operand, _PREC['not'])}"
        return f"{node.op}{_wrap(node.operand, _PREC['unary'])}"
    if isinstance(node, ast.Binary):
        p = _PREC[node.op]
        if node.op == "^":
            return f"{_wrap(node.left, ATOM)}^{_wrap(node.right, _PREC['unary'])}"
        if p == 4:  # comparisons do not chain
            return f"{_wrap(node.left, 5)} {node.op} {_wrap(node.right, 5)}"
        if node.op in ("and", "or"):
            return f"{_wrap(node.left, p)} {node.op} {_wrap(node.right, p + 1)}"
        return f"{_wrap(node.left, p)} {node.op} {_wrap(node.right, p + 1)}"
    raise TypeError(type(node).__name__)  # pragma: no cover
