"""Prescribed motions whose speed jumps (a ramp that stops, written with min): the drive would need an impulse,
which would change the speeds of the parts it carries; a right-hand side cannot apply one, so the compiler
refuses such a motion at its source line and names the remedy, a blended (C1) motion."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.language.diagnostics import MbsError
from mbs.runtime.event_loop import c_restart_tables

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


RAMP_START = '''
model ramp_start "a mass on a spring whose base starts moving at t0" {
    param rate = 0.004 m/s
    param t0 = 0.2 s
    gravity = (0, 0, 0) m/s^2
    part rack
    rigid mass {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact drive {
        connect inertial -> rack
        joint prismatic(axis = y) {
            prescribe s = if(t < t0, 0 m, rate * (t - t0))
        }
    }
    interact spring {
        connect rack -> mass
        joint prismatic(axis = y)
        force k = spring(k = 100 N/m, along = y)
    }
}
'''


def test_a_ramp_that_starts_with_an_if_on_time_is_a_switch_of_the_prescribed_motion():
    """An if on time is allowed (its speed steps: the comment in library/iltis/vehicle.mbs says why the Iltis
    rack may), but not stepped across: a switch the run locates, not continuous (the speed steps), marked as a
    prescribed motion's. On a tree C restarts at it (nothing is inconsistent: the coordinate is no state); on a
    model with loops Python projects the loops' speeds there (tests/library/test_iltis_suspension_travel.py)."""
    compiled = mbs.loads(RAMP_START).compile()
    (event,) = compiled.events
    assert event.prescribed and not event.continuous and "prescribed motion of drive.s" in event.name
    assert c_restart_tables(compiled)[0].tolist() == [1]
    res = mbs.loads(RAMP_START).simulate(t_end=0.5, sample=0.05)
    assert [e["time"] for e in res.events] == [pytest.approx(0.2, abs=1e-12)]


def test_only_a_motion_that_may_kink_has_its_second_derivative_taken():
    """lower.may_kink lets the compiler skip sympy's second derivative of a smooth motion: it must never call a
    motion smooth whose second derivative holds a DiracDelta (the refusal above depends on it)."""
    import sympy as sp

    from mbs.compiler.lower import may_kink
    t, a = sp.symbols("t a")
    smooth = [sp.Piecewise((0, t < 0), (a * t, t < 1), (a, True)), sp.sin(2 * sp.pi * t) * sp.exp(-t) + t ** 3 / 2,
              sp.sqrt(1 + t ** 2) * sp.atan2(t, a), sp.Float(0.5) * sp.log(1 + t ** 2) + sp.tanh(t)]
    kinked = [a * sp.Min(t, a), sp.Max(0, t), sp.Abs(t - 1), sp.Heaviside(t), sp.sign(t), sp.Function("f")(t)]
    for e in smooth:
        assert not may_kink(e) and not sp.diff(e, t, 2).has(sp.DiracDelta)
    for e in kinked:
        assert may_kink(e)
    assert sp.diff(kinked[0], t, 2).has(sp.DiracDelta)  # the case the check is for
