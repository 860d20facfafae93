"""Where the time of the Iltis bump scenes goes, and the tree-speed bound: what is reachable at their tolerance.

    python bench/bump_cost.py [--scenes bump_5 bump_10] [--repeat 5] [--cache-dir DIR] [--former rows|lambda|kept]
                              [--no-former] [--instructions]

Per scene, the whole `System.simulate(scene)` as a user runs it (equilibrium included, results with every output;
the scene's own integrator in C at its own tolerances, printed from the results' metadata: adams since the bump
scenes moved to it), medians of --repeat runs, split by timing each part inside the same runs.  All times are
CPU seconds of this process (single-threaded, so a quiet machine's wall time): on a shared machine the wall times
of one run wander by a factor of two and more with the others' load.  The parts:

* equilibrium: `static_equilibrium` (Newton on the reduced equations);
* integration in C (`Solver.sample`: every step, projection, event location and restart that C does itself), and
  of it the right-hand side calls (the run's rhs count, whatever the method's rhs calls per step, times the cost
  per call of `loop_rhs`, timed inside C at states of the run) and everything else in the integration, per
  accepted step (the method's own arithmetic: DOPRI5's stages or Adams' predictor, corrector and differences, the
  error norm, the step size control; the projection of each accepted step, the dense output, the event indicators
  and their root finding, the restarts' bookkeeping). The split is an estimate: the cost per call is timed apart
  from the run, in a warm loop over the rows' states, and moves with the load and the caches (8 to 13 us for the
  same function on the same machine), so the line of all but the rhs swings with it; instructions do not:
  bench/adams.py --instructions counts the same split for adams and dopri5, bench/event_instructions.py
  --machinery for DOPRI5 at the former settings;
* the events C handled, booked in Python (`event_loop.replay`: records, run-time values, rows);
* outputs: the rows of the results (each projected onto the loop constraints, then its outputs with the
  reaction forces: `Function.rows`), per row;
* the Python driver: the rest (the workspace, the switches' start, the results' assembly).

Beside them, interleaved in the same rounds, the whole simulate with DOPRI5 at the bump scenes' settings before they
moved to adams (rtol 1e-7, atol 1e-9: bench/dopri5_former.py DOPRI5_FORMER), from a first start as well: the
scene change's before and after, printed with its rhs calls and the ratio scene / former settings.

Every timed run is a first start: the start states the System keeps (mbs/system.py System._kept_start) are let go
before it (System.forget_starts), so that the loops' assembly and the static equilibrium are solved in each.  Beside
them, interleaved, a run of the same scene again from the kept start (the assembly and the equilibrium skipped, the
run the same to the bit) is timed and printed as the whole simulate against a first start's, with their ratio.

The tree-speed bound is the run's rhs count times the rhs cost of bench/chain.py's open chain with as many joint
velocities as the vehicle (articulated-body recursion): the wall time of the integration if the closed-loop rhs cost
what an open tree costs and nothing else cost anything; printed as a real-time factor beside the one measured, and
the real-time factor with every other part as measured and the rhs at tree speed.  Issue 12's target is 100.

Against the former path, measured in the same run (interleaved; --no-former skips it): the same model built with
the flags of --former, printed as everything but the rhs calls, everything outside the integration and the outputs
per row, current against former, with their ratios.  --former rows (the default): -DMBS_LOOP_ROWS_FORMER=1
(c/loops.c: every row of the results projected afresh, G evaluated and factored twice for it, instead of its Newton
steps starting from the factors of the row before; the multipliers solved over the whole factors instead of block by
block; with it the multipliers' rows of M over all columns, as --former lambda).  --former lambda:
-DMBS_LOOP_LAMBDA_FORMER=1 (c/loops.c mbs_loop_lambda: the rows of M times vdot over all NV columns instead of their
structural nonzeros).  --former kept: -DMBS_LOOP_STEP_KEPT_ATOL=0 (c/loops.c: an accepted step keeps a drift of at
most 1e-13, not a hundredth of the run's smallest atol).  --instructions counts the outputs' rows instead of timing
them (valgrind's callgrind, load-independent): one child process per build calls `Function.rows` over the run's
rows (the arguments simulate passes, saved from a run) with callgrind collecting inside that call only; and a whole
simulate from a first start and from the kept start (one child each, callgrind collecting inside one simulate after
two uncounted ones).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib
import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
import mbs.system
from mbs.runtime import build, event_loop, rows as rows_module
from mbs.runtime.backends import CBackend
from mbs.runtime.guard import RunGuard
from mbs.runtime.workspace import Workspace

sys.path.insert(0, str(Path(__file__).parent))
from chain import chain_text  # noqa: E402
#: the baseline line: the bump scenes' settings before they moved to adams (DOPRI5 at rtol 1e-7, atol 1e-9)
from dopri5_former import DOPRI5_FORMER, described, scene_settings  # noqa: E402

simulate_module = importlib.import_module("mbs.runtime.simulate")  # the package exports its function

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
TARGET_RTF = 100.0
#: rounds over the run's rows that time the rhs, and calls that time the open chain's (at one state)
RHS_ROUNDS = 5
RHS_CALLS = 300
#: CPU seconds of this process: on a shared machine wall times wander with the other processes' load (this bench
#: is single-threaded: the CPU time is the wall time of a quiet machine)
clock = time.process_time
#: The former paths' builds (c/loops.c), by --former: every row projected afresh (and the multipliers' rows of M
#: whole); the multipliers' rows of M over all columns.
FORMER_FLAGS = {"rows": ("-DMBS_LOOP_ROWS_FORMER=1", "-DMBS_LOOP_LAMBDA_FORMER=1"),
                "lambda": ("-DMBS_LOOP_LAMBDA_FORMER=1",),
                "kept": ("-DMBS_LOOP_STEP_KEPT_ATOL=0",)}
#: What each former path is, for the printed comparison.
FORMER_TEXT = {"rows": "every row projected afresh", "lambda": "the multipliers' rows of M over all columns",
               "kept": "every accepted step that drifted beyond 1e-13 polished"}


class PartTimer:
    """Wraps functions (module or class attributes) so that the seconds spent inside each are summed per part;
    nested parts are not double counted because the wrapped parts do not call one another."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.saved: list = []

    def wrap(self, owner, name: str, part: str) -> None:
        real = getattr(owner, name)
        self.saved.append((owner, name, real))
        seconds = self.seconds

        def timed(*args, **kwargs):
            start = clock()
            try:
                return real(*args, **kwargs)
            finally:
                seconds[part] = seconds.get(part, 0.0) + clock() - start
        setattr(owner, name, timed)

    def restore(self) -> None:
        for owner, name, real in reversed(self.saved):
            setattr(owner, name, real)


