"""What a user hook costs: the belt example (library/examples/hook_friction.mbs) run with its friction law as
a plain expression, as a C hook and as a Python hook (through a ctypes callback on the C back end), dopri5,
3 s at rtol 1e-9. Prints each run's median wall time and its ratio to the plain expression, measured in the
same run (medians of repeated runs; the machine is shared and noisy). With a stiff integrator
(`--integrator rodasp`) the generated Jacobian takes the hook's derivative by central differences of the hook
(compiler/hooks.py): two more hook calls per argument and Jacobian.

    python bench/hooks.py [--repeats N] [--integrator rodasp]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import median_time  # noqa: E402

import mbs  # noqa: E402

EXAMPLE = ROOT / "library" / "examples" / "hook_friction.mbs"
HOOKS = ROOT / "library" / "examples" / "hooks"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--integrator", default="dopri5")
    args = parser.parse_args()
    spec = importlib.util.spec_from_file_location("friction_law", HOOKS / "friction_law.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    system = mbs.load(EXAMPLE)
    runs = {"plain expression": dict(params={"plain": 1}, hooks={"friction_law": module.friction_law}),
            "C hook": dict(hooks={"friction_law": str(HOOKS / "friction_law.c")}),
            "Python hook (ctypes)": dict(hooks={"friction_law": module.friction_law})}
    times = {}
    for label, options in runs.items():
        options["integrator"] = args.integrator
        res = system.simulate("cycles", **options)  # compiles (cached) and checks the run
        assert res.success, res.message
        times[label] = median_time(lambda: system.simulate("cycles", **options), args.repeats)
        steps = res.metadata["stats"].get("nfev", "?")
        print(f"{label:22s} {times[label] * 1e3:8.2f} ms  ({steps} rhs calls)")
    base = times["plain expression"]
    for label, t in times.items():
        print(f"{label:22s} {t / base:6.2f} x the plain expression")


if __name__ == "__main__":
    main()
