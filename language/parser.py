"""Source text -> AST, with every syntax error of a file reported as a located diagnostic.

lark does the parsing (LALR, contextual lexer, grammar in grammar.lark). This module owns three things lark
does not: the newline rules (a post-lexer), the translation of lark's exceptions into our own words
(terminal names become "a name", "'{'"; long "expected one of" lists are capped), and recovery, so that one
run reports all syntax errors of a file rather than the first.
"""

from __future__ import annotations

import functools
from pathlib import Path

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from . import ast
from .diagnostics import Diagnostics, MbsError, Source, Span

GRAMMAR_FILE = Path(__file__).with_name("grammar.lark")
MAX_SYNTAX_ERRORS = 20  # beyond this, recovery mostly reports consequences of earlier errors

_BRACKETS_OPEN = {"LPAR", "LSQB"}
_BRACKETS_CLOSE = {"RPAR", "RSQB"}


class _NewlinePostLexer:
    """Statements end at newlines, except inside (...) and [...]; blank lines and leading ones vanish."""

    always_accept = ("_NL",)

    def process(self, stream):
        depth = 0
        previous = None
        for tok in stream:
            if tok.type == "_NL":
                if depth > 0 or previous in ("_NL", "LBRACE"):
                    continue
            elif tok.type in _BRACKETS_OPEN:
                depth += 1
            elif tok.type in _BRACKETS_CLOSE:
                depth = max(0, depth - 1)
            previous = tok.type
            yield tok


@functools.lru_cache(maxsize=1)
def _lark() -> Lark:
    return Lark(GRAMMAR_FILE.read_text(), parser="lalr", lexer="contextual", postlex=_NewlinePostLexer(),
                start=["start", "expr_only"], propagate_positions=True, maybe_placeholders=False,
                cache=False)


