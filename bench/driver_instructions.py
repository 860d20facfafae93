"""What Python does around the C integration of a warm Iltis bump run, counted in instructions (load-independent),
against a baseline checkout in the same run.

    python bench/driver_instructions.py [--scenes bump_5 bump_10] [--baseline REF] [--current REF] [--repeat 2]
                                        [--jobs 2] [--faults] [--cpu ROUNDS]

A warm `System.simulate(scene)` of library/iltis/vehicle.mbs spends most of its time inside the model's C: the
integration (`Solver.sample`), the results' rows (`Function.rows`: the equilibrium's difference columns, the
outputs) and single calls of model functions.  Everything else is Python and NumPy: the driver (parameters, the
workspace, the loops' assembly, the run's set-up and its results), the static equilibrium's Newton iteration
around its C calls, the events C handled booked in Python (runtime/event_loop.py replay).  bench/bump_cost.py times
the parts in CPU seconds, which wander with the machine's load; this counts them.

One child process per checkout, scene and part runs under valgrind's callgrind (needs `valgrind`, `callgrind_control`
and `callgrind_annotate` on the PATH): it loads the model (from the build cache) and runs the part twice without
instrumentation, switches it on (callgrind_control -i on), then runs the part --repeat times inside
`functools.reduce`, the only C function callgrind collects in (--toggle-collect), so that the count holds those calls
and nothing else.  The parts: `simulate` (the whole `System.simulate(scene)`) and `start`
(`System.start(scene)`: the parameters, the workspace, the loops' assembly and the static equilibrium).  Printed per
call: all instructions, those inside the model's C (the inclusive counts of `solver_sample`, `function_rows` and
`function_vectorcall` of the compiled model), and the rest: Python's own (the interpreter, NumPy, LAPACK); and the
Python function calls per simulate (cProfile, outside valgrind).  The baseline is the checkout of --baseline (a
git revision, default the commit before the driver's latest cuts), exported with `git archive` into a temporary
directory and imported from there; the ratio is current over baseline (--current: a revision exported the same way
instead of the working tree, so that the tree may change while it runs).  Takes a minute or two.  Callgrind counts
a bulk copy or fill (the rows' tables, the work memory: memcpy, memset) as about one instruction a byte (a copy of
1 MB: 1.05 M), more than such a copy costs beside as many instructions of the interpreter.

--faults adds what callgrind does not see: the minor page faults and the system CPU per simulate (getrusage over 20
warm calls, one process per checkout, scene and start: a first start, and the kept one, each run's results alive
during the next; and a first start whose results are let go before the next run, as a loop over runs that keeps a
figure of each does).  A run's big arrays come
from the heap, which glibc gives back to the kernel at the run's end when its free top exceeds the trim threshold;
the next run then touches fresh pages again, a fault each.  The count depends on the run's peak memory and the
order of its allocations (deterministic for a given build and sequence of calls, not a measure of load).
--cpu ROUNDS adds the whole simulate's CPU time (time.process_time, median of 20 warm calls per child), the
checkouts' children alternating one at a time, with the median of the rounds' ratios: wall-clock noise, unlike the
counts, but the figure the real-time factor is made of.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "library" / "iltis" / "vehicle.mbs"
#: The driver before the latest cuts (the commit that work started from: the signal handlers set by _signal.signal,
#: the results' table joined when read, the gimbal check and the coordinate owners kept per System; d455a0e before the
#: replay's blocks written once, the event log's rows made when read, the crossings' masks per model, a kept start's
#: work memory copied once; c5d63d1 before the solvers' set-up and a run's memory, 0af93aa before the driver's cuts,
#: 1abfa02 before the first ones).
BASELINE = "8441331"
#: Calls per child of the parts that are not counted under callgrind (cProfile's calls, the page faults).
REPEATS = {"calls": 5, "faults": 20, "cpu": 20}
#: The functions of the compiled model's glue whose inclusive counts are the model's C (c/mbs_python.c).
MODEL_C = ("solver_sample", "function_rows", "function_vectorcall")
#: pyproject.toml's package-dir: the import names of the checkout's folders.
PACKAGE_DIRS = {"base": "base", "language": "language", "compiler": "compiler", "runtime": "runtime",
                "library": "library"}

#: The child: argv: checkout (None: the installed one), model, scene, part, repeat, "callgrind" or "calls".
CHILD = """
import cProfile, functools, os, pstats, subprocess, sys
if sys.argv[1] != "-":
    sys.path.insert(0, sys.argv[1])
