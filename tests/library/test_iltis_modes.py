"""The Iltis quarter car, linearised about its static equilibrium: its two natural frequencies against the
two-mass formula built from the suspension's effective wheel rate there (the issue's check, within 1 %).

Everything on the formula's side comes from static equilibria and the kinetic energy, never from the
linearisation:

* Wheel rate k_w: the body mass is changed by +-1 % (two more static equilibria); the tyre load changes by the
  added weight, the suspension travel u = z_wheel - z_body (wheel centre from the tyre's centre sensor, body
  from lift.s) by du, and k_w = dF / du (central difference). That is the tangent rate of the whole corner at
  the equilibrium: leaf spring and strut with their lever ratios, the geometric stiffness of their preloads,
  and the weight of the links as they swing.
* Masses: the two equilibria also give the suspension's motion at fixed body height per unit of u (their
  difference minus the rigid heave of lift.s), a velocity direction w (through qdot = E v). With M the mass
  matrix there, the kinetic energy in the body height s and the travel u is
  [s' u'] [[M_ss, M_su], [M_su, M_uu]] [s' u']^T / 2, M_uu = w^T M w the generalized mass of the wheel's
  travel. The wheel does not only rise: it moves sideways and cambers as it travels, so M_uu is more than
  the 57.35 kg wheel even with massless links (59.7 kg with the steering rod at z = 0.522 m).
* Tyre rate 460000 N/m (the data sheet's; the tyre is vertical on a flat road).

Two mass choices, both honest: (1) the issue's own: massless links (the corner parameters m_leaf, m_arm,
m_carrier, m_rod set to 0, which must work), sprung mass = the quarter-car body, unsprung mass = M_uu;
(2) the links with their mass, and the masses of the two-mass model read off the kinetic energy in the
heights z_b = s, z_w = s + u: m_s = M_ss - 2 M_su + M_uu, m_u = M_uu. The two-mass formula drops the remaining
inertial coupling M_su - M_uu (the wheel's sideways and camber motion when the body moves alone); that, and
the body's share of the wheel's extra inertia in (1), is what separates the figures (measured with the rod at
z = 0.522 m: body bounce -0.27 %, wheel hop -0.04 % in (1); -0.007 % and -0.0004 % in (2)).

Compared are the linearised model's undamped frequencies (the stiffness part of the Jacobian at v = 0: the
damper's force vanishes at rest, only its slope enters, and that is the part the undamped formula lacks).
"""

import numpy as np
import pytest

import mbs
from mbs.runtime.workspace import Workspace

G = 9.81
K_TYRE = 460000.0
LINKS = ("m_leaf", "m_arm", "m_carrier", "m_rod")


def two_mass_frequencies(m_s, m_u, k_s, k_t) -> np.ndarray:
    """Roots of m_s m_u w^4 - (k_s m_u + (k_s + k_t) m_s) w^2 + k_s k_t = 0, in Hz."""
    b = k_s / m_s + (k_s + k_t) / m_u
    c = k_s * k_t / (m_s * m_u)
    root = np.sqrt(b * b - 4 * c)
    return np.sqrt(np.array([(b - root) / 2, (b + root) / 2])) / (2 * np.pi)


@pytest.fixture(scope="module")
def quarter_car():
    return mbs.load("library/iltis/quarter_car.mbs")


