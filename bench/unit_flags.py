"""The C compiler's flags per translation unit of the Iltis's split build: the current ones against the former ones
(or any other set), compiler CPU per unit and what the compiled right-hand side costs, in one run.

    python bench/unit_flags.py [--repeat 3] [--scene bump_5] [--calls 200] [--flags "-fno-gcse ..."]
                               [--compiler-instructions] [--no-count]

The vehicle's generated C (derived once) is split into its units (runtime/translation_units.py) and each unit is
compiled alone with both settings, one compiler at a time, the settings interleaved; printed per unit: its size,
the compiler's CPU seconds (user + system of the compiler process: less load-dependent than wall time on the
shared machine; medians of --repeat) with the former and the current flags and their ratio. The settings:

* former: the model units' flags before the change (FORMER_MODEL_UNIT_FLAGS, the outputs' unit's after them);
* current: runtime/build.py's (model_unit_flags, OUTPUTS_UNIT_FLAGS), or the model units' flags --flags names.

With --compiler-instructions each model unit's compile is also counted in instructions under cachegrind, once per
setting (load-independent: the CPU seconds of one compile wander by 15 % on the shared machine; about 30 s of CPU
for each compile).

Then both settings' libraries are built into one fresh cache and compared: the right-hand side (`rhs`) and the
outputs at random states around the scene's start, to the bit (GCC does not reassociate without -ffast-math, so
flags that only schedule, allocate or skip a pass must give the same bits), and, with valgrind on the PATH, the
instructions per call of `loop_rhs` (the C integrators' right-hand side) and `outputs` at the scene's static
equilibrium, counted by callgrind in a child process (bench/rhs_instructions.py: load-independent).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build
from rhs_instructions import instructions

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "library" / "iltis" / "vehicle.mbs"
#: The model units' flags (GCC) before the register allocator's flags were added (runtime/build.py
#: GCC_MODEL_UNIT_FLAGS).
FORMER_MODEL_UNIT_FLAGS = ("-fno-gcse", "--param=sccvn-max-alias-queries-per-access=100",
                           "--param=dse-max-alias-queries-per-store=32")
#: The functions counted with callgrind, in this order.
COUNTED = ("loop_rhs", "outputs")


@contextlib.contextmanager
def model_flags_set(flags: tuple[str, ...] | None):
    """runtime/build.py's model units' flags for GCC set to `flags` (None: left as they are)."""
    saved = build.GCC_MODEL_UNIT_FLAGS
    if flags is not None:
        build.GCC_MODEL_UNIT_FLAGS = tuple(flags)
    try:
        yield
    finally:
        build.GCC_MODEL_UNIT_FLAGS = saved


def unit_commands(files: dict[str, str], flags: tuple[str, ...] | None) -> dict[str, tuple[str, ...]]:
    """{unit: its compile command} of a split build with the model units' flags `flags` (None: the current)."""
    cc = tuple(build.compiler_command())
    with model_flags_set(flags):
        model_flags = build.model_unit_flags(cc)
    out = {}
    for name in files:
        if name.endswith(".c"):
            out[name] = (*cc, *build._compile_flags(build.base_flags(cc)),
                         *build.unit_flags(name, model_flags, build.OUTPUTS_UNIT_FLAGS), *build._includes(), "-c",
                         name, "-o", os.devnull)
    return out


def compiler_cpu(command: tuple[str, ...], cwd: str) -> float:
    """User + system CPU seconds of one compiler process (and its children: cc1)."""
    before = os.times()
    subprocess.run(command, cwd=cwd, check=True, capture_output=True)
    after = os.times()
    return (after.children_user - before.children_user) + (after.children_system - before.children_system)


def compiler_instructions(command: tuple[str, ...], cwd: str) -> float:
    """The instructions one compile executes (the driver, cc1 and the assembler, under cachegrind without its cache
    simulation: load-independent, where CPU seconds of the same compile wander by 15 % on the shared machine)."""
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(["valgrind", "--tool=cachegrind", "--cache-sim=no", "--trace-children=yes",
                        f"--cachegrind-out-file={out}/cg.%p", *command], cwd=cwd, check=True, capture_output=True)
        return float(sum(instructions(dump) for dump in Path(out).glob("cg.*")))


