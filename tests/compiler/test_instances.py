"""compiler/instances.py: a law shared by the instances of a component, converted once and renamed, is node for
node (srepr: classes, arguments and their order) what converting it gives, on the Iltis's four tyres and on
laws whose names change their order, where it must be converted as written."""

from pathlib import Path

import pytest
import sympy as sp

import mbs
from mbs.compiler import instances
from mbs.compiler.lower import lower_model
from mbs.compiler.symbolic import ToSympy
from mbs.language import expr as X

ROOT = Path(__file__).resolve().parents[2]


def test_the_iltis_tyres_laws_renamed_are_the_laws_converted(monkeypatch):
    seen = []
    convert, rename = instances.SharedLaws.convert, instances.renamed

    def recorded(self, expr, to_sympy):
        result = convert(self, expr, to_sympy)
        seen.append((result, to_sympy._convert(expr)))  # (the top node converted anew, its operands as they were)
        return result

    renamings = []
    monkeypatch.setattr(instances.SharedLaws, "convert", recorded)
    monkeypatch.setattr(instances, "renamed", lambda *a: renamings.append(1) or rename(*a))
    system = mbs.load(ROOT / "library" / "iltis" / "vehicle.mbs")
    lower_model(system.model, system.model.scene("bump_5"))
    assert len(seen) == 8 and len(renamings) == 6  # fy and mz of four tyres; three of each renamed
    for shared, converted in seen:
        assert sp.srepr(shared) == sp.srepr(converted)


def _sym(name):
    return X.Sym("param", name)


def _law(a: str, b: str) -> X.E:
    """|a - b| * sign(a) + max(a, b) + if(a < b, atan(a), a^3): kinds sympy orders by the names."""
    x, y = _sym(a), _sym(b)
    return X.Op("+", (X.Op("+", (X.Op("*", (X.Op("abs", (X.Op("-", (x, y)),)), X.Op("sign", (x,)))),
                                 X.Op("max", (x, y)))),
                      X.Op("if", (X.Op("<", (x, y)), X.Op("atan", (x,)), X.Op("^", (x, X.Const(3.0)))))))


@pytest.mark.parametrize("second", [("q.a", "q.b"), ("q.b", "q.a")])
def test_a_law_is_renamed_only_where_its_names_keep_their_order(monkeypatch, second):
    renamings = []
    rename = instances.renamed
    monkeypatch.setattr(instances, "renamed", lambda *a: renamings.append(1) or rename(*a))
    shared = instances.SharedLaws()
    no_state = lambda sym: pytest.fail(f"{sym} resolved")  # noqa: E731
    shared.convert(_law("p.a", "p.b"), ToSympy(no_state))
    result = shared.convert(_law(*second), ToSympy(no_state))
    assert sp.srepr(result) == sp.srepr(ToSympy(no_state)(_law(*second)))
    assert len(renamings) == (1 if second == ("q.a", "q.b") else 0)  # ("q.b" before "q.a": converted as written)


def test_a_law_with_a_table_is_converted_as_written():
    shared = instances.SharedLaws()
    table = X.Table(_sym("p.a"), (0.0, 1.0), (0.0, 2.0), "linear")
    first = shared.convert(table, ToSympy(lambda sym: None))
    assert sp.srepr(first) == sp.srepr(ToSympy(lambda sym: None)(table))
    assert not shared._converted
