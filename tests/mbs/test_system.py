"""The Python API and the simulate/compile/eom/info commands, end to end from text to results."""

import math

import numpy as np
import pytest

import mbs
import mbs.language.frontend
from mbs.cli import main
from mbs.pipeline import parameter_values

PENDULUM = """
model p {
    param l = 1 m
    param l2 = 2 * l
    rigid bob {
        body {
            mass = 1 kg
            com = (0, 0, -l)
            inertia = diag(0, 0, 0) kg*m^2
        }
    }
    interact hinge {
        connect inertial -> bob
        joint revolute(axis = y) {
            init phi = 5 deg
        }
    }
}
scene quick {
    t_end = 1 s
    sample = 0.1 s
    param l = 0.5 m
}
"""


def test_simulate_a_scene_and_read_results_by_name():
    system = mbs.loads(PENDULUM)
    res = system.simulate("quick")
    assert res.success
    assert res.t[0] == 0 and res.t[-1] == pytest.approx(1.0) and len(res.t) == 11
    # small-amplitude pendulum of length 0.5 m (the scene's value): phi = phi0 cos(w t)
    w = math.sqrt(9.81 / 0.5)
    assert res["hinge.phi"] == pytest.approx(math.radians(5) * np.cos(w * res.t), abs=2e-4)


def test_changing_a_parameter_needs_no_recompile():
    system = mbs.loads(PENDULUM)
    compiled = system.compile("quick")
    fast = system.simulate("quick", params={"l": 0.25})
    assert system.compile("quick") is compiled
    w = math.sqrt(9.81 / 0.25)
    assert fast["hinge.phi"] == pytest.approx(math.radians(5) * np.cos(w * fast.t), abs=2e-4)


def test_dependent_parameter_defaults_follow_overrides():
    model = mbs.loads(PENDULUM).model
    assert parameter_values(model)["l2"] == 2.0
    assert parameter_values(model, {"l": 3.0})["l2"] == 6.0


def test_cli_simulate_writes_csv_and_plot(tmp_path, capsys):
    path = tmp_path / "p.mbs"
    path.write_text(PENDULUM)
    out, plot = tmp_path / "r.csv", tmp_path / "r.png"
    assert main(["simulate", str(path), "--out", str(out), "--plot", str(plot), "--param", "l=50cm"]) == 0
    header = [line for line in out.read_text().splitlines() if not line.startswith("#")][0]
    assert header.split(",")[:2] == ["time", "hinge.phi"]
    assert plot.stat().st_size > 1000
    assert "scene quick" in capsys.readouterr().out


def test_cli_param_with_wrong_unit_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "p.mbs"
    path.write_text(PENDULUM)
    assert main(["simulate", str(path), "--param", "l=2kg"]) == 2  # a usage error
    assert "expected length (m), got mass (kg)" in capsys.readouterr().err


