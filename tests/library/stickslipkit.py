"""The closed form of stick-slip that the two stick-slip examples are checked against (the hand-written mode and
events, library/examples/stick_slip.mbs, and the friction element, stick_slip_coulomb.mbs).

With constant kinetic friction the motion is a stick phase at the belt speed from x_k - d to x_k + d and a slip
phase on a harmonic arc about x_k = mu_k m g / k (omega = sqrt(k / m), d = (mu_s - mu_k) m g / k): amplitude
A = sqrt(d^2 + (vb / omega)^2) about x_k, slip time (pi + 2 atan2(vb / omega, d)) / omega, stick time 2 d / vb.
"""

from __future__ import annotations

import math

import numpy as np

M, K, VB, MU_S, MU_K, G = 1.0, 100.0, 0.2, 0.6, 0.4, 9.81
OMEGA = math.sqrt(K / M)
X_K = MU_K * M * G / K
D = (MU_S - MU_K) * M * G / K
AMPLITUDE = math.hypot(D, VB / OMEGA)
T_SLIP = (math.pi + 2 * math.atan2(VB / OMEGA, D)) / OMEGA
T_STICK = 2 * D / VB


def times_of(res, name):
    """The times of the events called `name` in a run's log."""
    return np.array([e["time"] for e in res.events if e["event"] == name])
