"""The tape of temporaries: folding, sharing, guards, slicing, substitution."""

import re
import sys
from pathlib import Path

import pytest
import sympy as sp

from mbs.compiler.ccode import generate_c
from mbs.compiler.equations import derive_equations
from mbs.compiler.kinematics import Kinematics
from mbs.compiler.tape import Tape, is_trivial, sign_key

sys.path.insert(0, str(Path(__file__).parents[2] / "bench"))
from chain import chain  # noqa: E402

x, y, z = sp.symbols("x y z")


def test_trivial_values_get_no_temporary():
    tape = Tape()
    for e in (0, 1, -3, sp.Rational(1, 2), x, -x, 2 * x, sp.pi):
        assert tape.temp(e, "w") == e
    assert len(tape) == 0


def test_equal_and_negated_expressions_share_one_temporary():
    tape = Tape()
    a = tape.temp(x * y + z, "a")
    assert tape.temp(z + y * x, "b") is a
    assert tape.temp(-x * y - z, "c") == -a
    assert len(tape) == 1
    assert tape.entries[0].expr == x * y + z  # stored as asked, so its name tells the truth


def test_names_are_unique():
    tape = Tape()
    a, b = tape.temp(x * y, "w"), tape.temp(x * z, "w")
    assert {tape.entry(a).name, tape.entry(b).name} == {"w", "wx2"}


def test_inverse_is_guarded():
    tape = Tape()
    d = tape.temp(x * x + y, "d")
    inv = tape.inverse(d, "iD")
    assert tape.entry(inv).guard == d
    assert tape.inverse(4, "iD") == sp.Rational(1, 4)
    with pytest.raises(ZeroDivisionError):
        tape.inverse(0, "iD")


def test_slicing_and_expansion():
    tape = Tape()
    a = tape.temp(sp.sin(x), "a")
    b = tape.temp(a * y, "b")
    c = tape.temp(sp.cos(z), "c")  # not needed by b
    assert [e.symbol for e in tape.entries_for([b + 1])] == [a, b]
    assert tape.expand([b, c]) == [y * sp.sin(x), sp.cos(z)]
    assert tape.free_symbols([b]) == {x, y}


@pytest.fixture(scope="module")
def chain5():
    return derive_equations(Kinematics(chain(5, symbolic=True)))


def test_derived_tape_has_no_trivial_or_repeated_entries(chain5):
    tape = chain5.tape
    assert not any(is_trivial(e.expr) for e in tape.entries)
    exprs = [e.expr for e in tape.entries]
    assert len(set(exprs)) == len(exprs)
    assert not set(exprs) & {-e for e in exprs}


def test_generated_code_has_no_multiplication_by_zero_or_one(chain5):
    source = generate_c(chain5, chain5.parameters())
    body = source[source.index("int mbs_rhs"):]
    assert not re.search(r"(?<![\w.])[01](\.0)?\*|\*[01](\.0)?(?![\w.])", body)
    assert not re.search(r"[+-] 0(\.0)?(?![\w.])", body)


def test_sign_key_is_the_same_for_an_expression_and_its_negative():
    # Tape.temp only looks -expr up when an entry has expr's sign key: a key that differed would lose sharing
    w = sp.Dummy("w")
    for e in (x + y, x - y, -x - 2 * y + 3, sp.Rational(1, 3) * x * y - z, 2.5 * x * y, -x * y * z, sp.sin(x),
              -sp.cos(x) * w, x**2 - sp.Float(0.5), (x + y) * z - 1, sp.sqrt(x) - x * w / y):
        assert sign_key(-e) == sign_key(e), e


def test_a_negative_shares_the_temporary():
    tape = Tape()
    a = tape.temp(x * y + z * x - 3, "a")
    assert tape.temp(-x * y - z * x + 3, "b") == -a
    assert tape.temp(sp.Rational(-1, 2) * sp.sin(x) * y, "c") == -tape.temp(sp.sin(x) * y / 2, "d")
    assert len(tape) == 2
