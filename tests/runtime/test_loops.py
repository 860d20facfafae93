"""Closed kinematic loops end to end: constraints derived and compiled, projected, partitioned and integrated in
C (runtime/c/loops.c), assembled from approximate initial values (runtime/assembly.py). Oracles: the analytic
slider-crank and its Lagrange equation integrated by scipy, Freudenstein's equation of the four-bar, the
closed-form input-output relation of a spatial RSSR linkage, energy conservation, and the multipliers as the
force on the slider."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from mbs.compiler.ccode import generate_loop_c
from mbs.compiler.constraints import CutJoint, derive_constraints
from mbs.compiler.equations import derive_equations
from mbs.compiler.kinematics import Kinematics
from mbs.compiler.tree import JointSpec, Tree, TreeBody
from mbs.runtime import build
from mbs.runtime.assembly import AssemblyError, assemble, project_samples
from mbs.runtime.errors import EvaluationError
from mbs.runtime.model import load_c
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

G = 9.81
EYE = sp.eye(3)
PLANE = ((0, -1, 0),)  # revolute axis: angles counter-clockwise in the x-z plane (z up)
REPORT_RANK, REPORT_DOF, REPORT_ORDER = 5, 6, 8  # fields of loop_report


def at(x, y=0.0, z=0.0):
    return (EYE, (x, y, z))


def bar(name, parent, X, length, mass, axis=PLANE, prescribed=()):
    """A slender bar along its x axis on a revolute joint."""
    inertia = sp.diag(1e-4, mass * length**2 / 12, mass * length**2 / 12)
    return TreeBody(name, parent, JointSpec("revolute", axis), X, at(0), mass, (length / 2, 0, 0), inertia,
                    prescribed)


def state_name(symbol) -> str:
    name = symbol.name
    if ".der(" in name:
        head, local = name[:-1].split(".der(")
        return f"der({head}.{local})"
    return name


class Mechanism:
    """A tree with cut joints, compiled with its loop functions; `run` integrates and projects the samples."""

    def __init__(self, name, bodies, cuts, cache_dir, gravity=(0, 0, -G), parameters=None):
        tree = Tree(tuple(bodies), gravity)
        kin = Kinematics(tree)
        self.constraints = derive_constraints(kin, cuts)
        equations = derive_equations(kin, forward_dynamics=False)
        parameters = dict(parameters or {})
        symbols = [sp.Symbol(n) for n in parameters]
        self.source = generate_loop_c(equations, self.constraints, symbols, name)
        self.model = load_c(code=self.source, cache_dir=cache_dir, name=name,
                            q_names=[state_name(s) for s in tree.q_symbols],
                            v_names=[state_name(s) for s in tree.v_symbols], p_names=list(parameters),
                            p_default=list(parameters.values()))
        self.tree = tree

    def workspace(self, x0, fixed, t=0.0):
        data = Workspace(self.model)
        data.t = t
        data.x = assemble(self.model, data, x0, fixed=fixed, row_names=self.constraints.names).x
        return data

    def run(self, data, t_end, sample, rtol=1e-10, atol=1e-12):
        """(times, projected states, raw states) of a dopri5 run."""
        res = simulate(self.model, data, t_end, sample=sample, rtol=rtol, atol=atol, outputs=False)
        assert res.success, res.message
        raw = np.column_stack([res[n] for n in self.model.x_names])
        projected = raw.copy()
        assert project_samples(data, res.t, projected) == len(res.t)
        return res.t, projected, raw

    def residuals(self, data, times, states):
        """max |g| and max |G v + g_t| over the samples."""
        g = max(np.max(np.abs(data.constraints(t, x))) for t, x in zip(times, states))
        gd = max(np.max(np.abs(data.constraint_velocity(t, x))) for t, x in zip(times, states))
        return g, gd


# ---- the mechanisms ---------------------------------------------------------------------------------------------

SC = dict(r=0.1, L=0.4, mc=1.0, mr=0.5, ms=2.0)


def slider_crank(cache_dir, r, L, mc, mr, ms, gravity=(0, 0, -G), name="slider_crank"):
    slider = TreeBody("slider", -1, JointSpec("prismatic", ((1, 0, 0),)), at(0), at(0), ms, (0, 0, 0),
                      sp.diag(1e-3, 1e-3, 1e-3))
    bodies = (bar("crank", -1, at(0), r, mc), bar("rod", 0, at(r), L, mr), slider)
    return Mechanism(name, bodies, [CutJoint("wrist", JointSpec("revolute", PLANE), 1, at(L), 2, at(0))],
                     cache_dir, gravity)


FB = dict(a=0.2, b=0.7, c=0.5, d=0.6)  # Grashof crank-rocker: crank a, coupler b, rocker c, ground d


def four_bar(cache_dir, a, b, c, d):
    """The ground link d is a run-time parameter."""
    bodies = (bar("crank", -1, at(0), a, 1.0), bar("coupler", 0, at(a), b, 0.8),
              bar("rocker", -1, at(sp.Symbol("d")), c, 1.2))
    return Mechanism("four_bar", bodies, [CutJoint("pin", JointSpec("revolute", PLANE), 1, at(b), 2, at(c))],
                     cache_dir, parameters={"d": d})


def four_bar_state(theta, omega, a, b, c, d):
    """Approximate initial state (open branch) for crank angle theta: coupler and rocker angles from the
    triangle C-E-D."""
    C, D = a * np.array([math.cos(theta), math.sin(theta)]), np.array([d, 0.0])
    dist = np.linalg.norm(D - C)
    beta = math.atan2(*(D - C)[::-1]) + math.acos((b * b + dist * dist - c * c) / (2 * b * dist))
    E = C + b * np.array([math.cos(beta), math.sin(beta)])
    psi = math.atan2(*(E - D)[::-1])
    return np.array([theta, beta - theta, psi, omega, 0.0, 0.0])


@pytest.fixture(scope="module")
def sc(cache_dir):
    return slider_crank(cache_dir, **SC)


@pytest.fixture(scope="module")
def fb(cache_dir):
    return four_bar(cache_dir, **FB)


# ---- slider-crank -------------------------------------------------------------------------------------------------

def slider_crank_lagrange(r, L, mc, mr, ms, theta0, omega0, times):
    """theta(t) of the slider-crank from its one-coordinate Lagrange equation (independent of the compiler):
    m(theta) theta'' + m'(theta) theta'^2 / 2 + V'(theta) = 0, integrated by scipy's DOP853."""
    th, w = sp.symbols("theta omega")
    beta = -sp.asin(r * sp.sin(th) / L)                      # rod angle
    cc = r / 2 * sp.Matrix([sp.cos(th), sp.sin(th)])          # crank centre of mass
    rc = r * sp.Matrix([sp.cos(th), sp.sin(th)]) + L / 2 * sp.Matrix([sp.cos(beta), sp.sin(beta)])
    s = r * sp.cos(th) + L * sp.cos(beta)
    d = lambda e: sp.diff(e, th) * w  # noqa: E731
    T = (sp.Rational(1, 2) * (mc * r**2 / 12) * w**2 + sp.Rational(1, 2) * mc * (d(cc).dot(d(cc)))
         + sp.Rational(1, 2) * mr * d(rc).dot(d(rc)) + sp.Rational(1, 2) * (mr * L**2 / 12) * d(beta)**2
         + sp.Rational(1, 2) * ms * d(s)**2)
    m = sp.simplify(2 * T / w**2)
    V = G * (mc * cc[1] + mr * rc[1])
    m_f, dm_f, dV_f = (sp.lambdify(th, e) for e in (m, sp.diff(m, th), sp.diff(V, th)))

    def rhs(_, y):
        return [y[1], -(0.5 * dm_f(y[0]) * y[1]**2 + dV_f(y[0])) / m_f(y[0])]
    sol = solve_ivp(rhs, (times[0], times[-1]), [theta0, omega0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=times)
    return sol.y[0]


def test_slider_crank_against_its_analytic_kinematics_and_lagrange_equation(sc):
    r, L = SC["r"], SC["L"]
    data = sc.workspace([0.0, 0.0, 0.5, 40.0, 0.0, 0.0], fixed=["crank.phi", "der(crank.phi)"])
    times, X, raw = sc.run(data, 2.0, 0.01, rtol=1e-12, atol=1e-14)
    th, psi, s, w, dpsi, ds = X.T
    root = np.sqrt(L**2 - r**2 * np.sin(th)**2)
    assert np.max(np.abs(s - (r * np.cos(th) + root))) < 1e-12
    s_dot = -r * np.sin(th) * w * (1 + r * np.cos(th) / root)
    assert np.max(np.abs(ds - s_dot)) < 1e-11 * np.max(np.abs(w))
    # accelerations from the model's right-hand side against s'' = s'(th) th'' + s''(th) th'^2
    xdot = np.array([data.rhs(t, x) for t, x in zip(times, X)])
    th_dd, s_dd = xdot[:, 3], xdot[:, 5]
    ds_dth = -r * np.sin(th) * (1 + r * np.cos(th) / root)
    d2s_dth2 = -r * np.cos(th) - r**2 * np.cos(2 * th) / root - r**4 * np.sin(th)**2 * np.cos(th)**2 / root**3
    assert np.max(np.abs(s_dd - (ds_dth * th_dd + d2s_dth2 * w**2))) < 1e-8
    # the dynamics: the one-coordinate Lagrange equation, integrated independently
    theta = slider_crank_lagrange(**SC, theta0=0.0, omega0=40.0, times=times)
    assert np.max(np.abs(th - theta)) < 5e-9  # 1e-9 measured (7 turns); 6e-8 with rtol = 1e-10
    assert th[-1] > 6 * math.pi  # over the top against gravity, again and again


def check_multipliers(data, t, x):
    """lambda satisfies M vdot = f + G^T lambda at a consistent state x; returns it."""
    lam, vdot = data.multipliers(t, x), data.rhs(t, x)[data.model.nq:]
    M, f, Gm = data.mass_matrix(t, x), data.forces(t, x), data.constraint_jacobian(t, x)
    assert np.allclose(M @ vdot - f, Gm.T @ lam, rtol=1e-10, atol=1e-10 * np.max(np.abs(f)))
    return lam


def test_slider_crank_multiplier_is_the_force_on_the_slider(sc):
    """The x row of the cut is the rod's force on the slider, m_s s''."""
    data = sc.workspace([0.7, -0.2, 0.45, 8.0, 0.0, 0.0], fixed=["crank.phi", "der(crank.phi)"])
    lam = check_multipliers(data, 0.0, data.x)
    assert lam[0] == pytest.approx(SC["ms"] * data.rhs(0.0, data.x)[5], rel=1e-10)
    assert lam[1] == lam[3] == lam[4] == 0.0  # rows outside the plane are redundant: no reaction assigned


