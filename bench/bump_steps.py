"""What sets the number of steps of the Iltis bump scenes: accuracy or stability, and which coordinates.

    python bench/bump_steps.py [--scenes bump_5 bump_10]

Issue 12 asks for the bump scenes at 100 times real time with the scene's own integrator; this bench studies
DOPRI5's steps at the scenes' settings before they moved to adams (rtol 1e-7, atol 1e-9, set explicitly in every run:
bench/dopri5_former.py DOPRI5_FORMER). bench/bump_cost.py showed that their rhs calls alone, at an open tree's cost,
bound DOPRI5 below that on bump_10. Only fewer steps would help, so this bench asks what sets them (step counts are
load-independent):

* the steps against rtol (atol = rtol / 100, as the scenes): an explicit method limited by accuracy takes about
  rtol^(-1/5) times more steps per decade for DOPRI5 (order 5: 1.58 per decade); one limited by stability takes
  nearly the same number at every tolerance (the step stays at the stability boundary);
* the steps with the error controlled on a subset of the state only (every other component's atol 1e6, so its
  error never rejects a step), at the scene's rtol: the car body alone (its six coordinates and speeds), and all
  but the coordinates the loops make dependent (each corner but one of its seven joint coordinates and their speeds:
  which one is the independent one is the loop solver's choice, so each joint's coordinate is tried as it).

The baseline of every line is the scene with DOPRI5 at rtol 1e-7, atol 1e-9, in the same run. The rhs calls follow
the steps (6 per step, first-same-as-last, plus the restarts at events).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the bump scenes' settings before they moved to adams: what this bench studies (DOPRI5 at rtol 1e-7, atol 1e-9)
from dopri5_former import DOPRI5_FORMER, described  # noqa: E402

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
#: the joints of each corner's loops (their coordinates and speeds carry these names)
CORNER_JOINTS = ("leaf_bearing", "arm_bearing", "lower_ball", "rod_inner")
IGNORED = 1e6  # an atol no error reaches: the component does not take part in the step size control


def stats(system, scene: str, **options) -> dict:
    """The run's counts with DOPRI5 at the former settings, `options` overriding them (rtol, atol)."""
    return system.simulate(scene, **{**DOPRI5_FORMER, **options}).metadata["stats"]


def masked_atol(names, keep, atol: float) -> np.ndarray:
    """The scene's atol on the components whose names contain one of `keep`, IGNORED on the others."""
    return np.array([atol if any(k in name for k in keep) else IGNORED for name in names])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    args = ap.parse_args()
    system = mbs.load(MODEL)
    for scene in args.scenes:
        base = stats(system, scene)
        print(f"\n{scene} ({described()}, the scene's settings before adams): {base['nsteps']} steps, {base['nreject']} "
              f"rejected, {base['nfev']} rhs, {base['nevents']} events")
        print("  steps against the tolerance (atol = rtol / 100):")
        previous = None
        for rtol in RTOLS:
            s = stats(system, scene, rtol=rtol, atol=rtol / 100)
            growth = "" if previous is None else f"   x{s['nsteps'] / previous:.2f} per decade"
            print(f"    rtol {rtol:7.0e}: {s['nsteps']:6d} steps {s['nfev']:7d} rhs{growth}")
            previous = s["nsteps"]
        print(f"    (accuracy-limited DOPRI5: x{10 ** 0.2:.2f} per decade; stability-limited: about x1)")
        names = system.compile(scene).x_names
        body = masked_atol(names, ("floating",), DOPRI5_FORMER["atol"])
        s = stats(system, scene, atol=body)
        print(f"  the error controlled on a subset of the state only, rtol {DOPRI5_FORMER['rtol']:g} (against the "
              "whole state):")
        print(f"    the car body alone:                         {s['nsteps']:6d} steps, {s['nsteps'] / base['nsteps']:.2f}")
        for joint in CORNER_JOINTS:
            keep = ("floating", joint)
            s = stats(system, scene, atol=masked_atol(names, keep, DOPRI5_FORMER["atol"]))
            print(f"    the body and each corner's {joint + ':':17s}{s['nsteps']:6d} steps, "
                  f"{s['nsteps'] / base['nsteps']:.2f}")


if __name__ == "__main__":
    main()
