"""Cost of one right-hand-side call from Python: the compiled model vs plain NumPy calls (and Pinocchio's
``aba`` when installed), plus the cost of the same call made inside C.

    python bench/rhs_call.py [--calls N] [--repeats R]

Prints the median over R repeats of N calls each, in nanoseconds per call.  The model is the pendulum
fixture of the run-time tests (tests/runtime/fixtures/pendulum.c), built into the usual cache.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "runtime" / "fixtures"


def per_call(stmt, n: int, repeats: int, **names) -> float:
    """Median seconds per call of `stmt` over `repeats` runs of `n` calls."""
    times = timeit.repeat(stmt, globals=names, number=n, repeat=repeats)
    return statistics.median(times) / n


def pinocchio_aba():
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "hinge")
    model.appendBodyToJoint(joint, pin.Inertia(1.0, np.array([0.0, 0.0, -1.0]), np.eye(3) * 1e-6),
                            pin.SE3.Identity())
    data = model.createData()
    q, v, tau = np.array([0.5]), np.zeros(1), np.zeros(1)
    return lambda: pin.aba(model, data, q, v, tau)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=51)
    args = parser.parse_args(argv)
    from mbs.runtime.model import load_c, load_numpy
    from mbs.runtime.workspace import Workspace

    info = dict(p_default=[1.0, 1.0, 9.81], x0=[0.5, 0.0])
    c_data = Workspace(load_c(FIXTURES / "pendulum.c", **info))
    np_data = Workspace(load_numpy(FIXTURES / "pendulum_numpy.py", **info))
    x = np.array([0.5, 0.0])
    n, r = args.calls, args.repeats
    rows = [
        ("compiled rhs(t, x) from Python", per_call("f(0.0, x)", n, r, f=c_data.rhs, x=x)),
        ("same call timed inside C (model cost)", statistics.median(c_data.time_rhs(x, n) for _ in range(r))),
        ("np.empty(2) (allocation floor)", per_call("e(2)", n, r, e=np.empty)),
        ("np.add(x, x) (plain NumPy call)", per_call("add(x, x)", n, r, add=np.add, x=x)),
        ("NumPy back end rhs(t, x)", per_call("f(0.0, x)", max(1, n // 10), r, f=np_data.rhs, x=x)),
    ]
    aba = pinocchio_aba()
    if aba is not None:
        rows.append(("pinocchio.aba(model, data, q, v, tau)", per_call("aba()", n, r, aba=aba)))
    print(f"median of {r} x {n} calls, Python {sys.version.split()[0]}, NumPy {np.__version__}")
    for label, seconds in rows:
        print(f"  {label:<42s} {seconds * 1e9:8.1f} ns")
    overhead = rows[0][1] - rows[1][1]
    print(f"  {'=> Python->C overhead of rhs':<42s} {overhead * 1e9:8.1f} ns")
    return 0


if __name__ == "__main__":
    sys.exit(main())
