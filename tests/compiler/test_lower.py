"""Lowering a validated model to the tree: joint placements, mass data, force elements, sensors, outputs.

Checked against hand calculations of the generalized forces (virtual work) on small models; the tree
dynamics itself is checked against Pinocchio and sympy.physics.mechanics in test_tree_dynamics.py.
"""

import math

import numpy as np
import pytest
import sympy as sp

from mbs.compiler.equations import derive_equations, display_equations
from mbs.compiler.events import FROZEN
from mbs.compiler.lower import lower
from mbs.compiler.topology import build_topology
from mbs.compiler.tree import t
from mbs.language.frontend import load, load_text


def numeric(lowered, exprs, x, t_value=0.0, overrides=None):
    """Evaluate tape expressions by full substitution (small models only), with parameter defaults; switches
    (compiler/events.py) with the frozen flag 0, so every comparison is evaluated as written."""
    tree = lowered.tree
    values = {sp.Symbol(p.name): p.value for p in lowered.model.parameters}
    values.update({s.symbol: 0 for s in lowered.switches} | {FROZEN: 0})
    values.update(overrides or {})
    values.update(dict(zip(tree.q_symbols + tree.v_symbols, x)))
    values[t] = t_value
    full = lowered.kinematics.tape.expand(list(exprs))
    return np.array([float(sp.sympify(e).subs(values).evalf()) for e in full])


def test_pendulum_equation_is_the_textbook_one():
    lowered = lower(load("library/examples/pendulum.mbs"))
    M, k, q = display_equations(lowered.kinematics)
    m, l, phi = sp.symbols("m l hinge.phi")
    assert sp.simplify(M[0, 0] - (m * l**2 + sp.Float("1e-6"))) == 0
    assert k[0, 0] == 0
    assert sp.simplify(q[0, 0] + sp.Float("9.81") * m * l * sp.sin(phi)) == 0


def test_two_mass_quarter_car_generalized_forces_by_virtual_work():
    model = load("library/examples/two_mass_quarter_car.mbs")
    lowered = lower(model, model.scene("bump"))
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    s1, s2, v1, v2 = 0.7, -0.5, 0.1, -0.2
    x = [s1, s2, v1, v2]
    M = numeric(lowered, [e for row in eqs.mass_matrix for e in row], x).reshape(2, 2)
    f = numeric(lowered, eqs.forces, x)
    m1, m2, g = 378.0, 63.0, 9.81
    assert M == pytest.approx(np.array([[m1 + m2, m2], [m2, m2]]), rel=1e-12)
    length, rate = -(s2 + 0.1), -v2                       # spring top 0.1 m below the chassis origin
    tension = 35906 * (length - 0.5) + 2500 * rate       # positive pulls the wheel up to the chassis
    tyre = max(0.0, 460000 * (0.364 - (s1 + s2)))         # flat road at t = 0
    assert f == pytest.approx([-(m1 + m2) * g + tyre, -m2 * g + tension + tyre], rel=1e-12)
    outputs = dict(lowered.outputs)
    body_z, travel, load_ = numeric(lowered, [outputs["body_z"], outputs["suspension.travel"], outputs["wheel_load"]], x)
    assert (body_z, travel, load_) == pytest.approx((s1, length, tyre))


def test_line_force_along_a_fixed_axis_uses_the_projection():
    model = load_text("""
model m {
    gravity = (0, 0, 0) m/s^2
    part top {
        frame anchor at (0, 0, 1) m
    }
    rigid mass {
        body {
            mass = 2 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact fix {
        connect inertial -> top
        joint fixed
    }
    interact slide {
        connect inertial -> mass
        joint planar(normal = y, direction = x)
    }
    interact spring {
        connect top.anchor -> mass
        force f = line(f = 100 * (l + 0.5), along = z)
    }
}
""")
    lowered = lower(model)
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    x = [0.3, 0.2, 0.0, 0, 0, 0]   # planar: x along global x, y along normal x direction = y x x = -z
    f = numeric(lowered, eqs.forces, x)
    projection = (-0.2 - 1.0)      # z of the mass minus z of the anchor, along the anchor's z axis
    tension = 100 * (projection + 0.5)
    # the force on the mass is -tension along z: no x component although the mass is 0.3 m off the axis;
    # the planar y coordinate moves along -z, so its generalized force is +tension
    assert f[:2] == pytest.approx([0.0, tension])


def test_prescribed_motion_enters_with_its_time_derivatives():
    model = load_text("""
model m {
    param w = 3 rad/s
    gravity = (0, 0, 0) m/s^2
    rigid disc {
        body {
            mass = 1 kg
            inertia = diag(1, 2, 3) kg*m^2
        }
    }
    rigid arm {
        body {
            mass = 1 kg
            com = (1, 0, 0) m
            inertia = diag(0, 0, 0) kg*m^2
        }
    }
    interact spin {
        connect inertial -> disc
        joint revolute(axis = z) {
            prescribe phi = w * t
        }
    }
    interact pin {
        connect disc -> arm
        joint revolute(axis = z)
    }
}
""")
    lowered = lower(model)
    tree = lowered.tree
    assert [str(s) for s in tree.q_symbols] == ["pin.phi"]
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    # arm rotating with the disc at rate w: relative equilibrium, no generalized force needed
    f = numeric(lowered, eqs.forces, [0.4, 0.0], t_value=0.7)
    assert f == pytest.approx([0.0], abs=1e-12)


def test_loop_closing_joints_are_lowered_as_cut_joints():
    lowered = lower(load("library/examples/slider_crank.mbs"))
    assert [c.name for c in lowered.cuts] == ["wrist_pin"]
    assert [str(s) for s in lowered.tree.q_symbols] == ["main_bearing.phi", "guide.s", "crank_pin.phi"]


def test_topology_orients_joints_from_the_ground():
    topo = build_topology(load("library/iltis/quarter_car.mbs"))
    assert topo.bodies[0] == "body"
    assert {c.name for c in topo.cuts} == {"fl.upper_ball", "fl.rod_outer"}
    assert all(topo.parent_index[i] < i for i in range(len(topo.bodies)))


def test_a_joint_written_child_to_parent_is_flipped():
    text = """
model m {
    rigid b {
        body {
            mass = 1 kg
            com = (1, 0, -1) m
            inertia = diag(1e-6, 1e-6, 1e-6) kg*m^2
        }
    }
    interact hinge {
        connect b -> inertial
        joint revolute(axis = y)
    }
}
"""
    lowered = lower(load_text(text))
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    phi = 0.3
    f = numeric(lowered, eqs.forces, [phi, 0.0])
    # the ground rotates by phi about y relative to b, so b rotates by -phi about y: its centre of mass
    # (1, 0, -1) is at height sin(phi) - cos(phi), and Q = -dV/dphi = -m g (cos(phi) + sin(phi))
    assert f == pytest.approx([-9.81 * (math.cos(phi) + math.sin(phi))])
