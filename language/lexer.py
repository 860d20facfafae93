"""Tokens of .mbs text for lark's LALR parser: one compiled regex per parser context, newline rules built in.

Why not lark's own contextual lexer: it cost 5-7 us per token (a BasicLexer per parser state, a LineCounter
fed per token, generic callbacks, a separate match for every blank, and our newline post-lexer as a second
generator on top); this one costs under 2. It keeps lark's *decisions* exactly and drops the overhead:

- Context. Which word a text is depends on where the parser is: after a number ``m`` is a unit, after ``=``
  a name; ``at`` is a keyword after a frame's name but a name where the parser takes no ``at``. As lark does,
  each parser state gets a scanner over only the terminals that state accepts, with the terminals ordered as
  lark orders them (first matching alternative wins, not the longest) and keywords folded into the regex
  terminal (NAME, UNIT) that would match them. So keywords, units and names come out exactly as before; the
  terminals themselves are read from grammar.lark, never repeated here.
- Errors. Text no scanner of the state matches is tried against all terminals, as lark does: a known token
  in the wrong place is an ``UnexpectedToken`` (the parser's words: "unexpected ')'; expected ..."), anything
  else an ``UnexpectedCharacters`` at that character.
- Newlines. Statements end at a newline or ';'. Newlines inside (...) and [...], repeated ones and those right
  after '{' are dropped here, so the grammar never sees blank lines. Like any lark lexer, ``lex`` restarts
  with a fresh bracket depth when the parser resumes after a syntax error.
- Position. ``lexer_state.line_ctr`` is kept current (offset, line, column) before every token is handed
  over, because error recovery in parser.py reads and moves it.

Ignored text (blanks, '#' comments, backslash-newline) is skipped by a possessive prefix of every scanner
regex rather than as separate tokens; this is the same as lark's behaviour because no other terminal can
start with a blank, '#' or a backslash (the one overlap, '\\r' of '\\r\\n', lark also gives to the blanks).
"""

from __future__ import annotations

import re

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedToken
from lark.lexer import Lexer, PatternRE, PatternStr

NEWLINE = "_NL"  # the statement separator; accepted in every parser state, like lark's postlex always_accept
OPENING = frozenset({"LPAR", "LSQB"})
CLOSING = frozenset({"RPAR", "RSQB"})
NEWLINE_VANISHES_AFTER = frozenset({NEWLINE, "LBRACE"})  # repeated newlines, and the one that opens a block

_new_token = str.__new__


def _lark_order(terminal):
    """The order in which lark tries terminals: priority, then the widest and longest pattern first."""
    return (-terminal.priority, -terminal.pattern.max_width, -len(terminal.pattern.value), terminal.name)


class _Scanner:
    """The terminals one parser state accepts, as one regex.

    ``match(text, pos)`` skips ignored text, then matches one token; ``lastgroup`` names its terminal.
    ``keywords[terminal]`` maps the keywords folded into a regex terminal to their own terminal names.
    ``allowed`` is what lark reports as expected when the text here is a token of another context.
    """

    __slots__ = ("match", "keywords", "allowed")

    def __init__(self, terminals, skip: str):
        terminals = sorted(terminals, key=_lark_order)
        regexes = [t for t in terminals if isinstance(t.pattern, PatternRE)]
        folded = set()
        self.keywords: dict[str, dict[str, str]] = {t.name: {} for t in terminals}
        for regex in regexes:
            pattern = re.compile(regex.pattern.to_regexp())
            for word in terminals:
                if not isinstance(word.pattern, PatternStr) or word.priority != regex.priority:
                    continue
                m = pattern.match(word.pattern.value)
                if m and m.group(0) == word.pattern.value:
                    self.keywords[regex.name][word.pattern.value] = word.name
                    if word.pattern.flags <= regex.pattern.flags:
                        folded.add(word.name)
        kept = [t for t in terminals if t.name not in folded]
        alternatives = "|".join(f"(?P<{t.name}>{t.pattern.to_regexp()})" for t in kept)
        self.match = re.compile(f"{skip}(?:{alternatives})").match
        self.allowed = {t.name for t in kept}


class _Scanners(dict):
    """Parser state -> its scanner, each made when the parser first is in that state: a model's text meets a
    fraction of the grammar's states, and compiling every state's regex took a tenth of the parse of the Iltis
    in a fresh process. States that accept the same terminals share one scanner."""

    def __init__(self, lexer: "MbsLexer", states):
        super().__init__()
        self._lexer, self._states, self._by_accepts = lexer, states, {}

    def __missing__(self, state) -> _Scanner:
        lexer = self._lexer
        accepts = frozenset(a for a in self._states[state] if a in lexer.terminals_by_name) | {NEWLINE}
        scanner = self._by_accepts.get(accepts)
        if scanner is None:
            scanner = self._by_accepts[accepts] = _Scanner([t for t in lexer._tokens if t.name in accepts],
                                                           lexer._skip)
        self[state] = scanner
        return scanner


def _all_scanners(lexer: "MbsLexer", states) -> dict:
    """Every state's scanner made at once (as the lexer did before it made them on first use): the reference the
    tests hold the lazy ones to."""
    scanners = _Scanners(lexer, states)
    for state in states:
        scanners[state]  # noqa: B018 (made by __missing__)
    return scanners