def corner_at_rest(system, params: dict):
    """Wheel rate and the kinetic energy's 2x2 mass matrix (body height, travel) at the static equilibrium."""
    compiled = system.compile("modes")
    nq, nv = compiled.nq, compiled.nv
    lift = compiled.q_names.index("lift.s")
    assert compiled.v_names.index("der(lift.s)") == lift
    m_quarter = {p.name: p.value for p in system.model.parameters}["m_quarter"]
    dm = 0.01 * m_quarter
    states, travel, load = [], [], []
    for m in (m_quarter - dm, m_quarter + dm):
        result, outputs = system.equilibrium("modes", params={**params, "m_quarter": m})
        states.append(result.x)
        travel.append(outputs["tyre.radial.centre.z"] - result.x[lift])
        load.append(outputs["tyre.radial.load"])
    assert load[1] - load[0] == pytest.approx(2 * dm * G, rel=1e-5)  # the tyre carries the added weight
    du = travel[1] - travel[0]
    k_wheel = (load[1] - load[0]) / du

    rest, _ = system.equilibrium("modes", params=params)
    data = Workspace(compiled)
    for name, value in params.items():
        data.set_param(name, value)
    x = rest.x
    E = np.column_stack([data.qdot(0.0, np.concatenate([x[:nq], e])) for e in np.eye(nv)])
    w = np.linalg.lstsq(E, states[1][:nq] - states[0][:nq], rcond=None)[0]
    w[lift] -= states[1][lift] - states[0][lift]  # the suspension's own motion, body held
    w /= du
    # w is a secant over +-1 % load; it must lie on the constraints' tangent to the secant's accuracy
    assert np.max(np.abs(data.constraint_jacobian(0.0, x) @ w)) < 1e-4
    heave = np.eye(nv)[lift]
    M = data.mass_matrix(0.0, x)
    masses = np.array([[heave @ M @ heave, heave @ M @ w], [heave @ M @ w, w @ M @ w]])
    return k_wheel, masses


def test_massless_links_body_over_the_wheel_match_the_two_mass_formula_to_1_percent(quarter_car):
    params = {f"fl.{name}": 0.0 for name in LINKS}
    k_wheel, masses = corner_at_rest(quarter_car, params)
    p = {x.name: x.value for x in quarter_car.model.parameters}
    assert masses[0, 0] == pytest.approx(p["m_quarter"] + p["fl.m_wheel"], rel=1e-9)  # all the mass heaves
    assert masses[0, 1] == pytest.approx(p["fl.m_wheel"], rel=1e-6)  # the wheel rises with u, exactly
    formula = two_mass_frequencies(p["m_quarter"], masses[1, 1], k_wheel, K_TYRE)
    lin = quarter_car.linearize("modes", params=params)
    assert lin.dof == 2
    assert lin.undamped_frequencies == pytest.approx(formula, rel=0.01)
    assert [m.oscillatory for m in lin.modes] == [True, True]  # with the damper: bounce and hop, underdamped


def test_massive_links_generalized_masses_match_the_two_mass_formula_to_1_percent(quarter_car):
    k_wheel, masses = corner_at_rest(quarter_car, {})
    m_u = masses[1, 1]
    m_s = masses[0, 0] - 2 * masses[0, 1] + masses[1, 1]
    formula = two_mass_frequencies(m_s, m_u, k_wheel, K_TYRE)
    lin = quarter_car.linearize("modes")
    assert lin.dof == 2
    assert lin.undamped_frequencies == pytest.approx(formula, rel=0.01)


@pytest.mark.slow  # a second derivation of the full vehicle (~10 s) besides the balance test's
def test_full_vehicle_rigid_body_motions_have_zero_frequency_the_others_do_not():
    """Travel, side shift and yaw of the car on its point-contact tyres (no horizontal tyre forces) have
    neither stiffness nor damping: 3 of the 10 degrees of freedom, 6 zero eigenvalues; heave, pitch, roll and
    the four wheel hops are springs."""
    vehicle = mbs.load("library/iltis/vehicle.mbs")
    lin = vehicle.linearize("balance")
    assert lin.dof == 6 + 4
    rigid = [m for m in lin.modes if m.frequency == 0.0]
    assert len(rigid) == 6
    assert all(set(dict(m.dominant(2))) <= {"floating.x", "floating.y", "floating.wz"} for m in rigid)
    assert np.count_nonzero(lin.undamped_frequencies == 0.0) == 3
    assert np.all(lin.undamped_frequencies[3:] > 1.0)
