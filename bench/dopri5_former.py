"""The Iltis bump scenes' integrator settings before they moved to the Adams method (library/iltis/vehicle.mbs,
bump_5 and bump_10; the comment above them): DOPRI5 at rtol 1e-7, atol 1e-9.

The benches that study DOPRI5 itself (its retry after rejections, its restarts, the machinery around its steps, what
sets its steps; the builds with -DMBS_ODE_*_FORMER / -DMBS_MACHINERY_FORMER, whose paths only DOPRI5 and c/ode.c
take) pin these settings explicitly, in their own runs, their child processes and their references alike; the
benches of the scene as a user runs it take the scene's own settings and print one run with these as the baseline.
"""

from __future__ import annotations

#: the bump scenes' settings before they moved to adams: what this bench studies
DOPRI5_FORMER = {"integrator": "dopri5", "rtol": 1e-7, "atol": 1e-9}


def described(settings: dict = DOPRI5_FORMER) -> str:
    """`dopri5 rtol 1e-07 atol 1e-09`: the settings as printed."""
    return f"{settings['integrator']} rtol {settings['rtol']:g} atol {settings['atol']:g}"


def scene_settings(results) -> str:
    """The integrator and tolerances a run used, from its results' metadata (`adams rtol 2e-08 atol 2e-10`)."""
    meta = results.metadata
    nan = float("nan")
    return f"{meta.get('integrator', '?')} rtol {meta.get('rtol', nan):g} atol {meta.get('atol', nan):g}"