# ------------------------------------------------------------------------------------------ lark -> AST
class _ToAst(Transformer):
    """Mechanical translation of lark trees into ast dataclasses (STYLE.md point 5)."""

    def __init__(self, source: Source):
        super().__init__()
        self.source = source

    def _span(self, meta) -> Span:
        if getattr(meta, "empty", True):
            return Span.at(self.source, 0, 0)
        return Span.at(self.source, meta.start_pos, meta.end_pos)

    def _tok_span(self, tok: Token) -> Span:
        return Span.at(self.source, tok.start_pos, tok.end_pos)

    # -- names
    @v_args(meta=True)
    def ident(self, meta, children):
        tok = children[0]
        return ast.Ident(str(tok), self._tok_span(tok))

    @v_args(meta=True)
    def ref(self, meta, children):
        return ast.Ref(tuple(children), self._span(meta))

    dotted = ref

    @v_args(meta=True)
    def dotted_ident(self, meta, children):
        """Dotted names are allowed where a scene overrides a parameter of a component instance."""
        return ast.Ident(".".join(c.text for c in children), self._span(meta))

    def description(self, children):
        return _unquote(children[0])

    # -- expressions
    @v_args(meta=True)
    def number(self, meta, children):
        return ast.Number(str(children[0]), None, self._span(meta))

    @v_args(meta=True)
    def quantity(self, meta, children):
        num, unit = children
        return ast.Number(str(num), str(unit), self._span(meta), self._tok_span(unit))

    @v_args(meta=True)
    def _with_unit(self, meta, children):
        expr, unit = children
        return ast.WithUnit(expr, str(unit), self._span(meta), self._tok_span(unit))

    quantity_call = quantity_paren = quantity_vector = quantity_matrix = _with_unit

    @v_args(meta=True)
    def name(self, meta, children):
        return ast.Name(children[0], self._span(meta))

    @v_args(meta=True)
    def string(self, meta, children):
        return ast.String(_unquote(children[0]), self._span(meta))

    @v_args(meta=True)
    def call(self, meta, children):
        func, *args = children
        positional = tuple(a for a in args if not isinstance(a, ast.Kwarg))
        keywords = tuple(a for a in args if isinstance(a, ast.Kwarg))
        return ast.Call(func, positional, keywords, self._span(meta))

    @v_args(meta=True)
    def kwarg(self, meta, children):
        return ast.Kwarg(children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def arglist(self, meta, children):
        return tuple(children)

    @v_args(meta=True)
    def vector(self, meta, children):
        return ast.Vector(tuple(children), self._span(meta))

    @v_args(meta=True)
    def matrix(self, meta, children):
        return ast.Matrix(tuple(children), self._span(meta))

    @v_args(meta=True)
    def unary(self, meta, children):
        op, operand = children
        return ast.Unary(str(op), operand, self._span(meta))

    @v_args(meta=True)
    def not_op(self, meta, children):
        return ast.Unary("not", children[0], self._span(meta))

    @v_args(meta=True)
    def binop(self, meta, children):
        left, op, right = children
        return ast.Binary(str(op), left, right, self._span(meta))

    compare = binop

    @v_args(meta=True)
    def pow_op(self, meta, children):
        return ast.Binary("^", children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def and_op(self, meta, children):
        return ast.Binary("and", children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def or_op(self, meta, children):
        return ast.Binary("or", children[0], children[1], self._span(meta))

    def expr_only(self, children):
        return children[0]

    # -- declarations
    @v_args(meta=True)
    def import_decl(self, meta, children):
        return ast.Import(children[0], children[1] if len(children) > 1 else None, self._span(meta))

    @v_args(meta=True)
    def param_decl(self, meta, children):
        return ast.Param(children[0], children[1], _opt(children, 2), self._span(meta))

    @v_args(meta=True)
    def input_decl(self, meta, children):
        return ast.Input(children[0], children[1], _opt(children, 2), self._span(meta))

    @v_args(meta=True)
    def output_decl(self, meta, children):
        name, rest = children[0], children[1:]
        description = rest.pop() if rest and isinstance(rest[-1], str) else None
        return ast.Output(name, rest[0] if rest else None, description, self._span(meta))

    @v_args(meta=True)
    def func_decl(self, meta, children):
        description = children.pop() if isinstance(children[-1], str) else None
        name, *params, body = children
        return ast.Func(name, tuple(params), body, description, self._span(meta))

    @v_args(meta=True)
    def setting(self, meta, children):
        return ast.Setting(children[0], children[1], _opt(children, 2), self._span(meta))

    def frame_at(self, children):
        return ("at", children[0])

    def frame_rotate(self, children):
        return ("rotate", children[0])

    @v_args(meta=True)
    def frame_decl(self, meta, children):
        name, rest = children[0], list(children[1:])
        description = rest.pop() if rest and isinstance(rest[-1], str) else None
        parts = dict(rest)
        return ast.Frame(name, parts.get("at"), parts.get("rotate"), description, self._span(meta))

    @v_args(meta=True)
    def body_decl(self, meta, children):
        return ast.Body(tuple(children), self._span(meta))

    def _part(self, meta, children, rigid):
        name, rest = children[0], list(children[1:])
        description = rest.pop(0) if rest and isinstance(rest[0], str) else None
        bodies = [c for c in rest if isinstance(c, ast.Body)]
        frames = tuple(c for c in rest if isinstance(c, ast.Frame))
        return ast.Part(name, rigid, bodies[0] if bodies else None, frames, description, self._span(meta)), bodies

    @v_args(meta=True)
    def part_decl(self, meta, children):
        return self._part(meta, children, rigid=False)[0]

    @v_args(meta=True)
    def rigid_decl(self, meta, children):
        part, bodies = self._part(meta, children, rigid=True)
        if len(bodies) > 1:
            return _Repeated(part, "body", bodies[1].span)
        return part

    @v_args(meta=True)
    def port_decl(self, meta, children):
        name, rest = children[0], list(children[1:])
        description = rest.pop(0) if rest and isinstance(rest[0], str) else None
        return ast.Port(name, tuple(rest), description, self._span(meta))

    @v_args(meta=True)
    def connect_stmt(self, meta, children):
        return ast.Connect(children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def target(self, meta, children):
        return (children[0], False)

    @v_args(meta=True)
    def der_target(self, meta, children):
        return (children[0], True)

    @v_args(meta=True)
    def init_stmt(self, meta, children):
        (ref, derivative), value = children
        return ast.Init(ref, derivative, value, self._span(meta))

    @v_args(meta=True)
    def prescribe_stmt(self, meta, children):
        return ast.Prescribe(children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def joint_decl(self, meta, children):
        kind, rest = children[0], list(children[1:])
        args = rest.pop(0) if rest and isinstance(rest[0], tuple) else ()
        block = rest[0] if rest else None
        return ast.Joint(kind, args, tuple(block or ()), block is not None, self._span(meta))

    def joint_block(self, children):
        return list(children)

    @v_args(meta=True)
    def force_decl(self, meta, children):
        if len(children) == 3:
            return ast.Force(children[0], children[1], children[2], self._span(meta))
        return ast.Force(None, children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def sensor_decl(self, meta, children):
        return ast.Sensor(children[0], children[1], children[2], self._span(meta))

    @v_args(meta=True)
    def interact_decl(self, meta, children):
        name, rest = children[0], list(children[1:])
        description = rest.pop(0) if rest and isinstance(rest[0], str) else None
        return ast.Interact(name, description, tuple(rest), self._span(meta))

    @v_args(meta=True)
    def binding(self, meta, children):
        return ast.Binding(children[0], children[1], self._span(meta))

    @v_args(meta=True)
    def use_decl(self, meta, children):
        component, alias, rest = children[0], children[1], list(children[2:])
        args = rest.pop(0) if rest and isinstance(rest[0], tuple) else ()
        return ast.Use(component, alias, args, tuple(rest), self._span(meta))

    def _model(self, meta, children, kind):
        name, rest = children[0], list(children[1:])
        description = rest.pop(0) if rest and isinstance(rest[0], str) else None
        return ast.Model(kind, name, description, tuple(rest), self._span(meta))

    @v_args(meta=True)
    def model_decl(self, meta, children):
        return self._model(meta, children, "model")

    @v_args(meta=True)
    def component_decl(self, meta, children):
        return self._model(meta, children, "component")

    @v_args(meta=True)
    def scene_decl(self, meta, children):
        name, rest = children[0], list(children[1:])
        description = rest.pop(0) if rest and isinstance(rest[0], str) else None
        return ast.Scene(name, description, tuple(rest), self._span(meta))

    @v_args(meta=True)
    def start(self, meta, children):
        return ast.File(self.source.path, tuple(children), Span.at(self.source, 0, len(self.source.text)))


class _Repeated:
    """Marker for a construct the grammar accepts but the language forbids (a second body)."""

    def __init__(self, node, what, span):
        self.node, self.what, self.span = node, what, span


def _opt(children, index):
    return children[index] if len(children) > index else None


def _unquote(tok) -> str:
    return str(tok)[1:-1].replace('\\"', '"').replace("\\\\", "\\")


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
        self.reported: set[int] = set()

    def report(self, err: UnexpectedInput) -> None:
        if id(err) not in self.reported:
            self.reported.add(id(err))
            self.count += 1
            _syntax_diagnostic(err, self.source, self.diags)

    def __call__(self, err: UnexpectedInput) -> bool:
        self.report(err)
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
    try:
        tree = _lark().parse(source.text, start="start", on_error=recovery)
    except UnexpectedInput as err:
        recovery.report(err)
    if recovery.count:
        raise MbsError(diags.items)
    result = _ToAst(source).transform(tree)
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
    diags = Diagnostics()
    try:
        tree = _lark().parse(text, start="expr_only")
    except UnexpectedInput as err:
        _syntax_diagnostic(err, source, diags)
        raise MbsError(diags.items) from None
    return _ToAst(source).transform(tree)


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
