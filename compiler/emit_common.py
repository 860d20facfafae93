"""What the C and the NumPy emitters share: names, the printer's language-independent part, the plan of one
generated function, lookup-table data, and the text that describes the model and the options.

The two back ends differ only in syntax. Both name every input and temporary the same way, slice the same tape
entries for a function, write the same temporaries in place and evaluate the same arithmetic (`pow` is the C
library's in both, so is every other function), so a line of the C file and a line of the NumPy module can be
compared side by side when debugging a model.
"""

from __future__ import annotations

import keyword
import re
from dataclasses import dataclass
from importlib import metadata

import sympy as sp

from .fast_arith import replaced_symbols as replaced  # (its rules map the temporaries written in place)
from .hooks import is_helper as is_hook_helper
from .tape import count_reads, symbols_of
from .tree import t

#: A temporary read only once is written into its reader instead of getting a line of its own, if its text is
#: at most this long (keeps lines readable; about halves the size of the articulated-body code).
INLINE_MAX_CHARS = 48

# Precedence levels of the printed text (higher binds tighter); the same order in C and Python.
PREC_LOGIC, PREC_REL, PREC_ADD, PREC_MUL, PREC_UNARY, PREC_ATOM = 3, 5, 10, 20, 30, 40

#: Identifiers a generated name must not take: keywords of both languages, the arguments of the generated
#: functions, the math functions and helpers they call, and object-like lowercase macros of the headers the C
#: file is compiled after (<Python.h> pulls in stdio, errno, math). All-caps names are handled by `identifier`.
RESERVED = frozenset("""auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef union unsigned void
volatile while bool complex imaginary true false
t x p xdot M f qdot y out work i j k n
sin cos tan asin acos atan atan2 sinh cosh tanh exp log sqrt pow fabs fmin fmax floor ceil isfinite isnan nan
errno math_errhandling stderr stdin stdout static_assert sched_priority st_atime st_ctime st_mtime L_ctermid
L_cuserid L_tmpnam P_tmpdir unix linux i386
numpy bisect_right ArithmeticError ValueError""".split()) | set(keyword.kwlist)

#: The generated code's own names (helpers, tables, macros) start with this, in either case.
OWN_PREFIX = "mbs_"

TABLE_FUNCTION = re.compile(r"mbs_table_(\d+)$")


class CodegenError(ValueError):
    """An expression the printer cannot write (an unsupported function), or an unknown symbol."""


def generator_version() -> str:
    try:
        return metadata.version("baukasten")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


# ---- names ----------------------------------------------------------------------------------------------------

def identifier(name: str, *, capitals: bool = True) -> str:
    """A readable identifier, valid in C99 and Python, for a qualified name ("arm.der(phi)" -> "arm_dphi").

    Never one of the generated code's own names (prefix mbs_) and never all capitals: <Python.h> and the C
    library define hundreds of all-capital macros (EOF, NAN, EDOM, PATH_MAX, ...), so "EI" becomes "EI_"."""
    name = re.sub(r"der\((\w+)\)", r"d\1", name, flags=re.ASCII)
    name = re.sub(r"\W+", "_", name, flags=re.ASCII).strip("_") or "v"
    if name[0].isdigit():
        name = "_" + name
    if name.lower().startswith(OWN_PREFIX):
        name = "u_" + name
    if capitals and len(name) > 1 and not re.search("[a-z]", name):
        name += "_"
    return name


def _safe(name: str) -> str:
    """A tape temporary's name, kept as it is when already safe ("_dist"). The compiler chose it, so the rule
    against all-capital names is left out ("I2_00" is no macro)."""
    ok = (name.isidentifier() and name.isascii() and not name.startswith("__")
          and not (len(name) > 1 and name[0] == "_" and name[1].isupper()))
    bare = name.lstrip("_")
    if ok and _PLAIN.fullmatch(bare) and not bare.lower().startswith(OWN_PREFIX):
        return name  # (what identifier keeps as it is, told without its regex substitutions: every temporary)
    return name if ok and identifier(bare, capitals=False) == bare else identifier(name, capitals=False)


#: A name identifier(name, capitals=False) keeps as it is, unless it starts with OWN_PREFIX: ASCII letters, digits
#: and underscores, a letter first and no underscore last.
_PLAIN = re.compile(r"[A-Za-z](?:\w*[A-Za-z0-9])?", re.ASCII)


