"""C code for the equations of motion: an expression printer and an emitter that owns the file.

The generated file is self-describing and has one fixed contract (relied on by `mbs.runtime`):

    #define MBS_NQ, MBS_NV, MBS_NX (= MBS_NQ + MBS_NV), MBS_NP, MBS_NWORK
    int mbs_rhs(double t, const double *x, const double *p, double *xdot, double *work);    x = [q; v]
    int mbs_mass_matrix(double t, const double *x, const double *p, double *M, double *work); nv*nv, row-major
    int mbs_forces(double t, const double *x, const double *p, double *f, double *work);    f = q - k
    int mbs_qdot(double t, const double *x, const double *p, double *qdot, double *work);
    const char *mbs_state_name(int i);  const char *mbs_parameter_name(int i);   (NULL when out of range)

Each function returns 0 on success, 1 when the mass matrix (in mbs_rhs: an articulated inertia pivot) is not
positive, 2 when a result is not finite. The functions are reentrant: no allocation, no static mutable data; the
caller provides MBS_NWORK doubles of work memory. Parameters are read from p at run time, so changing them needs no
recompilation; prescribed coordinates are computed from t inside each function.

Every tape temporary a function needs becomes one `const double name = ...;` line, in tape order, under a comment
naming the algorithm step; a function only contains the temporaries its outputs depend on.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Sequence
from pathlib import Path

import sympy as sp

from .equations import Equations
from .tree import t

GENERATOR = "Baukasten mbs.compiler.ccode"

#: A temporary read only once is written into its reader instead of getting a line of its own, if its text is
#: at most this long (keeps lines readable; about halves the size of the articulated-body code).
INLINE_MAX_CHARS = 48

# Precedence levels of the printed C (higher binds tighter).
PREC_ADD, PREC_MUL, PREC_UNARY, PREC_ATOM = 10, 20, 30, 40

C_RESERVED = set("""auto break case char const continue default do double else enum extern float for goto if inline
int long register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
t x p xdot M f qdot work i j k n""".split()) | {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh",
                                                "cosh", "tanh", "exp", "log", "sqrt", "pow", "fabs", "fmin", "fmax",
                                                "floor", "ceil", "isfinite", "isnan"}


class CodegenError(ValueError):
    """An expression the C printer cannot write (an unsupported function), or an unknown symbol."""


class CPrinter:
    """C99 text of a sympy expression, one method per node kind; symbols are looked up in `names`."""

    FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan",
                 "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp", "log": "log",
                 "Abs": "fabs", "floor": "floor", "ceiling": "ceil"}
    RELATIONS = {"<": "<", "<=": "<=", ">": ">", ">=": ">=", "==": "==", "!=": "!="}

    def __init__(self, names: dict):
        self.names = names

    def doprint(self, expr) -> str:
        return self._print(sp.sympify(expr))[0]

    def _print(self, expr) -> tuple:
        """(text, precedence)."""
        for cls in type(expr).__mro__:
            method = getattr(self, f"_print_{cls.__name__}", None)
            if method is not None:
                return method(expr)
        raise CodegenError(f"cannot write {type(expr).__name__} in C: {expr}")

    def _paren(self, expr, prec: int) -> str:
        text, p = self._print(expr)
        return f"({text})" if p < prec else text

    # -- atoms --
    def _print_Symbol(self, expr):
        try:
            return self.names[expr], PREC_ATOM
        except KeyError:
            raise CodegenError(f"symbol {expr.name!r} is neither a state, a parameter, t nor a temporary") from None

    _print_Dummy = _print_Symbol

    def _print_Integer(self, expr):
        return str(int(expr)), (PREC_ATOM if expr >= 0 else PREC_UNARY)

    def _print_Rational(self, expr):
        return self._float(float(expr))

    def _print_Float(self, expr):
        return self._float(float(expr))

    def _print_NumberSymbol(self, expr):  # pi, E: C99 has no M_PI
        return self._float(float(expr))

    @staticmethod
    def _float(value: float) -> tuple:
        text = repr(value)  # shortest text that reads back as the same double
        if text in ("inf", "-inf", "nan"):
            raise CodegenError(f"non-finite constant {text}")
        if "e" not in text and "." not in text:
            text += ".0"
        return text, (PREC_ATOM if value >= 0 else PREC_UNARY)

    # -- arithmetic --
    def _print_Add(self, expr):
        terms = list(expr.args)
        # A positive term first reads better: "a - b" rather than "-b + a".
        terms.sort(key=lambda e: e.could_extract_minus_sign())
        out = self._paren(terms[0], PREC_ADD)
        for term in terms[1:]:
            if term.could_extract_minus_sign():
                out += " - " + self._paren(-term, PREC_MUL)
            else:
                out += " + " + self._paren(term, PREC_MUL)
        return out, PREC_ADD

    def _print_Mul(self, expr):
        coeff, rest = expr.as_coeff_Mul()
        sign = ""
        if coeff.is_negative:
            sign, coeff = "-", -coeff
        num, den = [], []
        for factor in sp.Mul.make_args(rest):
            if factor.is_Pow and factor.exp.is_Rational and factor.exp.is_negative:
                den.append(factor.base if factor.exp == -1 else sp.Pow(factor.base, -factor.exp))
            else:
                num.append(factor)
        parts = ([] if coeff == 1 else [self._print(coeff)[0]]) + [self._paren(f, PREC_MUL) for f in num]
        text = "*".join(parts) if parts else "1.0"
        if den:
            text += "/" + (self._paren(den[0], PREC_ATOM) if len(den) == 1
                           else "(" + "*".join(self._paren(f, PREC_MUL) for f in den) + ")")
        return sign + text, (PREC_ADD if sign else PREC_MUL)

    def _print_Pow(self, expr):
        base, exp = expr.args
        if exp == sp.S.Half:
            return f"sqrt({self.doprint(base)})", PREC_ATOM
        if exp.is_Rational and exp.is_negative:
            return "1.0/" + self._paren(sp.Pow(base, -exp), PREC_ATOM), PREC_MUL
        if exp in (2, 3) and base.is_Atom:
            return "*".join([self._paren(base, PREC_MUL)] * int(exp)), PREC_MUL
        return f"pow({self.doprint(base)}, {self.doprint(exp)})", PREC_ATOM

    # -- functions --
    def _print_Function(self, expr):
        name = self.FUNCTIONS.get(type(expr).__name__)
        if name is None:
            raise CodegenError(f"no C counterpart for the function {type(expr).__name__}")
        return f"{name}({', '.join(self.doprint(a) for a in expr.args)})", PREC_ATOM

    def _print_Min(self, expr):
        return self._fold("fmin", expr.args)

    def _print_Max(self, expr):
        return self._fold("fmax", expr.args)

    def _fold(self, fn, args):
        text = self.doprint(args[0])
        for a in args[1:]:
            text = f"{fn}({text}, {self.doprint(a)})"
        return text, PREC_ATOM

    def _print_Piecewise(self, expr):
        text = None
        for value, cond in reversed(expr.args):
            if text is None:
                if cond != sp.true:
                    raise CodegenError("a Piecewise needs a final (value, True) branch")
                text = self.doprint(value)
            else:
                text = f"({self.doprint(cond)} ? {self.doprint(value)} : {text})"
        return text, PREC_ATOM

    def _print_Relational(self, expr):
        op = self.RELATIONS.get(expr.rel_op)
        if op is None:
            raise CodegenError(f"cannot write the relation {expr.rel_op}")
        return f"{self._paren(expr.lhs, PREC_ADD)} {op} {self._paren(expr.rhs, PREC_ADD)}", PREC_ATOM - 1

    def _print_And(self, expr):
        return " && ".join(f"({self.doprint(a)})" for a in expr.args), PREC_ATOM - 1

    def _print_Or(self, expr):
        return " || ".join(f"({self.doprint(a)})" for a in expr.args), PREC_ATOM - 1

    def _print_Not(self, expr):
        return f"!({self.doprint(expr.args[0])})", PREC_ATOM

    def _print_BooleanTrue(self, expr):
        return "1", PREC_ATOM

    def _print_BooleanFalse(self, expr):
        return "0", PREC_ATOM


def c_identifier(name: str) -> str:
    """A readable C identifier for a qualified coordinate or parameter name ("arm.der(phi)" -> "arm_dphi")."""
    name = re.sub(r"der\((\w+)\)", r"d\1", name)
    name = re.sub(r"\W+", "_", name).strip("_") or "v"
    return "_" + name if name[0].isdigit() else name


class CEmitter:
    """Writes the C file of `equations`, with the run-time parameters in the order of `parameters`."""

    def __init__(self, equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
                 inline_max_chars: int = INLINE_MAX_CHARS):
        self.eqs, self.model_name, self.inline_max_chars = equations, model_name, inline_max_chars
        self.parameters = tuple(parameters)
        if equations.vdot is None:
            raise CodegenError("the equations were derived without forward dynamics; mbs_rhs needs vdot")
        missing = [s.name for s in equations.parameters() if s not in set(self.parameters)]
        if missing:
            raise CodegenError(f"parameters missing from the parameter list: {', '.join(missing)}")
        tree = equations.tree
        taken = set(C_RESERVED) | set(keyword.kwlist)
        self.names = {t: "t"}
        self.inputs: list[tuple[sp.Symbol, str, str]] = []  # (symbol, C name, "x[3]")
        for k, s in enumerate(tree.q_symbols + tree.v_symbols):
            self.inputs.append((s, self._claim(c_identifier(s.name), taken), f"x[{k}]"))
        for k, s in enumerate(self.parameters):
            self.inputs.append((s, self._claim(c_identifier(s.name), taken), f"p[{k}]"))
        self.names.update({s: name for s, name, _ in self.inputs})
        for entry in equations.tape.entries:
            self.names[entry.symbol] = self._claim(entry.name, taken)

    @staticmethod
    def _claim(name: str, taken: set) -> str:
        while name in taken:
            name += "_"
        taken.add(name)
        return name

    # ---- the file ---------------------------------------------------------------------------------------------

    def source(self) -> str:
        eqs, nv = self.eqs, self.eqs.tree.nv
        M = [eqs.mass_matrix[i][j] for i in range(nv) for j in range(nv)]
        mass_outputs = [(f"M[{i * nv + j}]", M[i * nv + j]) if j >= i else (f"M[{i * nv + j}]", f"M[{j * nv + i}]")
                        for i in range(nv) for j in range(nv)]
        parts = [
            self._header(),
            self._function("mbs_rhs", "xdot", [(f"xdot[{k}]", e) for k, e in enumerate(eqs.qdot + eqs.vdot)],
                           "x' = [qdot; vdot], vdot by the articulated-body algorithm", "MBS_NX"),
            self._function("mbs_mass_matrix", "M", mass_outputs,
                           "mass matrix M (nv x nv, row-major) by the composite-rigid-body algorithm", "MBS_NV*MBS_NV",
                           check_positive=True),
            self._function("mbs_forces", "f", [(f"f[{k}]", e) for k, e in enumerate(eqs.forces)],
                           "f = q - k (applied minus Coriolis/centrifugal/gyroscopic forces), M vdot = f", "MBS_NV"),
            self._function("mbs_qdot", "qdot", [(f"qdot[{k}]", e) for k, e in enumerate(eqs.qdot)],
                           "qdot = G(q) v", "MBS_NQ"),
            self._names_function("mbs_state_name", [s.name for s in eqs.tree.q_symbols + eqs.tree.v_symbols]),
            self._names_function("mbs_parameter_name", [s.name for s in self.parameters]),
        ]
        return "\n".join(parts)

    def write(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.source())
        return path

    def _header(self) -> str:
        tree = self.eqs.tree
        nq, nv = tree.nq, tree.nv
        lines = [f"/* Equations of motion of the model \"{self.model_name}\".",
                 f" * Generated by {GENERATOR}; do not edit.",
                 " * Options: vdot by the articulated-body algorithm; quaternion rotations scaled by 2/|q|^2;",
                 f" *     temporaries read once written in place up to {self.inline_max_chars} characters.",
                 " *",
                 f" * Tree of {len(tree.bodies)} rigid bod{'y' if len(tree.bodies) == 1 else 'ies'} in minimal "
                 f"coordinates, nq = {nq}, nv = {nv}, "
                 f"np = {len(self.parameters)}:",
                 " *     qdot = G(q) v,    M(q, t) vdot = f(q, v, t) = q - k",
                 " * State x = [q; v]:"]
        lines += [f" *   x[{k}]  {s.name}" for k, s in enumerate(tree.q_symbols + tree.v_symbols)]
        lines += [" * Parameters p:"] + [f" *   p[{k}]  {s.name}" for k, s in enumerate(self.parameters)]
        if not self.parameters:
            lines.append(" *   (none)")
        lines.append(" * Bodies (temporaries are numbered after them):")
        for i, b in enumerate(tree.bodies):
            parent = "ground" if b.parent < 0 else tree.bodies[b.parent].name
            lines.append(f" *   {i + 1}  {b.name}: {b.joint.kind} joint to {parent}")
            for k, e in enumerate(b.prescribed):
                if e is not None:
                    lines.append(f" *      prescribed coordinate {k}: {e}")
        lines += [" * Every function returns 0 on success, 1 if the mass matrix or an articulated-inertia pivot is",
                  " * not positive, 2 if a result is not finite.",
                  " */",
                  "#include <math.h>",
                  "#include <stddef.h>",
                  "",
                  f"#define MBS_NQ {nq}   /* free position coordinates */",
                  f"#define MBS_NV {nv}   /* free velocity coordinates */",
                  "#define MBS_NX (MBS_NQ+MBS_NV)",
                  f"#define MBS_NP {len(self.parameters)}   /* parameters */",
                  f"#define MBS_NWORK {nv * nv}   /* doubles of work memory the caller provides */",
                  "",
                  "/* Leave with status 1 (not positive) or 2 (not a number) unless the pivot d is positive. */",
                  "#define MBS_PIVOT(d) do { if (!((d) > 0.0)) return (d) <= 0.0 ? 1 : 2; } while (0)",
                  "",
                  "static int mbs_all_finite(const double *a, int n)",
                  "{",
                  "    int i;",
                  "    for (i = 0; i < n; ++i)",
                  "        if (!isfinite(a[i]))",
                  "            return 0;",
                  "    return 1;",
                  "}",
                  "",
                  "/* Cholesky factorisation of the n x n row-major matrix A into work (n*n doubles): 1 if A is",
                  " * positive definite. */",
                  "static int mbs_positive_definite(const double *A, int n, double *work)",
                  "{",
                  "    int i, j, k;",
                  "    for (i = 0; i < n; ++i) {",
                  "        for (j = 0; j <= i; ++j) {",
                  "            double s = A[i * n + j];",
                  "            for (k = 0; k < j; ++k)",
                  "                s -= work[i * n + k] * work[j * n + k];",
                  "            if (i == j) {",
                  "                if (!(s > 0.0))",
                  "                    return 0;",
                  "                work[i * n + i] = sqrt(s);",
                  "            } else {",
                  "                work[i * n + j] = s / work[j * n + j];",
                  "            }",
                  "        }",
                  "    }",
                  "    return 1;",
                  "}",
                  ""]
        comment, code = lines[:lines.index(" */") + 1], lines[lines.index(" */") + 1:]
        # Names and expressions inside the comment must not end it.
        return "\n".join([c.replace("*/", "* /") for c in comment[:-1]] + [comment[-1]] + code)

    def _function(self, name: str, out: str, outputs: list, doc: str, size: str, check_positive=False) -> str:
        tape = self.eqs.tape
        exprs = [e for _, e in outputs if not isinstance(e, str)]
        entries = tape.entries_for(exprs)
        used = tape.free_symbols(exprs)
        lines = [f"/* {doc} */",
                 f"int {name}(double t, const double *x, const double *p, double *{out}, double *work)", "{"]
        reads = [(s, cname, src) for s, cname, src in self.inputs if s in used]
        for s, cname, src in reads:
            lines.append(f"    const double {cname} = {src};   /* {s.name} */")
        unused = [arg for arg, present in (("t", t in used), ("x", any(src[0] == "x" for *_, src in reads)),
                                           ("p", any(src[0] == "p" for *_, src in reads)),
                                           ("work", check_positive)) if not present]
        if unused:
            lines.append("    " + " ".join(f"(void){arg};" for arg in unused))
        printer = CPrinter(self.names)
        reads = _read_counts(tape, entries, exprs)
        inlined: dict = {}  # temporary read once -> its expression, substituted into the reader (so constants fold)
        section = None
        for entry in entries:
            expr = entry.expr
            if any(d in inlined for d in tape.dependencies(entry)):
                expr = expr.xreplace(inlined)
            text = printer.doprint(expr)
            if reads[entry.symbol] == 1 and entry.guard is None and len(text) <= self.inline_max_chars:
                inlined[entry.symbol] = expr
                continue
            if entry.section != section:
                section = entry.section
                lines.append(f"    /* {section} */")
            if entry.guard is not None:
                lines.append(f"    MBS_PIVOT({printer.doprint(entry.guard.xreplace(inlined))});")
            lines.append(f"    const double {self.names[entry.symbol]} = {text};")
        lines.append("    /* outputs */")
        for target, e in outputs:
            text = e if isinstance(e, str) else printer.doprint(sp.sympify(e).xreplace(inlined))
            lines.append(f"    {target} = {text};")
        lines.append(f"    if (!mbs_all_finite({out}, {size}))")
        lines.append("        return 2;")
        if check_positive:
            lines.append(f"    return mbs_positive_definite({out}, MBS_NV, work) ? 0 : 1;")
        else:
            lines.append("    return 0;")
        lines.append("}\n")
        return "\n".join(lines)

    @staticmethod
    def _names_function(name: str, names: list) -> str:
        what = name[len("mbs_"):-len("_name")]
        lines = [f"/* Name of {what} i, NULL when out of range. */", f"const char *{name}(int i)", "{"]
        if names:
            lines.append("    static const char *const names[] = {")
            quoted = ['"' + n.replace("\\", "\\\\").replace('"', '\\"') + '",' for n in names]
            row = "       "
            for q in quoted:
                if len(row) + len(q) > 110:
                    lines.append(row)
                    row = "       "
                row += " " + q
            lines += [row, "    };", f"    return (i >= 0 && i < {len(names)}) ? names[i] : NULL;"]
        else:
            lines += ["    (void)i;", "    return NULL;"]
        return "\n".join(lines + ["}\n"])


def _read_counts(tape, entries, outputs) -> dict:
    """How often each temporary is read by the other entries and the outputs of one function."""
    counts = {e.symbol: 0 for e in entries}

    def visit(expr, weight=1):
        if expr in counts:
            counts[expr] += weight
        elif expr.is_Pow and expr.exp.is_Integer:
            visit(expr.base, weight * abs(int(expr.exp)))  # x**2 is written x*x
        else:
            for arg in expr.args:
                visit(arg, weight)

    for e in entries:
        visit(e.expr)
        if e.guard is not None:
            visit(e.guard)
    for o in outputs:
        visit(sp.sympify(o))
    return counts


def generate_c(equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
               inline_max_chars: int = INLINE_MAX_CHARS) -> str:
    """The C source text of `equations` (see the module docstring for the contract); `parameters` fixes the order
    of p."""
    return CEmitter(equations, parameters, model_name, inline_max_chars=inline_max_chars).source()
