"""The NumPy back end: the same functions as the C file (see ccode.py), as the text of one Python module.

For machines without a C compiler. The module mirrors the C file line by line (the same temporaries under the
same names, the same function library: `pow`, `fabs`, ... are the C library's, reached through `math`) and
fulfils the runtime's contract (runtime/backends.py, NumpyBackend):

    MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK   and MBS_NY when the model has outputs
    mbs_rhs(t, x, p, out, work) -> int          out (nx,)       x = [q; v], p: float arrays
    mbs_mass_matrix(t, x, p, out, work) -> int  out (nv, nv)
    mbs_forces(t, x, p, out, work) -> int       out (nv,)
    mbs_qdot(t, x, p, out, work) -> int         out (nq,)
    mbs_outputs(t, x, p, out, work) -> int      out (ny,)       only with outputs
    MBS_STATE_NAMES, MBS_PARAMETER_NAMES (and MBS_OUTPUT_NAMES): tuples of str

with the C statuses: 0 ok, 1 mass matrix or articulated-inertia pivot not positive, 2 a result not finite. The
inputs are small vectors, so a function reads them into Python floats once (`x.tolist()`): scalar `math` is
several times faster than NumPy's per-element ufuncs, and a division by zero, an overflow or a domain error
raises, which the function turns into status 2 (C gets inf or NaN there, which gives 2 too). The one difference:
a NaN that C drops again (fmax(NaN, 0), a comparison) leaves C at status 0 where Python already returned 2.

The text is written from sympy expressions by the printer below, never from model text: names are identifiers
made by `identifier`, strings are `repr`s, so importing the module runs nothing a model file wrote.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import sympy as sp

from .emit_common import (INLINE_MAX_CHARS, PREC_LOGIC, CodegenError, ExprPrinter, Naming,  # noqa: F401
                          Routine, check_inputs, describe, equation_routines, plan_routine, printable,
                          table_slopes)
from .equations import Equations
from .gc_pause import paused
from .jacobian import jacobian_or_none, parameter_jacobian_or_none
from .reactions import ACCELERATION_ARRAY

GENERATOR = "mbs.compiler.pycode"

#: Functions the printed expressions may call that the `math` module provides under the same name.
MATH_NAMES = ("acos", "asin", "atan", "atan2", "ceil", "cos", "cosh", "exp", "fabs", "floor", "log", "nan", "pow",
              "sin", "sinh", "sqrt", "tan", "tanh")


class PyPrinter(ExprPrinter):
    """Python text of a sympy expression (C semantics: math.pow, fmax/fmin helpers, NaN for no branch)."""

    LANGUAGE = "Python"
    AND, OR, TRUE, FALSE, NAN = "and", "or", "True", "False", "nan"

    def _conditional(self, cond, then, otherwise):
        return f"({then} if {cond} else {otherwise})"

    def _not(self, text):
        return f"not ({text})", PREC_LOGIC


#: Module-level helpers, defined only when the functions call them. fmax/fmin follow C99: a NaN argument
#: yields the other one.
HELPERS = {
    "fmax": '''def fmax(a, b):
    """C99 fmax: the larger of a and b; the other one when one is NaN."""
    return b if a != a or b > a else a''',
    "fmin": '''def fmin(a, b):
    """C99 fmin: the smaller of a and b; the other one when one is NaN."""
    return b if a != a or b < a else a''',
    "mbs_pow3": '''def mbs_pow3(x):
    """x^3 as the C code computes it: (x*x)*x."""
    return x * x * x''',
    "mbs_pow4": '''def mbs_pow4(x):
    """x^4 as the C code computes it: two squarings."""
    x2 = x * x
    return x2 * x2''',
    "mbs_sign": '''def mbs_sign(x):
    """-1.0, 0.0 or 1.0 (0.0 for NaN, like the model language's sign)."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)''',
    "mbs_lookup": '''def mbs_lookup(x, xs, ys, ms):
    """y(x) by binary search in the increasing knots xs: linear when ms is None, else the cubic Hermite
    interpolant with the knot slopes ms; the end values beyond the ends, NaN for NaN."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    if x != x:
        return x
    hi = bisect_right(xs, x)
    lo = hi - 1
    h = xs[hi] - xs[lo]
    s = (x - xs[lo]) / h
    if ms is None:
        return ys[lo] + s * (ys[hi] - ys[lo])
    s2 = s * s
    s3 = s2 * s
    return ((2.0 * s3 - 3.0 * s2 + 1.0) * ys[lo] + (s3 - 2.0 * s2 + s) * h * ms[lo]
            + (-2.0 * s3 + 3.0 * s2) * ys[hi] + (s3 - s2) * h * ms[hi])''',
    "mbs_not_positive": '''def mbs_not_positive(d):
    """The status of a failed pivot check: 1 when d <= 0, 2 when d is NaN."""
    return 1 if d <= 0.0 else 2''',
}