class Naming:
    """Identifiers of t, the states, the parameters and every tape temporary (unique among themselves and the
    reserved names). `inputs` lists (symbol, identifier, array, index) for x and p, in that order, then the
    run-time vectors `run_time_inputs` ((symbol, array, index): accelerations and multipliers, see
    compiler/reactions.py) that only the output function reads."""

    def __init__(self, equations, parameters, run_time_inputs=()):
        tree = equations.tree
        taken = set(RESERVED)
        self.names: dict = {t: "t"}
        self.inputs: list[tuple[sp.Symbol, str, str, int]] = []
        for k, s in enumerate(tree.x_symbols):
            self.inputs.append((s, _claim(identifier(s.name), taken), "x", k))
        for k, s in enumerate(parameters):
            self.inputs.append((s, _claim(identifier(s.name), taken), "p", k))
        for s, array, k in run_time_inputs:
            self.inputs.append((s, _claim(identifier(s.name), taken), array, k))
        self.names.update({s: name for s, name, _, _ in self.inputs})
        for entry in equations.tape.entries:
            self.names[entry.symbol] = _claim(_safe(entry.name), taken)


def _claim(name: str, taken: set) -> str:
    while name in taken:
        name += "_"
    taken.add(name)
    return name


# ---- the printer ----------------------------------------------------------------------------------------------

def _minus_sign(term) -> bool:
    """term.could_extract_minus_sign() for a term of a sum, without its cost: sympy's Mul builds -term to compare
    it with term (which only an infinite factor makes equal), a tenth of the time of printing a large model."""
    if term.is_Mul:
        first = term.args[0]
        return first.is_Number and negative_number(first, extended=True)
    if term.is_Number:
        return negative_number(term, extended=True)
    return bool(term.could_extract_minus_sign())


def negative_number(number, extended: bool = False) -> bool:
    """number.is_negative (extended: .is_extended_negative, true for -oo too) of a sympy Number, by plain
    comparison for a rational or a float: sympy asks its assumptions system, and a fresh Float or Rational (every
    coefficient the derivation makes) deduces all its facts at the first question, a quarter of the printing."""
    p = getattr(number, "p", None)  # Integer, Rational
    if p is not None:
        return p < 0
    if number.is_Float:
        return float(number) < 0  # NaN: False, as sympy's None
    return bool(number.is_extended_negative if extended else number.is_negative)


