"""The numerics report: the stiff mount is recognised as stiff and its fastest motion named; the pendulum is not."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.numerics_report import largest_stable_step, numerics_report

MODELS = Path(__file__).parent / "models"


def test_dopri5_stability_boundary_on_the_real_axis():
    # the DOPRI5 stability region reaches to about -3.3 on the negative real axis (Hairer, Norsett, Wanner I,
    # Fig. II.5.x); Hairer's code tests h |lambda| > 3.25 for stiffness
    assert 3.25 < largest_stable_step([-1.0]) < 3.35
    assert largest_stable_step([-1000.0]) == pytest.approx(largest_stable_step([-1.0]) / 1000, rel=1e-9)
    assert largest_stable_step([]) == np.inf


def test_stiff_mount_report():
    system = mbs.load(MODELS / "stiff_mount.mbs")
    data, settings = system.start("drop", jacobian=True)
    report = numerics_report(data.model, data, settings["t_end"], system.coordinate_owners(data.model))
    m, d, k = 1.0, 1e5, 1e9
    fast = (-d - np.sqrt(d * d - 4 * m * k)) / (2 * m)
    assert report.fastest.eigenvalue.real == pytest.approx(fast, rel=0.02)
    assert report.fastest.coordinate == "mount_guide.s"
    assert report.slowest.coordinate == "suspension.s"
    assert report.integrator == "rodas5p" and report.explicit_steps > 1e5
    assert "mount_guide" in report.text()


def test_pendulum_is_not_stiff():
    system = mbs.load("library/examples/pendulum.mbs")
    data, settings = system.start("swing", jacobian=True)
    report = numerics_report(data.model, data, settings["t_end"])
    # linearised at the start, 30 deg out: restoring stiffness m g l cos(phi0) over the inertia m l^2 + 1e-6
    omega = np.sqrt(9.81 * np.cos(np.radians(30)) / (1 + 1e-6))
    assert abs(report.fastest.eigenvalue.imag) == pytest.approx(omega, rel=1e-6)
    assert report.integrator == "dopri5"
