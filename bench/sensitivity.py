"""Forward sensitivities against their two alternatives, measured in the same run (medians of repeats):

* plain: one run of the scene (dopri5 in C, no sensitivities), the baseline;
* forward: `mbs.sensitivity.sensitivities` for k parameters (one augmented run, scipy DOP853, Python rhs);
* central FD: 2k + 1 full C runs (what the finite-difference check in the tests does).

    python bench/sensitivity.py [--model library/examples/double_pendulum.mbs] [--scene chaos] [--params m1,l1,l2]
        [--t-end 2] [--repeats 5]

Prints the times and the ratios forward/plain and forward/FD. The Python right-hand side of the augmented
system is the cost of a first version without a C integrator for it (runtime/sensitivity.py).
"""

from __future__ import annotations

import argparse

import mbs
from mbs.sensitivity import sensitivities
from timing import median_time  # bench/timing.py (the scripts run from bench/)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="library/examples/double_pendulum.mbs")
    ap.add_argument("--scene", default="chaos")
    ap.add_argument("--params", default="m1,l1,l2")
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    system = mbs.load(args.model)
    names = args.params.split(",")
    metrics = [f"final({n})" for n in system.compile(args.scene).q_names]
    values = dict(zip(system.compile(args.scene).p_names, system.compile(args.scene).p_default))

    def plain(params=None):
        res = system.simulate(args.scene, t_end=args.t_end, params=params)
        assert res.success, res.message

    def forward():
        sensitivities(system, args.scene, params=names, metrics=metrics, t_end=args.t_end)

    def central():
        plain()
        for name in names:
            for sign in (1, -1):
                plain({name: values[name] * (1 + sign * 1e-4)})

    forward()  # compile both variants outside the timing
    plain()
    t_plain, t_forward, t_fd = (median_time(f, args.repeats) for f in (plain, forward, central))
    print(f"{args.model} scene {args.scene}, t_end {args.t_end:g} s, {len(names)} parameters, "
          f"median of {args.repeats}")
    print(f"plain run (C dopri5)         {1e3 * t_plain:9.2f} ms")
    print(f"forward sensitivities        {1e3 * t_forward:9.2f} ms   {t_forward / t_plain:7.1f} x plain")
    print(f"central FD ({2 * len(names) + 1} full runs)    {1e3 * t_fd:9.2f} ms   forward/FD = {t_forward / t_fd:.2f}")


if __name__ == "__main__":
    main()
