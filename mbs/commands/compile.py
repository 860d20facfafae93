"""compile: the generated C, its header and a standalone library."""

from __future__ import annotations

from pathlib import Path

from .common import model_args


class Compile:
    help = "generate C for a model (or scene) and build it: DIR/<model>.c, .h and lib<model>.so"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene whose outputs to generate")
        p.add_argument("-o", "--output", default=".", metavar="DIR", help="output folder (default: .)")

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.standalone import write_standalone
        system = mbs.load(args.file, args.model)
        gen = system.generate(args.scene)
        paths = write_standalone(gen, Path(args.output))
        for path in paths:
            print(path)
        return 0
