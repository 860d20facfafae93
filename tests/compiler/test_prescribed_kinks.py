"""Prescribed motions whose speed jumps (a ramp that stops, written with min): the drive would need an impulse,
which would change the speeds of the parts it carries; a right-hand side cannot apply one, so the compiler
refuses such a motion at its source line and names the remedy, a blended (C1) motion."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.language.diagnostics import MbsError

MODELS = Path(__file__).parent / "models"


def test_a_ramp_that_stops_abruptly_is_refused_where_it_is_written():
    system = mbs.load(MODELS / "rack_ramp.mbs")
    with pytest.raises(MbsError) as err:
        system.compile("ramp")
    text = str(err.value)
    assert "rack_ramp.mbs:19:" in text and "'drive.s' has a kink" in text and "smoothstep" in text


def test_the_blended_ramp_the_message_suggests_runs():
    text = (MODELS / "rack_ramp.mbs").read_text().replace(
        "prescribe s = rate * min(t, t_stop)",
        "prescribe s = rate * t_stop * smoothstep(t, 0 s, t_stop)")
    res = mbs.loads(text).simulate("ramp").check()
    speed = res["drive.speed.y"]
    tau = np.clip(res.t / 0.5, 0, 1)
    np.testing.assert_allclose(speed, 0.004 * 6 * tau * (1 - tau), rtol=0, atol=1e-15)
    assert np.ptp(res["spring.s"]) > 1e-6  # the spring lags behind the accelerated base
