"""sensitivity: d(metric)/d(p) of a scene's run by the forward sensitivity equations (mbs/sensitivity.py)."""

from __future__ import annotations

from .common import model_args, parse_param
from .hook_args import hook_arg, hooks_from_args


class Sensitivity:
    help = ("derivatives of run metrics (final, peak, min, range, mean, rms, period of a state or output) with "
            "respect to parameters, by forward sensitivity equations integrated with the state")

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene to run (default: the model's first scene, if any)")
        p.add_argument("--param", action="append", default=[], metavar="NAME[=VALUE]", required=True,
                       help="a parameter to differentiate with respect to, optionally at another value than the "
                            "scene's (l or l=2m; repeatable)")
        p.add_argument("--metric", action="append", default=[], metavar="REDUCTION(COLUMN)",
                       help="e.g. period(hinge.phi), peak(der(hinge.phi)), final(x) (repeatable; default: peak "
                            "and final of each output)")
        p.add_argument("--method", default="DOP853",
                       help="scipy method for the augmented system: DOP853, RK45, Radau, BDF or LSODA "
                            "(default: %(default)s; checked by mbs.runtime.sensitivity)")
        p.add_argument("--t-end", type=float, help="end time [s] (default: the scene's)")
        p.add_argument("--out", help="CSV of the table (metric, parameter, value, p, derivative, normalised)")
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.sensitivity import sensitivities
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        names, at = [], {}
        for text in args.param:
            if "=" in text:
                name, value = parse_param(text, system.model)
                at[name] = value
            else:
                name = text.strip()
            names.append(name)
        table = sensitivities(system, scene, params=names, values=at, metrics=args.metric, t_end=args.t_end,
                              method=args.method, hooks=hooks_from_args(args))
        print(f"{system.model.name}" + (f" / scene {scene}" if scene else "") +
              f": forward sensitivities, {args.method}")
        print(table.text())
        if args.out:
            from mbs.base.atomic import write_text_atomic
            write_text_atomic(args.out, table.csv())
        return 0
