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
from mbs.runtime.equilibrium_newton import newton_equilibrium

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")


def start(system, scene):
    compiled = system.compile(scene)
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    return compiled, system._workspace(compiled, system.generate(scene), values)


def test_newton_finds_the_quarter_cars_rest_of_the_kinetic_damping(tmp_path, monkeypatch):
    system = mbs.load("library/iltis/quarter_car.mbs", cache_dir=str(tmp_path))
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


def test_an_unstable_rest_is_left_to_the_kinetic_damping(tmp_path):
    system = mbs.loads(PENDULUM, cache_dir=str(tmp_path))
    compiled, data = start(system, None)
    assert newton_equilibrium(compiled, data, data.x) is None  # it converges to upright, which is unstable
    result = E.static_equilibrium(compiled, data, data.x)
    assert math.cos(result.x[0]) == pytest.approx(1.0, abs=1e-9)  # hanging down


def test_chord_steps_reach_full_newtons_rest_with_fewer_evaluations(monkeypatch):
    """Keeping the Jacobian while the residual falls fast (CHORD_CONTRACTION) must land where Newton with a fresh
    Jacobian at every step lands (CHORD_CONTRACTION = 0 recomputes it after every step), for fewer rhs calls: on
    the Iltis vehicle (10 degrees of freedom, so 10 evaluations per Jacobian) from its assembled start."""
    from mbs.runtime import equilibrium_newton as N
    system = mbs.load("library/iltis/vehicle.mbs")  # the build cache the other Iltis tests share
    found = {}
    for label, contraction in (("chord", N.CHORD_CONTRACTION), ("full", 0.0)):
        compiled, data = start(system, "bump_5")
        calls = []
        rhs = data.function("rhs")
        monkeypatch.setitem(data._functions, "rhs", lambda t, x, rhs=rhs: calls.append(t) or rhs(t, x))
        monkeypatch.setattr(N, "CHORD_CONTRACTION", contraction)
        x = newton_equilibrium(compiled, data, data.x)
        assert x is not None
        assert np.max(np.abs(rhs(0.0, x)[compiled.nq:])) < N.TOLERANCE
        found[label] = (x, len(calls))
    (chord, n_chord), (full, n_full) = found["chord"], found["full"]
    # both stop within TOLERANCE = 1e-9 m/s^2 of rest: the stiff coordinates agree to that over the stiffness; the
    # chassis' travel (x) and yaw have none (a least-squares step moves them by the differences' noise, either way)
    stiff = [i for i, name in enumerate(compiled.q_names) if name not in ("floating.x", "floating.y", "floating.qz")]
    assert np.max(np.abs(chord[stiff] - full[stiff])) < 1e-9
    assert n_chord < 0.8 * n_full