import mbs
model, scene, part, repeat, how = sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), sys.argv[6]
assert mbs.__file__.startswith(sys.argv[1]) or sys.argv[1] == "-", mbs.__file__
system = mbs.load(model)
first = getattr(system, "forget_starts", lambda: None)  # each a first start (a checkout with kept starts)
run = {"simulate": lambda: (first(), system.simulate(scene)), "start": lambda: (first(), system.start(scene)),
       "kept": lambda: system.simulate(scene),
       "dropped": lambda: (first(), system.simulate(scene), None)[2]}[part]  # (each result let go at once)
run(); run()
if how == "cpu":  # the median process CPU time of a call, after a warm-up (no valgrind)
    import statistics, time
    functools.reduce(lambda _, __: run(), range(3), None)
    spent = []
    for _ in range(repeat):
        began = time.process_time()
        run()
        spent.append(time.process_time() - began)
    print("cpu", statistics.median(spent))
elif how == "faults":  # minor page faults and system CPU per call, after a warm-up (no valgrind)
    import resource
    functools.reduce(lambda _, __: run(), range(3), None)
    before = resource.getrusage(resource.RUSAGE_SELF)
    functools.reduce(lambda _, __: run(), range(repeat), None)
    after = resource.getrusage(resource.RUSAGE_SELF)
    print("faults", (after.ru_minflt - before.ru_minflt) / repeat, (after.ru_stime - before.ru_stime) / repeat)
elif how == "callgrind":  # instrumented from here on only (valgrind --instr-atstart=no): the load runs fast
    subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], check=True, capture_output=True)
    functools.reduce(lambda _, __: run(), range(repeat), None)
else:
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(repeat):
        run()
    profile.disable()
    print("calls", pstats.Stats(profile).total_calls / repeat)
"""


def export(revision: str, into: Path) -> Path:
    """The checkout of a git revision in `into`, importable as `mbs` from there (the package's folders linked
    into mbs/ as pyproject.toml maps them)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    for name, folder in PACKAGE_DIRS.items():
        (into / "mbs" / name).symlink_to(into / folder, target_is_directory=True)
    return into