def unit_costs(code: str, settings: dict[str, tuple[str, ...] | None], repeat: int,
               measure=compiler_cpu, units: tuple[str, ...] = ()) -> dict[str, dict[str, float]]:
    """{unit: {setting: the median of `measure` (compiler CPU seconds)}}, every unit (or those of `units`) compiled
    alone, the settings interleaved."""
    files = build._build_files(code, "vehicle.c")
    files[build.RUNTIME_UNIT] = build._runtime_unit()
    commands = {label: unit_commands(files, flags) for label, flags in settings.items()}
    runs: dict[str, dict[str, list[float]]] = {name: {label: [] for label in settings} for name in commands["former"]
                                               if not units or name in units}
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            Path(tmp, name).write_text(text, encoding="utf-8")
        for _ in range(repeat):
            for name in runs:
                for label in settings:
                    runs[name][label].append(measure(commands[label][name], tmp))
    return {name: {label: statistics.median(times) for label, times in by.items()} for name, by in runs.items()}


def compare_builds(code: str, scene: str, settings: dict[str, tuple[str, ...] | None], cache: str, rounds: int = 8,
                   timed: int = 25) -> tuple[dict[str, bool], dict[str, dict[str, float]]]:
    """({function: whether both settings' libraries give the same bits} for rhs and outputs at random states,
    {function: {setting: seconds per call inside C}}: the fastest of `timed` interleaved rounds at the start state (a
    round that was preempted is slow, never fast), a cross-check of the instruction counts that sees scheduling)."""
    system = mbs.load(MODEL, cache_dir=cache)
    compiled = system.compile(scene)
    data = system._workspace(compiled, system.generate(scene), dict(zip(compiled.p_names, compiled.p_default)))
    p = np.asarray(data.p, dtype=float)
    rng = np.random.default_rng(12)
    states = [data.x + 0.05 * rng.standard_normal(data.x.size) for _ in range(rounds)]
    values, functions = {}, {}
    for label, flags in settings.items():
        with model_flags_set(flags):
            module = build.load(build.build(code, cache_dir=cache))
        functions[label] = {fn: module.Function(fn, p, np.zeros(module.NWORK)) for fn in ("rhs", "outputs")}
        values[label] = {fn: [np.array(f(0.0, s), copy=True) for s in states] for fn, f in functions[label].items()}
    a, b = values.values()
    bits = {fn: all(np.array_equal(x, y) for x, y in zip(a[fn], b[fn])) for fn in a}
    x = np.ascontiguousarray(data.x)
    for label in settings:  # warmed up: the first rounds of a fresh library are slow
        for f in functions[label].values():
            f.time(x, 200)
    times = {fn: {label: np.inf for label in settings} for fn in ("rhs", "outputs")}
    for _ in range(timed):
        for fn, by in times.items():
            for label in settings:
                by[label] = min(by[label], functions[label][fn].time(x, 200))
    return bits, times


#: The callgrind child: the vehicle compiled with the model units' flags of argv (JSON, null: the current ones) into
#: the cache of $MBS_CACHE_DIR, its static equilibrium found, each counted function warmed up and timed inside C.
CHILD = """
import json, sys
from pathlib import Path
import numpy as np
sys.path.insert(0, sys.argv[1])
import mbs
from mbs import pipeline
from mbs.runtime.equilibrium import static_equilibrium
from unit_flags import COUNTED, MODEL, model_flags_set
flags, scene, calls, warm = json.loads(sys.argv[2]), sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
with model_flags_set(flags):
    system = mbs.load(MODEL)
    compiled = system.compile(scene)
values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
data = system._workspace(compiled, system.generate(scene), values)
if warm == 0:
    sys.exit(0)
x = np.ascontiguousarray(static_equilibrium(compiled, system._workspace(compiled, system.generate(scene), values),
                                            data.x).x)
for name in COUNTED:
    f = data.function(name)
    f.time(x, warm, 0.0)
    f.time(x, calls, 0.0)
"""