def test_cli_compile_writes_a_standalone_library(tmp_path):
    assert main(["compile", "library/examples/pendulum.mbs", "-o", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["libpendulum.so", "pendulum.c", "pendulum.h"]
    header = (tmp_path / "pendulum.h").read_text()
    assert "int pendulum_rhs(double t, const double *x, const double *p, double *xdot, double *work);" in header


def test_cli_eom_prints_readable_equations(capsys):
    assert main(["eom", "library/examples/pendulum.mbs"]) == 0
    out = capsys.readouterr().out
    assert "sin(hinge.phi)" in out and "M[1,1] = l**2*m + 1/1000000" in out  # exact: no 1.0e-6


def test_cli_info_shows_the_spanning_tree(capsys):
    assert main(["info", "library/iltis/quarter_car.mbs"]) == 0
    out = capsys.readouterr().out
    assert "loop closed by fl.upper_ball" in out


@pytest.mark.parametrize("path", ["library/examples/pendulum.mbs", "library/examples/double_pendulum.mbs",
                                  "library/examples/spatial_chain.mbs", "library/examples/two_mass_quarter_car.mbs"])
def test_every_shipped_tree_model_simulates_from_the_command_line(path, tmp_path):
    plot = tmp_path / "out.png"
    assert main(["simulate", path, "--plot", str(plot), "--t-end", "0.5"]) == 0
    assert plot.exists()


def test_numpy_back_end_gives_the_same_run_as_c():
    """Machines without a C compiler run the generated NumPy code; both back ends agree."""
    c_run = mbs.loads(PENDULUM).simulate("quick", integrator="RK45", rtol=1e-10, atol=1e-12)
    np_run = mbs.loads(PENDULUM, backend="numpy").simulate("quick", integrator="RK45", rtol=1e-10, atol=1e-12)
    assert np_run.metadata["backend"] == "numpy" if hasattr(np_run, "metadata") else True
    assert np_run["hinge.phi"] == pytest.approx(c_run["hinge.phi"], rel=1e-12, abs=1e-14)


def test_wheel_jumping_over_a_bump_on_the_library_tyre_never_pulls():
    """A wheel crossing a bump fast enough to lift off: the unilateral tyre force stays >= 0 throughout."""
    from tests.language.test_models import TYRE_ON_A_GUIDE
    text = TYRE_ON_A_GUIDE.replace(
        "joint planar(normal = y, direction = x)",
        "joint planar(normal = y, direction = x) {\n            init x = -1 m\n            init y = -0.364 m\n"
        "            init der(x) = 4 m/s\n        }").replace(
        "use tyres.point_contact", "output load = tyre.radial.load\n    use tyres.point_contact")
    system = mbs.System(mbs.language.frontend.load_text(text, directory="library"))
    res = system.simulate(t_end=1.0, sample=0.002, integrator="rodasp", rtol=1e-7, atol=1e-9)
    assert res.success, res.message
    assert min(res["tyre.deflection"]) < 0          # it did lift off
    assert min(res["load"]) >= 0.0                   # and the tyre never pulled it down
    assert max(res["load"]) > 50 * 9.81             # landing and climbing load the tyre above the weight


def test_cli_equilibrium_reports_the_resting_state(capsys):
    assert main(["equilibrium", "library/iltis/quarter_car.mbs", "--scene", "settle"]) == 0
    out = capsys.readouterr().out
    assert "static equilibrium" in out and "tyre.radial.load" in out


def test_a_scene_run_again_binds_its_parameters_once_and_each_run_gets_its_own_copy(monkeypatch):
    """System keeps the last parameter bindings (mbs/system.py KEPT_BINDINGS): the same overrides are bound and
    checked once, a caller that changes the values it got changes nothing the next run reads, and a sweep keeps
    no more than KEPT_BINDINGS of them."""
    import mbs.system as system_module
    system = mbs.loads(PENDULUM)
    bound = []
    real = system_module.pipeline.parameter_values
    monkeypatch.setattr(system_module.pipeline, "parameter_values", lambda *a: bound.append(1) or real(*a))
    first = system._parameter_values(system.scene("quick"), {"l": 0.25})
    first["l"] = 99.0
    again = system._parameter_values(system.scene("quick"), {"l": 0.25})
    assert len(bound) == 1 and again["l"] == 0.25 and again["l2"] == 0.5
    for k in range(2 * system_module.KEPT_BINDINGS):
        system._parameter_values(None, {"l": 1.0 + k})
    assert len(system._bindings) == system_module.KEPT_BINDINGS
    res = system.simulate("quick", params={"l": 0.25})
    w = math.sqrt(9.81 / 0.25)
    assert res["hinge.phi"] == pytest.approx(math.radians(5) * np.cos(w * res.t), abs=2e-4)


def test_a_compile_into_an_empty_cache_starts_the_runtime_object_as_the_derivation_starts(tmp_path, monkeypatch):
    """The runtime unit (the bindings and the integrators) depends on no model: with an empty cache it is being
    compiled (or is done) before the equations' C is written, and build takes it from there: compiled once."""
    from mbs.runtime import build
    cc = tuple(build.compiler_command())
    files = {build.RUNTIME_UNIT: build._runtime_unit()}
    ((_, _, runtime),) = build._unit_jobs(files, build.base_flags(cc), (), cc, tmp_path)
    seen, compiled = [], []
    prebuild, run = build.prebuild, build._run
    monkeypatch.setattr(build, "prebuild", lambda code, **options: seen.append(
        runtime in build._PREBUILDS or runtime.exists()) or prebuild(code, **options))
    monkeypatch.setattr(build, "_run", lambda command, *a: compiled.append(
        command[command.index("-c") + 1] if "-c" in command else "link") or run(command, *a))
    mbs.load("library/examples/pendulum.mbs", cache_dir=tmp_path).compile("swing")
    assert seen == [True] and compiled.count(build.RUNTIME_UNIT) == 1 and runtime.exists()
    assert not build._PREBUILDS
