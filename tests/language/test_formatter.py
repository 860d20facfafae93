"""`mbs fmt`: idempotent, comment-preserving, and the formatted model validates to an equal data model."""

import pytest

from mbs.language.diagnostics import Source
from mbs.language.formatter import format_source
from mbs.language.frontend import check, check_text
from mbs.language.parser import parse_source
from tests.conftest import SHIPPED_MODELS


def fmt(text: str, path="x.mbs") -> str:
    source = Source(path, text)
    return format_source(parse_source(source), source)


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.name)
def test_formatting_is_idempotent_and_preserves_the_model(path):
    text = path.read_text()
    once = fmt(text, str(path))
    assert fmt(once, str(path)) == once
    original = check(path)
    reformatted = check_text(once, str(path), directory=path.parent)
    assert [m for m in reformatted.models] == [m for m in original.models]
    assert original.components == reformatted.components


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.name)
def test_shipped_models_are_formatted(path):
    assert fmt(path.read_text(), str(path)) == path.read_text()


def test_comments_and_blank_lines_survive():
    text = ("# head comment\n\nmodel m {  # trailing on the brace\n    # before a\n    param a   =  1 kg   # after a"
            "\n\n\n    param b=(a+2 kg)*3\n    # at the end of the block\n}\n# tail\n")
    expected = ("# head comment\n\nmodel m {  # trailing on the brace\n    # before a\n    param a = 1 kg  # after a\n"
                "\n    param b = (a + 2 kg) * 3\n    # at the end of the block\n}\n# tail\n")
    assert fmt(text) == expected
    assert fmt(expected) == expected