def instructions_per_call(flags: tuple[str, ...] | None, scene: str, calls: int, cache: str) -> dict[str, float]:
    """{function: instructions per call} of the library built with the model units' flags `flags`."""
    bench = str(Path(__file__).resolve().parent)
    arguments = [bench, json.dumps(flags), scene, str(calls)]
    env = {**os.environ, build.CACHE_ENV: cache}
    subprocess.run([sys.executable, "-c", CHILD, *arguments, "0"], check=True, env=env)  # compiled outside valgrind
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp, "callgrind.out")
        done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--collect-atstart=no",
                               "--toggle-collect=function_time", "--dump-after=function_time", sys.executable, "-c",
                               CHILD, *arguments, "5"], capture_output=True, text=True, env=env)
        dumps = sorted(Path(tmp).glob("callgrind.out.*"), key=lambda p: int(p.name.rsplit(".", 1)[1]))
        if done.returncode != 0 or len(dumps) < 2 * len(COUNTED):
            raise SystemExit(f"the valgrind run failed (status {done.returncode}):\n{done.stderr[-3000:]}")
        # each function's warm-up dump, then its timed one
        return {name: instructions(dump) / calls for name, dump in zip(COUNTED, dumps[-2 * len(COUNTED):][1::2])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scene", default="bump_5")
    ap.add_argument("--calls", type=int, default=200)
    ap.add_argument("--flags", help="the model units' flags to compare with the former ones (default: "
                    "runtime/build.py's)")
    ap.add_argument("--no-count", action="store_true", help="skip the callgrind counts")
    ap.add_argument("--compiler-instructions", action="store_true",
                    help="also count the model units' compiles in instructions (cachegrind; minutes)")
    args = ap.parse_args(argv)
    current = tuple(shlex.split(args.flags)) if args.flags is not None else None
    settings = {"former": FORMER_MODEL_UNIT_FLAGS, "current": current}
    with model_flags_set(current):
        shown = " ".join(build.model_unit_flags(tuple(build.compiler_command()))) or "(none: not GCC)"
    print(f"model units' flags, former: {' '.join(FORMER_MODEL_UNIT_FLAGS)}\n                    current: {shown}")
    print(f"each beyond {' '.join(build.FLAGS)}; the outputs' unit adds {' '.join(build.OUTPUTS_UNIT_FLAGS)}")
    system = mbs.load(MODEL)
    code = system.generate(args.scene).c_source
    cpu = unit_costs(code, settings, args.repeat)
    sizes = {**build._build_files(code, "vehicle.c"), build.RUNTIME_UNIT: build._runtime_unit()}
    print(f"\ncompiler CPU per unit, each compiled alone, medians of {args.repeat} interleaved")
    print(f"  {'unit':12s} {'KiB':>6s} {'former':>8s} {'current':>8s} {'ratio':>6s}")
    for name, by in cpu.items():
        print(f"  {name:12s} {len(sizes[name]) / 1024:6.0f} {by['former']:7.2f}s {by['current']:7.2f}s "
              f"{by['current'] / by['former']:6.2f}")
    models = [n for n in cpu if n.startswith("model_")]
    for label, names in (("model units", models), ("all units", list(cpu))):
        a, b = (sum(cpu[n][s] for n in names) for s in ("former", "current"))
        print(f"  {label:19s} {a:7.2f}s {b:7.2f}s {b / a:6.2f}")
    if args.compiler_instructions and shutil.which("valgrind"):
        counted = unit_costs(code, settings, 1, compiler_instructions, tuple(models))
        print("the model units' compiles in instructions (cachegrind: load-independent; once each)")
        for name, by in counted.items():
            print(f"  {name:12s} former {by['former'] / 1e9:7.2f} G  current {by['current'] / 1e9:7.2f} G  "
                  f"{by['current'] / by['former']:6.2f}")
        a, b = (sum(by[s] for by in counted.values()) for s in ("former", "current"))
        print(f"  {'model units':12s} former {a / 1e9:7.2f} G  current {b / 1e9:7.2f} G  {b / a:6.2f}")
    with tempfile.TemporaryDirectory() as cache:
        bits, times = compare_builds(code, args.scene, settings, cache)
        print("\nthe same to the bit at random states: " + ", ".join(f"{fn} {'yes' if ok else 'NO'}"
                                                                      for fn, ok in bits.items()))
        print("seconds per call inside C at the start state (the fastest of 25 interleaved rounds; wall "
              "time on a shared machine)")
        for fn, by in times.items():
            print(f"  {fn:10s} former {by['former'] * 1e6:8.2f} us  current {by['current'] * 1e6:8.2f} us  "
                  f"{by['current'] / by['former']:6.3f}")
        if args.no_count or shutil.which("valgrind") is None:
            print("instructions per call: not counted (--no-count, or valgrind not on the PATH)")
            return 0
        counts = {label: instructions_per_call(flags, args.scene, args.calls, cache)
                  for label, flags in settings.items()}
    print(f"instructions per call at the {args.scene} static equilibrium (callgrind, {args.calls} calls)")
    for fn in COUNTED:
        a, b = counts["former"][fn], counts["current"][fn]
        print(f"  {fn:10s} former {a:10.0f}  current {b:10.0f}  {b / a:6.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
