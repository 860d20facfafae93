"""Forward differentiation of the tape against sympy's own derivative of the written-out expressions."""

import pytest
import sympy as sp

from mbs.compiler.differentiate import NotDifferentiable, forward_derivatives, partial_derivative
from mbs.compiler.tape import Tape

x, y, z = sp.symbols("x y z")


def test_derivatives_of_a_tape_match_the_expanded_expressions():
    tape = Tape()
    a = tape.temp(sp.sin(x) * y, "a")
    b = tape.temp(a * a + sp.exp(z), "b")
    c = tape.temp(b / (1 + x**2) + sp.sqrt(y), "c")
    fork, rows = forward_derivatives(tape, [c, a], [x, y, z])
    expanded = tape.expand([c, a])
    point = {x: 0.3, y: 1.7, z: -0.4}
    for r, row in enumerate(rows):
        values = fork.expand(row)
        for k, s in enumerate((x, y, z)):
            assert float(values[k].subs(point)) == pytest.approx(float(sp.diff(expanded[r], s).subs(point)),
                                                                 rel=1e-12)
    assert rows[1][2] == 0  # a does not depend on z: no temporary, an exact zero
    assert len(tape) == 3  # the original tape is untouched; the derivatives live on the fork


def test_kinks_take_the_derivative_of_the_active_piece():
    assert partial_derivative(sp.Abs(x * y), x).subs({x: -2, y: 3}) == -3
    d = partial_derivative(sp.Max(0, 5 * x), x)
    assert d.subs(x, 1) == 5 and d.subs(x, -1) == 0
    assert partial_derivative(sp.sign(x) * y, x) == 0


def test_an_undefined_function_has_no_derivative():
    table = sp.Function("mbs_table_0")
    with pytest.raises(NotDifferentiable):
        partial_derivative(table(x) * y, x)
