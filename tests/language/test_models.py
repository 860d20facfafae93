"""The validated data model of the shipped models: components, mirroring, units, scenes."""

import math

import pytest

from mbs.language import expr as X
from mbs.language.diagnostics import MbsError
from mbs.language.frontend import check, load, load_text
from tests.conftest import SHIPPED_MODELS


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.name)
def test_every_shipped_model_checks_without_errors(path):
    result = check(path)
    assert not [d for d in result.diagnostics if d.severity == "error"]


def value(e, model):
    env = {p.name: p.value for p in model.parameters}
    return X.evaluate(e, env)


def test_units_are_converted_to_si():
    m = load_text("""
model m {
    param v = 36 km/h
    param a = 90 deg
    param k = 2 kN/mm
    rigid b {
        body {
            mass = 1260 kg
            inertia = diag(1, 2, 2) kg*m^2
        }
        frame f at (100, 0, 0) mm
    }
    interact j {
        connect inertial -> b.f
        joint revolute(axis = y)
    }
    output o = v * a * k
}
""")
    params = m.parameter_map
    assert params["v"].value == pytest.approx(10.0)
    assert params["a"].value == pytest.approx(math.pi / 2)
    assert params["k"].value == pytest.approx(2e6)
    frame = m.part_map["b"].frame_map["f"]
    assert [value(c, m) for c in frame.position] == pytest.approx([0.1, 0, 0])


def test_quarter_car_instantiates_the_iltis_corner_with_prefixed_names():
    m = load("library/iltis/quarter_car.mbs")
    assert {"fl.leaf", "fl.arm", "fl.carrier", "fl.rod", "fl.wheel", "fl.slider"} <= set(m.part_map)
    assert "fl.m_wheel" in m.parameter_map
    coords = {c.name for c in m.coordinates}
    assert {"lift.s", "fl.arm_bearing.phi", "fl.hub.phi"} <= coords
    hub = m.interaction_map["fl.hub"].joint.coordinates[0]
    assert hub.prescribed is not None
    # port frames of the instance live on the chassis part
    assert "fl.chassis.leaf_pivot" in m.part_map["body"].frame_map


MIRROR_TEXT = """
component corner {
    port mount {
        frame pivot at (0.97, 0.26, 0.30) m
    }
    rigid arm {
        body {
            mass = 6 kg
            com = (0.97, 0.4, 0.27) m
            inertia = [[0.05, 0.01, 0], [0.01, 0.04, 0.003], [0, 0.003, 0.07]] kg*m^2
        }
        frame pivot at (0.97, 0.26, 0.30) m rotate axis_angle(z, 10 deg)
    }
    interact bearing {
        connect mount.pivot -> arm.pivot
        joint revolute(axis = x) {
            init phi = 5 deg
        }
    }
}
model car {
    use corner as left { mount = inertial }
    use corner as right(mirror = xz) { mount = inertial }
}
"""


def test_mirrored_instance_reflects_geometry_and_keeps_rotations_proper():
    import numpy as np
    m = load_text(MIRROR_TEXT)

    def num(v):
        return np.array([[value(c, m) for c in row] for row in v]) if isinstance(v[0], tuple) else \
            np.array([value(c, m) for c in v])
    left, right = m.part_map["left.arm"], m.part_map["right.arm"]
    S = np.diag([1.0, -1.0, 1.0])
    assert num(right.body.com) == pytest.approx(S @ num(left.body.com))
    assert num(right.body.inertia) == pytest.approx(S @ num(left.body.inertia) @ S)
    R_left, R_right = num(left.frame_map["pivot"].rotation), num(right.frame_map["pivot"].rotation)
    assert np.linalg.det(R_right) == pytest.approx(1.0)
    assert R_right == pytest.approx(S @ R_left @ S)
    # rotation axes mirror as axial vectors: the same joint angle gives the mirror-image motion
    ax_left = num(m.interaction_map["left.bearing"].joint.axes[0])
    ax_right = num(m.interaction_map["right.bearing"].joint.axes[0])
    assert ax_right == pytest.approx(-S @ ax_left)


def test_scene_outputs_and_settings():
    m = load("library/examples/pendulum.mbs")
    scene = m.scene("swing")
    assert scene.t_end == 10.0 and scene.sample == 0.01
    assert [o.name for o in scene.outputs] == ["hinge.phi", "rate"] + [
        f"hinge.pivot_force.{c}" for c in ("fx", "fy", "fz", "mx", "my", "mz")]  # a vector sensor, expanded
    assert scene.outputs[1].value == X.Sym("speed", "hinge.phi")


def test_expressions_are_data_not_code():
    """A model cannot reach Python: names resolve only to model entities, calls only to the fixed table."""
    with pytest.raises(MbsError) as err:
        load_text('model m {\n    param a = __import__("os")\n}\n')
    assert "unknown function '__import__'" in str(err.value)


def test_bare_numbers_take_the_dimension_of_their_context():
    m = load_text("""
model m {
    param l0 = 0.3 m
    param short = l0 - 0.1
    rigid b {
        body {
            mass = 2
            inertia = diag(1, 1, 1)
        }
    }
    interact j {
        connect inertial -> b
        joint prismatic(axis = z)
        force f = line(f = 35906 * (l - short))
    }
}
""")
    from mbs.language import units as U
    assert m.parameter_map["short"].dimension == U.LENGTH


TYRE_ON_A_GUIDE = """
import tyres.point_contact as tyres
import roads.profiles as roads

func my_road(x) = roads.cosine_bump(x, 0.1 m, 1 m, 0 m)

model wheel_on_guide {
    rigid wheel {
        body {
            mass = 50 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact guide {
        connect inertial -> wheel
        joint planar(normal = y, direction = x)
    }
    use tyres.point_contact as tyre(road = my_road) { wheel = wheel }
}
"""


def test_a_component_function_can_be_replaced_by_the_users_own():
    m = load_text(TYRE_ON_A_GUIDE, directory="library")
    force = m.interaction_map["tyre.radial"].forces[0]
    text = X.to_text(force.arg("force")[2])
    assert "cos(" in text  # the bump, not the component's flat default road


def test_a_replacement_function_must_take_the_same_arguments():
    bad = TYRE_ON_A_GUIDE.replace("func my_road(x) = roads.cosine_bump(x, 0.1 m, 1 m, 0 m)",
                                  "func my_road(x, y) = x + y")
    with pytest.raises(MbsError) as err:
        load_text(bad, directory="library")
    assert "function 'road' takes 1 argument(s); 'my_road' takes 2" in str(err.value)


def test_the_vehicle_is_four_instances_of_one_suspension_component():
    from mbs.language.parser import parse_text
    text = open("library/iltis/vehicle.mbs").read()
    uses = [s for item in parse_text(text).items if getattr(item, "kind", "") == "model"
            for s in item.statements if type(s).__name__ == "Use" and s.component.dotted == "susp.corner"]
    assert [u.alias.text for u in uses] == ["fl", "fr", "rl", "rr"]
    m = load("library/iltis/vehicle.mbs")
    for corner in ("fl", "fr", "rl", "rr"):
        assert {f"{corner}.leaf", f"{corner}.arm", f"{corner}.carrier", f"{corner}.rod", f"{corner}.wheel"} <= set(m.part_map)
    # the right front rack follows the negated steering input (mirrored instance)
    rack = m.interaction_map["fr.rack"].joint.coordinates[0]
    assert X.to_text(rack.prescribed) == "(-steer)"
