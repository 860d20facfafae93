"""The CPU time of the Iltis's right-hand side, current against a baseline, with the luck of the library's pages apart.

    python bench/rhs_placement.py [--baseline DIR] [--flags F ...] [--baseline-flags F ...] [--rounds 10]
                                  [--seconds 1.0] [--function loop_rhs] [--scene bump_10] [--no-copy]

Two builds of the scene's model (runtime/build.py, each cached by content): the current one (with --flags) and the
baseline (with --baseline-flags, and with --baseline DIR the run-time C files of DIR, another revision's runtime/c,
e.g. `git archive REV runtime/c | tar -x -C /tmp/base`, found first: -I DIR); without --baseline and flags the
baseline is the current build again, under another name (an A/A test: what the bench tells apart when nothing
differs).  Each round runs one fresh process per build, the builds alternating; before each, the build's library
(the .so file in the cache) is copied afresh in its place, so that its pages land elsewhere in physical memory.
Each process calls `--function` (loop_rhs: the rhs the C integrators call, no projection) over the states of one
run of the scene (saved from a run of the current build: the rows of its results, in one `Function.rows` call
after one uncounted) for `--seconds` of CPU, and reports the median CPU time per call of its passes; printed are each
build's median over the rounds, their ratio, and each build's spread (its fastest and slowest round).

Why fresh copies: the same library, byte for byte, runs the Iltis's loop_rhs 2.05 us a call from one file and 2.45 us
from another (the same code, only the name of its init function differs), in every process, until the file is
copied afresh, when the two may trade places: the caches are indexed by physical address, and which of the model's
150 kB of code a call runs (mbs_loop_terms alone is 120 kB) conflict with each other there is the pages' luck.  So
two builds compared once each differ by up to 20 % whatever their code; over fresh copies the luck averages out.
valgrind's instruction counts (bench/loop_work.py) see none of this: they are the measure of a change's work, this
bench whether the CPU follows.  --no-copy: the libraries as they lie (the luck of one placement each, to see it).
Since runtime/c/huge_text.c a library moves its code and constants onto huge pages when it is loaded (where the
kernel offers transparent huge pages), which takes most of that luck away; MBS_HUGE_TEXT=0 (the children inherit it)
brings the file's own pages back.

Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import mbs

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "library" / "iltis" / "vehicle.mbs"

#: The child: the build of `flags` (from the cache), `function` over the saved states for `seconds` of CPU; prints
#: the median CPU seconds per call of its passes.
CHILD = f"TESTS_RUNTIME = {str(ROOT / 'tests' / 'runtime')!r}\n" + """
import sys, time
from pathlib import Path
import numpy as np
import mbs
from mbs import pipeline
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import flagged_build
path, scene, states, function, seconds, flags = sys.argv[1:6] + [tuple(sys.argv[6:])]
system = mbs.load(path)
model = flagged_build(system, scene, flags)
values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
data = system._workspace(model, system.generate(scene), values)
saved = np.load(states)
ts, xs = np.ascontiguousarray(saved["ts"]), np.ascontiguousarray(saved["xs"])
f, ps = data.function(function), data.p.copy()[None, :]
out, which = np.empty_like(xs), np.zeros(len(ts), dtype=np.intp)
f.rows(ts, xs, out, ps, which)
passes, start = [], time.process_time()
while time.process_time() - start < float(seconds):
    begin = time.process_time()
    done = f.rows(ts, xs, out, ps, which)
    passes.append((time.process_time() - begin) / max(1, done))
print("PER_CALL", sorted(passes)[len(passes) // 2])
"""


def library_of(system, scene: str, flags: tuple[str, ...]) -> Path:
    """The cached library file of the scene's model built with `flags` (built now when it is not cached)."""
    sys.path.insert(0, str(ROOT / "tests" / "runtime"))
    from former_builds import flagged_build
    return Path(flagged_build(system, scene, flags).backend.module.__file__)


def copy_afresh(library: Path) -> None:
    """The library copied in its place (a new file: its pages are read into other physical memory)."""
    fresh = library.with_name(library.name + ".fresh")
    shutil.copyfile(library, fresh)
    shutil.copymode(library, fresh)
    fresh.replace(library)


def save_states(system, scene: str, path: Path) -> int:
    """The states of one run of the scene (its results' rows: time and the state columns) into path (npz)."""
    res = system.simulate(scene)
    names = system.compile(scene).x_names
    np.savez(path, ts=np.asarray(res["time"], dtype=float), xs=np.column_stack([res[name] for name in names]))
    return len(res["time"])


def per_call(scene: str, states: Path, function: str, seconds: float, flags: tuple[str, ...]) -> float:
    child = [sys.executable, "-c", CHILD, str(MODEL), scene, str(states), function, str(seconds), *flags]
    done = subprocess.run(child, capture_output=True, text=True)
    lines = [line for line in done.stdout.splitlines() if line.startswith("PER_CALL ")]
    if done.returncode != 0 or not lines:
        raise SystemExit(f"child failed:\n{done.stderr[-2000:]}")
    return float(lines[-1].split()[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="bump_10")
    ap.add_argument("--baseline", metavar="DIR", default="", help="the run-time C files of the baseline (-I DIR)")
    ap.add_argument("--flags", nargs="*", default=[], help="extra compiler flags of the current build")
    ap.add_argument("--baseline-flags", nargs="*", default=[], help="extra compiler flags of the baseline build")
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=1.0, help="CPU seconds of calls per process")
    ap.add_argument("--function", default="loop_rhs")
    ap.add_argument("--no-copy", action="store_true", help="the libraries not copied afresh before each process")
    args = ap.parse_args(argv)
    current = tuple(args.flags)
    baseline = ((f"-I{Path(args.baseline).resolve()}",) if args.baseline else ()) + tuple(args.baseline_flags)
    if baseline == current:  # the A/A test: the same code under another name (another cache entry)
        baseline = current + ("-DMBS_RHS_PLACEMENT_SAME=1",)
    system = mbs.load(MODEL)
    libraries = {"current": library_of(system, args.scene, current),
                 "baseline": library_of(system, args.scene, baseline)}
    flags = {"current": current, "baseline": baseline}
    times: dict[str, list[float]] = {"current": [], "baseline": []}
    with tempfile.TemporaryDirectory() as tmp:
        states = Path(tmp) / "states.npz"
        n = save_states(system, args.scene, states)
        for round_ in range(args.rounds):
            for label in ("current", "baseline") if round_ % 2 == 0 else ("baseline", "current"):
                if not args.no_copy:
                    copy_afresh(libraries[label])
                times[label].append(per_call(args.scene, states, args.function, args.seconds, flags[label]))
    fresh = "a fresh process" if args.no_copy else "a fresh process and a fresh copy of the library"
    print(f"Iltis {args.scene}: {args.function} over the run's {n} states, CPU time a call, {args.rounds} rounds "
          f"({fresh} each); baseline: {' '.join(baseline)}")
    for label in ("current", "baseline"):
        ts = times[label]
        print(f"  {label:<9s} median {statistics.median(ts) * 1e6:7.3f} us   fastest {min(ts) * 1e6:7.3f}   "
              f"slowest {max(ts) * 1e6:7.3f}")
    ratio = statistics.median(times["current"]) / statistics.median(times["baseline"])
    print(f"  ratio current / baseline (medians) {ratio:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