class MbsLexer(Lexer):
    """lark custom lexer (``Lark(..., lexer=MbsLexer)``), equivalent to lark's contextual lexer plus the
    newline rules of the language; see the module docstring."""

    __future_interface__ = 2  # lex(lexer_state, parser_state): we need the parser state for the context

    def __init__(self, lexer_conf):
        self.terminals_by_name = dict(lexer_conf.terminals_by_name)
        ignored = sorted((self.terminals_by_name[n] for n in lexer_conf.ignore), key=_lark_order)
        self._skip = "(?:%s)*+" % "|".join(t.pattern.to_regexp() for t in ignored)
        self._skip_match = re.compile(self._skip).match
        self._tokens = [t for t in lexer_conf.terminals if t.name not in lexer_conf.ignore]
        self._root = _Scanner(self._tokens, self._skip)
        self._states = None  # parse table states -> per state scanner, built on first use
        self._per_state: dict[int, _Scanner] = {}

    def _scanners(self, states) -> dict[int, _Scanner]:
        if self._states is not states:
            self._states = states
            self._per_state = _Scanners(self, states)
        return self._per_state

    def lex(self, lexer_state, parser_state):
        """Yield the tokens from ``lexer_state.line_ctr.char_pos`` on, reading the parser state per token.

        lark calls this anew (fresh bracket depth) whenever it resumes after a syntax error, so the position is
        read once here and only written afterwards.
        """
        text = lexer_state.text
        end_of_text = len(text) if isinstance(text, str) else text.end
        text = text if isinstance(text, str) else text.text
        counter = lexer_state.line_ctr
        pos, line, line_start = counter.char_pos, counter.line, counter.line_start_pos
        scanners = self._scanners(parser_state.parse_conf.states)
        state_stack = parser_state.state_stack
        depth, previous = 0, None
        while True:
            scanner = scanners[state_stack[-1]]
            m = scanner.match(text, pos, end_of_text)
            if m is None:
                skipped = self._skip_match(text, pos, end_of_text).end()
                line, line_start = _count_lines(text, pos, skipped, line, line_start)
                _store(counter, skipped, line, line_start)
                if skipped >= end_of_text:
                    return
                self._fail(lexer_state, parser_state, scanner, text, end_of_text)
            kind = m.lastgroup
            start, end = m.span(kind)
            if start != pos and text.count("\n", pos, start):  # a backslash continuation was skipped
                line, line_start = _count_lines(text, pos, start, line, line_start)
            value = m.group(kind)
            tok = _new_token(Token, value)
            tok.type = scanner.keywords[kind].get(value, kind)
            tok.value = value
            tok.start_pos, tok.end_pos = start, end
            tok.line = line
            tok.column = start - line_start + 1
            pos = end
            if kind == NEWLINE and value != ";":
                line, line_start = line + 1, end
            tok.end_line, tok.end_column = line, end - line_start + 1
            lexer_state.last_token = tok
            kind = tok.type
            if kind == NEWLINE:
                if depth or previous in NEWLINE_VANISHES_AFTER:
                    continue
            elif kind in OPENING:
                depth += 1
            elif kind in CLOSING and depth:
                depth -= 1
            previous = kind
            counter.char_pos, counter.line, counter.line_start_pos = pos, line, line_start
            counter.column = pos - line_start + 1
            yield tok

    def _fail(self, lexer_state, parser_state, scanner, text, end_of_text):
        """No terminal of this context matches: a token of another context, or a character of none."""
        counter = lexer_state.line_ctr
        pos = counter.char_pos
        last = lexer_state.last_token
        m = self._root.match(text, pos, end_of_text)
        if m is None:
            raise UnexpectedCharacters(text, pos, counter.line, counter.column, allowed=scanner.allowed,
                                       state=parser_state, token_history=last and [last],
                                       terminals_by_name=self.terminals_by_name)
        kind = m.lastgroup
        value = m.group(kind)
        tok = Token(self._root.keywords[kind].get(value, kind), value, pos, counter.line, counter.column)
        line, line_start = counter.line, counter.line_start_pos
        if kind == NEWLINE and value != ";":
            line, line_start = line + 1, m.end()
        _store(counter, m.end(), line, line_start)
        tok.end_pos, tok.end_line, tok.end_column = counter.char_pos, counter.line, counter.column
        lexer_state.last_token = tok
        raise UnexpectedToken(tok, scanner.allowed, state=parser_state, token_history=[last],
                              terminals_by_name=self.terminals_by_name)


def _count_lines(text: str, start: int, end: int, line: int, line_start: int) -> tuple[int, int]:
    """(line, offset of its first character) after skipping text[start:end] (backslash continuations)."""
    newlines = text.count("\n", start, end)
    if newlines:
        return line + newlines, text.rindex("\n", start, end) + 1
    return line, line_start


def _store(counter, pos: int, line: int, line_start: int) -> None:
    counter.char_pos, counter.line, counter.line_start_pos = pos, line, line_start
    counter.column = pos - line_start + 1
