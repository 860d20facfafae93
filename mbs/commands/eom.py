"""eom: the equations of motion written out, in named terms as NEWEUL printed them, or their value at a state."""

from __future__ import annotations

import sys

from .common import model_args, param_arg, params_from_args, split_assignment
from .hook_args import hook_arg, hooks_from_args


class Eom:
    help = "print the equations of motion M(y,t) v' + k(y,v,t) = q(y,v,t) in named terms, or their value at a state"

    FULL_MAX_VELOCITIES = 6  # written out without names, longer models are unreadable

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
        p.add_argument("--no-simplify", action="store_true", help="skip the simplification of the named terms")
        p.add_argument("--full", action="store_true",
                       help=f"M, k, q written out without named terms (at most {Eom.FULL_MAX_VELOCITIES} speeds)")
        p.add_argument("--at", nargs="+", metavar="NAME=VALUE",
                       help="print the numbers M, k, q at this state (unit optional: joint1.phi=30deg "
                            "der(joint1.phi)=1); unnamed coordinates and speeds take their initial values")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import numpy as np
        import sympy as sp

        import mbs
        from mbs.eom import equations_of_motion
        from mbs.language.diagnostics import Diagnostic, MbsError
        system = mbs.load(args.file, args.model)
        params = params_from_args(args, system)
        hooks = hooks_from_args(args)
        if args.at is not None:  # a hook needed for the numbers is missing: said before the derivation
            from mbs.runtime.hooks import bind, require_python
            require_python(bind(system.model.hooks, hooks, system.model.name), "mbs eom --at evaluates the "
                           "equations in Python")

        def progress(message: str) -> None:
            print(f"mbs eom: {message}", file=sys.stderr, flush=True)
        eq = equations_of_motion(system, simplify=not args.no_simplify, progress=progress)
        if args.at is not None:
            state = dict(_parse_state(text) for text in args.at)
            M, k, q = eq.at(state, params, hooks=hooks)
            with np.printoptions(precision=10, linewidth=160, suppress=False):
                print(f"{system.model.name} at " + ", ".join(f"{n} = {v:g}" for n, v in state.items()))
                print(f"y = [{', '.join(map(str, eq.y))}]\nv = [{', '.join(map(str, eq.v))}]")
                print(f"M =\n{M}\nk =\n{k.ravel()}\nq =\n{q.ravel()}")
            return 0
        if args.full:
            if len(eq.v) > Eom.FULL_MAX_VELOCITIES:
                raise MbsError([Diagnostic("error", f"model '{system.model.name}' has {len(eq.v)} speeds; --full "
                                                    f"writes out at most {Eom.FULL_MAX_VELOCITIES} (the named "
                                                    "form has no limit)", None)])
            M, k, q = eq.written_out()
            show = sp.latex if args.latex else sp.sstr
            for label, mat in (("M", M), ("k", k), ("q", q)):
                print(f"{label} = {show(mat)}")
            return 0
        print(eq.latex() if args.latex else eq.text())
        return 0


def _parse_state(text: str) -> tuple[str, float]:
    """NAME=VALUE[unit] of a coordinate or speed (the name is checked by EquationsOfMotion.at)."""
    name, number, unit = split_assignment(text, "--at", "joint1.phi=30deg")
    return name, number if unit is None else number * unit[0]