# ---- four-bar ----------------------------------------------------------------------------------------------------

def test_four_bar_follows_freudensteins_equation(fb):
    a, b, c, d = FB.values()
    data = fb.workspace(four_bar_state(math.pi / 2, 4.0, **FB), fixed=["crank.phi", "der(crank.phi)"])
    report = data.loop_report(0.0, data.x)
    assert (report[REPORT_RANK], report[REPORT_DOF]) == (2, 1)  # 5 rows of a revolute cut, 2 of them in the plane
    times, X, _ = fb.run(data, 3.0, 0.01)
    th, th_c, psi, w, _, dpsi = X.T
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    assert np.max(np.abs(K1 * np.cos(psi) - K2 * np.cos(th) + K3 - np.cos(th - psi))) < 1e-11
    velocity = -K1 * np.sin(psi) * dpsi + K2 * np.sin(th) * w + np.sin(th - psi) * (w - dpsi)
    assert np.max(np.abs(velocity)) < 1e-11 * np.max(np.abs(w))
    xdot = np.array([data.rhs(t, x) for t, x in zip(times, X)])
    wd, psid = xdot[:, 3], xdot[:, 5]
    acceleration = (-K1 * (np.cos(psi) * dpsi**2 + np.sin(psi) * psid) + K2 * (np.cos(th) * w**2 + np.sin(th) * wd)
                    + np.cos(th - psi) * (w - dpsi)**2 + np.sin(th - psi) * (wd - psid))
    assert np.max(np.abs(acceleration)) < 1e-8
    assert (th[-1] - th[0]) > 2 * math.pi  # the crank turns over
    for k in range(0, len(times), 50):
        check_multipliers(data, times[k], X[k])


