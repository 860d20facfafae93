"""The Iltis's event indicators (the generated mbs_events), current against the former text, in one run.

    python bench/indicators.py [--scene bump_10] [--compare bump_10 bump_5 anti_5 anti_10] [--no-count]
                               [--former angles|lookups]

The former text: mbs_events printed with one of compiler/angle_free.py's forks of the tape off, generated through
mbs.pipeline.generate (the derivation cache does not see the switch) and built like any model (cached by content).
Both builds differ in mbs_events alone.  --former angles (the default): ANGLE_FREE_INDICATORS False, the sines and
cosines of the wheels' spin evaluated, which the tyres' indicators do not depend on; --former lookups: GATED_LOOKUPS
False, the tyres' random road profiles looked up also where `rough` is 0 and scales them away.

Instructions (valgrind's callgrind, load-independent; needs `valgrind` on the PATH): the integration of one run of
--scene (`Solver.sample`, the scene's own integrator and tolerances: adams at rtol 5e-7 for bump_10) in a child
process per build, callgrind collecting inside it only: the integration, the calls of mbs_events and their
instructions at the accepted steps' ends, in the root finding and at the restarts, per call and per accepted step,
current against former with their ratios.  valgrind's libm rounds a little differently, so its step counts may
differ by a few from a run's own.

Then, outside valgrind, per scene of --compare, both builds' runs: the events (the same indicators in the same order
and directions), their times' largest difference, the steps and rhs calls, and the results' largest difference per
column (relative to the column's largest magnitude, absolute below 1).  The indicators' values change by round-off
only (exact algebra), so the events and the trajectories must be the same to round-off.

    python bench/indicators.py --groups [--scene bump_10]

What is left (the design of the next step: a root search that evaluates the indicators of its crossing's element
alone, not all of them): instructions per call of an mbs_events holding only the indicators of one element of each
kind (the first of the model's: a steering ramp's time switches, a leaf spring's stop, a strut damper's two rate
limits, a tyre's four), and of all of them, over the states of a run of --scene (its rows, the switches evaluated as
written).  Each is the current text with the other indicators left out (generated through mbs.pipeline.generate
with compiler/events.py event_code narrowed, built whole: a few minutes the first time), counted by callgrind in a
child process per build.

Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
import dataclasses
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "library" / "iltis" / "vehicle.mbs"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from event_instructions import RESTART, RHS_NAMES, ROOT_FINDER, profile, sample_under_callgrind  # noqa: E402


#: --former: the switch of compiler/angle_free.py the former text is printed with off
FORMERS = {"angles": "ANGLE_FREE_INDICATORS", "lookups": "GATED_LOOKUPS"}


def former_model(system, scene: str, former: str = "angles"):
    """The scene's compiled model with mbs_events printed as before (the switch FORMERS[former] False)."""
    from mbs import pipeline
    from mbs.compiler import angle_free
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    from mbs.runtime.translation_units import COLD_APART
    compiled = system.compile(scene)
    setattr(angle_free, FORMERS[former], False)
    try:
        generated = pipeline.generate(system.model, system.scene(scene), cold_apart=COLD_APART)
    finally:
        setattr(angle_free, FORMERS[former], True)
    return dataclasses.replace(compiled, backend=CBackend(build.load(build.build(generated.c_source))))


#: The child: one run of the scene with the current build, or with the former one installed ("former").
CHILD = f"BENCH = {str(Path(__file__).resolve().parent)!r}\n" + """
import sys
from pathlib import Path
import mbs
sys.path.insert(0, BENCH)
from indicators import former_model
path, scene, which = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
system = mbs.load(path)
if which != "current":
    model, compiled = former_model(system, scene, which), system.compile(scene)
    for key in [key for key, value in system._compiled.items() if value is compiled]:
        system._compiled[key] = model
stats = system.simulate(scene).metadata["stats"]
print("STATS", stats["nsteps"] - stats["nreject"], stats["nfev"], stats["nevents"])
"""


