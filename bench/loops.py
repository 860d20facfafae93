"""The cost of closing kinematic loops, and how far the integrated state drifts off them over a long run.

    python bench/loops.py [--models slider_crank quarter_car vehicle four_bar] [--rounds 9] [--t-end-scale 1]
                          [--instructions]

For each closed-loop model of the library:

* rhs cost: the compiled right-hand side of the closed-loop model against the SAME model's open tree, i.e. the
  same text with the loop-closing interactions removed (every `interact` block whose joint has `cut = true`,
  in the model file and in the library modules it imports). The spanning tree, its coordinates, bodies and
  force elements are unchanged: only the cut joints are gone, so the difference is what the loops cost: the
  projection of the state onto the constraints, the constraint Jacobian and its factorisation, the mass
  matrix and the null-space solve (runtime/c/loops.c) instead of the tree's articulated-body recursion. Both
  are evaluated at the same states (samples of a closed-loop run), one Python call per state ("py") and
  inside C without Python ("C", `Workspace.time_rhs`: the projecting rhs, which scipy's integrators and the
  outputs call, and so do DOPRI5 and rodasp in C, which project the accepted states besides), and inside C the
  rhs without the projection ("direct", `loop_rhs`, the loop algebra alone). Shared machines are noisy: each figure is the median
  over --rounds rounds in which the two models' batches are interleaved, and the ratio is the median of the
  per-round ratios (the stable figure).
  With --instructions the same calls are counted in instructions instead (valgrind's callgrind, needs `valgrind`
  on the PATH; a few minutes): a child process loads the built libraries and makes n calls of each function at
  the run's middle state inside C, collected only inside that timing loop (one callgrind dump per function).
  Instructions do not depend on the machine's load; they weigh a division or a libm call by its instructions,
  not its latency, so they are the load-independent figure next to the timed one, not a replacement.
  Two builds of the closed-loop model are timed in the same rounds: the default one, whose loops close in closed
  form where compiler/closed_form_loops.py proves it ("closed form": the dependent coordinates explicit functions
  of the independent ones, the reduced dynamics in minimal coordinates, the numeric solver where it declines),
  and the numeric loop solver alone (`closed_form=False`, "numeric"), the baseline. A model whose loops do not
  close in closed form prints "-" for it (both builds are then the same).
* drift: one long run per model (slider-crank 20 s at 10 rad/s; quarter car 10 s over the 5 m/s bump, its
  scene's tolerances; the vehicle 5 s over it at rtol 1e-7, atol 1e-9, the bump scenes' settings before they moved
  to adams, bench/dopri5_former.py), integrated with DOPRI5 in C. The right-hand side is evaluated at the projected
  state, so the integrated ("raw") state is not pulled back and its distance from the constraints may grow with
  time; the driver stores the projected samples. Printed: max |g| (position constraints, m) of the stored
  samples and of the raw integrated states, at the end and over the run, and over the first and last tenth
  of the run so growth is visible; and max |G v + g_t| of the stored samples.

Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
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
from mbs import pipeline
from mbs.runtime.assembly import project_samples
from mbs.runtime.integrators import get_integrator
from mbs.runtime.workspace import Workspace

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ROOT / "library"
sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the bump scenes' settings before they moved to adams: what the vehicle's DOPRI5 drift run studies
from dopri5_former import DOPRI5_FORMER  # noqa: E402

MODELS = {
    # name: (file, scene, t_end [s], sample [s], run settings when the file has no scene or they differ from its)
    "slider_crank": ("examples/slider_crank.mbs", None, 20.0, 0.01, dict(rtol=1e-8, atol=1e-10)),
    "quarter_car": ("iltis/quarter_car.mbs", "bump_5", 10.0, 0.005, {}),
    "vehicle": ("iltis/vehicle.mbs", "bump_5", 5.0, 0.005, dict(DOPRI5_FORMER)),
    # a crank-rocker four-bar under gravity (the test model of compiler/closed_form_loops.py)
    "four_bar": (ROOT / "tests" / "compiler" / "models" / "four_bar.mbs", None, 10.0, 0.01,
                 dict(rtol=1e-8, atol=1e-10)),
}


# ---- the open tree: the same text without the cut joints ------------------------------------------------------

INTERACT = re.compile(r"^[ \t]*interact\b[^\n{]*\{", re.M)
CUT = re.compile(r"\bcut\s*=\s*true\b")


def without_cut_joints(text: str) -> tuple[str, list[str]]:
    """The text with every interact block whose joint has cut = true removed, and the removed blocks' names.
    Blocks are found by brace matching (comments and strings in the library hold no braces)."""
    out, removed, pos = [], [], 0
    for m in INTERACT.finditer(text):
        if m.start() < pos:
            continue
        depth, i = 1, m.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        block = text[m.start():i]
        if CUT.search(block):
            out.append(text[pos:m.start()])
            removed.append(block.split()[1])
            pos = i + (text[i] == "\n")
    out.append(text[pos:])
    return "".join(out), removed


def open_tree_files(model_file: Path, workdir: Path) -> tuple[Path, list[str]]:
    """Write the model without its cut joints to workdir (the model file at its top, every library module with
    cut joints at its own library path, where the loader looks first) and return the new model path."""
    removed = []
    target = workdir / model_file.name
    text, cut = without_cut_joints(model_file.read_text())
    target.write_text(text)
    removed += cut
    for module in LIBRARY.rglob("*.mbs"):
        if module == model_file or not CUT.search(module.read_text()):
            continue
        text, cut = without_cut_joints(module.read_text())
        path = workdir / module.relative_to(LIBRARY)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        removed += cut
    return target, removed


# ---- runs -------------------------------------------------------------------------------------------------------

def workspace(system, scene):
    """A workspace with the scene's parameters (the model's defaults without a scene)."""
    compiled = system.compile(scene)
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    data = Workspace(compiled)
    data.p = pipeline.parameter_vector(compiled.p_names, values)
    return compiled, data


def long_run(system, scene, t_end, sample, settings):
    """(times, projected samples, raw integrated samples, wall s) of a DOPRI5 run in C from the scene's
    assembled (or equilibrium) start, the same integration simulate() performs; simulate() stores the
    projected samples."""
    start = system.simulate(scene, t_end=0.0, sample=1.0, **settings)  # the assembled / equilibrium start
    compiled, data = workspace(system, scene)
    x0 = np.array([start[n][0] for n in compiled.x_names])
    sc = system.scene(scene)
    rtol = settings.get("rtol", sc.rtol if sc is not None else 1e-8)
    atol = settings.get("atol", sc.atol if sc is not None else 1e-10)
    times = np.arange(0.0, t_end + sample / 2, sample)
    raw = np.empty((times.size, compiled.nx))
    wall = time.perf_counter()
    solver = get_integrator("dopri5")(data.function("rhs"), 0.0, x0, t_end, rtol=rtol, atol=atol, first_step=None,
                                      max_step=np.inf, min_step=0.0, max_steps=10_000_000)
    filled = solver.sample(times, raw, 0)
    wall = time.perf_counter() - wall
    if filled < times.size:
        print(f"  run stopped at t = {times[filled - 1]:.3f} s: {solver.message}", file=sys.stderr)
    times, raw = times[:filled], raw[:filled]
    projected = raw.copy()
    project_samples(data, times, projected)
    return data, times, projected, raw, wall, (rtol, atol)


def residuals(data, times, states, name="constraints"):
    f = data.function(name)
    return np.array([np.max(np.abs(f(t, x))) for t, x in zip(times, states)])


def rhs_costs(closed, open_, states, rounds: int):
    """Medians over rounds of seconds per rhs call (Python loop over the states, inside C, and inside C without
    the projection), and the median per-round ratios closed / open; `closed` is a list of workspaces (the builds
    to compare, timed in the same rounds), the result one tuple per build."""
    return [_costs(c, open_, states, rounds) for c in _interleaved(closed, open_, states, rounds)]


def _interleaved(closed, open_, states, rounds):
    """The per-round timings of every build of `closed` and of the open tree, the builds taking turns."""
    samples = [[] for _ in closed]
    for _ in range(rounds):
        for k, c in enumerate(closed):
            samples[k].append(_round(c, open_, states))
    return samples


def _costs(samples, open_, states, rounds):
    med = statistics.median
    py_c, py_o, c_c, c_o, c_d = zip(*samples)
    return (med(py_c), med(py_o), med(a / b for a, b in zip(py_c, py_o)),
            med(c_c), med(c_o), med(a / b for a, b in zip(c_c, c_o)), med(c_d), med(a / b for a, b in zip(c_d, c_o)))


def _round(closed, open_, states):
    """One round: (py closed, py open, C closed, C open, C direct) seconds per call."""
    fc, fo = closed.function("rhs"), open_.function("rhs")
    order = [open_.model.x_names.index(n) for n in closed.model.x_names]
    inverse = np.argsort(order)
    states_open = np.ascontiguousarray(states[:, inverse])  # the open model's state order
    calls = len(states)
    repeat = max(1, int(0.02 / max(1e-7, _batch(fc, states, 1) / calls)))  # batches of about 20 ms
    direct = closed.function("loop_rhs")
    probe = states[len(states) // 2]
    n_c = max(1000, repeat * calls // 4)
    return (_batch(fc, states, repeat) / (repeat * calls), _batch(fo, states_open, repeat) / (repeat * calls),
            closed.time_rhs(probe, n=n_c), open_.time_rhs(probe[inverse], n=n_c),
            closed.model.backend.time_call(direct, probe, n_c, 0.0))


def _batch(f, states, repeat):
    start = time.perf_counter()
    for _ in range(repeat):
        for x in states:
            f(0.0, x)
    return time.perf_counter() - start


# ---- instructions per call (callgrind) ------------------------------------------------------------------------

#: The child: load each built library by its path (no compilation: under valgrind the closed-form attempt would
#: run out of its time budget) and make n calls of one function at one state inside C.
INSTRUCTION_CHILD = """
import importlib.util, json, sys
import numpy as np
for entry in json.load(open(sys.argv[1])):
    name = entry["library"].rsplit("/", 1)[-1].split(".")[0]
    spec = importlib.util.spec_from_file_location(name, entry["library"])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    f = module.Function(entry["function"], np.array(entry["p"], dtype=float), np.zeros(module.NWORK))
    f.time(np.array(entry["x"], dtype=float), int(sys.argv[2]), 0.0)
