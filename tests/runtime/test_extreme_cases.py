"""Extreme cases (issue 11): each gives a checked result against a closed-form solution, or a clear diagnosis.

* a 1e-6 kg part next to a 1e3 kg one (mass matrix over nine decades): both motions against their closed forms;
* the round-off floor: the pendulum at rtol 1e-13 against the elliptic-integral period;
* a 1000 s conservative run: energy drift of every integrator (slow);
* a closed loop driven through singular configurations: the chain of three coupled four-bars through its flat
  positions, every integrator against the chain's one-coordinate equation (slow);
* the stiff mount: tests/runtime/test_stiffness.py.

Bounds: the runs are tolerance-controlled, so the global error is a multiple of rtol times the amplitude
that grows with the number of periods (at rtol 1e-8 over 160 periods of the tiny part: 2e-8 m for dopri5 and
rodasp, 3e-6 m for the BDF codes, whose phase error is larger). The mass-ratio runs use rtol 1e-10, where
every method stays well inside BOUND = 1e-6 m, still 1e-5 of the amplitudes and far below any modelling error
(a missing coupling term changes the tiny part's motion by its full forced amplitude, 2.4e-2 m).
"""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipk

import mbs

MODELS = Path(__file__).parent / "models"
G = 9.81
BOUND = 1e-6


@pytest.fixture(scope="module")
def mass_ratio():
    return mbs.load(MODELS / "mass_ratio.mbs")


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "auto", "cvode_bdf", "ida"])
def test_tiny_part_next_to_a_heavy_one(mass_ratio, integrator):
    res = mass_ratio.simulate("swing", integrator=integrator, rtol=1e-10, atol=1e-12)
    assert res.metadata["status"] == "finished", res.message
    m1, m2, k1, k2 = 1000.0, 1e-6, 1e6, 0.01
    w1, w2 = np.sqrt(k1 / m1), np.sqrt(k2 / m2)
    z_eq = 1.0 - (m1 + m2) * G / k1
    amplitude = 1.1 - z_eq
    t = res.t
    heavy = z_eq + amplitude * np.cos(w1 * t)  # the tiny part's pull (1e-8 N) shifts it by < 1e-14 m
    # the tiny part relative to the heavy one, w = s + l0: w'' + w2^2 w = -g - z1'' , w(0) = w'(0) = 0
    forced = amplitude * w1**2 / (w2**2 - w1**2)
    tiny = -G / w2**2 + forced * np.cos(w1 * t) + (G / w2**2 - forced) * np.cos(w2 * t) - 0.5
    assert np.max(np.abs(res["heavy_z"] - heavy)) < BOUND
    assert np.max(np.abs(res["tiny_guide.s"] - tiny)) < BOUND


def test_round_off_floor_rtol_1e_13():
    system = mbs.load("library/examples/pendulum.mbs")
    phi0 = np.radians(30)
    omega0 = np.sqrt(G / (1 + 1e-6))
    period = 4 / omega0 * ellipk(np.sin(phi0 / 2) ** 2)
    res = system.simulate("swing", t_eval=[0.0, period, 2 * period], rtol=1e-13, atol=1e-15)
    assert res.metadata["status"] == "finished", res.message
    # at the round-off floor the error is a few hundred ulps of the state after some 7,000 steps
    assert np.max(np.abs(res["hinge.phi"][1:] - phi0)) < 1e-11
    assert np.max(np.abs(res["der(hinge.phi)"][1:])) < 1e-10


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "cvode_adams", "cvode_bdf", "DOP853"])
def test_energy_drift_over_1000_s(integrator):
    system = mbs.load("library/examples/pendulum.mbs")
    res = system.simulate("swing", t_end=1000.0, sample=1.0, integrator=integrator, rtol=1e-8, atol=1e-10)
    assert res.metadata["status"] == "finished", res.message
    inertia = 1.0 + 1e-6
    phi, rate = res["hinge.phi"], res["der(hinge.phi)"]
    energy = 0.5 * inertia * rate**2 + G * (1 - np.cos(phi))
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    print(f"{integrator}: relative energy drift over 1000 s at rtol 1e-8: {drift:.2e}")
    # tolerance-proportional methods drift linearly in time, about rtol per period; 1000 s are 2200 periods
    assert drift < 1e-8 * 2200 * 10


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "auto", "cvode_adams", "cvode_bdf", "ida",
                                        "Radau", "BDF"])
def test_closed_loop_through_its_singular_positions(integrator, tmp_path):
    """Three coupled four-bars fall from upright through the flat position (every loop singular: the rank of
    its constraint Jacobian drops) and back (1.5 s, two crossings). Every integrator finishes, and the crank
    converges to the reference (scipy's DOP853 at 1e-13 on theta'' = -k cos(theta), tests/runtime/fourbar_chain.py)
    as the tolerance tightens; at rtol 1e-8 all are within 1e-6 rad (measured: 3e-9 (Radau) to 6.7e-7 (cvode_bdf))."""
    sys.path.insert(0, str(Path(__file__).parent))
    from fourbar_chain import fourbar_chain
    from test_fourbar_chain import reference

    system = mbs.loads(fourbar_chain(3), cache_dir=str(tmp_path))
    ref = reference(3, 1.5, 0.01)
    errors = []
    for rtol in (1e-6, 1e-8):
        res = system.simulate(t_end=1.5, sample=0.01, integrator=integrator, rtol=rtol, atol=1e-2 * rtol)
        assert res.metadata["status"] == "finished", res.message
        errors.append(np.max(np.abs(res["pivot0.phi"] - ref)))
    assert np.min(res["pivot0.phi"]) < -np.pi / 2  # through both flat positions
    assert errors[1] < 1e-6 and errors[1] < 0.3 * errors[0]


@pytest.mark.slow
def test_dop853_on_the_quarter_car_at_loose_tolerances(tmp_path):
    """scipy's DOP853 takes large steps at loose tolerances; their trial states lie far off the Iltis quarter
    car's loops, where the projection's Newton iteration may fail.  A failed projection makes the trial point
    answer a huge value (integrators/scipy_methods.py), so the step is rejected and shrunk, never taken with a
    wrong value: every run over the bump at 5 m/s finishes, and the wheel's travel converges to dopri5's at
    rtol 1e-10 (a different method, in C) as the tolerance tightens."""
    system = mbs.load(str(Path(__file__).parents[2] / "library" / "iltis" / "quarter_car.mbs"),
                      cache_dir=str(tmp_path))
    compiled = system.compile("bump_5")
    positions = compiled.x_names[:compiled.nq]
    ref = system.simulate("bump_5", integrator="dopri5", rtol=1e-10, atol=1e-12)
    assert ref.success, ref.message
    errors = []
    for rtol in (1e-3, 1e-4, 1e-5, 1e-6):
        res = system.simulate("bump_5", integrator="DOP853", rtol=rtol, atol=1e-2 * rtol)
        assert res.metadata["status"] == "finished", res.message
        # at the sample times both runs share (each run adds rows at both sides of its own events, and DOP853
        # at a loose tolerance locates a different number of them), the first row at each
        common = np.intersect1d(res.t, ref.t)
        at, at_ref = np.searchsorted(res.t, common), np.searchsorted(ref.t, common)
        assert len(common) >= 500  # the 2.5 s sampled every 5 ms
        errors.append(max(np.max(np.abs(res[name][at] - ref[name][at_ref])) for name in positions))
    print("DOP853 on the quarter car, largest position error against dopri5 at 1e-10:", errors)
    assert errors[-1] < 1e-5 and errors[-1] < 0.1 * errors[0]
