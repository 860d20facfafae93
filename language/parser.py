"""Source text -> AST, with every syntax error of a file reported as a located diagnostic.

lark does the parsing (LALR, grammar in grammar.lark) with our lexer (lexer.py: the parser-context rules for
keywords and units, and the newline rules). This module owns three things lark does not: building the AST,
the translation of lark's exceptions into our own words (terminal names become "a name", "'{'"; long
"expected one of" lists are capped), and recovery, so that one run reports all syntax errors of a file
rather than the first.

The AST is built while parsing, by our own function for each grammar rule, called by lark's LALR loop with
the rule's raw children (keywords and punctuation included, so spans come from the tokens). lark's tree
builder with positions followed by a Transformer walk cost a tree node per reduction and a second pass, more
than half of the front end's time on a large model.
"""

from __future__ import annotations

import contextlib
import functools
import gc
from pathlib import Path

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from . import ast
from .diagnostics import Diagnostics, MbsError, Source, Span
from .lexer import MbsLexer

GRAMMAR_FILE = Path(__file__).with_name("grammar.lark")
MAX_SYNTAX_ERRORS = 20  # beyond this, recovery mostly reports consequences of earlier errors


@functools.lru_cache(maxsize=1)
def _lark() -> Lark:
    lark = Lark(GRAMMAR_FILE.read_text(), parser="lalr", lexer=MbsLexer, start=["start", "expr_only"],
                maybe_placeholders=False, cache=False)
    # lark names rules by Tokens, whose Python-level __eq__ then runs in the goto lookup after every
    # reduction (~8 % of parsing); plain strings are equal and hash the same.
    for rule in lark.rules:
        rule.origin.name = str(rule.origin.name)
    return lark


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

    def _span(self, first, last) -> Span:
        start, line, col = _head(first)
        return Span(self.source, start, _end(last), line, col)

    def _tok_span(self, tok: Token) -> Span:
        return Span(self.source, tok.start_pos, tok.end_pos, tok.line, tok.column)

    def _climb(self, items: _Chain):
        """The tree of a flat operand, operator, operand, ... list, by precedence climbing."""
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

    dotted = ref

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
            return self._climb(_Chain([value]) if kind is _Prefix else value)
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
        return ast.Setting(c[0], _node(c[2]), c[4] if len(c) > 3 else None, self._span(c[0], c[-1]))

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
        frames = tuple(s for s in statements if type(s) is ast.Frame)
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


@functools.lru_cache(maxsize=1)
def _reductions() -> tuple[dict, tuple]:
    """lark's rules with how each is reduced: rules lark would inline (names starting with '_') by a generic
    function, the others by the _AstBuilder method named after the rule or its alias."""
    rules = _lark().rules
    generic, named = {}, []
    by_origin: dict[str, list] = {}
    for rule in rules:
        by_origin.setdefault(rule.origin.name, []).append(rule)
    for origin, alternatives in by_origin.items():
        if origin.startswith("_"):
            single = all(len(r.expansion) == 1 and not r.expansion[0].is_term for r in alternatives)
            generic.update((r, _pass_on if single else _collect) for r in alternatives)
        else:
            for r in alternatives:
                name = r.alias or origin
                if not callable(getattr(_AstBuilder, name, None)):
                    raise RuntimeError(f"grammar rule {name!r} has no _AstBuilder method")
                named.append((r, name))
    return generic, tuple(named)


