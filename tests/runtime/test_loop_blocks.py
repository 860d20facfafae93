"""The kept partition's solve block by block (runtime/c/loops.c: mbs_loop_factor_blocks, mbs_loop_null_space_blocks,
mbs_loop_reduced_mass_blocks) against the general one of a fresh partition (mbs_loop_factor, mbs_loop_null_space,
mbs_loop_reduced_mass): the first `loop_rhs` of a workspace chooses its partition by complete pivoting and solves
over the whole factors; the second, at the same state, factors G by the kept partition's plan and forms T^T M T
by its blocks, writing exact zeros between the blocks of loops the mass matrix does not couple
(mbs_loop_blocks_coupled).  The two agree to round-off where the loops' blocks are coupled through M (the second
four-bar mounted on the first one's crank: the crank's velocity moves its links) and where they are not (both on
the floating body, tests/runtime/models/floating_four_bars.mbs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import build
from mbs.runtime.workspace import Workspace

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

FLOATING = Path(__file__).parent / "models" / "floating_four_bars.mbs"


def stacked_text() -> str:
    """floating_four_bars with the right four-bar's ground pivots on the left crank instead of the body."""
    text = FLOATING.read_text()
    text = text.replace('        frame tip at (a, 0, 0)\n    }\n\n    rigid left_coupler',
                        '        frame tip at (a, 0, 0)\n        frame right_crank at (0, -1, 0)\n'
                        '        frame right_pivot at (d, -1, 0)\n    }\n\n    rigid left_coupler', 1)
    text = text.replace("connect base.right_crank -> right_crank_link",
                        "connect left_crank_link.right_crank -> right_crank_link")
    text = text.replace("connect base.right_pivot -> right_rocker",
                        "connect left_crank_link.right_pivot -> right_rocker")
    assert text.count("left_crank_link.right_") == 2
    return text


def first_and_kept(system) -> tuple[np.ndarray, np.ndarray]:
    """loop_rhs at the start state by a fresh partition (a new workspace's first call), then by the kept one."""
    data, _ = system.start(None)
    work = Workspace(data.model)
    work.p, work.x = data.p, data.x.copy()
    f = work.function("loop_rhs")
    return np.array(f(0.0, work.x)), np.array(f(0.0, work.x))


@pytest.mark.parametrize("text", [FLOATING.read_text(), stacked_text()], ids=["uncoupled", "coupled"])
def test_the_kept_partitions_blocks_solve_as_the_fresh_partition(text):
    system = mbs.loads(text)
    fresh, kept = first_and_kept(system)
    nv = len(system.compile(None).v_names)
    vdot_fresh, vdot_kept = fresh[-nv:], kept[-nv:]
    assert np.all(np.isfinite(vdot_kept)) and np.max(np.abs(vdot_kept)) > 1.0  # moving: crank rates of 4 to 6 rad/s
    assert np.allclose(vdot_kept, vdot_fresh, rtol=1e-9, atol=1e-9 * np.max(np.abs(vdot_fresh)))
    assert np.array_equal(kept[:-nv], fresh[:-nv])  # the same state: the same qdot
