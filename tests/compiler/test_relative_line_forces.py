"""Line forces between two bodies below a common moving body, computed in that body's frame (Kinematics.load_frame,
compiler/kinematics.py, and the forces along an axis of compiler/lower.py), against the same forces computed in world
components (the path of a force with an end on the ground, forced here by a load frame of -1): the generalized
forces and the elements' tensions agree at random states and speeds, on a floating car body whose two arms carry a
spring-damper from the body to an arm, one between the two arms, and springs along an axis of a rotated frame on
the body and on an arm (whose axis turns in the body's frame)."""

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from mbs.compiler.equations import derive_equations
from mbs.compiler.events import FROZEN
from mbs.compiler.kinematics import Kinematics
from mbs.compiler.lower import lower
from mbs.compiler.tree import t
from mbs.language.frontend import load_text

sys.path.insert(0, str(Path(__file__).parent))
from treekit import numeric_function  # noqa: E402

MODEL = """
model relative_lines {
    gravity = (0, 0, -9.81) m/s^2
    rigid car {
        body {
            mass = 10 kg
            com = (0.1, 0.05, 0.2) m
            inertia = diag(1, 2, 3) kg*m^2
        }
        frame a1 at (0.5, 0.2, 0.3) m
        frame a2 at (-0.4, -0.1, 0.5) m
        frame top at (0.45, 0.25, 0.8) m
        frame tilted at (0.3, -0.2, 0.6) m rotate cardan(17 deg, 11 deg, -6 deg)
    }
    rigid arm {
        body {
            mass = 2 kg
            com = (0.6, 0.3, 0.1) m
            inertia = diag(0.1, 0.2, 0.3) kg*m^2
        }
        frame pivot at (0.5, 0.2, 0.3) m
        frame tip at (0.8, 0.4, 0.0) m
        frame slant at (0.7, 0.3, 0.1) m rotate cardan(-25 deg, 14 deg, 32 deg)
    }
    rigid link {
        body {
            mass = 1.5 kg
            com = (-0.3, 0.1, 0.3) m
            inertia = diag(0.2, 0.1, 0.15) kg*m^2
        }
        frame pivot at (-0.4, -0.1, 0.5) m
        frame end at (-0.2, 0.3, 0.1) m
    }
    interact floating {
        connect inertial -> car
        joint free
    }
    interact hinge1 {
        connect car.a1 -> arm.pivot
        joint revolute(axis = x)
    }
    interact hinge2 {
        connect car.a2 -> link.pivot
        joint revolute(axis = y)
    }
    interact strut {
        connect car.top -> arm.tip
        force s = spring_damper(k = 2000 N/m, d = 150 N*s/m, l0 = 0.5 m)
    }
    interact tie {
        connect arm.tip -> link.end
        force s = spring_damper(k = 800 N/m, d = 40 N*s/m, l0 = 1.0 m)
    }
    interact leaf {
        connect car.tilted -> link.end
        force s = line(f = 300 * (l + 0.2) + 20 * v, along = z)
    }
    interact bar {
        connect arm.slant -> link.end
        force s = line(f = 500 * (l - 0.1) + 30 * v, along = x)
    }
}
"""

FORCES = ("strut.s", "tie.s", "leaf.s", "bar.s")


def forces_and_tensions(lowered, states):
    """The generalized forces and the three elements' tensions at each state (t = 0, parameter defaults, switches
    as written), evaluated from the tape in Python (treekit.numeric_function, independent of the C printer)."""
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    outputs = list(eqs.forces) + [lowered.lowering._force_values[name] for name in FORCES]
    tree = lowered.tree
    symbols = sorted(eqs.tape.free_symbols(outputs) - set(tree.q_symbols) - set(tree.v_symbols) - {t}, key=str)
    defaults = {sp.Symbol(p.name): p.value for p in lowered.model.parameters}
    values = [float(defaults.get(s, 0.0)) for s in symbols]   # switches and the frozen flag 0: as written
    assert all(s in defaults or s == FROZEN or s in {w.symbol for w in lowered.switches} for s in symbols)
    f = numeric_function(eqs, symbols, outputs)
    return [np.array(f(0.0, list(map(float, x)), values)) for x in states]


def random_states(tree, n=3):
    rng = np.random.default_rng(12)
    states = []
    for _ in range(n):
        q = rng.normal(0.0, 0.4, tree.nq)
        quaternion = rng.normal(0.0, 1.0, 4)
        q[3:7] = quaternion / np.linalg.norm(quaternion)   # the free joint: x y z, then qw qx qy qz
        states.append(np.concatenate([q, rng.normal(0.0, 2.0, tree.nv)]))
    return states


def test_line_forces_in_the_common_body_frame_are_the_world_ones(monkeypatch):
    model = load_text(MODEL)
    relative = lower(model)
    assert relative.kinematics.load_frame("hinge1", "hinge2") == relative.tree.body_index("floating")
    states = random_states(relative.tree)
    ours = forces_and_tensions(relative, states)
    monkeypatch.setattr(Kinematics, "load_frame", lambda self, a, b: -1)
    world = forces_and_tensions(lower(model), states)
    for a, b in zip(ours, world):
        assert np.max(np.abs(b)) > 10.0   # the loads are there
        assert a == pytest.approx(b, rel=1e-11, abs=1e-9 * np.max(np.abs(b)))