ALWAYS = '''def mbs_all_finite(a):
    """True if no entry of the array a is inf or NaN."""
    return bool(numpy.isfinite(a).all())


def mbs_positive_definite(A):
    """1 if the symmetric matrix A (its lower triangle) is positive definite: the Cholesky factorisation of
    the C file, step by step."""
    n = len(A)
    A = A.tolist()
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = A[i][j]
            for k in range(j):
                s -= L[i][k] * L[j][k]
            if i == j:
                if not s > 0.0:
                    return 0
                L[i][i] = sqrt(s)
            else:
                L[i][j] = s / L[j][j]
    return 1'''


class PyEmitter:
    """Writes the NumPy module of `equations`; arguments as for ccode.CEmitter."""

    def __init__(self, equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
                 outputs=(), tables=(), origin: str = "", inline_max_chars: int = INLINE_MAX_CHARS,
                 run_time_inputs=(), jacobian: bool = False, parameter_jacobian: bool = False,
                 dynamics=None, events=(), actions=()):
        self.eqs, self.model_name, self.inline_max_chars = equations, model_name, inline_max_chars
        self.jacobian = self.parameter_jacobian = None
        if jacobian:
            self.eqs, self.jacobian = jacobian_or_none(equations)
        if parameter_jacobian:
            self.eqs, self.parameter_jacobian = parameter_jacobian_or_none(self.eqs, parameters)
        self.run_time_inputs = tuple(run_time_inputs)
        self.dynamics_routines, dynamics_inputs, *frames = dynamics if dynamics is not None else ([], ())
        self.frame_names = tuple(frames[0]) if frames else ()
        self.parameters = tuple(parameters)
        self.outputs = tuple((str(name), sp.sympify(e)) for name, e in outputs)
        self.events = tuple((str(name), sp.sympify(e)) for name, e in events)
        self.actions = tuple((str(name), sp.sympify(e)) for name, e in actions)
        self.tables = tuple(getattr(tables, "tables", tables))
        self.origin = origin
        check_inputs(equations, self.parameters, self.outputs + self.events + self.actions, self.tables, run_time_inputs=self.run_time_inputs)
        self.naming = Naming(self.eqs, self.parameters, self.run_time_inputs + tuple(dynamics_inputs))

    def source(self) -> str:
        printer = PyPrinter(self.naming.names, len(self.tables))
        functions = [self._function(plan_routine(self.eqs.tape, self.naming, printer, name, out, doc, shape,
                                                 results, check_positive=positive,
                                                 inline_max_chars=self.inline_max_chars))
                     for name, out, doc, shape, results, positive in self._routines()]
        used = printer.used | {"sqrt"}  # mbs_positive_definite
        if self.tables:
            used.add("mbs_lookup")
        if any(step.guard is not None for f in functions for step in f[1]):
            used.add("mbs_not_positive")
        parts = [self._header(used), *(HELPERS[h] for h in sorted(HELPERS) if h in used), ALWAYS,
                 *self._tables(), *(text for text, _ in functions)]
        return "\n\n\n".join(parts) + "\n"

    def _routines(self) -> list:
        return (equation_routines(self.eqs, self.outputs, self.events, self.actions) + list(self.dynamics_routines)
                + [r for r in (self.jacobian, self.parameter_jacobian) if r])

    def write(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.source())
        return path

    def _header(self, used: set) -> str:
        tree = self.eqs.tree
        text = describe(self.eqs, self.parameters, self.outputs, self.tables, self.model_name, self.origin,
                        GENERATOR, self.inline_max_chars)
        text += ["", "Functions mbs_<name>(t, x, p, out, work) -> status write into out (shapes in MBS_<N..>); "
                 "work is unused."]
        # A docstring must not be ended or escaped by the text it shows.
        doc = "\n".join(_docstring_text(line).rstrip() for line in text)
        imports = [f"from math import {', '.join(sorted(n for n in MATH_NAMES if n in used))}"]
        if self.tables:
            imports.insert(0, "from bisect import bisect_right")
        names = [s.name for s in tree.x_symbols]
        lines = [f'"""{doc}\n"""', "", *imports, "", "import numpy", "",
                 f"MBS_MODEL = {self.model_name!r}",
                 f"MBS_NQ = {tree.nq}  # free position coordinates",
                 f"MBS_NV = {tree.nv}  # free velocity coordinates",
                 *([f"MBS_NZ = {tree.nz}  # extra differential states", "MBS_NX = MBS_NQ + MBS_NV + MBS_NZ"]
                   if tree.nz else ["MBS_NX = MBS_NQ + MBS_NV"]),
                 f"MBS_NP = {len(self.parameters)}  # parameters",
                 f"MBS_NWORK = {tree.nv * tree.nv}  # doubles of work memory (the C file's size; unused here)"]
        if self.outputs:
            lines.append(f"MBS_NY = {len(self.outputs)}  # outputs")
        if self.dynamics_routines:
            lines.append("MBS_NXA = MBS_NX + MBS_NV  # input [q; v; a] of mbs_inverse_dynamics")
        if self.frame_names:
            lines += [f"MBS_NF = {len(self.frame_names)}  # named frames",
                      f"MBS_FRAME_NAMES = {self.frame_names!r}"]
        if self.events:
            lines.append(f"MBS_NEV = {len(self.events)}  # event indicators (mbs_events)")
        if self.actions:
            lines.append(f"MBS_NACT = {len(self.actions)}  # values of event actions (mbs_event_actions)")
        lines += [f"MBS_STATE_NAMES = {tuple(names)!r}",
                  f"MBS_PARAMETER_NAMES = {tuple(s.name for s in self.parameters)!r}"]
        if self.outputs:
            lines.append(f"MBS_OUTPUT_NAMES = {tuple(name for name, _ in self.outputs)!r}")
        return "\n".join(lines)

    def _tables(self) -> list[str]:
        parts = []
        for k, table in enumerate(self.tables):
            smooth = table.method == "smooth"
            lines = [f"mbs_table_{k}_x = {tuple(float(v) for v in table.xs)!r}",
                     f"mbs_table_{k}_y = {tuple(float(v) for v in table.ys)!r}"]
            if smooth:
                lines.append(f"mbs_table_{k}_m = {table_slopes(table.xs, table.ys)!r}")
            kind = "monotone cubic" if smooth else "linear"
            lines += ["", "", f"def mbs_table_{k}(x):",
                      f'    """Lookup table {k}: {kind} interpolation in {len(table.xs)} points, constant beyond '
                      'the ends."""',
                      f"    return mbs_lookup(x, mbs_table_{k}_x, mbs_table_{k}_y, "
                      f"{f'mbs_table_{k}_m' if smooth else 'None'})"]
            parts.append("\n".join(lines))
        return parts

    def _function(self, r: Routine) -> tuple:
        """(text, steps) of one function."""
        lines = [f"def {r.name}(t, x, p, out, work):", f'    """{_docstring_text(r.doc)}."""']
        arrays = [a for a in ("x", "p") if any(array == a for _, _, array, _ in r.reads)]
        if any(array == ACCELERATION_ARRAY for _, _, array, _ in r.reads):
            lines += ["    # the accelerations at (t, x) first", "    mbs_xdot = numpy.empty(MBS_NX)",
                      "    mbs_status = mbs_rhs(t, x, p, mbs_xdot, work)", "    if mbs_status != 0:",
                      "        return mbs_status", f"    {ACCELERATION_ARRAY} = mbs_xdot[MBS_NQ:].tolist()"]
        lines += [f"    {a} = {a}.tolist()" for a in arrays]
        lines += [f"    {name} = {array}[{index}]  # {printable(s.name)}" for s, name, array, index in r.reads]
        lines.append("    try:")
        section = None
        for step in r.steps:
            if step.section != section:
                section = step.section
                lines.append(f"        # {printable(section)}")
            if step.guard is not None:
                lines += [f"        if not {step.guard} > 0.0:",
                          f"            return mbs_not_positive({step.guard})"]
            lines.append(f"        {step.name} = {step.text}")
        lines.append("        # outputs")
        index = (lambda k: f"{k // r.shape[1]}, {k % r.shape[1]}") if len(r.shape) == 2 else str
        for k, value in r.results:
            lines.append(f"        out[{index(k)}] = {f'out[{index(value)}]' if isinstance(value, int) else value}")
        if not r.results:
            lines.append("        pass")
        lines += ["    except (ArithmeticError, ValueError):  # division by zero, overflow, domain error",
                  "        return 2",
                  "    if not mbs_all_finite(out):",
                  "        return 2"]
        lines.append("    return 1 - mbs_positive_definite(out)" if r.check_positive else "    return 0")
        return "\n".join(lines), r.steps


def _docstring_text(text: str) -> str:
    """Text safe inside a triple-quoted docstring: no escape, no end of the string, one line."""
    return re.sub('"(?=")', '\\\\"', printable(text).replace("\\", "\\\\"))


@paused  # (compiler/gc_pause.py)
def generate_numpy(equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
                   outputs=(), tables=(), origin: str = "", inline_max_chars: int = INLINE_MAX_CHARS,
                   run_time_inputs=(), jacobian: bool = False, parameter_jacobian: bool = False,
                   dynamics=None, events=(), actions=()) -> str:
    """The Python module text of `equations` (see the module docstring), arguments as for ccode.generate_c.
    Load it with mbs.runtime.model.load_numpy (after writing it to a file) or import it."""
    return PyEmitter(equations, parameters, model_name, outputs=outputs, tables=tables, origin=origin,
                     inline_max_chars=inline_max_chars, run_time_inputs=run_time_inputs,
                     jacobian=jacobian, parameter_jacobian=parameter_jacobian, dynamics=dynamics, events=events,
                     actions=actions).source()


__all__ = ["PyEmitter", "PyPrinter", "generate_numpy", "CodegenError"]
