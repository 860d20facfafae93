"""tir: a Magic Formula TIR file as a parameter set for tyres.magic_formula instances of a model."""

from __future__ import annotations

from .common import model_args


class Tir:
    help = "convert a Magic Formula TIR file (units checked) into a parameter set for a model's tyres"

    @staticmethod
    def arguments(p):
        p.add_argument("tir", metavar="TIR", help="the TIR file")
        model_args(p)
        p.add_argument("--instance", action="append", required=True,
                       help="a tyres.magic_formula instance of the model, e.g. tyre_fl (repeatable)")
        p.add_argument("-o", "--out", required=True, help="the parameter set to write (NAME.params)")

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.base.atomic import write_text_atomic
        from mbs.paramsets import read
        from mbs.tir import parameter_set, read_tir
        from mbs.language.diagnostics import Diagnostic, MbsError
        system = mbs.load(args.file, args.model)
        coefficients = read_tir(args.tir)
        names = set(system.model.parameter_map)
        params = {n.split(".", 1)[1] for n in names if n.split(".", 1)[0] == args.instance[0] and "." in n}
        missing = [i for i in args.instance if f"{i}.PCX1" not in names]
        if missing:
            raise MbsError([Diagnostic("error", f"{', '.join(missing)}: not a tyres.magic_formula instance of model "
                                                f"'{system.model.name}'", None)])
        text, unused = parameter_set(coefficients, args.instance, params)
        write_text_atomic(args.out, text)
        from pathlib import Path
        read(Path(args.out), system.model)   # every line checked against the model, as --params will
        used = len(coefficients) - len(unused)
        print(f"{args.out}: {used} coefficients for {', '.join(args.instance)}"
              + (f"; not used by the model: {', '.join(unused)}" if unused else ""))
        return 0
