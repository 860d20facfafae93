"""From what size a model with closed loops is built in parts (runtime/translation_units.py LOOP_SPLIT_FRACTION).

    python bench/split_threshold.py [--models quarter_car slider_crank four_bar] [--repeat 3]

A generated file below SPLIT_MIN_CHARS (96 kB) is compiled as one translation unit; a model with loops is split from
LOOP_SPLIT_FRACTION of it. The baseline, run interleaved with the current setting, is the former rule (every model
from 96 kB). Each run builds into an empty build cache that holds only the model's derived equations and the runtime
object every model shares (as after a user's first model), so what is timed is the C compiler alone:

* the model's first scene (text to loaded library): wall time and the compiler processes' CPU time;
* a second scene with other outputs, into the same cache: what a user waits for when they run another scene;
* the whole first scene's `simulate` afterwards (CPU time, the best of a few; split, the model's units get the
  model units' flags: runtime/build.py GCC_MODEL_UNIT_FLAGS).

Printed: medians of the runs, and the baseline's figure over the current one (above 1: the current is faster). A
model whose file is split under neither rule, or under both, shows the same figures twice.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import mbs
from mbs.runtime import build
from mbs.runtime import cache as build_cache
from mbs.runtime import translation_units as units

ROOT = Path(__file__).resolve().parent.parent
#: name: (file, first scene, a second scene with other outputs or None)
MODELS = {
    "quarter_car": (ROOT / "library" / "iltis" / "quarter_car.mbs", "bump_5", "settle"),
    "slider_crank": (ROOT / "library" / "examples" / "slider_crank.mbs", None, None),
    "four_bar": (ROOT / "tests" / "compiler" / "models" / "four_bar.mbs", None, None),
}
CURRENT = units.LOOP_SPLIT_FRACTION


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def warm_cache(path: Path, first, second) -> Path:
    """A cache with the model's derived equations (both scenes) and the runtime object, nothing else built."""
    warm = Path(tempfile.mkdtemp(prefix="mbs-bench-split-warm-"))
    system = mbs.load(path, cache_dir=str(warm))
    for scene in (first, second) if second else (first,):
        system.generate(scene)
    build.runtime_object(cache_dir=warm)
    return warm


def fresh_from(warm: Path) -> Path:
    """An empty build cache but for the derived equations, the validated model and the runtime object of `warm`."""
    fresh = Path(tempfile.mkdtemp(prefix="mbs-bench-split-"))
    for entry in warm.iterdir():
        if entry.name.startswith((build_cache.DERIVED_PREFIX, build_cache.CHECKED_PREFIX, build_cache.OBJECT_PREFIX)):
            shutil.copy2(entry, fresh)
    return fresh


def one_run(path: Path, first, second, warm: Path, fraction: float) -> dict:
    units.LOOP_SPLIT_FRACTION = fraction
    cache = fresh_from(warm)
    try:
        system = mbs.load(path, cache_dir=str(cache))
        out = {}
        for label, scene in (("first", first), ("second", second)):
            if label == "second" and second is None:
                continue
            wall, cpu = time.perf_counter(), children_cpu()
            system.compile(scene)
            out[label] = time.perf_counter() - wall
            out[label + " cpu"] = children_cpu() - cpu
        code = system.generate(first).c_source
        out["split"] = units.split_sources(code, "model.c") is not None
        runs = []
        for _ in range(5):
            start = time.process_time()
            system.simulate(first)
            runs.append(time.process_time() - start)
        out["simulate"] = min(runs)
        return out
    finally:
        units.LOOP_SPLIT_FRACTION = CURRENT
        shutil.rmtree(cache, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"loop models split from {CURRENT * units.SPLIT_MIN_CHARS / 1000:.0f} kB (baseline: "
          f"{units.SPLIT_MIN_CHARS / 1000:.0f} kB); empty build caches but the derived equations and the runtime "
          f"object; medians of {args.repeat}, interleaved")
    for name in args.models:
        path, first, second = MODELS[name]
        warm = warm_cache(path, first, second)
        try:
            size = len(mbs.load(path, cache_dir=str(warm)).generate(first).c_source)
            runs = {"current": [], "baseline": []}
            for _ in range(args.repeat):
                runs["current"].append(one_run(path, first, second, warm, CURRENT))
                runs["baseline"].append(one_run(path, first, second, warm, 1.0))
        finally:
            shutil.rmtree(warm, ignore_errors=True)
        print(f"\n{name} ({size / 1000:.0f} kB of C; split: current {runs['current'][0]['split']}, baseline "
              f"{runs['baseline'][0]['split']})")
        keys = [("first", "first scene, wall", "s"), ("first cpu", "first scene, compiler CPU", "s"),
                ("second", f"second scene ({second}), wall", "s"), ("second cpu", "second scene, compiler CPU", "s"),
                ("simulate", f"simulate {first or 'the model'}, CPU (best of 5)", "ms")]
        for key, label, unit in keys:
            if key not in runs["current"][0]:
                continue
            scale = 1000 if unit == "ms" else 1
            now = statistics.median(r[key] for r in runs["current"]) * scale
            before = statistics.median(r[key] for r in runs["baseline"]) * scale
            ratio = f"{before / now:.2f}" if now > 0 else "-"
            print(f"  {label:40s} {now:8.2f} {unit:2s} against {before:8.2f} {unit:2s}  baseline / current {ratio}")


if __name__ == "__main__":
    main()
