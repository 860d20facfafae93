"""accuracy: error against run time of every integrator over a tolerance ladder (runtime/accuracy.py)."""

from __future__ import annotations

from .common import model_args, param_arg, params_from_args
from .hook_args import hook_arg, hooks_from_args


class Accuracy:
    help = ("work-precision table: every integrator over a tolerance ladder against a confirmed reference "
            "(error, wall time, rhs/Jacobian calls, steps)")

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene to run (default: the model's first scene, if any)")
        param_arg(p)
        hook_arg(p)
        p.add_argument("--integrators", help="comma-separated integrators (default: every C and SUNDIALS method, "
                                             "DOP853, Radau and BDF; mbs.runtime.accuracy.DEFAULT_INTEGRATORS)")
        p.add_argument("--tolerances", default="1e-3..1e-10",
                       help="comma-separated rtols, or a decade range A..B (default: %(default)s)")
        p.add_argument("--repeats", type=int, default=3, help="runs per point; wall time is their median")
        p.add_argument("--t-end", type=float, help="end time [s] (default: the scene's)")
        p.add_argument("--out", help="CSV of the table")
        p.add_argument("--plot", help="log-log work-precision plot (PNG/PDF/SVG)")

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.runtime.errors import UsageError
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        table = system.accuracy(scene, params=params_from_args(args, system), t_end=args.t_end,
                                integrators=([s.strip() for s in args.integrators.split(",") if s.strip()]
                                             if args.integrators else None),
                                tolerances=parse_tolerances(args.tolerances, UsageError), repeats=args.repeats,
                                hooks=hooks_from_args(args))
        print(f"{system.model.name}" + (f" / scene {scene}" if scene else "") + f", t = {table.times[0]:g} .. "
              f"{table.times[-1]:g} s")
        print(table.text())
        if args.out:
            table.to_csv(args.out)
        if args.plot:
            table.plot(args.plot, title=f"{system.model.name}" + (f", scene {scene}" if scene else ""))
        return 0


def parse_tolerances(text: str, error=ValueError) -> list[float]:
    """'1e-3,1e-6' as given, or 'A..B' every decade from A down to B."""
    try:
        if ".." in text:
            a, b = (float(s) for s in text.split(".."))
            lo, hi = sorted((round(__import__("math").log10(a)), round(__import__("math").log10(b))))
            return [10.0**k for k in range(hi, lo - 1, -1)]
        values = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise error(f"--tolerances {text}: give comma-separated numbers or a range like 1e-3..1e-10") from None
    if not values or any(not v > 0 for v in values):
        raise error(f"--tolerances {text}: tolerances must be positive")
    return values
