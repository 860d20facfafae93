"""Where the Iltis bump scenes' DOPRI5 steps are rejected, and the retry that measures the order (c/dopri5.c).

    python bench/restart_steps.py [--scenes bump_5 bump_10 anti_5 anti_10] [--speeds 0.3 0.6] [--where]
                                  [--accuracy] [--instructions] [--former steps|handback|machinery]

Each scene's run (DOPRI5 in C at rtol 1e-7, atol 1e-9, events restarted in C) with the current c/dopri5.c
against the former retry, the same model built with -DMBS_ODE_STEPS_FORMER=1 (after a rejection the step always
shrinks by err^0.17 / 0.9, the 5th-order model of the error), both in the same run: steps (accepted + rejected),
rejected steps, rhs calls and events, with the ratios current / former.  Step counts do not depend on the machine's
load; a scene's trajectory does change a little with any change of its step sequence (the switches' events come
in a different order at times), so --speeds adds the scenes at their speed v +- those offsets (m/s) as a sample.

--former handback: the baseline is the former hand-back instead, the same model built with
-DMBS_ODE_HANDBACK_FORMER=1: an event handed back to Python without a jump of the state (a prescribed motion's switch
on a model with loops: the steering rack's, at the start and the end of its ramp) went on in a new solver that had learned nothing, where now
it takes over the first-step fractions, the indicators' last events, the step a restart in C takes and DOPRI5's
controller memory (c/ode.c mbs_ode_take_over).  With --where a RESUME is counted as a restart (its first step: 0).

--former machinery: the baseline is the former machinery around the rhs calls, the same model built with
-DMBS_MACHINERY_FORMER=1 (bench/event_instructions.py --machinery counts its instructions): the step counts and, with
--accuracy, the results against the reference show what it changes (nothing but the accepted steps' projection:
a step drifted by at most 1e-13, or a hundredth of atol, keeps its positions, one drifted beyond 1e-12 is polished
with the factors at hand instead of projected afresh; the trajectories part by round-off, then by the integration
error).

Every run here is DOPRI5 at rtol 1e-7, atol 1e-9, set explicitly (bench/dopri5_former.py DOPRI5_FORMER): the bump
scenes' settings before they moved to adams (anti_5 and anti_10 still have them), what this bench studies; the
reference of --accuracy is DOPRI5 too.

--where: the trace build (-DMBS_ODE_TRACE=1, every attempt and restart written to stderr) of either retry, and where
its rejections are: by the accepted steps since the last restart in C (0: the first step after it), the first
steps' by the indicators that fired (tyre touch-down, leaf spring stop, damper kinks), runs of rejections in a row,
and the rhs calls they and the restarts cost.

--accuracy: each output column of both runs against a reference of the same scene, DOPRI5 at rtol 1e-11 (atol
1e-13), the largest difference relative to the column's largest magnitude (absolute below 1), and the two runs'
difference.

--instructions: the instructions of one run's integration (Solver.sample) under callgrind, as
bench/event_instructions.py --machinery counts them, for both builds (valgrind on the PATH; a few minutes).
"""

from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
# the flagged build and the run with it: the tests' helper (the tests compare the same two builds)
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "runtime"))
from former_builds import flagged_build, simulate_with  # noqa: E402
sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the bump scenes' settings before they moved to adams: what this bench studies (DOPRI5 at rtol 1e-7, atol 1e-9)
from dopri5_former import DOPRI5_FORMER, described  # noqa: E402
#: the reference of --accuracy: DOPRI5 (named: the bump scenes' own integrator is adams now) at rtol 1e-11
REFERENCE = {"integrator": "dopri5", "rtol": 1e-11, "atol": 1e-13}
#: --former: the former behaviour a flag builds back, and what it is
FORMERS = {"steps": (("-DMBS_ODE_STEPS_FORMER=1",), "the former retry (-DMBS_ODE_STEPS_FORMER=1)"),
           "handback": (("-DMBS_ODE_HANDBACK_FORMER=1",), "the former hand-back (-DMBS_ODE_HANDBACK_FORMER=1: the "
                        "solver after an event handed back to Python has learned nothing)"),
           "machinery": (("-DMBS_MACHINERY_FORMER=1",), "the former machinery (-DMBS_MACHINERY_FORMER=1: DOPRI5's "
                         "scalar loops, the lookups' search over all knots, each accepted step polished, a drifted one projected "
                         "afresh)")}
