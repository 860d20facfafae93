"""The event form of the Iltis bump at 10 m/s against its smooth form, counted in instructions rather than timed.

    python bench/event_instructions.py [--scene bump_10]

Wall times of the two forms differ by a few per cent, less than a shared machine's noise (bench/events.py
printed ratios from 0.83 to 1.44 for the same code in one afternoon).  Instructions executed do not depend on
the load: each form runs in a child process under valgrind's callgrind (needs `valgrind` on the PATH), once
with one `simulate` (compile and warm-up) and once with three; the difference divided by two is the
instruction count of one whole `simulate` (equilibrium, integration, rows, event bookkeeping in Python
included).  The ratio event / smooth is issue 10's figure ("no slower": <= 1).  Takes a few minutes: callgrind
runs about 50 times slower than the machine.

Every run here, in the children and in this process, is DOPRI5 at rtol 1e-7, atol 1e-9, set explicitly
(bench/dopri5_former.py DOPRI5_FORMER): the bump scenes' settings before they moved to adams, what this bench studies
(the restarts and the machinery around DOPRI5's steps; the former builds' paths are DOPRI5's and c/ode.c's).

    python bench/event_instructions.py --machinery [--scene bump_10] [--former machinery|events|scan|single]
                                       [--repeat 7]

The integration of one run of the event form (`Solver.sample`, callgrind collecting inside it only: every step,
projection, root finding and restart C does), split by part and counted for two builds of the same model in the
same run, current / former:

* --former machinery (the default): -DMBS_MACHINERY_FORMER=1, the former machinery around the rhs calls: c/dopri5.c's
  elementwise loops (stages, error estimate, dense output) and c/ode.c's error norm scalar, the generated lookup
  tables' search over all their knots instead of from the interval evenly spaced knots put x in (the road profile
  of the Iltis's tyres, in the rhs and the indicators alike), and c/loops.c's projection of accepted steps polishing
  every one to round-off and projecting afresh one that drifted beyond 1e-12;
* --former events: -DMBS_ODE_EVENTS_FORMER=1, the former root finding (each crossing located from its step's ends
  alone, the departure probe taken in every search, the bracket closed by probes four doubles either side of the
  secant's root and bisection, the indicators at an event evaluated again by its restart);
* --former scan: -DMBS_ODE_SCAN_FORMER=1, the former test for a crossing at a step's end (c/ode.c mbs_ode_find_event:
  the root finding's bookkeeping set up for every indicator, each then tested in turn, where the indicators are now
  tested all at once, vectorized, and a step without a crossing goes on at once);
* --former single: -DMBS_ODE_SINGLE_FORMER=1, the root finding evaluating every indicator at its trial points (c/ode.c
  mbs_ode_trial_indicators), where it now evaluates the ones that crossed in the step alone (mbs_event_indicator).

The parts: the rhs calls (of the steps, of the restarts), the projection of the accepted steps, the indicator
evaluations (`mbs_events`: at the steps' ends, in the root finding, at the restarts, with their counts), the root
finding's own work (dense output at its trial points, the search), DOPRI5's own arithmetic (stages, error norm,
dense coefficients), the restarts' own bookkeeping, and the rest; each also per accepted step.  Then the wall time
(CPU seconds) of the integration of both builds, interleaved, medians of --repeat runs, and the two builds' runs
compared outside valgrind: the events (count, indicators, order) and their times, the steps, and the results'
largest difference per column.  valgrind's floating point differs from the machine's in the last bits (its libm
takes other paths), so the step counts under it differ a little from a run's own.

Instructions are the figure to go by: the wall time of the part outside the rhs calls is a few per cent of a run
and the shared machine's load moves a run by more.  They and a sampling profile (perf) of the integration agree:
about 13 % of the integration is outside the rhs calls in bump_5 and bump_10 alike, some 10 us per step either way.
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
sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the bump scenes' settings before they moved to adams: what this bench studies (DOPRI5 at rtol 1e-7, atol 1e-9)
from dopri5_former import DOPRI5_FORMER, described, scene_settings  # noqa: E402

#: The child: the vehicle with `switches` set in its model header, `count` runs of the scene (DOPRI5_FORMER).
CHILD = f"DOPRI5_FORMER = {DOPRI5_FORMER!r}\n" + """
import sys
from pathlib import Path
import mbs
path, form, scene, count = Path(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
text = path.read_text()
header = next(line for line in text.splitlines() if line.startswith("model "))
system = mbs.loads(text.replace(header, header + "\\n    switches = " + form, 1), path=str(path))
for _ in range(count):
    system.simulate(scene, **DOPRI5_FORMER)
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


#: The build switches of the baselines of --machinery: the former machinery (c/dopri5.c's scalar loops, the
#: lookups' search over all knots), the former root finding (c/ode.c) and the former test for a crossing at a step's
#: end (c/ode.c mbs_ode_find_event: each indicator's bookkeeping set up, then tested in turn).
FORMERS = {"machinery": ("-DMBS_MACHINERY_FORMER=1",), "events": ("-DMBS_ODE_EVENTS_FORMER=1",),
           "scan": ("-DMBS_ODE_SCAN_FORMER=1",), "single": ("-DMBS_ODE_SINGLE_FORMER=1",)}
FORMER_FLAGS = FORMERS["events"]

#: The tests' helpers (tests/runtime/former_builds.py: install_flagged_build), for the child processes
TESTS_RUNTIME = str(Path(__file__).resolve().parent.parent / "tests" / "runtime")

#: The child of --machinery: the event form's scene once (DOPRI5_FORMER), its model built with the flags given (none:
#: as usual).
MACHINERY_CHILD = f"DOPRI5_FORMER = {DOPRI5_FORMER!r}\nTESTS_RUNTIME = {TESTS_RUNTIME!r}\n" + """
import sys
from pathlib import Path
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, flags = Path(sys.argv[1]), sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
if flags:
    install_flagged_build(system, scene, flags)
stats = system.simulate(scene, **DOPRI5_FORMER).metadata["stats"]
print("ACCEPTED", stats["nsteps"] - stats["nreject"])
"""


def sample_under_callgrind(child: list[str], out: Path) -> tuple[int, tuple[int, ...], dict]:
    """One child process (`child`, a command whose stdout has a line "STATS n ...") under callgrind, collecting
    inside Solver.sample only (solver_sample), its build made first outside valgrind: (the instructions collected,
    the numbers of its STATS line, the call pairs of profile(out))."""
    subprocess.run(child, check=True, capture_output=True)
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=solver_sample",
                           f"--callgrind-out-file={out}", *child], capture_output=True, text=True)
    total = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    stats = re.search(r"^STATS ((?:\d+ ?)+)$", done.stdout, re.M)
    if done.returncode != 0 or not total or not stats:
        raise SystemExit(f"valgrind run failed ({' '.join(child[3:])}):\n{done.stderr[-2000:]}")
    return int(total.group(1)), tuple(int(v) for v in stats.group(1).split()), profile(out)[1]


