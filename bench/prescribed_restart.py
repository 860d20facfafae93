"""A prescribed motion's switch on a model with loops restarted in C, against the former hand-back to Python.

    python bench/prescribed_restart.py [--scenes bump_10] [--repeat 9] [--instructions] [--all]

The Iltis bump scenes' steering rack has two prescribed-motion switches (the start and the end of its ramp: switch.1,
switch.2).  Its speed may step there, and the loops' speeds with it: the state after the event is projected onto the
constraints.  That used to be Python's work: the event went back to runtime/event_loop.py, which projected the state
and started a new solver that took over what the old one had learned (c/ode.c mbs_ode_take_over).  Now c/ode.c
mbs_ode_restart applies it, projects the state with the model's projection and restarts from there (events marked
MBS_ODE_HANDLED_PROJECT by runtime/event_loop.py _restart_tables).  The baseline is the same model built with
-DMBS_ODE_PRESCRIBED_FORMER=1 (such an event goes back to Python, as before), measured in the same run.  --all: the
baseline built with c/ode.c's other former event machinery as well (-DMBS_ODE_SCAN_FORMER=1: each indicator tested in
turn at a step's end; -DMBS_ODE_SINGLE_FORMER=1: every indicator evaluated at the root finding's trial points).

Printed per scene: whether the two runs give the same event log (names, directions, changes, times) and the largest
difference of their rows (0 when the run is the same to the bit), the run's counters; the CPU time of the whole
`System.simulate(scene)` from a first start (System.forget_starts), medians of --repeat runs interleaved current /
former, and their ratio; with --instructions the instructions of one whole simulate (callgrind, after two uncounted
runs, one child process per build: load-independent) and their ratio.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
TESTS_RUNTIME = str(Path(__file__).resolve().parent.parent / "tests" / "runtime")
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import flagged_build, simulate_with  # noqa: E402

FORMER = ("-DMBS_ODE_PRESCRIBED_FORMER=1",)

#: The child of --instructions: the scene's whole simulate, callgrind collecting inside the third (functools.reduce
#: is the toggle: the first two warm the caches and the build), its model built with the flags given (none: as usual).
CHILD = f"TESTS_RUNTIME = {TESTS_RUNTIME!r}\n" + """
import functools, sys
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, flags = sys.argv[1], sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
if flags:
    install_flagged_build(system, scene, flags)
def run():
    system.forget_starts()
    system.simulate(scene)
run(); run()
functools.reduce(lambda _, __: run(), range(1), None)
"""


#: --all: the baseline with the former crossing test and search as well
ALL_FORMER = FORMER + ("-DMBS_ODE_SCAN_FORMER=1", "-DMBS_ODE_SINGLE_FORMER=1")


def instructions(scene: str, flags: tuple[str, ...], workdir: Path) -> int:
    """Instructions of one whole simulate of the scene (callgrind), the model built with `flags`."""
    child = [sys.executable, "-c", CHILD, str(MODEL), scene, *flags]
    subprocess.run(child, check=True, capture_output=True)  # the build, outside valgrind
    out = workdir / f"callgrind.{scene}.{len(flags)}"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=functools_reduce",
                           f"--callgrind-out-file={out}", *child], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed ({scene} {' '.join(flags)}):\n{done.stderr[-2000:]}")
    return int(found.group(1))


def same_run(system, scene: str, former) -> None:
    """The event logs and the rows of both builds."""
    now, was = system.simulate(scene), simulate_with(system, scene, former)
    log = [(e["event"], e["direction"], e["changes"], e["time"]) for e in now.events]
    same_log = log == [(e["event"], e["direction"], e["changes"], e["time"]) for e in was.events]
    names = [n for n in now.names if n != "time"]
    if len(now.t) == len(was.t):
        gap = max(float(np.max(np.abs(now[n] - was[n]))) for n in names)
        rows = f"largest difference of the rows {gap:.3g}"
    else:
        rows = f"rows {len(now.t)} against {len(was.t)}"
    print(f"  event logs the same: {same_log} ({len(log)} events); {rows}")
    for label, res in (("current", now), ("former ", was)):
        stats = res.metadata["stats"]
        print(f"  {label}: " + ", ".join(f"{k} {stats[k]}" for k in ("nsteps", "nreject", "nfev", "nevents")))


def timed(system, scene: str, former, repeat: int) -> None:
    """CPU time of the whole simulate from a first start, both builds interleaved."""
    times = {"current": [], "former": []}
    for _ in range(repeat):
        for label, run in (("current", lambda: system.simulate(scene)),
                           ("former", lambda: simulate_with(system, scene, former))):
            system.forget_starts()
            start = time.process_time()
            run()
            times[label].append(time.process_time() - start)
    now, was = (statistics.median(times[k]) for k in ("current", "former"))
    print(f"  whole simulate, CPU time, median of {repeat} interleaved: {now * 1e3:.2f} ms against {was * 1e3:.2f} ms "
          f"(ratio {now / was:.3f})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["bump_10"])
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--instructions", action="store_true", help="callgrind counts of one whole simulate per build")
    ap.add_argument("--all", action="store_true", help="the baseline with the former crossing test and search too")
    args = ap.parse_args(argv)
    flags = ALL_FORMER if args.all else FORMER
    system = mbs.load(MODEL)
    for scene in args.scenes:
        former = flagged_build(system, scene, flags)
        print(f"{scene}: restarted in C (current) against handed back to Python ({' '.join(flags)})")
        same_run(system, scene, former)
        for _ in range(2):  # warm both
            system.simulate(scene)
            simulate_with(system, scene, former)
        timed(system, scene, former, args.repeat)
        if args.instructions:
            with tempfile.TemporaryDirectory() as tmp:
                now, was = (instructions(scene, build, Path(tmp)) for build in ((), flags))
            print(f"  whole simulate, instructions (callgrind): {now / 1e6:.2f} M against {was / 1e6:.2f} M "
                  f"(ratio {now / was:.4f}, {(was - now) / 1e6:.2f} M fewer)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
