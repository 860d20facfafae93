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
    """x_s(phi), x_s'(phi), the generalized mass M(phi), M'(phi) of the crank angle, and the rate of the rod's angle
    theta'(phi), from the geometry."""
    phi = sp.Symbol("phi")
    pin = sp.Matrix([R * sp.cos(phi), R * sp.sin(phi)])
    xs = R * sp.cos(phi) + sp.sqrt(L ** 2 - (R * sp.sin(phi)) ** 2)
    rod_centre = (pin + sp.Matrix([xs, 0])) / 2
    rod_angle = sp.atan2(-pin[1], xs - pin[0])
    vc, wr, vs = rod_centre.diff(phi), rod_angle.diff(phi), xs.diff(phi)
    mass = M_CRANK * R ** 2 / 3 + M_ROD * vc.dot(vc) + M_ROD * L ** 2 / 12 * wr ** 2 + M_SLIDER * vs ** 2
    return tuple(sp.lambdify(phi, e, "math") for e in (xs, vs, mass, mass.diff(phi), wr, rod_angle))


def reference_run(mu_s, mu_k, t_end, where="guide", normal=N, lever=1.0, w0=0.0):
    """Grip times (each with whether it sticks) and the final slider position: slip phases integrated with the
    kinetic force against the slip, a grip where the slip speed reaches zero. The slip coordinate s is the
    slider's position (where = "guide") or the angle of the slider against the rod, -theta ("wrist_pin"); its
    friction's generalized force on phi is -mu N lever sign(s') ds/dphi, and a stop holds if the spring's
    generalized force needs at most mu_s N lever |ds/dphi|. w0: the crank's initial speed."""
    xs, dxs, mass, dmass, dtheta, _ = slider_crank()
    ds = dxs if where == "guide" else (lambda phi: -dtheta(phi))
    spring = lambda phi: -K * (xs(phi) - L0) * dxs(phi)  # the spring's generalized force on phi
    t, y, grips = 0.0, [PHI0, w0], []
    sign = math.copysign(1.0, ds(PHI0) * (w0 if w0 else spring(PHI0)))  # moving from the start, or let go

    def rhs(_, y):
        phi, w = y
        q = spring(phi) - sign * mu_k * normal * lever * ds(phi)
        return [w, (q - 0.5 * dmass(phi) * w * w) / mass(phi)]

    stop = lambda _, y: ds(y[0]) * y[1]
    stop.terminal = True
    while t < t_end:
        stop.direction = -sign
        sol = solve_ivp(rhs, (t, t_end), y, events=stop, rtol=1e-12, atol=1e-14, method="DOP853")
        if not sol.t_events[0].size:
            return grips, xs(sol.y[0, -1])
        t, y = sol.t_events[0][0], [sol.y_events[0][0][0], 0.0]
        holds = abs(spring(y[0])) <= mu_s * normal * lever * abs(ds(y[0]))
        grips.append((t, holds))
        if holds:
            return grips, xs(y[0])
        sign = math.copysign(1.0, spring(y[0]) * ds(y[0]))
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
    The run decides by itself that it starts sliding (the loops are assembled without the stick rows, which
    would hold the initial speeds), along the initial velocity."""
    v0 = math.hypot(1.2, 0.5)
    system = mbs.load(MODEL, "plane_beside_a_loop")
    res = system.simulate(t_end=1.0, t_eval=np.linspace(0.0, 1.0, 11), rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    assert [(e["event"], e["direction"]) for e in res.events] == [("rub.friction.slip", "start"),
                                                                   ("rub.friction.grip", "falling")]
    assert f"e1: 0 -> {1.2 / v0:.6g}; rub.friction.e2: 0 -> {0.5 / v0:.6g}" in res.events[0]["changes"]
    assert "1 -> 0" in res.events[1]["changes"]
    assert res.events[1]["time"] == pytest.approx(v0 / (0.3 * 9.81), abs=1e-9)
    distance = np.hypot(res["table.x"][-1], res["table.y"][-1])
    assert distance == pytest.approx(v0 ** 2 / (2 * 0.3 * 9.81), abs=1e-9)
    assert res["friction_force"][-1] == pytest.approx(0.0, abs=1e-9)


# ---- friction in the joint that closes the loop (a cut joint has no coordinate: its relative motion is a function
# of the tree state, its lock one more row) ----------------------------------------------------------------------

PIN_NORMAL, PIN_RADIUS = 500.0, 0.04  # the wrist pin's friction: its torque mu N r about the pin


def loop_closed_at(tmp_path, where: str, w0: float = 0.0) -> Path:
    """The slider-crank with its loop closed at the joint that has the friction: the guide (prismatic) with the
    guide's friction, or the wrist pin (revolute) with the friction moved there; w0: the crank's initial speed."""
    text = MODEL.read_text().replace("init phi = 70 deg", f"init phi = 70 deg\n            init der(phi) = {w0} rad/s")
    if where == "guide":
        text = text.replace("joint prismatic(axis = x)\n        force friction",
                            "joint prismatic(axis = x, cut = true)\n        force friction", 1)
        text = text.replace("joint revolute(axis = y, cut = true)", "joint revolute(axis = y)", 1)
    else:
        element = "        force friction = coulomb(mu_s = mu_s, mu_k = mu_k, normal = N)\n"
        assert element in text
        text = text.replace(element, "").replace("output friction_force = guide.f", "")
        text = text.replace("joint revolute(axis = y, cut = true)\n",
                            "joint revolute(axis = y, cut = true)\n" + element.replace(
                                "normal = N)", f"normal = {PIN_NORMAL} N, radius = {PIN_RADIUS} m)"), 1)
        text = text.replace("        sensor f = force(element = friction)\n", "", 1)
    path = tmp_path / f"closed_at_{where}.mbs"
    path.write_text(text)
    return path


def energy(phi, w):
    """Kinetic energy and the spring's, by hand from the geometry [J]."""
    xs, _, mass, *_ = slider_crank()
    return np.array([0.5 * mass(a) * b * b + 0.5 * K * (xs(a) - L0) ** 2 for a, b in zip(phi, w)])


