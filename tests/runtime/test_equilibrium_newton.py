"""Static equilibrium by Newton on the reduced equations (runtime/equilibrium_newton.py) against the kinetic
damping it replaces (an independent method: a damped transient that slides into the minimum), on the Iltis
quarter car (closed loops) and on a pendulum started near its unstable upright position (Newton must not
return that one)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbs
from mbs import pipeline
from mbs.runtime import build
from mbs.runtime import equilibrium as E
from mbs.runtime.equilibrium_newton import _step, newton_equilibrium

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")


def start(system, scene):
    compiled = system.compile(scene)
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    return compiled, system._workspace(compiled, system.generate(scene), values)


def test_newton_finds_the_quarter_cars_rest_of_the_kinetic_damping(monkeypatch):
    system = mbs.load("library/iltis/quarter_car.mbs")  # the default cache: the Iltis tests' build of it
    compiled, data = start(system, "settle")
    x = newton_equilibrium(compiled, data, data.x)
    assert x is not None
    assert np.max(np.abs(data.rhs(0.0, x)[compiled.nq:])) < 1e-9
    monkeypatch.setattr(E, "newton_equilibrium", lambda *args: None)
    compiled, data = start(system, "settle")
    damped = E.static_equilibrium(compiled, data, data.x)
    # the damping stops at |vdot| <= 1e-6: positions agree to that over the stiffness (about 1e-7 m here)
    assert np.max(np.abs(x[:compiled.nq] - damped.x[:compiled.nq])) < 1e-6


PENDULUM = """
model pendulum "a pendulum near its upright position" {
    rigid bob {
        body {
            mass = 1 kg
            com = (0, 0, -1) m
            inertia = diag(0.01, 0.01, 0.01) kg*m^2
        }
    }
    interact hinge {
        connect inertial -> bob
        joint revolute(axis = x) {
            init phi = 179 deg
        }
    }
}
"""


def test_an_unstable_rest_is_left_to_the_kinetic_damping():
    system = mbs.loads(PENDULUM)
    compiled, data = start(system, None)
    assert newton_equilibrium(compiled, data, data.x) is None  # it converges to upright, which is unstable
    result = E.static_equilibrium(compiled, data, data.x)
    assert math.cos(result.x[0]) == pytest.approx(1.0, abs=1e-9)  # hanging down



def test_a_direction_without_stiffness_is_held_exactly_where_its_column_is_not_zero():
    """Coordinates (z, pitch, yaw): yaw feels no force (its row of accelerations is zero) but moves the z
    acceleration a little (its column is 1 % of z's: the Iltis' heading with its front wheels at the start of the
    bump). The rest it finds must keep yaw where it was and solve the other two by hand: z = 1/100, pitch = 2/50.
    The minimum-norm step would move yaw by about 1e-4 (the test's teeth)."""
    J = np.array([[-100.0, 0.0, -1.0],
                  [0.0, -50.0, 0.0],
                  [0.0, 0.0, 0.0]])
    acc = np.array([1.0, 2.0, 0.0])
    step = _step(J, acc)
    assert step[2] == 0.0
    assert step[:2] == pytest.approx([0.01, 0.04], rel=1e-14)
    assert abs(np.linalg.lstsq(J, -acc, rcond=None)[0][2]) > 1e-5


def test_the_column_pivots_are_those_of_the_textbook_loop():
    """_pivot_columns against QR with column pivoting written as the textbook has it (Golub and Van Loan 5.4.2,
    numpy arrays throughout) on random null-space bases, ties among them: the same pivots."""
    from mbs.runtime.equilibrium_newton import _pivot_columns

    def textbook(A, k):
        R, chosen = np.array(A, dtype=float), []
        for _ in range(k):
            norms = np.einsum("ij,ij->j", R, R)
            norms[chosen] = -1.0
            j = int(norms.argmax())
            if not norms[j] > 0.0:
                break
            chosen.append(j)
            q = R[:, j] / np.sqrt(norms[j])
            R -= np.outer(q, q @ R)
        return chosen
    rng = np.random.default_rng(5)
    for trial in range(300):
        k, n = rng.integers(1, 5), rng.integers(5, 12)
        A = rng.standard_normal((k, n))
        if trial % 3 == 0:
            A[:, rng.integers(n)] = A[:, 0]  # two columns of the same norm
        if trial % 5 == 0:
            A[:, 1] = 0.0
        assert _pivot_columns(A, k) == textbook(A, k)
    assert _pivot_columns(np.zeros((2, 4)), 2) == textbook(np.zeros((2, 4)), 2) == []