def test_driven_four_bar_follows_its_prescribed_crank(cache_dir):
    """The crank angle prescribed, theta(t) = 0.5 + 2 t + 0.3 sin 3t: no degree of freedom is left, the motion
    comes from the rheonomic terms g_t and gddot alone; the rocker follows Freudenstein's equation solved for
    psi."""
    a, b, c, d = FB.values()
    tt = sp.Symbol("t")
    theta_t = 0.5 + 2 * tt + sp.Rational(3, 10) * sp.sin(3 * tt)
    bodies = (bar("crank", -1, at(0), a, 1.0, prescribed=(theta_t,)), bar("coupler", 0, at(a), b, 0.8),
              bar("rocker", -1, at(d), c, 1.2))
    mech = Mechanism("driven_four_bar", bodies,
                     [CutJoint("pin", JointSpec("revolute", PLANE), 1, at(b), 2, at(c))], cache_dir)
    x0 = four_bar_state(0.5, 0.0, **FB)
    data = mech.workspace([x0[1], x0[2], 0.0, 0.0], fixed=[])
    assert data.loop_report(0.0, data.x)[REPORT_DOF] == 0
    times, X, _ = mech.run(data, 2.0, 0.01)
    theta = 0.5 + 2 * times + 0.3 * np.sin(3 * times)
    w, wd = 2 + 0.9 * np.cos(3 * times), -2.7 * np.sin(3 * times)
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A_, B_, C_ = K1 - np.cos(theta), -np.sin(theta), K2 * np.cos(theta) - K3
    psi_closed = np.arctan2(B_, A_) + np.arccos(C_ / np.hypot(A_, B_))
    psi, dpsi = X[:, 1], X[:, 3]
    assert np.max(np.abs(np.angle(np.exp(1j * (psi - psi_closed))))) < 1e-10
    velocity = -K1 * np.sin(psi) * dpsi + K2 * np.sin(theta) * w + np.sin(theta - psi) * (w - dpsi)
    assert np.max(np.abs(velocity)) < 1e-11 * np.max(np.abs(w))
    psid = np.array([data.rhs(t, x)[3] for t, x in zip(times, X)])
    acceleration = (-K1 * (np.cos(psi) * dpsi**2 + np.sin(psi) * psid) + K2 * (np.cos(theta) * w**2
                    + np.sin(theta) * wd) + np.cos(theta - psi) * (w - dpsi)**2 + np.sin(theta - psi) * (wd - psid))
    assert np.max(np.abs(acceleration)) < 1e-8


