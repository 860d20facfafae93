"""The general force laws of library/forces: their values against the defining formulas, and masses on them
against the closed-form dynamics of a linear oscillator (frequency sqrt(k/m), static deflection m g / k,
decay rate d / 2m, a half-sine contact of duration pi sqrt(m/k)) and energy conservation without damping.

The laws are evaluated through the whole pipeline: a model whose outputs are the laws of a joint coordinate
and its rate, compiled, and its output function called at states chosen here.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.equilibrium import ACCELERATION_TOLERANCE
from mbs.runtime.workspace import Workspace

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "physics"))
import physkit  # noqa: E402

G = 9.81

LAWS = """
import forces.laws as laws

func table_lin(x) = lookup(x, [[-0.1 m, -300 N], [0 m, 0 N], [0.05 m, 500 N], [0.2 m, 4000 N]], "linear")

model laws_probe {
    param k = 20000 N/m
    param k3 = 3e6 N/m^3
    param d = 800 N*s/m
    param l0 = 0.3 m
    param f0 = 1500 N
    param gap = 0.02 m
    param m = 1 kg
    rigid probe {
        body {
            mass = m
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide {
        connect inertial -> probe
        joint prismatic(axis = z)
    }
    output linear = laws.linear_spring(slide.s, k, l0)
    output preloaded = laws.preloaded_spring(slide.s, k, l0, f0)
    output damper = laws.linear_damper(der(slide.s), d)
    output both = laws.spring_damper(slide.s, der(slide.s), k, d, l0, f0)
    output bump = laws.bump_stop(slide.s, gap, k, k3, d, der(slide.s))
    output bump_tension = laws.bump_stop_tension(slide.s, l0, k, k3, d, der(slide.s))
    output rebound = laws.rebound_stop(slide.s, l0, k, k3, d, der(slide.s))
    output table = table_lin(slide.s)
}
"""

K, K3, D, L0, F0, GAP = 20000.0, 3e6, 800.0, 0.3, 1500.0, 0.02


def progressive(x, rate):
    """k x + k3 x^3 + d x' for x > 0, clipped at zero: a stop pushes (or holds) but never sticks."""
    return np.where(x > 0, np.maximum(0.0, K * x + K3 * x**3 + D * rate), 0.0)


@pytest.fixture(scope="module")
def probe():
    system = mbs.loads(LAWS)
    compiled = system.compile()
    data = Workspace(compiled)
    values = {"k": K, "k3": K3, "d": D, "l0": L0, "f0": F0, "gap": GAP, "m": 1.0}
    data.p = [values.get(n, 0.0) if n.startswith("switch.") else values[n] for n in compiled.p_names]  # as written

    def evaluate(s, rate):
        x = np.array(data.x)
        x[compiled.nq] = rate
        x[0] = s
        return dict(zip(compiled.y_names, data.outputs(0.0, x)))
    return evaluate


STATES = [(s, r) for s in (-0.15, -0.05, 0.0, 0.01, 0.019, 0.021, 0.05, 0.2, 0.29, 0.3, 0.31, 0.45)
          for r in (-2.0, -0.3, 0.0, 0.4, 3.0)]


def test_laws_follow_their_formulas(probe):
    xs = np.array([-0.1, 0.0, 0.05, 0.2])
    ys = np.array([-300.0, 0.0, 500.0, 4000.0])
    for s, r in STATES:
        y = probe(s, r)
        assert y["linear"] == pytest.approx(K * (s - L0), rel=1e-13, abs=1e-9)
        assert y["preloaded"] == pytest.approx(F0 + K * (s - L0), rel=1e-13, abs=1e-9)
        assert y["damper"] == pytest.approx(D * r, rel=1e-13, abs=1e-12)
        assert y["both"] == pytest.approx(F0 + K * (s - L0) + D * r, rel=1e-13, abs=1e-9)
        assert y["bump"] == pytest.approx(progressive(s - GAP, r), rel=1e-13, abs=1e-9)
        # as a tension: compression l0 - l, closing rate -v, and it pushes (negative tension)
        assert y["bump_tension"] == pytest.approx(-progressive(L0 - s, -r), rel=1e-13, abs=1e-9)
        assert y["rebound"] == pytest.approx(progressive(s - L0, r), rel=1e-13, abs=1e-9)
        assert y["table"] == pytest.approx(np.interp(s, xs, ys), rel=1e-13, abs=1e-9)
        # a bump stop never pulls, a rebound stop never pushes, also while opening fast
        assert y["bump"] >= 0.0 and y["bump_tension"] <= 0.0 and y["rebound"] >= 0.0


# ------------------------------------------------------------------------------------ a mass on the laws

SPRING_STOP = """
import forces.laws as laws

model spring_on_stop {
    param m = 2 kg
    param k = 800 N/m
    param l0 = 0.5 m
    param f0 = 0 N
    param l_stop = 0.45 m
    param k_stop = 20000 N/m
    param k3_stop = 0 N/m^3
    param d_stop = 0 N*s/m
    param s0 = 0.5 m
    param v0 = 0 m/s
    gravity = (0, 0, -9.81) m/s^2
    rigid mass {
        body {
            mass = m
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide "the mass moves vertically above the ground frame" {
        connect inertial -> mass
        joint prismatic(axis = z) {
            init s = s0
            init der(s) = v0
        }
        force spring = line(f = laws.preloaded_spring(l, k, l0, f0), along = z)
        force stop = line(f = laws.bump_stop_tension(l, l_stop, k_stop, k3_stop, d_stop, v), along = z)
        sensor stop_force = force(element = stop)
    }
    output stop_tension = slide.stop_force
}

scene rest {
    start = equilibrium
    t_end = 0.01 s
}
"""


@pytest.fixture(scope="module")
def spring_stop():
    return mbs.loads(SPRING_STOP)


def test_static_deflection_of_a_preloaded_spring_is_the_unbalanced_weight_over_k(spring_stop):
    m, k, f0 = 2.0, 800.0, -10.0  # the spring carries a compressive preload of 10 N at l0
    res = spring_stop.simulate("rest", params={"f0": f0, "l_stop": 0.0})
    # at rest the spring's tension balances the weight: f0 + k (l - l0) = -m g, to within what the
    # equilibrium search calls rest (an acceleration below ACCELERATION_TOLERANCE: m / k of it in position)
    assert res["slide.s"][0] == pytest.approx(0.5 - (m * G + f0) / k, rel=0, abs=ACCELERATION_TOLERANCE * m / k)
    assert abs(res["der(slide.s)"][-1]) <= ACCELERATION_TOLERANCE * 0.01


def test_a_mass_on_a_linear_spring_oscillates_at_sqrt_k_over_m(spring_stop):
    m, k = 2.0, 800.0
    s_rest = 0.5 - m * G / k
    res = spring_stop.simulate(t_end=3.0, sample=0.002, rtol=1e-11, atol=1e-13, integrator="dopri5",
                               params={"l_stop": 0.0, "s0": s_rest + 0.01})
    assert res.success, res.message
    T = physkit.period(res.t, res["slide.s"] - s_rest, res["der(slide.s)"])
    assert T == pytest.approx(2 * math.pi * math.sqrt(m / k), rel=1e-8)
    # the stop far below never touches
    assert np.all(res["stop_tension"] == 0.0)


#: A stop's force at the located opening of its contact [N]: the switches hold the contact branch up to the
#: crossing, whose row (just before the event) has the law at its zero to the crossing's round-off, k x with x a
#: few doubles of l_stop = 0.45 m (k_stop = 2e4 N/m: ~1e-12 N; observed 8.7e-13 N).  Without switches it was 0.
AT_OPENING = 1e-9


def test_energy_is_conserved_over_spring_and_progressive_stop_without_damping(spring_stop):
    m, k, l0 = 2.0, 800.0, 0.5
    l_stop, k_stop, k3_stop = 0.45, 20000.0, 4e7
    res = spring_stop.simulate(t_end=2.0, sample=0.001, rtol=1e-11, atol=1e-13, integrator="dopri5",
                               params={"k3_stop": k3_stop, "s0": 0.6})
    assert res.success, res.message
    s, v = res["slide.s"], res["der(slide.s)"]
    x = np.maximum(0.0, l_stop - s)
    energy = 0.5 * m * v**2 + m * G * s + 0.5 * k * (s - l0) ** 2 + 0.5 * k_stop * x**2 + 0.25 * k3_stop * x**4
    assert x.max() > 0.005  # it does run into the stop, into its progressive range
    assert np.ptp(energy) < 1e-8 * energy.max()
    assert np.all(res["stop_tension"] <= AT_OPENING)


def test_contact_with_a_linear_stop_is_half_a_period_and_the_mass_leaves_at_its_impact_speed():
    """No gravity, no spring: a mass flies into the stop, stays in contact for pi sqrt(m/k), leaves at -v."""
    system = mbs.loads(SPRING_STOP.replace("gravity = (0, 0, -9.81) m/s^2", "gravity = (0, 0, 0) m/s^2"))
    m, k_stop, v0, l_stop = 2.0, 20000.0, -0.8, 0.45
    res = system.simulate(t_end=0.3, sample=1e-4, rtol=1e-11, atol=1e-13, integrator="dopri5",
                          params={"k": 0.0, "s0": 0.5, "v0": v0})
    assert res.success, res.message
    roots = physkit.crossings(res.t, res["slide.s"] - l_stop, res["der(slide.s)"])
    assert len(roots) == 2
    assert roots[0] == pytest.approx(0.05 / 0.8, rel=1e-9)
    assert roots[1] - roots[0] == pytest.approx(math.pi * math.sqrt(m / k_stop), rel=1e-7)
    assert res["der(slide.s)"][-1] == pytest.approx(-v0, rel=1e-8)


def test_a_damped_stop_never_pulls_and_lets_the_mass_go():
    """With strong damping a linear stop would pull on the way out; the law clips it to zero instead."""
    system = mbs.loads(SPRING_STOP.replace("gravity = (0, 0, -9.81) m/s^2", "gravity = (0, 0, 0) m/s^2"))
    res = system.simulate(t_end=0.3, sample=1e-4, rtol=1e-10, atol=1e-12, integrator="dopri5",
                          params={"k": 0.0, "s0": 0.5, "v0": -0.8, "d_stop": 150.0})
    assert res.success, res.message
    tension = res["stop_tension"]
    assert tension.min() < -100.0          # it did hit the stop
    assert tension.max() <= AT_OPENING     # and never pulled
    # while the stop is compressed on the way out (s < l_stop, v > 0) the unclipped law k x - d v crosses
    # zero before the stop opens: from there the force is exactly zero
    s, v = res["slide.s"], res["der(slide.s)"]
    unclipped = 20000.0 * (0.45 - s) - 150.0 * v
    late = (s < 0.45) & (v > 0) & (unclipped < 0)
    assert late.any() and np.all(np.abs(tension[late]) <= AT_OPENING)
    assert v[-1] > 0.0 and s[-1] > 0.45     # it left, slower than it came
    assert v[-1] < 0.8


# ------------------------------------------------------------------------------------ table spring-damper

TABLE = """
import forces.table as table

func my_spring(l) = lookup(l, [[0.2 m, -300 N], [0.3 m, 0 N], [0.4 m, 300 N]], "smooth")
func my_damper(v) = lookup(v, [[-1 m/s, 0 N], [1 m/s, 0 N]], "linear")

model table_mass {
    param s0 = 0.31 m
    gravity = (0, 0, 0) m/s^2
    part inertial {
        frame anchor at (0, 0, 0) m
    }
    rigid mass {
        body {
            mass = 0.75 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide {
        connect inertial -> mass
        joint prismatic(axis = z) {
            init s = s0
        }
    }
    use table.spring_damper as strut(spring = my_spring, damper = my_damper) {
        a = inertial.anchor
        b = mass.origin
    }
}
"""


def test_a_table_spring_of_collinear_points_is_a_linear_spring():
    """Monotone cubic through collinear points is that line: the period is 2 pi sqrt(m / 3000 N/m)."""
    system = mbs.loads(TABLE)
    res = system.simulate(t_end=1.0, sample=0.001, rtol=1e-11, atol=1e-13, integrator="dopri5")
    assert res.success, res.message
    T = physkit.period(res.t, res["slide.s"] - 0.3, res["der(slide.s)"])
    assert T == pytest.approx(2 * math.pi * math.sqrt(0.75 / 3000.0), rel=1e-8)


# ------------------------------------------------------------------------------------ bushing

BUSHING = """
import forces.bushing as bushing

model mounted {
    param m = 5 kg
    param izz = 0.2 kg*m^2
    param kz = 50000 N/m
    param krz = 300 N*m/rad
    param dz = 0 N*s/m
    param drz = 0 N*m*s/rad
    param z0 = 0 m
    param psi0 = 0 rad
    gravity = (0, 0, -9.81) m/s^2
    part inertial {
        frame mount at (0, 0, 1) m
    }
    rigid block {
        body {
            mass = m
            com = (0, 0, 0) m
            inertia = diag(0.1, 0.15, izz)
        }
        frame mount at (0, 0, 0) m
    }
    interact floating {
        connect inertial.mount -> block.mount
        joint free(rotation = cardan) {
            init z = z0
            init gamma = psi0
        }
    }
    use bushing.bushing as bush(kz = kz, krz = krz, dz = dz, drz = drz, kx = 40000 N/m, ky = 30000 N/m, krx = 200 N*m/rad, kry = 250 N*m/rad) {
        a = inertial.mount
        b = block.mount
    }
}

scene rest {
    start = equilibrium
    t_end = 0.01 s
}
"""


@pytest.fixture(scope="module")
def mounted():
    return mbs.loads(BUSHING)


def test_a_block_on_a_bushing_sags_by_m_g_over_kz(mounted):
    res = mounted.simulate("rest")
    assert res["floating.z"][0] == pytest.approx(-5.0 * G / 50000.0, rel=0, abs=ACCELERATION_TOLERANCE * 5.0 / 50000.0)
    assert res["floating.x"][0] == pytest.approx(0.0, abs=1e-12)
    assert res["floating.gamma"][0] == pytest.approx(0.0, abs=1e-12)


def test_bushing_vertical_and_torsional_frequencies_and_damping(mounted):
    m, kz, izz, krz = 5.0, 50000.0, 0.2, 300.0
    z_rest = -m * G / kz
    res = mounted.simulate(t_end=1.0, sample=0.0005, rtol=1e-11, atol=1e-13, integrator="dopri5",
                           params={"z0": z_rest + 0.002, "psi0": 0.01})
    assert res.success, res.message
    Tz = physkit.period(res.t, res["floating.z"] - z_rest, res["der(floating.z)"])
    Tpsi = physkit.period(res.t, res["floating.gamma"], res["der(floating.gamma)"])
    assert Tz == pytest.approx(2 * math.pi * math.sqrt(m / kz), rel=1e-8)
    assert Tpsi == pytest.approx(2 * math.pi * math.sqrt(izz / krz), rel=1e-8)
    # damped: the amplitude decays as exp(-d t / 2m) (vertical) and exp(-dr t / 2 Izz) (torsion), at the
    # damped frequency. The torsional rate comes from the bushing's lever points, which measure psi' cos psi:
    # at 1 mrad that changes the decay by 2.5e-7 of it, below the 1e-6 asked of the envelope
    dz, drz = 20.0, 0.5
    res = mounted.simulate(t_end=1.0, sample=0.0005, rtol=1e-11, atol=1e-13, integrator="dopri5",
                           params={"z0": z_rest + 0.002, "psi0": 0.001, "dz": dz, "drz": drz})
    assert res.success, res.message
    for y, dy, rate, omega0 in ((res["floating.z"] - z_rest, res["der(floating.z)"], dz / (2 * m), math.sqrt(kz / m)),
                                (res["floating.gamma"], res["der(floating.gamma)"], drz / (2 * izz),
                                 math.sqrt(krz / izz))):
        omega = math.sqrt(omega0**2 - rate**2)
        # the solution A exp(-rate t) cos(omega t - phi): undo the decay and it is a pure cosine
        A = np.hypot(y, (dy + rate * y) / omega) * np.exp(rate * res.t)
        assert np.ptp(A) < 1e-6 * A.max()
        assert physkit.period(res.t, y, dy) == pytest.approx(2 * math.pi / omega, rel=1e-7)
