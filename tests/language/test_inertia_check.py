"""A coordinate that no mass or inertia moves is a located error at `mbs check` (issue 17), not a
ZeroDivisionError in the derivation; prescribed motion or a closed loop holds a massless part."""

import pytest

import mbs
from mbs.cli import main

CHAIN = """
model chain {
    gravity = (0, 0, -9.81) m/s^2
    rigid a {
        body {
            mass = 1 kg
            com = (0, 0, -1) m
            inertia = diag(1, 1, 1) kg*m^2
        }
        frame tip at (0, 0, -1) m
    }
    part b {
        frame o at (0, 0, 0) m
        frame end at (0, 0, -1) m
    }
    interact j1 {
        connect inertial -> a
        joint revolute(axis = y)
    }
    interact j2 {
        connect a.tip -> b.o
        joint JOINT
    }
    EXTRA
}
"""


def model(joint="revolute(axis = y)", extra=""):
    return CHAIN.replace("JOINT", joint).replace("EXTRA", extra)


@pytest.mark.parametrize("joint, coordinates", [
    ("revolute(axis = y)", "j2.phi"),
    ("free(rotation = cardan)", "j2.x, j2.y, j2.z, j2.alpha, j2.beta, j2.gamma"),
    ("cylindrical(axis = z)", "j2.s, j2.phi"),
])
def test_a_massless_part_at_the_end_of_a_chain_is_a_located_error(joint, coordinates):
    with pytest.raises(mbs.MbsError) as info:
        mbs.loads(model(joint), path="chain.mbs")
    [d] = [d for d in info.value.diagnostics if d.severity == "error"]
    assert f"no mass or inertia determines the motion of {coordinates}" in d.message
    assert "massless part 'b'" in d.message
    assert d.span is not None and d.span.line == 22


def test_a_massless_part_a_force_acts_on_is_still_undetermined():
    spring = 'interact s {\n connect inertial -> b.end\n force k = spring(k = 100 N/m)\n }'
    with pytest.raises(mbs.MbsError, match="no mass or inertia determines the motion of j2.phi"):
        mbs.loads(model(extra=spring))


def test_a_prescribed_massless_coordinate_is_fine():
    mbs.loads(model(joint="revolute(axis = y) {\n prescribe phi = 1 rad/s * t\n }"))


def test_a_massless_part_held_by_a_loop_is_fine():
    loop = 'interact back {\n connect inertial -> b.end\n joint spherical(rotation = cardan)\n }'
    mbs.loads(model(extra=loop))


def test_a_point_mass_turning_about_itself_is_a_located_error_not_an_internal_one(tmp_path, capsys):
    """Beyond what `mbs check` sees structurally: the derivation finds the zero pivot and names the joint."""
    src = tmp_path / "point.mbs"
    src.write_text("""
model point {
    rigid a {
        body {
            mass = 1 kg
            inertia = diag(0, 0, 0) kg*m^2
        }
    }
    interact j {
        connect inertial -> a
        joint spherical(rotation = cardan)
    }
}
""")
    assert main(["check", str(src)]) == 0
    assert main(["simulate", str(src), "--t-end", "0.1"]) == 1
    err = capsys.readouterr().err
    assert "point.mbs:11:9: error: no mass or inertia determines the motion of j.alpha, j.beta, j.gamma" in err


def test_a_free_joint_neither_holds_nor_carries_a_massless_part():
    """Found by the fuzz harness: a free joint to a massive part closes no loop and transmits no load."""
    free = 'interact back {\n connect b.end -> inertial\n joint free(rotation = cardan)\n }'
    with pytest.raises(mbs.MbsError, match="no mass or inertia determines the motion of j2.phi"):
        mbs.loads(model(extra=free))


def test_a_loop_closed_by_a_free_joint_runs_as_a_tree(tmp_path):
    """Found by the fuzz harness: the 'loop' has no constraint rows, so the tree's own dynamics run (the code
    generator had neither constraints nor accelerations and failed)."""
    text = model(extra="interact back {\n connect inertial -> b.end\n joint free(rotation = cardan, cut = true)\n }")
    text = text.replace("    part b {", "    rigid b {\n body {\n mass = 1 kg\n inertia = diag(1, 1, 1) kg*m^2\n }")
    res = mbs.loads(text, backend="numpy").simulate(t_end=0.05)
    assert res.success
