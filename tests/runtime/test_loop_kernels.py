"""The kept partition's block kernels inlined with a constant size (runtime/c/loops.c MBS_LOOP_BY_SIZE: the Iltis
corner's 6 rows, their loops unrolled) and the accepted step's residual read from its polish (mbs_loop_project_stamped)
against the former code (-DMBS_LOOP_BLOCK_FORMER=1: every size a variable; -DMBS_LOOP_RECHECK_FORMER=1: the constraints
evaluated again after the polish): the same arithmetic in the same order, so the same run to the bit, on the quarter
car over the bump (one corner: a block of 6 rows, adams with a projection at every step) and on a four-bar pair (blocks
of another size, the kernels with the size a variable).  The rows' positions kept within MBS_LOOP_ROW_KEPT
(-DMBS_LOOP_ROW_POLISH_FORMER=1: every row polished) change the rows by about the constraints' round-off alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import build

from former_builds import flagged_build, simulate_with

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

QUARTER_CAR = Path(__file__).resolve().parents[2] / "library" / "iltis" / "quarter_car.mbs"
FLOATING = Path(__file__).parent / "models" / "floating_four_bars.mbs"
ILTIS = Path(__file__).resolve().parents[2] / "library" / "iltis" / "vehicle.mbs"
SAME_BITS = ("-DMBS_LOOP_BLOCK_FORMER=1", "-DMBS_LOOP_RECHECK_FORMER=1")


@pytest.fixture(scope="module")
def quarter_car():
    system = mbs.load(QUARTER_CAR)
    return system, flagged_build(system, "bump_10", SAME_BITS)


def test_the_block_kernels_run_the_quarter_car_as_the_former_code_to_the_bit(quarter_car):
    system, former = quarter_car
    now = system.simulate("bump_10", integrator="adams", t_end=0.8)
    before = simulate_with(system, "bump_10", former, integrator="adams", t_end=0.8)
    assert now.metadata["stats"] == before.metadata["stats"]
    assert now.metadata["stats"]["nfev"] > 500  # over the bump: many steps, each projected
    assert np.array_equal(np.asarray(now.data), np.asarray(before.data))


def test_the_block_kernels_of_other_sizes_run_as_the_former_code_to_the_bit():
    system = mbs.load(FLOATING)  # two planar four-bars on a floating body: blocks of 3 pivot rows
    former = flagged_build(system, None, SAME_BITS)
    now = system.simulate(None, t_end=0.5, integrator="adams")
    before = simulate_with(system, None, former, t_end=0.5, integrator="adams")
    assert now.metadata["stats"] == before.metadata["stats"]
    assert np.array_equal(np.asarray(now.data), np.asarray(before.data))


@pytest.mark.slow
def test_the_iltis_kernels_of_constant_size_run_as_the_former_code_to_the_bit():
    """The whole vehicle over the bump: four corner blocks of 6 rows and T^T M T of NV - NC = 10, every kernel with its
    size a constant (its factors and solve unrolled whole, MBS_LOOP_BY_REDUCED_SIZE), T's pattern kept with the plan."""
    system = mbs.load(ILTIS)
    former = flagged_build(system, "bump_10", SAME_BITS)
    now = system.simulate("bump_10", t_end=0.5)
    before = simulate_with(system, "bump_10", former, t_end=0.5)
    assert now.metadata["stats"] == before.metadata["stats"]
    assert np.array_equal(np.asarray(now.data), np.asarray(before.data))


def test_rows_kept_within_the_step_tolerance_differ_from_the_polished_ones_by_round_off(quarter_car):
    system, _ = quarter_car
    polished = flagged_build(system, "bump_10", ("-DMBS_LOOP_ROW_POLISH_FORMER=1",))
    now = system.simulate("bump_10", integrator="adams", t_end=0.8)
    before = simulate_with(system, "bump_10", polished, integrator="adams", t_end=0.8)
    assert now.metadata["stats"] == before.metadata["stats"]  # the rows feed nothing back into the run
    a, b = np.asarray(now.data), np.asarray(before.data)
    span = np.ptp(b, axis=0)
    physical = span > 1e-9  # columns that are more than round-off around zero
    assert np.any(a != b)  # some rows were kept unpolished
    assert np.max(np.abs(a - b)[:, physical] / span[physical]) < 1e-8