@contextlib.contextmanager
def _without_cycle_collection():
    """A parse allocates about ten objects per token and frees few, so Python's cycle collector would walk
    the growing AST again and again: a third of the parse time of a 14k-line file. Nothing built here forms
    a cycle, so collection waits until the parse is over."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _start_parse(source: Source, start: str):
    """A lark interactive parser over the source, building our AST."""
    generic, named = _reductions()
    builder = _AstBuilder(source)
    callbacks = dict(generic)
    callbacks.update((rule, getattr(builder, name)) for rule, name in named)
    parser = _lark().parse_interactive(source.text, start=start)
    parser.parser_state.parse_conf.callbacks = callbacks  # a fresh ParseConf per parse: nothing shared
    return parser


# ------------------------------------------------------------------------------------------ errors
_TERMINAL_WORDS = {
    "NAME": "a name", "NUMBER": "a number", "STRING": "a string", "UNIT": "a unit", "_NL": "end of statement",
    "LBRACE": "'{'", "RBRACE": "'}'", "LPAR": "'('", "RPAR": "')'", "LSQB": "'['", "RSQB": "']'",
    "COMMA": "','", "DOT": "'.'", "EQUAL": "'='", "COMP_OP": "a comparison", "ADD_OP": "'+' or '-'",
    "MUL_OP": "'*' or '/'", "CIRCUMFLEX": "'^'", "$END": "end of file", "__ANON_0": "'->'",
}
MAX_EXPECTED_SHOWN = 6


def _describe_terminal(name: str) -> str:
    if name in _TERMINAL_WORDS:
        return _TERMINAL_WORDS[name]
    if name.isupper() and not name.startswith("_"):
        return f"'{name.lower()}'"  # keywords: lark names them by their text in upper case
    return name.lower()


def _describe_token(tok: Token) -> str:
    if tok.type == "$END":
        return "end of file"
    if tok.type == "_NL":
        return "end of line" if str(tok) != ";" else "';'"
    return f"'{tok}'"


def _expected_list(expected) -> str:
    words = sorted({_describe_terminal(t) for t in expected if t not in ("_NL",)} or {"end of statement"})
    if len(words) > MAX_EXPECTED_SHOWN:
        words = words[:MAX_EXPECTED_SHOWN] + ["..."]
    return ", ".join(words)


def _syntax_diagnostic(err: UnexpectedInput, source: Source, diags: Diagnostics) -> int:
    """Report one lark error; return the offset at which the offending text starts."""
    if isinstance(err, UnexpectedCharacters):
        ch = source.text[err.pos_in_stream] if err.pos_in_stream < len(source.text) else ""
        what = f"unexpected character {ch!r}" if ch.isprintable() else f"unexpected character {ch!r} (not text)"
        diags.error(what, Span.at(source, err.pos_in_stream, err.pos_in_stream + 1))
        return err.pos_in_stream
    if isinstance(err, UnexpectedToken):
        tok = err.token
        start = tok.start_pos if tok.start_pos is not None else len(source.text)
        end = tok.end_pos if tok.end_pos is not None else start
        if tok.type == "$END":
            start = end = len(source.text.rstrip())
        if tok.type == "_NL":
            end = start + 1 if str(tok) == ";" else start
        message = f"unexpected {_describe_token(tok)}; expected {_expected_list(err.expected)}"
        if tok.type == "$END":
            message = f"unexpected end of file; expected {_expected_list(err.expected)} (is a '}}' missing?)"
        diags.error(message, Span.at(source, start, max(end, start + (0 if tok.type == '$END' else 1))))
        return start
    if isinstance(err, UnexpectedEOF):
        end = len(source.text.rstrip())
        diags.error(f"unexpected end of file; expected {_expected_list(err.expected)}", Span.at(source, end, end))
        return end
    diags.error("syntax error", Span.at(source, 0, 0))
    return 0


class _PanicRecovery:
    """Classic yacc-style recovery: after an error, skip to the end of the statement and pop parser
    states until one can continue there; so one run reports every syntax error of a file."""

    def __init__(self, source: Source, diags: Diagnostics):
        self.source, self.diags, self.count = source, diags, 0

    def parse(self, parser):
        """Run the interactive parser to the end of the text; None if it had to give up."""
        while True:
            try:
                return parser.resume_parse()
            except UnexpectedInput as err:
                self.count += 1
                _syntax_diagnostic(err, self.source, self.diags)
                if not self.recover(err):
                    return None

    def recover(self, err: UnexpectedInput) -> bool:
        """Move lexer and parser to the end of the erroneous statement; False where that is not possible."""
        if self.count >= MAX_SYNTAX_ERRORS:
            return False
        parser = getattr(err, "interactive_parser", None)
        if parser is None or (isinstance(err, UnexpectedToken) and err.token.type == "$END"):
            return False
        lexer_state = parser.lexer_thread.state
        here = lexer_state.line_ctr.char_pos
        if isinstance(err, UnexpectedToken) and err.token.type in ("_NL", "RBRACE"):
            stop, kind = err.token.start_pos, err.token.type
        else:
            stop, kind = _statement_end(self.source.text, here + (1 if isinstance(err, UnexpectedCharacters) else 0))
            if kind is None:
                return False
        # Move the lexer to the statement end; pop parser states until one can continue there.
        if stop > here:
            lexer_state.line_ctr.feed(lexer_state.text.text[here:stop])
        else:
            lexer_state.line_ctr = _rewound(lexer_state.line_ctr, self.source.text, stop)
        state = parser.parser_state
        while len(state.state_stack) > 1 and kind not in parser.accepts():
            state.state_stack.pop()
            state.value_stack.pop()
        return kind in parser.accepts()


def _rewound(line_ctr, text, pos):
    """A fresh line counter at pos (the token that failed was already consumed by the lexer)."""
    from lark.lexer import LineCounter
    counter = LineCounter(line_ctr.newline_char)
    counter.feed(text[:pos])
    return counter


def _statement_end(text: str, pos: int) -> tuple[int, str | None]:
    """Offset and token kind of the end of the statement holding pos, skipping brackets, strings, comments."""
    for respect_brackets in (True, False):
        depth, i = 0, pos
        while i < len(text):
            c = text[i]
            if c == '"':
                close = text.find('"', i + 1)
                i = len(text) if close < 0 else close + 1
                continue
            if c == "#":
                nl = text.find("\n", i)
                i = len(text) if nl < 0 else nl
                continue
            if c in "([{" and respect_brackets:
                depth += 1
            elif c in ")]}" and respect_brackets and depth > 0:
                depth = max(0, depth - 1)
            elif c in "\n;" and depth == 0:
                return i, "_NL"
            elif c == "}" and depth == 0:
                return i, "RBRACE"
            i += 1
    return len(text), None


# ------------------------------------------------------------------------------------------ entry points
def parse_source(source: Source, diags: Diagnostics | None = None) -> ast.File:
    """Parse a whole file; raise MbsError with all syntax errors found."""
    diags = diags if diags is not None else Diagnostics()
    recovery = _PanicRecovery(source, diags)
    with _without_cycle_collection():
        result = recovery.parse(_start_parse(source, "start"))
    if recovery.count:
        raise MbsError(diags.items)
    _report_repeated(result, diags)
    return result


def _report_repeated(file: ast.File, diags: Diagnostics) -> None:
    def walk(items):
        for item in items:
            if isinstance(item, _Repeated):
                diags.error(f"a rigid part has one {item.what}; this is a second one", item.span)
            elif isinstance(item, ast.Model):
                walk(item.statements)
    walk(file.items)
    if diags.error_count:
        raise MbsError(diags.items)


def parse_text(text: str, path: str = "<string>") -> ast.File:
    return parse_source(Source(path, text))


def parse_expression(text: str, path: str = "<expr>") -> ast.Expr:
    """Parse one expression (used by tests and by command-line overrides such as --param m=2kg)."""
    source = Source(path, text)
    try:
        return _start_parse(source, "expr_only").resume_parse()
    except UnexpectedInput as err:
        diags = Diagnostics()
        _syntax_diagnostic(err, source, diags)
        raise MbsError(diags.items) from None


def read_source(path: str | Path, shown_path: str | None = None) -> Source:
    """Read a model file as text; undecodable bytes become a located error, not a traceback."""
    p = Path(path)
    shown = shown_path or str(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        diags = Diagnostics()
        diags.error(f"cannot read file: {exc.strerror or exc}", None)
        raise MbsError([_prefix_path(d, shown) for d in diags.items]) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        source = Source(shown, raw.decode("utf-8", errors="replace"))
        diags = Diagnostics()
        diags.error("file is not UTF-8 text (byte 0x%02x)" % raw[exc.start], Span.at(source, exc.start, exc.start + 1))
        raise MbsError(diags.items) from None
    if "\x00" in text:
        source = Source(shown, text.replace("\x00", " "))
        pos = text.index("\x00")
        diags = Diagnostics()
        diags.error("file contains a NUL byte: is it a binary file?", Span.at(source, pos, pos + 1))
        raise MbsError(diags.items) from None
    return Source(shown, text)


def _prefix_path(diag, path):
    from dataclasses import replace
    return replace(diag, message=f"{path}: {diag.message}")


def comments_of(source: Source) -> list[tuple[int, int, str]]:
    """Every '#' comment as (offset, line, text), for the formatter (the grammar ignores them)."""
    out = []
    text = source.text
    i, in_string = 0, False
    while i < len(text):
        c = text[i]
        if in_string:
            if c == "\\":
                i += 2
                continue
            if c == '"' or c == "\n":
                in_string = False
        elif c == '"':
            in_string = True
        elif c == "#":
            end = text.find("\n", i)
            end = len(text) if end < 0 else end
            out.append((i, source.position(i)[0], text[i:end].rstrip()))
            i = end
            continue
        i += 1
    return out
