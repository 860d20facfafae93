"""The run-time loop work of the Iltis over the bump (c/loops.c), current against former, in instructions.

    python bench/loop_work.py [--scene bump_10] [--no-rows] [--baseline DIR] [--former all|rates|kept]
                              [--simulate] [--accuracy [--scales S ...] [--dopri5]]

Two builds of the scene's model: the current one and the former (FORMER_FLAGS, each a compile-time switch of
c/loops.c that brings back the former arithmetic of one change; with --baseline DIR instead the run-time C files of
DIR, another revision's runtime/c, e.g. `git archive REV runtime/c | tar -x -C /tmp/base`, found first: -I DIR).  For each build, one run of the scene's
integration (`Solver.sample`, the scene's own integrator and tolerances) under valgrind's callgrind
(load-independent), per call or step:

* the loop algebra of an rhs call (`mbs_loop_solve_accelerations` inside `mbs_loop_rhs_direct`: the kept partition's
  factors, T^T M T, its factors, the solve; the generated loop terms apart), its two parts (the kept partition's
  factors of G, `mbs_loop_partition`; the rest, `mbs_loop_accelerations`: T and c0, T^T M T and T^T (f - M c0), its
  L D L^T and the solve, vdot) and the whole rhs call;
* the projection of an accepted step (`mbs_loop_project_step` from `mbs_ode_accept`);
* the integration's total, per accepted step;

and the rows of the results (one `Function.rows` over the run's rows with `projected`, as simulate calls it, the
arguments saved from a run: bench/output_rows.py), per row.  Printed with the ratios current / former.  Then, outside
valgrind, one simulate with each build: whether the results (every column, every row) and the run's statistics are
the same to the bit, or how far apart.  valgrind's libm rounds a little differently, so its step counts may differ by a few from a
run's own (the same for both builds).

--former NAME: the former build of one change only (FORMERS; all: every switch of FORMER_FLAGS, the default; kept: an
accepted step keeps a drift of at most 1e-13, not a hundredth of the run's smallest atol, c/loops.c
MBS_LOOP_STEP_KEPT_ATOL).
--simulate: also one whole simulate of the scene per build under callgrind (Python and C, after two uncounted runs),
with its rhs calls, and the ratio.  --accuracy: also both builds' results against a tight reference of the scene
(REFERENCE: DOPRI5 at rtol 1e-11), for a change that alters the trajectory: the largest difference of each column
relative to its largest magnitude (absolute below 1), the largest and the median over the columns, at the scene's
tolerances and at tolerances 1e-4 apart (TOLERANCE_SCALES, or --scales), whose spread is what any change of the step
sequence does to the errors; --dopri5: the runs with DOPRI5 at the bump scenes' former settings (bench/dopri5_former.py)
instead of the scene's own.

Nothing is asserted: figures are printed for a reader to compare.
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

import mbs

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "runtime"))
from bump_cost import MODEL, saved_rows  # noqa: E402
from dopri5_former import DOPRI5_FORMER, described  # noqa: E402
from event_instructions import sample_under_callgrind  # noqa: E402
from former_builds import flagged_build, simulate_with  # noqa: E402
from output_rows import callgrind as rows_callgrind  # noqa: E402

#: The former behaviour, one switch per change (c/loops.c).
FORMER_FLAGS = ("-DMBS_LOOP_RECHECK_FORMER=1", "-DMBS_LOOP_ROW_POLISH_FORMER=1", "-DMBS_LOOP_BLOCK_FORMER=1")
#: --former: one change's switch alone, or all of them.
FORMERS = {"all": FORMER_FLAGS,
           "rates": ("-DMBS_LOOP_RATES_FORMER=1",),
           "kept": ("-DMBS_LOOP_STEP_KEPT_ATOL=0",)}
#: The reference of --accuracy: DOPRI5 (the bump scenes' own integrator is adams) at a tight tolerance.
REFERENCE = {"integrator": "dopri5", "rtol": 1e-11, "atol": 1e-13}
#: --accuracy: the scene's tolerances times these, each run with both builds.
TOLERANCE_SCALES = (1.0, 1.0001, 0.9999, 1.0003)

#: The child: one simulate of the scene with the model built with the flags given; callgrind collects inside
#: Solver.sample only.  Prints the accepted steps and rhs calls.
CHILD = f"TESTS_RUNTIME = {str(Path(__file__).resolve().parent.parent / 'tests' / 'runtime')!r}\n" + """
import sys
from pathlib import Path
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, flags = Path(sys.argv[1]), sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
install_flagged_build(system, scene, flags)
stats = system.simulate(scene).metadata["stats"]
print("STATS", stats["nsteps"] - stats["nreject"], stats["nfev"])
"""


#: The child of --simulate: one whole simulate of the scene with the model built with the flags given, counted inside
#: functools.reduce after two uncounted runs (the kept start, as bench/bump_cost.py counts it).  Prints its rhs calls.
SIMULATE_CHILD = f"TESTS_RUNTIME = {str(Path(__file__).resolve().parent.parent / 'tests' / 'runtime')!r}\n" + """
import functools, os, subprocess, sys
from pathlib import Path
import mbs
sys.path.insert(0, TESTS_RUNTIME)
from former_builds import install_flagged_build
path, scene, flags = Path(sys.argv[1]), sys.argv[2], tuple(sys.argv[3:])
system = mbs.load(path)
install_flagged_build(system, scene, flags)
def run():
    return system.simulate(scene).metadata["stats"]