class ExprPrinter:
    """Text of a sympy expression, one method per node kind; subclasses give the syntax that differs.

    `names` maps symbols to identifiers, `n_tables` is the number of lookup tables (calls of mbs_table_k).
    `used` collects the functions the printed text calls, so that the emitter defines or imports only those."""

    FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan",
                 "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp", "log": "log",
                 "Abs": "fabs", "floor": "floor", "ceiling": "ceil", "sign": "mbs_sign"}
    RELATIONS = {"<": "<", "<=": "<=", ">": ">", ">=": ">=", "==": "==", "!=": "!="}
    LANGUAGE = "?"
    AND, OR, TRUE, FALSE, NAN = "", "", "", "", ""

    def __init__(self, names: dict, n_tables: int = 0):
        self.names, self.n_tables = names, n_tables
        self.used: set[str] = set()
        self.hook_calls: dict[str, int] = {}  # helper of a user hook (compiler/hooks.py) -> its arguments after t
        # expression -> its text: the functions of a file print many of the same temporaries (the kinematics of
        # the mass matrix, the forces, the constraints ...), and printing is a good part of the derivation time.
        # `used` and `hook_calls` only grow, so a text printed before has put its names there already.
        self._printed: dict = {}
        self._free: dict = {}  # expression -> its free symbols, for the same reason
        self._nodes: dict = {}  # node -> (text, precedence) (see _print)
        self._methods: dict = {}  # node type -> its print method

    def free_symbols(self, expr) -> set:
        """expr.free_symbols, remembered (the functions of a file read many of the same temporaries)."""
        found = self._free.get(expr)
        if found is None:
            found = self._free[expr] = symbols_of(expr)
        return found

    def doprint(self, expr) -> str:
        text = self._printed.get(expr)
        if text is None:
            expr = sp.sympify(expr)
            text = self._printed[expr] = self._print(expr)[0]
        return text

    def _print(self, expr) -> tuple:
        """(text, precedence), remembered per node: the temporaries' expressions share their factors and terms
        (a sine, a product of two temporaries), printed once each."""
        done = self._nodes.get(expr)
        if done is None:
            done = self._nodes[expr] = self._method(type(expr))(expr)
        return done

    def _method(self, kind: type):
        """The _print_<class> method for a node type: its own class's, else the nearest base class's."""
        method = self._methods.get(kind)
        if method is None:
            for cls in kind.__mro__:
                method = getattr(self, f"_print_{cls.__name__}", None)
                if method is not None:
                    break
            else:
                def method(expr):
                    raise CodegenError(f"cannot write {type(expr).__name__} in {self.LANGUAGE}: {expr}")
            self._methods[kind] = method
        return method

    def _paren(self, expr, prec: int) -> str:
        text, p = self._print(expr)
        return f"({text})" if p < prec else text

    def _call(self, name: str, args) -> tuple:
        self.used.add(name)
        return f"{name}({', '.join(self.doprint(a) for a in args)})", PREC_ATOM

    # -- language hooks --
    def _conditional(self, cond: str, then: str, otherwise: str) -> str:
        raise NotImplementedError

    def _not(self, text: str) -> tuple:
        raise NotImplementedError

    # -- atoms --
    def _print_Symbol(self, expr):
        try:
            return self.names[expr], PREC_ATOM
        except KeyError:
            raise CodegenError(f"symbol {expr.name!r} is neither a state, a parameter, t nor a temporary") from None

    _print_Dummy = _print_Symbol

    def _print_Integer(self, expr):
        if abs(int(expr)) >= 2**31:  # beyond a C int: write a double
            return self._float(float(expr))
        return str(int(expr)), (PREC_ATOM if expr >= 0 else PREC_UNARY)

    def _print_Rational(self, expr):
        return self._float(float(expr))

    def _print_Float(self, expr):
        return self._float(float(expr))

    def _print_NumberSymbol(self, expr):  # pi, E: C99 has no M_PI
        return self._float(float(expr))

    def _print_Infinity(self, expr):
        raise CodegenError(f"non-finite constant {expr} (a division by zero in the model?)")

    _print_NegativeInfinity = _print_ComplexInfinity = _print_NaN = _print_Infinity

    @staticmethod
    def _float(value: float) -> tuple:
        text = repr(value)  # shortest text that reads back as the same double
        if text in ("inf", "-inf", "nan"):
            raise CodegenError(f"non-finite constant {text}")
        if "e" not in text and "." not in text:
            text += ".0"
        return text, (PREC_ATOM if value >= 0 else PREC_UNARY)

    def _value(self, expr) -> str:
        """A branch or fmax/fmin argument: integers as doubles (no C expression becomes integer-valued, and
        Python computes with floats throughout)."""
        return self._float(float(expr))[0] if expr.is_Integer else self.doprint(expr)

    # -- arithmetic --
    def _print_Add(self, expr):
        terms = list(expr.args)
        # A positive term first reads better: "a - b" rather than "-b + a".
        terms.sort(key=_minus_sign)
        out = self._paren(terms[0], PREC_ADD)
        for term in terms[1:]:
            if _minus_sign(term):
                out += " - " + self._paren(-term, PREC_MUL)
            else:
                out += " + " + self._paren(term, PREC_MUL)
        return out, PREC_ADD

    def _print_Mul(self, expr):
        coeff, rest = expr.as_coeff_Mul()
        sign = ""
        if negative_number(coeff):
            sign, coeff = "-", -coeff
        num, den = [], []
        for factor in sp.Mul.make_args(rest):
            if factor.is_Pow and factor.exp.is_Rational and factor.exp.p < 0:
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
            return self._call("sqrt", [base])
        if exp.is_Rational and exp.p < 0:
            return "1.0/" + self._paren(sp.Pow(base, -exp), PREC_ATOM), PREC_MUL
        if exp in (2, 3) and base.is_Atom:
            return "*".join([self._paren(base, PREC_MUL)] * int(exp)), PREC_MUL
        if exp in (3, 4):  # the products as for an atom, in a helper (the base printed once): without -ffast-math
            return self._call(f"mbs_pow{int(exp)}", [base])  # GCC keeps pow(x, 3) a library call of ~140
        return self._call("pow", [base, exp])  # instructions (pow(x, 2) it makes x*x itself, exactly)

    # -- functions --
    def _print_Function(self, expr):
        name = type(expr).__name__
        table = TABLE_FUNCTION.match(name)
        if table:
            if int(table.group(1)) >= self.n_tables or len(expr.args) != 1:
                raise CodegenError(f"{expr} calls lookup table {table.group(1)}, but only {self.n_tables} "
                                   f"table(s) were given")
            return self._call(name, expr.args)
        if is_hook_helper(name):
            self.hook_calls[name] = len(expr.args) - 1
            return self._call(name, expr.args)
        target = self.FUNCTIONS.get(name)
        if target is None:
            raise CodegenError(f"no {self.LANGUAGE} counterpart for the function {name}")
        return self._call(target, expr.args)

    def _print_Min(self, expr):
        return self._fold("fmin", expr.args)

    def _print_Max(self, expr):
        return self._fold("fmax", expr.args)

    def _fold(self, fn, args):
        self.used.add(fn)
        text = self._value(args[0])
        for a in args[1:]:
            text = f"{fn}({text}, {self._value(a)})"
        return text, PREC_ATOM

    def _print_Piecewise(self, expr):
        pieces = list(expr.args)
        if pieces[-1].cond == sp.true:
            text = self._value(pieces.pop().expr)
        else:  # no branch applies: undefined, as in sympy (the result then fails the finiteness check)
            self.used.add("nan")
            text = self.NAN
        for value, cond in reversed(pieces):
            text = self._conditional(self.doprint(cond), self._value(value), text)
        return text, PREC_ATOM

    def _print_Relational(self, expr):
        op = self.RELATIONS.get(expr.rel_op)
        if op is None:
            raise CodegenError(f"cannot write the relation {expr.rel_op}")
        return f"{self._paren(expr.lhs, PREC_ADD)} {op} {self._paren(expr.rhs, PREC_ADD)}", PREC_REL

    def _print_And(self, expr):
        return f" {self.AND} ".join(f"({self.doprint(a)})" for a in expr.args), PREC_LOGIC

    def _print_Or(self, expr):
        return f" {self.OR} ".join(f"({self.doprint(a)})" for a in expr.args), PREC_LOGIC

    def _print_Not(self, expr):
        return self._not(self.doprint(expr.args[0]))

    def _print_ITE(self, expr):
        """A boolean if-then-else, which sympy makes of a comparison with a Piecewise inside."""
        cond, then, otherwise = expr.args
        return self._conditional(self.doprint(cond), f"({self.doprint(then)})", f"({self.doprint(otherwise)})"), \
            PREC_ATOM

    def _print_BooleanTrue(self, expr):
        return self.TRUE, PREC_ATOM

    def _print_BooleanFalse(self, expr):
        return self.FALSE, PREC_ATOM


