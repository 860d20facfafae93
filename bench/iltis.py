"""The Iltis full vehicle: compile time, size, and the bump runs against scipy's RK45 as the baseline.

Prints the compile time (text to loaded library, fresh cache), the numbers of coordinates, velocities and
degrees of freedom, the generated C size, and for each bump scene the wall time and real-time factor
(simulated time / wall time) with the best integrator available (DOPRI5 in C) and with scipy's RK45
driving the same compiled model, as a ratio. Medians of --repeat runs.

    python bench/iltis.py [--repeat 3] [--scenes bump_5 bump_10]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

import mbs

MODEL = "library/iltis/vehicle.mbs"


def median_run(system, scene: str, integrator: str, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = system.simulate(scene, integrator=integrator)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        start = time.perf_counter()
        system = mbs.load(MODEL, cache_dir=cache)
        compiled = system.compile(args.scenes[0])
        compile_time = time.perf_counter() - start
        gen = system.generate(args.scenes[0])
        report = None
        print(f"model {MODEL}: compile {compile_time:.1f} s (text to loaded library, fresh cache)")
        print(f"  tree coordinates nq = {compiled.nq}, velocities nv = {compiled.nv}, "
              f"cut-joint constraint rows = {len(gen.constraints.names) if gen.constraints else 0}")
        from mbs.runtime.workspace import Workspace
        data = Workspace(compiled)
        if "loop_report" in compiled.functions:
            data.x = compiled.x0
            report = data.loop_report(0.0, compiled.x0)
        if report is not None:
            print(f"  degrees of freedom (rank of the constraint Jacobian): {int(report[6])}")
        print(f"  generated C: {len(gen.c_source) / 1024:.0f} KiB")
        print(f"\n{'scene':10s} {'t_end':>6s} {'dopri5 wall':>12s} {'RTF':>6s} {'RK45 wall':>10s} {'RTF':>6s} "
              f"{'RK45/dopri5':>12s}")
        for scene in args.scenes:
            t_end = system.scene(scene).t_end
            best, res = median_run(system, scene, "dopri5", args.repeat)
            base, res_base = median_run(system, scene, "RK45", max(1, args.repeat // 2))
            ok = "" if res.success and res_base.success else f"  ({res.message or res_base.message})"
            print(f"{scene:10s} {t_end:6.2f} {best:11.2f}s {t_end / best:6.2f} {base:9.2f}s {t_end / base:6.2f} "
                  f"{base / best:12.1f}{ok}")


if __name__ == "__main__":
    main()
