"""The drift an accepted step keeps (c/loops.c MBS_LOOP_STEP_KEPT_ATOL: a hundredth of the run's smallest atol,
MBS_LOOP_STEP_KEPT_PIVOT: only with a kept partition clear of singular positions) on a mechanism that passes
through singular positions: the 40 four-bars of tests/runtime/test_fourbar_chain.py over 20 s (six flat crossings).

    python bench/kept_drift.py [--integrators dopri5 adams] [--rtols 1e-6 1e-8] [--starts 11]

Three builds of the chain's model in the same run: the current one; `ungated` (-DMBS_LOOP_STEP_KEPT_PIVOT=0: the
drift kept whatever the kept partition's pivots, which are 2e-3 of the largest entry of G here); `former`
(-DMBS_LOOP_STEP_KEPT_ATOL=0: every drift beyond 1e-13 polished).  Per integrator and rtol (atol a hundredth of it,
the tests' ratio), the largest crank error against the reference over runs from the start with its speeds times
1 + k 1e-15 (--starts of them, k centred on 0): round-off in the start moves a run through the flat crossings
differently, so one run's error says little (at rtol 1e-10 21 such runs spread from 2e-7 to 7e-5 rad); their median
and range are printed per build, then the ratios of the medians to the former's.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import build
from mbs.runtime.backends import CBackend

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "runtime"))
import test_fourbar_chain as chain  # noqa: E402

#: The builds compared, by their extra compiler flags.
BUILDS = {"current": (), "ungated": ("-DMBS_LOOP_STEP_KEPT_PIVOT=0",), "former": ("-DMBS_LOOP_STEP_KEPT_ATOL=0",)}


def flagged(system, compiled, flags: tuple[str, ...]):
    """The chain's compiled model (with its Jacobian) built with `flags`."""
    if not flags:
        return compiled
    code = system.generate(None, jacobian=True).c_source
    return dataclasses.replace(compiled, backend=CBackend(build.load(build.build(code, extra_flags=flags))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--integrators", nargs="+", default=["dopri5", "adams"])
    ap.add_argument("--rtols", nargs="+", type=float, default=[1e-6, 1e-8])
    ap.add_argument("--starts", type=int, default=11)
    args = ap.parse_args(argv)
    system = mbs.loads(chain.fourbar_chain(40))
    start, _ = system.start(jacobian=True)
    reference = chain.reference(40, chain.FORTY_T_END, chain.FORTY_SAMPLE)
    models = {label: flagged(system, start.model, flags) for label, flags in BUILDS.items()}
    speeds = [1.0 + k * 1e-15 for k in range(-(args.starts // 2), args.starts - args.starts // 2)]
    print(f"40 four-bars over {chain.FORTY_T_END:g} s, the largest crank error [rad] over {len(speeds)} runs from "
          "starts perturbed by round-off (median, min .. max)")
    for integrator in args.integrators:
        for rtol in args.rtols:
            medians = {}
            for label, model in models.items():
                errors = [float(np.max(np.abs(chain.forty_run((system, model, start, reference), integrator, rtol,
                                                               s)["pivot0.phi"] - reference))) for s in speeds]
                medians[label] = float(np.median(errors))
                print(f"  {integrator} rtol {rtol:g} {label:<8} median {medians[label]:.2e} ({min(errors):.1e} .. "
                      f"{max(errors):.1e})", flush=True)
            print(f"  {integrator} rtol {rtol:g} ratios to the former: " + ", ".join(
                f"{label} {medians[label] / medians['former']:.2f}" for label in BUILDS if label != "former"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