def energy(data, times, X, masses_and_coms):
    """Kinetic energy from the mass matrix plus the potential energy of the bodies' centres of mass, which
    `masses_and_coms(x)` lists as (mass, height) pairs."""
    nq = data.model.nq
    return np.array([0.5 * x[nq:] @ data.mass_matrix(t, x) @ x[nq:] + G * sum(m * z for m, z in masses_and_coms(x))
                     for t, x in zip(times, X)])


def test_constraints_hold_after_a_long_run_without_drift(fb):
    a, b, c, d = FB.values()
    data = fb.workspace(four_bar_state(1.0, 6.0, **FB), fixed=["crank.phi", "der(crank.phi)"])
    times, X, raw = fb.run(data, 20.0, 0.01, rtol=1e-9, atol=1e-11)
    first, last = times < 1.0, times > 19.0
    g0, gd0 = fb.residuals(data, times[first], X[first])
    g1, gd1 = fb.residuals(data, times[last], X[last])
    assert max(g0, g1) < 1e-12 and max(gd0, gd1) < 1e-11  # the stored states satisfy the constraints ...
    # ... as well at the end as at the start, down to the round-off of evaluating g itself: the link lengths
    # times the angles' own round-off (one eps |angle| for each of the three links), which grows with the angle
    # turned (about 120 rad after 20 s)
    g_floor = 4 * np.finfo(float).eps * max(a, b, c, d) * (1 + np.max(np.abs(X[last][:, :3])))
    assert g1 <= max(10 * g0, g_floor) and gd1 <= max(10 * gd0, 1e-13)

    def bodies(x):
        th, th_c, psi = x[:3]
        return [(1.0, a / 2 * math.sin(th)), (0.8, a * math.sin(th) + b / 2 * math.sin(th + th_c)),
                (1.2, c / 2 * math.sin(psi))]
    E = energy(data, times, X, bodies)
    assert np.ptp(E) < 1e-6 * np.max(np.abs(E))
    # the integrated (unprojected) states stay within the integration error of the manifold
    assert max(np.max(np.abs(data.constraints(t, x))) for t, x in zip(times, raw)) < 1e-6


