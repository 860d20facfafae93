"""The runtime object (runtime/build.py RUNTIME_UNIT: the Python bindings and the integrators, c/mbs_python.c,
compiled once and kept in the build cache) against the former layout, which compiled them into every model.

    python bench/runtime_object.py [--models pendulum iltis chain40] [--repeat 3]

Per model, measured in this run with the two layouts interleaved (medians of --repeat; the machine is shared and
noisy, so the compiler's CPU seconds are printed beside wall seconds):

* a fresh compile (text to loaded library; bench/compile_time.py fresh_compile): now, into a cache that holds the
  runtime object, as after a user's first model; the former layout, the bindings and the integrators included at
  the end of the model's one unit (a small model) or of its glue unit (a split one), <Python.h> first, as before;
* run time: the right-hand side, the outputs and the mass matrix per call inside C, and a whole simulate (the
  pendulum's swing, the vehicle's bump_5, a chain's 1 s), now against the former layout: the bindings read the
  model's sizes from its mbs_model_info instead of macros, and the integrators call the model through the same
  function pointers as before.

The runtime object's own compile (once per compiler and flags) is printed first.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compile_time import call_times, fresh_compile, median, model_text, runtime_cpu  # noqa: E402

from mbs.runtime import build  # noqa: E402

PYTHON_FIRST = "#define PY_SSIZE_T_CLEAN\n#include <Python.h>\n"


@contextlib.contextmanager
def former_layout():
    """Builds as before the runtime object: the bindings and the integrators in the model's one unit or glue unit
    (a define in the flags keeps the cache key, and with it the loaded module, apart from the current build's)."""
    build_files, flags = build._build_files, build.FLAGS

    def files(code: str, filename: str) -> dict[str, str]:
        out = build_files(code, filename)
        del out[build.RUNTIME_UNIT]
        unit = "unit.c" if "unit.c" in out else build._units.GLUE_UNIT
        out[unit] = PYTHON_FIRST + out[unit] + '#include "mbs_python.c"\n'
        return out

    build._build_files, build.FLAGS = files, flags + ("-DMBS_BENCH_FORMER_LAYOUT=1",)
    try:
        yield
    finally:
        build._build_files, build.FLAGS = build_files, flags


def simulate_times(runs: tuple[dict, dict], name: str, rounds: int) -> tuple[float, float, float]:
    """Median seconds of a whole simulate with each build and the median of their ratios, the order of the two
    swapped every round (on a loaded machine the first of a pair is often the slower: a small model's run is 1 ms)."""
    _, _, scene, t_end = model_text(name)
    walls: list[list[float]] = [[], []]
    for k in range(rounds):
        for j in ((0, 1) if k % 2 == 0 else (1, 0)):
            system = runs[j]["system"]
            start = time.perf_counter()
            system.simulate(scene, t_end=t_end) if t_end is not None else system.simulate(scene)
            walls[j].append(time.perf_counter() - start)
    ratios = [a / b for a, b in zip(*walls)]
    return statistics.median(walls[0]), statistics.median(walls[1]), statistics.median(ratios)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["pendulum", "iltis", "chain40"])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"the runtime object alone: compiler cpu {runtime_cpu():.2f} s (once per compiler and flags)")
    for name in args.models:
        runs: dict[str, list] = {"now": [], "former": []}
        for _ in range(args.repeat):
            for setting in runs:
                with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
                    with former_layout() if setting == "former" else contextlib.nullcontext():
                        runs[setting].append(fresh_compile(name, cache))
        now, former = runs["now"], runs["former"]
        print(f"\n{name}: medians of {args.repeat}")
        print(f"  {'':8s} {'compile':>8s} {'derive':>7s} {'C after':>8s} {'cc cpu':>7s}")
        for label, rs in (("now", now), ("former", former)):
            print(f"  {label:8s} {median(rs, 'total'):7.2f}s {median(rs, 'derive'):6.2f}s {median(rs, 'cc'):7.2f}s "
                  f"{median(rs, 'cc cpu'):6.2f}s")
        ratio = lambda key: median(former, key) / median(now, key)  # noqa: E731
        print(f"  former / now: compile {ratio('total'):.2f} x, C after the derivation {ratio('cc'):.2f} x, "
              f"C compiler cpu {ratio('cc cpu'):.2f} x")
        for fn, (a, b, r) in call_times(now[-1]["compiled"], former[-1]["compiled"], 15).items():
            print(f"  {fn} per call in C: {a * 1e6:.3f} us now against {b * 1e6:.3f} us former: {r:.3f} x")
        a, b, r = simulate_times((now[-1], former[-1]), name, 20 if name == "pendulum" else max(args.repeat, 6))
        print(f"  simulate: {a * 1e3:.1f} ms now against {b * 1e3:.1f} ms former: {r:.2f} x")


if __name__ == "__main__":
    main()
