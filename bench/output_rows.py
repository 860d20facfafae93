"""Where a row of the results goes, and what the rows pass costs against its baselines (the Iltis over the bump).

    python bench/output_rows.py [--scenes bump_5 bump_10 positions] [--repeat 15] [--flags] [--cache-dir DIR]

A row of a run with closed loops (runtime/rows.py project_and_evaluate_rows: Function.rows with `projected`,
c/mbs_python.c) is projected onto the loop closure (c/loops.c mbs_loop_project_row), the loops are solved there
for the accelerations and multipliers (mbs_loop_rates, called by the generated mbs_outputs when its outputs read
them), then the outputs' own expressions are evaluated (compiler/ccode.py, the outputs' unit). Per scene, from the
arguments simulate passes to the rows pass (recorded from a run):

* where the instructions of one Function.rows call over the run's rows go, per row (valgrind's callgrind,
  load-independent): the projection, the loop solve, the outputs' own expressions, and the rest (the loop over
  the rows, the rows copied at an event's two sides); beside them the instructions of the rhs the integrator calls
  (`loop_rhs`, over the same states), so that a row reads in right-hand sides;
* bump_5's rows projected alone, as a run without outputs projects them (rows.project_rows: `project_row`, each
  row's Newton steps from the factors the row before left) against `project` row by row (mbs_project: G evaluated
  and factored twice a row), the former path, in instructions;
* the scene `positions` is bump_5 with outputs of positions alone (heave, pitch, roll, a wheel's travel): its
  mbs_outputs solves no loops, and its rows are counted and timed against the former build (-DMBS_LOOP_ROWS_FORMER=1:
  each row projected afresh by mbs_project, as every row of such outputs was before their projection started from
  the factors the previous row's projection left), interleaved in this process, with their ratio;
* --flags: the outputs' unit at -Og (runtime/build.py OUTPUTS_UNIT_FLAGS, the current), -O1 and the model units'
  level: the unit's compiler CPU seconds alone (medians of 3), and per row the instructions and the CPU time of the
  rows pass (medians of --repeat interleaved rounds), with the ratios to -Og, and whether the outputs are the same
  to the bit.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import resource
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build

sys.path.insert(0, str(Path(__file__).parent))
from bump_cost import MODEL, saved_rows  # noqa: E402

#: bump_5 with outputs that read no accelerations (mbs_outputs then calls no mbs_loop_rates).
POSITIONS_SCENE = """
scene positions "bump_5 with outputs of positions alone" {
    param v = 5 m/s
    start = equilibrium
    t_end = 2.5 s
    sample = 0.005 s
    integrator = dopri5
    rtol = 1e-7
    atol = 1e-9
    output heave
    output pitch
    output roll
    output fl.travel
}
"""
#: The parts of a row, by the functions callgrind counts inclusively inside Function.rows.
PARTS = {"projection": "rows_project", "loop solve": "mbs_loop_rates", "outputs": "mbs_outputs"}
FORMER_FLAGS = ("-DMBS_LOOP_ROWS_FORMER=1",)
clock = time.process_time


def load_module(path: Path):
    name = path.name.split(".")[0]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: The child callgrind counts: the built library loaded by its path, one Function(name).rows over the saved rows
#: (the outputs' with `projected`, as simulate calls it), collected inside that call only.
CHILD = """
import importlib.util, sys
import numpy as np
library, saved, name = sys.argv[1], np.load(sys.argv[2]), sys.argv[3]
spec = importlib.util.spec_from_file_location(library.rsplit("/", 1)[-1].split(".")[0], library)
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
f = module.Function(name, saved["ps"][0].copy(), np.zeros(module.NWORK))
ts, xs, which, ps = saved["ts"], saved["xs"], saved["which"], saved["ps"]
if name == "outputs":
    done = f.rows(ts, xs, np.empty((len(ts), int(saved["ny"]))), ps, which, np.empty_like(xs))
else:
    done = f.rows(ts, xs, np.empty_like(xs), ps, which)
assert done == len(ts), done
"""


def callgrind(library: Path, saved: Path, workdir: Path, function: str = "outputs") -> dict[str, int]:
    """{function: inclusive instructions} of one Function(`function`).rows call over the saved rows (the outputs'
    with `projected`), and "total"."""
    out = workdir / "callgrind.out"
    done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=function_rows",
                           f"--callgrind-out-file={out}", sys.executable, "-c", CHILD, str(library), str(saved),
                           function], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    counts = {"total": int(found.group(1))}
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                          capture_output=True, text=True).stdout
    for line in text.splitlines():
        hit = re.match(r"\s*([\d,]+)\s+\([\s\d.]+%\)\s+\S*:(\w+)\s", line)
        if hit:
            counts.setdefault(hit.group(2), int(hit.group(1).replace(",", "")))
    return counts


def rows_time(module, saved) -> tuple[float, np.ndarray]:
    """(CPU seconds, the outputs) of one Function.rows call over the saved rows (a fresh work each time)."""
    ts, xs, which, ps = saved["ts"], saved["xs"], saved["which"], saved["ps"]
    f = module.Function("outputs", ps[0].copy(), np.zeros(module.NWORK))
    out, projected = np.empty((len(ts), int(saved["ny"]))), np.empty_like(xs)
    start = clock()
    done = f.rows(ts, xs, out, ps, which, projected)
    spent = clock() - start
    assert done == len(ts), done
    return spent, out


def interleaved(modules: dict, saved, repeat: int) -> tuple[dict, dict]:
    """{label: median CPU seconds per row}, {label: the outputs}, the builds' rounds interleaved."""
    times, outs = {k: [] for k in modules}, {}
    for _ in range(repeat):
        for label, module in modules.items():
            spent, outs[label] = rows_time(module, saved)
            times[label].append(spent / len(saved["ts"]))
    return {k: statistics.median(v) for k, v in times.items()}, outs