FORMER_FLAGS = FORMERS["steps"][0]
TRACE_FLAGS = ("-DMBS_ODE_TRACE=1",)
KEYS = ("nsteps", "nreject", "nfev", "nevents")
#: the DOPRI5 stages a rejected step costs (first same as last: the seventh is the next step's first)
STAGES = 6

#: The tests' helpers (tests/runtime/former_builds.py: install_flagged_build), for the child processes
TESTS_RUNTIME = str(Path(__file__).resolve().parent.parent / "tests" / "runtime")

#: The child of --where: one run of the scene built with the trace flags (and the former retry's if given), DOPRI5 at
#: the bump scenes' former settings (DOPRI5_FORMER).
TRACE_CHILD = f"DOPRI5_FORMER = {DOPRI5_FORMER!r}\nTESTS_RUNTIME = {TESTS_RUNTIME!r}\n" + """
import sys
from pathlib import Path
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, flags = Path(sys.argv[1]), sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
install_flagged_build(system, scene, flags)
print("\\n".join(spec.name for spec in system.compile(scene).events), flush=True)
sys.stderr.write("BEGIN\\n")
sys.stderr.flush()
stats = system.simulate(scene, **DOPRI5_FORMER).metadata["stats"]
sys.stderr.flush()
print("STATS", stats["nsteps"], stats["nreject"], stats["nfev"], stats["nevents"], flush=True)
"""


def speed_of(scene: str) -> float:
    """The scene's speed v (m/s) from its name (bump_10: 10)."""
    return float(scene.rsplit("_", 1)[1])


def counts(system, former, scenes, speeds) -> None:
    """The step counts of both builds, per run and summed, with the ratios current / former."""
    total = {label: dict.fromkeys(KEYS, 0) for label in ("current", "former")}
    print(f"{'run':<18}{'':>9}{'steps':>8}{'rejected':>10}{'rhs':>8}{'events':>8}")
    for scene in scenes:
        for dv in (0.0, *[s for d in speeds for s in (-d, d)]):
            params = {"v": speed_of(scene) + dv} if dv else {}
            runs = {"current": system.simulate(scene, params=params, **DOPRI5_FORMER).metadata["stats"],
                    "former": simulate_with(system, scene, former[scene], params=params,
                                            **DOPRI5_FORMER).metadata["stats"]}
            label = scene if not dv else f"{scene} v{dv:+.1f}"
            for which in ("former", "current"):
                s = runs[which]
                for key in KEYS:
                    total[which][key] += s[key]
                print(f"{label if which == 'former' else '':<18}{which:>9}" + "".join(
                    f"{s[key]:>{w}d}" for key, w in zip(KEYS, (8, 10, 8, 8))))
            now, was = runs["current"], runs["former"]
            print(f"{'':<18}{'ratio':>9}{now['nsteps'] / was['nsteps']:>8.3f}"
                  f"{now['nreject'] / max(1, was['nreject']):>10.3f}{now['nfev'] / was['nfev']:>8.3f}")
    now, was = total["current"], total["former"]
    print(f"{'all runs':<18}{'former':>9}" + "".join(f"{was[k]:>{w}d}" for k, w in zip(KEYS, (8, 10, 8, 8))))
    print(f"{'':<18}{'current':>9}" + "".join(f"{now[k]:>{w}d}" for k, w in zip(KEYS, (8, 10, 8, 8))))
    print(f"{'':<18}{'ratio':>9}{now['nsteps'] / was['nsteps']:>8.3f}{now['nreject'] / was['nreject']:>10.3f}"
          f"{now['nfev'] / was['nfev']:>8.3f}")


