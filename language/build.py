"""The AST builder: one function per grammar rule, called by lark's LALR loop while it parses (parser.py).

Each reduction gets the rule's raw children (keywords and punctuation included, so spans come from the
tokens) and returns an AST node or an intermediate value (_Part, _List, _Chain, _Prefix). Binary operators
arrive as flat chains and are turned into trees by precedence climbing. lark's tree builder with positions
followed by a Transformer walk cost a tree node per reduction and a second pass, more than half of the front
end's time on a large model.
"""

from __future__ import annotations

from lark import Token

from . import ast
from .diagnostics import Diagnostic, MbsError, Source, Span


# ------------------------------------------------------------------------------------------ values of a parse
class _Part:
    """A value on the parser's stack that is not an AST node (a description, an argument list, a parenthesised
    expression, ...), with the text it covers: the spans of the nodes around it are made from it.
    ``head`` is (offset, line, column) of its first character, ``end`` the offset after its last."""

    __slots__ = ("kind", "value", "head", "end")

    def __init__(self, kind: str, value, head: tuple[int, int, int], end: int):
        self.kind, self.value, self.head, self.end = kind, value, head, end


class _List(list):
    """The values of a list rule (statements of a block, ``("," expr)*``): lark's helper rules extend it."""


class _Chain(list):
    """A flat operand, operator, operand, ... list (grammar rules arith and expr), not yet a tree."""


class _Prefix:
    """A unary + or - waiting for precedence climbing: it takes every '^' after its operand."""

    __slots__ = ("op", "operand")

    def __init__(self, op: Token, operand):
        self.op, self.operand = op, operand


class _Repeated:
    """Marker for a construct the grammar accepts but the language forbids (a second body)."""

    def __init__(self, node, what, span):
        self.node, self.what, self.span = node, what, span


def _head(value) -> tuple[int, int, int]:
    """(offset, line, column) where the text of a stack value starts; a parenthesised expression starts at
    its '('. Tokens and spans know their line, so spans are made without searching the line table."""
    kind = type(value)
    if kind is Token:
        return value.start_pos, value.line, value.column
    if kind is _Part:
        return value.head
    if kind is _Chain:
        return _head(value[0])
    if kind is _Prefix:
        return _head(value.op)
    span = value.span
    return span.start, span.line, span.col


def _end(value) -> int:
    kind = type(value)
    if kind is Token:
        return value.end_pos
    if kind is _Part:
        return value.end
    if kind is _Chain:
        return _end(value[-1])
    return value.span.end


#: Deepest expression accepted (parenthesis, operator and sign levels); deeper ones are a located error.
MAX_EXPRESSION_DEPTH = 100


def _children(node) -> tuple:
    """The sub-expressions of an expression node (none for names, numbers and strings)."""
    kind = type(node)
    if kind is ast.Binary:
        return (node.left, node.right)
    if kind is ast.Unary:
        return (node.operand,)
    if kind is ast.WithUnit or kind is ast.Kwarg:
        return (node.expr if kind is ast.WithUnit else node.value,)
    if kind is ast.Call:
        return (*node.args, *node.kwargs)
    if kind is ast.Vector or kind is ast.Matrix:
        return node.items
    if kind is _Part:
        return (node.value,)
    return ()


def _last(value):
    """The innermost last item of a chain or a chain of signs (where its text ends)."""
    while type(value) is _Chain or type(value) is _Prefix:
        value = value[-1] if type(value) is _Chain else value.operand
    return value


def _node(value):
    """The AST node of an expression value (a parenthesised one is its content)."""
    return value.value if type(value) is _Part else value


def _description(children):
    last = children[-1]
    return last.value if type(last) is _Part and last.kind == "description" else None


def _unquote(tok) -> str:
    return str(tok)[1:-1].replace('\\"', '"').replace("\\\\", "\\")


