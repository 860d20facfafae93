"""A scene's compiled model built with extra compiler flags -- the former behaviour of run-time C that a flag brings
back (c/ode.c -DMBS_ODE_EVENTS_FORMER=1, c/dopri5.c -DMBS_ODE_STEPS_FORMER=1) -- and a run of the scene with it:
the same-run baseline of the tests that compare the two."""

from __future__ import annotations

import dataclasses

from mbs.runtime import build
from mbs.runtime.backends import CBackend


def flagged_build(system, scene: str, flags: tuple[str, ...]):
    """The scene's compiled model with its C built with `flags` (cached by content like any build)."""
    compiled = system.compile(scene)
    result = build.build(system.generate(scene).c_source, extra_flags=flags)
    return dataclasses.replace(compiled, backend=CBackend(build.load(result)))


def install_flagged_build(system, scene: str, flags: tuple[str, ...]):
    """The scene's compiled model replaced by flagged_build(system, scene, flags) for the rest of the process: the
    model a bench's child process runs (built in one piece, also with no flags)."""
    compiled, model = system.compile(scene), flagged_build(system, scene, flags)
    for key in [key for key, value in system._compiled.items() if value is compiled]:
        system._compiled[key] = model


def simulate_with(system, scene: str, model, **kwargs):
    """system.simulate(scene, **kwargs) with the scene's compiled model replaced by `model` for the call."""
    compiled = system.compile(scene)
    keys = [key for key, value in system._compiled.items() if value is compiled]
    for key in keys:
        system._compiled[key] = model
    try:
        return system.simulate(scene, **kwargs)
    finally:
        for key in keys:
            system._compiled[key] = compiled
