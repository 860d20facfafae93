"""The Iltis constrained right-hand side against an open chain with the same number of joint velocities, counted
in instructions per call rather than timed (issue 12: Iltis rhs <= 3 x the open chain).

    python bench/rhs_instructions.py [--scene bump_5] [--calls 200] [--profile N] [--baseline DIR]
                                     [--simulate SCENE --repeat N]

Wall times on a shared machine wander by a factor of three between runs (bench/iltis.py printed the open chain
at 3.4 and at 10.5 us in one day); instructions executed do not depend on the load.  One child process, run
under valgrind's callgrind (needs `valgrind` on the PATH), compiles (from the cache) the vehicle and bench/chain.py's
spatial pendulum with as many links as the vehicle has joint velocities, finds the scene's static equilibrium,
and times each function inside C (`Function.time`, no Python in the loop): callgrind collects only inside that
timing loop and dumps its count after each, so the counts hold the calls and nothing else.  Each function is
called a few times first (the kept partition chosen, caches warm), then --calls times; printed per call:

* `rhs`: the right-hand side the integrators see from Python (the state projected onto the loop closure, then
  the constrained accelerations);
* `loop_rhs`: the same without the projection (the right-hand side of the C integrators, which project each
  accepted step);
* the open chain's `rhs` (articulated-body recursion of the generated code), the baseline;

with the ratios to the open chain.  --profile N also prints the N functions with the most inclusive
instructions inside the Iltis `loop_rhs` (callgrind_annotate).  --baseline DIR also counts the vehicle's `rhs` and
`loop_rhs` built with the run-time C files of DIR (a copy of another revision's runtime/c, e.g. `git archive main
runtime/c | tar -x -C /tmp/main`; its mbs_glue.c and loops.c are found there first, `-I DIR`) in the same run, and
prints the current counts against them as ratios.  With it, --simulate SCENE also times the whole
`System.simulate(SCENE)` (CPU seconds of this process, each run from a first start) with the current build and the
baseline's, interleaved --repeat times, and prints the medians and their ratio, and each run's rhs calls and
steps (so that a ratio that comes from another step sequence shows as one): a wall-time figure, unlike the
counts, so noisy on a shared machine.  Takes a minute or two (more when the models are
not in the build cache: the first run compiles them outside valgrind).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
#: Issue 12's target: the constrained rhs at most this many times the open chain's.
TARGET_RATIO = 3.0
#: The functions timed, in this order (the chain's last); with --baseline then BASELINE_FUNCTIONS.
FUNCTIONS = ("rhs", "loop_rhs", "chain rhs")
BASELINE_FUNCTIONS = ("baseline rhs", "baseline loop_rhs")

#: The child: both models compiled, each function warmed up and then timed inside C; argv: model, scene, calls,
#: warm-up calls[, the baseline's folder of run-time C files].  With 0 calls only the compile (outside valgrind, so
#: that the counts hold no build).
CHILD = """
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, sys.argv[1])
import mbs
from mbs import pipeline
from mbs.runtime.equilibrium import static_equilibrium
from mbs.runtime.workspace import Workspace
from chain import chain_text
model, scene, calls, warm = Path(sys.argv[2]), sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
baseline = sys.argv[6] if len(sys.argv) > 6 else ""
system = mbs.load(model)
compiled = system.compile(scene)
values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
data = system._workspace(compiled, system.generate(scene), values)
chain = mbs.loads(chain_text(compiled.nv)).compile()
if baseline:  # the same model with the run-time C files of the baseline's folder (found before the current ones)
    import dataclasses
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    built = build.build(system.generate(scene).c_source, extra_flags=(f"-I{baseline}",))
    base = dataclasses.replace(compiled, backend=CBackend(build.load(built)))
    base_data = system._workspace(base, system.generate(scene), values)
if warm == 0:
    sys.exit(0)
x = static_equilibrium(compiled, system._workspace(compiled, system.generate(scene), values), data.x).x
chain_data = Workspace(chain)
timed = [(data.function("rhs"), x), (data.function("loop_rhs"), x), (chain_data.function("rhs"), chain.x0)]
if baseline:
    timed += [(base_data.function("rhs"), x), (base_data.function("loop_rhs"), x)]
for f, state in timed:
    f.time(np.ascontiguousarray(state), warm, 0.0)
    f.time(np.ascontiguousarray(state), calls, 0.0)
