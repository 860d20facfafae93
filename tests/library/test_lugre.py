"""library/forces/lugre.mbs (LuGre friction, bristle deflection as an extra state) in library/examples/
lugre_block.mbs against scipy's Radau on the equations of Canudas de Wit et al. (1995), written here by hand:

    m x'' = k (vp t - x) - F,   z' = v - sigma0 |v| z / g(v),   g(v) = fc + (fs - fc) exp(-(v / vs)^2),
    F = sigma0 z + sigma1 z' + sigma2 v,   v = x'.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbs

EXAMPLE = Path(__file__).resolve().parents[2] / "library" / "examples" / "lugre_block.mbs"
M, K, VP = 1.0, 2.0, 0.1
SIGMA0, SIGMA1, SIGMA2, FC, FS, VS = 1e5, 316.227766, 0.4, 1.0, 1.5, 0.001
T_END = 8.0


def reference(t_eval):
    def g(v):
        return FC + (FS - FC) * math.exp(-(v / VS) ** 2)

    def f(t, y):
        x, v, z = y
        zdot = v - SIGMA0 * abs(v) * z / g(v)
        friction = SIGMA0 * z + SIGMA1 * zdot + SIGMA2 * v
        return [v, (K * (VP * t - x) - friction) / M, zdot]
    sol = solve_ivp(f, (0.0, t_eval[-1]), [0.0, 0.0, 0.0], t_eval=t_eval, method="Radau", rtol=1e-11, atol=1e-13)
    assert sol.success
    return sol.y


@pytest.fixture(scope="module")
def run():
    return mbs.load(EXAMPLE).simulate("pull", t_end=T_END, rtol=1e-10, atol=1e-12)


def test_the_block_moves_as_the_hand_written_lugre_equations(run):
    x, v, z = reference(run.t)
    assert np.max(np.abs(run["slide.s"] - x)) < 1e-8
    assert np.max(np.abs(run["friction.z"] - z)) < 1e-10  # deflections are ~1e-5 m
    assert np.max(np.abs(run["speed"] - v)) < 1e-7


def test_it_sticks_and_slips_with_the_break_away_force_as_the_peak(run):
    spring = run["spring_force"]
    # the block breaks away when the spring force reaches the static level fs and sticks again below fc
    assert FC < spring.max() < 1.1 * FS
    sticking = np.abs(run["speed"]) < 1e-3
    assert sticking.any() and (~sticking).any()
    assert np.max(np.abs(run["friction.z"])) <= FS / SIGMA0 * 1.01  # the bristles deflect at most fs / sigma0
