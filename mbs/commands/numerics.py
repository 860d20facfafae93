"""numerics: stiffness, time scales and a recommended integrator from the linearisation at the start."""

from __future__ import annotations

from .common import model_args, param_arg, params_from_args
from .hook_args import hook_arg, hooks_from_args


class Numerics:
    help = ("numerics report at the start: eigenvalue spread, fastest/slowest motion, largest stable explicit "
            "step, recommended integrator and tolerance")

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose start and parameters to use (default: the first scene)")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.runtime.numerics_report import numerics_report
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        data, settings = system.start(scene, params=params_from_args(args, system), jacobian=True,
                                      hooks=hooks_from_args(args))
        report = numerics_report(data.model, data, settings["t_end"], system.coordinate_owners(data.model))
        print(f"{system.model.name}" + (f" / scene {scene}" if scene else "") + f", at t = {data.t:g} s")
        print(report.text())
        return 0
