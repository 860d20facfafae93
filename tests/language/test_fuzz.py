"""Property-based fuzzing: whatever the input, the front end answers with our own located errors.

Inputs are random text, random bytes, and shipped models mutated by deleting, duplicating and replacing
characters and tokens. The only acceptable outcomes are a model or an MbsError whose diagnostics render.
"""

import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mbs.language.diagnostics import MbsError
from mbs.language.frontend import check, check_text
from tests.conftest import SHIPPED_MODELS

SEEDS = [p.read_text() for p in SHIPPED_MODELS]
TOKENS = ["{", "}", "(", ")", "[", "]", ",", "=", "->", ".", "m", "kg", "N/m", "1e9", "-", "^", "*", "/",
          "model", "component", "rigid", "part", "body", "frame", "interact", "connect", "joint", "force", "sensor",
          "use", "port", "param", "scene", "der(", "inertial", "\n", ";", '"', "#", "at", "rotate", "in", "0",
          "nan", "1/0", "if(", "lookup(", "mirror = xz", "cut = true"]


def assert_front_end_answers(text: str) -> None:
    try:
        check_text(text, "fuzz.mbs", directory=Path("library/iltis"))
    except MbsError as err:
        rendered = "\n".join(d.render() for d in err.diagnostics)
        assert rendered
        assert any(d.severity == "error" for d in err.diagnostics)


@st.composite
def mutated_model(draw):
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(1, 6))):
        pos = draw(st.integers(0, max(0, len(text) - 1)))
        action = draw(st.sampled_from(["delete", "insert", "duplicate", "truncate"]))
        if action == "delete":
            end = pos + draw(st.integers(1, 20))
            text = text[:pos] + text[end:]
        elif action == "insert":
            text = text[:pos] + draw(st.sampled_from(TOKENS)) + text[pos:]
        elif action == "duplicate":
            end = pos + draw(st.integers(1, 40))
            text = text[:end] + text[pos:end] + text[end:]
        else:
            text = text[:pos]
    return text


FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(mutated_model())
def test_mutated_models_never_crash_the_front_end(text):
    assert_front_end_answers(text)


@FUZZ
@given(st.lists(st.sampled_from(TOKENS + list("abcxyz019 .")), max_size=80).map(" ".join))
def test_token_soup_never_crashes_the_front_end(text):
    assert_front_end_answers(text)


@FUZZ
@given(st.text(max_size=300))
def test_random_text_never_crashes_the_front_end(text):
    assert_front_end_answers(text)


@settings(max_examples=50, deadline=None)
@given(st.binary(max_size=300))
def test_random_bytes_in_a_file_never_crash_the_front_end(data):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "garbage.mbs"
        path.write_bytes(data)
        try:
            check(path)
        except MbsError as err:
            assert err.diagnostics
