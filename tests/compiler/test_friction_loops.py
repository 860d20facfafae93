"""Switched dry friction in a tree joint of a closed loop (compiler/friction_loops.py): the slider-crank of
models/friction_loops.mbs, a spring on the slider and coulomb friction in its guide, against scipy on the
hand-written one-degree-of-freedom equation of the mechanism (Lagrange in the crank angle, the kinetic energy
derived with sympy from the geometry) and against the closed-form holding force of a locked mechanism."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import mbs

MODEL = Path(__file__).parent / "models" / "friction_loops.mbs"
R, L, M_CRANK, M_ROD, M_SLIDER, K, L0, N = 0.1, 0.4, 1.0, 0.5, 2.0, 2000.0, 0.45, 50.0
PHI0 = math.radians(70)


def slider_crank():
    """x_s(phi), x_s'(phi), the generalized mass M(phi) and M'(phi) of the crank angle, from the geometry."""
    phi = sp.Symbol("phi")
    pin = sp.Matrix([R * sp.cos(phi), R * sp.sin(phi)])
    xs = R * sp.cos(phi) + sp.sqrt(L ** 2 - (R * sp.sin(phi)) ** 2)
    rod_centre = (pin + sp.Matrix([xs, 0])) / 2
    rod_angle = sp.atan2(-pin[1], xs - pin[0])
    vc, wr, vs = rod_centre.diff(phi), rod_angle.diff(phi), xs.diff(phi)
    mass = M_CRANK * R ** 2 / 3 + M_ROD * vc.dot(vc) + M_ROD * L ** 2 / 12 * wr ** 2 + M_SLIDER * vs ** 2
    return tuple(sp.lambdify(phi, e, "math") for e in (xs, vs, mass, mass.diff(phi)))


def reference_run(mu_s, mu_k, t_end):
    """Grip times (each with whether it sticks) and the final slider position: slip phases integrated with the
    kinetic force against the slider's speed, a grip where that speed reaches zero."""
    xs, dxs, mass, dmass = slider_crank()
    spring = lambda phi: -K * (xs(phi) - L0)  # on the slider, along x
    t, y, sign, grips = 0.0, [PHI0, 0.0], math.copysign(1.0, spring(PHI0)), []

    def rhs(_, y):
        phi, w = y
        q = (spring(phi) - sign * mu_k * N) * dxs(phi)
        return [w, (q - 0.5 * dmass(phi) * w * w) / mass(phi)]

    stop = lambda _, y: dxs(y[0]) * y[1]
    stop.terminal = True
    while t < t_end:
        stop.direction = -sign
        sol = solve_ivp(rhs, (t, t_end), y, events=stop, rtol=1e-12, atol=1e-14, method="DOP853")
        if not sol.t_events[0].size:
            return grips, xs(sol.y[0, -1])
        t, y = sol.t_events[0][0], [sol.y_events[0][0][0], 0.0]
        holds = abs(spring(y[0])) <= mu_s * N
        grips.append((t, holds))
        if holds:
            return grips, xs(y[0])
        sign = math.copysign(1.0, spring(y[0]))
    return grips, xs(y[0])


def at_a_contact(tmp_path) -> Path:
    """The model with the guide's friction moved to a point contact of the slider on the floor (tangent = x):
    the same physics, the lock a row of the contact's slip speed instead of the joint speed."""
    text = MODEL.read_text()
    element = ("        force friction = coulomb(mu_s = mu_s, mu_k = mu_k, normal = N)\n"
               "        sensor f = force(element = friction)\n")
    assert element in text and "output friction_force = guide.f" in text
    text = text.replace(element, "").replace("output friction_force = guide.f", "output friction_force = floor.f")
    floor = "    interact floor {\n        connect inertial -> slider\n" + element.replace("N)", "N, tangent = x)")
    path = tmp_path / "contact.mbs"
    path.write_text(text.replace("    interact wrist_pin", floor + "    }\n\n    interact wrist_pin", 1))
    return path


