"""Extra differential states in the language: declaration, units, components, scenes, formatting."""

from __future__ import annotations

import numpy as np
import pytest

import mbs
from mbs.language import expr as X
from mbs.language import units as U
from mbs.language.diagnostics import MbsError
from mbs.language.diagnostics import Source
from mbs.language.formatter import format_source
from mbs.language.parser import parse_source

COMPONENT = """
component lag "a first-order lag of its command" {
    param T = 0.1 s
    input command = 0 m
    state y = offset + 1 mm "lagging position"
    param offset = 1 mm
    der(y) = (command - y) / T
    output out = y
}

model two {
    gravity = (0, 0, 0) m/s^2
    rigid b {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact rail {
        connect inertial.origin -> b.origin
        joint prismatic(axis = x)
        force drive = joint(s = 100 N/m * (fast.y + slow.y - rail.s) - 20 N*s/m * der(rail.s))
    }
    use lag as fast(T = 0.05 s, command = 1 m)
    use lag as slow(command = 2 m)
}

scene start {
    t_end = 0.2 s
    sample = 0.01 s
    init slow.y = 0.5 m
}
"""


def test_states_of_component_instances_are_prefixed_and_keep_their_units():
    system = mbs.loads(COMPONENT, "two")
    states = {s.name: s for s in system.model.states}
    assert set(states) == {"fast.y", "slow.y"}
    assert states["fast.y"].dimension == U.LENGTH
    assert X.evaluate(states["fast.y"].init, {"fast.offset": 1e-3}) == pytest.approx(2e-3)
    assert X.Sym("param", "fast.T") in X.symbols(states["fast.y"].rate)


def test_each_instance_integrates_its_own_state_from_the_scene_initial_value():
    res = mbs.loads(COMPONENT, "two").simulate("start", rtol=1e-10, atol=1e-12)
    t = res.t
    assert np.allclose(res["fast.y"], 1 - (1 - 2e-3) * np.exp(-t / 0.05), atol=1e-8)
    assert np.allclose(res["slow.y"], 2 - 1.5 * np.exp(-t / 0.1), atol=1e-8)
    assert res.unit("slow.y") == "m"


def format_text(text: str) -> str:
    source = Source("<test>", text)
    return format_source(parse_source(source), source)


def test_formatting_keeps_state_declarations_and_equations():
    text = format_text(COMPONENT)
    assert 'state y = offset + 1 mm "lagging position"' in text
    assert "der(y) = (command - y) / T" in text
    assert format_text(text) == text


def test_a_state_in_geometry_is_an_error():
    bad = COMPONENT.replace("inertia = diag(1, 1, 1) kg*m^2", "inertia = diag(1, 1, 1) kg*m^2 * (1 + fast.y / 1 m)")
    with pytest.raises(MbsError):
        mbs.loads(bad, "two")