@pytest.mark.parametrize("where, w0, stops", [("guide", 0.0, 2), ("wrist_pin", 0.0, 3), ("guide", 6.0, 3),
                                               ("wrist_pin", 6.0, 4)])
def test_friction_in_the_loop_closing_joint_matches_the_hand_written_equation(tmp_path, where, w0, stops):
    """At rest the element is let go at the start (the spring needs more than the static limit); moving (the
    crank turning against the spring) it starts in slip, in the direction it slides: decided by the run, not
    given by the user."""
    lever = dict(normal=PIN_NORMAL, lever=PIN_RADIUS) if where == "wrist_pin" else {}
    grips, x_rest = reference_run(0.4, 0.3, 1.0, where, w0=w0, **lever)
    assert [holds for _, holds in grips][-1] and not any(holds for _, holds in grips[:-1])
    assert len(grips) == stops  # stops beyond the limit, then one that holds
    res = simulate(1.0, loop_closed_at(tmp_path, where, w0))
    assert res.success, res.message
    logged = [(e["time"], e["event"]) for e in res.events]
    assert [name for _, name in logged] == [f"{where}.friction.{e}" for e in ("slip",) + ("grip", "slip") *
                                            (len(grips) - 1) + ("grip",)]
    assert logged[0][0] == 0.0 and all(a[0] == b[0] for a, b in zip(logged[1::2], logged[2::2]))  # let go at once
    for (t_ref, _), (t, _) in zip(grips, logged[1::2]):
        assert t == pytest.approx(t_ref, abs=1e-8)
    assert res["slider_x"][-1] == pytest.approx(x_rest, abs=1e-9)
    # the energy balance: what the spring and the motion lost is the kinetic friction's work, mu_k N lever
    # times the distance slid (the slip coordinate runs one way in each slip phase)
    _, _, _, _, _, theta = slider_crank()
    phi = res["main_bearing.phi"]
    slip = res["slider_x"] if where == "guide" else -np.array([theta(a) for a in phi])
    at = [0] + [int(np.flatnonzero(res.t == t)[0]) for t, _ in logged[1::2]]
    slid = sum(abs(slip[j] - slip[i]) for i, j in zip(at, at[1:]))
    assert res["der(main_bearing.phi)"][0] == pytest.approx(w0, abs=1e-12)
    lost = energy(phi[[0]], [w0])[0] - energy(phi[[-1]], [0.0])[0]
    force = 0.3 * (PIN_NORMAL * PIN_RADIUS if where == "wrist_pin" else N)
    assert lost == pytest.approx(force * slid, rel=1e-8)
