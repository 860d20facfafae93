"""mbs_mass_matrix, mbs_forces and mbs_constraint_acceleration of a closed-loop model read off the one-pass
mbs_loop_terms (compiler/ccode_loop_terms.py): checked against the same spanning tree compiled as an open model
(its own, separately printed M and f) and against central differences of the separately printed constraint
velocity."""

from pathlib import Path

import numpy as np
import pytest

import mbs

ROOT = Path(__file__).parents[2]
SLIDER_CRANK = (ROOT / "library" / "examples" / "slider_crank.mbs").read_text()
CUT = SLIDER_CRANK[SLIDER_CRANK.index("    interact wrist_pin"):SLIDER_CRANK.rstrip().rindex("}")]


@pytest.fixture(scope="module")
def models():
    gravity = SLIDER_CRANK.replace("gravity = (0, 0, 0) m/s^2", "gravity = (0, 0, -9.81) m/s^2")
    closed = mbs.loads(gravity, path="slider_crank.mbs")
    tree = mbs.loads(gravity.replace(CUT, ""), path="tree.mbs")
    return closed, tree


def _workspace(system):
    from mbs.runtime.workspace import Workspace
    return Workspace(system.compile())


def test_the_read_off_functions_are_the_tree_s_own(models):
    closed, tree = models
    assert "mbs_loop_terms(t, x, p, work, NULL)" in closed.generate().c_source
    a, b = _workspace(closed), _workspace(tree)
    assert closed.generate().q_names == tree.generate().q_names  # the same spanning tree, the same coordinates
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-2, 2, b.x.size)
        np.testing.assert_allclose(a.mass_matrix(0.0, x), b.mass_matrix(0.0, x), rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(a.forces(0.0, x), b.forces(0.0, x), rtol=1e-12, atol=1e-12)


def test_the_constraint_acceleration_is_the_rate_of_the_constraint_velocity(models):
    """gddot with vdot = 0 is d/dt (G(q) v) at constant v: the central difference of gdot along q' = v."""
    data = _workspace(models[0])
    gdot, gddot, qdot = (data.function(n) for n in ("constraint_velocity", "constraint_acceleration", "qdot"))
    rng = np.random.default_rng(5)
    nq = qdot(0.0, data.x).size
    for _ in range(5):
        x = rng.uniform(-2, 2, data.x.size)
        dq, eps = qdot(0.0, x), 1e-5
        plus, minus = x.copy(), x.copy()
        plus[:nq] += eps * dq
        minus[:nq] -= eps * dq
        np.testing.assert_allclose(gddot(0.0, x), (gdot(0.0, plus) - gdot(0.0, minus)) / (2 * eps),
                                   rtol=1e-7, atol=1e-8)
