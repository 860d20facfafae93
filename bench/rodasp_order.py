"""dopri5, rodasp and rodas5p over a tolerance ladder on closed loops: steps, rhs calls, Jacobians, the error at the
end and wall time, with the ratios to dopri5 in the same run, at the same tolerance and at the same achieved
error (issue 11: the Rosenbrock methods' order on closed-loop mechanisms).

    python bench/rodasp_order.py [--models slider_crank iltis_bump] [--tolerances 1e-6 1e-8 1e-10 1e-12]
                                 [--rounds 3]

The error is the weighted RMS of the end state (weight 1e-2 + |reference|) against a reference run at rtol 1e-13
(dopri5; rodas5p's run at the same tolerance is printed as its check). atol = 1e-2 rtol. The observed order
between two tolerances is log(tol ratio) / log(step ratio): 5 for dopri5 and rodas5p, 4 for rodasp (its steps
grow as rtol^(-1/4)). Wall time: the median over --rounds runs, interleaved so that load on the machine hits
every method alike. At the same error: steps and wall time interpolated log-log along each method's ladder at
the errors every method reached. Nothing is asserted: figures for a reader.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

ROOT = Path(__file__).resolve().parent.parent
MODELS = {"slider_crank": ("library/examples/slider_crank.mbs", None),
          "iltis_bump": ("library/iltis/quarter_car.mbs", "bump_5")}
INTEGRATORS = ("dopri5", "rodasp", "rodas5p")


def weighted_error(x, x_ref):
    return float(np.sqrt(np.mean(((x - x_ref) / (1e-2 + np.abs(x_ref))) ** 2)))


def at_error(rows, target, key):
    """``key`` (steps or wall) at the achieved error ``target``, interpolated log-log along one ladder."""
    points = sorted((row["error"], row[key]) for row in rows if row["error"] > 0)
    errors = np.log([p[0] for p in points])
    values = np.log([p[1] for p in points])
    return float(np.exp(np.interp(math.log(target), errors, values)))


def ladder(name, tolerances, rounds):
    path, scene = MODELS[name]
    data, settings = mbs.load(ROOT / path).start(scene, jacobian=True)

    def run(integrator, rtol):
        work = Workspace(data.model)
        work.p, work.t, work.x = data.p, data.t, data.x.copy()
        started = time.perf_counter()
        res = simulate(data.model, work, settings["t_end"], integrator=integrator, rtol=rtol, atol=1e-2 * rtol,
                       outputs=False, max_steps=5_000_000)
        wall = time.perf_counter() - started
        return wall, res, np.array([res[n][-1] for n in data.model.x_names])

    _, _, x_ref = run("dopri5", 1e-13)
    _, _, x_check = run("rodas5p", 1e-13)
    print(f"\n{name} ({path}{', scene ' + scene if scene else ''}, t_end {settings['t_end']:g} s; "
          f"generated Jacobian: {'jacobian' in data.model.functions}); reference dopri5 at rtol 1e-13, "
          f"rodas5p there differs by {weighted_error(x_check, x_ref):.1e}")
    print(f"{'rtol':>7} {'integrator':10} {'steps':>7} {'rejected':>8} {'rhs':>8} {'rhs/step':>8} {'jac':>6} "
          f"{'error':>9} {'wall [s]':>9} {'steps/dopri5':>12} {'wall/dopri5':>11} {'order':>6}")
    rows = {integrator: [] for integrator in INTEGRATORS}
    for rtol in tolerances:
        walls, last = {integrator: [] for integrator in INTEGRATORS}, {}
        for _ in range(rounds):  # interleaved: load on the machine hits every method alike
            for integrator in INTEGRATORS:
                wall, res, x = run(integrator, rtol)
                walls[integrator].append(wall)
                last[integrator] = res.metadata["stats"], weighted_error(x, x_ref)  # the same in every round
        for integrator in INTEGRATORS:
            stats, error = last[integrator]
            row = dict(rtol=rtol, error=error, steps=stats["nsteps"], wall=statistics.median(walls[integrator]))
            order = ""
            if rows[integrator]:
                before = rows[integrator][-1]
                order = f"{math.log(before['rtol'] / rtol) / math.log(row['steps'] / before['steps']):.2f}"
            rows[integrator].append(row)
            base = rows["dopri5"][-1]  # dopri5 comes first
            print(f"{rtol:7.0e} {integrator:10} {stats['nsteps']:7d} {stats['nreject']:8d} {stats['nfev']:8d} "
                  f"{stats['nfev'] / stats['nsteps']:8.2f} {stats['njev']:6d} {error:9.2e} {row['wall']:9.4f} "
                  f"{row['steps'] / base['steps']:12.2f} {row['wall'] / base['wall']:11.2f} {order:>6}")
    common = [max(min(r["error"] for r in rows[i]) for i in INTEGRATORS),
              min(max(r["error"] for r in rows[i]) for i in INTEGRATORS)]
    targets = [10.0 ** k for k in range(math.ceil(math.log10(common[0])), math.floor(math.log10(common[1])) + 1)]
    print("\nat the same achieved error (interpolated log-log along each ladder):")
    print(f"{'error':>9} " + " ".join(f"{i + ' steps':>14} {'wall':>8}" for i in INTEGRATORS)
          + " " + " ".join(f"{i + ' steps/dopri5':>20} {'wall/dopri5':>11}" for i in INTEGRATORS[1:]))
    for target in targets:
        steps = {i: at_error(rows[i], target, "steps") for i in INTEGRATORS}
        wall = {i: at_error(rows[i], target, "wall") for i in INTEGRATORS}
        print(f"{target:9.0e} " + " ".join(f"{steps[i]:14.0f} {wall[i]:8.4f}" for i in INTEGRATORS) + " "
              + " ".join(f"{steps[i] / steps['dopri5']:20.2f} {wall[i] / wall['dopri5']:11.2f}"
                         for i in INTEGRATORS[1:]))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--tolerances", nargs="+", type=float, default=[1e-6, 1e-8, 1e-10, 1e-12])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    for name in args.models:
        ladder(name, args.tolerances, args.rounds)


if __name__ == "__main__":
    main()