def timed_run(system, scene: str, first_start: bool = True, **settings):
    """One whole simulate(): (wall, seconds per part, results); first_start: the System's kept start states let go
    first (mbs/system.py System._kept_start), so that the loops' assembly and the equilibrium are solved in it;
    settings: overrides of the scene's (integrator, rtol, atol), none: the scene as it is."""
    if first_start:
        system.forget_starts()
    parts = PartTimer()
    parts.wrap(mbs.system, "static_equilibrium", "equilibrium")
    real_watch = RunGuard.watch

    def watch(guard, solver):  # the guard gives each solver a sample of its own (C budgets): time that one
        real_watch(guard, solver)
        parts.wrap(solver, "sample", "integration")
    RunGuard.watch = watch
    parts.wrap(event_loop, "replay", "events booked")
    parts.wrap(simulate_module, "project_and_evaluate_rows", "outputs")
    parts.wrap(simulate_module, "evaluate_rows", "outputs")
    parts.wrap(simulate_module, "project_rows", "outputs")  # (rows projected alone: a run without outputs)
    try:
        start = clock()
        res = system.simulate(scene, **settings)
        wall = clock() - start
    finally:
        RunGuard.watch = real_watch
        parts.restore()
    return wall, parts.seconds, res


def start_times(system, scene: str, repeat: int) -> tuple[float, float]:
    """(CPU seconds of System.start(scene) from a first start, from the kept start): medians, interleaved."""
    first, kept = [], []
    for _ in range(repeat):
        system.forget_starts()
        for times in (first, kept):
            start = clock()
            system.start(scene)
            times.append(clock() - start)
    return statistics.median(first), statistics.median(kept)


def former_model(system, scene: str, flags: tuple[str, ...], cache_dir=None):
    """The scene's compiled model built with `flags` (cached like any build: slow the first time only)."""
    compiled = system.compile(scene)
    result = build.build(system.generate(scene).c_source, cache_dir=cache_dir, extra_flags=flags)
    return dataclasses.replace(compiled, backend=CBackend(build.load(result)))


@contextlib.contextmanager
def using(system, scene: str, model):
    """system.simulate(scene) runs `model` (None: the current build) inside the block."""
    if model is None:
        yield
        return
    compiled = system.compile(scene)
    keys = [key for key, value in system._compiled.items() if value is compiled]
    for key in keys:
        system._compiled[key] = model
    try:
        yield
    finally:
        for key in keys:
            system._compiled[key] = compiled