# ---- the plan of one function ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Step:
    """`name = text` under the comment `section`, evaluated after checking `guard > 0` (guard None: no check)."""

    name: str
    text: str
    section: str
    guard: str | None


@dataclass(frozen=True)
class Routine:
    """A generated function `name(t, x, p, <out>, work) -> status`, printed, before its syntax is chosen.

    reads: (symbol, identifier, array, index) of the inputs it uses; steps: its temporaries in tape order;
    results: (k, text) for out[k] = text, or (k, j) with an int j for out[k] = out[j] (a symmetric entry);
    shape: of out (the index k is row-major); check_positive: status 1 unless out is positive definite."""

    name: str
    out: str
    doc: str
    shape: tuple
    uses_t: bool
    reads: tuple
    steps: tuple
    results: tuple
    check_positive: bool = False


def plan_routine(tape, naming: Naming, printer: ExprPrinter, name: str, out: str, doc: str, shape: tuple,
                 results: list, *, check_positive: bool = False, inline_max_chars: int = INLINE_MAX_CHARS,
                 counts: dict | None = None) -> Routine:
    """Slice `tape` for `results` ((k, expr) or (k, int j)) and print it: each needed temporary becomes a step,
    except one read once whose text is short, which is substituted into its reader (so constants fold).  `counts`:
    the read counts of a larger routine this one is a slice of (read_counts), so that each temporary and output is
    printed as that routine prints it (the same operations: compiler/ccode.py mbs_event_indicator); None: its own."""
    exprs = [sp.sympify(e) for _, e in results if not isinstance(e, int)]
    entries = tape.entries_for(exprs)
    if counts is None:
        counts = read_counts(tape, entries, exprs)
    inlined: dict = {}
    steps = []
    written = []  # every expression as printed: substitution may cancel a symbol (a = v - w; b = a + w)
    for entry in entries:
        expr = entry.expr
        if any(d in inlined for d in tape.dependencies(entry)):
            expr = replaced(expr, inlined)
        text = printer.doprint(expr)
        if counts[entry.symbol] == 1 and entry.guard is None and len(text) <= inline_max_chars:
            inlined[entry.symbol] = expr
            continue
        guard = None if entry.guard is None else replaced(entry.guard, inlined)
        written += [expr] if guard is None else [expr, guard]
        steps.append(Step(naming.names[entry.symbol], text, entry.section,
                          None if guard is None else printer.doprint(guard)))
    printed = []
    for k, e in results:
        if not isinstance(e, int):
            e = replaced(sp.sympify(e), inlined)
            written.append(e)
        printed.append((k, e if isinstance(e, int) else printer.doprint(e)))
    used = set().union(*map(printer.free_symbols, written))
    reads = tuple(r for r in naming.inputs if r[0] in used)
    return Routine(name, out, doc, shape, t in used, reads, tuple(steps), tuple(printed), check_positive)