def kind(name: str, rising: bool) -> str:
    """The force law an indicator's switch belongs to and its comparison, from its name, and the direction."""
    found = re.match(r"\S+ \((\S+) in ", name)
    for key, label in (("radial.contact", "tyre contact"), ("leaf_spring", "leaf spring stop"),
                       ("damper", "damper kink"), ("prescribed", "steering rack")):
        if key in name:
            return f"{label} {found.group(1) if found else ''} {'rising' if rising else 'falling'}"
    return name


def where(scene: str, former: bool, former_flags=FORMER_FLAGS, former_label=FORMERS["steps"][1]) -> None:
    """--where: the trace build's rejections, by steps since the last restart and by the events before them."""
    flags = TRACE_FLAGS + (former_flags if former else ())
    done = subprocess.run([sys.executable, "-c", TRACE_CHILD, str(MODEL), scene, *flags], capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise SystemExit(f"trace run failed:\n{done.stderr[-2000:]}")
    out = done.stdout.splitlines()
    names = out[:-1]
    nsteps, nreject, nfev, nevents = (int(v) for v in out[-1].split()[1:])
    since = None  # accepted steps since the last restart in C (None: none yet in this solver)
    fired = ""
    attempts, rejected = collections.Counter(), collections.Counter()
    first_by, runs = collections.Counter(), collections.Counter()
    restarts = solvers = handbacks = resumes = run = 0
    used, last_step = [], None
    for line in done.stderr.split("BEGIN\n", 1)[1].splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] in ("RESTART", "RESUME"):  # a restart in C, or a new solver going on from a handed-back event
            restarts += words[0] == "RESTART"
            resumes += words[0] == "RESUME"
            since = 0
            fired = ", ".join(sorted({kind(names[int(w[:-1])], w[-1] == "+")
                                      for w in words[words.index("fired") + 1:]}))
            if last_step is not None and words[0] == "RESTART":  # the step the event cut short: its share used
                used.append((float(words[1]) - last_step[0]) / last_step[1])
        elif words[0] == "INIT":
            solvers += 1
            since = None
        elif words[0] == "HANDBACK":
            handbacks += 1
        elif words[0] == "STEP":
            ok = words[4] == "1"
            last_step = (float(words[1]), float(words[2])) if ok else last_step
            key = "before any restart" if since is None else min(since, 5)
            attempts[key] += 1
            if not ok:
                rejected[key] += 1
                run += 1
                if since == 0:
                    first_by[fired] += 1
            else:
                if run:
                    runs[run] += 1
                run = 0
                if since is not None:
                    since += 1
    total = sum(rejected.values())
    label = former_label if former else "current"
    print(f"\n{scene}, {label}: {nsteps} steps, {nreject} rejected, {nfev} rhs, {nevents} events; "
          f"{restarts} restarts in C, {solvers} solver(s) started ({handbacks // 2} events handed back to Python, "
          f"{resumes} runs going on from them)")
    print(f"  rejected steps cost {STAGES * total} rhs ({STAGES * total / nfev:.1%}); the restarts' own f "
          f"{restarts} rhs ({restarts / nfev:.1%})")
    print(f"  the steps an event cut short: on average {np.mean(used):.2f} of each used (the rest, "
          f"{STAGES * (len(used) - np.sum(used)):.0f} rhs or {STAGES * (len(used) - np.sum(used)) / nfev:.1%}, "
          "integrated past the event on the old branch)")
    print("  attempts and rejections by accepted steps since the last restart (0: its first step):")
    for key in ["before any restart", 0, 1, 2, 3, 4, 5]:
        if attempts[key]:
            label = f"{key}" if key != 5 else "5 or more"
            print(f"    {label:<20} {attempts[key]:6d} attempts {rejected[key]:5d} rejected "
                  f"({rejected[key] / attempts[key]:.1%}; {STAGES * rejected[key] / nfev:.1%} of the rhs)")
    print("  first steps rejected, by the events of their restart:")
    for key, count in first_by.most_common():
        print(f"    {count:4d}  {key}")
    print("  runs of rejections in a row (length: how many): "
          + ", ".join(f"{length}: {count}" for length, count in sorted(runs.items())))