"""


def instruction_entry(data, function: str, x) -> dict:
    """What the child needs to call `function` of the workspace's library at x with the workspace's parameters."""
    return dict(library=str(data.model.backend.module.__file__), function=function,
                x=[float(v) for v in x], p=[float(v) for v in data.p])


def instructions_per_call(entries: list[dict], calls: int = 2000) -> list[float]:
    """Instructions per call of each entry (callgrind, collected inside the C timing loop only, one dump per
    entry; the loop's own few instructions per call included, the same for every entry)."""
    with tempfile.TemporaryDirectory(prefix="mbs-bench-callgrind-") as tmp:
        spec, out = Path(tmp) / "spec.json", Path(tmp) / "callgrind.out"
        spec.write_text(json.dumps(entries))
        done = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no",
                               "--toggle-collect=function_time", "--dump-after=function_time",
                               f"--callgrind-out-file={out}", sys.executable, "-c", INSTRUCTION_CHILD, str(spec),
                               str(calls)], capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"valgrind failed:\n{done.stderr[-2000:]}")
        counts = []
        for k in range(1, len(entries) + 1):
            found = re.search(r"^totals:\s*(\d+)", (Path(f"{out}.{k}")).read_text(), re.M)
            counts.append(int(found.group(1)) / calls if found else float("nan"))
        return counts


