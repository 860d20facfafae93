"""Calling model functions from Python: fresh arrays, input handling, statuses, both back ends agree."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbs.runtime.errors import EvaluationError, UsageError
from mbs.runtime.workspace import Workspace, evaluate


def test_each_call_returns_a_fresh_array(pendulum):
    data = Workspace(pendulum)
    a = data.rhs(0.0, np.array([0.3, 0.1]))
    keep = a.copy()
    b = data.rhs(0.0, np.array([0.9, -2.0]))
    assert a is not b and not np.shares_memory(a, b)
    np.testing.assert_array_equal(a, keep)  # the second call did not overwrite the first result


def test_solve_ivp_with_the_compiled_rhs_matches_numpy_back_end(pendulum, pendulum_numpy):
    """A rhs reusing its output buffer corrupts solve_ivp (it keeps references to earlier results);
    the reusing wrapper below shows that this comparison detects such corruption."""
    c, py = Workspace(pendulum), Workspace(pendulum_numpy)
    kwargs = dict(method="RK45", rtol=1e-9, atol=1e-12, dense_output=False)
    ref = solve_ivp(py.rhs, (0.0, 3.0), py.x, **kwargs)
    res = solve_ivp(c.rhs, (0.0, 3.0), c.x, **kwargs)
    np.testing.assert_allclose(res.y, ref.y, rtol=0, atol=1e-12)
    buffer = np.empty(2)

    def reusing(t, x):
        buffer[:] = c.rhs(t, x)
        return buffer

    bad = solve_ivp(reusing, (0.0, 3.0), c.x, **kwargs)
    assert not np.allclose(bad.y[:, -1], ref.y[:, -1], rtol=0, atol=1e-9)


def test_inputs_lists_ints_and_non_contiguous_arrays(pendulum):
    data = Workspace(pendulum)
    expected = data.rhs(0.0, np.array([0.5, 0.0]))
    np.testing.assert_array_equal(data.rhs(0, [0.5, 0]), expected)
    np.testing.assert_array_equal(data.rhs(np.float32(0), np.array([[0.5, 9], [0.0, 9]])[:, 0]), expected)
    np.testing.assert_array_equal(data.rhs(0.0, memoryview(np.array([0.5, 0.0]))), expected)


@pytest.mark.parametrize("bad, error", [([1.0, 2.0, 3.0], ValueError), ([[0.5, 0.0]], ValueError),
                                        ("ab", ValueError), (None, (TypeError, ValueError))])
def test_wrong_inputs_raise(pendulum, bad, error):
    data = Workspace(pendulum)
    with pytest.raises(error):
        data.rhs(0.0, bad)
    with pytest.raises(TypeError):
        data.rhs("t", [0.5, 0.0])
    with pytest.raises(TypeError):
        data.rhs(0.0)


def test_status_raises_evaluation_error_naming_it(failing):
    data = Workspace(failing)
    data.p[4] = 1.0  # status 2 from t = 0.5 on
    data.rhs(0.4, [0.1, 0.0])
    with pytest.raises(EvaluationError) as info:
        data.rhs(0.75, [0.1, 0.0])
    assert (info.value.function, info.value.status, info.value.t) == ("rhs", 2, 0.75)
    assert "model function 'rhs' returned status 2 (non-finite value) at t = 0.75 s" in str(info.value)
    data.p[4] = 2.0
    with pytest.raises(EvaluationError, match=r"status 1 \(singular mass matrix\)"):
        data.rhs(1.0, [0.1, 0.0])


def test_parameters_are_read_in_place(pendulum):
    data = Workspace(pendulum)
    before = data.rhs(0.0, [0.5, 0.0])[1]
    data.set_param("g", 2 * 9.81)
    assert data.rhs(0.0, [0.5, 0.0])[1] == pytest.approx(2 * before)
    data.p = [1.0, 2.0, 9.81]  # assignment copies into the bound array
    assert data.rhs(0.0, [0.5, 0.0])[1] == pytest.approx(before / 2)
    with pytest.raises(UsageError):
        data.p = [1.0, 2.0]


def test_numpy_back_end_equals_c_back_end(pendulum, pendulum_numpy):
    c, py = Workspace(pendulum), Workspace(pendulum_numpy)
    assert pendulum.functions == pendulum_numpy.functions
    rng = np.random.default_rng(1)
    for _ in range(50):
        t, x = rng.uniform(0, 10), rng.uniform(-4, 4, size=2)
        for name in pendulum.functions:
            a, b = c.function(name)(t, x), py.function(name)(t, x)
            assert a.shape == b.shape
            np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-14)


def test_mass_matrix_shape_and_evaluate(pendulum):
    data = Workspace(pendulum)
    data.p = [2.0, 3.0, 9.81]
    assert data.mass_matrix(0.0, data.x).shape == (1, 1)
    assert evaluate(pendulum, data, "mass_matrix")[0, 0] == pytest.approx(18.0)
    np.testing.assert_array_equal(evaluate(pendulum, data), data.rhs(data.t, data.x))
    with pytest.raises(UsageError, match="no function 'constraints'"):
        data.function("constraints")
    with pytest.raises(UsageError, match="does not belong"):
        evaluate(pendulum, object())


def test_time_rhs_is_measured_inside_c(pendulum):
    seconds = Workspace(pendulum).time_rhs(n=10000)
    assert 0 < seconds < 1e-5


def test_load_model_prefers_c_and_falls_back_to_numpy(cache_dir, monkeypatch):
    from pathlib import Path

    from mbs.runtime.errors import BuildError
    from mbs.runtime.model import load_model

    fixtures = Path(__file__).parent / "fixtures"
    c_file, py_file = fixtures / "pendulum.c", fixtures / "pendulum_numpy.py"
    assert load_model(c_file, py_file, cache_dir=cache_dir).backend.kind == "c"
    assert load_model(c_file, py_file, backend="numpy").backend.kind == "numpy"
    monkeypatch.setenv("CC", "/nonexistent/cc-for-test")
    model = load_model(c_file, py_file, cache_dir=cache_dir, name="pendulum", p_default=[1.0, 1.0, 9.81])
    assert model.backend.kind == "numpy" and model.name == "pendulum"
    with pytest.raises(BuildError):
        load_model(c_file, backend="c", cache_dir=cache_dir / "other")
    with pytest.raises(UsageError):
        load_model(None, None)
    with pytest.raises(UsageError):
        load_model(c_file, backend="fortran")


def test_model_metadata_is_checked_and_read_only(pendulum):
    from mbs.runtime.model import CompiledModel

    assert (pendulum.nq, pendulum.nv, pendulum.nx, pendulum.np, pendulum.ny) == (1, 1, 2, 3, 2)
    assert pendulum.x_names == ("hinge.phi", "hinge.phi_dot")
    with pytest.raises(ValueError):
        pendulum.p_default[0] = 2.0
    with pytest.raises(AttributeError):
        pendulum.name = "other"
    with pytest.raises(UsageError, match="q_names needs 1 names, got 2"):
        CompiledModel.from_backend(pendulum.backend, q_names=["a", "b"])
    with pytest.raises(UsageError, match="p_default needs 3 values"):
        CompiledModel.from_backend(pendulum.backend, p_default=[1.0])
    plain = CompiledModel.from_backend(pendulum.backend)
    assert plain.q_names == ("q0",) and plain.y_names == ("y0", "y1") and not plain.p_default.any()
    with pytest.raises(UsageError, match="no parameter 'mass'"):
        pendulum.parameter_index("mass")
