"""Cost of every integrator on a stiff, a closed-loop and a vehicle model, as ratios to dopri5 in the same run.

    python bench/integrators.py [--models stiff_mount slider_crank iltis_bump vehicle_bump] [--integrators ...]
        [--rounds 3]

For each model (its scene's tolerances) and integrator: accepted+rejected steps, right-hand-side calls,
Jacobian evaluations, wall time (median over --rounds runs; the machine may be shared), and the ratio of the
wall time to dopri5's measured in the same rounds. Each model is compiled with the generated Jacobian where it
has one (trees and closed loops; not with lookup tables), so rodasp, Radau, BDF, cvode_bdf and ida use it.
The end state's difference to a tight dopri5 run is printed so a fast but wrong run is visible.

Nothing is asserted: figures are printed for a reader to compare.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

ROOT = Path(__file__).resolve().parent.parent
MODELS = {
    # name: (file, scene)
    "stiff_mount": ("tests/runtime/models/stiff_mount.mbs", "drop"),
    "slider_crank": ("library/examples/slider_crank.mbs", None),
    "iltis_bump": ("library/iltis/quarter_car.mbs", "bump_5"),
    "vehicle_bump": ("library/iltis/vehicle.mbs", "bump_5"),  # the full vehicle: on request (--models)
}
DEFAULT_MODELS = ("stiff_mount", "slider_crank", "iltis_bump")
INTEGRATORS = ("dopri5", "adams", "auto", "rodasp", "rodas5p", "cvode_adams", "cvode_bdf", "ida", "Radau", "BDF")


def run(model, data, settings, integrator, max_steps):
    work = Workspace(model)
    work.p, work.t, work.x = data.p, data.t, data.x.copy()
    started = time.perf_counter()
    res = simulate(model, work, settings["t_end"], sample=settings.get("sample"), integrator=integrator,
                   rtol=settings["rtol"], atol=settings["atol"], max_steps=max_steps, outputs=False)
    return time.perf_counter() - started, res


def bench(name, integrators, rounds, max_steps):
    path, scene = MODELS[name]
    system = mbs.load(ROOT / path)
    data, settings = system.start(scene, jacobian=True)
    model = data.model
    _, reference = run(model, data, dict(settings, rtol=1e-11, atol=1e-13), "dopri5", 10 * max_steps)
    x_ref = np.array([reference[n][-1] for n in model.x_names])
    walls = {i: [] for i in integrators}
    results = {}
    for _ in range(rounds):  # interleaved, so load changes hit every integrator alike
        for integrator in integrators:
            wall, results[integrator] = run(model, data, settings, integrator, max_steps)
            walls[integrator].append(wall)
    base = statistics.median(walls["dopri5"]) if "dopri5" in walls else float("nan")
    print(f"\n{name} ({path}{', scene ' + scene if scene else ''}; rtol {settings['rtol']:g}, atol {settings['atol']:g}, "
          f"t_end {settings['t_end']:g} s; generated Jacobian: {'jacobian' in model.functions})")
    print(f"{'integrator':<12} {'steps':>8} {'rejected':>8} {'rhs':>9} {'jac':>7} {'rhs/step':>8} {'wall [s]':>9} "
          f"{'/dopri5':>8} {'end error':>10}  status")
    for integrator in integrators:
        res = results[integrator]
        st = res.metadata["stats"]
        wall = statistics.median(walls[integrator])
        n = len(res[model.x_names[0]])
        x = np.array([res[k][n - 1] for k in model.x_names]) if n else np.full(model.nx, np.nan)
        error = np.max(np.abs(x - x_ref) / (1e-3 + np.abs(x_ref)))
        print(f"{integrator:<12} {st['nsteps']:>8} {st['nreject']:>8} {st['nfev']:>9} {st['njev']:>7} "
              f"{st['nfev'] / max(1, st['nsteps']):>8.2f} {wall:>9.4f} {wall / base:>8.2f} {error:>10.2e}  "
              f"{res.metadata['status']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=list(DEFAULT_MODELS), choices=list(MODELS))
    parser.add_argument("--integrators", nargs="+", default=list(INTEGRATORS))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--max-steps", type=int, default=2_000_000)
    args = parser.parse_args()
    integrators = ["dopri5"] + [i for i in args.integrators if i != "dopri5"]
    for name in args.models:
        bench(name, integrators, args.rounds, args.max_steps)


if __name__ == "__main__":
    main()
