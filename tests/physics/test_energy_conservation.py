"""Conservative mechanisms keep their energy: kinetic plus potential energy computed in the test from the
simulated states by forward kinematics written in numpy (physkit), from the mechanism's description written
again here by hand, not from anything the compiler produced.

Bound: the integrators run at rtol 1e-11; the energy error of a tolerance-controlled run grows with the local
errors, a few times rtol over 10 s (observed below 3e-11 of the energy scale m g l summed over the links, for
both integrators, even for the chaotic double pendulum). DRIFT = 1e-9 leaves a margin of 30; a wrong sign or
factor anywhere in the equations (a Coriolis term, an inertia product, a frame rotation) breaks the energy
balance at 1e-3 or more.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import physkit  # noqa: E402
from physkit import Link, cardan, rot  # noqa: E402

import mbs  # noqa: E402
from mbs.runtime.workspace import Workspace  # noqa: E402

G = 9.81
DRIFT = 1e-9
T_END = 10.0


def double_pendulum():
    m1, m2, l1, l2 = 1.3, 0.7, 0.9, 1.2
    rod = lambda m, l: np.diag([m * l * l / 12, m * l * l / 12, 1e-3])  # noqa: E731
    return [Link("shoulder", -1, "revolute", m1, np.array([0, 0, -l1 / 2]), rod(m1, l1), axes=((0, 1, 0),)),
            Link("elbow", 0, "revolute", m2, np.array([0, 0, -l2 / 2]), rod(m2, l2), axes=((0, 1, 0),),
                 ra=np.array([0, 0, -l1]))]


def ball_chain():
    sizes = [(1.0, 0.5), (0.8, 0.6), (0.6, 0.4), (0.5, 0.3)]   # (m, l) of links a, b, c, d
    links = []
    for i, ((m, l), name) in enumerate(zip(sizes, ["top", "ab", "bc", "cd"])):
        inertia = np.array([[m * l * l / 12 + 0.002, 0.001, -0.0005],
                            [0.001, m * l * l / 12 + 0.003, 0.001],
                            [-0.0005, 0.001, 0.004]])
        ra = np.zeros(3) if i == 0 else np.array([0, 0.01, -sizes[i - 1][1]])
        links.append(Link(name, i - 1, "cardan" if name == "cd" else "spherical", m, np.array([0.03, -0.02, -l / 2]),
                          inertia, ra=ra))
    return links


def mixed_chain():
    d = np.radians
    return [
        Link("hip", -1, "universal", 1.2, np.array([0.02, 0, -0.3]), np.diag([0.04, 0.05, 0.01]),
             axes=((1, 0, 0), (0, 1, 0))),
        Link("knee", 0, "revolute", 0.8, np.array([0.1, 0.05, -0.2]),
             np.array([[0.02, 0.003, 0], [0.003, 0.03, -0.002], [0, -0.002, 0.015]]), axes=((1, 1, 0),),
             ra=np.array([0, 0.05, -0.6]), Ra=rot((0, 0, 1), d(30))),
        Link("wrist", 1, "universal", 0.5, np.array([0, 0.08, -0.15]), np.diag([0.01, 0.008, 0.004]),
             axes=((0, 0, 1), (1, 0, 1)), ra=np.array([0.05, 0, -0.45]), Ra=cardan(d(10), d(-20), d(5))),
        Link("spin", 2, "revolute", 0.3, np.array([0.12, 0, 0]), np.diag([0.001, 0.004, 0.004]), axes=((0, 0, 1),),
             ra=np.array([0, 0, -0.3])),
    ]


#: fixture file -> (links, energy scale [J]: sum of m g l over the links, l its length)
MODELS = {
    "double_pendulum": (double_pendulum, G * (1.3 * 0.9 + 0.7 * 1.2)),
    "ball_chain": (ball_chain, G * (1.0 * 0.5 + 0.8 * 0.6 + 0.6 * 0.4 + 0.5 * 0.3)),
    "mixed_chain": (mixed_chain, G * (1.2 * 0.6 + 0.8 * 0.45 + 0.5 * 0.3 + 0.3 * 0.12)),
}


@pytest.fixture(scope="module", params=list(MODELS))
def model(request):
    make, scale = MODELS[request.param]
    return mbs.load(physkit.MODELS / f"{request.param}.mbs"), make(), scale


def energies(res, links):
    return np.array([physkit.energy(links, physkit.sample_values(res, i)) for i in range(len(res))])


@pytest.mark.parametrize("integrator", ["dopri5", "DOP853"])
def test_energy_is_conserved(model, integrator):
    system, links, scale = model
    res = system.simulate(t_end=T_END, sample=0.01, integrator=integrator, rtol=1e-11, atol=1e-12)
    assert res.success, res.message
    kinetic, potential = energies(res, links).T
    total = kinetic + potential
    # The test is not vacuous: a good part of the energy goes back and forth between the two forms.
    assert np.ptp(kinetic) > 0.1 * scale
    assert np.max(np.abs(total - total[0])) < DRIFT * scale


def test_initial_energy_is_the_mass_matrix_quadratic_form(model):
    # The compiled mass matrix is the kinetic energy's Hessian in the speeds: T = v^T M v / 2 at the start.
    system, links, _ = model
    compiled = system.compile()
    data = Workspace(compiled)
    x = data.x.copy()
    v = x[compiled.nq:]
    values = dict(zip(compiled.x_names, x))
    kinetic, _ = physkit.energy(links, values)
    assert kinetic > 0.1
    assert 0.5 * v @ data.mass_matrix(0.0, x) @ v == pytest.approx(kinetic, rel=1e-12)