def profile(path: Path) -> tuple[dict[str, int], dict[tuple[str, str], tuple[int, int]]]:
    """A callgrind output file's instructions per function (its own, callees excluded) and per call pair
    (caller, callee): (calls, inclusive instructions of those calls)."""
    names, own, pairs = {}, {}, {}
    caller = callee = None
    cost_follows = False

    def name(line: str, key: str) -> str:
        found = re.match(rf"{key}=\((\d+)\)(?: (.*))?", line)
        if found.group(2):
            names[found.group(1)] = found.group(2).strip()
        return found.group(1)
    with open(path) as lines:
        for line in lines:
            if cost_follows:  # the line after calls=: position and the inclusive cost of those calls
                count, cost = pairs.get((caller, callee), (0, 0))
                pairs[(caller, callee)] = (count + calls, cost + int(line.split()[1]))
                cost_follows = False
            elif line.startswith("fn="):
                caller = name(line.strip(), "fn")
            elif line.startswith("cfn="):
                callee = name(line.strip(), "cfn")
            elif line.startswith("calls="):
                calls = int(line.split("=")[1].split()[0])
                cost_follows = True
            elif line[:1].isdigit() or line[:1] in "+-*":  # position and cost of the function's own instructions
                words = line.split()
                if len(words) >= 2 and caller is not None:
                    own[caller] = own.get(caller, 0) + int(words[1])
    named = {names.get(key, key): value for key, value in own.items()}
    return named, {(names.get(a, a), names.get(b, b)): value for (a, b), value in pairs.items()}


