"""Optimisation on Dask: a constrained optimum with a closed-form answer (the longest pendulum whose period stays
below a bound), the optimum written as a scene that runs, bad constraints as errors."""

from __future__ import annotations

import math

import pytest

import mbs
from mbs import MbsError
from mbs.cli import main
from mbs.studies.optimize import Constraint, optimize

pytest.importorskip("distributed")
G, I_BOB = 9.81, 1e-6


def length_with_period(period: float) -> float:
    """The compound pendulum (tests/studies/test_sweep.py) from 30 deg: T = 4 sqrt((l^2 + I)/(g l)) K; solved
    for l by the quadratic l^2 - c l + I = 0 with c = g (T / 4K)^2 (the larger root)."""
    from scipy.special import ellipk
    c = G * (period / (4 * ellipk(math.sin(math.radians(15)) ** 2))) ** 2
    return (c + math.sqrt(c * c - 4 * I_BOB)) / 2


def test_the_constraint_is_active_at_the_closed_form_length(dask_client):
    system = mbs.load("library/examples/pendulum.mbs")
    opt = optimize(system, "swing", "-period(hinge.phi)", {"l": (0.5, 3.0)},
                   constraints=["period(hinge.phi) <= 2.5"], maxiter=10, client=dask_client)
    assert opt.feasible and opt.constraints["period(hinge.phi)"] <= 2.5
    # differential evolution's tolerance, and the period from 0.01 s samples: 2e-3 of the length
    assert opt.x["l"] == pytest.approx(length_with_period(2.5), rel=2e-3)
    assert opt.log and opt.log[-1]["value"] == pytest.approx(opt.value)
    assert len(opt.rows) == opt.evaluations  # every run kept, none repeated
    assert "scene swing_optimum" in opt.scene_text and f"param l = {opt.x['l']:.10g} m" in opt.scene_text


def test_cli_writes_a_scene_that_runs(dask_client, tmp_path, capsys):
    out = tmp_path / "pendulum_opt.mbs"
    status = main(["optimize", "library/examples/pendulum.mbs", "--scene", "swing", "--param", "l=50cm:3m",
                   "--maximize", "period(hinge.phi)", "--constraint", "period(hinge.phi) <= 2.5",
                   "--maxiter", "3", "--popsize", "4", "--scheduler", dask_client.scheduler.address,
                   "-o", str(out), "--out", str(tmp_path / "runs.csv")])
    printed = capsys.readouterr().out
    assert status == 0 and "generation   1" in printed and "optimum:" in printed
    system = mbs.load(out)
    res = system.simulate("swing_optimum")
    l_best = float(printed.split("optimum: ")[1].split(" at l = ")[1].split(" ")[0])
    assert system.model.scene("swing_optimum").params  # the optimum's parameter is set in the scene
    assert res.success and res.t[-1] == 10.0
    lines = (tmp_path / "runs.csv").read_text().splitlines()
    assert any(line.startswith(f"{l_best:.6g}"[:5]) for line in lines if not line.startswith("#"))


@pytest.mark.parametrize("text", ["peak(x) < 3", "peak(x) <= ", "3 >= peak(x)"])
def test_constraints_need_a_metric_a_sense_and_a_number(text):
    with pytest.raises(MbsError, match="expected 'METRIC <= NUMBER'"):
        Constraint.parse(text)
