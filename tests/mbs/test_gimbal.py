"""A spherical joint in Cardan angles warns at run time near its gimbal singularity (beta = +-90 deg)."""

import math
from pathlib import Path

import pytest

import mbs
from mbs.cli import main
from mbs.gimbal import GIMBAL_MARGIN, GimbalWarning

TUMBLER = Path(__file__).parent / "models" / "cardan_tumbler.mbs"


@pytest.fixture(scope="module")
def tumbler():
    return mbs.load(TUMBLER)


def test_the_run_through_the_singularity_warns_with_joint_and_first_time(tumbler):
    with pytest.warns(GimbalWarning) as caught:
        res = tumbler.simulate("through")
    # beta = 70 deg + 1 rad/s * t reaches 90 deg - margin at t = 10 deg / (1 rad/s)
    first = math.radians(20) - GIMBAL_MARGIN
    text = str(caught[0].message)
    assert "joint 'ball'" in text and "rotation = quaternion" in text
    t_reported = float(text.split("first at t = ")[1].split(" s")[0])
    assert first <= t_reported <= first + 0.01  # the first sample past it (sampled every 10 ms)
    assert res.metadata["warnings"] == [text]


def test_a_run_away_from_the_singularity_is_silent(tumbler, recwarn):
    res = tumbler.simulate("away")
    assert not [w for w in recwarn if issubclass(w.category, GimbalWarning)]
    assert not res.metadata.get("warnings")


def test_the_command_prints_the_warning_once(capsys, tmp_path):
    status = main(["simulate", str(TUMBLER.relative_to(Path.cwd())), "--scene", "through"])
    err = capsys.readouterr().err
    assert status == 0
    assert err.count("gimbal singularity") == 1 and err.startswith("tumbler: warning: joint 'ball'")
