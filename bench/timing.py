"""What every benchmark here times with: the median wall time of repeated calls (the machines are shared and
noisy: medians, and ratios measured in the same run, are the stable figures)."""

from __future__ import annotations

import statistics
import time


def median_time(fn, repeats: int) -> float:
    """Median wall time [s] of `repeats` calls of fn()."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def interleaved_medians(fns, repeats: int) -> list[float]:
    """Median wall time [s] of each of ``fns`` over `repeats` rounds that call each once in turn (a change of the
    machine's load meets them all alike)."""
    times = [[] for _ in fns]
    for _ in range(repeats):
        for fn, spent in zip(fns, times):
            start = time.perf_counter()
            fn()
            spent.append(time.perf_counter() - start)
    return [statistics.median(t) for t in times]
