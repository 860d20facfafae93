"""What the build cache's size bound (runtime/cache_bound.py) costs: the walk, a store's bookkeeping, a hit's touch,
and a warm `mbs simulate` with the bound against one without it.

    python bench/cache_bound.py [--files 24000] [--runs 15]

1. The walk (scan) of a cache of --files fake files (libraries with record and C copy, objects with record,
   derivations, validated models, in the proportions of a developer's cache), and enforce under the bound (the walk,
   no eviction, the ledger written), against a bare os.scandir with a stat of each file; medians of 5.
2. A store's bookkeeping under the bound (stored: the ledger appended and summed) against writing the smallest entry
   (cache.write_derived of a few bytes, which it follows), and a hit's touch (cache.problem of a library, which hashes
   it: with the bound, then with none); medians.
3. `mbs simulate library/examples/pendulum.mbs` with every cache warm, --runs times each way, interleaved (the
   machine is shared): the default bound against MBS_CACHE_MAX_SIZE=0 (no touch, no ledger); medians of wall and
   CPU time of the child, and their ratio.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "library" / "examples" / "pendulum.mbs"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median_time  # noqa: E402  (bench/timing.py)


def fake_cache(folder: Path, files: int) -> None:
    """About `files` files shaped like a developer's cache (by count: 45 % libraries' files, 16 % objects', 32 %
    derivations, 6 % validated models), each a few kB (the walk stats, it does not read)."""
    from mbs.runtime import cache
    made, i = 0, 0
    while made < files:
        i += 1
        name = f"{i:024x}{i:08x}"
        kind = i % 16
        if kind < 5:   # a library: module, record, C copy
            paths = [f"{cache.PREFIX}{name[:24]}{cache.EXT_SUFFIX}", f"{cache.PREFIX}{name[:24]}.json",
                     f"{cache.PREFIX}{name[:24]}.c"]
        elif kind < 8:  # an object and its record
            paths = [f"{cache.OBJECT_PREFIX}{name}.o", f"{cache.OBJECT_PREFIX}{name}.json"]
        elif kind < 15:
            paths = [f"{cache.DERIVED_PREFIX}{name}.json"]
        else:
            paths = [f"{cache.CHECKED_PREFIX}{name}.json"]
        for p in paths:
            (folder / p).write_bytes(b"x" * 2000)
        made += len(paths)


def bench_walk(files: int) -> None:
    from mbs.runtime import cache_bound
    with tempfile.TemporaryDirectory(prefix="bench-cache-bound-") as tmp:
        folder = Path(tmp)
        fake_cache(folder, files)
        n = sum(1 for _ in folder.iterdir())
        stats = median_time(lambda: [e.stat() for e in os.scandir(folder)], 5)
        walk = median_time(lambda: cache_bound.scan(folder), 5)
        enforce = median_time(lambda: cache_bound.enforce(folder, 10**12), 5)
        print(f"walk of {n} files: scan {walk * 1e3:.1f} ms ({walk / n * 1e6:.1f} us a file), enforce under the "
              f"bound {enforce * 1e3:.1f} ms; a bare scandir and stat of every file {stats * 1e3:.1f} ms, ratio "
              f"{walk / stats:.2f} (medians of 5)")


def bench_store_and_hit() -> None:
    from mbs.runtime import cache, cache_bound
    with tempfile.TemporaryDirectory(prefix="bench-cache-bound-") as tmp:
        folder = Path(tmp)
        os.environ[cache_bound.MAX_SIZE_ENV] = "1G"
        cache.write_derived(folder / f"{cache.DERIVED_PREFIX}first.json", {"k": 1}, "bench")  # the ledger's total
        for i in range(200):  # a ledger of 200 stores since the last walk
            cache_bound.stored(folder, "x", 1000)
        store = median_time(lambda: cache_bound.stored(folder, "x", 1000), 200)
        write = median_time(lambda: cache.write_derived(folder / f"{cache.DERIVED_PREFIX}w.json", {"k": 1}, "b"),
                             50)
        print(f"a store's bookkeeping (ledger of 200 lines): {store * 1e6:.0f} us; writing the smallest entry "
              f"(which includes it): {write * 1e6:.0f} us; ratio {store / write:.3f}")
        module = folder / f"{cache.PREFIX}lib{cache.EXT_SUFFIX}"
        module.write_bytes(os.urandom(150_000))  # a small model's library (the mean of a developer's: 152 kB)
        cache.record(module, "lib", "", "bench")
        with_touch = median_time(lambda: cache.problem(module), 300)
        os.environ[cache_bound.MAX_SIZE_ENV] = "0"
        without = median_time(lambda: cache.problem(module), 300)
        del os.environ[cache_bound.MAX_SIZE_ENV]
        print(f"a hit's check of a 150 kB library: {with_touch * 1e6:.0f} us with the touch, {without * 1e6:.0f} us "
              f"without (no bound); ratio {with_touch / without:.3f}")


def _run(cmd, env) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def bench_warm_simulate(runs: int) -> None:
    with tempfile.TemporaryDirectory(prefix="bench-cache-bound-") as tmp:
        out = Path(tmp) / "out.csv"
        cmd = [sys.executable, "-m", "mbs", "simulate", str(MODEL), "--out", str(out)]
        base = {k: v for k, v in os.environ.items() if k != "MBS_CACHE_MAX_SIZE"}
        ways = {"default bound (1 GB)": dict(base, MBS_CACHE_DIR=str(Path(tmp) / "cache")),
                "no bound (MBS_CACHE_MAX_SIZE=0)": dict(base, MBS_CACHE_DIR=str(Path(tmp) / "cache"),
                                                        MBS_CACHE_MAX_SIZE="0")}
        for env in ways.values():  # warm-up: derive, compile, then one warm run each
            _run(cmd, env)
        times = {name: [] for name in ways}
        for _ in range(runs):
            for name, env in ways.items():
                times[name].append(_run(cmd, env))
        medians = {name: (statistics.median(w for w, _ in t), statistics.median(c for _, c in t))
                   for name, t in times.items()}
        for name, (wall, cpu) in medians.items():
            print(f"warm mbs simulate pendulum, {name}: wall {wall:.3f} s, CPU {cpu:.3f} s (medians of {runs})")
        (bw, bc), (nw, nc) = medians.values()
        print(f"ratio bound / no bound: wall {bw / nw:.3f}, CPU {bc / nc:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", type=int, default=24000)
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args()
    bench_walk(args.files)
    bench_store_and_hit()
    bench_warm_simulate(args.runs)


if __name__ == "__main__":
    main()