run(); run()
subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], check=True, capture_output=True)
stats = functools.reduce(lambda _, __: run(), range(1), None)
print("STATS", stats["nfev"])
"""


def simulate_instructions(scene: str, flags: tuple[str, ...], workdir: Path) -> tuple[int, int]:
    """(instructions, rhs calls) of one whole simulate of SIMULATE_CHILD with the build of `flags`."""
    child = [sys.executable, "-c", SIMULATE_CHILD, str(MODEL), scene, *flags]
    subprocess.run(child, check=True, capture_output=True)  # the build, outside valgrind
    done = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no", "--collect-atstart=no",
                           "--toggle-collect=functools_reduce", f"--callgrind-out-file={workdir / 'callgrind.sim'}",
                           *child], capture_output=True, text=True)
    total = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    stats = re.search(r"^STATS (\d+)$", done.stdout, re.M)
    if done.returncode != 0 or not total or not stats:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    return int(total.group(1)), int(stats.group(1))


def column_errors(run, reference) -> np.ndarray:
    """The largest difference of each column of `run` from `reference` relative to the column's largest magnitude
    (absolute below 1)."""
    gaps = []
    for name in reference.names:
        if name == "t":
            continue
        a, b = np.asarray(run[name]), np.asarray(reference[name])
        gaps.append(float(np.max(np.abs(a - b))) / max(1.0, float(np.max(np.abs(b)))) if a.shape == b.shape
                    else float("inf"))
    return np.array(gaps)


def print_accuracy(system, scene: str, former, scales=TOLERANCE_SCALES, settings=None) -> None:
    """--accuracy: both builds' simulate against the reference, at the scene's tolerances and at tolerances a hair
    apart (TOLERANCE_SCALES): any change of the step sequence moves the errors about as much as such a hair does, so
    the spread of those runs is the yardstick of a difference between the builds."""
    reference = system.simulate(scene, **REFERENCE)
    own = dict(settings) if settings else system.simulate(scene).metadata
    found = {"current": [], "former": []}
    for scale in scales:
        tolerances = {"rtol": own["rtol"] * scale, "atol": own["atol"] * scale}
        if settings:
            tolerances["integrator"] = settings["integrator"]
        found["current"].append(column_errors(system.simulate(scene, **tolerances), reference))
        found["former"].append(column_errors(simulate_with(system, scene, former, **tolerances), reference))
    print(f"  against the scene with {REFERENCE}, {described(settings) if settings else 'its own settings'} at "
          f"tolerances times {', '.join(map(str, scales))} (the largest error of a column, relative; over the "
          "columns, its largest and its median):")
    for label, runs in found.items():
        print(f"    {label:<8} largest " + " ".join(f"{np.max(e):.3e}" for e in runs)
              + f"; median " + " ".join(f"{np.median(e):.3e}" for e in runs)
              + f"; mean of the medians {np.mean([np.median(e) for e in runs]):.3e}")
    now, was = (np.mean([np.median(e) for e in found[label]]) for label in ("current", "former"))
    print(f"    ratio of the means of the medians current / former {now / was:.3f}")


def run_parts(scene: str, flags: tuple[str, ...], workdir: Path) -> dict[str, tuple[int, int]]:
    """{part: (calls, inclusive instructions)} of one run's integration with the build of `flags`, and
    "integration": (accepted steps, total), "rhs calls": (rhs calls, 0)."""
    child = [sys.executable, "-c", CHILD, str(MODEL), scene, *flags]
    total, (accepted, _), pairs = sample_under_callgrind(child, workdir / "callgrind.out")

    def calls(callers, callee) -> tuple[int, int]:
        found = [v for (a, b), v in pairs.items() if a in callers and b == callee]
        return sum(v[0] for v in found), sum(v[1] for v in found)
    rhs_callers = {a for (a, b) in pairs if b == "mbs_loop_rhs_direct" and a != "mbs_loop_rhs_direct"}
    return {"rhs": calls(rhs_callers, "mbs_loop_rhs_direct"),
            "loop algebra": calls(("mbs_loop_rhs_direct",), "mbs_loop_solve_accelerations"),
            "  kept factors of G": calls(("mbs_loop_solve_accelerations",), "mbs_loop_partition"),
            "  T, T^T M T, L D L^T, vdot": calls(("mbs_loop_solve_accelerations",), "mbs_loop_accelerations"),
            "projection": calls(("mbs_ode_accept",), "mbs_loop_project_step"),
            "integration": (accepted, total)}


#: Columns whose range over the run is below this are round-off around a quantity zero by symmetry (a bearing's
#: moment about its own axis: 1e-11 N m): their differences are printed apart, in their unit.
NOISE_RANGE = 1e-9


def compare_results(system, scene: str, former) -> str:
    """One simulate of the scene with the current build against one with `former`: the same to the bit, or the
    largest difference of a column relative to its range over the run (columns of round-off apart, NOISE_RANGE), and
    whether the run's statistics, its steps and rhs calls, are the same (the integration's trajectory)."""
    now, was = system.simulate(scene), simulate_with(system, scene, former)
    a, b = np.asarray(now.data), np.asarray(was.data)
    stats = "the same" if now.metadata["stats"] == was.metadata["stats"] else "different"
    if a.shape != b.shape:
        return f"differ: {a.shape} against {b.shape} ({stats} run statistics)"
    if np.array_equal(a, b):
        return f"the same to the bit ({a.shape[0]} rows, {a.shape[1]} columns; {stats} run statistics)"
    span, diff = np.ptp(b, axis=0), np.max(np.abs(a - b), axis=0)
    noise = span < NOISE_RANGE
    relative = diff[~noise] / np.where(span[~noise] > 0, span[~noise], 1.0)
    return (f"{np.sum(diff == 0)} of {a.shape[1]} columns the same to the bit, the largest difference "
            f"{np.max(relative):.1e} of its column's range ({np.sum(noise)} columns of round-off, range below "
            f"{NOISE_RANGE:g}, apart: their largest difference {np.max(diff[noise], initial=0.0):.1e}); "
            f"{a.shape[0]} rows, {stats} run statistics")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="bump_10")
    ap.add_argument("--no-rows", action="store_true", help="skip the rows of the results")
    ap.add_argument("--baseline", metavar="DIR", default="",
                    help="the former: the run-time C files of DIR (another revision's runtime/c) instead of the flags")
    ap.add_argument("--former", choices=sorted(FORMERS), default="all", help="the former switches (FORMERS)")
    ap.add_argument("--simulate", action="store_true", help="also count one whole simulate per build")
    ap.add_argument("--accuracy", action="store_true", help="also both builds against a tight reference")
    ap.add_argument("--scales", nargs="+", type=float, default=list(TOLERANCE_SCALES),
                    help="--accuracy: the tolerances times these")
    ap.add_argument("--dopri5", action="store_true",
                    help="--accuracy: with DOPRI5 at the bump scenes' former settings (bench/dopri5_former.py)")
    args = ap.parse_args(argv)
    former_flags = (f"-I{Path(args.baseline).resolve()}",) if args.baseline else FORMERS[args.former]
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        raise SystemExit("needs valgrind (callgrind, callgrind_annotate) on the PATH")
    system = mbs.load(MODEL)
    builds = {"current": (), "former": former_flags}
    print(f"Iltis {args.scene}: the loops' run-time work, instructions (callgrind); former: {' '.join(former_flags)}")
    with tempfile.TemporaryDirectory(prefix="mbs-bench-loop-work-") as tmp:
        tmp = Path(tmp)
        parts = {label: run_parts(args.scene, flags, tmp) for label, flags in builds.items()}
        steps = {label: p["integration"][0] for label, p in parts.items()}
        print("  " + f"{'':<34}" + "".join(f"{label:>14}" for label in builds) + f"{'ratio':>8}")
        counts = {label: f"{steps[label]} {parts[label]['rhs'][0]}" for label in builds}
        print("  " + f"{'accepted steps, rhs calls':<34}" + "".join(f"{counts[label]:>14}" for label in builds))
        for key, per in (("loop algebra", "a call"), ("  kept factors of G", "a call"),
                         ("  T, T^T M T, L D L^T, vdot", "a call"), ("rhs", "a call"), ("projection", "a step"),
                         ("integration", "a step")):
            cells = {}
            for label in builds:
                number, cost = parts[label][key]
                cells[label] = cost / max(1, steps[label] if key == "integration" else number)
            print("  " + f"{f'{key}, {per}':<34}" + "".join(f"{cells[label]:>14,.0f}" for label in builds)
                  + f"{cells['current'] / cells['former']:>8.3f}")
        if not args.no_rows:
            saved = tmp / "rows.npz"
            rows = saved_rows(system, args.scene, saved)
            libraries = {"current": Path(system.compile(args.scene).backend.module.__file__),
                         "former": flagged_build(system, args.scene, former_flags).backend.module.__file__}
            per_row = {label: rows_callgrind(Path(path), saved, tmp)["total"] / rows
                       for label, path in libraries.items()}
            print("  " + f"{f'rows ({rows}), a row':<34}" + "".join(f"{per_row[label]:>14,.0f}" for label in builds)
                  + f"{per_row['current'] / per_row['former']:>8.3f}")
        if args.simulate:
            whole = {label: simulate_instructions(args.scene, flags, tmp) for label, flags in builds.items()}
            print("  " + f"{'a whole simulate, rhs calls':<34}" + "".join(f"{whole[label][1]:>14}" for label in builds))
            print("  " + f"{'a whole simulate (Python and C)':<34}" + "".join(f"{whole[label][0]:>14,}" for label in builds)
                  + f"{whole['current'][0] / whole['former'][0]:>8.3f}")
    former = flagged_build(system, args.scene, former_flags)
    print(f"  simulate({args.scene!r}) current against former: " + compare_results(system, args.scene, former))
    if args.accuracy:
        print_accuracy(system, args.scene, former, tuple(args.scales), DOPRI5_FORMER if args.dopri5 else None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