#: The child of --instructions: the built library loaded by its path, Function.rows of the outputs over the rows
#: saved (with `projected`), the call counted by callgrind (--toggle-collect=function_rows).
INSTRUCTION_CHILD = """
import importlib.util, sys
import numpy as np
library, saved = sys.argv[1], np.load(sys.argv[2])
name = library.rsplit("/", 1)[-1].split(".")[0]
spec = importlib.util.spec_from_file_location(name, library)
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
f = module.Function("outputs", saved["ps"][0].copy(), np.zeros(module.NWORK))
ts, xs, which, ps = saved["ts"], saved["xs"], saved["which"], saved["ps"]
out, projected = np.empty((len(ts), int(saved["ny"]))), np.empty_like(xs)
done = f.rows(ts, xs, out, ps, which, projected)
assert done == len(ts), done
"""


#: The child of --instructions that counts a whole simulate: argv model, scene, "first" (the kept starts let go before
#: each run) or "kept"; two runs uninstrumented, then one counted inside functools.reduce (--toggle-collect).
SIMULATE_CHILD = """
import functools, os, subprocess, sys
import mbs
system = mbs.load(sys.argv[1])
scene, first = sys.argv[2], sys.argv[3] == "first"
def run():
    if first:
        system.forget_starts()
    system.simulate(scene)
run(); run()
subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], check=True, capture_output=True)
functools.reduce(lambda _, __: run(), range(1), None)
"""


def simulate_instructions(scene: str, how: str, workdir: Path) -> int:
    """Instructions callgrind counts in one whole System.simulate(scene) of SIMULATE_CHILD (`how`: first, kept)."""
    out = workdir / f"callgrind.{how}"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no", "--collect-atstart=no",
                           "--toggle-collect=functools_reduce", f"--callgrind-out-file={out}", sys.executable, "-c",
                           SIMULATE_CHILD, str(MODEL), scene, how], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    return int(found.group(1))


def print_start_instructions(scene: str) -> None:
    """Instructions of a whole simulate from a first start and from the kept start."""
    if shutil.which("valgrind") is None or shutil.which("callgrind_control") is None:
        print("  valgrind or callgrind_control is not on the PATH: no instruction counts")
        return
    with tempfile.TemporaryDirectory(prefix="mbs-bench-start-") as tmp:
        first, kept = (simulate_instructions(scene, how, Path(tmp)) for how in ("first", "kept"))
    print(f"  a whole simulate in instructions (callgrind, Python and C): from the kept start {kept / 1e6:.1f} M, "
          f"from a first start {first / 1e6:.1f} M, ratio {kept / first:.3f}")


def saved_rows(system, scene: str, path: Path) -> int:
    """Saves the arguments simulate passes to the outputs' Function.rows for the scene (recorded from a run) into
    path (npz); returns the number of rows."""
    seen = {}
    real = rows_module.project_and_evaluate_rows

    def record(data, name, ps, ts, xs, which, projected, out):
        seen.update(ts=np.array(ts, dtype=float), xs=np.array(xs, dtype=float), which=np.array(which, dtype=np.intp),
                    ps=np.array(ps, dtype=float).reshape(len(ps), -1), ny=out.shape[1])
        return real(data, name, ps, ts, xs, which, projected, out)
    simulate_module.project_and_evaluate_rows = record
    try:
        system.simulate(scene)
    finally:
        simulate_module.project_and_evaluate_rows = real
    np.savez(path, **seen)
    return len(seen["ts"])


def row_instructions(library: str, saved: Path, workdir: Path) -> int:
    """Instructions callgrind counts inside the one Function.rows call of INSTRUCTION_CHILD."""
    out = workdir / "callgrind.rows"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=function_rows",
                           f"--callgrind-out-file={out}", sys.executable, "-c", INSTRUCTION_CHILD, library,
                           str(saved)], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    return int(found.group(1))


def print_instructions(system, scene: str, former) -> None:
    """Instructions per row of the outputs' rows, current and former build."""
    if shutil.which("valgrind") is None:
        print("  valgrind is not on the PATH: no instruction counts")
        return
    with tempfile.TemporaryDirectory(prefix="mbs-bench-rows-") as tmp:
        saved = Path(tmp) / "rows.npz"
        n = saved_rows(system, scene, saved)
        counts = {label: row_instructions(str(model.backend.module.__file__), saved, Path(tmp))
                  for label, model in (("current", system.compile(scene)), ("former", former))}
    print(f"  outputs' rows in instructions (callgrind, one Function.rows over the run's {n} rows): current "
          f"{counts['current'] / n:,.0f} per row, former {counts['former'] / n:,.0f}, ratio "
          f"{counts['current'] / counts['former']:.2f}")


