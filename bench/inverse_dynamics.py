"""Inverse dynamics per call: our generated mbs_inverse_dynamics against Pinocchio's rnea, on bench/chain.py's chain.

    python bench/inverse_dynamics.py [N ...] [--states S] [--calls C] [--repeat R]

Per N (default: chain.py's sizes 1 2 5 10 20 40), in the same run: id/py, our inverse dynamics called from
Python (the compiled function, one call per state); rnea/py, ``pinocchio.rnea(model, data, q, v, a)`` the same
way; id/C, ours timed inside C (no Python in the loop). Medians over batches at several random states, ours and
Pinocchio's batches interleaved (the machine is shared). |dtau| is the largest difference of the two results:
both compute the same joint forces. Target of issue 16: ours no slower at every N (id/py / rnea/py <= 1).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from chain import SIZES, chain_text, per_call, pinocchio_chain  # noqa: E402


def compiled_dynamics(n: int):
    import mbs
    from mbs.dynamics import dynamics_functions
    with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
        return dynamics_functions(mbs.loads(chain_text(n), cache_dir=cache, backend="c"))


def measure(n: int, states: int, calls: int, repeats: int, rng) -> dict:
    import pinocchio as pin
    dyn = compiled_dynamics(n)
    model = pinocchio_chain(n)
    pdata = model.createData()
    inverse = dyn.data.function("inverse_dynamics")
    ours, rnea, in_c, diff = [], [], [], 0.0
    for _ in range(states):
        q, v, a = rng.uniform(-1.5, 1.5, n), rng.normal(size=n), rng.normal(size=n)
        xa = np.concatenate([q, v, a])
        diff = max(diff, float(np.abs(inverse(0.0, xa) - pin.rnea(model, pdata, q, v, a)).max()))
        for _ in range(repeats):
            ours.append(per_call(inverse, (0.0, xa), calls))
            rnea.append(per_call(pin.rnea, (model, pdata, q, v, a), calls))
            in_c.append(inverse.time(xa, calls))
    return {"n": n, "id_py": statistics.median(ours), "rnea_py": statistics.median(rnea),
            "id_c": statistics.median(in_c), "diff": diff}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=list(SIZES))
    parser.add_argument("--states", type=int, default=3)
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    print(f"{'N':>3} {'id/py us':>9} {'rnea/py us':>11} {'id/C us':>8} {'id/py / rnea/py':>16} {'|dtau|':>9}")
    worst = 0.0
    for n in args.sizes:
        row = measure(n, args.states, args.calls, args.repeat, rng)
        ratio = row["id_py"] / row["rnea_py"]
        worst = max(worst, ratio)
        print(f"{n:>3} {1e6 * row['id_py']:9.2f} {1e6 * row['rnea_py']:11.2f} {1e6 * row['id_c']:8.3f} "
              f"{ratio:16.2f} {row['diff']:9.1e}", flush=True)
    print(f"target id/py / rnea/py <= 1 at every N: worst {worst:.2f} -> {'ok' if worst <= 1.0 else 'MISSED'}")


if __name__ == "__main__":
    main()
