"""The event form of the Iltis bump at 10 m/s against its smooth form, counted in instructions rather than timed.

    python bench/event_instructions.py [--scene bump_10]

Wall times of the two forms differ by a few per cent, less than a shared machine's noise (bench/events.py
printed ratios from 0.83 to 1.44 for the same code in one afternoon).  Instructions executed do not depend on
the load: each form runs in a child process under valgrind's callgrind (needs `valgrind` on the PATH), once
with one `simulate` (compile and warm-up) and once with three; the difference divided by two is the
instruction count of one whole `simulate` (equilibrium, integration, rows, event bookkeeping in Python
included).  The ratio event / smooth is issue 10's figure ("no slower": <= 1).  Takes a few minutes: callgrind
runs about 50 times slower than the machine.

    python bench/event_instructions.py --machinery [--scene bump_10]

The integration of one run of the event form (`Solver.sample`, callgrind collecting inside it only: every step,
projection, root finding and restart C does) built from the current c/ode.c against the former root finding, the
same model built with -DMBS_ODE_EVENTS_FORMER=1 (each crossing located from its step's ends alone, the departure
probe taken in every search, the bracket closed by probes four doubles either side of the secant's root and
bisection, the indicators at an event evaluated again by its restart), both counted in the same run: instructions of
the integration, of its rhs calls, of its indicator evaluations (`mbs_events`, with their count) and of the rest,
with the ratios current / former.  Then, outside valgrind, the two builds' runs compared: the events (count,
indicators, order) and their times, the steps, and the results' largest difference per column.  valgrind's floating
point differs from the machine's in the last bits (its libm takes other paths), so the step counts under it differ a
little from a run's own.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"

#: The child: the vehicle with `switches` set in its model header, `count` runs of the scene.
CHILD = """
import sys
from pathlib import Path
import mbs
path, form, scene, count = Path(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
text = path.read_text()
header = next(line for line in text.splitlines() if line.startswith("model "))
system = mbs.loads(text.replace(header, header + "\\n    switches = " + form, 1), path=str(path))
for _ in range(count):
    system.simulate(scene)
"""


def instructions(form: str, scene: str, count: int, workdir: Path) -> int:
    """Instructions callgrind counts for the child with `count` runs of the scene."""
    out = workdir / f"callgrind.{form}.{count}"
    done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c",
                           CHILD, str(MODEL), form, scene, str(count)], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed ({form}, {count} runs):\n{done.stderr[-2000:]}")
    return int(found.group(1))


#: The build switch of the former root finding (c/ode.c).
FORMER_FLAGS = ("-DMBS_ODE_EVENTS_FORMER=1",)

#: The child of --machinery: the event form's scene once, its model built with the flags given (none: as usual).
MACHINERY_CHILD = """
import dataclasses, sys
from pathlib import Path
import mbs
from mbs.runtime import build
from mbs.runtime.backends import CBackend
path, scene, flags = Path(sys.argv[1]), sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
compiled = system.compile(scene)
if flags:
    model = dataclasses.replace(compiled, backend=CBackend(build.load(build.build(
        system.generate(scene).c_source, extra_flags=flags))))
    for key in [key for key, value in system._compiled.items() if value is compiled]:
        system._compiled[key] = model
system.simulate(scene)
"""


def callees(path: Path) -> dict[str, tuple[int, int]]:
    """Per function called in a callgrind output file: (calls, inclusive instructions of those calls)."""
    names, calls, inclusive = {}, {}, {}
    callee, cost_follows = None, False
    with open(path) as lines:
        for line in lines:
            if cost_follows:  # the line after calls=: position and the inclusive cost of those calls
                inclusive[callee] = inclusive.get(callee, 0) + int(line.split()[1])
                cost_follows = False
            elif line.startswith(("fn=", "cfn=")):
                found = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line.strip())
                if found:
                    if found.group(2):
                        names[found.group(1)] = found.group(2)
                    if line.startswith("cfn="):
                        callee = found.group(1)
            elif line.startswith("calls="):
                calls[callee] = calls.get(callee, 0) + int(line.split("=")[1].split()[0])
                cost_follows = True
    return {names[key]: (calls[key], inclusive.get(key, 0)) for key in calls}


def integration_instructions(scene: str, flags: tuple[str, ...], workdir: Path) -> dict[str, float]:
    """The instructions of the integration of one run (inside Solver.sample), its rhs calls and its indicators."""
    out = workdir / f"callgrind.machinery{len(flags)}"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=solver_sample",
                           f"--callgrind-out-file={out}", sys.executable, "-c", MACHINERY_CHILD, str(MODEL), scene,
                           *flags], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed ({flags or 'current'}):\n{done.stderr[-2000:]}")
    called = callees(out)
    rhs = next(name for name in ("mbs_loop_rhs_direct", "mbs_loop_rhs", "mbs_rhs") if name in called)
    return {"integration": int(found.group(1)), "rhs": called[rhs][1], "rhs calls": called[rhs][0],
            "indicators": called.get("mbs_events", (0, 0))[1], "indicator calls": called.get("mbs_events", (0, 0))[0]}


def compare_runs(scene: str) -> None:
    """The scene's event form with the current and the former root finding, compared outside valgrind."""
    import dataclasses
    import mbs
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    system = mbs.load(MODEL)
    compiled = system.compile(scene)
    former = dataclasses.replace(compiled, backend=CBackend(build.load(build.build(
        system.generate(scene).c_source, extra_flags=FORMER_FLAGS))))
    current = system.simulate(scene)
    keys = [key for key, value in system._compiled.items() if value is compiled]
    for key in keys:
        system._compiled[key] = former
    try:
        before = system.simulate(scene)
    finally:
        for key in keys:
            system._compiled[key] = compiled
    same = [(e["event"], e["direction"]) for e in current.events] == [
        (e["event"], e["direction"]) for e in before.events]
    times = np.array([e["time"] for e in current.events]) - np.array([e["time"] for e in before.events]) \
        if same else np.array([np.inf])
    print(f"  outside valgrind: {len(current.events)} events now, {len(before.events)} before, "
          f"{'the same indicators in the same order' if same else 'NOT the same events'}; event times differ by at "
          f"most {np.max(np.abs(times)):.2e} s")
    stats_now, stats_before = current.metadata["stats"], before.metadata["stats"]
    print(f"  steps {stats_now['nsteps']} (rejected {stats_now['nreject']}), rhs {stats_now['nfev']}; before: "
          f"{stats_before['nsteps']} ({stats_before['nreject']}), {stats_before['nfev']}")
    worst, column = 0.0, ""
    for name in current.names:  # relative to a column's largest magnitude, absolute below 1 (test_event_restarts)
        if len(current[name]) != len(before[name]):
            continue
        gap = float(np.max(np.abs(current[name] - before[name]))) / max(1.0, float(np.max(np.abs(before[name]))))
        if gap > worst:
            worst, column = gap, name
    print(f"  results: the largest difference {worst:.2e} ({column}; relative to the column's largest magnitude, "
          f"absolute below 1); the scene's rtol {current.metadata.get('rtol', 'n/a')}")


def machinery(scene: str) -> int:
    """--machinery: the integration's instructions, current against the former root finding, in the same run."""
    counts = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, flags in (("current", ()), ("former", FORMER_FLAGS)):
            subprocess.run([sys.executable, "-c", MACHINERY_CHILD, str(MODEL), scene, *flags], check=True)  # build
            counts[label] = integration_instructions(scene, flags, Path(tmp))
    now, was = counts["current"], counts["former"]
    print(f"Iltis {scene} (event form), dopri5: instructions of one run's integration (Solver.sample, callgrind):")
    for label, key in (("integration", "integration"), ("  rhs calls", "rhs"), ("  indicators", "indicators")):
        print(f"  {label:<20} current {now[key] / 1e6:8.1f} M   former {was[key] / 1e6:8.1f} M   "
              f"ratio {now[key] / was[key]:.3f}")
    rest_now = now["integration"] - now["rhs"] - now["indicators"]
    rest_was = was["integration"] - was["rhs"] - was["indicators"]
    print(f"  {'  the rest':<20} current {rest_now / 1e6:8.1f} M   former {rest_was / 1e6:8.1f} M   "
          f"ratio {rest_now / rest_was:.3f}")
    machinery_now, machinery_was = now["integration"] - now["rhs"], was["integration"] - was["rhs"]
    print(f"  {'all but the rhs':<20} current {machinery_now / 1e6:8.1f} M   former {machinery_was / 1e6:8.1f} M   "
          f"ratio {machinery_now / machinery_was:.3f}")
    print(f"  indicator evaluations {now['indicator calls']} against {was['indicator calls']}; rhs calls "
          f"{now['rhs calls']} against {was['rhs calls']}")
    compare_runs(scene)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_10")
    parser.add_argument("--machinery", action="store_true",
                        help="the integration's instructions, current against the former root finding (c/ode.c)")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not on the PATH: nothing to count")
        return 1
    if args.machinery:
        return machinery(args.scene)
    for form in ("false", "true"):  # compile both forms outside valgrind first: the counts then hold no build
        subprocess.run([sys.executable, "-c", CHILD, str(MODEL), form, args.scene, "1"], check=True)
    per_run = {}
    with tempfile.TemporaryDirectory() as tmp:
        for form in ("false", "true"):
            one, three = (instructions(form, args.scene, n, Path(tmp)) for n in (1, 3))
            per_run[form] = (three - one) / 2
    smooth, events = per_run["false"], per_run["true"]
    print(f"Iltis {args.scene}, dopri5, instructions of one whole simulate() (callgrind, load-independent):")
    print(f"  smooth form (switches = false, baseline) {smooth / 1e6:10.1f} M")
    print(f"  event form  (switches = true)            {events / 1e6:10.1f} M   ratio {events / smooth:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
