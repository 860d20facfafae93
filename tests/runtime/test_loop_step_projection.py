"""The projection of a C integrator's accepted step (c/loops.c mbs_loop_project_step, `loop_accept`'s second half)
from the factors of G the step's last stage left at its positions: a state that drifted off the constraints by more
than the Newton tolerance (1e-12) but at most 1e-9 is polished with those factors (Newton's steps from the Jacobian
at these very positions) and held to the tolerance, instead of projected afresh; a larger drift goes to
mbs_project.  Either way the result is mbs_project's to round-off, on the constraints to 1e-12 (Freudenstein's
four-bar, whose constraints are the loop's closure: test_loops.py).  A drift of at most 1e-13 (one step's, usually)
keeps its positions as they are, its velocities made consistent with them; one between 1e-13 and the tolerance is
polished (keeping it raised DOPRI5's round-off floor on the 40 four-bars at rtol 1e-10: c/loops.c
MBS_LOOP_STEP_KEPT), unless a C integrator's run set a larger drift from its tolerances: a hundredth of its smallest
atol where the kept partition is clear of singular positions (c/loops.c mbs_loop_step_drift,
MBS_LOOP_STEP_KEPT_ATOL)."""

from __future__ import annotations

import numpy as np
import pytest

from mbs.runtime import build
from mbs.runtime.integrators import native
from test_loops import FB, four_bar, four_bar_state

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")


@pytest.fixture(scope="module")
def four_bar_data(cache_dir):
    mechanism = four_bar(cache_dir, **FB)
    return mechanism.workspace(four_bar_state(1.0, 6.0, **FB), fixed=["crank.phi", "der(crank.phi)"])


@pytest.mark.parametrize("drift", [3e-12, 1e-11, 3e-10, 1e-7])
def test_a_drifted_step_is_projected_as_mbs_project_does(four_bar_data, drift):
    data = four_bar_data
    nx = len(data.x)
    nq = nx // 2
    x = np.array(data.x)
    x[:nq] += drift * np.array([0.3, -1.0, 0.7])  # positions off the loop's closure by about `drift`
    residual = np.max(np.abs(data.constraints(0.0, x)))
    assert drift / 10 < residual < 10 * drift
    step_end = data.function("loop_accept")(0.0, x)
    projected, fresh = step_end[nx:], data.function("project")(0.0, x)
    assert np.max(np.abs(data.constraints(0.0, projected))) <= 1e-12
    assert np.max(np.abs(data.constraint_velocity(0.0, projected))) <= 1e-10
    assert np.allclose(projected, fresh, rtol=0.0, atol=1e-13)
    assert np.array_equal(step_end[:nx], data.function("loop_rhs")(0.0, x))  # the last stage's rhs: untouched


def drifted(data, drift):
    """The state of `data` with its positions off the loop's closure by about `drift`, its velocities off theirs."""
    nq = len(data.x) // 2
    x = np.array(data.x)
    x[:nq] += drift * np.array([0.3, -1.0, 0.7])
    x[nq:] += 1e-9
    return x


def test_a_step_that_drifted_by_round_off_keeps_its_positions(four_bar_data):
    data = four_bar_data
    nx = len(data.x)
    nq = nx // 2
    x = drifted(data, 2e-14)
    assert 1e-15 < np.max(np.abs(data.constraints(0.0, x))) <= 1e-13
    projected = data.function("loop_accept")(0.0, x)[nx:]
    assert np.array_equal(projected[:nq], x[:nq])  # not polished to the round-off floor
    assert np.max(np.abs(data.constraint_velocity(0.0, projected))) <= 1e-12
    assert np.allclose(projected, data.function("project")(0.0, x), rtol=0.0, atol=1e-13)


def test_a_step_that_drifted_within_the_tolerance_is_polished(four_bar_data):
    """A residual between 1e-13 and the Newton tolerance 1e-12: on the constraints to the tolerance already, but
    polished to the round-off floor all the same (the round-off floor of tight runs through singular positions rose
    where such drifts were kept), its velocities consistent, the result mbs_project's to round-off."""
    data = four_bar_data
    nx = len(data.x)
    nq = nx // 2
    x = drifted(data, 4e-13)
    residual = np.max(np.abs(data.constraints(0.0, x)))
    assert 1e-13 < residual <= 1e-12
    projected = data.function("loop_accept")(0.0, x)[nx:]
    assert not np.array_equal(projected[:nq], x[:nq])  # polished
    assert np.max(np.abs(data.constraints(0.0, projected))) < 1e-13
    assert np.max(np.abs(data.constraint_velocity(0.0, projected))) <= 1e-12
    assert np.allclose(projected, data.function("project")(0.0, x), rtol=0.0, atol=1e-13)


def test_a_run_keeps_a_drift_of_a_hundredth_of_its_atol(cache_dir):
    """A C integrator set up on the workspace's rhs tells the projection of its accepted steps (the same work) its
    smallest atol: at atol 1e-9 a drift of 3e-12 (above the Newton tolerance) keeps its positions, its velocities made
    consistent with them; one beyond 1e-11 is polished as before.  A run at atol 1e-11 (a hundredth below 1e-13)
    polishes the 3e-12 again: each run sets its own.  (The four-bar's kept partition is clear of its singular
    positions: its smallest relative pivot above MBS_LOOP_STEP_KEPT_PIVOT.)"""
    data = four_bar(cache_dir, **FB).workspace(four_bar_state(1.0, 6.0, **FB),
                                               fixed=["crank.phi", "der(crank.phi)"])
    nx, nq = len(data.x), len(data.x) // 2
    module = native.native_module(data.rhs)
    accept = data.function("loop_accept")

    def step_end(drift, atol):
        module.Solver("dopri5", data.rhs, 0.0, np.asarray(data.x, dtype=float), 1.0, 1e-6, atol)
        x = drifted(data, drift)
        return x, accept(0.0, x)[nx:]

    x, kept = step_end(3e-12, 1e-9)
    assert 1e-12 < np.max(np.abs(data.constraints(0.0, x))) <= 1e-11
    assert np.array_equal(kept[:nq], x[:nq])  # not polished
    assert np.max(np.abs(data.constraint_velocity(0.0, kept))) <= 1e-12
    assert np.allclose(kept, data.function("project")(0.0, x), rtol=0.0, atol=1e-11)
    x, polished = step_end(3e-11, 1e-9)
    assert 1e-11 < np.max(np.abs(data.constraints(0.0, x)))
    assert not np.array_equal(polished[:nq], x[:nq])
    assert np.max(np.abs(data.constraints(0.0, polished))) <= 1e-12
    x, polished = step_end(3e-12, 1e-11)
    assert not np.array_equal(polished[:nq], x[:nq])
    assert np.max(np.abs(data.constraints(0.0, polished))) < 1e-13
    assert np.allclose(polished, data.function("project")(0.0, x), rtol=0.0, atol=1e-13)