def accuracy(system, former, scenes) -> None:
    """--accuracy: both runs against a reference, DOPRI5 at rtol 1e-11."""
    print(f"\nlargest difference per run against the scene with {described(REFERENCE)} (relative to a column's "
          "largest magnitude, absolute below 1):")
    for scene in scenes:
        reference = system.simulate(scene, **REFERENCE)
        runs = {"current": system.simulate(scene, **DOPRI5_FORMER),
                "former": simulate_with(system, scene, former[scene], **DOPRI5_FORMER)}
        gaps = {}
        for which, run in [*runs.items(), ("current - former", None)]:
            worst, column = 0.0, ""
            for name in reference.names:
                if name == "t":
                    continue
                a = runs["current"][name] if run is None else run[name]
                b = runs["former"][name] if run is None else reference[name]
                if len(a) != len(b):
                    continue
                gap = float(np.max(np.abs(a - b))) / max(1.0, float(np.max(np.abs(b))))
                if gap > worst:
                    worst, column = gap, name
            gaps[which] = (worst, column)
        print(f"  {scene}: current {gaps['current'][0]:.2e} ({gaps['current'][1]}), former {gaps['former'][0]:.2e} "
              f"({gaps['former'][1]}), ratio {gaps['current'][0] / gaps['former'][0]:.2f}; current - former "
              f"{gaps['current - former'][0]:.2e} ({gaps['current - former'][1]})")


def instructions(scenes, former_flags=FORMER_FLAGS) -> None:
    """--instructions: callgrind's count of one run's integration, both builds (bench/event_instructions.py)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import event_instructions as counting
    print("\ninstructions of one run's integration (Solver.sample, callgrind; its libm differs from the machine's in "
          "the last bits, so its step counts a little too):")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            found = {}
            for label, flags in (("current", ()), ("former", former_flags)):
                subprocess.run([sys.executable, "-c", counting.MACHINERY_CHILD, str(MODEL), scene, *flags],
                               check=True, capture_output=True)  # the build, outside valgrind
                found[label] = counting.integration_instructions(scene, flags, Path(tmp))
            now, was = found["current"], found["former"]
            print(f"  {scene}: current {now['integration'] / 1e6:9.1f} M ({now['rhs calls']} rhs), former "
                  f"{was['integration'] / 1e6:9.1f} M ({was['rhs calls']} rhs), ratio "
                  f"{now['integration'] / was['integration']:.3f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10", "anti_5", "anti_10"])
    parser.add_argument("--speeds", nargs="*", type=float, default=[],
                        help="also run each scene at v +- these offsets (m/s)")
    parser.add_argument("--where", action="store_true", help="where the rejections are (trace builds)")
    parser.add_argument("--accuracy", action="store_true", help="both runs against a DOPRI5 reference at rtol 1e-11")
    parser.add_argument("--instructions", action="store_true", help="callgrind counts of the integration")
    parser.add_argument("--former", choices=sorted(FORMERS), default="steps",
                        help="the baseline: the former retry (steps) or the former hand-back (handback)")
    args = parser.parse_args(argv)
    import mbs
    system = mbs.load(MODEL)
    flags, label = FORMERS[args.former]
    former = {scene: flagged_build(system, scene, flags) for scene in args.scenes}
    print(f"Iltis scenes, {described()} (the bump scenes' settings before adams, set explicitly): the current build "
          f"against {label}, same run")
    counts(system, former, args.scenes, args.speeds)
    if args.where:
        for scene in args.scenes:
            for was in (True, False):
                where(scene, was, flags, label)
    if args.accuracy:
        accuracy(system, former, args.scenes)
    if args.instructions:
        if subprocess.run(["which", "valgrind"], capture_output=True).returncode != 0:
            print("valgrind is not on the PATH: no instructions counted")
        else:
            instructions(args.scenes, flags)
    return 0


if __name__ == "__main__":
    sys.exit(main())