def rhs_cost(system, scene: str, res) -> float:
    """CPU seconds per call of the rhs the C integrators call (`loop_rhs`, no projection) inside C, over the states of
    the run one after another (its rows, in one `Function.rows` call: no Python between them), the run-time values of
    the scene's start (a switch's branch changes which side of a kink is evaluated, not the cost).  One state
    called again and again (`time_call`) finds the caches warm and costs about two thirds of this."""
    compiled = system.compile(scene)
    from mbs import pipeline
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    data = system._workspace(compiled, system.generate(scene), values)
    f = data.function("loop_rhs")
    xs = np.column_stack([res[name] for name in compiled.x_names])
    distinct = np.r_[True, np.any(xs[1:] != xs[:-1], axis=1)]  # the rows at an event's two sides: once (rows
    ts = np.ascontiguousarray(res["time"][distinct], dtype=float)  # copies a repeated row instead of calling f)
    xs = np.ascontiguousarray(xs[distinct])
    out, ps, which = np.empty_like(xs), data.p.copy()[None, :], np.zeros(len(ts), dtype=np.intp)
    costs = []
    for _ in range(RHS_ROUNDS):
        start = clock()
        done = f.rows(ts, xs, out, ps, which)
        costs.append((clock() - start) / max(1, done))
    return statistics.median(costs)


