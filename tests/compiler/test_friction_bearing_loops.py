"""Bearing friction (normal = reaction) in a closed loop (compiler/friction_loops.py, runtime/c/loops.c): the
slider-crank of models/bearing_loops.mbs with load-dependent friction in its main bearing (a tree joint of the
loop: its load includes the loop's constraint forces) or in its wrist pin (the joint that closes the loop: its load
is those forces), against scipy on hand-written equations: Lagrange in the crank angle for the motion, Newton-Euler
of the slider, the rod and the crank for the bearing load, the friction torque T = -sign(slip) mu_k r |load(T)|
found by brentq at every evaluation (the load depends on the torque through the accelerations)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import brentq

import mbs

MODEL = Path(__file__).parent / "models" / "bearing_loops.mbs"
R, L, M_CRANK, M_ROD, M_SLIDER, K, L0, G = 0.1, 0.4, 20.0, 0.5, 2.0, 2000.0, 0.45, 9.81
MU_S, MU_K = 0.4, 0.3
PHI0 = math.radians(70)


def mechanism():
    """Functions of the crank angle phi (and of its rate w and acceleration a where they need them), in the
    plane of the mechanism with y = -z (gravity along +y): the slider's position, its rate and acceleration, the
    rod angle's rate, the generalized mass and its derivative, the rod's centre's acceleration, the rod's moment
    balance about the crank pin without loads (I theta'' + m (G - C) x a_G) and the rod vector d = S - C."""
    phi, w, a = sp.symbols("phi w a")
    C = sp.Matrix([R * sp.cos(phi), R * sp.sin(phi)])
    xs = R * sp.cos(phi) + sp.sqrt(L ** 2 - (R * sp.sin(phi)) ** 2)
    S = sp.Matrix([xs, 0])
    centre = (C + S) / 2
    theta = sp.atan2(-C[1], xs - C[0])
    acc = lambda e: sp.diff(e, phi) * a + sp.diff(e, phi, 2) * w ** 2
    vc = centre.diff(phi)
    mass = (M_CRANK * R ** 2 / 3 + M_ROD * vc.dot(vc) + M_ROD * L ** 2 / 12 * theta.diff(phi) ** 2
            + M_SLIDER * xs.diff(phi) ** 2)
    a_centre, g = centre.applyfunc(acc), centre - C
    of_phi = lambda e: sp.lambdify(phi, e, "math")
    of_motion = lambda e: sp.lambdify((phi, w, a), e, "math")
    return dict(xs=of_phi(xs), dxs=of_phi(xs.diff(phi)), theta=of_phi(theta), dtheta=of_phi(theta.diff(phi)),
                mass=of_phi(mass), dmass=of_phi(mass.diff(phi)), axs=of_motion(acc(xs)),
                a_centre=of_motion(list(a_centre)), d=of_phi(list(S - C)),
                rod=of_motion(M_ROD * L ** 2 / 12 * acc(theta) + M_ROD * (g[0] * a_centre[1] - g[1] * a_centre[0])))


def reference(where, radius, t_end, t_eval):
    """(grips with whether they hold, sample times, crank angles): slip phases integrated with DOP853, a grip
    where the slip rate reaches zero; it holds if the torque that keeps the mechanism at rest is within mu_s r
    times the load it then carries, else the joint slips on the way the mechanism is pushed."""
    m = mechanism()
    # generalized forces on phi: the spring, and the rod's weight (potential -m_rod g R sin(phi) / 2)
    drive = lambda phi: -K * (m["xs"](phi) - L0) * m["dxs"](phi) + M_ROD * G * R * math.cos(phi) / 2
    ds = m["dtheta"] if where == "wrist_pin" else (lambda phi: 1.0)  # the slip angle's rate per crank rate

    def accel(phi, w, T):
        return (drive(phi) + T * ds(phi) - 0.5 * m["dmass"](phi) * w * w) / m["mass"](phi)

    def load(phi, w, T):
        """The radial load of the pin with the friction torque T on the crank (main bearing) or the rod (wrist)."""
        a = accel(phi, w, T)
        px = M_SLIDER * m["axs"](phi, w, a) + K * (m["xs"](phi) - L0)  # the rod's force on the slider
        dx, dy = m["d"](phi)
        # the rod about the crank pin: -(d x P) + T + its weight's moment (G - C = d / 2) = its rate of momentum
        py = ((T if where == "wrist_pin" else 0.0) + M_ROD * G * dx / 2 - m["rod"](phi, w, a) + dy * px) / dx
        if where == "wrist_pin":
            return math.hypot(px, py)
        ac = m["a_centre"](phi, w, a)
        cx, cy = M_ROD * ac[0] + px, M_ROD * ac[1] + py - M_ROD * G  # the crank's force on the rod
        return math.hypot(cx, cy - M_CRANK * G)  # the flywheel's centre is on the pivot: it does not move

    def torque(phi, w, sign):
        return brentq(lambda T: T + sign * MU_K * radius * load(phi, w, T), -100.0, 100.0, xtol=1e-15, rtol=1e-15)

    t, y, grips, ts, ys = 0.0, [PHI0, 0.0], [], [], []
    sign = math.copysign(1.0, drive(PHI0) * ds(PHI0))
    while True:
        stop = lambda _, y: ds(y[0]) * y[1]
        stop.terminal, stop.direction = True, -sign
        sol = solve_ivp(lambda _, y: [y[1], accel(y[0], y[1], torque(y[0], y[1], sign))], (t, t_end), y,
                        events=stop, rtol=1e-12, atol=1e-14, method="DOP853", dense_output=True)
        inside = t_eval[(t_eval >= t) & (t_eval <= sol.t[-1])]
        ts, ys = ts + list(inside), ys + list(sol.sol(inside)[0])
        if not sol.t_events[0].size:
            return grips, np.array(ts), np.array(ys)
        t, y = sol.t_events[0][0], [sol.y_events[0][0][0], 0.0]
        hold = -drive(y[0]) / ds(y[0])
        grips.append((t, abs(hold) <= MU_S * radius * load(y[0], 0.0, hold)))
        if grips[-1][1]:
            inside = t_eval[t_eval > t]
            return grips, np.array(ts + list(inside)), np.array(ys + [y[0]] * len(inside))
        sign = math.copysign(1.0, drive(y[0]) * ds(y[0]))


def model_with_friction_in(tmp_path, where) -> Path:
    if where == "main_bearing":
        return MODEL
    text = MODEL.read_text()
    element = ("        force friction = coulomb(mu_s = mu_s, mu_k = mu_k, normal = reaction, radius = r_pin)\n"
               "        sensor f = force(element = friction)\n")
    head = "        joint revolute(axis = y, cut = true)\n"
    assert element in text and head in text
    text = text.replace(element, "").replace(head, head + element)
    path = tmp_path / "wrist_pin.mbs"
    path.write_text(text.replace("output torque = main_bearing.f", "output torque = wrist_pin.f"))
    return path


@pytest.mark.parametrize("where, radius, t_end, grips", [("main_bearing", 0.04, 0.4, [True]),
                                                          ("wrist_pin", 0.1, 0.5, [False, False])])
def test_bearing_friction_in_a_loop_matches_the_hand_written_equations(tmp_path, where, radius, t_end, grips):
    times = np.linspace(0.0, t_end, 2001)
    expected, t_ref, phi_ref = reference(where, radius, t_end, times)
    assert [holds for _, holds in expected] == grips  # the main bearing comes to rest; the wrist pin cannot hold
    system = mbs.load(model_with_friction_in(tmp_path, where))
    res = system.simulate(t_end=t_end, t_eval=times, params={"r_pin": radius}, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    logged = [(e["time"], e["event"]) for e in res.events]
    names = ["slip"] + ["grip", "slip"] * (len(grips) - grips[-1]) + ["grip"] * grips[-1]
    assert [name for _, name in logged] == [f"{where}.friction.{n}" for n in names]
    for (t, _), (t_model, _) in zip(expected, [e for e in logged if e[1].endswith("grip")]):
        assert t_model == pytest.approx(t, abs=1e-9)
    phi = res["main_bearing.phi"]
    np.testing.assert_allclose(np.interp(t_ref, res.t, phi), phi_ref, atol=1e-9)

    # the friction torque is mu r times the joint's load as its reaction sensor reports it (the multipliers or
    # the inverse dynamics with them): mu_k while slipping, within mu_s while at rest
    prefix = "main" if where == "main_bearing" else "wrist"
    load = np.hypot(res[f"{prefix}_fx"], res[f"{prefix}_fz"])
    rest = res.t > expected[-1][0] + 1e-9 if grips[-1] else np.zeros(res.t.size, dtype=bool)
    sliding = ~rest & (np.abs(res["der(main_bearing.phi)"]) > 1e-6)
    np.testing.assert_allclose(np.abs(res["torque"][sliding]), MU_K * radius * load[sliding], rtol=1e-10)
    assert np.all(np.abs(res["torque"][rest]) <= MU_S * radius * load[rest])

    # the energy balance: what the motion, the spring and gravity lost is the work of the friction torque
    m = mechanism()
    w = res["der(main_bearing.phi)"]
    energy = np.array([0.5 * m["mass"](a) * b * b + 0.5 * K * (m["xs"](a) - L0) ** 2
                       - M_ROD * G * R * math.sin(a) / 2 for a, b in zip(phi, w)])
    rate = w if where == "main_bearing" else np.array([m["dtheta"](a) for a in phi]) * w
    power = np.abs(res["torque"] * rate)
    bounds = [0.0] + [t for t, name in logged if name.endswith("grip")] + [t_end]
    work = 0.0
    for a, b in zip(bounds, bounds[1:]):  # per slip phase (the torque jumps at the events)
        rows = np.flatnonzero((res.t >= a) & (res.t <= b))
        rows = rows[np.concatenate([[True], np.diff(res.t[rows]) > 0])]
        if rows.size > 2:
            work += simpson(power[rows], x=res.t[rows])
    assert energy[0] - energy[-1] == pytest.approx(work, rel=1e-6)


def test_the_generated_c_compiles_without_warnings(tmp_path):
    from mbs.runtime import build
    source = mbs.load(MODEL).generate().c_source
    result = build.build(source, filename="bearing_loops.c", cache_dir=tmp_path)
    assert not result.cached and result.warnings == "", result.warnings


def test_two_coupled_bearings_in_a_loop_each_carry_mu_times_their_load(tmp_path):
    """Friction in the main bearing and in the wrist pin at once: each one's torque changes the other's load
    (through the loop's constraint forces), solved by Newton's method on the tape (compiler/friction_bearing.py).
    Each torque against its own reaction sensor, and the energy balance with both torques' work."""
    text = MODEL.read_text()
    element = ("        force friction = coulomb(mu_s = mu_s, mu_k = mu_k, normal = reaction, radius = r_pin)\n"
               "        sensor f = force(element = friction)\n")
    head = "        joint revolute(axis = y, cut = true)\n"
    text = text.replace(head, head + element).replace("output torque = main_bearing.f",
                                                       "output torque = main_bearing.f\n    output wrist = wrist_pin.f")
    path = tmp_path / "both.mbs"
    path.write_text(text)
    t_end = 0.3
    res = mbs.load(path).simulate(t_end=t_end, t_eval=np.linspace(0.0, t_end, 1501), params={"r_pin": 0.03},
                                  rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    first = [(e["event"], e["time"]) for e in res.events][:4]
    assert first[:2] == [("main_bearing.friction.slip", 0.0), ("wrist_pin.friction.slip", 0.0)]
    # both slip rates are the crank's times a factor: they reach zero together, and both grip there
    assert {name for name, _ in first[2:]} == {"main_bearing.friction.grip", "wrist_pin.friction.grip"}
    assert first[2][1] == first[3][1]
    m = mechanism()
    phi, w = res["main_bearing.phi"], res["der(main_bearing.phi)"]
    rate = np.array([m["dtheta"](a) for a in phi]) * w
    grips = [e["time"] for e in res.events if e["event"].endswith("grip")]
    assert grips and grips[0] > 0.1  # the first reversal; both slip until then
    before = res.t < grips[0] - 1e-9
    # the wrist pin's slip rate is the slider's (b) turning against the rod's (a): -theta'
    for torque, load, speed in ((res["torque"], np.hypot(res["main_fx"], res["main_fz"]), w),
                                (res["wrist"], np.hypot(res["wrist_fx"], res["wrist_fz"]), -rate)):
        np.testing.assert_allclose(np.abs(torque[before]), 0.3 * 0.03 * load[before], rtol=1e-10)
        assert np.all(torque[before][1:] * speed[before][1:] < 0)  # against the motion
    power = np.abs(res["torque"] * w) + np.abs(res["wrist"] * rate)
    rows = np.flatnonzero(before)
    energy = np.array([0.5 * m["mass"](a) * b * b + 0.5 * K * (m["xs"](a) - L0) ** 2
                       - M_ROD * G * R * math.sin(a) / 2 for a, b in zip(phi[rows], w[rows])])
    assert energy[0] - energy[-1] == pytest.approx(simpson(power[rows], x=res.t[rows]), rel=1e-6)
