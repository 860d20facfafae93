"""mbs eom and mbs.eom: readable equations in named terms, exact constants, values at a state.

The oracle of the numbers is the generated right-hand side (articulated-body algorithm, a different algorithm
from the CRBA/RNEA of the printed M, k, q): at any state, M^-1 (q - k) must be its accelerations.
"""

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import mbs
from mbs.cli import main
from mbs.eom import equations_of_motion
from mbs.language.diagnostics import MbsError
from mbs.runtime.workspace import Workspace

ARM = Path(__file__).parents[1] / "compiler" / "models" / "spatial_arm.mbs"


@pytest.fixture(scope="module")
def arm():
    system = mbs.load(ARM, backend="numpy")
    return system, equations_of_motion(system)


def test_constants_stay_exact_so_no_round_off_terms_appear(arm):
    _, eq = arm
    expressions = [item.expr for item in eq.intermediates] + list(eq.M) + list(eq.k) + list(eq.q)
    floats = {f for e in expressions for f in e.atoms(sp.Float)}
    assert not floats  # the skew axis is sqrt(2)/2 exactly, the gravity 981/100, the inertias decimals
    assert any(e.has(sp.sqrt(2)) for e in expressions)


def test_mass_matrix_and_forces_at_a_state_give_the_simulators_accelerations(arm):
    system, eq = arm
    compiled = system.compile()
    data = Workspace(compiled)
    rng = np.random.default_rng(7)
    for _ in range(3):
        state = dict(zip(compiled.x_names, rng.uniform(-1.5, 1.5, compiled.nx)))
        M, k, q = eq.at(state)
        assert np.allclose(M, M.T, rtol=0, atol=1e-14) and np.all(np.linalg.eigvalsh(M) > 0)
        data.x = [state[n] for n in compiled.x_names]
        vdot = data.function("rhs")(0.0, data.x)[compiled.nq:]
        assert np.allclose(np.linalg.solve(M, q.ravel() - k.ravel()), vdot, rtol=1e-10, atol=1e-10)


def test_k_vanishes_at_rest_and_q_holds_the_weights(arm):
    system, eq = arm
    at_rest = {"der(joint1.phi)": 0.0, "der(joint2.phi)": 0.0, "der(joint3.phi)": 0.0}
    _, k, q = eq.at(at_rest)
    assert np.allclose(k, 0.0, atol=1e-14)
    _, _, q_light = eq.at(at_rest, params={"m1": 1e-9, "m2": 1e-9, "m3": 1e-9, "ftip": 0.0})
    assert np.abs(q).max() > 1.0 and np.allclose(q_light, 0.0, atol=1e-6)


def test_written_out_matches_the_named_form(arm):
    _, eq = arm
    M, k, q = eq.written_out()
    values = {s: 0.3 * (i + 1) for i, s in enumerate(eq.y + eq.v)}
    values.update({sp.Symbol(n): v for n, v in (("m1", 2), ("m2", 1.5), ("m3", 1), ("l1", 0.4), ("l2", 0.5),
                                                  ("l3", 0.3), ("ftip", 10))})
    named = eq.equations.evaluate(values)
    for full, part in zip((M, k, q), named):
        assert np.allclose(np.array(full.xreplace(values).evalf().tolist(), dtype=float),
                           np.array(part.tolist(), dtype=float), rtol=1e-12, atol=1e-12)


def test_cli_prints_named_terms_text_and_latex(capsys):
    path = str(ARM.relative_to(Path.cwd()))
    assert main(["eom", path]) == 0
    out = capsys.readouterr().out
    assert "# body 1 (joint1): revolute joint" in out and "M[1,1] = " in out and "q[3] = " in out
    assert "e-1" not in out  # no round-off such as 4.163336342344337e-17
    assert main(["eom", path, "--latex"]) == 0
    latex = capsys.readouterr().out
    assert "\\begin{align*}" in latex and "M_{1,1} &=" in latex


def test_cli_numbers_at_a_state_with_units(capsys):
    path = str(ARM.relative_to(Path.cwd()))
    assert main(["eom", path, "--at", "joint1.phi=30deg", "der(joint2.phi)=1", "--param", "ftip=0"]) == 0
    out = capsys.readouterr().out
    assert "joint1.phi = 0.523599" in out and "M =" in out
    assert main(["eom", path, "--at", "joint9.phi=1"]) == 1
    assert "has no coordinate or speed 'joint9.phi'" in capsys.readouterr().err


def test_unknown_state_name_is_an_error(arm):
    _, eq = arm
    with pytest.raises(MbsError, match="did you mean 'joint1.phi'"):
        eq.at({"joint1.ph": 0.1})
