"""The cost of the Jacobian of a closed mechanism's right-hand side (runtime/c/loop_jacobian.c) on the chain of
coupled four-bars (tests/runtime/fourbar_chain.py), against the difference Jacobian the integrators fall back on.

    python bench/loop_jacobian.py [--cells 10 40] [--rounds 7] [--cache-dir DIR]

A chain of N four-bars has 2 (2 N + 1) states and one degree of freedom; beyond 40 states its Jacobian takes the
partials of the loop residuals by differences (compiler/jacobian_loops.py, MAX_STATES), as central differences
along each column's directions, the columns the projection undoes not computed. Printed per chain, as medians
over --rounds rounds at states of a dopri5 run (one Python call each):

* the generated Jacobian (mbs_jacobian) and the projecting right-hand side (mbs_rhs), per call;
* the baseline measured in the same run: central differences of the projecting right-hand side, 2 nx calls
  (what rodasp and scipy's implicit methods use where the generated Jacobian fails), and the ratio;
* the difference of the two Jacobians relative to the largest entry, median over the states (both are
  approximations: the differences' error is about their step squared and the Newton tolerance over the step;
  at a state where the differences' right-hand sides project by another partition than the Jacobian's, the
  columns of the directions off the constraints differ too, each the derivative of f after its own projection:
  1.6 on the 10-chain at theta = -0.148 rad, 1.5e-5 relative at theta = -3.18).

Before this Jacobian took its partials by forward differences per state (nx + 1 residuals, and a table of
(nv + 3 nc + nq) x (nx + 1) products per column): 172 ms per call on the 40-chain, 280 right-hand sides.
Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "runtime"))

import mbs  # noqa: E402
from fourbar_chain import fourbar_chain  # noqa: E402
from mbs.runtime.simulate import central_differences, simulate  # noqa: E402
from mbs.runtime.workspace import Workspace  # noqa: E402


def per_call(f, states, repeat=1) -> float:
    """Seconds per call of f(0, x) over the states."""
    began = time.perf_counter()
    for _ in range(repeat):
        for x in states:
            f(0.0, x)
    return (time.perf_counter() - began) / (repeat * len(states))


def chain_states(cells: int, cache_dir: str):
    """(workspace with the Jacobian, a few states of the chain's motion through its flat positions)."""
    system = mbs.loads(fourbar_chain(cells), cache_dir=cache_dir)
    start, _ = system.start(jacobian=True)
    data = Workspace(start.model)
    data.p, data.t, data.x = start.p, start.t, start.x.copy()
    result = simulate(start.model, data, 1.5, sample=0.25, integrator="dopri5", rtol=1e-8, atol=1e-10,
                      outputs=False)
    states = np.column_stack([result[name] for name in start.model.x_names])[1:]
    return start, states


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[10, 40])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--cache-dir", help="build cache to reuse (default: a fresh one; the 40-chain then "
                                            "takes a few minutes to compile)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as fresh:
        cache = args.cache_dir or fresh
        print(f"{'chain':>9} {'nx':>4} {'jacobian':>11} {'rhs':>9} {'jac/rhs':>8} {'differences':>12} "
              f"{'differences/jacobian':>21} {'|dJ|/|J|':>9}")
        for cells in args.cells:
            data, states = chain_states(cells, cache)
            jac, rhs = data.function("jacobian"), data.function("rhs")
            rounds = []
            for _ in range(args.rounds):
                rounds.append((per_call(jac, states), per_call(rhs, states, repeat=20),
                               per_call(lambda t, x: central_differences(rhs, t, x), states)))
            tj, tr, td = (statistics.median(r[i] for r in rounds) for i in range(3))
            ratio = statistics.median(r[2] / r[0] for r in rounds)
            deviation = statistics.median(np.abs(jac(0.0, x)[:, :-1] - central_differences(rhs, 0.0, x)).max()
                                          / np.abs(jac(0.0, x)).max() for x in states)
            print(f"{cells:>3} cells {data.model.nx:>4} {tj * 1e3:>8.2f} ms {tr * 1e3:>6.3f} ms {tj / tr:>8.1f} "
                  f"{td * 1e3:>9.1f} ms {ratio:>21.1f} {deviation:>13.1e}")


if __name__ == "__main__":
    main()
