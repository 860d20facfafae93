"""Work against precision of Adams (c/adams.c) and DOPRI5 on the Iltis bump scenes, in one run.

    python bench/adams.py [--cases bump_5 bump_10 quarter_5 quarter_10] [--rtols 1e-6 1e-7 1e-8 1e-9]
        [--adams-rtols ...] [--repeat 3] [--variants]
    python bench/adams.py --whole [--repeat 7] [--adams-rtols R R] [--pece-rtols R R]

Per case (a scene of library/iltis/vehicle.mbs or quarter_car.mbs, started as `System.start` starts it): a reference
with DOPRI5 at rtol 1e-11 (atol 1e-13, as bench/integrators.py), then dopri5 and adams over the tolerance ladder
(atol = rtol / 100, the scenes' ratio), interleaved per tolerance, each run's right-hand sides, steps, rejected
steps, integration wall time (median of --repeat, every run of the case interleaved per round; `mbs.runtime.simulate`
without outputs) and its error against the
reference on the scene's sample grid (the rows at events left out): the weighted RMS norm of runtime/accuracy.py
per sample (|x - x_ref| / (1e-2 + |x_ref|)), its largest over the samples (`max`: on bump_10 one sample beside a
leaf spring's stop decides it) and its median (`median`).

Then, per error measure, what adams costs at the accuracy dopri5 reaches at rtol 1e-7 (atol 1e-9: the bump scenes'
settings before they moved to adams, bench/dopri5_former.py DOPRI5_FORMER, always in dopri5's ladder): its rhs calls
and wall time interpolated log-log between the two adams runs whose errors bracket dopri5's, and their ratios to
dopri5's at 1e-7 (below 1: adams is cheaper).  `--variants` also runs the restart variants of c/adams.c over the
same ladder, each with its cost at dopri5's accuracy: the model built with -DADAMS_RESTART=0 (forget the history at
an event, start at order 1, as CVODE), -DADAMS_RESTART=2 (re-evaluate it with the new branch) and
-DADAMS_RESTART_ORDER=12 (keep it at the order it had), against the default (keep it, order 3 at most); and the
former growth limit of the step, -DADAMS_MAX_GROWTH=2 (3 now); the final evaluation's variants, -DADAMS_PECE_FORMER=1
(pece: f evaluated again at every accepted state, the former build) and -DADAMS_PECE=0 (pec: never), against the
default (skipped while h L is small, c/adams.c).

`--whole`: instead, the whole `System.simulate` of the vehicle's bump scenes (or `--scenes`; the start from scratch, equilibrium,
integration, every output) with dopri5 at the scenes' former settings (rtol 1e-7, atol 1e-9, DOPRI5_FORMER) and with
adams at the scene's own (adams since the scenes moved to it), CPU time of this process, interleaved, medians of
--repeat, their ratio and real-time factors, where the work-precision figures above compare at equal accuracy.
`--adams-rtols R [R ...]`: adams at these rtols instead (atol R / 100; one per scene, bump_5's first, or one for
both), each run's errors against the reference printed beside (the measures above): the whole simulate at equal
accuracy.  `--pece-rtols R [R ...]`: also adams built -DADAMS_PECE_FORMER=1 (PECE throughout, the former build) at
these rtols, interleaved, with the ratio adams / adams PECE; both adams runs then on models built in one piece.

    python bench/adams.py --instructions [--cases bump_10] [--adams-rtols R] [--former] [--pece-rtols R] [--baseline REV]

`--instructions`: the integration of one run (`Solver.sample`) counted in instructions under valgrind's callgrind
(load-independent), split by part: the rhs calls, the projection of the accepted steps, the indicators (`mbs_events`,
at the steps' ends, in the root finding, at the restarts), the root finding's own work, the restarts' own, and the
method's own (its steps' arithmetic, the dense output at the samples, the rest), each also per accepted step; dopri5
at the scenes' former settings (rtol 1e-7, atol 1e-9) and adams at the scene's own, adams at --adams-rtols
(atol / 100) when given, with --former adams built with -DADAMS_STEP_FORMER=1 (its step's loops scalar, the
whole chain of differences updated every step: the same bits), with --pece-rtols R [R ...] adams built
-DADAMS_PECE_FORMER=1 (f evaluated again at every accepted state) at each R, with --baseline REV adams of the checkout
of git revision REV (exported as bench/driver_instructions.py exports it) at the scene's settings, and the ratios of
the integration and the method's own part to it.
valgrind's libm rounds a little differently, so its step counts may differ by a few from a run's own.

Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build
from mbs.runtime.backends import CBackend
from mbs.runtime.simulate import output_times, simulate
from mbs.runtime.workspace import Workspace

sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the bump scenes' settings before they moved to adams: dopri5's side of every comparison here
from dopri5_former import DOPRI5_FORMER  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASES = {
    # name: (file, scene)
    "bump_5": ("library/iltis/vehicle.mbs", "bump_5"),
    "bump_10": ("library/iltis/vehicle.mbs", "bump_10"),
    "quarter_5": ("library/iltis/quarter_car.mbs", "bump_5"),
    "quarter_10": ("library/iltis/quarter_car.mbs", "bump_10"),
}
REFERENCE_RTOL, REFERENCE_ATOL = 1e-11, 1e-13
ATOL_RATIO = 1e-2
#: the weight's floor of runtime/accuracy.py's error norm
WEIGHT_FLOOR = 1e-2
#: the restart variants of c/adams.c: label -> (build flag, what it does); the default keeps the history at order 3
VARIANTS = {"afresh": ("-DADAMS_RESTART=0", "the history forgotten, order 1 from the event (CVODE's way)"),
            "re-eval": ("-DADAMS_RESTART=2", "the history re-evaluated with the new branch"),
            "uncapped": ("-DADAMS_RESTART_ORDER=12", "the history kept at the order it had"),
            "growth2": ("-DADAMS_MAX_GROWTH=2", "the step grown by 2 at most, as before (3 now)"),
            "pece": ("-DADAMS_PECE_FORMER=1", "f evaluated again at every accepted state, as before (PECE)"),
            "pec": ("-DADAMS_PECE=0", "f never evaluated again (PEC)")}


@dataclasses.dataclass
class Run:
    integrator: str
    rtol: float
    nfev: int
    nsteps: int
    nreject: int
    events: int
    wall: float
    errors: dict  # measure -> error
    status: str


def run(model, start, settings, integrator, rtol, atol):
    """(wall time, results) of one integration from the start workspace, without outputs."""
    work = Workspace(model)
    work.p, work.t, work.x = start.p, start.t, start.x.copy()
    began = time.perf_counter()
    res = simulate(model, work, settings["t_end"], sample=settings.get("sample"), integrator=integrator, rtol=rtol,
                   atol=atol, max_steps=2_000_000, outputs=False)
    return time.perf_counter() - began, res


def states_at(model, res, times) -> np.ndarray:
    """The states at the sample times (a run with events has rows at its events between them)."""
    t = np.asarray(res["time"])
    on = np.flatnonzero(np.isin(t, times))
    _, first = np.unique(t[on], return_index=True)
    rows = on[first]
    if rows.size != times.size:
        return np.full((times.size, model.nx), np.nan)
    return np.column_stack([np.asarray(res[n])[rows] for n in model.x_names])


def errors(x, ref) -> dict:
    norm = np.sqrt(np.mean(((x - ref) / (WEIGHT_FLOOR + np.abs(ref))) ** 2, axis=1))
    return {"max": float(np.max(norm)), "median": float(np.median(norm))}


def ladder(configurations, start, settings, times, ref, repeat) -> list[Run]:
    """Every configuration (label, compiled model, integrator, rtol), interleaved per round so that the load of a
    shared machine hits them alike."""
    walls = {key: [] for key in configurations}
    last = {}
    for _ in range(repeat):
        for key in configurations:
            _, model, integrator, rtol = key
            wall, last[key] = run(model, start, settings, integrator, rtol, ATOL_RATIO * rtol)
            walls[key].append(wall)
    runs = []
    for key in configurations:
        label, model, _, rtol = key
        res, st = last[key], last[key].metadata["stats"]
        runs.append(Run(label, rtol, st["nfev"], st["nsteps"], st["nreject"], st.get("nevents", 0),
                        statistics.median(walls[key]), errors(states_at(model, res, times), ref),
                        res.metadata["status"]))
    return runs


def at_accuracy(runs: list[Run], target: float, measure: str):
    """(rhs calls, wall, exact) interpolated log-log at error `target` between the two runs that bracket it; when
    every run is more accurate than that, the cheapest run's (an upper bound, exact False); else None."""
    points = sorted((r.errors[measure], r.nfev, r.wall) for r in runs if r.status == "finished"
                    and r.errors[measure] > 0 and math.isfinite(r.errors[measure]))
    for (e1, n1, w1), (e2, n2, w2) in zip(points, points[1:]):
        if e1 <= target <= e2 and e2 > e1:
            s = math.log(target / e1) / math.log(e2 / e1)
            return (math.exp(math.log(n1) + s * math.log(n2 / n1)), math.exp(math.log(w1) + s * math.log(w2 / w1)),
                    True)
    if points and points[-1][0] <= target:
        cheapest = min(points, key=lambda point: point[1])
        return cheapest[1], cheapest[2], False
    return None


