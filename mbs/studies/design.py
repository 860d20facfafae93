"""Designs of experiments: which parameter values a study runs.

``grid``: every combination of the listed values (the full factorial). ``lhs N``: a Latin hypercube of N
points between the smallest and largest listed value of each parameter (scipy.stats.qmc, seeded, so a study
is repeatable): each parameter's range is cut into N strata and each stratum is sampled once.
"""

from __future__ import annotations

import itertools
from typing import Mapping, Sequence

import numpy as np

from mbs.language.diagnostics import Diagnostic, MbsError


def _error(message: str) -> MbsError:
    return MbsError([Diagnostic("error", message, None)])


def grid(values: Mapping[str, Sequence[float]]) -> list[dict[str, float]]:
    """Every combination, the last parameter varying fastest."""
    names = list(values)
    return [dict(zip(names, combo)) for combo in itertools.product(*(values[n] for n in names))]


def latin_hypercube(values: Mapping[str, Sequence[float]], n: int, seed: int = 0) -> list[dict[str, float]]:
    """n points spread over the ranges [min, max] of each parameter's listed values."""
    from scipy.stats import qmc
    if n < 1:
        raise _error(f"--design lhs needs a positive number of points, got {n}")
    names = list(values)
    lows = np.array([min(values[name]) for name in names], dtype=float)
    highs = np.array([max(values[name]) for name in names], dtype=float)
    flat = [name for name, lo, hi in zip(names, lows, highs) if lo == hi]
    if flat:
        raise _error(f"--design lhs samples between the smallest and largest value of each parameter; give "
                     f"'{flat[0]}' two different values (a range), e.g. {flat[0]}=1,2")
    unit = qmc.LatinHypercube(d=len(names), seed=seed).random(n)
    points = qmc.scale(unit, lows, highs)
    return [dict(zip(names, map(float, row))) for row in points]


def design(values: Mapping[str, Sequence[float]], kind: str = "grid", n: int | None = None,
           seed: int = 0) -> list[dict[str, float]]:
    """The variants of a study as {parameter: value} dicts."""
    if not values:
        raise _error("a sweep needs at least one parameter to vary (--param NAME=v1,v2,...)")
    if kind == "grid":
        return grid(values)
    if kind == "lhs":
        if n is None:
            raise _error("--design lhs needs the number of points: --design lhs 20")
        return latin_hypercube(values, n, seed)
    raise _error(f"unknown design '{kind}' (use grid or lhs N)")