def print_instructions(rows) -> None:
    """rows: (model, [closed rhs, closed direct, numeric rhs, numeric direct, open rhs] instructions per call)."""
    print("\nrhs instructions per call at the run's middle state (callgrind; load-independent)")
    print(f"{'model':14s} {'open':>7s} {'closed form':>12s} {'ratio':>6s} {'direct':>7s} {'ratio':>6s}"
          f" {'numeric':>8s} {'ratio':>6s} {'direct':>7s} {'ratio':>6s}")
    for name, (cf, cf_direct, nu, nu_direct, open_) in rows:
        print(f"{name:14s} {open_:7.0f} {cf:12.0f} {cf / open_:6.2f} {cf_direct:7.0f} {cf_direct / open_:6.2f}"
              f" {nu:8.0f} {nu / open_:6.2f} {nu_direct:7.0f} {nu_direct / open_:6.2f}")
    print("(ratio = closed / open tree; 'closed form': the default build (the numeric solver where no closed form "
          "is proven), 'numeric': closed_form=False; rhs projects, direct does not; issue 12's target: under 3)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["slider_crank", "quarter_car", "vehicle", "four_bar"],
                    choices=sorted(MODELS))
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--t-end-scale", type=float, default=1.0, help="scale the long runs' simulated time")
    ap.add_argument("--instructions", action="store_true",
                    help="also count instructions per rhs call with callgrind (needs valgrind; a few minutes)")
    args = ap.parse_args()
    if args.instructions and shutil.which("valgrind") is None:
        raise SystemExit("--instructions: valgrind is not on the PATH")
    cost_rows, drift_rows, instruction_rows = [], [], []
    for name in args.models:
        file, scene, t_end, sample, settings = MODELS[name]
        path = LIBRARY / file
        t_end *= args.t_end_scale
        system = mbs.load(path)
        started = time.perf_counter()
        compiled = system.compile(scene)
        compile_closed = time.perf_counter() - started
        gen = system.generate(scene)
        with tempfile.TemporaryDirectory(prefix="mbs-bench-open-") as work:
            open_path, _ = open_tree_files(path, Path(work))
            open_system = mbs.load(open_path)
            started = time.perf_counter()
            open_compiled = open_system.compile(scene)
            compile_open = time.perf_counter() - started
            open_gen = open_system.generate(scene)
        if open_gen.constraints is not None or sorted(open_compiled.x_names) != sorted(compiled.x_names):
            raise SystemExit(f"{name}: the open variant is not the same tree without loops")
        print(f"{name}: {path.relative_to(ROOT)}" + (f", scene {scene}" if scene else "")
              + f"; nq = {compiled.nq}, nv = {compiled.nv}, constraint rows = {len(gen.constraints.names)}; "
              f"cut joints removed for the open tree: {', '.join(c.name for c in gen.lowered.topology.cuts)}; "
              f"compile {compile_closed:.1f} s "
              f"(closed), {compile_open:.1f} s (open) (0 when cached)", flush=True)
        data, times, projected, raw, wall, (rtol, atol) = long_run(system, scene, t_end, sample, settings)
        report = data.loop_report(times[0], projected[0])
        g_proj, g_raw = residuals(data, times, projected), residuals(data, times, raw)
        gd_proj = residuals(data, times, projected, "constraint_velocity")
        tenth = max(1, len(times) // 10)
        drift_rows.append((name, times[-1], rtol, atol, wall, int(report[5]), int(report[6]),
                           g_proj[-1], g_proj.max(), gd_proj.max(), g_raw[-1], g_raw.max(), g_raw[:tenth].max(),
                           g_raw[-tenth:].max()))
        open_data = Workspace(open_compiled)
        open_data.p = [dict(zip(compiled.p_names, data.p)).get(n, v)
                       for n, v in zip(open_compiled.p_names, open_compiled.p_default)]
        states = projected[:: max(1, len(times) // 50)]
        numeric = Workspace(system.compile(scene, closed_form=False))
        numeric.p = data.p
        closed_form, baseline = rhs_costs([data, numeric], open_data, states, args.rounds)
        if args.instructions:
            probe = states[len(states) // 2]
            order = [compiled.x_names.index(n) for n in open_compiled.x_names]
            entries = [instruction_entry(data, "rhs", probe), instruction_entry(data, "loop_rhs", probe),
                       instruction_entry(numeric, "rhs", probe), instruction_entry(numeric, "loop_rhs", probe),
                       instruction_entry(open_data, "rhs", probe[order])]
            instruction_rows.append((name, instructions_per_call(entries)))
        has_form = "mbs_closed_form(" in gen.c_source
        cost_rows.append((name + (" closed form" if has_form else " (no closed form)"), *closed_form))
        cost_rows.append((name + " numeric", *baseline))

    print(f"\nrhs per call, medians of {args.rounds} interleaved rounds at ~50 states of the run (us)")
    print(f"{'model':28s} {'closed py':>10s} {'open py':>8s} {'ratio':>6s} {'closed C':>9s} {'open C':>7s}"
          f" {'ratio':>6s}"
          f" {'direct C':>9s} {'ratio':>6s}")
    for name, pc, po, rp, cc, co, rc, cd, rd in cost_rows:
        print(f"{name:28s} {pc * 1e6:10.2f} {po * 1e6:8.2f} {rp:6.1f} {cc * 1e6:9.2f} {co * 1e6:7.2f} {rc:6.1f}"
              f" {cd * 1e6:9.2f} {rd:6.1f}")
    print("(ratio = closed / open tree, the loop overhead; issue 12's target: under 3; closed C projects the state at "
          "every call, direct C does not project; 'closed form': the default build, loops closed in closed form where "
          "proven; 'numeric': the numeric loop solver alone, the baseline, same rounds)")

    if instruction_rows:
        print_instructions(instruction_rows)

    print("\nconstraint residuals of the long runs (DOPRI5 in C): max |g| [m] of the stored (projected) samples and"
          " of the raw integrated state")
    print(f"{'model':13s} {'t_end':>6s} {'rtol':>6s} {'wall':>6s} {'rank':>4s} {'DOF':>3s} "
          f"{'proj end':>9s} {'proj max':>9s} {'|gdot| max':>10s} "
          f"{'raw end':>9s} {'raw max':>9s} {'raw 1st10%':>10s} {'raw last10%':>11s}")
    for (name, te, rtol, atol, wall, rank, dof, pe, pm, gdm, re_, rm, r0, r1) in drift_rows:
        print(f"{name:13s} {te:6.1f} {rtol:6.0e} {wall:5.2f}s {rank:4d} {dof:3d} {pe:9.1e} {pm:9.1e} {gdm:10.1e} "
              f"{re_:9.1e} {rm:9.1e} {r0:10.1e} {r1:11.1e}")


if __name__ == "__main__":
    main()
