"""Derivation + C emission time of the N-link spatial pendulum.

Links of 1 kg and 1 m hang from revolute joints whose axes alternate between x and y; each link's frame is at its
upper joint, its centre of mass 0.5 m below, inertia diag(1/12, 1/12, 1e-3) kg m^2 about the centre. With
--symbolic the masses and lengths are run-time parameters m_i, l_i (inertia m_i l_i^2/12 about x and y).

    python bench/chain.py [--symbolic] [N ...]        (default N = 1 2 5 10 20 40)

Prints per N: derivation time, emission time, tape length, C size. Compilation and comparisons against other
codes are left to the caller.
"""

from __future__ import annotations

import argparse
import time

import sympy as sp

from mbs.compiler.ccode import generate_c
from mbs.compiler.equations import derive_equations
from mbs.compiler.kinematics import Kinematics
from mbs.compiler.tree import JointSpec, Tree, TreeBody

AXES = ((1, 0, 0), (0, 1, 0))
JZ = sp.Rational(1, 1000)  # polar inertia of a link [kg m^2]


def chain(n: int, symbolic: bool = False) -> Tree:
    """The n-link pendulum under gravity g (a parameter when symbolic, else 9.81)."""
    bodies = []
    for i in range(n):
        if symbolic:
            m, l = sp.symbols(f"m_{i + 1} l_{i + 1}")
        else:
            m, l = sp.Integer(1), sp.Integer(1)
        lp = 0 if i == 0 else (sp.Symbol(f"l_{i}") if symbolic else 1)
        inertia = sp.diag(m * l**2 / 12, m * l**2 / 12, JZ)
        bodies.append(TreeBody(f"link{i + 1}", i - 1, JointSpec("revolute", (AXES[i % 2],)),
                               (sp.eye(3), (0, 0, -lp)), (sp.eye(3), (0, 0, 0)), m, (0, 0, -l / 2), inertia))
    g = sp.Symbol("g") if symbolic else sp.Float(9.81)
    return Tree(tuple(bodies), (0, 0, -g))


def measure(n: int, symbolic: bool) -> dict:
    tree = chain(n, symbolic)
    t0 = time.perf_counter()
    eqs = derive_equations(Kinematics(tree))
    t1 = time.perf_counter()
    source = generate_c(eqs, eqs.parameters(), f"chain{n}")
    t2 = time.perf_counter()
    return {"n": n, "derive": t1 - t0, "emit": t2 - t1, "tape": len(eqs.tape), "bytes": len(source.encode())}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=[1, 2, 5, 10, 20, 40])
    parser.add_argument("--symbolic", action="store_true", help="masses and lengths as run-time parameters")
    args = parser.parse_args(argv)
    print(f"{'N':>4} {'derive [s]':>11} {'emit [s]':>9} {'total [s]':>10} {'tape':>7} {'C [KiB]':>8}")
    for n in args.sizes:
        r = measure(n, args.symbolic)
        print(f"{r['n']:>4} {r['derive']:>11.3f} {r['emit']:>9.3f} {r['derive'] + r['emit']:>10.3f} "
              f"{r['tape']:>7} {r['bytes'] / 1024:>8.1f}")


if __name__ == "__main__":
    main()
