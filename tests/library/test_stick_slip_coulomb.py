"""library/examples/stick_slip_coulomb.mbs (the friction element) against the closed form of stick-slip.

The same closed form as tests/library/test_stick_slip.py (the hand-written mode and events): a stick phase at
the belt speed from x_k - d to x_k + d, a slip phase on a harmonic arc about x_k = mu_k m g / k with
omega = sqrt(k / m), d = (mu_s - mu_k) m g / k; amplitude A = sqrt(d^2 + (vb / omega)^2) about x_k, slip time
(pi + 2 atan2(vb / omega, d)) / omega, stick time 2 d / vb.  Here nobody wrote the holding force k s: the
compiler derived it from the equations of motion.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stickslipkit import (
    AMPLITUDE,
    MU_K,
    MU_S,
    T_SLIP,
    T_STICK,
    VB,
    X_K,
    D,
    G,
    K,
    M,
    times_of,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "library" / "examples" / "stick_slip_coulomb.mbs"
SLIP, GRIP = "contact.friction.slip", "contact.friction.grip"


@pytest.fixture(scope="module")
def system():
    return mbs.load(EXAMPLE)


@pytest.fixture(scope="module")
def run(system):
    return system.simulate("cycles")


def sticking_rows(res):
    """Samples inside a stick phase (from the start or a grip to the next slip), event rows excluded."""
    bounds = [0.0] + [e["time"] for e in res.events]
    inside = np.zeros(res.t.size, dtype=bool)
    starts = [0.0] + list(times_of(res, GRIP))
    for start in starts:
        later = [b for b in bounds if b > start]
        end = later[0] if later else np.inf
        inside |= ((res.t > start) | ((res.t == start) & (start == 0.0))) & (res.t < end)
    return inside


def test_stick_and_slip_alternate_with_the_closed_form_durations(run):
    assert run.success, run.message
    slips, grips = times_of(run, SLIP), times_of(run, GRIP)
    assert len(slips) >= 6 and len(grips) >= 6
    assert slips[0] == pytest.approx((X_K + D) / VB, abs=1e-12)  # sticks from s = 0 until k s = mu_s m g
    named = [e["event"] for e in run.events]
    assert named == [SLIP, GRIP] * (len(named) // 2) + [SLIP] * (len(named) % 2)
    np.testing.assert_allclose(grips - slips[:len(grips)], T_SLIP, atol=1e-9)
    np.testing.assert_allclose(np.diff(slips), T_SLIP + T_STICK, atol=1e-9)


def test_while_it_sticks_the_block_moves_with_the_belt_held_by_the_spring(run):
    sticking = sticking_rows(run)
    assert sticking.sum() > 100
    assert np.max(np.abs(run["velocity"][sticking] - VB)) <= 1e-9
    # the holding force the compiler derived is the spring's pull, k s, and within the static limit
    np.testing.assert_allclose(run["friction_force"][sticking], K * run["position"][sticking], atol=1e-9)
    assert np.all(np.abs(run["friction_force"][sticking]) <= MU_S * M * G + 1e-9)
    slipping = ~sticking & ~np.isin(run.t, [e["time"] for e in run.events])
    np.testing.assert_allclose(run["friction_force"][slipping], MU_K * M * G, rtol=1e-12)


def test_the_limit_cycle_amplitude_is_the_closed_form(system, run):
    slip, grip = times_of(run, SLIP)[2], times_of(run, GRIP)[2]
    res = system.simulate("cycles", t_eval=np.linspace(slip, grip, 20001))
    assert res["position"].max() == pytest.approx(X_K + AMPLITUDE, abs=1e-9)
    assert res["position"].min() == pytest.approx(X_K - AMPLITUDE, abs=1e-9)
