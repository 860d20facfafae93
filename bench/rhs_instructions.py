"""The Iltis constrained right-hand side against an open chain with the same number of joint velocities, counted
in instructions per call rather than timed (issue 12: Iltis rhs <= 3 x the open chain).

    python bench/rhs_instructions.py [--scene bump_5] [--calls 200] [--profile N] [--baseline REF]

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
instructions inside the Iltis `loop_rhs` (callgrind_annotate).  Takes a minute or two (more when the models are
not in the build cache: the first run compiles them outside valgrind).

--baseline REF (a git commit or branch, e.g. main) counts the same functions with the compiler, runtime and
language of REF too (`git archive` into a temporary folder, imported ahead of this checkout, its own build
cache) and prints each count with its ratio to REF's, measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
#: Issue 12's target: the constrained rhs at most this many times the open chain's.
TARGET_RATIO = 3.0
#: The functions timed, in this order (the chain's last).
FUNCTIONS = ("rhs", "loop_rhs", "chain rhs")

#: The child: both models compiled, each function warmed up and then timed inside C; argv: model, scene, calls,
#: warm-up calls.  With `--prepare` only the compile (outside valgrind, so that the counts hold no build).
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
system = mbs.load(model)
compiled = system.compile(scene)
values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
data = system._workspace(compiled, system.generate(scene), values)
chain = mbs.loads(chain_text(compiled.nv)).compile()
if warm == 0:
    sys.exit(0)
x = static_equilibrium(compiled, system._workspace(compiled, system.generate(scene), values), data.x).x
chain_data = Workspace(chain)
for f, state in ((data.function("rhs"), x), (data.function("loop_rhs"), x), (chain_data.function("rhs"), chain.x0)):
    f.time(np.ascontiguousarray(state), warm, 0.0)
    f.time(np.ascontiguousarray(state), calls, 0.0)
"""


#: The packages of the repository by their folders (pyproject.toml's package-dir): a baseline's source tree is
#: imported as the package `mbs` from a folder that links them under its mbs/.
PACKAGES = ("base", "language", "compiler", "runtime", "library")


def baseline_tree(ref: str, folder: Path) -> dict:
    """The environment that makes a child import `mbs` from the repository at git `ref` (extracted into folder),
    with a build cache of its own."""
    repo = Path(__file__).resolve().parent.parent
    source = folder / "source"
    source.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(repo), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(source)], input=archive, check=True)
    package = folder / "importable" / "mbs"
    package.parent.mkdir()
    subprocess.run(["cp", "-r", str(source / "mbs"), str(package)], check=True)
    for name in PACKAGES:
        (package / name).symlink_to(source / name)
    env = dict(os.environ, PYTHONPATH=str(package.parent), MBS_CACHE_DIR=str(folder / "cache"))
    return env


def run_child(scene: str, calls: int, warm: int, workdir: Path, env: dict | None = None) -> list[Path]:
    """The callgrind dumps of the child: one per Function.time call (warm-up and timed, for each function)."""
    out = workdir / "callgrind.out"
    command = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--collect-atstart=no",
               "--toggle-collect=function_time", "--dump-after=function_time", sys.executable, "-c", CHILD,
               str(Path(__file__).resolve().parent), str(MODEL), scene, str(calls), str(warm)]
    for old in workdir.glob("callgrind.out*"):
        old.unlink()
    done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=workdir)
    dumps = sorted(workdir.glob("callgrind.out.*"), key=lambda p: int(p.name.rsplit(".", 1)[1]))
    if done.returncode != 0 or len(dumps) < 2 * len(FUNCTIONS):
        raise SystemExit(f"the valgrind run failed (status {done.returncode}, {len(dumps)} dumps):\n"
                         f"{done.stderr[-3000:]}")
    return dumps[-2 * len(FUNCTIONS):]


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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_5")
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--warm", type=int, default=5, help="calls of each function before the counted ones")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="print the N functions with the most inclusive instructions in the Iltis loop_rhs")
    parser.add_argument("--keep", metavar="DIR", help="keep the callgrind dumps in DIR (for callgrind_annotate)")
    parser.add_argument("--baseline", metavar="REF", help="count REF's build too (a git commit or branch) and print "
                        "the ratios to it")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not on the PATH: nothing to count")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        builds = [("this checkout", None)]
        if args.baseline:
            builds.append((args.baseline, baseline_tree(args.baseline, Path(tmp) / "baseline")))
        counts = {}
        for label, env in builds:
            subprocess.run([sys.executable, "-c", CHILD, str(Path(__file__).resolve().parent), str(MODEL),
                            args.scene, "0", "0"], check=True, env=env, cwd=tmp)  # compile outside valgrind
            workdir = Path(args.keep or tmp) / ("current" if env is None else "baseline")
            workdir.mkdir(parents=True, exist_ok=True)
            dumps = run_child(args.scene, args.calls, args.warm, workdir, env)
            counted = dumps[1::2]  # each function's warm-up dump, then its timed one
            counts[label] = {name: instructions(dump) / args.calls for name, dump in zip(FUNCTIONS, counted)}
            if env is None:
                loop_dump = counted[1]
                profiled = profile(loop_dump, args.profile) if args.profile else ""
        per_call = counts["this checkout"]
        chain = per_call["chain rhs"]
        print(f"Iltis ({args.scene}, at its static equilibrium) against the open chain of as many joint velocities: "
              f"instructions per call inside C (callgrind, {args.calls} calls each, load-independent)")
        base = counts.get(args.baseline)
        versus = (lambda name: f"   {base[name]:10.0f} at {args.baseline}, {per_call[name] / base[name]:5.3f} x"
                  ) if base else (lambda name: "")
        print(f"  constrained rhs (projected)     {per_call['rhs']:10.0f}   {per_call['rhs'] / chain:5.2f} x the chain"
              + versus("rhs"))
        print(f"  constrained rhs (no projection) {per_call['loop_rhs']:10.0f}   {per_call['loop_rhs'] / chain:5.2f} x "
              f"the chain (target <= {TARGET_RATIO:g} x)" + versus("loop_rhs"))
        print(f"  open chain rhs (baseline)       {chain:10.0f}" + " " * 19 + versus("chain rhs"))
        if args.profile:
            print(f"\nIltis loop_rhs, the {args.profile} functions with the most inclusive instructions "
                  f"({args.calls} calls):")
            print(profiled)
    return 0


if __name__ == "__main__":
    sys.exit(main())