def counted(scene: str, which: str, workdir: Path) -> dict:
    """The integration's instructions and mbs_events' calls by caller, of one run under callgrind (which: "current"
    or a key of FORMERS)."""
    child = [sys.executable, "-c", CHILD, str(MODEL), scene, which]
    total, (accepted, nfev, nevents), pairs = sample_under_callgrind(child, workdir / f"callgrind.{which}")

    def calls(callers, callees) -> tuple[int, int]:
        found = [v for (a, b), v in pairs.items()
                 if (callers is None or a in callers) and b in callees and a not in callees]
        return sum(v[0] for v in found), sum(v[1] for v in found)
    return {"integration": (0, total), "rhs": calls(None, RHS_NAMES),
            "indicators": calls(None, ("mbs_events",)),
            "at the steps' ends": calls(("mbs_ode_find_event",), ("mbs_events",)),
            "in the root finding": calls(ROOT_FINDER, ("mbs_events",)),
            "at the restarts": calls(RESTART, ("mbs_events",)),
            "accepted": accepted, "nfev": nfev, "nevents": nevents}


def instructions(scene: str, former: str = "angles") -> None:
    """The instructions of the indicators, current against former (see the module's docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        now, was = (counted(scene, which, Path(tmp)) for which in ("current", former))
    print(f"Iltis {scene}, the scene's integrator and tolerances: instructions of one run's integration "
          f"(Solver.sample, callgrind), current mbs_events against the former text ({FORMERS[former]} False)")
    print(f"  accepted steps {now['accepted']} (former {was['accepted']}), rhs calls {now['nfev']} "
          f"({was['nfev']}), events {now['nevents']} ({was['nevents']})")
    print(f"  {'part':<26}{'calls':>7}{'current':>10}{'former':>10}{'ratio':>7}{'per call':>10}{'former':>8}"
          f"{'per step':>10}{'former':>8}")
    for key in ("integration", "rhs", "indicators", "at the steps' ends", "in the root finding", "at the restarts"):
        (n, a), (m, b) = now[key], was[key]
        per_call = f"{a / n:10.0f}{b / max(1, m):8.0f}" if n else f"{'':>18}"
        print(f"  {key:<26}{n if n else '':>7}{a / 1e6:9.1f}M{b / 1e6:9.1f}M{a / b:7.3f}{per_call}"
              f"{a / max(1, now['accepted']):10.0f}{b / max(1, was['accepted']):8.0f}")


def compare(scenes, former: str = "angles") -> None:
    """Both builds' runs of each scene outside valgrind: the events, their times, the steps and the results."""
    import mbs
    sys.path.insert(0, str(ROOT / "tests" / "runtime"))
    from former_builds import simulate_with
    system = mbs.load(MODEL)
    print("\nBoth builds' runs outside valgrind (current against former):")
    for scene in scenes:
        current, before = system.simulate(scene), simulate_with(system, scene, former_model(system, scene, former))
        same = [(e["event"], e["direction"]) for e in current.events] == [
            (e["event"], e["direction"]) for e in before.events]
        times = (np.array([e["time"] for e in current.events]) - np.array([e["time"] for e in before.events])
                 if same else np.array([np.inf]))
        worst, column, bits = 0.0, "", 0
        for name in current.names:  # relative to a column's largest magnitude, absolute below 1
            if len(current[name]) != len(before[name]):
                worst, column = np.inf, name
                continue
            bits += not np.array_equal(current[name], before[name], equal_nan=True)
            gap = float(np.max(np.abs(current[name] - before[name]))) / max(1.0, float(np.max(np.abs(before[name]))))
            if gap > worst:
                worst, column = gap, name
        a, b = current.metadata["stats"], before.metadata["stats"]
        print(f"  {scene}: {len(current.events)} events ({len(before.events)} former), "
              f"{'the same indicators in the same order and directions' if same else 'NOT the same events'}, "
              f"times differ by at most {np.max(np.abs(times), initial=0.0):.2e} s; steps {a['nsteps']} "
              f"({b['nsteps']}), rhs {a['nfev']} ({b['nfev']}); results: {len(current.names) - bits} of "
              f"{len(current.names)} columns the same to the bit, the largest difference {worst:.2e}"
              f"{f' ({column})' if column else ''}")


def element_groups(events) -> dict[str, tuple[int, ...]]:
    """The indicators of the first element of each kind, by the element the event table names ("fl.strut.damper":
    kind "strut.damper"), and all of them."""
    elements: dict[str, list[int]] = {}
    for k, entry in enumerate(events):
        elements.setdefault(entry["name"].split(" in ")[-1].rstrip(")"), []).append(k)
    groups, kinds = {}, set()
    for element, indices in elements.items():
        kind = element.split(".", 1)[-1]
        if kind not in kinds:
            kinds.add(kind)
            groups[element] = tuple(indices)
    groups["all"] = tuple(range(len(events)))
    return groups


