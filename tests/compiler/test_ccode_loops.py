"""The mass matrix's structural nonzeros the generator hands the loop solver (compiler/ccode_loops.py mass_pattern,
runtime/c/loops.c reads M T_j over them): exact where the table says zero, at every state, and as sparse as the
topology makes M (bodies on different branches of the tree share no inertia)."""

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import mbs
from mbs.compiler.ccode_loops import mass_pattern

ROOT = Path(__file__).parents[2]


def _table(text: str, name: str) -> list[int]:
    found = re.search(rf"static const int {name}\[\d+\] = \{{([^}}]*)\}};", text)
    assert found, name
    return [int(v) for v in found.group(1).split(",")]


def pattern_of(text: str) -> np.ndarray:
    """The boolean nv x nv pattern the C tables of mass_pattern describe."""
    rows, begin, end = (_table(text, n) for n in ("mbs_mass_row", "mbs_mass_begin", "mbs_mass_end"))
    nv = len(rows) - 1
    pattern = np.zeros((nv, nv), dtype=bool)
    for i in range(nv):
        for k in range(rows[i], rows[i + 1]):
            pattern[i, begin[k]:end[k]] = True
    return pattern


def test_runs_of_a_hand_written_matrix():
    a, b, c = sp.symbols("a b c")
    upper = [[a, 0, b, c], [0, a, 0, 0], [b, 0, c, a], [c, 0, a, 1]]  # symmetric; 0 the structural zeros
    text = mass_pattern(upper)
    assert "#define MBS_MASS_PATTERN 1" in text
    assert _table(text, "mbs_mass_row") == [0, 2, 3, 5, 7]  # rows 0, 2, 3: [0, 1) and [2, 4); row 1: [1, 2)
    assert _table(text, "mbs_mass_begin") == [0, 2, 1, 0, 2, 0, 2]
    assert _table(text, "mbs_mass_end") == [1, 4, 2, 1, 4, 1, 4]
    np.testing.assert_array_equal(pattern_of(text), np.array([[e != 0 for e in row] for row in upper]))


def test_the_quarter_car_s_mass_matrix_is_zero_outside_its_pattern():
    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")
    pattern = pattern_of(system.generate().c_source)
    from mbs.runtime.workspace import Workspace
    data = Workspace(system.compile())
    rng = np.random.default_rng(7)
    for _ in range(5):
        x = data.x + rng.uniform(-0.3, 0.3, data.x.size)
        M = data.mass_matrix(0.0, x)
        assert np.all(M[~pattern] == 0.0)
        np.testing.assert_array_equal(pattern, pattern.T)


@pytest.mark.parametrize("corner", ["fl", "fr", "rl", "rr"])
def test_the_iltis_corners_share_no_inertia(corner):
    """The four suspensions hang on the car body in separate branches: M couples a corner's velocities with the
    body's and its own only (the block-arrow structure the loop solver's T^T M T follows). Every corner velocity
    couples with the body's rotations, the steering rod's two with none of its translations: the rod's mass centre
    sits on its joint (suspension.mbs: com = frame inner), so turning it moves no mass along (those entries
    evaluated to 0 before they were printed as 0, in body frames at the joints: compiler/lower.py)."""
    generated = mbs.load(ROOT / "library" / "iltis" / "vehicle.mbs").generate("bump_5")
    pattern = pattern_of(generated.c_source)
    names = list(generated.v_names)
    mine = [i for i, n in enumerate(names) if corner + "." in n]
    others = [i for i, n in enumerate(names) if any(c + "." in n for c in ("fl", "fr", "rl", "rr") if c != corner)]
    body = [i for i, n in enumerate(names) if "floating" in n]
    assert len(mine) == 7 and len(others) == 21 and len(body) == 6
    assert not pattern[np.ix_(mine, others)].any()
    rod = [i for i in mine if ".rod_inner." in names[i]]
    assert len(rod) == 2
    assert pattern[np.ix_(mine, body[3:])].any(axis=1).all()  # (every motion of a corner turns the body)
    translations = pattern[np.ix_(mine, body[:3])]
    assert translations[[k for k, i in enumerate(mine) if i not in rod]].all()  # (it moves the mass centre)
    assert not translations[[k for k, i in enumerate(mine) if i in rod]].any()


def test_without_the_pattern_the_solver_reads_whole_rows_to_the_same_result():
    """loops.c's fallback for a model without the table (every entry of M counted) against the table's path: the
    same products in the same order, plus products with M's exact zeros, so the same right-hand side."""
    from mbs.runtime.model import load_c
    from mbs.runtime.workspace import Workspace
    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")  # (the default cache: the other tests' build)
    generated = system.generate()
    source = generated.c_source
    start = source.index("#define MBS_MASS_PATTERN 1")
    end = source.index("\n", source.index("static const int mbs_mass_end"))
    whole = source[:start] + source[end + 1:]
    assert "MBS_MASS_PATTERN" not in whole
    info = dict(q_names=list(generated.q_names), v_names=list(generated.v_names), p_names=list(generated.p_names))
    compiled = system.compile()
    patterned = Workspace(compiled)
    fallback = Workspace(load_c(code=whole, name="whole_rows",
                                p_default=list(compiled.p_default), **info))
    rng = np.random.default_rng(11)
    f, g = patterned.function("loop_rhs"), fallback.function("loop_rhs")
    for _ in range(5):
        x = patterned.x + rng.uniform(-0.01, 0.01, patterned.x.size)
        np.testing.assert_allclose(g(0.0, x), f(0.0, x), rtol=1e-13, atol=1e-13)