def variant_model(system, scene, model, flags: tuple[str, ...] = ()):
    """The scene's compiled model built in one piece with the flags (every run of a case takes such a build: the
    scene's own build may be split into units with other optimisation flags, which changes the cost of a rhs)."""
    code = system.generate(scene).c_source
    return dataclasses.replace(model, backend=CBackend(build.load(build.build(code, extra_flags=flags))))


def bench(name, rtols, adams_rtols, repeat, variants) -> None:
    path, scene = CASES[name]
    system = mbs.load(ROOT / path)
    start, settings = system.start(scene)
    model = variant_model(system, scene, start.model)
    times = output_times(float(start.t), settings["t_end"], sample=settings.get("sample"))
    ref_wall, reference = run(model, start, settings, "dopri5", REFERENCE_RTOL, REFERENCE_ATOL)
    ref = states_at(model, reference, times)
    scene_rtol, dopri5_rtol = settings["rtol"], DOPRI5_FORMER["rtol"]
    print(f"\n{name} ({path}, scene {scene}; {settings['t_end']:g} s, {times.size} samples; the scene's "
          f"{settings['integrator']} rtol {scene_rtol:g}); reference dopri5 rtol {REFERENCE_RTOL:g}: "
          f"{reference.metadata['stats']['nfev']} rhs, {ref_wall:.2f} s")
    ladders = {"dopri5": sorted(set(rtols) | {dopri5_rtol}), "adams": sorted(set(adams_rtols) | {scene_rtol})}
    builds = [("adams", model)] + [(label, variant_model(system, scene, model, tuple(flag.split())))
                                   for label, (flag, _) in (VARIANTS.items() if variants else ())]
    labels = [label for label, _ in builds]
    configurations = [("dopri5", model, "dopri5", r) for r in ladders["dopri5"]]
    configurations += [(label, built, "adams", r) for label, built in builds for r in ladders["adams"]]
    runs = ladder(configurations, start, settings, times, ref, repeat)
    print(f"  {'integrator':<10} {'rtol':>7} {'rhs':>7} {'steps':>6} {'rej':>5} {'events':>6} {'wall [ms]':>9} "
          f"{'max':>9} {'median':>9}  status")
    for r in runs:
        print(f"  {r.integrator:<10} {r.rtol:>7.0e} {r.nfev:>7} {r.nsteps:>6} {r.nreject:>5} {r.events:>6} "
              f"{r.wall * 1e3:>9.1f} {r.errors['max']:>9.2e} {r.errors['median']:>9.2e}  {r.status}")
    if variants:
        described = (f"{k}: {flag}, {what}" for k, (flag, what) in VARIANTS.items())
        print("  (adams: the default build; " + "; ".join(described) + ")")
    base = next(r for r in runs if r.integrator == "dopri5" and r.rtol == dopri5_rtol)
    for measure in ("max", "median"):
        target = base.errors[measure]
        print(f"  at dopri5's {measure} error at rtol {dopri5_rtol:g} (the bump scenes' former setting; "
              f"{target:.2e}; {base.nfev} rhs, "
              f"{base.wall * 1e3:.1f} ms):")
        for label in labels:
            found = at_accuracy([r for r in runs if r.integrator == label], target, measure)
            if found is None:
                print(f"    {label:<10} no two runs bracket it")
                continue
            nfev, wall, exact = found
            bound = "" if exact else " (at most: its loosest run is more accurate)"
            print(f"    {label:<10} {nfev:7.0f} rhs, {wall * 1e3:6.1f} ms: rhs ratio {nfev / base.nfev:.2f}, "
                  f"wall ratio {wall / base.wall:.2f}{bound}")


