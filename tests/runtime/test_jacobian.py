"""The generated Jacobian mbs_jacobian: exact against central differences of the right-hand side, the same in C
and NumPy, used by rodasp (fewer right-hand sides per step); for closed loops assembled (test_loop_jacobian.py)."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs import pipeline

MODELS = Path(__file__).parent / "models"


def _central_differences(f, t, x, h=1e-6):
    n = x.size
    J = np.empty((n, n + 1))
    for j in range(n + 1):
        dt, dx = (h, np.zeros(n)) if j == n else (0.0, h * np.eye(n)[j])
        J[:, j] = (f(t + dt, x + dx) - f(t - dt, x - dx)) / (2 * h)
    return J


@pytest.fixture(scope="module")
def stiff_mount():
    system = mbs.load(MODELS / "stiff_mount.mbs")  # (the default cache: test_stiffness's build of it)
    return system


def test_only_the_stiff_scene_gets_a_jacobian(stiff_mount):
    assert "jacobian" not in stiff_mount.compile("drop").functions
    model = stiff_mount.compile("drop_stiff")
    assert "jacobian" in model.functions and model.backend.functions["jacobian"] == (4, 5)


@pytest.mark.parametrize("path", ["library/examples/double_pendulum.mbs", "library/examples/two_mass_quarter_car.mbs"])
def test_generated_jacobian_equals_central_differences_in_c_and_numpy(path):
    system = mbs.load(path)
    gen = system.generate(None, jacobian=True)
    data = system._workspace(system.compile(None, jacobian=True), gen, pipeline.parameter_values(system.model))
    rng = np.random.default_rng(1)
    x = data.x + 0.1 * rng.standard_normal(data.x.size)
    t = 0.37 if "quarter" not in path else 0.5  # on the bump: the road drives the time column
    J = data.function("jacobian")(t, x)
    reference = _central_differences(data.function("rhs"), t, x)
    assert np.allclose(J, reference, rtol=1e-6, atol=1e-6 * np.abs(reference).max())
    numpy_module = {}
    exec(compile(gen.numpy_source, "model.py", "exec"), numpy_module)
    Jn = np.zeros_like(J)
    assert numpy_module["mbs_jacobian"](t, x, data.p, Jn, np.zeros(max(1, data.model.nwork))) == 0
    assert np.allclose(Jn, J, rtol=1e-12, atol=1e-12 * np.abs(J).max())


def test_rodasp_with_the_generated_jacobian_needs_six_rhs_per_step(stiff_mount):
    res = stiff_mount.simulate("drop_stiff")
    stats = res.metadata["stats"]
    assert res.metadata["status"] == "finished"
    assert stats["nsteps"] < 2000
    assert stats["nfev"] <= 8 * stats["nsteps"]
    # the static deflection of the two springs in series under gravity, independent of the integrator
    g, m_body = 9.81, 100.0
    settled = 0.5 - m_body * g / 1e4
    assert res["body_z"][-1] == pytest.approx(settled, abs=2e-3)  # the 1.6 Hz bounce has decayed to < 2 mm


def test_closed_loops_get_the_assembled_jacobian():
    """Their mbs_jacobian is runtime/c/loop_jacobian.c's, from the generated partials (tests/runtime/test_loop_jacobian.py)."""
    system = mbs.load("library/examples/slider_crank.mbs")
    gen = pipeline.generate(system.model, None, jacobian=True)
    assert "int mbs_loop_partials(" in gen.c_source and "#define MBS_LOOP_JACOBIAN 1" in gen.c_source
