"""Stiffness: dopri5 detects it on the stiff mount and names the mount; auto switches and finishes quickly; a
non-stiff model raises no warning and auto stays explicit there."""

from pathlib import Path

import numpy as np
import pytest

import mbs

MODELS = Path(__file__).parent / "models"


@pytest.fixture(scope="module")
def stiff_mount():
    return mbs.load(MODELS / "stiff_mount.mbs")  # (the default cache: test_jacobian's build of it)


def test_dopri5_warns_once_naming_the_mount(stiff_mount):
    res = stiff_mount.simulate("drop", t_end=0.05)
    [warning] = res.metadata["warnings"]
    assert "dominated by mount_guide.s" in warning and "force mount_guide.mount" in warning
    assert "rodasp" in warning
    # the fastest eigenvalue of the mount: the larger root of m s^2 + d s + k = 0 (the body above is 100x
    # heavier and 1e5 times softer, so it barely shifts it)
    m, d, k = 1.0, 1e5, 1e9
    fast = (-d - np.sqrt(d * d - 4 * m * k)) / (2 * m)
    quoted = float(warning.split("eigenvalue ")[1].split(" ")[0])
    assert quoted == pytest.approx(fast, rel=0.02)


@pytest.mark.parametrize("integrator", ["auto", "rodasp", "rodas5p", "BDF", "cvode_bdf", "ida"])
def test_auto_and_the_stiff_integrators_finish_in_few_steps(stiff_mount, integrator):
    res = stiff_mount.simulate("drop", integrator=integrator)
    assert res.metadata["status"] == "finished"
    assert res.metadata["stats"]["nsteps"] < 2000
    assert res["body_z"][-1] == pytest.approx(0.5 - 100 * 9.81 / 1e4, abs=2e-3)


def test_auto_switches_only_when_stiff():
    system = mbs.load("library/examples/pendulum.mbs")
    res = system.simulate(integrator="auto", t_end=5.0)
    reference = system.simulate(integrator="dopri5", t_end=5.0)
    assert res.metadata["warnings"] == [] and reference.metadata["warnings"] == []
    assert res.metadata["stats"] == reference.metadata["stats"]  # dopri5 throughout, step for step
