"""eom: the equations of motion written out."""

from __future__ import annotations

from .common import model_args


class Eom:
    help = "print the equations of motion M(y,t) y'' + k(y,y',t) = q(y,y',t) of a small model"

    MAX_VELOCITIES = 6  # beyond this the written-out expressions are too long to read

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
        p.add_argument("--no-simplify", action="store_true", help="skip sympy's simplification (faster)")

    @staticmethod
    def run(args) -> int:
        import sympy as sp

        import mbs
        from mbs.compiler.equations import display_equations
        from mbs.compiler.lower import lower
        from mbs.language.diagnostics import Diagnostic, MbsError
        system = mbs.load(args.file, args.model)
        lowered = lower(system.model)
        tree = lowered.tree
        if tree.nv > Eom.MAX_VELOCITIES:
            raise MbsError([Diagnostic("error", f"model '{system.model.name}' has {tree.nv} velocities; mbs eom "
                                                f"writes equations out for at most {Eom.MAX_VELOCITIES}", None)])
        M, k, q = display_equations(lowered.kinematics, simplify=not args.no_simplify)
        from mbs.pipeline import display_name
        shown = {s: sp.Symbol(display_name(s.name)) for s in tree.q_symbols + tree.v_symbols}
        M, k, q = (m.xreplace(shown) for m in (M, k, q))
        y = sp.Matrix([shown[s] for s in tree.q_symbols])
        v = sp.Matrix([shown[s] for s in tree.v_symbols])
        if args.latex:
            print(f"% {system.model.name}: M(y, t) \\dot v + k(y, v, t) = q(y, v, t)")
            print(f"y = {sp.latex(y)}, \\quad v = {sp.latex(v)}")
            print(f"M = {sp.latex(M)}")
            print(f"k = {sp.latex(k)}")
            print(f"q = {sp.latex(q)}")
        else:
            print(f"{system.model.name}: M(y, t) v' + k(y, v, t) = q(y, v, t)")
            print(f"y = {list(y)}\nv = {list(v)}\n")
            for label, mat in (("M", M), ("k", k), ("q", q)):
                print(f"{label} =")
                print(sp.pretty(mat, use_unicode=False, wrap_line=False))
                print()
        return 0
