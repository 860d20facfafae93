"""rodasp against dopri5 over a tolerance ladder on closed loops: steps, rhs calls, Jacobians and the error at
the end, as ratios to dopri5 in the same run (issue 11: rodasp's order on closed-loop mechanisms).

    python bench/rodasp_order.py [--models slider_crank iltis_bump] [--tolerances 1e-6 1e-8 1e-10 1e-12]

The error is the weighted RMS of the end state (weight 1e-2 + |reference|) against dopri5 at rtol 1e-13;
atol = 1e-2 rtol. The observed order between two tolerances is log(tol ratio) / log(step ratio), which is 4
for a Rosenbrock method of order 4 with an exact Jacobian and drops when the Jacobian is not (finite
differences of the loop solver). Nothing is asserted: figures for a reader.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

ROOT = Path(__file__).resolve().parent.parent
MODELS = {"slider_crank": ("library/examples/slider_crank.mbs", None),
          "iltis_bump": ("library/iltis/quarter_car.mbs", "bump_5")}


def ladder(name, tolerances):
    path, scene = MODELS[name]
    data, settings = mbs.load(ROOT / path).start(scene, jacobian=True)

    def run(integrator, rtol):
        work = Workspace(data.model)
        work.p, work.t, work.x = data.p, data.t, data.x.copy()
        res = simulate(data.model, work, settings["t_end"], integrator=integrator, rtol=rtol, atol=1e-2 * rtol,
                       outputs=False, max_steps=5_000_000)
        return res, np.array([res[n][-1] for n in data.model.x_names])

    _, x_ref = run("dopri5", 1e-13)
    print(f"\n{name} ({path}{', scene ' + scene if scene else ''}, t_end {settings['t_end']:g} s; "
          f"generated Jacobian: {'jacobian' in data.model.functions})")
    print(f"{'rtol':>7} {'integrator':10} {'steps':>7} {'rejected':>8} {'rhs':>8} {'jac':>6} {'error':>9} "
          f"{'steps/dopri5':>12} {'order':>6}")
    previous = {}
    for rtol in tolerances:
        base = None
        for integrator in ("dopri5", "rodasp"):
            res, x = run(integrator, rtol)
            stats = res.metadata["stats"]
            error = float(np.sqrt(np.mean(((x - x_ref) / (1e-2 + np.abs(x_ref))) ** 2)))
            base = base or stats["nsteps"]
            order = ""
            if integrator in previous:
                tol0, steps0 = previous[integrator]
                order = f"{math.log(tol0 / rtol) / math.log(stats['nsteps'] / steps0):.2f}"
            previous[integrator] = (rtol, stats["nsteps"])
            print(f"{rtol:7.0e} {integrator:10} {stats['nsteps']:7d} {stats['nreject']:8d} {stats['nfev']:8d} "
                  f"{stats['njev']:6d} {error:9.2e} {stats['nsteps'] / base:12.2f} {order:>6}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--tolerances", nargs="+", type=float, default=[1e-6, 1e-8, 1e-10, 1e-12])
    args = parser.parse_args()
    for name in args.models:
        ladder(name, args.tolerances)


if __name__ == "__main__":
    main()
