"""User hooks at run time (runtime/hooks.py): Python and C implementations, every integrator, both back ends,
hooks in forces, event conditions, event actions and outputs, and every way a hook can fail.

Checked against what no one here wrote: scipy's solve_ivp on the hand-written equation of the belt example
(m x'' = -k x + f(vb - x')), the closed form of a bouncing ball's impacts, and the same friction law written
as a plain expression in the model.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbs
from mbs.cli import main
from mbs.language.diagnostics import MbsError
from mbs.runtime.build import have_c_compiler
from mbs.runtime.errors import BuildError, UsageError
from mbs.runtime.results import Results

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "library" / "examples" / "hook_friction.mbs"
C_LAW = ROOT / "library" / "examples" / "hooks" / "friction_law.c"
PY_LAW = ROOT / "library" / "examples" / "hooks" / "friction_law.py"
HERE = Path(__file__).parent
BALL = HERE / "models" / "hook_ball.mbs"
needs_c = pytest.mark.skipif(not have_c_compiler(), reason="no C compiler")


def _python_law():
    spec = importlib.util.spec_from_file_location("hook_friction_law", PY_LAW)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.friction_law


LAW = _python_law()


@pytest.fixture(scope="module")
def belt():
    return mbs.load(EXAMPLE)


@pytest.fixture(scope="module")
def plain(belt):
    """The law written as an expression in the model (plain = 1): the reference of every hooked run."""
    return belt.simulate("cycles", params={"plain": 1}, hooks={"friction_law": LAW})


# ------------------------------------------------------------------------------------------ equal results
@needs_c
@pytest.mark.parametrize("impl", ["python", "c"])
def test_the_hooked_law_gives_the_plain_expressions_motion(belt, plain, impl):
    res = belt.simulate("cycles", hooks={"friction_law": LAW if impl == "python" else str(C_LAW)})
    assert res.success, res.message
    assert np.max(np.abs(res["position"] - plain["position"])) < 1e-8
    assert np.max(np.abs(res["friction_force"] - plain["friction_force"])) < 1e-5
    assert np.ptp(res["position"]) > 0.05  # it does slip and stick: the law is exercised over its range


def test_the_hooked_run_matches_scipy_on_the_hand_written_equation(belt):
    m, k, vb, mu_s, mu_k, g = 1.0, 100.0, 0.2, 0.6, 0.4, 9.81
    res = belt.simulate("cycles", hooks={"friction_law": LAW})

    def rhs(t, y):
        return [y[1], (-k * y[0] + LAW(vb - y[1], m * g, mu_s, mu_k)) / m]
    ref = solve_ivp(rhs, (0, 3), [0.0, 0.0], method="LSODA", t_eval=res.t, rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(res["position"] - ref.y[0])) < 1e-7


@needs_c
@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "auto", "RK45", "DOP853", "Radau", "BDF", "LSODA",
                                        "cvode_adams", "cvode_bdf", "ida"])
def test_every_integrator_runs_a_c_hook(belt, plain, integrator):
    if integrator in ("cvode_adams", "cvode_bdf", "ida"):
        pytest.importorskip("sksundae")
    res = belt.simulate("cycles", t_end=1.0, integrator=integrator, rtol=1e-8, atol=1e-10,
                        hooks={"friction_law": str(C_LAW)})
    assert res.success, res.message
    n = len(res.t)
    assert np.max(np.abs(res["position"] - plain["position"][:n])) < 1e-5


@needs_c
def test_cvode_runs_a_python_hook_through_the_c_library(belt, plain):
    pytest.importorskip("sksundae")
    res = belt.simulate("cycles", t_end=1.0, integrator="cvode_bdf", rtol=1e-8, atol=1e-10,
                        hooks={"friction_law": LAW})
    assert res.success, res.message
    assert np.max(np.abs(res["position"] - plain["position"][:len(res.t)])) < 1e-5


def test_the_numpy_back_end_calls_a_python_hook_directly(plain):
    system = mbs.load(EXAMPLE, backend="numpy")
    res = system.simulate("cycles", t_end=0.5, hooks={"friction_law": LAW})
    assert res.success, res.message and res.metadata["backend"] == "numpy"
    assert np.max(np.abs(res["position"] - plain["position"][:len(res.t)])) < 1e-8


def test_a_c_hook_on_the_numpy_back_end_is_a_usage_error():
    with pytest.raises(UsageError, match="C back end"):
        mbs.load(EXAMPLE, backend="numpy").simulate("cycles", hooks={"friction_law": str(C_LAW)})


@needs_c
@pytest.mark.parametrize("impl", ["python", "c"])
def test_equilibrium_and_linearisation_take_hooks(belt, impl):
    """(python: the ctypes callback must outlive the binding that set it; it once did not, and crashed.)"""
    hooks = {"friction_law": LAW if impl == "python" else str(C_LAW)}
    rest, _ = belt.equilibrium("cycles", hooks=hooks)
    assert rest.x[0] == pytest.approx(LAW(0.2, 9.81, 0.6, 0.4) / 100.0, rel=1e-8)  # k s = f(vb) at rest
    hooked = belt.linearize("cycles", hooks=hooks)
    plain_law = belt.linearize("cycles", params={"plain": 1}, hooks=hooks)
    assert np.allclose(np.sort_complex(hooked.eigenvalues), np.sort_complex(plain_law.eigenvalues), atol=1e-5)
    assert np.abs(hooked.eigenvalues).max() == pytest.approx(10.0, rel=1e-4)  # sqrt(k / m): no slope at vb


# ------------------------------------------------------------------------------------------ events and outputs
def _ball_hooks(e=0.8, floor_cm=25.0):
    """The floor in cm (the model declares the hook in cm), the impact law, the energies (two results)."""
    return {"floor_height": lambda x: floor_cm, "impact_law": lambda v: -e * v,
            "energy": lambda m, z, v: (0.5 * m * v * v, m * 9.81 * z)}


@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_hooks_in_an_event_condition_an_action_and_the_outputs(backend):
    if backend == "auto" and not have_c_compiler():
        pytest.skip("no C compiler")
    res = mbs.load(BALL, backend=backend).simulate(t_end=2.0, rtol=1e-10, atol=1e-12, hooks=_ball_hooks())
    assert res.success, res.message
    g, drop, e = 9.81, 1.0 - 0.25, 0.8
    t1 = math.sqrt(2 * drop / g)
    times = [ev["time"] for ev in res.events]
    assert times[:2] == pytest.approx([t1, t1 + 2 * e * g * t1 / g], abs=1e-9)  # flight 2 e v1 / g, v1 = g t1
    energy = res["kinetic"] + res["potential"]
    first = res.t < t1 - 1e-6
    assert np.allclose(energy[first], 0.5 * 9.81 * 1.0, rtol=1e-8)  # conserved in the first flight
    after = (res.t > times[0] + 1e-6) & (res.t < times[1] - 1e-6)
    lost = 0.5 * 9.81 * 1.0 - 0.5 * 0.5 * (g * t1) ** 2 * (1 - e * e)
    assert np.allclose(energy[after], lost, rtol=1e-8)  # the impact law took (1 - e^2) of the kinetic energy


@needs_c
def test_one_c_file_implements_several_hooks_with_the_python_hooks_results():
    ball = mbs.load(BALL)
    c_file = str(HERE / "hooks" / "ball_hooks.c")
    in_c = ball.simulate(t_end=2.0, rtol=1e-10, atol=1e-12,
                         hooks={"floor_height": c_file, "impact_law": c_file, "energy": c_file})
    in_python = ball.simulate(t_end=2.0, rtol=1e-10, atol=1e-12, hooks=_ball_hooks())
    assert in_c.success, in_c.message
    assert [e["time"] for e in in_c.events] == pytest.approx([e["time"] for e in in_python.events], abs=1e-12)
    assert np.allclose(in_c["kinetic"], in_python["kinetic"], rtol=1e-12, atol=1e-12)


def test_a_components_hook_serves_every_instance_and_a_hook_may_have_no_arguments():
    system = mbs.load(HERE / "models" / "hook_component.mbs")
    assert [h.name for h in system.model.hooks] == ["offset", "damping_law"]
    res = system.simulate(t_end=3.0, hooks={"damping_law": lambda v: 10.0 * v, "offset": lambda: 0.5})
    assert res.success, res.message
    assert res["der(fall.s)"][-1] == pytest.approx(-9.81 / 20.0, rel=1e-6)  # m g = 2 c v: both dampers pull
    assert res["height"][-1] == pytest.approx(res["fall.s"][-1] + 0.5)


# ------------------------------------------------------------------------------------------ failures
def _raising(w, n, mu_s, mu_k):
    if w < 0.15:
        raise ValueError("slip speed below the table")
    return n * mu_k


@pytest.mark.parametrize("backend,integrator", [("auto", "dopri5"), ("auto", "rodasp"), ("auto", "Radau"),
                                                ("numpy", "RK45")])
def test_a_python_hook_that_raises_stops_the_run_naming_it(backend, integrator):
    if backend == "auto" and not have_c_compiler():
        pytest.skip("no C compiler")
    res = mbs.load(EXAMPLE, backend=backend).simulate("cycles", integrator=integrator,
                                                      hooks={"friction_law": _raising})
    assert not res.success
    assert "hook 'friction_law' failed at t = 0.01" in res.message
    assert "ValueError: slip speed below the table" in res.message and "w = 0.14" in res.message
    assert "results kept up to t = 0.01 s" in res.message and "slide.s = " in res.message
    assert list(res.t) == pytest.approx([0.0, 0.01])  # the samples before the failure, outputs and all
    assert np.all(np.isfinite(res["friction_force"]))


@needs_c
@pytest.mark.parametrize("law,reason", [("nan_law.c", "returned a non-finite result"),
                                        ("status_law.c", "returned status 7")])
def test_a_c_hook_that_fails_stops_the_run_naming_it(belt, law, reason):
    res = belt.simulate("cycles", hooks={"friction_law": str(HERE / "hooks" / law)})
    assert not res.success
    assert "hook 'friction_law' failed at t = 0.01" in res.message and reason in res.message
    assert list(res.t) == pytest.approx([0.0, 0.01])


@needs_c
def test_the_failure_of_one_run_does_not_leak_into_the_next(belt, plain):
    assert not belt.simulate("cycles", hooks={"friction_law": _raising}).success
    res = belt.simulate("cycles", hooks={"friction_law": LAW})
    assert res.success, res.message


def test_a_hook_returning_the_wrong_number_of_results_is_a_failure(belt):
    res = belt.simulate("cycles", t_end=0.1, hooks={"friction_law": lambda *a: (1.0, 2.0)})
    assert not res.success and "returned 2 values; the hook declares 1 result(s) (f)" in res.message


def test_a_declared_hook_without_implementation_is_a_located_error_before_the_run(belt):
    with pytest.raises(MbsError) as err:
        belt.simulate("cycles")
    diag = err.value.diagnostics[0]
    assert "hook 'friction_law' is declared but no implementation was supplied" in diag.message
    assert "--hook friction_law=file.c" in diag.message and diag.span.line == 23


def test_an_implementation_for_an_undeclared_hook_is_a_usage_error(belt):
    with pytest.raises(UsageError, match="declares no hook 'friction'; did you mean 'friction_law'"):
        belt.simulate("cycles", hooks={"friction_law": LAW, "friction": LAW})


@needs_c
def test_a_c_hook_that_does_not_compile_shows_the_compilers_message():
    with pytest.raises(BuildError) as err:
        mbs.load(EXAMPLE).simulate("cycles", hooks={"friction_law": str(HERE / "hooks" / "broken_law.c")})
    assert "broken_law.c:4:" in err.value.message and "undeclared_gain" in err.value.message


# ------------------------------------------------------------------------------------------ the command
@needs_c
def test_mbs_simulate_takes_c_and_python_hooks(capsys, tmp_path):
    out = tmp_path / "run.csv"
    assert main(["simulate", str(EXAMPLE), "--t-end", "0.5", "--hook", f"friction_law={C_LAW}",
                 "--out", str(out)]) == 0
    c_run = Results.from_csv(out)
    assert main(["simulate", str(EXAMPLE), "--t-end", "0.5", "--hook", f"friction_law={PY_LAW}:friction_law",
                 "--out", str(out)]) == 0
    python_run = Results.from_csv(out)
    assert len(c_run) == len(python_run) == 51
    assert np.allclose(python_run["position"], c_run["position"], rtol=0, atol=1e-9)


@needs_c
def test_mbs_simulate_reports_a_c_hook_that_does_not_compile_with_file_and_line(capsys):
    broken = HERE / "hooks" / "broken_law.c"
    assert main(["simulate", str(EXAMPLE), "--hook", f"friction_law={broken}"]) == 1
    err = capsys.readouterr().err
    assert f"{broken}:4:" in err and "Traceback" not in err


@pytest.mark.parametrize("argv,status,text", [
    ([], 1, "hook_friction.mbs:23:5: error: hook 'friction_law' is declared but no implementation"),
    (["--hook", "friction_law"], 2, "expected NAME=file.c or NAME=module.py:function"),
    (["--hook", "friction_law=missing.c"], 2, "no C file missing.c"),
    (["--hook", f"friction_law={PY_LAW}:nothing"], 2, "has no function 'nothing'"),
    (["--hook", f"other={PY_LAW}:friction_law"], 2, "declares no hook 'other'"),
])
def test_mbs_simulate_hook_usage_errors(capsys, argv, status, text):
    assert main(["simulate", str(EXAMPLE), *argv]) == status
    err = capsys.readouterr().err
    assert text in err and "Traceback" not in err


@needs_c
def test_the_python_api_takes_a_module_file_by_name_as_the_command_line_does():
    system = mbs.load(EXAMPLE)
    law = f"{HERE / 'hooks' / 'friction_law_derivative.py'}:friction_law"
    by_name = system.simulate("cycles", t_end=0.5, hooks={"friction_law": law})
    plain = system.simulate("cycles", t_end=0.5, params={"plain": 1}, hooks={"friction_law": str(C_LAW)})
    assert by_name.success and np.max(np.abs(by_name["position"] - plain["position"])) < 1e-12