def callees(path: Path) -> dict[str, tuple[int, int]]:
    """Per function called in a callgrind output file: (calls, inclusive instructions of those calls)."""
    total = {}
    for (_, callee), (count, cost) in profile(path)[1].items():
        was = total.get(callee, (0, 0))
        total[callee] = (was[0] + count, was[1] + cost)
    return total


#: The functions of the integration by the part they belong to (callgrind names them; a static function the
#: compiler inlined is counted with its caller).
RHS_NAMES = ("mbs_loop_rhs_direct", "mbs_loop_rhs", "mbs_rhs")
PROJECT_NAMES = ("mbs_loop_project_step", "mbs_project")
ROOT_FINDER = ("mbs_ode_locate", "mbs_ode_g_at")
RESTART = ("mbs_ode_restart", "mbs_ode_depart", "mbs_ode_bridge")
#: the indicators: all at once, and one alone (the root finding's, c/ode.c mbs_ode_trial_indicators)
INDICATOR_NAMES = ("mbs_events", "mbs_event_indicator")


def integration_parts(path: Path, total: int) -> dict[str, float]:
    """The integration's instructions by part (see the module's docstring), with the counts of the calls."""
    own, pairs = profile(path)

    def calls(callers, callees_) -> tuple[int, int]:
        found = [value for (a, b), value in pairs.items() if (callers is None or a in callers) and b in callees_]
        return sum(v[0] for v in found), sum(v[1] for v in found)

    def inclusive(names) -> int:  # calls to these from anything but themselves
        return sum(v[1] for (a, b), v in pairs.items() if b in names and a not in names)
    rhs = calls(None, RHS_NAMES)
    rhs_restarts = calls(RESTART, RHS_NAMES)
    events_at = {"ends": calls(("mbs_ode_find_event",), INDICATOR_NAMES),
                 "roots": calls(ROOT_FINDER, INDICATOR_NAMES),
                 "restarts": calls(RESTART, INDICATOR_NAMES)}
    indicators = calls(None, INDICATOR_NAMES)
    projection = calls(("mbs_ode_accept",), PROJECT_NAMES)
    root_finding = inclusive(ROOT_FINDER)
    step = inclusive(("dp_step",))
    step_rhs, step_accept = calls(("dp_step",), RHS_NAMES)[1], calls(("dp_step",), ("mbs_ode_accept",))[1]
    restarts = inclusive(RESTART)
    lookups = sum(v for key, v in own.items() if key.startswith("mbs_lookup"))
    parts = {"integration": total, "rhs": rhs[1], "rhs calls": rhs[0], "rhs of restarts": rhs_restarts[1],
             "rhs of restarts calls": rhs_restarts[0], "projection": projection[1],
             "indicators": indicators[1], "indicator calls": indicators[0],
             "root finding": root_finding - events_at["roots"][1],
             "dopri5": step - step_rhs - step_accept,
             "restarts": restarts - rhs_restarts[1] - events_at["restarts"][1],
             "lookups": lookups, "lookup calls": calls(None, tuple(k for k in own if k.startswith("mbs_lookup")))[0]}
    for key, (count, cost) in events_at.items():
        parts[f"indicators {key}"], parts[f"indicators {key} calls"] = cost, count
    parts["rest"] = total - sum(parts[key] for key in ("rhs", "projection", "indicators", "root finding",
                                                       "dopri5", "restarts"))
    return parts


