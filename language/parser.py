"""Source text -> AST, with every syntax error of a file reported as a located diagnostic.

lark does the parsing (LALR, grammar in grammar.lark) with our lexer (lexer.py: the parser-context rules for
keywords and units, and the newline rules). This module owns three things lark does not: building the AST
(by the functions of build.py, one per grammar rule, which lark's LALR loop calls while it parses), the
translation of lark's exceptions into our own words (terminal names become "a name", "'{'"; long "expected
one of" lists are capped), and recovery, so that one run reports all syntax errors of a file rather than the
first.
"""
from __future__ import annotations

import contextlib
import functools
import gc
import os
from pathlib import Path

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from . import ast
from .build import _AstBuilder, _collect, _pass_on, _Repeated
from .diagnostics import Diagnostics, MbsError, Source, Span
from .lexer import MbsLexer

GRAMMAR_FILE = Path(__file__).with_name("grammar.lark")
MAX_SYNTAX_ERRORS = 20  # beyond this, recovery mostly reports consequences of earlier errors


@functools.lru_cache(maxsize=1)
def _lark() -> Lark:
    grammar = GRAMMAR_FILE.read_text()
    final = _table_cache(grammar)
    fresh = final is not None and not final.exists()
    cache = False if final is None else str(final.with_name(f".{final.name}.{os.getpid()}.tmp") if fresh else final)
    lark = Lark(grammar, parser="lalr", lexer=MbsLexer, start=["start", "expr_only"],
                maybe_placeholders=False, cache=cache)
    if fresh and os.path.exists(cache):
        os.replace(cache, final)  # lark writes in place; readers in other processes see the whole file or none
    # lark names rules by Tokens, whose Python-level __eq__ then runs in the goto lookup after every
    # reduction (~8 % of parsing); plain strings are equal and hash the same.
    for rule in lark.rules:
        rule.origin.name = str(rule.origin.name)
    return lark


def _table_cache(grammar: str) -> Path | None:
    """The file lark keeps its LALR tables in (building them is most of a small model's check time), named by
    the hash of the grammar and lark's version, so a changed grammar gets a new file; None when the cache folder
    cannot be made."""
    import hashlib

    import lark as lark_module

    from mbs.base.cachedir import default_cache_dir
    key = hashlib.sha256(f"{grammar}\0{lark_module.__version__}".encode()).hexdigest()[:24]
    try:
        folder = default_cache_dir() / "parser"
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder / f"grammar-{key}.lark-tables"


# ------------------------------------------------------------------------------------------ lark -> AST
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
def without_cycle_collection():
    """A parse (and the validation after it) allocates about ten objects per token and frees few, so Python's
    cycle collector would walk the growing AST again and again: a third of the time for a 14k-line file.
    Nothing built here forms a cycle, so collection waits until the work is over; nesting is harmless."""
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
    with without_cycle_collection():
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