def simulate(t_end, model=MODEL, **params):
    system = mbs.load(model, "slider_crank_friction")
    return system.simulate(t_end=t_end, t_eval=np.linspace(0.0, t_end, 51), params=params, rtol=1e-10, atol=1e-12)


def test_a_locked_mechanism_holds_the_spring_with_the_guides_friction():
    res = simulate(0.2, mu_s=1.2)  # the limit 60 N exceeds the spring's 54 N
    assert res.success, res.message
    x0 = R * math.cos(PHI0) + math.sqrt(L ** 2 - (R * math.sin(PHI0)) ** 2)
    assert not res.events
    np.testing.assert_allclose(res["slider_x"], x0, atol=1e-12)
    np.testing.assert_allclose(res["friction_force"], K * (x0 - L0), rtol=1e-10)  # balances the spring


@pytest.mark.parametrize("where", ["guide", "floor"])
def test_slip_and_stick_in_a_closed_loop_match_the_hand_written_equation(tmp_path, where):
    grips, x_rest = reference_run(0.4, 0.3, 1.0)
    assert [holds for _, holds in grips] == [False, True]  # the first stop is beyond the limit, the second holds
    res = simulate(1.0, MODEL if where == "guide" else at_a_contact(tmp_path))
    assert res.success, res.message
    logged = [(e["time"], e["event"]) for e in res.events]
    assert [name for _, name in logged] == [f"{where}.friction.{e}" for e in ("slip", "grip", "slip", "grip")]
    for (t_ref, _), (t, _) in zip(grips, logged[1::2]):
        assert t == pytest.approx(t_ref, abs=1e-8)
    assert logged[2][0] == logged[1][0]  # let go at once: held beyond mu_s N
    assert res["slider_x"][-1] == pytest.approx(x_rest, abs=1e-9)
    resting = res.t > grips[-1][0] + 1e-6
    np.testing.assert_allclose(res["friction_force"][resting], K * (x_rest - L0), rtol=1e-8)
    sliding = (res.t > 1e-6) & (res.t < grips[0][0] - 1e-6)
    np.testing.assert_allclose(res["friction_force"][sliding], -0.3 * N, rtol=1e-12)


def test_the_generated_c_compiles_without_warnings(tmp_path):
    from mbs.runtime import build
    source = mbs.load(MODEL, "slider_crank_friction").generate().c_source
    result = build.build(source, filename="friction_loops.c", cache_dir=tmp_path)
    assert not result.cached and result.warnings == "", result.warnings


def test_a_plane_contact_in_a_model_with_a_loop_stops_at_the_closed_form_time():
    """The oblique launch of test_friction_plane.py beside a slider-crank: its two sticking rows join the loop's.
    A run that starts sliding in a loop model is started in its slip mode (the stick rows would hold the
    assembly's velocities otherwise)."""
    v0 = math.hypot(1.2, 0.5)
    system = mbs.load(MODEL, "plane_beside_a_loop")
    res = system.simulate(t_end=1.0, t_eval=np.linspace(0.0, 1.0, 11), rtol=1e-10, atol=1e-12,
                          params={"rub.friction.mode": 1, "rub.friction.e1": 1.2 / v0, "rub.friction.e2": 0.5 / v0})
    assert res.success, res.message
    assert [e["event"] for e in res.events] == ["rub.friction.grip"] and "1 -> 0" in res.events[0]["changes"]
    assert res.events[0]["time"] == pytest.approx(v0 / (0.3 * 9.81), abs=1e-9)
    distance = np.hypot(res["table.x"][-1], res["table.y"][-1])
    assert distance == pytest.approx(v0 ** 2 / (2 * 0.3 * 9.81), abs=1e-9)
    assert res["friction_force"][-1] == pytest.approx(0.0, abs=1e-9)
