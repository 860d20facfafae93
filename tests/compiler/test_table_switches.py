"""Breakpoints of a linear lookup table become switches (compiler/events.py, SwitchRegistry.table): a mass on a
spring whose table gives stiffness 100 N/m in extension and 400 N/m in compression.  Checked against the closed
form (half a period of each side: pi/10 s and pi/20 s, starting from rest at 0.5 m), and the same model with
``switches = false`` stays as written (one table call, no events)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbs

MODEL = '''
model two_rate_spring {{
    {setting}
    func spring(s) = lookup(s, [[-1, 400], [0, 0], [1, -100]], "linear")
    rigid mass {{
        body {{
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }}
    }}
    interact slide {{
        connect inertial -> mass
        joint prismatic(axis = x) {{
            init s = 0.5 m
        }}
        force f = joint(s = spring(slide.s) * 1 N)
    }}
}}
'''


def crossing_times(n: int) -> np.ndarray:
    """Zero crossings: a quarter period of the soft side, then alternately half a stiff and half a soft one."""
    halves = [math.pi / 20 if k % 2 == 0 else math.pi / 10 for k in range(n - 1)]
    return math.pi / 20 + np.concatenate([[0.0], np.cumsum(halves)])


def test_a_table_breakpoint_is_an_event_at_the_closed_form_times():
    res = mbs.loads(MODEL.format(setting="switches = true")).simulate(t_end=2.0, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    times = np.array([e["time"] for e in res.events])
    assert all("table in slide.f" in e["event"] for e in res.events)
    expected = crossing_times(20)
    expected = expected[expected < 2.0]
    assert len(times) == len(expected) == 8
    assert np.max(np.abs(times - expected)) < 1e-9
    # amplitudes: 0.5 m on the soft side, 0.25 m on the stiff one (energy: 100 * 0.5^2 = 400 * 0.25^2)
    assert np.max(res["slide.s"]) == pytest.approx(0.5, abs=1e-9)
    assert np.min(res["slide.s"]) == pytest.approx(-0.25, abs=1e-4)  # the samples' 5 ms grid misses the peak


def test_without_switches_the_table_is_evaluated_as_written():
    system = mbs.loads(MODEL.format(setting="switches = false"))
    res = system.simulate(t_end=2.0, rtol=1e-10, atol=1e-12)
    assert res.success and res.events == []
    assert "mbs_table_0(" in system.generate().c_source