def child(tree: str, scene: str, part: str, repeat: int, how: str, workdir: Path) -> float:
    """Instructions per call inside the model's C and in all ((model C, all)), or Python calls per call."""
    args = [sys.executable, "-c", CHILD, tree, str(MODEL), scene, part, str(repeat), how]
    printed = {"cpu": r"cpu (\S+)", "faults": r"faults (\S+) (\S+)", "calls": r"calls (\S+)"}
    if how in printed:  # the figures the child prints on a line of their own
        done = subprocess.run(args, capture_output=True, text=True, cwd=workdir)
        found = re.search(printed[how], done.stdout)
        if done.returncode != 0 or not found:
            raise SystemExit(f"child failed:\n{done.stderr[-2000:]}")
        values = tuple(float(v) for v in found.groups())
        return values if how == "faults" else values[0]
    out = Path(tempfile.mkstemp(prefix="callgrind.", dir=workdir)[1])
    done = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no", "--collect-atstart=no",
                           "--toggle-collect=functools_reduce",
                           f"--callgrind-out-file={out}", *args], capture_output=True, text=True, cwd=workdir)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    annotated = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                               capture_output=True, text=True).stdout
    inside = 0
    for line in annotated.splitlines():
        match = re.match(r"\s*([\d,]+)\s.*\?\?\?:(\w+) \[.*mbs_model_", line)
        if match and match.group(2) in MODEL_C:
            inside += int(match.group(1).replace(",", ""))
    return inside / repeat, int(found.group(1)) / repeat


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    ap.add_argument("--baseline", default=BASELINE, help="git revision of the baseline checkout")
    ap.add_argument("--current", default=None, metavar="REV",
                    help="git revision to count as the current checkout (default: the working tree, as installed)")
    ap.add_argument("--repeat", type=int, default=2, help="calls counted per child")
    ap.add_argument("--jobs", type=int, default=2, help="children at once")
    ap.add_argument("--faults", action="store_true", help="also the minor page faults and system CPU per simulate "
                    "(a first start and the kept one, 20 calls after a warm-up, one process each)")
    ap.add_argument("--cpu", type=int, default=0, metavar="ROUNDS",
                    help="also the whole simulate's CPU time (a first start): ROUNDS rounds of one child per checkout, "
                         "one after the other (current, baseline, current, ...), each the median of 20 calls; the "
                         "median over the rounds and the median of the rounds' ratios")
    args = ap.parse_args(argv)
    for tool in ("valgrind", "callgrind_control", "callgrind_annotate"):
        if shutil.which(tool) is None:
            raise SystemExit(f"{tool} is not on the PATH")
    with tempfile.TemporaryDirectory(prefix="mbs-bench-driver-") as tmp:
        tmp = Path(tmp)
        (tmp / "baseline").mkdir()
        if args.current is not None:
            (tmp / "current").mkdir()
        trees = {"current": "-" if args.current is None else str(export(args.current, tmp / "current")),
                 "baseline": str(export(args.baseline, tmp / "baseline"))}
        jobs = [(label, scene, part, how) for scene in args.scenes for part in ("simulate", "start")
                for label in trees for how in ("callgrind",)]
        jobs += [(label, scene, "simulate", "calls") for scene in args.scenes for label in trees]
        if args.faults:
            jobs += [(label, scene, part, "faults") for scene in args.scenes
                     for part in ("simulate", "kept", "dropped") for label in trees]
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            futures = {job: pool.submit(child, trees[job[0]], job[1], job[2],
                                        REPEATS.get(job[3], args.repeat), job[3], tmp) for job in jobs}
            counts = {job: future.result() for job, future in futures.items()}
        cpu = {(label, scene): [] for label in trees for scene in args.scenes}
        for _ in range(args.cpu):  # one child at a time, the checkouts alternating: the same load for both
            for scene in args.scenes:
                for label in trees:
                    cpu[(label, scene)].append(child(trees[label], scene, "simulate", REPEATS["cpu"], "cpu", tmp))
    current = "current checkout" if args.current is None else args.current
    print(f"Python around the C of a warm Iltis run, instructions per call (callgrind), {current} against "
          f"{args.baseline} in the same run; Python's own: all but the model's C ({', '.join(MODEL_C)})")
    for scene in args.scenes:
        print(f"\n{scene}:")
        for part, what in (("simulate", "System.simulate (whole run)"),
                           ("start", "System.start (parameters, workspace, assembly, equilibrium)")):
            (c_now, all_now), (c_then, all_then) = (counts[(label, scene, part, "callgrind")] for label in trees)
            own_now, own_then = all_now - c_now, all_then - c_then
            print(f"  {what}: all {all_now / 1e6:.2f} M (baseline {all_then / 1e6:.2f} M); model C "
                  f"{c_now / 1e6:.2f} M ({c_then / 1e6:.2f} M); Python's own {own_now / 1e6:.2f} M against "
                  f"{own_then / 1e6:.2f} M, ratio {own_now / own_then:.2f}")
        calls_now, calls_then = (counts[(label, scene, "simulate", "calls")] for label in trees)
        print(f"  Python function calls per simulate (cProfile): {calls_now:,.0f} against {calls_then:,.0f}, ratio "
              f"{calls_now / calls_then:.2f}")
        if args.cpu:
            now, then = cpu[("current", scene)], cpu[("baseline", scene)]
            ratios = [a / b for a, b in zip(now, then)]
            print(f"  whole simulate's CPU time (a first start), median of {args.cpu} rounds: "
                  f"{1e3 * statistics.median(now):.2f} ms against {1e3 * statistics.median(then):.2f} ms, ratio of "
                  f"the rounds' {statistics.median(ratios):.3f} (rounds: {', '.join(f'{r:.3f}' for r in ratios)})")
        if args.faults:
            for part, what in (("simulate", "a first start"), ("kept", "the kept start"),
                               ("dropped", "a first start, each result let go before the next run")):
                (faults_now, sys_now), (faults_then, sys_then) = (counts[(label, scene, part, "faults")]
                                                                  for label in trees)
                print(f"  minor page faults per simulate from {what}: {faults_now:.1f} against {faults_then:.1f} "
                      f"(system CPU {1e3 * sys_now:.2f} ms against {1e3 * sys_then:.2f} ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
