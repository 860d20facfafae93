"""The bad input of issue 10 that concerns modes and events, beyond the golden error files
(tests/language/errors/events.mbs: a vector condition, a jump of a position, a mode nobody declared;
errors/hooks.mbs: hooks).

A mode, like a parameter, is a declaration of its block: the language resolves names regardless of the order
of statements, so a mode used above its `mode` line means the same as below it (checked here), and a mode
that is declared nowhere is the located error.
"""

from __future__ import annotations

import pytest

import mbs
from mbs.language.diagnostics import MbsError

MODEL = """model m {{
    {first}
    gravity = (0, 0, 0) m/s^2
    rigid b {{
        body {{
            mass = 1 kg
            com = (0, 0, 0) m
            inertia = diag(1, 1, 1) kg*m^2
        }}
    }}
    interact slide {{
        connect inertial.origin -> b.origin
        joint prismatic(axis = z)
        force push = joint(s = gear * 1 N)
    }}
    event shift when slide.s > 1 m {{
        set gear = gear + 1
    }}
    {last}
}}
"""


def test_a_mode_used_above_its_declaration_means_the_same_as_below_it():
    above = mbs.loads(MODEL.format(first="", last="mode gear = 1"))
    below = mbs.loads(MODEL.format(first="mode gear = 1", last=""))
    assert above.model == below.model
    res = above.simulate(t_end=3.0)
    assert [e["event"] for e in res.events] == ["shift"]
    assert res.events[0]["time"] == pytest.approx(2 ** 0.5, abs=1e-9)  # s = t^2 / 2 under 1 N on 1 kg


def test_a_mode_declared_nowhere_is_a_located_error():
    with pytest.raises(MbsError) as err:
        mbs.loads(MODEL.format(first="", last=""))
    found = [(d.message, d.span.line) for d in err.value.diagnostics]
    assert any("unknown name 'gear'" in m and line == 14 for m, line in found)  # the force reading it
    assert any("'gear' is not a mode or parameter" in m and line == 17 for m, line in found)  # the event setting it
