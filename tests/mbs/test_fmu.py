"""FMI 2.0 export checked by an independent FMI client (FMPy): its validation passes, and FMPy's Model Exchange
(its own CVODE) and Co-Simulation runs agree with `mbs simulate` to 1e-5 on trees, closed loops and a scene that
starts from static equilibrium."""

from __future__ import annotations

import numpy as np
import pytest

import mbs
from mbs.cli import main
from mbs.fmu import export_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

CASES = [  # file, scene, t_end (the double pendulum is chaotic: a horizon over which 1e-5 is meaningful)
    ("library/examples/pendulum.mbs", "swing", None),
    ("library/examples/double_pendulum.mbs", "chaos", 3.0),
    ("library/examples/slider_crank.mbs", None, None),
    ("library/examples/two_mass_quarter_car.mbs", "bump", None),
    ("library/iltis/quarter_car.mbs", "bump_5", None),
]


def compare(system, scene, fmu, res, params=None):
    """Largest difference of states and outputs between FMPy (ME and CS) and our results, relative to 1 + peak."""
    compiled = system.compile(scene)
    md = read_model_description(str(fmu))
    names = [v.name for v in md.modelVariables if v.causality == "output" or v.name in compiled.x_names]
    dt = res.t[1] - res.t[0]
    ours = on_grid(res.t, dt)
    worst = {}
    for kind in ("ModelExchange", "CoSimulation"):
        out = simulate_fmu(str(fmu), fmi_type=kind, stop_time=res.t[-1], output_interval=dt,
                           relative_tolerance=1e-10, output=list(dict.fromkeys(names)), start_values=params or {})
        theirs = on_grid(out["time"], dt)
        assert len(theirs) == len(ours)
        worst[kind] = max(np.max(np.abs(out[n][theirs] - res[n][ours])) / (1 + np.max(np.abs(res[n])))
                          for n in names)
    return worst


def on_grid(t, dt):
    """Rows at the output times k dt, once each: both sides add rows at events (a switch of the road's bump, the
    set-point step), where the state is continuous; the sample grid is what the two runs share."""
    k = np.round(t / dt)
    on = np.flatnonzero(np.abs(t - k * dt) <= 1e-9 * dt)
    return on[np.concatenate([[True], k[on][1:] != k[on][:-1]])]


@pytest.mark.parametrize("path, scene, t_end", CASES, ids=[c[0].rsplit("/", 1)[1] for c in CASES])
def test_fmpy_validates_and_agrees_with_simulate(path, scene, t_end, tmp_path):
    system = mbs.load(path)
    fmu = export_fmu(system, scene, tmp_path / "model.fmu")
    assert validate_fmu(str(fmu)) == []
    res = system.simulate(scene, t_end=t_end, rtol=1e-11, atol=1e-12)
    assert res.success
    for kind, error in compare(system, scene, fmu, res).items():
        assert error < 1e-5, f"{kind}: {error:.3g}"


def test_parameters_are_tunable_start_values(tmp_path):
    system = mbs.load("library/examples/pendulum.mbs")
    fmu = export_fmu(system, "swing", tmp_path / "p.fmu")
    res = system.simulate("swing", params={"l": 2.0}, t_end=3.0, rtol=1e-11, atol=1e-12)
    for kind, error in compare(system, "swing", fmu, res, params={"l": 2.0}).items():
        assert error < 1e-5, f"{kind}: {error:.3g}"


def test_model_description_lists_units_descriptions_and_outputs(tmp_path):
    system = mbs.load("library/examples/pendulum.mbs")
    md = read_model_description(str(export_fmu(system, "swing", tmp_path / "p.fmu")))
    variables = {v.name: v for v in md.modelVariables}
    assert variables["l"].causality == "parameter" and variables["l"].unit == "m"
    assert variables["l"].description == "rod length" and float(variables["l"].start) == 1.0
    assert variables["hinge.phi"].causality == "output"  # the scene outputs the coordinate itself
    assert variables["hinge.pivot_force.fz"].causality == "output"
    assert [d.variable.name for d in md.derivatives] == ["hinge.phi'", "der(hinge.phi)'"]
    assert md.defaultExperiment.stopTime == "10.0"


def test_cli_refuses_a_wrong_suffix(capsys):
    assert main(["fmu", "library/examples/pendulum.mbs", "-o", "pendulum.zip"]) == 1
    assert "an FMU file ends in .fmu" in capsys.readouterr().err


def test_switches_are_event_indicators_in_model_exchange_and_located_in_co_simulation(tmp_path):
    """The stiff arm's set-point step (a switch by default): FMPy's Model Exchange (its CVODE locating the
    indicator's root) and our Co-Simulation pass the step and agree with `mbs simulate`, which is checked against
    the hand-written arm in tests/runtime/test_switches_by_default.py.  Observed, relative to 1 + peak: 2e-7 (ME,
    FMPy's CVODE on the whirling elbow), 2e-12 (CS)."""
    system = mbs.load("tests/runtime/models/stiff_arm.mbs")
    fmu = export_fmu(system, None, tmp_path / "arm.fmu")
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.numberOfEventIndicators == 1
    assert not any(v.name.startswith("switch.") for v in md.modelVariables)  # branch flags are internal
    res = system.simulate(t_end=0.7, sample=0.001, rtol=1e-10, atol=1e-12)
    for kind in ("ModelExchange", "CoSimulation"):
        out = simulate_fmu(str(fmu), fmi_type=kind, stop_time=0.7, output_interval=0.001, relative_tolerance=1e-9,
                           output=["shoulder.phi", "elbow.phi"])
        ours, theirs = on_grid(res.t, 0.001), on_grid(out["time"], 0.001)  # ME records the event's two rows too
        assert len(ours) == len(theirs) == 701
        for name in ("shoulder.phi", "elbow.phi"):  # the elbow whirls through 22 rad after the step
            error = np.max(np.abs(out[name][theirs] - res[name][ours])) / (1 + np.max(np.abs(res[name])))
            assert error < 1e-6, (kind, name, error)
        assert out["shoulder.phi"][-1] == pytest.approx(-np.pi / 4, abs=1e-5)