@pytest.mark.parametrize("method", ["dopri5", "rodasp", "rodas5p"])
def test_the_c_integrators_keep_their_own_state_on_the_constraints(fb, method):
    """Every accepted step is projected onto the constraints (coordinate projection), so the integrated state
    itself does not drift away by the accumulated integration error: at every step of a 20 s run its residual
    stays within the Newton tolerance of the projection (1e-12), or within the drift an accepted step keeps when
    that is more (a hundredth of atol, c/loops.c MBS_LOOP_STEP_KEPT_ATOL: 1e-11 at atol 1e-9). Unprojected, the
    state of such a run drifts linearly in time, past 1e-8 at rtol 1e-8 (bench/loops.py before the projection)."""
    from mbs.runtime.integrators.registry import get_integrator
    data = fb.workspace(four_bar_state(1.0, 6.0, **FB), fixed=["crank.phi", "der(crank.phi)"])
    atol = 1e-9
    solver = get_integrator(method)(data.function("rhs"), 0.0, data.x, 20.0, rtol=1e-7, atol=atol)
    residuals = []
    while solver.status == "running":
        solver.step()
        residuals.append(np.max(np.abs(data.constraints(solver.t, solver.y))))
    assert solver.status == "finished", solver.message
    assert len(residuals) > 100  # a long run of many steps
    assert max(residuals) <= max(1e-12, 1e-2 * atol)


def test_partition_switches_at_the_dead_centres(cache_dir):
    """A slider-crank large enough that the slider is the best independent coordinate most of the time; at the
    dead centres its dependent block (crank, rod) is singular and the partition must switch."""
    r, L = 2.0, 6.0
    mech = slider_crank(cache_dir, r, L, 1.0, 0.5, 2.0, gravity=(0, 0, 0), name="big_slider_crank")
    data = mech.workspace([0.3, -0.1, 7.8, 5.0, 0.0, 0.0], fixed=["crank.phi", "der(crank.phi)"])
    times, X, _ = mech.run(data, 5.0, 0.002, rtol=1e-9, atol=1e-11)
    independent = np.array([data.loop_report(t, x)[REPORT_ORDER + 2] for t, x in zip(times, X)])
    slider_block = np.array([abs(np.linalg.det(data.constraint_jacobian(t, x)[[0, 2]][:, :2]))
                             for t, x in zip(times, X)])
    singular = slider_block < 0.02 * np.max(slider_block)
    assert np.any(independent == 2) and np.any(singular)
    assert not np.any(independent[singular] == 2)  # never the slider where its dependent block is singular
    assert (X[-1, 0] - X[0, 0]) > 4 * math.pi      # through several dead centres
    th, s = X[:, 0], X[:, 2]
    assert np.max(np.abs(s - r * np.cos(th) - np.sqrt(L**2 - r**2 * np.sin(th)**2))) < 1e-10
    E = energy(data, times, X, lambda x: [])
    assert np.ptp(E) < 1e-6 * E[0]


# ---- spatial RSSR with a massless coupler ----------------------------------------------------------------------

RSSR = dict(r1=0.1, r2=0.3, L=0.4, B=(0.2, 0.05, 0.15))


def rssr_rocker_angles(theta, r1, r2, L, B):
    """Both closed-form rocker angles psi(theta): |P(theta) - Q(psi)| = L with P = r1 (cos, sin, 0) about z at
    the origin and Q = B + r2 (0, cos psi, sin psi) about x at B."""
    P = np.stack([r1 * np.cos(theta), r1 * np.sin(theta), np.zeros_like(theta)], axis=-1)
    PB = P - np.array(B)
    A_, B_ = 2 * r2 * PB[..., 1], 2 * r2 * PB[..., 2]
    C_ = np.sum(PB**2, axis=-1) + r2**2 - L**2
    base, spread = np.arctan2(B_, A_), np.arccos(C_ / np.hypot(A_, B_))
    return base + spread, base - spread


