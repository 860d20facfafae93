"""compile: the generated C, its header and a standalone library."""

from __future__ import annotations

from pathlib import Path

from .common import model_args
from .hook_args import hook_arg, hooks_from_args


class Compile:
    help = "generate C for a model (or scene) and build it: DIR/<model>.c, .h and lib<model>.so"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose outputs to generate")
        p.add_argument("-o", "--output", default=".", metavar="DIR", help="output folder (default: .)")
        p.add_argument("--dynamics", action="store_true",
                       help="also mbs_inverse_dynamics, mbs_bias_forces, mbs_gravity_forces (docs/equations.md)")
        p.add_argument("--frame", action="append", default=[], metavar="PART.FRAME",
                       help="with --dynamics: position, velocity and Jacobian of this frame (repeatable)")
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.standalone import write_standalone
        from mbs.runtime.hooks import bind
        system = mbs.load(args.file, args.model)
        binding = bind(system.model.hooks, hooks_from_args(args), system.model.name)  # before the derivation
        gen = system.generate(args.scene, dynamics=args.dynamics or bool(args.frame), frames=tuple(args.frame),
                              cold_apart=False)  # the whole file: a library for other tools has every function
        paths = write_standalone(gen, Path(args.output), binding)
        for path in paths:
            print(path)
        return 0
