"""What the run-time derives once per immutable object (runtime/derived.py), and the workspace's model functions
bound at their first use (runtime/workspace.py)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mbs.runtime.derived import derived
from mbs.runtime.errors import UsageError
from mbs.runtime.workspace import Workspace


def test_a_derived_value_is_computed_once_per_object_and_arrays_are_read_only():
    calls = []
    owner, other = SimpleNamespace(), SimpleNamespace()

    def compute():
        calls.append(1)
        return np.arange(3.0)
    first = derived(owner, "table", compute)
    assert derived(owner, "table", compute) is first and len(calls) == 1
    assert not first.flags.writeable
    derived(other, "table", compute)
    assert len(calls) == 2
    assert derived(owner, "none", lambda: None) is None and derived(owner, "none", lambda: 1) is None


def test_workspace_functions_are_made_at_first_use_the_same_object_after_and_wrapped_if_asked(pendulum):
    data = Workspace(pendulum)
    rhs = data.function("rhs")
    assert data.function("rhs") is rhs and data.rhs is rhs and data.__getattr__("rhs") is rhs
    with pytest.raises(UsageError, match="has no function 'nope'"):
        data.function("nope")
    with pytest.raises(AttributeError):
        data.nope
    seen = []
    data.wrap_functions(lambda f: seen.append(f) or f)
    assert seen == [rhs]  # the ones made already, now ...
    data.function("outputs")
    assert len(seen) == 2  # ... the others when they are made
    np.testing.assert_array_equal(data.rhs(0.0, data.x), Workspace(pendulum).rhs(0.0, data.x))
