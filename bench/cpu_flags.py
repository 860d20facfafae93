"""What the CPU's instruction-set flags buy (runtime/build.py cpu_flags: -mavx2 and GCC's -mtune=native on an
x86-64 CPU with AVX2), on the Iltis bump scenes as a user runs them, and that they change no bit.

    python bench/cpu_flags.py [--scenes bump_5 bump_10] [--repeat 7]

Per scene, the whole `System.simulate(scene)` from a first start (the kept start states let go: equilibrium,
integration, every output), CPU time of this process, medians of --repeat runs interleaved with the same scene built
without the flags (MBS_CPU_FLAGS empty: the portable build every machine makes): both times, their ratio, the
real-time factors, and whether the two runs' results are the same to the bit (every column, the event log).
Building both libraries compiles the vehicle twice into the cache the first time (about 3 s each).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"


def system_with(flags: str | None, scenes):
    """The vehicle loaded and its scenes compiled with MBS_CPU_FLAGS set to `flags` (None: detected)."""
    saved = os.environ.get(build.CPU_FLAGS_ENV)
    if flags is None:
        os.environ.pop(build.CPU_FLAGS_ENV, None)
    else:
        os.environ[build.CPU_FLAGS_ENV] = flags
    try:
        system = mbs.load(MODEL)
        for scene in scenes:
            system.compile(scene)
        return system
    finally:
        if saved is None:
            os.environ.pop(build.CPU_FLAGS_ENV, None)
        else:
            os.environ[build.CPU_FLAGS_ENV] = saved


def cpu_run(system, scene: str):
    system.forget_starts()
    start = time.process_time()
    res = system.simulate(scene)
    return time.process_time() - start, res


def same_bits(a, b) -> bool:
    return (a.names == b.names and np.array_equal(a.data, b.data, equal_nan=True)
            and [sorted(e.items()) for e in a.events] == [sorted(e.items()) for e in b.events])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    detected = build.cpu_flags(tuple(build.compiler_command()))
    if os.environ.get(build.CPU_FLAGS_ENV) is not None:
        print(f"(MBS_CPU_FLAGS is set: the flags measured are {' '.join(detected) or 'none'})")
    if not detected:
        print("this CPU and compiler get no instruction-set flags (runtime/build.py cpu_flags): nothing to compare")
        return 0
    portable, flagged = system_with("", args.scenes), system_with(None, args.scenes)
    print(f"whole simulate of the Iltis bump scenes, CPU time, medians of {args.repeat} interleaved runs; "
          f"flags {' '.join(detected)} against none (the portable build)")
    for scene in args.scenes:
        times = {"none": [], "flags": []}
        for _ in range(args.repeat):
            seconds, base = cpu_run(portable, scene)
            times["none"].append(seconds)
            seconds, res = cpu_run(flagged, scene)
            times["flags"].append(seconds)
        t_end = float(res["time"][-1]) - float(res["time"][0])
        none, flags = statistics.median(times["none"]), statistics.median(times["flags"])
        print(f"{scene}: with the flags {flags * 1e3:.1f} ms (real-time factor {t_end / flags:.1f}), without "
              f"{none * 1e3:.1f} ms ({t_end / none:.1f}): ratio {flags / none:.3f}; results the same to the bit: "
              f"{'yes' if same_bits(base, res) else 'NO'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
