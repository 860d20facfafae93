"""Forward differentiation of the tape against sympy's own derivative of the written-out expressions."""

import pytest
import sympy as sp

from mbs.compiler.differentiate import NotDifferentiable, forward_derivatives, partial_derivative, sympy_diff
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


def test_the_generated_jacobian_is_the_same_text_in_every_process(tmp_path):
    """The build cache is keyed by the generated text: the Jacobian's temporaries must not come out in the order
    of a set of symbols, which changes with Python's hash seed (it did: every process compiled anew)."""
    import hashlib
    import os
    import subprocess
    import sys
    from pathlib import Path

    model = Path(__file__).resolve().parents[1] / "runtime" / "models" / "stiff_arm.mbs"
    script = ("import hashlib, sys, mbs; g = mbs.load(sys.argv[1]).generate(jacobian=True); "
              "print(hashlib.sha256(g.c_source.encode()).hexdigest())")
    digests = set()
    for seed in ("1", "2", "3"):
        env = dict(os.environ, PYTHONHASHSEED=seed, MBS_CACHE_DIR=str(tmp_path / f"cache{seed}"))
        out = subprocess.run([sys.executable, "-c", script, str(model)], env=env, capture_output=True, text=True,
                             check=True)
        digests.add(out.stdout.strip())
    assert len(digests) == 1 and len(next(iter(digests))) == len(hashlib.sha256().hexdigest())


def _expressions():
    """Sums, products, powers and functions of the kinds the tape holds (and a few it rarely does)."""
    w = sp.Dummy("w")
    yield from (x, 3, sp.Rational(-1, 2) * x, x * y * z, -x * y, 2.5 * x**2 * y, 1 / (x + y), sp.sqrt(x * y + 1),
                x**y, sp.sin(x) * sp.cos(x * y) - 3 * y, (x + 1) * (y - 1) * sp.exp(z * x), sp.atan2(y, x) + w * x,
                sp.Piecewise((x * y, x > y), (x**3, True)), sp.Abs(x) * y, (x - y)**-3 * w / (1 + z**2),
                sp.Float(1.5) * (x * y + sp.pi) ** 2)


def test_sympy_diff_gives_sympys_expression_itself():
    # not only the same value: the same expression, so the generated C does not change (the text is compared)
    for e in _expressions():
        for s in (x, y, z):
            assert sympy_diff(sp.sympify(e), s, {}) == sp.diff(e, s), (e, s)