def test_spatial_rssr_with_a_massless_tie_rod(cache_dir):
    """Crank (revolute z) - massless coupler (spherical, quaternion) - rocker (revolute x), closed by a spherical
    cut: 3 rows, rank 3, 2 degrees of freedom (one is the tie rod's spin, which has no inertia)."""
    r1, r2, L, B = RSSR.values()
    z, x_axis = ((0, 0, 1),), ((1, 0, 0),)
    crank = bar("crank", -1, at(0), r1, 1.0, axis=z)
    coupler = TreeBody("coupler", 0, JointSpec("spherical"), at(r1), at(0), 0, (0, 0, 0), sp.zeros(3))
    rocker = TreeBody("rocker", -1, JointSpec("revolute", x_axis), at(*B), at(0), 1.5, (0, r2 / 2, 0),
                      sp.diag(1.5 * r2**2 / 12, 1e-4, 1.5 * r2**2 / 12))
    mech = Mechanism("rssr", (crank, coupler, rocker),
                     [CutJoint("ball", JointSpec("spherical"), 1, at(L), 2, at(0, r2, 0))], cache_dir)
    theta0 = 0.3
    psi0 = rssr_rocker_angles(np.array(theta0), **RSSR)[0]
    P = np.array([r1 * math.cos(theta0), r1 * math.sin(theta0), 0])
    Q = np.array(B) + r2 * np.array([0, math.cos(psi0), math.sin(psi0)])
    u = (Q - P) / L  # coupler direction, world; in the crank frame rotated back by theta0
    c, s = math.cos(theta0), math.sin(theta0)
    u = np.array([c * u[0] + s * u[1], -s * u[0] + c * u[1], u[2]])
    quat = np.r_[1 + u[0], np.cross([1, 0, 0], u)]  # shortest arc from x to u
    x0 = np.r_[theta0, quat / np.linalg.norm(quat), psi0 + 0.01, 12.0, 0, 0, 0, 0]
    data = mech.workspace(x0, fixed=["crank.phi", "der(crank.phi)"])
    assert data.loop_report(0.0, data.x)[REPORT_RANK:REPORT_DOF + 1].tolist() == [3, 2]
    times, X, _ = mech.run(data, 2.0, 0.01)
    theta, psi = X[:, 0], X[:, 5]
    closed = rssr_rocker_angles(theta, **RSSR)[0]
    assert np.max(np.abs(np.angle(np.exp(1j * (psi - closed))))) < 1e-10
    assert (theta[-1] - theta[0]) > 2 * math.pi

    # the coupler has no mass (data.mass_matrix reports M singular): the energy of crank and rocker
    w, dpsi = X[:, 6], X[:, 10]
    E = 0.5 * (r1**2 / 3) * w**2 + 0.5 * (1.5 * r2**2 / 3) * dpsi**2 + 1.5 * G * (B[2] + r2 / 2 * np.sin(psi))
    assert np.ptp(E) < 1e-6 * np.max(np.abs(E))


# ---- redundant constraints ------------------------------------------------------------------------------------

def test_overconstrained_parallelogram_is_mobile(cache_dir):
    """Three equal parallel cranks under one coupler: 10 rows (two revolute cuts), 4 of them in the plane, rank 3
    (one redundant), 1 degree of freedom; the coupler translates on a circle."""
    a, d = 0.3, 0.8
    bodies = (bar("left", -1, at(0), a, 1.0), bar("coupler", 0, at(a), d, 2.0), bar("right", -1, at(d), a, 1.0),
              bar("middle", -1, at(d / 2), a, 0.5))
    mech = Mechanism("parallelogram", bodies,
                     [CutJoint("right_pin", JointSpec("revolute", PLANE), 1, at(d), 2, at(a)),
                      CutJoint("middle_pin", JointSpec("revolute", PLANE), 1, at(d / 2), 3, at(a))], cache_dir)
    theta0 = -math.pi / 2 + 0.5  # hanging, swung out
    data = mech.workspace([theta0, -theta0 + 0.01, theta0 + 0.02, theta0 - 0.01, 0, 0, 0, 0],
                          fixed=["left.phi"])
    found = assemble(mech.model, data, data.x, fixed=["left.phi"], row_names=mech.constraints.names)
    # the in-plane rows of both pins are dependent together; the out-of-plane rows vanish identically
    in_plane = {f"{pin}.{c}" for pin in ("right_pin", "middle_pin") for c in "xz"}
    assert (found.rank, found.dof, set(found.redundant)) == (3, 1, in_plane)
    assert set(found.idle) == set(mech.constraints.names) - in_plane
    report = data.loop_report(0.0, data.x)
    assert (report[REPORT_RANK], report[REPORT_DOF]) == (3, 1)
    times, X, _ = mech.run(data, 3.0, 0.01)
    left, coupler, right, middle = X[:, :4].T
    assert np.max(np.abs(right - left)) < 1e-11 and np.max(np.abs(middle - left)) < 1e-11
    assert np.max(np.abs(left + coupler)) < 1e-11  # the coupler stays horizontal

    def heights(x):
        s = math.sin(x[0])
        return [(1.0, a / 2 * s), (2.0, a * s), (1.0, a / 2 * s), (0.5, a / 2 * s)]
    E = energy(data, times, X, heights)
    assert np.ptp(E) < 1e-7 * np.max(np.abs(E))
    assert np.ptp(left) > 0.9  # it swings
    lam = check_multipliers(data, times[7], X[7])
    assert np.count_nonzero(lam) <= 3  # one reaction per independent row, the redundant rows carry none


