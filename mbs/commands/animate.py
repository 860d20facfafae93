"""animate: a run as a self-contained HTML page (three.js) with play/pause, a time slider and speed."""

from __future__ import annotations

from .common import ProgressBar, model_args, param_arg, params_from_args
from .hook_args import hook_arg, hooks_from_args


class Animate:
    help = "simulate a scene and write a self-contained HTML animation (three.js): parts, road, play, slider, speed"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene to animate (default: the model's first scene, if any)")
        p.add_argument("-o", "--output", required=True, metavar="PAGE.html", help="the page to write")
        p.add_argument("--t-end", type=float, help="end time [s]")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs import pipeline
        from mbs.animation import animation
        from mbs.animation_page import write_page
        from mbs.language.diagnostics import Diagnostic, MbsError
        if not args.output.lower().endswith((".html", ".htm")):
            raise MbsError([Diagnostic("error", f"-o {args.output}: the animation is an .html page", None)])
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        params = params_from_args(args, system)
        hooks = hooks_from_args(args)
        progress = ProgressBar()
        try:
            res = system.simulate(scene, t_end=args.t_end, params=params, progress=progress, hooks=hooks)
        finally:
            progress.close()
        values = pipeline.parameter_values(system.model, {**pipeline.scene_overrides(system.scene(scene)), **params})
        path = write_page(animation(system, scene, res, values), args.output)
        print(f"{path}: {len(res)} samples, t = {res.t[0]:g} .. {res.t[-1]:g} s" +
              ("" if res.success else f" ({res.message})"))
        return 0 if res.success else 1