def whole(repeat: int, adams_rtols: list[float] | None, scenes=("bump_5", "bump_10"),
          pece_rtols: list[float] | None = None) -> None:
    """The whole simulate of the vehicle's scenes (bump_5 and bump_10 unless --scenes) with dopri5 at the bump
    scenes' former settings and adams at the scene's own or at `adams_rtols` (see the docstring); with `pece_rtols`
    also adams built -DADAMS_PECE_FORMER=1 at those rtols, and both adams runs on models built in one piece."""
    sys.path.insert(0, TESTS_RUNTIME)
    from former_builds import flagged_build, simulate_with
    system = mbs.load(ROOT / "library/iltis/vehicle.mbs")
    for number, scene in enumerate(scenes):
        tolerances = {"dopri5": {k: DOPRI5_FORMER[k] for k in ("rtol", "atol")}, "adams": {}}
        if adams_rtols:
            rtol = adams_rtols[min(number, len(adams_rtols) - 1)]
            tolerances["adams"] = {"rtol": rtol, "atol": ATOL_RATIO * rtol}
        models = {"dopri5": None, "adams": None}
        if pece_rtols:
            rtol = pece_rtols[min(number, len(pece_rtols) - 1)]
            tolerances["pece"] = {"rtol": rtol, "atol": ATOL_RATIO * rtol}
            models["adams"] = flagged_build(system, scene, ())
            models["pece"] = flagged_build(system, scene, ("-DADAMS_PECE_FORMER=1",))

        def simulate_one(key):
            integrator = "dopri5" if key == "dopri5" else "adams"
            if models[key] is None:
                return system.simulate(scene, integrator=integrator, **tolerances[key])
            return simulate_with(system, scene, models[key], integrator=integrator, **tolerances[key])
        cpu = {key: [] for key in models}
        runs = {}
        for key in cpu:  # compiled and warm before the clock
            simulate_one(key)
        for _ in range(repeat):
            for key in cpu:
                system.forget_starts()  # every run a first start: the equilibrium counted
                started = time.process_time()
                runs[key] = simulate_one(key)
                cpu[key].append(time.process_time() - started)
        simulated = float(runs["dopri5"].t[-1] - runs["dopri5"].t[0])
        med = {key: statistics.median(cpu[key]) for key in cpu}
        d, a = med["dopri5"], med["adams"]
        rtols = {k: runs[k].metadata.get("rtol", tolerances[k].get("rtol")) for k in cpu}
        print(f"{scene}: whole simulate, CPU, medians of {repeat}: dopri5 rtol {rtols['dopri5']:g} {d * 1e3:.1f} ms "
              f"({simulated / d:.1f}x real time), adams rtol {rtols['adams']:g} {a * 1e3:.1f} ms "
              f"({simulated / a:.1f}x); adams / dopri5 {a / d:.2f}")
        if pece_rtols:
            f = med["pece"]
            print(f"  adams PECE (-DADAMS_PECE_FORMER=1) rtol {rtols['pece']:g} {f * 1e3:.1f} ms ({simulated / f:.1f}x); "
                  f"adams / adams PECE {a / f:.2f}")
        if adams_rtols or pece_rtols:
            start, settings = system.start(scene)
            model = start.model
            times = output_times(float(start.t), settings["t_end"], sample=settings.get("sample"))
            _, reference = run(model, start, settings, "dopri5", REFERENCE_RTOL, REFERENCE_ATOL)
            ref = states_at(model, reference, times)
            for key in cpu:
                e = errors(states_at(model, runs[key], times), ref)
                st = runs[key].metadata["stats"]
                print(f"  {key:<7} rtol {rtols[key] or settings['rtol']:g}: {st['nfev']} rhs, "
                      f"{st['nsteps']} steps; error against dopri5 at rtol {REFERENCE_RTOL:g}: max {e['max']:.2e}, "
                      f"median {e['median']:.2e}")