# ---- assembly and failures -------------------------------------------------------------------------------------

def test_assembly_keeps_what_the_user_fixed_and_reports_the_rest(sc):
    data = Workspace(sc.model)
    result = assemble(sc.model, data, [0.4, 0.0, 0.5, 10.0, 0.0, 0.0], fixed=["crank.phi", "der(crank.phi)"],
                      row_names=sc.constraints.names)
    x = result.x
    assert x[0] == 0.4 and x[3] == 10.0
    assert result.residual < 1e-12 and result.velocity_residual < 1e-12
    assert (result.rank, result.dof) == (2, 1)
    assert {name for name, *_ in result.changed} == {"rod.phi", "slider.s", "der(rod.phi)", "der(slider.s)"}
    assert "rod.phi: 0 -> " in result.describe()


def test_a_mechanism_that_cannot_be_assembled_names_its_loop(sc):
    """The slider held 1 m from the crank pivot: rod and crank (0.4 + 0.1 m) cannot reach it."""
    data = Workspace(sc.model)
    with pytest.raises(AssemblyError) as info:
        assemble(sc.model, data, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0], fixed=["slider.s", "crank.phi"],
                 row_names=sc.constraints.names, spans={"wrist": None})
    error = info.value
    assert (error.loop, error.constraint, error.stage) == ("wrist", "wrist.x", "position")
    assert error.residual == pytest.approx(0.5, abs=1e-9)
    assert error.message == ("the closed loop through joint 'wrist' cannot be assembled: its position "
                             "constraint 'wrist.x' is off by 0.5 m after 1 iteration(s) holding crank.phi, slider.s")


def test_speeds_that_contradict_each_other_are_reported(sc):
    data = Workspace(sc.model)
    with pytest.raises(AssemblyError) as info:
        assemble(sc.model, data, [0.7, 0.0, 0.4, 8.0, 0.0, 5.0], fixed=["der(crank.phi)", "der(slider.s)"],
                 row_names=sc.constraints.names)
    error = info.value
    assert (error.loop, error.stage) == ("wrist", "velocity") and error.constraint in ("wrist.x", "wrist.z")
    assert error.residual > 0.1 and " m/s after " in error.message


def test_the_run_time_projection_reports_a_loop_it_cannot_close(fb):
    """The four-bar's ground link set longer than the three other links together: no configuration exists."""
    data = Workspace(fb.model)
    x = four_bar_state(1.0, 0.0, **FB)
    data.set_param("d", 1.5)
    with pytest.raises(EvaluationError) as info:
        data.project(0.0, x)
    assert info.value.status == 3
    report = data.loop_report(0.0, x)
    assert report[0] == 3 and fb.constraints.names[int(report[4])] in ("pin.x", "pin.z")
    assert report[3] > 0.01  # the residual left
    data.set_param("d", FB["d"])
    assert data.loop_report(0.0, x)[0] == 0