def integration_instructions(scene: str, flags: tuple[str, ...], workdir: Path) -> dict[str, float]:
    """The instructions of the integration of one run (inside Solver.sample), by part."""
    out = workdir / f"callgrind.machinery{len(flags)}"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=solver_sample",
                           f"--callgrind-out-file={out}", sys.executable, "-c", MACHINERY_CHILD, str(MODEL), scene,
                           *flags], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed ({flags or 'current'}):\n{done.stderr[-2000:]}")
    steps = re.search(r"^ACCEPTED (\d+)$", done.stdout, re.M)
    parts = integration_parts(out, int(found.group(1)))
    parts["accepted"] = int(steps.group(1)) if steps else 0
    return parts


def compare_runs(scene: str, flags: tuple[str, ...], repeat: int) -> None:
    """The scene's event form built as usual and with `flags`, compared outside valgrind: the integration's wall
    time (interleaved, medians), the events and their times, the steps, and the results."""
    import statistics
    import mbs
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "runtime"))
    from bump_cost import timed_run, using
    from former_builds import flagged_build
    system = mbs.load(MODEL)
    former = flagged_build(system, scene, flags)
    system.simulate(scene, **DOPRI5_FORMER)
    with using(system, scene, former):
        system.simulate(scene, **DOPRI5_FORMER)
    now_runs, was_runs = [], []
    for _ in range(repeat):  # interleaved: the load drifts
        now_runs.append(timed_run(system, scene, **DOPRI5_FORMER))
        with using(system, scene, former):
            was_runs.append(timed_run(system, scene, **DOPRI5_FORMER))
    seconds = {label: statistics.median(run[1].get("integration", 0.0) for run in runs)
               for label, runs in (("current", now_runs), ("former", was_runs))}
    print(f"  wall (CPU seconds of the integration, medians of {repeat} interleaved runs; the machine's load moves "
          f"them): current {seconds['current'] * 1e3:.1f} ms, former {seconds['former'] * 1e3:.1f} ms, ratio "
          f"{seconds['current'] / seconds['former']:.3f}")
    current, before = now_runs[-1][2], was_runs[-1][2]
    same = [(e["event"], e["direction"]) for e in current.events] == [
        (e["event"], e["direction"]) for e in before.events]
    times = np.array([e["time"] for e in current.events]) - np.array([e["time"] for e in before.events]) \
        if same else np.array([np.inf])
    print(f"  outside valgrind: {len(current.events)} events now, {len(before.events)} before, "
          f"{'the same indicators in the same order' if same else 'NOT the same events'}; event times differ by at "
          f"most {np.max(np.abs(times), initial=0.0):.2e} s")
    stats_now, stats_before = current.metadata["stats"], before.metadata["stats"]
    print(f"  steps {stats_now['nsteps']} (rejected {stats_now['nreject']}), rhs {stats_now['nfev']}; before: "
          f"{stats_before['nsteps']} ({stats_before['nreject']}), {stats_before['nfev']}")
    worst, column, bits = 0.0, "", 0
    for name in current.names:  # relative to a column's largest magnitude, absolute below 1 (test_event_restarts)
        if len(current[name]) != len(before[name]):
            continue
        bits += not np.array_equal(current[name], before[name], equal_nan=True)
        gap = float(np.max(np.abs(current[name] - before[name]))) / max(1.0, float(np.max(np.abs(before[name]))))
        if gap > worst:
            worst, column = gap, name
    print(f"  results: {len(current.names) - bits} of {len(current.names)} columns the same to the bit; the largest "
          f"difference {worst:.2e}{f' ({column})' if column else ''} (relative to the column's largest magnitude, "
          f"absolute below 1); the runs' settings {scene_settings(current)}")


