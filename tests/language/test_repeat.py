"""Repetition in the language: `for` blocks and indexed names, unrolled before validation."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.language.frontend import check_text
from mbs.runtime.workspace import Workspace

CHAIN = Path(__file__).parent / "models" / "chain_for.mbs"


def explicit_chain(n: int) -> str:
    """The same chain written out statement by statement (independent of the repetition pass)."""
    lines = ["model chain {"]
    for i in range(1, n + 1):
        lines += [f"    rigid link{i} {{", "        body {", "            mass = 1 kg",
                  "            com = (0, 0, -0.5) m", "            inertia = diag(1 / 12, 1 / 12, 1e-3) kg*m^2",
                  "        }", "        frame tip at (0, 0, -1) m", "    }"]
        parent = "inertial" if i == 1 else f"link{i - 1}.tip"
        init = "0.3 rad" if i == 1 else (f"{0.1 * i!r} rad" if i % 2 == 0 else "0 rad")
        lines += [f"    interact j{i} {{", f"        connect {parent} -> link{i}",
                  f"        joint revolute(axis = {'xy'[(i - 1) % 2]}) {{", f"            init phi = {init}",
                  "        }", "    }"]
    return "\n".join(lines + ["}", ""])


def test_a_looped_chain_has_the_equations_of_the_written_out_one():
    looped = mbs.load(CHAIN, backend="numpy").compile()
    written = mbs.loads(explicit_chain(6), backend="numpy").compile()
    assert looped.q_names == tuple(f"j[{i}].phi" for i in range(1, 7))
    np.testing.assert_allclose(looped.x0, written.x0, rtol=1e-15)
    rng = np.random.default_rng(1)
    a, b = Workspace(looped), Workspace(written)
    for _ in range(3):
        x = rng.normal(size=looped.nx)
        np.testing.assert_allclose(a.rhs(0.0, x), b.rhs(0.0, x), rtol=1e-12, atol=1e-12)


def test_errors_inside_a_loop_are_located_and_name_the_iteration():
    text = """model bad {
    for i in range(1, 4) {
        rigid link[i] {
            body {
                mass = 1 kg
                inertia = diag(1, 1, 1) kg*m^2
            }
        }
        interact j[i] {
            connect link[i - 1] -> link[i]
            joint revolute(axis = x)
        }
    }
}
"""
    with pytest.raises(mbs.MbsError) as err:
        check_text(text, "bad.mbs")
    rendered = "\n".join(d.render() for d in err.value.diagnostics)
    assert "bad.mbs:10:21: error: unknown part 'link[0]'" in rendered
    assert "note: in the iteration i = 1 of this loop" in rendered


@pytest.mark.parametrize("header, message", [
    ("for i in range(1, n)", "'n' is not a loop variable here"),
    ("for i in range(1, 3, 0)", "the step of a range cannot be 0"),
    ("for i in 3", "a loop runs over range(first, stop[, step]) or a vector of integers"),
    ("for i in (1, 2.5)", "must be a whole number, this is 2.5"),
])
def test_bad_loop_headers_are_located_errors(header, message):
    text = f"model m {{\n    {header} {{\n        part p[i]\n    }}\n}}\n"
    with pytest.raises(mbs.MbsError) as err:
        check_text(text, "m.mbs")
    first = err.value.diagnostics[0]
    assert message in first.message and first.span.line == 2


def test_nested_loops_and_a_reused_variable():
    grid = """model m {
    for i in range(1, 3) {
        for k in (1, 2) {
            rigid p[10 * i + k] {
                body {
                    mass = 1 kg
                    inertia = diag(1, 1, 1) kg*m^2
                }
            }
            interact slide[10 * i + k] {
                connect inertial -> p[10 * i + k]
                joint prismatic(axis = z)
            }
        }
    }
}
"""
    model = check_text(grid, "m.mbs").models[0]
    assert [p.name for p in model.parts if p.name != "inertial"] == ["p[11]", "p[12]", "p[21]", "p[22]"]
    reused = grid.replace("for k in (1, 2)", "for i in (1, 2)")
    with pytest.raises(mbs.MbsError, match="already the variable of an enclosing loop"):
        check_text(reused, "m.mbs")


def test_an_array_of_component_instances_and_indexed_frames():
    text = """component cell {
    param k = 100 N/m
    port base
    rigid m {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide {
        connect base -> m
        joint prismatic(axis = z)
        force spring = joint(s = -k * s)
    }
}

model row {
    part inertial {
        for i in (1, 2, 3) {
            frame anchor[i] at (1 m * i, 0 m, 0 m)
        }
    }
    for i in range(1, 4) {
        use cell as c[i](k = 100 N/m * i) {
            base = inertial.anchor[i]
        }
    }
    output top = c[3].slide.s
}
"""
    model = check_text(text, "row.mbs").models[0]
    assert [c.name for c in model.coordinates] == ["c[1].slide.s", "c[2].slide.s", "c[3].slide.s"]
    assert [p.value for p in model.parameters if p.name.endswith(".k")] == [100.0, 200.0, 300.0]
