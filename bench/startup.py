"""Start-up cost of the command line: `mbs --help` and `mbs check` on a small model against the bare interpreter.

    python bench/startup.py [--runs 15]

Each command runs --runs times in a fresh interpreter (interleaved, so load changes hit all alike); printed
are the medians of wall time and of CPU time (user + system of the child, less sensitive to a shared machine's
load), and each as a ratio to `python -c pass` measured in the same run. The issue's target: `mbs --help` and
`mbs check` well under half a second. The first `mbs check` builds the parser tables into the build cache;
the warm-up run below does that before anything is measured.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "library" / "examples" / "pendulum.mbs"
COMMANDS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
    "mbs --help": [sys.executable, "-m", "mbs", "--help"],
    "mbs --version": [sys.executable, "-m", "mbs", "--version"],
    "mbs check pendulum.mbs": [sys.executable, "-m", "mbs", "check", str(MODEL)],
}


def run_once(cmd) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=15)
    args = parser.parse_args()
    for cmd in COMMANDS.values():  # warm-up: bytecode and parser-table caches
        run_once(cmd)
    samples = {name: ([], []) for name in COMMANDS}
    for _ in range(args.runs):
        for name, cmd in COMMANDS.items():
            wall, cpu = run_once(cmd)
            samples[name][0].append(wall)
            samples[name][1].append(cpu)
    base_wall = statistics.median(samples["python -c pass"][0])
    base_cpu = statistics.median(samples["python -c pass"][1])
    print(f"medians of {args.runs} runs (load average {os.getloadavg()[0]:.1f})")
    print(f"{'command':28s} {'wall [s]':>9} {'/ python':>9} {'cpu [s]':>9} {'/ python':>9}")
    for name, (walls, cpus) in samples.items():
        wall, cpu = statistics.median(walls), statistics.median(cpus)
        print(f"{name:28s} {wall:>9.3f} {wall / base_wall:>9.1f} {cpu:>9.3f} {cpu / base_cpu:>9.1f}")


if __name__ == "__main__":
    main()
