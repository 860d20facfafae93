"""fmu: the model as an FMI 2.0 FMU (Model Exchange and Co-Simulation) for other simulation tools."""

from __future__ import annotations

from .common import model_args
from .hook_args import hook_arg, hooks_from_args


class Fmu:
    help = "export an FMI 2.0 FMU (Model Exchange and Co-Simulation) built from the generated C"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose outputs, start state and settings the FMU takes "
                                       "(default: the model's first scene, if any)")
        p.add_argument("-o", "--output", required=True, metavar="FILE.fmu", help="the FMU file to write")
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.fmu import export_fmu
        from mbs.language.diagnostics import Diagnostic, MbsError
        if not args.output.lower().endswith(".fmu"):
            raise MbsError([Diagnostic("error", f"-o {args.output}: an FMU file ends in .fmu", None)])
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        system.scene(scene)
        hooks = hooks_from_args(args)
        path = export_fmu(system, scene, args.output, hooks)
        compiled = system.compile(scene, hooks=hooks)
        print(f"{path}: FMI 2.0 ME+CS, {compiled.nx} states, {compiled.np} parameters, {compiled.ny} outputs")
        return 0
