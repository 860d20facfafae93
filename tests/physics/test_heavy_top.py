"""The heavy symmetric (Lagrange) top of library/examples: against its closed-form nutation bounds and its
three first integrals, and the top written with its inertia about the tip against the same top about its
centre of mass.

With theta the angle of the figure axis from the vertical, u = cos(theta), transverse and axial moments A, C
about the tip, the spin L3 and the vertical angular momentum Lz constant (Goldstein, Classical Mechanics,
sec. 5.7):

    u'^2 = f(u) = (1 - u^2)(alpha - beta u) - (b - a u)^2,
    alpha = 2 E' / A,  beta = 2 m g l / A,  a = L3 / A,  b = Lz / A,  E' = E - L3^2 / (2 C)

and u stays between the two roots of the cubic f in [-1, 1]. Released without nutation rate (theta' = 0) and
without precession, the start u0 is one root; the other bounds the nutation.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import physkit  # noqa: E402

import mbs  # noqa: E402
from mbs.language import expr as X  # noqa: E402

EXAMPLES = Path(__file__).parents[2] / "library" / "examples"
G = 9.81
RTOL, ATOL = 1e-10, 1e-12
QUAT = ["pivot.qw", "pivot.qx", "pivot.qy", "pivot.qz"]
OMEGA = ["pivot.wx", "pivot.wy", "pivot.wz"]


@pytest.fixture(scope="module")
def runs():
    out = {}
    for name in ("heavy_top", "tip_top"):
        system = mbs.load(EXAMPLES / f"{name}.mbs")
        res = system.simulate("nutation", rtol=RTOL, atol=ATOL)
        assert res.success, res.message
        out[name] = (system, res)
    return out


def top_constants(system):
    p = {q.name: q.value for q in system.model.parameters}
    A_tip = p["A"] + p["m"] * p["l"] ** 2
    return p["m"], p["l"], A_tip, p["C"], p["tilt"], p["spin"]


def invariants(res, m, l, A, C):
    """Energy, spin L3 and vertical angular momentum Lz about the tip, at every sample."""
    q = np.column_stack([res[n] for n in QUAT])
    w = np.column_stack([res[n] for n in OMEGA])
    R = np.array([physkit.quat_matrix(qi) for qi in q])
    inertia = np.array([A, A, C])
    energy = 0.5 * np.sum(inertia * w * w, axis=1) + m * G * l * R[:, 2, 2]
    L_inertial = np.einsum("nij,nj->ni", R, inertia * w)
    return energy, C * w[:, 2], L_inertial[:, 2], R[:, 2, 2]


def nutation_roots(m, l, A, C, tilt, spin):
    """The two roots of f(u) in [-1, 1] for the release without theta' and precession."""
    u0 = np.cos(tilt)
    L3 = C * spin
    Lz = L3 * u0
    E_prime = m * G * l * u0  # E - L3^2 / (2C): the release has no transverse angular velocity
    alpha, beta, a, b = 2 * E_prime / A, 2 * m * G * l / A, L3 / A, Lz / A
    # f(u) = (1 - u^2)(alpha - beta u) - (b - a u)^2 as a cubic in u
    cubic = np.polynomial.Polynomial([alpha - b * b, -beta + 2 * a * b, -alpha - a * a, beta])
    roots = sorted(r.real for r in cubic.roots() if abs(r.imag) < 1e-12 and -1 - 1e-12 <= r.real <= 1 + 1e-12)
    return roots


def test_nutation_stays_between_the_closed_form_bounds_and_reaches_both(runs):
    system, res = runs["heavy_top"]
    m, l, A, C, tilt, spin = top_constants(system)
    roots = nutation_roots(m, l, A, C, tilt, spin)
    assert len(roots) == 2 and np.isclose(max(roots), np.cos(tilt), atol=1e-12)
    *_, u = invariants(res, m, l, A, C)
    lower, upper = roots
    assert upper - lower > 1e-3  # a visible nutation, so that reaching the bound means something
    assert u.max() == pytest.approx(upper, abs=1e-8)
    assert u.min() >= lower - 1e-8
    # sampled every 1 ms, the samples miss the turning point by u'' dt^2 / 8 at most
    assert u.min() == pytest.approx(lower, abs=1e-3 * (upper - lower))


def test_energy_spin_and_vertical_momentum_are_conserved(runs):
    system, res = runs["heavy_top"]
    m, l, A, C, tilt, spin = top_constants(system)
    energy, L3, Lz, _ = invariants(res, m, l, A, C)
    assert np.ptp(energy) < 1e-8 * abs(energy[0]) + 1e-12
    assert np.ptp(L3) < 1e-8 * abs(L3[0])
    assert np.ptp(Lz) < 1e-8 * abs(L3[0])
    assert L3[0] == pytest.approx(C * spin)


def test_the_top_with_inertia_about_the_tip_moves_as_the_top_about_its_centre_of_mass(runs):
    _, about_com = runs["heavy_top"]
    system, about_tip = runs["tip_top"]
    p = {q.name: q.value for q in system.model.parameters}
    assert p["A_tip"] == pytest.approx(1.5e-4 + p["m"] * p["l"] ** 2)  # the examples describe one top
    for name in QUAT + OMEGA:
        scale = np.abs(about_com[name]).max()
        assert np.abs(about_tip[name] - about_com[name]).max() < 1e-7 * scale, name


def test_the_shifted_inertia_is_the_centre_of_mass_inertia():
    """The compiler's parallel-axis shift, read back from the data model, against the written one."""
    com = mbs.load(EXAMPLES / "heavy_top.mbs").model
    tip = mbs.load(EXAMPLES / "tip_top.mbs").model
    values = {p.name: p.value for p in tip.parameters}
    def body(model):
        return next(part.body for part in model.parts if part.name == "top")
    shifted = np.array([[X.evaluate(c, values) for c in row] for row in body(tip).inertia])
    written = np.array([[X.evaluate(c, {p.name: p.value for p in com.parameters}) for c in row]
                        for row in body(com).inertia])
    assert np.allclose(shifted, written, rtol=0, atol=1e-15)