"""


def run_child(scene: str, calls: int, warm: int, workdir: Path, functions=FUNCTIONS, baseline: str = "") -> list[Path]:
    """The callgrind dumps of the child: one per Function.time call (warm-up and timed, for each function)."""
    out = workdir / "callgrind.out"
    command = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--collect-atstart=no",
               "--toggle-collect=function_time", "--dump-after=function_time", sys.executable, "-c", CHILD,
               str(Path(__file__).resolve().parent), str(MODEL), scene, str(calls), str(warm), baseline]
    for old in workdir.glob("callgrind.out*"):
        old.unlink()
    done = subprocess.run(command, capture_output=True, text=True)
    dumps = sorted(workdir.glob("callgrind.out.*"), key=lambda p: int(p.name.rsplit(".", 1)[1]))
    if done.returncode != 0 or len(dumps) < 2 * len(functions):
        raise SystemExit(f"the valgrind run failed (status {done.returncode}, {len(dumps)} dumps):\n"
                         f"{done.stderr[-3000:]}")
    return dumps[-2 * len(functions):]


def instructions(dump: Path) -> int:
    """The instructions a callgrind dump holds (its `totals:` or `summary:` line)."""
    found = re.search(r"^(?:totals|summary):\s*(\d+)", dump.read_text(errors="replace"), re.M)
    if not found:
        raise SystemExit(f"no instruction total in {dump}")
    return int(found.group(1))


def profile(dump: Path, top: int) -> str:
    """The `top` functions of a dump by inclusive instructions (callgrind_annotate)."""
    done = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(dump)], capture_output=True, text=True)
    lines = [line for line in done.stdout.splitlines() if re.match(r"^\s*[\d,]+ \(", line)]
    return "\n".join(lines[:top])


def simulate_times(scene: str, baseline: str, repeat: int) -> None:
    """Print the CPU seconds of System.simulate(scene) with the current build and with the baseline's run-time C
    (-I baseline), interleaved `repeat` times: medians, their ratio, and each build's rhs calls and steps."""
    import dataclasses
    import statistics
    import time

    import mbs
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    system = mbs.load(MODEL)
    compiled = system.compile(scene)
    built = build.build(system.generate(scene).c_source, extra_flags=(f"-I{baseline}",))
    models = {"current": compiled, "baseline": dataclasses.replace(compiled, backend=CBackend(build.load(built)))}
    keys = [key for key, value in system._compiled.items() if value is compiled]
    seconds: dict[str, list[float]] = {name: [] for name in models}
    stats: dict[str, dict] = {}
    try:
        for _ in range(repeat):
            for name, model in models.items():
                for key in keys:
                    system._compiled[key] = model
                system.forget_starts()
                start = time.process_time()
                res = system.simulate(scene)
                seconds[name].append(time.process_time() - start)
                stats[name] = res.metadata["stats"]
    finally:
        for key in keys:
            system._compiled[key] = compiled
    current, former = statistics.median(seconds["current"]), statistics.median(seconds["baseline"])
    print(f"\nSystem.simulate({scene!r}), CPU seconds, medians of {repeat} interleaved runs:")
    for name, median in (("current", current), ("baseline", former)):
        print(f"  {name:9s} {median * 1e3:8.1f} ms   rhs calls {stats[name]['nfev']}, steps {stats[name]['nsteps']}")
    print(f"  ratio     {current / former:.3f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_5")
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--warm", type=int, default=5, help="calls of each function before the counted ones")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="print the N functions with the most inclusive instructions in the Iltis loop_rhs")
    parser.add_argument("--keep", metavar="DIR", help="keep the callgrind dumps in DIR (for callgrind_annotate)")
    parser.add_argument("--baseline", metavar="DIR", default="",
                        help="also count rhs and loop_rhs built with the run-time C files of DIR (another revision's "
                             "runtime/c), and print the ratios")
    parser.add_argument("--simulate", metavar="SCENE", default="",
                        help="with --baseline: also time System.simulate(SCENE) with both builds, interleaved")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each build for --simulate")
    args = parser.parse_args(argv)
    if args.simulate and not args.baseline:
        parser.error("--simulate needs --baseline")
    if shutil.which("valgrind") is None:
        print("valgrind is not on the PATH: nothing to count")
        return 1
    baseline = str(Path(args.baseline).resolve()) if args.baseline else ""
    functions = FUNCTIONS + (BASELINE_FUNCTIONS if baseline else ())
    subprocess.run([sys.executable, "-c", CHILD, str(Path(__file__).resolve().parent), str(MODEL), args.scene,
                    "0", "0", baseline], check=True)  # compile outside valgrind (a no-op when cached)
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(args.keep or tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        dumps = run_child(args.scene, args.calls, args.warm, workdir, functions, baseline)
        counted = dumps[1::2]  # each function's warm-up dump, then its timed one
        per_call = {name: instructions(dump) / args.calls for name, dump in zip(functions, counted)}
        chain = per_call["chain rhs"]
        print(f"Iltis ({args.scene}, at its static equilibrium) against the open chain of as many joint velocities: "
              f"instructions per call inside C (callgrind, {args.calls} calls each, load-independent)")
        print(f"  constrained rhs (projected)     {per_call['rhs']:10.0f}   {per_call['rhs'] / chain:5.2f} x the chain")
        print(f"  constrained rhs (no projection) {per_call['loop_rhs']:10.0f}   {per_call['loop_rhs'] / chain:5.2f} x "
              f"the chain (target <= {TARGET_RATIO:g} x)")
        print(f"  open chain rhs (baseline)       {chain:10.0f}")
        if baseline:
            print(f"\nAgainst the run-time C of {baseline} (same run, same model):")
            for name in ("rhs", "loop_rhs"):
                former = per_call[f"baseline {name}"]
                print(f"  {name:9s} {per_call[name]:10.0f} against {former:10.0f}   ratio {per_call[name] / former:.3f}")
        if args.profile:
            print(f"\nIltis loop_rhs, the {args.profile} functions with the most inclusive instructions "
                  f"({args.calls} calls):")
            print(profile(counted[1], args.profile))
    if args.simulate:
        simulate_times(args.simulate, baseline, args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