# Binding power of the binary operators (higher binds tighter). Unary + and - bind between * / and ^, so
# -x^2 is -(x^2) and -a*b is (-a)*b; ^ is right-associative. Comparisons never meet another operator here:
# the grammar builds them from finished operands.
_BINDING = {"or": 1, "and": 2, "+": 3, "-": 3, "*": 4, "/": 4, "^": 6}
_UNARY_BINDING = 5
_RIGHT_ASSOCIATIVE = frozenset({"^"})


# ------------------------------------------------------------------------------------------ lark -> AST
class _AstBuilder:
    """The AST of one source, built bottom-up from lark's reductions (STYLE.md point 5, done while parsing).

    Each method is named after a grammar rule (or its alias) and gets that rule's children as lark's parser
    has them: tokens, AST nodes, _Part, _List, _Chain or _Prefix values; lark expands optional parts of a
    rule into alternatives, so the number of children tells which alternative matched.
    """

    def __init__(self, source: Source):
        self.source = source
        self._depths: dict[int, int] = {}  # id(expression node) -> nesting depth, filled bottom-up

    def _span(self, first, last) -> Span:
        start, line, col = _head(first)
        return Span(self.source, start, _end(last), line, col)

    def _tok_span(self, tok: Token) -> Span:
        return Span(self.source, tok.start_pos, tok.end_pos, tok.line, tok.column)

    def _deep(self, depth: int, where) -> MbsError:
        return MbsError([Diagnostic("error", f"this expression is nested {depth} levels deep, more than the "
                                             f"{MAX_EXPRESSION_DEPTH} allowed (a sum of n terms or a chain of n "
                                             "signs counts n levels): split it into parameters or functions",
                                    self._span(where, _last(where)))])

    def _limit_depth(self, node):
        """The node, unless it is nested deeper than MAX_EXPRESSION_DEPTH (every later stage recurses over
        expressions; a located error here instead of a RecursionError there)."""
        depths, stack = self._depths, [node]
        while stack:
            top = stack[-1]
            children = [c for c in _children(top) if id(c) not in depths]
            if children:
                stack.extend(children)
                continue
            stack.pop()
            depth = 1 + max((depths[id(c)] for c in _children(top)), default=0)
            if depth > MAX_EXPRESSION_DEPTH:
                raise self._deep(depth, top)
            depths[id(top)] = depth
        return node

    def _climb(self, items: _Chain):
        """The tree of a flat operand, operator, operand, ... list, by precedence climbing."""
        chained = sum(1 for item in items if type(item) is Token and item.value == "^")
        for item in items:  # climbing recurses along signs and '^': bound it before it starts
            signs = 0
            while type(item) is _Prefix:
                item, signs = item.operand, signs + 1
            chained += signs
        if chained > MAX_EXPRESSION_DEPTH:
            raise self._deep(chained, items)
        pos = 0

        def operand():
            nonlocal pos
            item = items[pos]
            if type(item) is not _Prefix:
                pos += 1
                return item
            items[pos] = item.operand  # the prefix applies to its operand and to any tighter operator after it
            inner = climb(_UNARY_BINDING + 1)
            return ast.Unary(item.op.value, _node(inner), self._span(item.op, inner))

        def climb(min_binding: int):
            nonlocal pos
            left = operand()
            while pos < len(items):
                op = items[pos].value
                binding = _BINDING[op]
                if binding < min_binding:
                    break
                pos += 1
                right = climb(binding if op in _RIGHT_ASSOCIATIVE else binding + 1)
                left = ast.Binary(op, _node(left), _node(right), self._span(left, right))
            return left

        return climb(0)

    # -- names
    def ident(self, c):
        tok = c[0]
        return ast.Ident(tok.value, self._tok_span(tok))

    def ref(self, c):
        parts = (c[0], *c[1]) if len(c) > 1 else (c[0],)
        return ast.Ref(parts, self._span(parts[0], parts[-1]))

    def dotted(self, c):
        parts = (c[0], *c[1]) if len(c) > 1 else (c[0],)
        return ast.Ref(parts, self._span(parts[0], parts[-1]))

    def indexed(self, c):
        from .formatter import expr  # the canonical text of the index: 'link[i - 1]' in messages and fmt
        index = _node(c[2])
        return ast.IndexedIdent(f"{c[0].text}[{expr(index)}]", self._span(c[0], c[-1]), c[0].text, index)

    def for_decl(self, c):
        return ast.For(c[1], _node(c[3]), tuple(c[-2]) if type(c[-2]) is not Token else (),
                       self._span(c[0], c[-1]))

    frame_for = for_decl  # frames of a part repeated: the same node, its statements are frames

    def dotted_ident(self, c):
        """Dotted names are allowed where a scene overrides a parameter of a component instance."""
        parts = (c[0], *c[1])
        return ast.Ident(".".join(p.text for p in parts), self._span(parts[0], parts[-1]))

    def description(self, c):
        tok = c[0]
        return _Part("description", _unquote(tok), _head(tok), tok.end_pos)

    # -- expressions: expr or test -> logic -> arith -> operand
    def arith(self, c):
        return c[0]

    operand = arith

    def chain(self, c):
        """arith and logic: one more operator and operand for the flat list."""
        left = c[0]
        if type(left) is _Chain:
            left += c[1:]
            return left
        return _Chain(c)

    def test(self, c):
        """expr and test: the tree of a finished list (or of a lone prefixed operand)."""
        value = c[0]
        kind = type(value)
        if kind is _Chain or kind is _Prefix:
            return self._limit_depth(self._climb(_Chain([value]) if kind is _Prefix else value))
        return value

    expr = test

    def compare(self, c):
        left, op, right = self.test(c[:1]), c[1], self.test(c[2:])
        return ast.Binary(op.value, _node(left), _node(right), self._span(left, right))

    def not_op(self, c):
        return ast.Unary("not", _node(c[1]), self._span(c[0], c[1]))

    def prefix(self, c):
        return _Prefix(c[0], c[1])

    def number(self, c):
        return ast.Number(c[0].value, None, self._tok_span(c[0]))

    def quantity(self, c):
        num, unit = c
        return ast.Number(num.value, unit.value, self._span(num, unit), self._tok_span(unit))

    def name(self, c):
        return ast.Name(c[0], c[0].span)

    def string(self, c):
        return ast.String(_unquote(c[0]), self._tok_span(c[0]))

    def with_unit(self, c):
        expr, unit = c
        return ast.WithUnit(expr, unit.value, self._span(expr, unit), self._tok_span(unit))

    def parens(self, c):
        return _Part("parens", _node(c[1]), _head(c[0]), c[2].end_pos)

    def parens_unit(self, c):
        unit = c[3]
        return ast.WithUnit(_node(c[1]), unit.value, self._span(c[0], unit), self._tok_span(unit))

    def _args(self, c) -> tuple:
        """Arguments from the children between '(' and ')': nothing, or _arg and maybe a _List of more."""
        if not c:
            return ()
        args = [c[0], *c[1]] if len(c) > 1 else c
        return tuple(a if type(a) is ast.Kwarg else _node(a) for a in args)

    def call(self, c):
        args = self._args(c[2:-1])
        positional = tuple(a for a in args if type(a) is not ast.Kwarg)
        keywords = tuple(a for a in args if type(a) is ast.Kwarg)
        return ast.Call(c[0], positional, keywords, self._span(c[0], c[-1]))

    def kwarg(self, c):
        return ast.Kwarg(c[0], _node(c[2]), self._span(c[0], c[2]))

    def arglist(self, c):
        return _Part("args", self._args(c[1:-1]), _head(c[0]), c[-1].end_pos)

    def vector(self, c):
        return ast.Vector(tuple(_node(e) for e in (c[1], *c[2])), self._span(c[0], c[-1]))

    def matrix(self, c):
        items = [x for x in c[1:-1] if type(x) is not Token]
        items = [items[0], *items[1]] if len(items) > 1 else items
        return ast.Matrix(tuple(_node(e) for e in items), self._span(c[0], c[-1]))

    def expr_only(self, c):
        return _node(c[0])

    # -- declarations
    def import_decl(self, c):
        return ast.Import(c[1], c[3] if len(c) > 2 else None, self._span(c[0], c[-1]))

    def param_decl(self, c):
        return ast.Param(c[1], _node(c[3]), _description(c), self._span(c[0], c[-1]))

    def mode_decl(self, c):
        return ast.Param(c[1], _node(c[3]), _description(c), self._span(c[0], c[-1]), kind="mode")

    def state_decl(self, c):
        return ast.State(c[1], _node(c[3]), _description(c), self._span(c[0], c[-1]))

    def rate_decl(self, c):
        return ast.Rate(c[2], _node(c[5]), _description(c), self._span(c[0], c[-1]))

    def event_decl(self, c):
        description = c[4].value if len(c) > 4 and type(c[4]) is _Part else None
        actions = tuple(c[-2]) if type(c[-1]) is Token and c[-1].value == "}" and type(c[-2]) is not Token else ()
        return ast.Event(c[1], _node(c[3]), description, actions, self._span(c[0], c[-1]))

    def hook_decl(self, c):
        from .hooks import HookDecl, slots_of
        args, results = slots_of([c[2]]), slots_of([c[4]])
        last = c[-1] if _description(c) is not None or not results else results[-1]
        return HookDecl(c[1], args, results, _description(c), self._span(c[0], last))

    def hook_args(self, c):
        from .hooks import slots_of
        return slots_of(c)

    hook_results = hook_args

    def hook_slot(self, c):
        from .hooks import HookSlot
        unit = c[2] if len(c) > 2 else None
        return HookSlot(c[0], str(unit) if unit is not None else None,
                        self._tok_span(unit) if unit is not None else None, self._span(c[0], c[-1]))

    def reinit_stmt(self, c):
        ref, derivative = c[1].value
        return ast.Reinit(ref, derivative, _node(c[3]), self._span(c[0], c[-1]))

    def set_stmt(self, c):
        return ast.Set(c[1], _node(c[3]), self._span(c[0], c[-1]))

    def terminate_stmt(self, c):
        return ast.Terminate(self._span(c[0], c[0]))

    def input_decl(self, c):
        return ast.Input(c[1], _node(c[3]), _description(c), self._span(c[0], c[-1]))

    def output_decl(self, c):
        value = _node(c[3]) if len(c) > 3 else None
        return ast.Output(c[1], value, _description(c), self._span(c[0], c[-1]))

    def func_decl(self, c):
        description = _description(c)
        rest = [x for x in c[1:-1 if description is not None else None] if type(x) is not Token]
        body = rest.pop()
        params = (*rest[1:2], *(rest[2] if len(rest) > 2 else ()))
        return ast.Func(rest[0], params, _node(body), description, self._span(c[0], c[-1]))

    def setting(self, c):
        after = {c[i].value: c[i + 1] for i in range(3, len(c) - 1, 2)}  # 'in' frame, 'about' frame
        return ast.Setting(c[0], _node(c[2]), after.get("in"), self._span(c[0], c[-1]), after.get("about"))

    def frame_at(self, c):
        return _Part("at", _node(c[1]), _head(c[0]), _end(c[1]))

    def frame_rotate(self, c):
        return _Part("rotate", _node(c[1]), _head(c[0]), _end(c[1]))

    def frame_decl(self, c):
        parts = {p.kind: p.value for p in c[2:]}
        return ast.Frame(c[1], parts.get("at"), parts.get("rotate"), parts.get("description"),
                         self._span(c[0], c[-1]))

    def body_decl(self, c):
        return ast.Body(tuple(c[2]), self._span(c[0], c[-1]))

    def _part(self, c, rigid):
        """part, port and rigid: keyword name description? ("{" statements "}")?"""
        description = c[2].value if len(c) > 2 and type(c[2]) is _Part else None
        statements = c[-2] if type(c[-1]) is Token else ()
        bodies = [s for s in statements if type(s) is ast.Body]
        frames = tuple(s for s in statements if type(s) in (ast.Frame, ast.For))
        part = ast.Part(c[1], rigid, bodies[0] if bodies else None, frames, description, self._span(c[0], c[-1]))
        return part, bodies, statements, description

    def part_decl(self, c):
        return self._part(c, rigid=False)[0]

    def rigid_decl(self, c):
        part, bodies, _, _ = self._part(c, rigid=True)
        return _Repeated(part, "body", bodies[1].span) if len(bodies) > 1 else part

    def port_decl(self, c):
        _, _, frames, description = self._part(c, rigid=False)
        return ast.Port(c[1], tuple(frames), description, self._span(c[0], c[-1]))

    def _block(self, c):
        """model, component, interact, scene: keyword name description? "{" statements "}" """
        return c[1], (c[2].value if type(c[2]) is _Part else None), tuple(c[-2]), self._span(c[0], c[-1])

    def model_decl(self, c):
        name, description, statements, span = self._block(c)
        return ast.Model("model", name, description, statements, span)

    def component_decl(self, c):
        name, description, statements, span = self._block(c)
        return ast.Model("component", name, description, statements, span)

    def interact_decl(self, c):
        return ast.Interact(*self._block(c))

    def scene_decl(self, c):
        return ast.Scene(*self._block(c))

    def connect_stmt(self, c):
        return ast.Connect(c[1], c[3], self._span(c[0], c[-1]))

    def joint_decl(self, c):
        parts = {p.kind: p.value for p in c[2:]}
        block = parts.get("block")
        return ast.Joint(c[1], parts.get("args", ()), tuple(block or ()), block is not None,
                         self._span(c[0], c[-1]))

    def joint_block(self, c):
        return _Part("block", c[1], _head(c[0]), c[-1].end_pos)

    def target(self, c):
        return _Part("target", (c[0], False), _head(c[0]), c[0].span.end)

    def der_target(self, c):
        return _Part("target", (c[2], True), _head(c[0]), c[-1].end_pos)

    def init_stmt(self, c):
        ref, derivative = c[1].value
        return ast.Init(ref, derivative, _node(c[3]), self._span(c[0], c[-1]))

    def prescribe_stmt(self, c):
        return ast.Prescribe(c[1], _node(c[3]), self._span(c[0], c[-1]))

    def force_decl(self, c):
        name = c[1] if len(c) == 5 else None
        return ast.Force(name, c[-2], c[-1].value, self._span(c[0], c[-1]))

    def sensor_decl(self, c):
        return ast.Sensor(c[1], c[3], c[4].value, self._span(c[0], c[-1]))

    def use_decl(self, c):
        args = c[4].value if len(c) > 4 and type(c[4]) is _Part else ()
        bindings = tuple(c[-2]) if type(c[-1]) is Token else ()
        return ast.Use(c[1], c[3], args, bindings, self._span(c[0], c[-1]))

    def binding(self, c):
        return ast.Binding(c[0], c[2], self._span(c[0], c[-1]))

    def start(self, c):
        # line 1, column 1 as such: Span.at would build the line table of the whole file for nothing
        return ast.File(self.source.path, tuple(c[0]), Span(self.source, 0, len(self.source.text), 1, 1))


def _pass_on(c):
    """A rule lark would inline that has one child (a statement kind, an argument): its value."""
    return c[0]


def _collect(c):
    """A rule lark would inline that repeats (statements and newlines, ``("," x)*``): its values in order."""
    if c and type(c[0]) is _List:
        items = c[0]
        items.extend(x for x in c[1:] if type(x) is not Token)
        return items
    return _List(x for x in c if type(x) is not Token)
