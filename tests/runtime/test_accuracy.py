"""Work-precision on the shipped pendulum: every integrator's error falls with its tolerance, and the reference
agrees with the closed-form period (complete elliptic integral) to its own stated accuracy."""

import numpy as np
import pytest
from scipy.special import ellipk

import mbs
from mbs.commands.accuracy import parse_tolerances
from mbs.runtime.accuracy import ATOL_RATIO, DEFAULT_INTEGRATORS, work_precision

PHI0 = np.radians(30.0)


@pytest.fixture(scope="module")
def pendulum():
    return mbs.load("library/examples/pendulum.mbs")


def test_every_integrator_gets_more_accurate_with_its_tolerance(pendulum):
    table = pendulum.accuracy("swing", t_end=2.0, tolerances=[1e-3, 1e-5, 1e-7], repeats=1)
    assert {r.integrator for r in table.rows} == set(DEFAULT_INTEGRATORS)
    for name in DEFAULT_INTEGRATORS:
        errors = [r.error for r in table.rows if r.integrator == name]
        assert all(r.status == "finished" for r in table.rows if r.integrator == name)
        assert errors[0] > errors[1] > errors[2] > table.reference_error, (name, errors)
    assert table.text().count("\n") == len(table.rows) + 1


def test_reference_agrees_with_the_elliptic_integral_period(pendulum):
    data, _ = pendulum.start("swing")
    m, l, g, iyy = 1.0, 1.0, 9.81, 1e-6  # the model's bob: a point mass on a massless rod, and its tiny inertia
    omega0 = np.sqrt(m * g * l / (m * l * l + iyy))
    period = 4.0 / omega0 * ellipk(np.sin(PHI0 / 2) ** 2)
    times = np.array([0.0, period / 2, period, 3 * period])
    table = work_precision(data.model, data, times[-1], t_eval=times, integrators=["dopri5"],
                           tolerances=[1e-8], repeats=1)
    assert 0 < table.reference_error < 1e-2 * table.rows[0].error  # far below the run it judges
    phi, rate = table.reference_states[:, 0], table.reference_states[:, 1]
    # a component's error is at most sqrt(n) times the weighted RMS norm times its weight
    bound = np.sqrt(2) * table.reference_error * (ATOL_RATIO + PHI0)
    assert abs(phi[2] - PHI0) <= bound and abs(phi[3] - PHI0) <= bound
    assert abs(phi[1] + PHI0) <= bound
    assert abs(rate[2]) <= np.sqrt(2) * table.reference_error * (ATOL_RATIO + 0.0) + bound * omega0


def test_tolerance_ladders():
    assert parse_tolerances("1e-3..1e-6") == [1e-3, 1e-4, 1e-5, 1e-6]
    assert parse_tolerances("1e-4,1e-8") == [1e-4, 1e-8]
    with pytest.raises(ValueError):
        parse_tolerances("fast")
