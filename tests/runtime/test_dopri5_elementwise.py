"""c/dopri5.c's elementwise loops (the stages' combinations, the error estimate, the dense output's coefficients) and
c/ode.c's error norm's weighted squares are vectorized by GCC at -O2 through the optimize attribute of the functions
that hold them: two doubles per SSE2 instruction, each element computed by the same operations in the same order
(the norm's squares added in the elements' order).  The reference is the same model built
with -DMBS_MACHINERY_FORMER=1 (the scalar loops): a run with events restarted in C (two contacts closing 4e-10 s
apart, located on the dense output) must agree with it to the bit, and the current build's dp_step must hold packed
multiplications where the former's holds none."""

from __future__ import annotations

import platform
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import build
from former_builds import flagged_build, simulate_with

TWIN_DROPS = Path(__file__).parent / "models" / "twin_drops.mbs"
FORMER = ("-DMBS_MACHINERY_FORMER=1",)


@pytest.fixture(scope="module")
def twins():
    system = mbs.load(TWIN_DROPS)
    return system, flagged_build(system, "drops", FORMER)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp"])
def test_the_vectorized_loops_give_the_scalar_loops_runs_to_the_bit(twins, integrator):
    """Every column, every event time and every counter of the run are the former build's (rodasp shares the error
    norm, c/ode.c)."""
    system, former = twins
    now = system.simulate("drops", integrator=integrator)
    before = simulate_with(system, "drops", former, integrator=integrator)
    assert now.success and before.success and len(now.events) >= 2
    assert [(e["event"], e["direction"], e["time"]) for e in now.events] == \
        [(e["event"], e["direction"], e["time"]) for e in before.events]
    assert now.metadata["stats"] == before.metadata["stats"]
    for name in now.names:
        assert np.array_equal(now[name], before[name]), name


def _function_text(path: str, name: str) -> str:
    done = subprocess.run(["objdump", "-d", "--no-show-raw-insn", f"--disassemble={name}", path],
                          capture_output=True, text=True)
    return done.stdout if done.returncode == 0 and f"<{name}>:" in done.stdout else ""


def _gcc_on_x86_64() -> bool:
    cc = tuple(build.compiler_command())
    return platform.machine() == "x86_64" and build.model_unit_flags(cc) == build.GCC_MODEL_UNIT_FLAGS


@pytest.mark.skipif(shutil.which("objdump") is None or not _gcc_on_x86_64(),
                    reason="the check reads GCC's x86-64 code with objdump")
def test_gcc_vectorizes_the_stage_loops_and_the_former_build_does_not(twins):
    system, former = twins
    current = _function_text(system.compile("drops").backend.module.__file__, "dp_step")
    scalar = _function_text(former.backend.module.__file__, "dp_step")
    if not current or not scalar:
        pytest.skip("dp_step's symbol is not in the built module (stripped)")
    assert current.count("mulpd") >= 10  # the six stages, the error estimate, the dense output
    assert scalar.count("mulpd") == 0
    norm = _function_text(system.compile("drops").backend.module.__file__, "mbs_ode_error_norm")
    if norm:  # not inlined into its callers
        assert "divpd" in norm
