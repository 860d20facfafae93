"""The event form of the Iltis bump at 10 m/s against its smooth form, counted in instructions rather than timed.

    python bench/event_instructions.py [--scene bump_10]

Wall times of the two forms differ by a few per cent, less than a shared machine's noise (bench/events.py
printed ratios from 0.83 to 1.44 for the same code in one afternoon).  Instructions executed do not depend on
the load: each form runs in a child process under valgrind's callgrind (needs `valgrind` on the PATH), once
with one `simulate` (compile and warm-up) and once with three; the difference divided by two is the
instruction count of one whole `simulate` (equilibrium, integration, rows, event bookkeeping in Python
included).  The ratio event / smooth is issue 10's figure ("no slower": <= 1).  Takes a few minutes: callgrind
runs about 50 times slower than the machine.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"

#: The child: the vehicle with `switches` set in its model header, `count` runs of the scene.
CHILD = """
import sys
from pathlib import Path
import mbs
path, form, scene, count = Path(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
text = path.read_text()
header = next(line for line in text.splitlines() if line.startswith("model "))
system = mbs.loads(text.replace(header, header + "\\n    switches = " + form, 1), path=str(path))
for _ in range(count):
    system.simulate(scene)
"""


def instructions(form: str, scene: str, count: int, workdir: Path) -> int:
    """Instructions callgrind counts for the child with `count` runs of the scene."""
    out = workdir / f"callgrind.{form}.{count}"
    done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c",
                           CHILD, str(MODEL), form, scene, str(count)], capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or not found:
        raise SystemExit(f"valgrind run failed ({form}, {count} runs):\n{done.stderr[-2000:]}")
    return int(found.group(1))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bump_10")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not on the PATH: nothing to count")
        return 1
    for form in ("false", "true"):  # compile both forms outside valgrind first: the counts then hold no build
        subprocess.run([sys.executable, "-c", CHILD, str(MODEL), form, args.scene, "1"], check=True)
    per_run = {}
    with tempfile.TemporaryDirectory() as tmp:
        for form in ("false", "true"):
            one, three = (instructions(form, args.scene, n, Path(tmp)) for n in (1, 3))
            per_run[form] = (three - one) / 2
    smooth, events = per_run["false"], per_run["true"]
    print(f"Iltis {args.scene}, dopri5, instructions of one whole simulate() (callgrind, load-independent):")
    print(f"  smooth form (switches = false, baseline) {smooth / 1e6:10.1f} M")
    print(f"  event form  (switches = true)            {events / 1e6:10.1f} M   ratio {events / smooth:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
