"""Which switches are continuous (compiler/events.py: nothing jumps where they flip, so the runtime computes the
rows at both sides of their events once): kinks by construction, an ``if`` when its branches agree on the
comparison's surface, checked against hand-computed branch values; and at run time the rows at a continuous
event are twins while those at a jump still differ."""

from __future__ import annotations

import numpy as np
import pytest

import mbs

MODEL = '''
model stop {{
    func law(s) = {law}
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
        force f = joint(s = law(slide.s) * 1 N - 100 * slide.s * 1 N/m)
    }}
    output push = law(slide.s)
}}
'''


def continuity(law: str) -> list[bool]:
    return [e.continuous for e in mbs.loads(MODEL.format(law=law)).compile().events]


@pytest.mark.parametrize("law, expected", [
    # at s = 0.1 m both branches are 0 (20 * (0.1 - 0.1)): a kink
    ("if(s > 0.1 m, 20 * (s / 1 m - 0.1), 0)", [True]),
    # 20 on one side, 0 on the other: a step of 20
    ("if(s > 0.1 m, 20, 0)", [False]),
    # the Iltis damper's pieces (library/iltis/forces.mbs): at V = -0.2 the line gives -785.28 and the polynomial
    # -785.2802 (2.5e-7 of it, the printed digits); at 0.21 the line 2262.45647, the polynomial 2262.4576 (5e-7)
    ("if(s < -0.2 m, -416.42 + 1844.3 * s / 1 m, if(s > 0.21 m, 1919.1638 + 1634.727 * s / 1 m, 9945.627 * s / 1 m "
     "+ 33955.72 * (s / 1 m)^2 - 59832.25 * (s / 1 m)^3 - 395651.0 * (s / 1 m)^4))", [True, True]),
    # the same pieces with the line shifted by 1: a jump of 1 in 785 at -0.2
    ("if(s < -0.2 m, -415.42 + 1844.3 * s / 1 m, 0)", [False]),
    ("max(0, 3 * s / 1 m)", [True]),
    ("abs(s / 1 m - 0.2)", [True]),
    ("sign(s / 1 m - 0.2)", [False, False]),  # two comparisons, > and <
    # crossing s = 0 changes s / 1 m (0 there) against 0: continuous; crossing s = 0.3 changes 7 against 0: a jump
    ("if(s > 0 m and s < 0.3 m, 7 * s / 1 m, 0)", [True, False]),
    # one comparison read continuously (max) and as a step (if): the switch jumps
    ("max(s / 1 m, 0) + if(s >= 0 m, 1, 0)", [False]),
])
def test_continuity_of_switches_against_hand_computed_branches(law, expected):
    assert continuity(law) == expected


def rows_at_events(law: str, integrator: str = "dopri5"):
    res = mbs.loads(MODEL.format(law=law)).simulate(t_end=1.0, sample=0.01, integrator=integrator)
    assert res.success, res.message
    times = np.array([e["time"] for e in res.events])
    assert len(times) >= 2
    at = [np.flatnonzero(res.t == t) for t in times]
    assert all(len(rows) == 2 for rows in at)  # a row just before and just after each event
    return res, at


@pytest.mark.parametrize("integrator", ["dopri5", "RK45"])  # restarts in C, and the Python loop's
def test_the_rows_at_a_continuous_event_are_twins(integrator):
    res, at = rows_at_events("if(s > 0.1 m, 20 * (s / 1 m - 0.1), 0)", integrator)
    for before, after in at:
        assert np.array_equal(res.data[before], res.data[after])
        # the one computed value is the law at the event: 0 on the kink, to the location's round-off
        assert abs(res["push"][before]) < 1e-9


@pytest.mark.parametrize("integrator", ["dopri5", "RK45"])
def test_the_rows_at_a_jump_still_differ(integrator):
    res, at = rows_at_events("if(s > 0.1 m, 20, 0)", integrator)
    for before, after in at:
        assert np.array_equal(res.data[before, 1:3], res.data[after, 1:3])  # the state does not jump
        assert {res["push"][before], res["push"][after]} == {0.0, 20.0}  # the law does
