"""The lexer alone: which text becomes which token where, newline rules, positions, lexical errors.

The lexer decides by parser context (a word after a number is a unit, after '=' a name), so the tokens of a
fragment are read by running the parser over it. The last tests check it against lark's own contextual
lexer with the newline rules it replaced, token by token, on every shipped model.
"""

import pytest
from lark import Lark
from lark.exceptions import UnexpectedInput

from mbs.language.diagnostics import MbsError
from mbs.language.parser import GRAMMAR_FILE, _lark, parse_expression, parse_text
from tests.conftest import SHIPPED_MODELS


def tokens(text: str, start: str = "expr_only", parser: Lark | None = None) -> list[tuple[str, str]]:
    run = (parser or _lark()).parse_interactive(text, start=start)
    return [(t.type, t.value) for t in run.iter_parse()]


def in_body(line: str) -> str:
    return "model m {\n    rigid r {\n        body {\n            %s\n        }\n    }\n}\n" % line


def test_a_unit_is_one_token_written_without_spaces():
    assert tokens("2 m*x") == [("NUMBER", "2"), ("UNIT", "m*x")]
    assert tokens("2 m * x") == [("NUMBER", "2"), ("UNIT", "m"), ("MUL_OP", "*"), ("NAME", "x")]
    assert tokens("35906 N/m") == [("NUMBER", "35906"), ("UNIT", "N/m")]
    assert tokens("10 km/h") == [("NUMBER", "10"), ("UNIT", "km/h")]
    assert tokens("5 1/s") == [("NUMBER", "5"), ("UNIT", "1/s")]


def test_a_unit_may_follow_a_vector_a_call_or_a_parenthesised_expression():
    assert tokens("(0, 0, -9.81) m/s^2") == [
        ("LPAR", "("), ("NUMBER", "0"), ("COMMA", ","), ("NUMBER", "0"), ("COMMA", ","), ("ADD_OP", "-"),
        ("NUMBER", "9.81"), ("RPAR", ")"), ("UNIT", "m/s^2")]
    assert tokens("diag(1, 2, 3) kg*m^2")[-2:] == [("RPAR", ")"), ("UNIT", "kg*m^2")]
    assert tokens("(a) m")[-1] == ("UNIT", "m")
    assert tokens("[1, 2] deg")[-1] == ("UNIT", "deg")


def test_after_a_closing_parenthesis_a_keyword_the_parser_takes_stays_a_keyword():
    frame = tokens("model m {\n  part p {\n    frame f at (0,0,0) rotate axis_angle(x, 30 deg)\n  }\n}\n", "start")
    words = [t for t in frame if t[1] in ("at", "rotate", "axis_angle", "x", "deg")]
    assert words == [("AT", "at"), ("ROTATE", "rotate"), ("NAME", "axis_angle"), ("NAME", "x"), ("UNIT", "deg")]
    inertia = tokens(in_body("inertia = diag(1,2,3) kg*m^2 in arm"), "start")
    assert ("UNIT", "kg*m^2") in inertia and ("IN", "in") in inertia and ("NAME", "arm") in inertia
    assert tokens("(a) and b")[3] == ("AND", "and")
    assert tokens("f(x) or y")[4] == ("OR", "or")


def test_keywords_are_names_where_the_parser_takes_no_keyword():
    assert tokens("model at {\n}\n", "start")[1] == ("NAME", "at")
    assert tokens("rotate + in")[::2] == [("NAME", "rotate"), ("NAME", "in")]


def test_comparisons_and_arrows():
    assert tokens("a < b") == [("NAME", "a"), ("COMP_OP", "<"), ("NAME", "b")]
    assert tokens("a <= -b")[1:3] == [("COMP_OP", "<="), ("ADD_OP", "-")]
    connect = tokens("model m {\n  interact i {\n    connect a.b -> c\n  }\n}\n", "start")
    assert ("__ANON_0", "->") in connect


def test_newlines_end_statements_except_in_brackets_after_braces_and_in_runs():
    text = "model m {\n\n  param a = (1,\n    2)\n\n\n  param b = [3,\n 4]; param c = 5 # note\n}\n"
    kinds = [k for k, _ in tokens(text, "start")]
    assert kinds == ["MODEL", "NAME", "LBRACE",
                     "PARAM", "NAME", "EQUAL", "LPAR", "NUMBER", "COMMA", "NUMBER", "RPAR", "_NL",
                     "PARAM", "NAME", "EQUAL", "LSQB", "NUMBER", "COMMA", "NUMBER", "RSQB", "_NL",
                     "PARAM", "NAME", "EQUAL", "NUMBER", "_NL", "RBRACE", "_NL"]


