"""library/examples/stick_slip.mbs against its closed form: a mass on a spring, dragged by a belt with dry friction.

With constant kinetic friction the motion is a stick phase at the belt speed from x_k - d to x_k + d and a slip
phase on a harmonic arc about x_k = mu_k m g / k (omega = sqrt(k / m), d = (mu_s - mu_k) m g / k):
amplitude A = sqrt(d^2 + (vb / omega)^2) about x_k, slip time (pi + 2 atan2(vb / omega, d)) / omega, stick
time 2 d / vb.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stickslipkit import AMPLITUDE, T_SLIP, T_STICK, VB, X_K, D, times_of

EXAMPLE = Path(__file__).resolve().parents[2] / "library" / "examples" / "stick_slip.mbs"


@pytest.fixture(scope="module")
def system():
    return mbs.load(EXAMPLE)


@pytest.fixture(scope="module")
def run(system):
    return system.simulate("cycles")


def test_stick_and_slip_alternate_with_the_closed_form_durations(run):
    assert run.success, run.message
    slips, grips = times_of(run, "slip"), times_of(run, "grip")
    assert len(slips) >= 6 and len(grips) >= 6
    assert slips[0] == pytest.approx((X_K + D) / VB, abs=1e-12)  # sticks from s = 0 until k s = mu_s m g
    named = [e["event"] for e in run.events if e["event"] in ("slip", "grip")]
    assert named == ["slip", "grip"] * (len(named) // 2) + ["slip"] * (len(named) % 2)
    np.testing.assert_allclose(grips - slips[:len(grips)], T_SLIP, atol=1e-9)
    np.testing.assert_allclose(np.diff(slips), T_SLIP + T_STICK, atol=1e-9)


def test_while_it_sticks_the_mass_moves_with_the_belt(run):
    sticking = run["sticking"] > 0.5
    assert sticking.sum() > 100
    assert np.max(np.abs(run["der(slide.s)"][sticking] - VB)) <= 1e-9
    grips = times_of(run, "grip")
    rows = np.isin(run.t, grips) & sticking
    np.testing.assert_allclose(run["slide.s"][rows], X_K - D, atol=1e-9)  # where the slip arc ends


def test_the_limit_cycle_amplitude_is_the_closed_form(system, run):
    slip, grip = times_of(run, "slip")[2], times_of(run, "grip")[2]
    res = system.simulate("cycles", t_eval=np.linspace(slip, grip, 20001))
    assert res["slide.s"].max() == pytest.approx(X_K + AMPLITUDE, abs=1e-9)
    assert res["slide.s"].min() == pytest.approx(X_K - AMPLITUDE, abs=1e-9)


def test_a_stribeck_drop_shortens_the_slip(system):
    res = system.simulate("cycles", params={"stribeck": 1.0})
    assert res.success, res.message
    slips, grips = times_of(res, "slip"), times_of(res, "grip")
    assert len(grips) >= 3 and np.all(grips - slips[:len(grips)] > 0)
    assert not np.allclose(grips - slips[:len(grips)], T_SLIP, atol=1e-3)
