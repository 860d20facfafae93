"""What each C optimisation level buys: compile time against right-hand-side speed for the closed-loop models.

    python bench/optlevels.py [--models iltis chain40] [--levels O0 O1 O2 O3]

For each model the generated C (derived once) is compiled with each level appended to the build flags (the last
-O wins) into a fresh cache: the C compiler's wall time, then the right-hand side the integrators call, timed
inside C at the start state (`Function.time`, median of 5). Ratios are to -O2, the build default, in this run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build

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
    args = ap.parse_args()
    for name in args.models:
        system, scene = system_of(name)
        compiled = system.compile(scene)
        data = system._workspace(compiled, system.generate(scene), dict(zip(compiled.p_names, compiled.p_default)))
        code = system.generate(scene).c_source
        rows = {}
        for level in ("-" + name.lstrip("-") for name in args.levels):
            with tempfile.TemporaryDirectory() as cache:
                start = time.perf_counter()
                result = build.build(code, cache_dir=cache, extra_flags=(level,))
                seconds = time.perf_counter() - start
                module = build.load(result)
                work = np.zeros(module.NWORK)
                f = module.Function("rhs", np.asarray(data.p, dtype=float), work)
                rhs = statistics.median(f.time(data.x, 500) for _ in range(5))
            rows[level] = (seconds, rhs)
        base = rows.get("-O2", next(iter(rows.values())))
        print(f"{name}: generated C {len(code) / 1024:.0f} KiB")
        print(f"  {'level':6s} {'compile':>9s} {'/ -O2':>6s} {'rhs':>10s} {'/ -O2':>6s}")
        for level, (seconds, rhs) in rows.items():
            print(f"  {level:6s} {seconds:8.1f}s {seconds / base[0]:6.2f} {rhs * 1e6:8.1f}us {rhs / base[1]:6.2f}")


if __name__ == "__main__":
    main()
