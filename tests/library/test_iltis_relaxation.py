"""The tyre relaxation length on the Iltis (library/iltis/vehicle.mbs: input relax, scene steer_ramp_20_relax).

A first-order relaxation with length sigma makes the slip angle, and with it the lateral force, follow the
steering through a lag of time constant sigma / V (V = 20 m/s: 25 ms). Checked on the front axle's lateral
force: the relaxed run's force is the plain run's passed through a first-order lag, and the time constant that
fits best is sigma / V. Not to the digit: the camber part of the Calspan force is not relaxed, and the car
responds a little later with the lag, so its own contribution to the slip differs (the fitted constant is
20 ms; 0 ms and 50 ms fit five times worse). Off (the default), the model has no state at all.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbs
from mbs.runtime import comfort

SIGMA, V = 0.5, 20.0   # the scene's relaxation length and speed
FRONT = ("tyre_fl.radial.forces.fy", "tyre_fr.radial.forces.fy")


def lagged(t: np.ndarray, f: np.ndarray, tau: float) -> np.ndarray:
    """f (linear between samples) through tau y' + y = f, y(t0) = 0: exact for the piecewise-linear input."""
    y = np.zeros_like(f)
    for k in range(1, t.size):
        h = t[k] - t[k - 1]
        e, slope = np.exp(-h / tau), (f[k] - f[k - 1]) / h
        y[k] = y[k - 1] * e + f[k] - slope * tau - (f[k - 1] - slope * tau) * e
    return y


def axle_force(res) -> np.ndarray:
    """The front axle's lateral force from its value at the start (the rack starts moving at 0.2 s)."""
    f = sum(res[name] for name in FRONT)
    return f - f[0]


@pytest.mark.slow
def test_relaxation_length_makes_the_front_lateral_force_lag_the_steering_by_sigma_over_v():
    vehicle = mbs.load("library/iltis/vehicle.mbs")
    assert vehicle.generate("steer_ramp_20").z_names == ()
    assert vehicle.generate("steer_ramp_20_relax").z_names == tuple(
        f"tyre_{c}.radial.contact.alpha_r" for c in ("fl", "fr", "rl", "rr"))
    plain = vehicle.simulate("steer_ramp_20", t_end=0.5, sample=0.001)
    relaxed = vehicle.simulate("steer_ramp_20_relax", t_end=0.5, sample=0.001)
    assert plain.success and relaxed.success
    # on the samples alone: each run also has a row before and after each of its own events
    samples = [comfort.sample_rows(res.t) for res in (plain, relaxed)]
    assert np.array_equal(plain.t[samples[0]], relaxed.t[samples[1]])
    t, f0, f1 = plain.t[samples[0]], axle_force(plain)[samples[0]], axle_force(relaxed)[samples[1]]
    assert np.max(np.abs(f1)) > 400  # the ramp builds up a real force (N)
    taus = np.arange(0.002, 0.06, 0.0005)
    misfit = np.array([np.sqrt(np.mean((f1 - lagged(t, f0, tau))**2)) for tau in taus])
    best = taus[int(np.argmin(misfit))]
    assert best == pytest.approx(SIGMA / V, rel=0.25)
    assert misfit.min() < 0.01 * np.max(np.abs(f1))                       # a lag describes it to 1 %
    no_lag = np.sqrt(np.mean((f1 - f0)**2))
    assert no_lag > 5 * misfit.min()
    twice = misfit[int(np.argmin(np.abs(taus - 2 * SIGMA / V)))]
    assert twice > 5 * misfit.min()
