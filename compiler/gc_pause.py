"""The derivation runs with Python's cyclic garbage collector paused.

A derivation allocates hundreds of thousands of sympy nodes, tuples and dicts, and keeps most of them (the tape
holds every temporary's expression). The cyclic collector runs every 700 net allocations and traverses the young
objects each time, the older ones now and then: a quarter of the CPU time of a fresh derivation of the Iltis
(bench/derive.py, the previous path against the current one), although it finds next to nothing: sympy's
expressions are trees, freed by their reference counts as soon as they are dropped. Paused, the few cycles a
derivation leaves (a lowering and its converters, which refer to each other) wait for the collector's next run
after the derivation; the peak memory of the Iltis's derivation stays the same (within 2 %).
"""

from __future__ import annotations

import functools
import gc

#: Whether `paused` pauses the collector (bench/derive.py switches it off to measure the previous code path).
ENABLED = True


def paused(function):
    """`function` run with the cyclic collector paused (and resumed after it, unless it was paused before)."""
    @functools.wraps(function)
    def run(*args, **kwargs):
        if not ENABLED or not gc.isenabled():
            return function(*args, **kwargs)
        gc.disable()
        try:
            return function(*args, **kwargs)
        finally:
            gc.enable()
    return run