def cpu_per_call(compiled, f, x, calls: int) -> float:
    """CPU seconds per call of f at x, called `calls` times inside C (no Python between the calls)."""
    x = np.ascontiguousarray(x, dtype=float)
    compiled.backend.time_call(f, x, 5, 0.0)  # warm
    start = clock()
    compiled.backend.time_call(f, x, calls, 0.0)
    return (clock() - start) / calls


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cache-dir", default=None)
    ap.add_argument("--former", choices=sorted(FORMER_FLAGS), default="rows", help="the former path to compare with")
    ap.add_argument("--no-former", action="store_true", help="without the former path's runs")
    ap.add_argument("--instructions", action="store_true", help="also count the outputs' rows (callgrind)")
    args = ap.parse_args(argv)
    system = mbs.load(MODEL, cache_dir=args.cache_dir)
    compiled = system.compile(args.scenes[0])
    chain = mbs.loads(chain_text(compiled.nv), cache_dir=args.cache_dir).compile()
    chain_data = Workspace(chain)
    chain_rhs = statistics.median(cpu_per_call(chain, chain_data.function("rhs"), chain.x0, 10 * RHS_CALLS)
                                  for _ in range(5))
    print(f"Iltis bump scenes as a user runs them (each scene's own integrator in C, at its own tolerances), whole "
          f"simulate() (equilibrium to results with every output), CPU time, medians of {args.repeat}; baseline: "
          f"{described()} (the bump scenes' settings before adams), interleaved; open chain of {compiled.nv} links: "
          f"rhs {chain_rhs * 1e6:.2f} us per call")
    for scene in args.scenes:
        t_end = system.scene(scene).t_end
        system.simulate(scene)  # compile and warm up
        system.simulate(scene, **DOPRI5_FORMER)
        former = None if args.no_former else former_model(system, scene, FORMER_FLAGS[args.former], args.cache_dir)
        runs, former_runs, kept_runs, dopri5_runs = [], [], [], []
        for _ in range(args.repeat):  # interleaved: the load drifts
            runs.append(timed_run(system, scene))
            dopri5_runs.append(timed_run(system, scene, **DOPRI5_FORMER))  # the scene's former settings
            kept_runs.append(timed_run(system, scene, first_start=False))  # from the start the run before kept
            if former is not None:
                with using(system, scene, former):
                    former_runs.append(timed_run(system, scene))
        res = runs[-1][2]
        stats = res.metadata["stats"]
        nfev, rows = stats["nfev"], len(res["time"])
        med = statistics.median
        wall = med(r[0] for r in runs)
        part = {name: med(r[1].get(name, 0.0) for r in runs)
                for name in ("equilibrium", "integration", "events booked", "outputs")}
        rhs = rhs_cost(system, scene, res)
        rhs_total = min(nfev * rhs, part["integration"])
        driver = max(0.0, wall - sum(part.values()))
        bound = nfev * chain_rhs
        rest_at_tree = wall - rhs_total + bound

        def line(name, seconds, note=""):
            print(f"  {name:34s} {seconds * 1e3:8.1f} ms {100 * seconds / wall:5.1f} %  {note}")
        print(f"\n{scene} ({scene_settings(res)}): {t_end:g} s simulated in {wall * 1e3:.0f} ms, real-time factor "
              f"{t_end / wall:.1f} (target {TARGET_RTF:g}); {stats['nsteps']} steps, {stats.get('nreject', 0)} "
              f"rejected, {nfev} rhs ({nfev / max(1, stats['nsteps']):.2f} per step), {stats.get('nevents', 0)} "
              f"events, {rows} rows")
        line("equilibrium", part["equilibrium"])
        line("integration in C", part["integration"])
        line("  of it rhs calls", rhs_total, f"{nfev} x {rhs * 1e6:.2f} us (loop_rhs over the run's rows)")
        accepted = max(1, stats["nsteps"] - stats.get("nreject", 0))
        line("  of it all but the rhs calls", part["integration"] - rhs_total,
             f"{(part['integration'] - rhs_total) / accepted * 1e6:.1f} us per accepted step "
             f"({res.metadata['integrator']}: the method's own arithmetic, projection, dense output, indicators, "
             f"root finding, restarts)")
        line("events booked in Python", part["events booked"])
        line("outputs", part["outputs"], f"{rows} rows, {part['outputs'] / max(1, rows) * 1e6:.1f} us per row "
             f"({part['outputs'] / max(1, rows) / rhs:.1f} rhs)")
        line("Python driver (the rest)", driver)
        print(f"  tree-speed bound: {nfev} rhs x {chain_rhs * 1e6:.2f} us (open chain) = {bound * 1e3:.1f} ms: "
              f"real-time factor {t_end / bound:.0f} with nothing else costing; {t_end / rest_at_tree:.1f} with the "
              f"other parts as measured (now {t_end / wall:.1f})")
        was = med(r[0] for r in dopri5_runs)
        was_stats = dopri5_runs[-1][2].metadata["stats"]
        print(f"  baseline, the scene's former settings ({scene_settings(dopri5_runs[-1][2])}; same run, interleaved): "
              f"whole simulate {was * 1e3:.1f} ms, real-time factor {t_end / was:.1f}; {was_stats['nsteps']} steps, "
              f"{was_stats['nfev']} rhs; the scene now / former: {wall / was:.2f} (rhs calls "
              f"{nfev / was_stats['nfev']:.2f})")
        kept = med(r[0] for r in kept_runs)
        same = all(np.array_equal(r[2].data, res.data) for r in kept_runs)
        start_first, start_kept = start_times(system, scene, 3 * args.repeat)
        print(f"  run again from the kept start (System._kept_start: no assembly, no equilibrium; the results "
              f"{'the same to the bit' if same else 'NOT THE SAME'}): whole simulate {kept * 1e3:.1f} ms against "
              f"{wall * 1e3:.1f} ms for a first start, ratio {kept / wall:.2f}, real-time factor {t_end / kept:.1f}; "
              f"System.start alone {start_kept * 1e3:.2f} ms against {start_first * 1e3:.2f} ms")
        if former is not None:
            def rest(run):  # everything but the rhs calls (their count is the same in both builds)
                return run[0] - rhs_total
            def outside(run):  # everything but the integration in C (which neither path changes): less noise
                return run[0] - run[1].get("integration", 0.0)
            now, before = med(rest(r) for r in runs), med(rest(r) for r in former_runs)
            out_c, out_f = med(outside(r) for r in runs), med(outside(r) for r in former_runs)
            out_now, out_before = (med(r[1].get("outputs", 0.0) for r in rs) / max(1, rows) for rs in (runs, former_runs))
            print(f"  against the former path ({FORMER_TEXT[args.former]}; same run, interleaved): everything but "
                  f"the rhs calls {now * 1e3:.1f} ms, former {before * 1e3:.1f} ms, ratio {now / before:.2f}; outside the "
                  f"integration {out_c * 1e3:.1f} ms, former {out_f * 1e3:.1f} ms, ratio {out_c / out_f:.2f}; "
                  f"outputs {out_now * 1e6:.1f} us per row, former {out_before * 1e6:.1f} us, ratio "
                  f"{out_now / out_before:.2f}; whole simulate {wall * 1e3:.0f} ms, former "
                  f"{med(r[0] for r in former_runs) * 1e3:.0f} ms")
            if args.instructions:
                print_instructions(system, scene, former)
        if args.instructions:
            print_start_instructions(scene)
    return 0


if __name__ == "__main__":
    sys.exit(main())