def read_counts(tape, entries, outputs) -> dict:
    """How often each temporary is read by the other entries and the outputs of one function (an entry's reads are
    counted once per tape, Tape.reads: the functions of a file slice many of the same entries)."""
    counts = {e.symbol: 0 for e in entries}
    for e in entries:
        for symbol, n in tape.reads(e).items():
            if symbol in counts:
                counts[symbol] += n
    for o in outputs:
        count_reads(sp.sympify(o), counts, counts)
    return counts


def equation_routines(equations, outputs, events=(), actions=()) -> list:
    """(name, out, doc, shape, results, check_positive) of every function of the contract, in file order."""
    eqs, nq, nv = equations, equations.tree.nq, equations.tree.nv
    mass = [(i * nv + j, eqs.mass_matrix[i][j] if j >= i else j * nv + i) for i in range(nv) for j in range(nv)]
    routines = [
        ("mbs_rhs", "xdot", "x' = [qdot; vdot], vdot by the articulated-body algorithm"
         + ("; z' of the extra states" if eqs.zdot else ""), (nq + nv + len(eqs.zdot),),
         list(enumerate(eqs.qdot + (eqs.vdot or ()) + eqs.zdot)), False),
        ("mbs_mass_matrix", "M", "mass matrix M (nv x nv, row-major) by the composite-rigid-body algorithm",
         (nv, nv), mass, True),
        ("mbs_forces", "f", "f = q - k (applied minus Coriolis/centrifugal/gyroscopic forces), M vdot = f",
         (nv,), list(enumerate(eqs.forces)), False),
        ("mbs_qdot", "qdot", "qdot = G(q) v", (nq,), list(enumerate(eqs.qdot)), False),
    ]
    if eqs.vdot is None:  # a model with loops: its mbs_rhs is the loop solver's (compiler/ccode_loops.py)
        routines = routines[1:]
    if outputs:
        routines.append(("mbs_outputs", "y", "outputs y: " + ", ".join(n for n, _ in outputs), (len(outputs),),
                         [(k, e) for k, (_, e) in enumerate(outputs)], False))
    if events:  # compiler/events.py: zero crossings the integrator locates, and the values actions assign
        routines.append(("mbs_events", "g", "event indicators g (zero crossings): " + ", ".join(n for n, _ in events),
                         (len(events),), [(k, e) for k, (_, e) in enumerate(events)], False))
    if actions:
        routines.append(("mbs_event_actions", "a", "values event actions assign: " + ", ".join(n for n, _ in actions),
                         (len(actions),), [(k, e) for k, (_, e) in enumerate(actions)], False))
    return routines


def check_inputs(equations, parameters, outputs, tables, constraints=None, run_time_inputs=()) -> None:
    """CodegenError unless vdot exists, every parameter the results use is in `parameters`, and the tables
    hold finite data with increasing x."""
    if equations.vdot is None and constraints is None:
        raise CodegenError("the equations were derived without forward dynamics; mbs_rhs needs vdot")
    tree = equations.tree
    states = set(tree.x_symbols) | {t} | {s for s, _, _ in run_time_inputs}
    needed = set(equations.parameters()) | (equations.tape.free_symbols([e for _, e in outputs]) - states)
    if constraints is not None:
        needed |= set(constraints.parameters())
    missing = sorted(s.name for s in needed if s not in set(parameters))
    if missing:
        raise CodegenError(f"parameters missing from the parameter list: {', '.join(missing)}")
    for k, table in enumerate(tables):
        values = [*table.xs, *table.ys]
        if len(table.xs) < 2 or len(table.xs) != len(table.ys) or not all(map(_finite, values)) \
                or any(b <= a for a, b in zip(table.xs, table.xs[1:])) or table.method not in ("linear", "smooth"):
            raise CodegenError(f"lookup table {k} needs at least two points with finite values, increasing x, "
                               "and the method 'linear' or 'smooth'")


