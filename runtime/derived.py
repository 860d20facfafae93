"""What a run derives from an immutable object alone (a compiled model, a scene's generated code): computed at its
first use and kept on that object, as functools.cached_property keeps its values.

Why: every run of a warm System used to walk the model's events, parameter names and state names again to build
the same small tables (the events' directions, which events C restarts itself, the friction elements, the loops'
fixed coordinates); for the Iltis bump those walks were a sizeable part of the Python around the C integration.
Only values that depend on nothing but the object are kept here, and only immutable ones (tuples, read-only
arrays), so that no run can change what the next one reads.
"""

from __future__ import annotations

from typing import Callable, TypeVar

import numpy as np

T = TypeVar("T")
_MISSING = object()


def derived(owner, key: str, compute: Callable[[], T]) -> T:
    """``compute()``, kept in ``owner.__dict__`` under "_derived_<key>" (computed again only if two threads ask
    at once: the value is the same).  A numpy array is made read-only before it is kept."""
    slot = "_derived_" + key
    kept = owner.__dict__.get(slot, _MISSING)
    if kept is _MISSING:
        kept = compute()
        if isinstance(kept, np.ndarray):
            kept.flags.writeable = False
        owner.__dict__[slot] = kept
    return kept


def friction_modes_of(model) -> tuple[int, ...]:
    """runtime/friction.py friction_modes(model) (the p indices of the switched friction elements' modes), once per
    model: a model without such elements skips their checks at the start of a run and after its events."""
    from .friction import friction_modes
    return derived(model, "friction_modes", lambda: tuple(friction_modes(model)))