def split_line(scene: str, counts: dict, rows: int, rhs: float) -> None:
    total = counts["total"]
    parts = {name: counts.get(fn, 0) for name, fn in PARTS.items()}
    own = parts["outputs"] - parts["loop solve"]  # mbs_outputs calls mbs_loop_rates
    shares = {"projection": parts["projection"], "loop solve": parts["loop solve"], "outputs' own": own}
    shares["the rest"] = total - sum(shares.values())
    text = ", ".join(f"{name} {value / rows:,.0f} ({100 * value / total:.0f} %)" for name, value in shares.items())
    print(f"  {scene}: {rows} rows, {total / rows:,.0f} instructions a row ({total / rows / rhs:.2f} rhs of "
          f"{rhs:,.0f}): {text}")


def unit_cpu(code: str, outputs_flags: tuple[str, ...]) -> float:
    """Compiler CPU seconds of the outputs' unit alone with `outputs_flags` (median of 3)."""
    cc = tuple(build.compiler_command())
    files = build._build_files(code, "model.c")
    includes = (f"-I{build.C_DIR}", f"-I{sysconfig.get_paths()['include']}", f"-I{np.get_include()}")
    command = (*cc, *build._compile_flags(build.FLAGS),
               *build.unit_flags("outputs.c", build.model_unit_flags(cc), outputs_flags), *includes, "-c",
               "outputs.c", "-o", "outputs.o")
    seconds = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            Path(tmp, name).write_text(text, encoding="utf-8")
        for _ in range(3):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run(command, cwd=tmp, check=True, capture_output=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            seconds.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return statistics.median(seconds)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10", "positions"])
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--flags", action="store_true", help="the outputs' unit at -Og, -O1 and the model units' level")
    ap.add_argument("--cache-dir", default=None)
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        raise SystemExit("needs valgrind (callgrind, callgrind_annotate) on the PATH")
    system = mbs.loads(MODEL.read_text() + POSITIONS_SCENE, path=str(MODEL), cache_dir=args.cache_dir)
    print("Rows of the Iltis over the bump (one Function.rows over a run's rows; instructions: callgrind, per row)")
    with tempfile.TemporaryDirectory(prefix="mbs-bench-output-rows-") as tmp:
        tmp = Path(tmp)
        for scene in args.scenes:
            system.simulate(scene)
            saved_path = tmp / f"{scene}.npz"
            rows = saved_rows(system, scene, saved_path)
            saved = np.load(saved_path)
            library = Path(system.compile(scene).backend.module.__file__)
            counts = callgrind(library, saved_path, tmp)
            rhs = callgrind(library, saved_path, tmp, "loop_rhs")["total"] / rows
            split_line(scene, counts, rows, rhs)
            if scene == "bump_5":  # the same rows without outputs: projected alone (simulate(outputs=False))
                alone = {name: callgrind(library, saved_path, tmp, name)["total"] / rows
                         for name in ("project_row", "project")}
                print(f"    the same rows projected alone (simulate(outputs=False), rows.project_rows): project_row "
                      f"{alone['project_row']:,.0f} instructions a row, project (the former) {alone['project']:,.0f}, "
                      f"ratio {alone['project_row'] / alone['project']:.2f}")
            if scene == "positions":
                code = system.generate(scene).c_source
                former = build.build(code, cache_dir=args.cache_dir, extra_flags=FORMER_FLAGS).path
                before = callgrind(former, saved_path, tmp)["total"]
                modules = {"current": load_module(library), "former": load_module(former)}
                seconds, outs = interleaved(modules, saved, args.repeat)
                diff = np.max(np.abs(outs["current"] - outs["former"]) / (np.abs(outs["former"]) + 1e-300))
                print(f"    against the former build (every row of such outputs projected afresh, "
                      f"{' '.join(FORMER_FLAGS)}): {counts['total'] / rows:,.0f} instructions a row, former "
                      f"{before / rows:,.0f}, ratio {counts['total'] / before:.2f}; CPU {seconds['current'] * 1e6:.2f} "
                      f"us a row, former {seconds['former'] * 1e6:.2f} us, ratio "
                      f"{seconds['current'] / seconds['former']:.2f} (medians of {args.repeat} interleaved); the "
                      f"outputs' largest relative difference {diff:.1e}")
            if args.flags and scene != "positions":
                code = system.generate(scene).c_source
                levels = {"-Og": ("-Og",), "-O1": ("-O1",), "model units' level": ()}
                paths = {k: build.build(code, cache_dir=args.cache_dir, outputs_flags=v).path for k, v in levels.items()}
                instructions = {k: callgrind(p, saved_path, tmp)["total"] / rows for k, p in paths.items()}
                seconds, outs = interleaved({k: load_module(p) for k, p in paths.items()}, saved, args.repeat)
                for label, flags in levels.items():
                    cpu = unit_cpu(code, flags)
                    same = np.array_equal(outs[label], outs["-Og"])
                    print(f"    outputs' unit at {label}: compile {cpu:.2f} s CPU; a row {instructions[label]:,.0f} "
                          f"instructions ({instructions[label] / instructions['-Og']:.3f} of -Og), "
                          f"{seconds[label] * 1e6:.2f} us CPU ({seconds[label] / seconds['-Og']:.3f} of -Og); "
                          f"outputs {'the same to the bit' if same else 'differ from -Og'}"
                          + ("" if same else f" (largest relative "
                             f"{np.max(np.abs(outs[label] - outs['-Og']) / (np.abs(outs['-Og']) + 1e-300)):.1e})"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
