"""The equations of motion of a model for reading, in the manner NEWEUL printed them, and their value at a state.

    from mbs.eom import equations_of_motion
    eq = equations_of_motion(mbs.load("tests/compiler/models/spatial_arm.mbs"))
    eq.M, eq.k, eq.q            # sympy matrices in named intermediates: M(y, t) v' + k(y, v, t) = q(y, v, t)
    eq.intermediates            # the kinematics of each body, in order
    print(eq.text()); print(eq.latex())
    M, k, q = eq.at({"joint1.phi": 0.3})   # numbers (NumPy) at a state; the rest from the model's inits

Conventions (stated once, here and in docs/equations.md): y are the joint coordinates, v the speeds (der(y),
or the angular velocity wx wy wz in frame b for quaternion joints). M is the symmetric positive definite mass
matrix; k holds the Coriolis, centrifugal and gyroscopic forces and the terms of prescribed motion (zero at
v = 0 without prescribed motion); q the applied forces: weights, springs, dampers, point forces and joint forces.
A generalized force is positive when it does positive work on a positive speed (q_i v_i > 0 drives the
coordinate forwards). Units: SI, per row the unit of the generalized force (N or N*m).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np
import sympy as sp

from mbs.compiler.lower import lower
from mbs.compiler.readable import Intermediate, ReadableEquations, readable_equations
from mbs.compiler.symbolic import parameter_symbol
from mbs.compiler.tree import Tree
from mbs.compiler.tree import t as T
from mbs.language.diagnostics import Diagnostic, MbsError

from . import pipeline
from .system import System


@dataclass(frozen=True)
class EquationsOfMotion:
    """ReadableEquations of a model with the state symbols named as the language names them (der(j.phi))."""

    system: System
    equations: ReadableEquations
    y: tuple
    v: tuple
    tree: Tree
    rates: tuple = ()  # (state, right-hand side) of the extra differential states (language/states.py)

    @property
    def M(self) -> sp.Matrix:
        return self.equations.M

    @property
    def k(self) -> sp.Matrix:
        return self.equations.k

    @property
    def q(self) -> sp.Matrix:
        return self.equations.q

    @property
    def intermediates(self) -> tuple[Intermediate, ...]:
        return self.equations.intermediates

    def written_out(self):
        """(M, k, q) with every intermediate substituted back (small models)."""
        return self.equations.written_out()

    def at(self, state: Mapping[str, float] | None = None, params: Mapping[str, float] | None = None,
           hooks: Mapping | None = None):
        """(M, k, q) as NumPy arrays at a state: coordinates and speeds by name (SI), the others at the model's
        initial values; parameters at their defaults unless given. hooks: Python implementations of the model's
        user hooks (the equations are evaluated in Python here; a C hook is refused)."""
        from mbs.runtime.hooks import bind, require_python
        model = self.system.model
        binding = bind(model.hooks, hooks, model.name)
        require_python(binding, "mbs eom --at evaluates the equations in Python")
        values = pipeline.parameter_values(model, params)
        names = tuple(pipeline.display_name(s.name) for s in self.tree.x_symbols)
        start = dict(zip(names, pipeline.initial_state_of(model, None, self.tree, values)))
        state = dict(state or {})
        unknown = [name for name in state if name not in start]
        if unknown:
            from mbs.language.scope import did_you_mean
            raise MbsError([Diagnostic("error", f"model '{model.name}' has no coordinate or speed '{unknown[0]}'"
                                                f"{did_you_mean(unknown[0], start)} (states: "
                                                f"{', '.join(start)})", None)])
        start.update(state)
        env = {parameter_symbol(name): value for name, value in values.items()}
        env.update({s: start[str(s)] for s in self.y + self.v + tuple(self.tree.states)})
        env[T] = 0.0
        M, k, q = self.equations.evaluate(env, binding.value if binding is not None else None)
        return tuple(np.array(m.tolist(), dtype=float).reshape(m.shape) for m in (M, k, q))

    def text(self) -> str:
        lines = [f"{self.system.model.name}: M(y, t) v' + k(y, v, t) = q(y, v, t)",
                 f"y = [{', '.join(map(str, self.y))}]", f"v = [{', '.join(map(str, self.v))}]"]
        section = None
        for item in self.intermediates:
            if item.section != section:
                section = item.section
                lines += ["", f"# {section}"]
            lines.append(f"{item.symbol} = {sp.sstr(item.expr)}")
        lines.append("")
        n = self.M.shape[0]
        for i in range(n):
            for j in range(i, n):
                if self.M[i, j] != 0:
                    lines.append(f"M[{i + 1},{j + 1}] = {sp.sstr(self.M[i, j])}")
        lines.append("(M is symmetric; entries not listed are zero)")
        lines.append("")
        lines += [f"k[{i + 1}] = {sp.sstr(x)}" for i, x in enumerate(self.k)]
        lines.append("")
        lines += [f"q[{i + 1}] = {sp.sstr(x)}" for i, x in enumerate(self.q)]
        if self.rates:
            lines += ["", "# extra states"] + [f"der({z}) = {sp.sstr(rate)}" for z, rate in self.rates]
        return "\n".join(lines)

    def latex(self) -> str:
        names = _latex_names(self)

        def tex(e):
            return sp.latex(e, symbol_names=names)
        lines = [f"% {self.system.model.name}: M(y, t) \\dot v + k(y, v, t) = q(y, v, t)", "\\begin{align*}"]
        section = None
        for item in self.intermediates:
            if item.section != section:
                section = item.section
                lines.append(f"&\\text{{{section}}} \\\\")
            lines.append(f"{tex(item.symbol)} &= {tex(item.expr)} \\\\")
        n = self.M.shape[0]
        for i in range(n):
            for j in range(i, n):
                if self.M[i, j] != 0:
                    lines.append(f"M_{{{i + 1},{j + 1}}} &= {tex(self.M[i, j])} \\\\")
        lines += [f"k_{{{i + 1}}} &= {tex(x)} \\\\" for i, x in enumerate(self.k)]
        lines += [f"q_{{{i + 1}}} &= {tex(x)} \\\\" for i, x in enumerate(self.q)]
        lines[-1] = lines[-1].removesuffix(" \\\\")
        lines.append("\\end{align*}")
        return "\n".join(lines)


def equations_of_motion(system: System, *, simplify: bool = True,
                        progress: Callable[[str], None] | None = None) -> EquationsOfMotion:
    """The model's equations of motion in named intermediates (the spanning tree's, for closed loops: the loop
    constraints are not part of M, k, q). `progress` receives a line for stages slower than a second."""
    lowered = lower(system.model)
    equations = readable_equations(lowered.kinematics, simplify=simplify, progress=progress)
    tree = lowered.tree
    shown = {s: sp.Symbol(pipeline.display_name(s.name)) for s in tree.q_symbols + tree.v_symbols}
    renamed = ReadableEquations(
        tuple(shown[s] for s in equations.y), tuple(shown[s] for s in equations.v),
        tuple(Intermediate(i.section, i.symbol, i.expr.xreplace(shown)) for i in equations.intermediates),
        *(m.xreplace(shown) for m in (equations.M, equations.k, equations.q)))
    rates = lowered.kinematics.tape.expand(lowered.state_rates) if lowered.state_rates else []
    return EquationsOfMotion(system, renamed, renamed.y, renamed.v, tree,
                             tuple(zip(tree.states, (r.xreplace(shown) for r in rates))))


def _latex_names(eq: EquationsOfMotion) -> dict:
    names = {}
    for s in eq.y:
        names[s] = f"\\mathrm{{{s}}}"
    for s in eq.v:
        text = str(s)
        names[s] = (f"\\dot{{\\mathrm{{{text[4:-1]}}}}}" if text.startswith("der(") else f"\\mathrm{{{text}}}")
    for item in eq.intermediates:
        head, _, tail = str(item.symbol).partition("_")
        names[item.symbol] = f"{head}_{{{tail}}}" if tail else head
    return names


__all__ = ["EquationsOfMotion", "equations_of_motion"]