def test_backslash_newline_continues_a_statement_and_positions_follow_the_lines():
    text = "model m {\n  param a = 1 + \\\n    2\n}\n"
    toks = list(_lark().parse_interactive(text, start="start").iter_parse())
    two = next(t for t in toks if t == "2")
    assert [t.type for t in toks].count("_NL") == 2  # after the statement and after '}', none in between
    assert (two.line, two.column, two.end_line, two.end_column) == (3, 5, 3, 6)
    assert (two.start_pos, two.end_pos) == (text.index("2"), text.index("2") + 1)
    newline = toks[toks.index(two) + 1]
    assert (newline.type, newline.line, newline.end_line, newline.end_column) == ("_NL", 3, 4, 1)


@pytest.mark.parametrize("text, message, col", [
    ('model m {\n  param a = "abc\n}\n', "unexpected character '\"'", 13),
    ("model m {\n  param a = 1 \x00\n}\n", "unexpected character '\\x00' (not text)", 15),
    ("model m {\n  param a = 1 \\ 2\n}\n", "unexpected character '\\\\'", 15),
    ("model m {\n  param a = 2 $\n}\n", "unexpected character '$'", 15),
])
def test_text_no_terminal_matches_is_a_located_error(text, message, col):
    with pytest.raises(MbsError) as err:
        parse_text(text, "x.mbs")
    first = err.value.diagnostics[0]
    assert (first.message, first.span.line, first.span.col) == (message, 2, col)


def test_a_token_of_another_context_is_reported_as_that_token():
    with pytest.raises(MbsError) as err:
        parse_expression("1 + )")
    assert err.value.diagnostics[0].message.startswith("unexpected ')'; expected '('")


# ------------------------------------------------------------------------------------------ oracle
class _NewlineRules:
    """The post-lexer the lexer replaced, kept here as the oracle's newline rules."""

    always_accept = ("_NL",)

    def process(self, stream):
        depth, previous = 0, None
        for tok in stream:
            if tok.type == "_NL":
                if depth > 0 or previous in ("_NL", "LBRACE"):
                    continue
            elif tok.type in ("LPAR", "LSQB"):
                depth += 1
            elif tok.type in ("RPAR", "RSQB"):
                depth = max(0, depth - 1)
            previous = tok.type
            yield tok


@pytest.fixture(scope="module")
def lark_contextual() -> Lark:
    return Lark(GRAMMAR_FILE.read_text(), parser="lalr", lexer="contextual", postlex=_NewlineRules(),
                start=["start", "expr_only"], maybe_placeholders=False)


def positioned(text: str, parser: Lark) -> list[tuple]:
    """Every token with its position, then the kind and offset of the error that ended the stream, if any."""
    run = parser.parse_interactive(text, start="start")
    out = []
    try:
        for t in run.iter_parse():
            out.append((t.type, t.value, t.start_pos, t.end_pos, t.line, t.column, t.end_line, t.end_column))
    except UnexpectedInput as err:
        out.append((type(err).__name__, err.pos_in_stream, sorted(getattr(err, "expected", ()) or ())))
    return out


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.name)
def test_tokens_are_those_of_lark_contextual_lexer_on_every_shipped_model(path, lark_contextual):
    text = path.read_text()
    assert positioned(text, _lark()) == positioned(text, lark_contextual)


@pytest.mark.parametrize("text", [
    "model m {\n  param a = 1 kg inertia\n}\n",  # 'in' of 'inertia' is a keyword after a unit
    "model m {\n  param a = (1, 2) rotate*x\n}\n",  # one unit, not the keyword
    "model m {\n  frame_x = 2 at\n  param p = 1_000\n}\n",
    "model m {\n  param a = 1 + )\n}\n",
    "model m {\n  param a = 1\r\n  param b = .5e3 % \\\n + 2\n}\n",
    'scene s {\n  t_end = 5 s "done"; x = 1 1/s^2\n}\n',
])
def test_tokens_are_those_of_lark_contextual_lexer_on_odd_text(text, lark_contextual):
    assert positioned(text, _lark()) == positioned(text, lark_contextual)


def test_a_state_s_scanner_made_on_first_use_is_the_one_made_with_all_the_others():
    """The scanners are made when the parser first is in a state (lexer._Scanners): each must match as the one
    made for every state at once, and states accepting the same terminals share one."""
    from mbs.language import lexer
    lark = _lark()
    states = lark.parser.parser.parser.parse_table.states
    lazy, eager = lexer._Scanners(lark.parser.lexer, states), lexer._all_scanners(lark.parser.lexer, states)
    assert not lazy
    for state in states:
        made, every = lazy[state], eager[state]
        assert made.match.__self__.pattern == every.match.__self__.pattern
        assert made.keywords == every.keywords and made.allowed == every.allowed
    assert len({id(s) for s in lazy.values()}) == len({id(s) for s in eager.values()}) < len(states)
