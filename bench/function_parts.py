"""Long generated functions in parts (compiler/ccode_parts.py) against whole, and the cold units of a model with
loop terms (runtime/translation_units.py COLD_WITH_LOOP_TERMS): what they buy at compile time, what they cost at
run time.

    python bench/function_parts.py [--models iltis chain40 fourbar40] [--repeat 3] [--units]

Per model, measured in this run with the two settings interleaved (medians of --repeat; the machine is shared and
noisy, so CPU seconds are printed beside wall seconds):

* a fresh compile (text to loaded library, a cache empty but for the runtime object every model shares;
  bench/compile_time.py fresh_compile) with the current settings against the former ones: every function printed
  whole, and in a model with loops the mass matrix, the forces and the constraint acceleration compiled at the
  model units' level; printed: wall time, the derivation, the C build after it, the C compiler's CPU seconds;
* the right-hand side, the outputs and the mass matrix per call inside C (fastest of interleaved rounds) and a
  whole simulate (the vehicle's bump_5, a chain's 1 s), current against former;
* the same results to the bit: the right-hand side and the outputs of both builds at the start state;
* --units: each translation unit of both texts compiled alone, one at a time: its size and CPU seconds, and the
  longest unit (what a parallel build waits for).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compile_time import (TARGETS, call_times, compiled_workspace, fresh_compile, median,  # noqa: E402
                          simulate_times, unit_cpu)

from mbs.compiler import ccode_parts  # noqa: E402
from mbs.runtime import translation_units  # noqa: E402


@contextlib.contextmanager
def whole_functions():
    """The former settings: no function cut into parts, no cold units in a model with loops."""
    saved = ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS
    ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS = 10 ** 12, frozenset()
    try:
        yield
    finally:
        ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS = saved


def same_results(current, former) -> bool:
    """The right-hand side and the outputs of both builds at the start state, compared to the bit."""
    for fn in ("rhs", "outputs"):
        values = []
        for compiled in (current, former):
            data = compiled_workspace(compiled)
            if fn not in data.model.backend.functions:
                break
            values.append(np.array(data.function(fn)(0.0, data.x), copy=True))
        if len(values) == 2 and not np.array_equal(values[0], values[1]):
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["iltis", "chain40"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--units", action="store_true", help="also each unit compiled alone, both texts")
    args = ap.parse_args()
    print(f"parts of about {ccode_parts.PART_CHARS} characters, functions over {ccode_parts.SPLIT_CHARS} cut")
    for name in args.models:
        runs: dict[str, list] = {"parts": [], "whole": []}
        for _ in range(args.repeat):
            for setting in runs:
                with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
                    with whole_functions() if setting == "whole" else contextlib.nullcontext():
                        runs[setting].append(fresh_compile(name, cache))
        parts, whole = runs["parts"], runs["whole"]
        print(f"\n{name}: generated C {len(parts[0]['code']) // 1024} KiB in parts, "
              f"{len(whole[0]['code']) // 1024} KiB whole; medians of {args.repeat}")
        print(f"  {'':8s} {'compile':>8s} {'derive':>7s} {'C after':>8s} {'cc cpu':>7s}")
        for label, rs in (("parts", parts), ("whole", whole)):
            print(f"  {label:8s} {median(rs, 'total'):7.1f}s {median(rs, 'derive'):6.1f}s {median(rs, 'cc'):7.1f}s "
                  f"{median(rs, 'cc cpu'):6.1f}s")
        ratio = lambda key: median(whole, key) / median(parts, key)  # noqa: E731
        target = TARGETS.get(name)
        print(f"  whole / parts: compile {ratio('total'):.2f} x, C after the derivation {ratio('cc'):.2f} x, "
              f"C compiler cpu {ratio('cc cpu'):.2f} x"
              + (f"; target: compile under {target:.0f} s (now {median(parts, 'total'):.1f} s)" if target else ""))
        current, former = parts[-1]["compiled"], whole[-1]["compiled"]
        print(f"  same results to the bit (rhs, outputs at the start): {same_results(current, former)}")
        for fn, (a, b, r) in call_times(current, former, 15).items():
            print(f"  {fn} per call in C: {a * 1e6:.2f} us in parts against {b * 1e6:.2f} us whole: {r:.3f} x")
        a, b, r = simulate_times(parts[-1], whole[-1], name, args.repeat)
        print(f"  simulate: {a * 1e3:.0f} ms in parts against {b * 1e3:.0f} ms whole: {r:.2f} x")
        if args.units:
            texts = {"parts": parts[-1]["code"], "whole": whole[-1]["code"]}
            with whole_functions():  # the whole text's cold units as the former build made them
                whole_units = unit_cpu(texts["whole"], former=False)
            for label, units in (("parts", unit_cpu(texts["parts"], former=False)), ("whole", whole_units)):
                longest = max(units.items(), key=lambda item: item[1][1])
                print(f"  {label}: {len(units)} units, compiler cpu {sum(c for _, c in units.values()):.1f} s in "
                      f"all, the longest {longest[0]} {longest[1][1]:.1f} s")


if __name__ == "__main__":
    main()
