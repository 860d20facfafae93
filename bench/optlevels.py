"""What each C optimisation level buys: compile time against right-hand-side speed for the closed-loop models.

    python bench/optlevels.py [--models iltis chain40] [--levels O0 O1 O2 O3] [--whole]

For each model the generated C (derived once) is compiled with each level into a fresh cache: by default the level
applies to the model's units of the split build (runtime/translation_units.py; the glue unit with the integrators and the
loop solver keeps -O2), with --whole to every unit; last, as the baseline, the former build: one unit at -O2. Printed: the build's wall time and the compiler processes'
CPU time (the fairer figure on a shared machine), then the right-hand side the integrators call, timed inside C
at the start state (`Function.time`, median of 5). Ratios are to -O2, the build default, in this run.
"""

from __future__ import annotations

import argparse
import math
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build
from mbs.runtime import translation_units as units
from mbs.runtime.build import COLD_UNIT_FLAGS
from mbs.runtime.translation_units import SPLIT_MIN_CHARS

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from fourbar_chain import fourbar_chain  # noqa: E402


def system_of(name: str):
    if name == "iltis":
        return mbs.load(ROOT / "library" / "iltis" / "vehicle.mbs"), "bump_5"
    return mbs.loads(fourbar_chain(int(name.removeprefix("chain")))), None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["iltis", "chain40"])
    ap.add_argument("--levels", nargs="+", default=["O0", "O1", "O2", "O3"], help="without the dash")
    ap.add_argument("--whole", action="store_true", help="the level for every unit, the glue's too")
    args = ap.parse_args()
    for name in args.models:
        system, scene = system_of(name)
        compiled = system.compile(scene)
        data = system._workspace(compiled, system.generate(scene), dict(zip(compiled.p_names, compiled.p_default)))
        code = system.generate(scene).c_source
        rows = {}
        runs = [(level, level, True) for level in ("-" + name.lstrip("-") for name in args.levels)]
        for label, level, split in runs + [("-O2, one unit (the former build)", "-O2", False)]:
            with tempfile.TemporaryDirectory() as cache:
                units.SPLIT_MIN_CHARS = SPLIT_MIN_CHARS if split else math.inf
                start, cpu = time.perf_counter(), _children_cpu()
                default = build.model_unit_flags(tuple(build.compiler_command()))
                flags = dict(extra_flags=(level,)) if args.whole else dict(model_flags=(*default, level))
                # the level for every model unit, the outputs' and the cold ones' too (their own flags come after)
                flags["outputs_flags"], build.COLD_UNIT_FLAGS = (), ()
                result = build.build(code, cache_dir=cache, **flags)
                seconds, cpu = time.perf_counter() - start, _children_cpu() - cpu
                units.SPLIT_MIN_CHARS = SPLIT_MIN_CHARS
                build.COLD_UNIT_FLAGS = COLD_UNIT_FLAGS
                module = build.load(result)
                work = np.zeros(module.NWORK)
                f = module.Function("rhs", np.asarray(data.p, dtype=float), work)
                rhs = statistics.median(f.time(data.x, 500) for _ in range(5))
            rows[label] = (seconds, cpu, rhs)
        base = rows.get("-O2", next(iter(rows.values())))
        where = "every unit" if args.whole else "the model's units (glue -O2)"
        print(f"{name}: generated C {len(code) / 1024:.0f} KiB; level for {where}; {build.build_jobs()} jobs")
        print(f"  {'level':6s} {'wall':>8s} {'/ -O2':>6s} {'cpu':>8s} {'/ -O2':>6s} {'rhs':>10s} {'/ -O2':>6s}")
        for label, (seconds, cpu, rhs) in rows.items():
            print(f"  {label:6s} {seconds:7.1f}s {seconds / base[0]:6.2f} {cpu:7.1f}s {cpu / base[1]:6.2f} "
                  f"{rhs * 1e6:8.2f}us {rhs / base[2]:6.2f}")


def _children_cpu() -> float:
    """User + system CPU seconds of the finished child processes (the C compiler's)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


if __name__ == "__main__":
    main()