def group_model(system, scene: str, keep: tuple[int, ...]):
    """The compiled module of the scene's text with mbs_events holding the indicators `keep` alone."""
    from mbs import pipeline
    from mbs.compiler import events
    from mbs.runtime import build
    from mbs.runtime.translation_units import COLD_APART
    every = events.event_code

    def narrowed(*args, **kwargs):
        indicators, values, table = every(*args, **kwargs)
        return tuple(indicators[k] for k in keep), values, tuple(table[k] for k in keep)
    events.event_code = narrowed
    try:
        generated = pipeline.generate(system.model, system.scene(scene), cold_apart=COLD_APART)
    finally:
        events.event_code = every
    return build.load(build.build(generated.c_source))


#: The child of --groups: mbs_events of one group over the states saved by the parent (no run here: callgrind collects
#: in every mbs_events of the process).
GROUP_CHILD = f"BENCH = {str(Path(__file__).resolve().parent)!r}\n" + """
import sys
from pathlib import Path
import numpy as np
import mbs
sys.path.insert(0, BENCH)
from indicators import element_groups, group_model
path, scene, group, states = Path(sys.argv[1]), sys.argv[2], sys.argv[3], np.load(sys.argv[4])
system = mbs.load(path)
keep = element_groups(system.generate(scene).events)[group]
module = group_model(system, scene, keep)
t, x, p = states["t"], states["x"], states["p"]
f = module.Function("events", p, np.zeros(module.NWORK))
out = np.zeros((len(t), len(keep)))
f.rows(t, x, out, p[np.newaxis, :].copy(), np.zeros(len(t), dtype=np.intp))
print("ROWS", len(t))
"""


def saved_states(scene: str, path: Path) -> None:
    """The rows of a run of the scene (time, state) and its parameters, into an .npz file for the children."""
    import mbs
    system = mbs.load(MODEL)
    res, compiled = system.simulate(scene), system.compile(scene)
    x = np.ascontiguousarray(np.column_stack([res[name] for name in compiled.x_names]))
    np.savez(path, t=np.ascontiguousarray(res["time"], dtype=float), x=x,
             p=np.array(system.start(scene)[0].p, dtype=float))


def groups(scene: str) -> None:
    """--groups: instructions per call of mbs_events narrowed to one element's indicators (see the docstring)."""
    import mbs
    named = element_groups(mbs.load(MODEL).generate(scene).events)
    print(f"Iltis {scene}: instructions per call of mbs_events holding one element's indicators alone (callgrind, "
          f"over the rows of a run)")
    with tempfile.TemporaryDirectory() as tmp:
        states = Path(tmp) / "states.npz"
        saved_states(scene, states)
        for group, keep in named.items():
            child = [sys.executable, "-c", GROUP_CHILD, str(MODEL), scene, group, str(states)]
            subprocess.run(child, check=True, capture_output=True)  # the build, outside valgrind
            out = Path(tmp) / "callgrind.group"
            done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no",
                                   "--toggle-collect=mbs_events", f"--callgrind-out-file={out}", *child],
                                  capture_output=True, text=True)
            if done.returncode != 0 or "ROWS" not in done.stdout:
                raise SystemExit(f"valgrind run failed ({group}):\n{done.stderr[-2000:]}")
            # (calls, not rows: a row equal to the one before it takes its value)
            calls = [v for (_, callee), v in profile(out)[1].items() if callee == "mbs_events"]
            count, cost = sum(v[0] for v in calls), sum(v[1] for v in calls)
            print(f"  {group:<40}{len(keep):>3} indicators {cost / max(1, count):8.0f} per call ({count} calls)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_10", help="the scene whose integration is counted")
    parser.add_argument("--compare", nargs="*", default=["bump_10", "bump_5", "anti_5", "anti_10"],
                        help="scenes whose runs are compared outside valgrind")
    parser.add_argument("--no-count", action="store_true", help="skip the instruction counts")
    parser.add_argument("--groups", action="store_true", help="instead: mbs_events narrowed to one element's")
    parser.add_argument("--former", choices=sorted(FORMERS), default="angles", help="the former text's switch off")
    args = parser.parse_args(argv)
    if args.groups:
        if shutil.which("valgrind") is None:
            print("valgrind is not on the PATH: nothing to count")
            return 1
        groups(args.scene)
        return 0
    if not args.no_count:
        if shutil.which("valgrind") is None:
            print("valgrind is not on the PATH: nothing to count")
            return 1
        instructions(args.scene, args.former)
    if args.compare:
        compare(args.compare, args.former)
    return 0


if __name__ == "__main__":
    sys.exit(main())