def test_slider_crank_model_file_end_to_end(cache_dir, monkeypatch):
    """library/examples/slider_crank.mbs through the lowering (with the loop check switched off and the cut
    joints built as the proposed change to compiler/lower.py does), assembled from the file's init values."""
    from mbs.compiler import lower as lower_module
    from mbs.compiler.topology import Topology
    from mbs.language import expr as X
    from mbs.language.frontend import load

    model = load(Path(__file__).parents[2] / "library" / "examples" / "slider_crank.mbs")
    monkeypatch.setattr(Topology, "has_loops", property(lambda self: False))
    lowering = lower_module._Lowering(model, None)
    lowering.attach_forces()
    cuts = []
    for inter in lowering.topology.cuts:
        axes = tuple(tuple(lowering.geometry(c) for c in axis) for axis in inter.joint.axes)
        cuts.append(CutJoint(inter.name, JointSpec(inter.joint.kind, axes), lowering.body(inter.a.part),
                             lowering._pose(inter.a), lowering.body(inter.b.part), lowering._pose(inter.b)))
    kin = lowering.kin
    constraints = derive_constraints(kin, cuts)
    equations = derive_equations(kin, forward_dynamics=False)
    params = sorted(set(equations.parameters()) | set(constraints.parameters()), key=lambda s: s.name)
    values = {"r": 0.1, "L": 0.4, "m_crank": 1.0, "m_rod": 0.5, "m_slider": 2.0}
    source = generate_loop_c(equations, constraints, params, model.name)
    compiled = load_c(code=source, cache_dir=cache_dir, name=model.name,
                      q_names=[state_name(s) for s in kin.tree.q_symbols],
                      v_names=[state_name(s) for s in kin.tree.v_symbols], p_names=[p.name for p in params],
                      p_default=[values[p.name] for p in params])
    fixed = [c.name for c in model.coordinates if c.init is not X.ZERO]
    fixed += [f"der({c.name})" for c in model.coordinates if c.init_speed is not X.ZERO]
    assert sorted(fixed) == ["crank_pin.phi", "der(main_bearing.phi)", "guide.s"]
    inits = {"guide.s": 0.5, "der(main_bearing.phi)": 10.0}  # the file's init values
    assert compiled.x_names[:3] == ("main_bearing.phi", "guide.s", "crank_pin.phi")  # breadth-first tree order
    x0 = [inits.get(name, 0.0) for name in compiled.x_names]
    data = Workspace(compiled)
    result = assemble(compiled, data, x0, fixed=fixed, row_names=constraints.names)
    assert result.x[3] == 10.0 and result.dof == 1
    data.x = result.x
    res = simulate(compiled, data, 2.0, sample=0.01, rtol=1e-10, atol=1e-12)
    states = np.column_stack([res[n] for n in compiled.x_names])
    project_samples(data, res.t, states)
    th, s = states[:, 0], states[:, 1]
    # the projection stops at max |g| <= 1e-12 (MBS_LOOP_TOL in c/loops.c) in the cut joint's own rows; along the
    # guide that residual grows by at most 1 / cos(rod angle), sin(rod angle) <= r / L = 0.25, plus round-off
    bound = 1e-12 / math.sqrt(1 - 0.25**2) + 1e-13
    assert np.max(np.abs(s - 0.1 * np.cos(th) - np.sqrt(0.16 - 0.01 * np.sin(th)**2))) < bound
    assert (th[-1] - th[0]) > 2 * math.pi


def test_multipliers_over_the_mass_pattern_are_those_over_whole_rows():
    """mbs_loop_lambda sums the rows of M times vdot over the structural nonzeros of M (MBS_MASS_PATTERN): the
    multipliers satisfy M vdot = f + G^T lambda, and are those of the former sums over whole rows
    (-DMBS_LOOP_LAMBDA_FORMER=1) to the bit, at the states of a moving slider-crank (M with zeros between the
    slider and the crank)."""
    import mbs
    from former_builds import flagged_build

    system = mbs.load(Path(__file__).resolve().parent / "models" / "slider_crank_spring.mbs")
    assert "#define MBS_MASS_PATTERN 1" in system.generate().c_source
    res = system.simulate(t_end=0.2, sample=0.02)
    compiled = system.compile()
    states = res.data[:, 1:1 + compiled.nx]
    data, former = Workspace(compiled), Workspace(flagged_build(system, None, ("-DMBS_LOOP_LAMBDA_FORMER=1",)))
    data.p = former.p = compiled.p_default
    moving = 0
    for t, x in zip(res.t, states):
        lam = check_multipliers(data, float(t), x)
        assert np.array_equal(lam, former.multipliers(float(t), x))
        moving += np.max(np.abs(lam)) > 1.0
    assert moving > len(states) // 2  # the spring drives the crank: reactions of newtons
