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

    python bench/function_parts.py --order [--models iltis] [--repeat 3]

measures instead the order of the statements inside each part (compiler/ccode_parts.py part_order: a carried value
read where first used, stored where computed, an output written after its last temporary) and the parts' size
(ccode_parts.PART_CHARS) against the former order (every read at the top, the outputs and the stores at the end)
and size (FORMER_PART_CHARS): each model unit (model_*.c, the units of
the integrators' functions) of both texts compiled alone, the two texts interleaved, --repeat times: its size,
the median CPU seconds of the C compiler for each and their ratio, and the model units' sum; the two builds'
right-hand side and outputs at the start state compared to the bit. (bench/rhs_instructions.py counts what the
order does to the right-hand side's instructions.)

    python bench/function_parts.py --order --split-baseline 15000 [--models iltis] [--repeat 3]

the same, with the baseline the current order and parts but every function over 15,000 characters cut (rather
than over ccode_parts.SPLIT_CHARS): what cutting the shorter functions too would buy.
"""

from __future__ import annotations

import argparse
import contextlib
import resource
import statistics
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compile_time import (TARGETS, call_times, compiled_workspace, fresh_compile, median,  # noqa: E402
                          model_text, simulate_times, unit_cpu)

import mbs  # noqa: E402
from mbs.compiler import ccode_parts  # noqa: E402
from mbs.runtime import build, translation_units  # noqa: E402


@contextlib.contextmanager
def whole_functions():
    """The former settings: no function cut into parts, no cold units in a model with loops."""
    saved = ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS
    ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS = 10 ** 12, frozenset()
    try:
        yield
    finally:
        ccode_parts.SPLIT_CHARS, translation_units.COLD_WITH_LOOP_TERMS = saved


def _former_part_order(part, results) -> list:
    """part_order as it was: the carried reads first, then the temporaries, the outputs, the stores for later
    parts."""
    return ([("read", name) for name in part.imports] + [("step", step) for step in part.steps]
            + [("write", entry) for entry in results] + [("keep", name) for name in part.exports])


#: The characters of temporaries a part aimed for before part_order (ccode_parts.PART_CHARS now).
FORMER_PART_CHARS = 20_000


@contextlib.contextmanager
def former_order():
    """The statements of each part in the former order, in parts of the former size (the baseline of --order)."""
    from mbs.compiler import ccode
    saved = ccode.part_order, ccode_parts.PART_CHARS, ccode_parts.SPLIT_CHARS
    ccode.part_order = _former_part_order
    ccode_parts.PART_CHARS, ccode_parts.SPLIT_CHARS = FORMER_PART_CHARS, 3 * FORMER_PART_CHARS // 2
    try:
        yield
    finally:
        ccode.part_order, ccode_parts.PART_CHARS, ccode_parts.SPLIT_CHARS = saved


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def model_unit_texts(code: str) -> dict[str, str]:
    """{unit: text} of the split build's files: the model units (model_*.c) and the header they include."""
    files = build._build_files(code, "model.c")
    return {name: text for name, text in files.items() if not name.endswith(".c") or name.startswith("model_")}


def compile_cpu(files: dict[str, str], unit: str, folder: Path) -> float:
    """CPU seconds of the C compiler for `unit` alone, with the flags of a split build's model units."""
    cc = tuple(build.compiler_command())
    for name, text in files.items():
        (folder / name).write_text(text, encoding="utf-8")
    includes = (f"-I{build.C_DIR}", f"-I{sysconfig.get_paths()['include']}", f"-I{np.get_include()}")
    command = (*cc, *build._compile_flags(build.base_flags(cc)), *build.model_unit_flags(cc), *includes, "-c", unit,
               "-o", unit[:-2] + ".o")
    cpu = _children_cpu()
    subprocess.run(command, cwd=folder, check=True, capture_output=True)
    return _children_cpu() - cpu


@contextlib.contextmanager
def split_above(chars: int):
    """The current order and parts, with every function over `chars` characters cut (the --split-baseline)."""
    saved = ccode_parts.SPLIT_CHARS
    ccode_parts.SPLIT_CHARS = chars
    try:
        yield
    finally:
        ccode_parts.SPLIT_CHARS = saved


def order_report(name: str, repeat: int, baseline=former_order, baseline_label: str = "former") -> None:
    """The --order figures of model `name` (see the module's doc); baseline: the context of the text compared
    with the current one (the former order and size, or split_above)."""
    text, path, scene, _ = model_text(name)
    with tempfile.TemporaryDirectory(prefix="mbs-bench-") as tmp:
        systems, texts = {}, {}
        for label in ("in order", "former"):  # (each its own cache: the generated C is cached by the model's text)
            with baseline() if label == "former" else contextlib.nullcontext():
                cache = Path(tmp, label.replace(" ", "_") + "_cache")
                systems[label] = mbs.loads(text, path=path, cache_dir=cache)
                texts[label] = model_unit_texts(systems[label].generate(scene).c_source)
        if texts["in order"] == texts["former"]:
            print(f"\n{name}: no function in parts, the same text in either order")
            return
        units = sorted(n for n in texts["in order"] if n.endswith(".c"))
        cpu = {label: {u: [] for u in units} for label in texts}
        folders = {label: Path(tmp, label.replace(" ", "_")) for label in texts}
        for folder in folders.values():
            folder.mkdir()
        for _ in range(repeat):
            for unit in units:
                for label in texts:
                    cpu[label][unit].append(compile_cpu(texts[label], unit, folders[label]))
        print(f"\n{name}: the model units compiled alone, each order interleaved; medians of {repeat}")
        print(f"  baseline ('former'): {baseline_label}")
        print(f"  {'unit':10s} {'KiB':>5s} {'in order':>9s} {'former':>8s} {'ratio':>6s}")
        sums = {label: [sum(cpu[label][u][k] for u in units) for k in range(repeat)] for label in texts}
        for unit in units:
            a, b = (statistics.median(cpu[label][unit]) for label in texts)
            print(f"  {unit:10s} {len(texts['in order'][unit]) / 1024:5.0f} {a:8.2f}s {b:7.2f}s {a / b:6.2f}")
        a, b = (statistics.median(sums[label]) for label in texts)
        print(f"  {'sum':10s} {'':5s} {a:8.2f}s {b:7.2f}s {a / b:6.2f}   (in order / former: C compiler CPU of "
              "the model units)")
        compiled = {}
        for label, system in systems.items():
            with baseline() if label == "former" else contextlib.nullcontext():
                compiled[label] = system.compile(scene)
        print(f"  same results to the bit (rhs, outputs at the start): "
              f"{same_results(compiled['in order'], compiled['former'])}")


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
    ap.add_argument("--order", action="store_true",
                    help="instead: the statements' order inside the parts against the former order (model units)")
    ap.add_argument("--split-baseline", type=int, metavar="CHARS",
                    help="with --order: the baseline is the current order and parts with every function over CHARS "
                         "characters cut")
    args = ap.parse_args()
    if args.order:
        for name in args.models:
            if args.split_baseline:
                order_report(name, args.repeat, lambda: split_above(args.split_baseline),
                             f"the same order and parts, every function over {args.split_baseline} characters cut "
                             f"(now over {ccode_parts.SPLIT_CHARS})")
            else:
                order_report(name, args.repeat, former_order,
                             f"the former order in parts of {FORMER_PART_CHARS} characters")
        return
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
