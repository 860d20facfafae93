"""The parser alone: fragments, operator precedence, units as tokens, newline rules, spans."""

import pytest

from mbs.language import ast
from mbs.language.diagnostics import MbsError
from mbs.language.formatter import expr
from mbs.language.parser import parse_expression, parse_text


@pytest.mark.parametrize("text, canonical", [
    ("1+2*3", "1 + 2 * 3"),
    ("(1+2)*3", "(1 + 2) * 3"),
    ("-x^2", "-x^2"),
    ("(-x)^2", "(-x)^2"),
    ("a - (b - c)", "a - (b - c)"),
    ("a / (b * c)", "a / (b * c)"),
    ("2^3^2", "2^3^2"),
    ("not a and b or c", "not a and b or c"),
    ("a < b == c", None),
    ("10 km/h", "10 km/h"),
    ("(0, 0, -9.81) m/s^2", "(0, 0, -9.81) m/s^2"),
    ("diag(1, 2, 3) kg*m^2", "diag(1, 2, 3) kg*m^2"),
    ("if(x > 0, 1 N, -1 N)", "if(x > 0, 1 N, -1 N)"),
    ("der(hinge.phi)", "der(hinge.phi)"),
    ("[[0, 1], [1, 2]]", "[[0, 1], [1, 2]]"),
    ("5 1/s", "5 1/s"),
])
def test_expression_precedence_round_trips(text, canonical):
    if canonical is None:
        with pytest.raises(MbsError):
            parse_expression(text)
        return
    assert expr(parse_expression(text)) == canonical
    assert expr(parse_expression(canonical)) == canonical


def test_unit_is_one_token_after_a_number():
    node = parse_expression("2 m * x")
    assert isinstance(node, ast.Binary) and node.op == "*"
    assert isinstance(node.left, ast.Number) and node.left.unit == "m"
    assert isinstance(node.right, ast.Name)


def test_newlines_inside_brackets_are_ignored_and_semicolons_separate():
    f = parse_text("model m {\n  param a = (1,\n   2,\n   3); param b = 2\n\n\n}\n")
    names = [s.name.text for s in f.items[0].statements]
    assert names == ["a", "b"]


def test_spans_point_at_the_text():
    text = "model m {\n    param mass = 12 kg\n}\n"
    param = parse_text(text).items[0].statements[0]
    assert (param.name.span.line, param.name.span.col) == (2, 11)
    assert param.value.span.text == "12 kg"
    assert param.value.unit_span.text == "kg"


def test_all_syntax_errors_of_a_file_are_reported():
    with pytest.raises(MbsError) as err:
        parse_text("model m {\n  param = 1\n  param b = 2 +\n  param c = 3\n}\n", "x.mbs")
    messages = [d.message for d in err.value.diagnostics]
    assert len(messages) == 2, messages
    assert all(d.span.source.path == "x.mbs" for d in err.value.diagnostics)


def test_empty_and_comment_only_files_parse_to_nothing():
    assert parse_text("").items == ()
    assert parse_text("# nothing\n\n   # here\n").items == ()
