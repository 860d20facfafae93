"""Corrections found by writing reference problems in the language (issue 18): quaternion speeds named as the
joint defines them, starting quaternions that are not unit, inertia about a frame, masses and inertias checked
whenever parameters are bound, point masses, one default tolerance.

The error texts are golden files in errors/ (test_golden_errors.py); the texts of runs that succeed with a
note, or fail at run time, are golden files in notes/ (NAME.expected: what `mbs check` or the command prints).
"""

import inspect
import os
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs import pipeline
from mbs.cli import main
from mbs.language.catalog import DEFAULT_ATOL, DEFAULT_RTOL, SCENE_DEFAULTS
from mbs.language.diagnostics import MbsError
from mbs.runtime.integrators.base import OdeSolver
from mbs.runtime.simulate import simulate

NOTES = Path(__file__).parent / "notes"

FREE = """
model m {
    gravity = (0, 0, 0) m/s^2
    param s = 1
    rigid b {
        body {
            mass = 2 kg
            inertia = diag(1, 2, 3) kg*m^2
        }
    }
    interact float {
        connect inertial -> b
        joint free {
            init qw = s
        }
    }
}
scene spin {
    init float.wx = 0.5 rad/s
    init float.wz = -2 rad/s
    init der(float.y) = 3 m/s
}
"""


def golden(name: str, text: str) -> None:
    expected = NOTES / f"{name}.expected"
    if os.environ.get("MBS_REGOLD"):
        expected.write_text(text)
    assert text == expected.read_text()


@pytest.mark.parametrize("name", ["quaternion_rounded", "point_mass"])
def test_check_passes_with_exactly_the_golden_notes(name, capsys):
    assert main(["check", str((NOTES / f"{name}.mbs").relative_to(Path.cwd()))]) == 0
    golden(name, capsys.readouterr().err)


def test_a_param_override_that_makes_a_mass_negative_is_located_at_body_and_parameter(capsys, tmp_path):
    path = str((NOTES / "bound_by_param.mbs").relative_to(Path.cwd()))
    status = main(["simulate", path, "--param", "m=-1kg", "--out", str(tmp_path / "r.csv")])
    assert status == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    golden("bound_by_param", err)


def test_python_params_are_checked_like_param_overrides():
    system = mbs.load(NOTES / "bound_by_param.mbs")
    with pytest.raises(MbsError, match="the mass of 'bob' must not be negative, but it is -1 kg"):
        system.simulate(params={"m": -1.0})
    with pytest.raises(MbsError, match="parameter 'm' is -1 kg here"):
        system.linearize(params={"m": -1.0})
    # a mass taken to its massless limit is a parameter study, not an error (the mass matrix may stay regular)
    from mbs.language.binding import bound_body_problems, parameter_values
    assert bound_body_problems(system.model, parameter_values(system.model, {"m": 0.0}), {"m": None}) == []


def test_scene_sets_quaternion_speeds_by_their_names_wx_wy_wz():
    system = mbs.loads(FREE, backend="numpy")
    gen = system.generate("spin")
    x0 = dict(zip(gen.q_names + gen.v_names, pipeline.initial_state(gen, pipeline.parameter_values(system.model))))
    assert (x0["float.wx"], x0["float.wy"], x0["float.wz"], x0["der(float.y)"]) == (0.5, 0.0, -2.0, 3.0)
    assert x0["float.qw"] == 1.0


def test_a_starting_quaternion_far_from_unit_through_a_parameter_fails_at_run_time():
    system = mbs.loads(FREE, backend="numpy")
    gen = system.generate("spin")
    with pytest.raises(MbsError, match="starting quaternion of joint 'float' has norm 3, far from 1"):
        pipeline.initial_state(gen, pipeline.parameter_values(system.model, {"s": 3.0}))
    near = pipeline.initial_state(gen, pipeline.parameter_values(system.model, {"s": 1.01}))
    assert np.linalg.norm(near[:7][3:]) == pytest.approx(1.0)  # normalised (the note was given at check time)


def test_inertia_in_and_about_a_frame_is_rotated_then_shifted():
    """Components in the axes of a rotated frame, about its origin: I_C = R I R^T - m (|d|^2 E - d d^T)."""
    text = """
    model m {
        rigid link {
            body {
                mass = 0.3 kg
                com = (0.1, 0.2, -0.3) m
                inertia = [[0.5, 0.01, 0.02], [0.01, 0.6, 0.03], [0.02, 0.03, 0.7]] kg*m^2 in bearing about bearing
            }
            frame bearing at (0.4, -0.1, 0.2) m rotate axis_angle(z, 30 deg)
        }
        interact j {
            connect inertial -> link.bearing
            joint revolute(axis = z)
        }
    }"""
    from mbs.language import expr as X
    body = next(p.body for p in mbs.loads(text).model.parts if p.name == "link")
    got = np.array([[X.evaluate(c, {}) for c in row] for row in body.inertia])
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    written = np.array([[0.5, 0.01, 0.02], [0.01, 0.6, 0.03], [0.02, 0.03, 0.7]])
    d = np.array([0.4, -0.1, 0.2]) - np.array([0.1, 0.2, -0.3])
    expected = R @ written @ R.T - 0.3 * (d @ d * np.eye(3) - np.outer(d, d))
    assert np.allclose(got, expected, rtol=0, atol=1e-14)


def test_one_default_tolerance_for_scenes_the_python_api_and_the_runtime():
    assert (SCENE_DEFAULTS["rtol"], SCENE_DEFAULTS["atol"]) == (DEFAULT_RTOL, DEFAULT_ATOL)
    for function in (simulate, OdeSolver.__init__):
        parameters = inspect.signature(function).parameters
        assert (parameters["rtol"].default, parameters["atol"].default) == (DEFAULT_RTOL, DEFAULT_ATOL)
    from mbs.system import _settings
    settings = _settings(None, None, None, None, None, None)
    assert (settings["rtol"], settings["atol"]) == (DEFAULT_RTOL, DEFAULT_ATOL)
