"""A parameter sweep on Dask against the same variants run one after another in this process.

    python bench/sweep.py [--model library/iltis/quarter_car.mbs] [--scene bump_5] [--variants 8] [--repeat 3]

Both runs use the same compiled model (compiled once before timing) and the same variants (by default the
speed v of the Iltis quarter car over the bump, spread over 2.5 .. 10 m/s). Dask: a local cluster of one worker per core,
started before timing (its start-up, a few seconds, is printed separately); serial: `system.simulate` in a
loop. Medians over --repeat rounds, both measured in every round (the machine is shared and noisy). The ratio
serial / Dask is the speed-up; on n cores it cannot exceed n.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np


def main() -> None:
    import mbs
    from mbs.studies import local_cluster, sweep
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="library/iltis/quarter_car.mbs")
    parser.add_argument("--scene", default="bump_5")
    parser.add_argument("--param", default="v")
    parser.add_argument("--low", type=float, default=2.5)
    parser.add_argument("--high", type=float, default=10.0)
    parser.add_argument("--variants", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    system = mbs.load(args.model)
    system.compile(args.scene)
    values = list(np.linspace(args.low, args.high, args.variants))
    started = time.perf_counter()
    client = local_cluster()
    print(f"local cluster of {len(client.scheduler_info()['workers'])} workers ({os.cpu_count()} cores) "
          f"started in {time.perf_counter() - started:.1f} s")
    sweep(system, args.scene, {args.param: values[:2]}, client=client)  # workers load the model once
    serial, dask = [], []
    try:
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            for v in values:
                system.simulate(args.scene, params={args.param: v})
            serial.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            table = sweep(system, args.scene, {args.param: values}, client=client)
            dask.append(time.perf_counter() - t0)
            assert not table.failed, table.failed[0].message
    finally:
        client.close()
        client.cluster.close()
    s, d = statistics.median(serial), statistics.median(dask)
    print(f"{args.variants} variants of {args.model} / {args.scene}: serial {s:.2f} s, Dask {d:.2f} s "
          f"(medians of {args.repeat}); speed-up serial / Dask = {s / d:.2f}")


if __name__ == "__main__":
    main()
