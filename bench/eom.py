"""`mbs eom` on the three-joint spatial arm and the Iltis quarter car: how long a reader waits for the equations.

    python bench/eom.py [--repeat R]

Each model is run R times (default 3) as a user runs it, `mbs eom FILE` in a fresh process, and so is
`mbs check FILE` in the same run as the baseline (start-up, parse, validate: what every command pays). Printed
per model: the median wall and CPU times of both and their ratio. The machine is shared, so the CPU time is the
steadier figure. Targets of issue 16: the arm under 5 s, the quarter car under 30 s.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"spatial arm": (ROOT / "tests" / "compiler" / "models" / "spatial_arm.mbs", 5.0),
          "Iltis quarter car": (ROOT / "library" / "iltis" / "quarter_car.mbs", 30.0)}


def timed(args: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one `mbs ...` run in a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "mbs.cli", *args], cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"mbs {' '.join(args)} failed:\n{done.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{'model':<20} {'eom wall':>9} {'eom CPU':>8} {'check wall':>11} {'check CPU':>10} {'eom/check CPU':>14}"
          f" {'target':>7}")
    for name, (path, target) in MODELS.items():
        eom, check = [], []
        for _ in range(args.repeat):
            check.append(timed(["check", str(path)]))
            eom.append(timed(["eom", str(path)]))
        ew, ec = (statistics.median(x[i] for x in eom) for i in (0, 1))
        cw, cc = (statistics.median(x[i] for x in check) for i in (0, 1))
        verdict = "ok" if ec < target else "MISSED"
        print(f"{name:<20} {ew:8.2f}s {ec:7.2f}s {cw:10.2f}s {cc:9.2f}s {ec / cc:14.1f} {target:5.0f} s {verdict}")


if __name__ == "__main__":
    main()