def _finite(v) -> bool:
    return abs(float(v)) < float("inf")


# ---- lookup tables --------------------------------------------------------------------------------------------

def table_slopes(xs, ys) -> tuple:
    """Fritsch-Carlson monotone slopes at the knots (the same arithmetic as mbs.language.expr.interpolate):
    end slopes are the end secants, an interior slope is 0 at a local extremum, else the harmonic mean of the
    neighbouring secants."""
    d = [(ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k]) for k in range(len(xs) - 1)]
    inner = [0.0 if a * b <= 0 else 2.0 / (1.0 / a + 1.0 / b) for a, b in zip(d, d[1:])]
    return tuple(float(v) for v in [d[0], *inner, d[-1]])


def table_description(k: int, table) -> str:
    kind = "linear" if table.method == "linear" else "monotone cubic (Fritsch-Carlson slopes)"
    return (f"mbs_table_{k}: {kind} in {len(table.xs)} points, x from {table.xs[0]!r} to {table.xs[-1]!r}, "
            "constant beyond")


# ---- the description --------------------------------------------------------------------------------------------

def describe(equations, parameters, outputs, tables, model_name: str, origin: str, module: str,
             inline_max_chars: int) -> list[str]:
    """Plain-text lines naming the model, the options and the layout of the generated code's arrays (outputs
    None: they are written in a part of their own, compiler/ccode.py generate_c_outputs)."""
    tree = equations.tree
    nq, nv = tree.nq, tree.nv
    lines = [f"Equations of motion of the model \"{model_name}\"."]
    if origin:
        lines.append(f"From {origin}.")
    lines += [f"Generated by Baukasten {generator_version()} ({module}); do not edit.",
              "Options: vdot by the articulated-body algorithm; quaternion rotations scaled by 2/|q|^2;",
              f"    temporaries read once written in place up to {inline_max_chars} characters;",
              (f"    {len(outputs)} output(s), " if outputs is not None else "    outputs at the end of the file, ")
              + f"{len(tables)} lookup table(s).",
              "",
              f"Tree of {len(tree.bodies)} rigid bod{'y' if len(tree.bodies) == 1 else 'ies'} in minimal "
              f"coordinates, nq = {nq}, nv = {nv}, np = {len(parameters)}:",
              "    qdot = G(q) v,    M(q, t) vdot = f(q, v, t) = q - k",
              *([f"    z' = h(q, v, z, t): {tree.nz} extra state(s)", "State x = [q; v; z]:"] if tree.nz
                else ["State x = [q; v]:"])]
    lines += [f"  x[{k}]  {s.name}" for k, s in enumerate(tree.x_symbols)]
    lines += ["Parameters p:"] + [f"  p[{k}]  {s.name}" for k, s in enumerate(parameters)]
    if not parameters:
        lines.append("  (none)")
    if outputs:
        lines += ["Outputs y:"] + [f"  y[{k}]  {name}" for k, (name, _) in enumerate(outputs)]
    if tables:
        lines += ["Lookup tables:"] + [f"  {table_description(k, tb)}" for k, tb in enumerate(tables)]
    lines.append("Bodies (temporaries are numbered after them):")
    for i, b in enumerate(tree.bodies):
        parent = "ground" if b.parent < 0 else tree.bodies[b.parent].name
        lines.append(f"  {i + 1}  {b.name}: {b.joint.kind} joint to {parent}")
        for k, e in enumerate(b.prescribed):
            if e is not None:
                lines.append(f"     prescribed coordinate {k}: {e}")
    lines += ["Every function returns 0 on success, 1 if the mass matrix or an articulated-inertia pivot is",
              "not positive, 2 if a result is not finite."]
    return [printable(line) for line in lines]


def printable(text: str) -> str:
    """`text` with every non-printable character (a newline, say) replaced by '?': for comments, which a
    newline would end in Python."""
    return "".join(c if c.isprintable() else "?" for c in str(text))
