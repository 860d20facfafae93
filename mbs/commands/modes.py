"""modes: the modes of a vehicle at speed, named by their motion; a root locus over a speed range."""

from __future__ import annotations

from .common import model_args, param_arg, params_from_args
from .hook_args import hook_arg, hooks_from_args


def parse_speeds(text: str) -> list[float]:
    """'20' -> [20]; '5:30:5' -> 5, 10, ..., 30 (start:stop:step, stop included); '5,10,20' -> a list."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    try:
        if ":" in text:
            start, stop, step = (float(p) for p in text.split(":"))
            if step <= 0 or stop < start:
                raise ValueError
            count = int(round((stop - start) / step)) + 1
            return [start + i * step for i in range(count)]
        return [float(p) for p in text.split(",")]
    except ValueError:
        raise MbsError([Diagnostic("error", f"--speed expects V, V1,V2,... or START:STOP:STEP in m/s; got '{text}'",
                                   None)]) from None


class Modes:
    help = "modes about the steady straight run at a speed: frequency, damping, name; --speed A:B:S: root locus"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose parameters to use (its start state, at the given speed)")
        p.add_argument("--speed", default="0", help="m/s: one speed, a list 5,10,20 or a range 5:30:5 "
                                                    "(default 0: at rest)")
        p.add_argument("--speed-param", default="v", help="the model's speed parameter (default v)")
        p.add_argument("--rigid", action="store_true", help="also list the rigid-body motions (0 Hz)")
        p.add_argument("--out", help="mode shapes and energy shares as JSON")
        p.add_argument("--plot", help="root locus over the speeds (PNG/PDF/SVG)")
        p.add_argument("--shapes", help="the mode shapes as a picture: energy shares per mode, at the first speed")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import json

        import mbs
        from mbs.base.atomic import write_text_atomic
        from mbs.modes import plot_root_locus, plot_shapes, root_locus, table
        system = mbs.load(args.file, args.model)
        if args.speed_param not in system.model.parameter_map:
            from mbs.language.diagnostics import Diagnostic, MbsError
            raise MbsError([Diagnostic("error", f"model '{system.model.name}' has no speed parameter "
                                                f"'{args.speed_param}' (name it with --speed-param)", None)])
        params = params_from_args(args, system)
        locus = root_locus(system, args.scene, parse_speeds(args.speed), params=params,
                           speed_param=args.speed_param, hooks=hooks_from_args(args))
        for speed, modes in locus.items():
            print(f"{system.model.name}" + (f" / scene {args.scene}" if args.scene else "")
                  + f": modes about the steady run at {speed:g} m/s")
            print(table(modes, rigid=args.rigid))
        if args.out:
            write_text_atomic(args.out, json.dumps({f"{v:g}": [m.as_dict() for m in modes]
                                                    for v, modes in locus.items()}, indent=1))
            print(f"mode shapes written to {args.out}")
        if args.plot:
            plot_root_locus(locus, args.plot, system.model.name)
            print(f"root locus written to {args.plot}")
        if args.shapes:
            speed, modes = next(iter(locus.items()))
            plot_shapes(modes, args.shapes, f"{system.model.name}: modes at {speed:g} m/s")
            print(f"mode shapes drawn in {args.shapes}")
        return 0