#: The rows of --machinery's table: label, part, the key of its count of calls (or None).
ROWS = (("integration", "integration", None),
        ("  rhs calls", "rhs", "rhs calls"),
        ("    of it at restarts", "rhs of restarts", "rhs of restarts calls"),
        ("    of it table lookups", "lookups", "lookup calls"),
        ("  all but the rhs", "machinery", None),
        ("    projection of steps", "projection", None),
        ("    indicators", "indicators", "indicator calls"),
        ("      at the steps' ends", "indicators ends", "indicators ends calls"),
        ("      in the root finding", "indicators roots", "indicators roots calls"),
        ("      at the restarts", "indicators restarts", "indicators restarts calls"),
        ("    root finding's own", "root finding", None),
        ("    DOPRI5's arithmetic", "dopri5", None),
        ("    restarts' bookkeeping", "restarts", None),
        ("    the rest", "rest", None))


def machinery(scene: str, former: str, repeat: int) -> int:
    """--machinery: the integration's instructions by part, current against the former build, in the same run."""
    flags = FORMERS[former]
    counts = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, build_flags in (("current", ()), ("former", flags)):
            subprocess.run([sys.executable, "-c", MACHINERY_CHILD, str(MODEL), scene, *build_flags], check=True,
                           capture_output=True)  # the build, outside valgrind
            counts[label] = integration_instructions(scene, build_flags, Path(tmp))
    for parts in counts.values():
        parts["machinery"] = parts["integration"] - parts["rhs"]
    now, was = counts["current"], counts["former"]
    print(f"Iltis {scene} (event form), {described()}: instructions of one run's integration (Solver.sample, "
          f"callgrind), the current build against {' '.join(flags)}, and per accepted step ({now['accepted']} now, "
          f"{was['accepted']} before):")
    print(f"  {'part':<28}{'current':>10}{'former':>10}{'ratio':>8}{'calls now':>11}{'before':>8}"
          f"{'per step':>10}{'before':>8}")
    for label, key, calls in ROWS:
        a, b = now[key], was[key]
        ratio = f"{a / b:8.3f}" if b else f"{'':>8}"
        count = f"{now[calls]:>11d}{was[calls]:>8d}" if calls else f"{'':>19}"
        print(f"  {label:<28}{a / 1e6:9.1f}M{b / 1e6:9.1f}M{ratio}{count}"
              f"{a / max(1, now['accepted']):10.0f}{b / max(1, was['accepted']):8.0f}")
    compare_runs(scene, flags, repeat)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_10")
    parser.add_argument("--machinery", action="store_true",
                        help="the integration's instructions by part, current against a former build")
    parser.add_argument("--former", choices=sorted(FORMERS), default="machinery",
                        help="--machinery's baseline: the former machinery (default), root finding, crossing test "
                             "or indicators at the trial points")
    parser.add_argument("--repeat", type=int, default=7, help="--machinery's interleaved timed runs per build")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not on the PATH: nothing to count")
        return 1
    if args.machinery:
        return machinery(args.scene, args.former, args.repeat)
    for form in ("false", "true"):  # compile both forms outside valgrind first: the counts then hold no build
        subprocess.run([sys.executable, "-c", CHILD, str(MODEL), form, args.scene, "1"], check=True)
    per_run = {}
    with tempfile.TemporaryDirectory() as tmp:
        for form in ("false", "true"):
            one, three = (instructions(form, args.scene, n, Path(tmp)) for n in (1, 3))
            per_run[form] = (three - one) / 2
    smooth, events = per_run["false"], per_run["true"]
    print(f"Iltis {args.scene}, {described()}, instructions of one whole simulate() (callgrind, load-independent):")
    print(f"  smooth form (switches = false, baseline) {smooth / 1e6:10.1f} M")
    print(f"  event form  (switches = true)            {events / 1e6:10.1f} M   ratio {events / smooth:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