#: The tests' helpers (tests/runtime/former_builds.py: install_flagged_build), for the child processes
TESTS_RUNTIME = str(Path(__file__).resolve().parent.parent / "tests" / "runtime")

#: The child of --instructions: one simulate of a case's scene with an integrator and tolerances, its model built in
#: one piece with the flags given; callgrind collects inside Solver.sample only.
INSTRUCTIONS_CHILD = f"TESTS_RUNTIME = {TESTS_RUNTIME!r}\n" + """
import sys
from pathlib import Path
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, integrator, rtol, flags = Path(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4], tuple(sys.argv[5:])
system = mbs.load(path)
install_flagged_build(system, scene, flags)
tolerances = {} if rtol == "scene" else {"rtol": float(rtol), "atol": float(rtol) * %r}
stats = system.simulate(scene, integrator=integrator, **tolerances).metadata["stats"]
print("STATS", stats["nsteps"] - stats["nreject"], stats["nfev"], stats["nreject"])
""" % ATOL_RATIO


def instruction_parts(path: Path, total: int) -> dict[str, float]:
    """The integration's instructions by part (see the docstring), from a callgrind output file."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from event_instructions import PROJECT_NAMES, RESTART, RHS_NAMES, ROOT_FINDER, profile
    _, pairs = profile(path)

    def calls(callers, callees) -> tuple[int, int]:  # calls into callees from callers (any but themselves)
        found = [v for (a, b), v in pairs.items()
                 if (callers is None or a in callers) and b in callees and a not in callees]
        return sum(v[0] for v in found), sum(v[1] for v in found)
    rhs, rhs_restarts = calls(None, RHS_NAMES), calls(RESTART, RHS_NAMES)
    projection = calls(("mbs_ode_accept",), PROJECT_NAMES)
    indicators = calls(None, ("mbs_events",))
    at = {"ends": calls(("mbs_ode_find_event",), ("mbs_events",)), "roots": calls(ROOT_FINDER, ("mbs_events",)),
          "restarts": calls(RESTART, ("mbs_events",))}
    parts = {"integration": (0, total), "rhs": rhs, "rhs at restarts": rhs_restarts, "projection": projection,
             "indicators": indicators, "indicators at ends": at["ends"], "indicators in roots": at["roots"],
             "indicators at restarts": at["restarts"],
             "root finding": (0, calls(None, ROOT_FINDER)[1] - at["roots"][1]),
             "restarts": (0, calls(None, RESTART)[1] - rhs_restarts[1] - at["restarts"][1])}
    parts["method"] = (0, total - sum(parts[k][1] for k in ("rhs", "projection", "indicators", "root finding",
                                                             "restarts")))
    return parts


def instructions(cases, adams_rtols, former: bool, pece_rtols=None, baseline: str | None = None) -> None:
    """--instructions: the integration's instructions by part (see the docstring)."""
    for name in cases:
        path, scene = CASES[name]
        runs = [("dopri5", "dopri5", repr(DOPRI5_FORMER["rtol"]), ()), ("adams", "adams", "scene", ())]
        if former:
            runs.append(("adams former", "adams", "scene", ("-DADAMS_STEP_FORMER=1",)))
        runs += [(f"adams {r:g}", "adams", repr(r), ()) for r in adams_rtols or ()]
        runs += [(f"PECE {r:g}", "adams", repr(r), ("-DADAMS_PECE_FORMER=1",)) for r in pece_rtols or ()]
        if baseline:
            runs.append((f"adams {baseline}", "adams", "scene", ()))
        counts = {}
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ)
            if baseline:
                sys.path.insert(0, str(Path(__file__).resolve().parent))
                from driver_instructions import export
                (Path(tmp) / "baseline").mkdir()
                checkout = export(baseline, Path(tmp) / "baseline")
            for label, integrator, rtol, flags in runs:
                if baseline and label == f"adams {baseline}":  # mbs imported from the checkout
                    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(checkout), os.environ.get("PYTHONPATH")]))
                child = [sys.executable, "-c", INSTRUCTIONS_CHILD, str(ROOT / path), scene, integrator, rtol, *flags]
                # the build, outside valgrind (run from tmp: python -c imports mbs from the working directory first)
                subprocess.run(child, check=True, capture_output=True, env=env, cwd=tmp)
                out = Path(tmp) / "callgrind.out"
                done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no",
                                       "--toggle-collect=solver_sample", f"--callgrind-out-file={out}", *child],
                                      capture_output=True, text=True, env=env, cwd=tmp)
                total = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
                stats = re.search(r"^STATS (\d+) (\d+) (\d+)$", done.stdout, re.M)
                if done.returncode != 0 or not total or not stats:
                    raise SystemExit(f"valgrind run failed ({label}):\n{done.stderr[-2000:]}")
                counts[label] = (instruction_parts(out, int(total.group(1))), *map(int, stats.groups()))
        print(f"\n{name} ({path}, scene {scene}): instructions of one run's integration (Solver.sample, callgrind), "
              f"by part, and per accepted step")
        print("  " + f"{'part':<24}" + "".join(f"{label:>24}" for label, *_ in runs))
        print("  " + f"{'accepted steps, rhs, rej':<24}"
              + "".join(f"{f'{c[1]} {c[2]} {c[3]}':>24}" for c in counts.values()))
        for key in ("integration", "rhs", "rhs at restarts", "projection", "indicators", "indicators at ends",
                    "indicators in roots", "indicators at restarts", "root finding", "restarts", "method"):
            cells = []
            for parts, accepted, _, _ in counts.values():
                number, cost = parts[key]
                count = f" {number:6d}" if number else " " * 7
                cells.append(f"{cost / 1e6:7.1f}M {cost / max(1, accepted):7.0f}{count}")
            print("  " + f"{key:<24}" + "".join(f"{cell:>24}" for cell in cells))
        base = counts["dopri5"][0]["integration"][1]
        print("  integration / dopri5's: " + ", ".join(
            f"{label} {c[0]['integration'][1] / base:.3f}" for label, c in counts.items() if label != "dopri5"))
        if former:
            now, was = (counts[label][0]["integration"][1] for label in ("adams", "adams former"))
            print(f"  adams / adams former: {now / was:.3f}")
        if baseline:
            print(f"  adams / adams {baseline}: " + ", ".join(
                f"{key} {counts['adams'][0][key][1] / counts[f'adams {baseline}'][0][key][1]:.3f}"
                for key in ("integration", "method", "root finding", "restarts")))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--rtols", nargs="+", type=float, default=[1e-6, 1e-7, 1e-8, 1e-9])
    parser.add_argument("--adams-rtols", nargs="+", type=float, default=[1e-6, 1e-7, 1e-8, 1e-9, 1e-10])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--variants", action="store_true", help="also the restart variants of c/adams.c")
    parser.add_argument("--whole", action="store_true", help="the whole simulate of the vehicle's bump scenes instead")
    parser.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"], help="--whole: the vehicle's scenes")
    parser.add_argument("--pece-rtols", nargs="+", type=float, default=None,
                        help="--whole: also adams built -DADAMS_PECE_FORMER=1 at these rtols (one per scene); "
                        "--instructions: at each of them")
    parser.add_argument("--instructions", action="store_true",
                        help="the integration's instructions by part under callgrind instead")
    parser.add_argument("--former", action="store_true", help="--instructions: also adams built -DADAMS_STEP_FORMER=1")
    parser.add_argument("--baseline", default=None, metavar="REV",
                        help="--instructions: also adams of the checkout of git revision REV (the same-run baseline)")
    args = parser.parse_args()
    given = any(a.startswith("--adams-rtol") for a in sys.argv[1:])
    if args.whole:
        whole(args.repeat, args.adams_rtols if given else None, args.scenes, args.pece_rtols)
        return
    if args.instructions:
        instructions(args.cases if any(a.startswith("--cases") for a in sys.argv[1:]) else ["bump_10"],
                     args.adams_rtols if given else None, args.former, args.pece_rtols, args.baseline)
        return
    for name in args.cases:
        bench(name, args.rtols, args.adams_rtols, args.repeat, args.variants)


if __name__ == "__main__":
    main()
