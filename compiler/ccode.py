"""C code for the equations of motion: an expression printer and an emitter that owns the file.

The generated file is self-describing and has one fixed contract (relied on by `mbs.runtime`):

    #define MBS_NQ, MBS_NV, MBS_NX (= MBS_NQ + MBS_NV), MBS_NP, MBS_NWORK
    #define MBS_NY                 only when the model has outputs (then mbs_outputs exists)
    int mbs_rhs(double t, const double *x, const double *p, double *xdot, double *work);    x = [q; v]
    int mbs_mass_matrix(double t, const double *x, const double *p, double *M, double *work); nv*nv, row-major
    int mbs_forces(double t, const double *x, const double *p, double *f, double *work);    f = q - k
    int mbs_qdot(double t, const double *x, const double *p, double *qdot, double *work);
    int mbs_outputs(double t, const double *x, const double *p, double *y, double *work);   (if MBS_NY)
    const char *mbs_state_name(int i);  const char *mbs_parameter_name(int i);   (NULL when out of range)
    const char *mbs_output_name(int i);                                          (if MBS_NY)

Each function returns 0 on success, 1 when the mass matrix (in mbs_rhs: an articulated inertia pivot) is not
positive, 2 when a result is not finite. The functions are reentrant: no allocation, no static mutable data; the
caller provides MBS_NWORK doubles of work memory. Parameters are read from p at run time, so changing them needs no
recompilation; prescribed coordinates are computed from t inside each function. Lookup tables are static const
arrays with a static function `mbs_table_<k>(x)` each.

Every tape temporary a function needs becomes one `const double name = ...;` line, in tape order, under a comment
naming the algorithm step; a function only contains the temporaries its outputs depend on.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import sympy as sp

from .c_text import c_string, name_table  # noqa: F401 (c_string: part of this module's API)
from .ccode_loops import (CONSTRAINT_MATRIX, constraint_matrix_routine, loop_definitions, loop_functions, loop_routines,
                          loop_work_size, state_rates_routine, unchecked_constraint_matrix, unchecked_mass_matrix)
from .ccode_closed_form import CLOSED_FORM, closed_form_definitions, closed_form_functions, closed_form_routine
from .ccode_loop_terms import (LOOP_TERMS, LOOP_TERMS_READ, loop_terms_checks, loop_terms_readers, loop_terms_routine,
                               loop_terms_size)
from .ccode_parts import names_in, part_order, plan_parts
from .ccode_trig import INLINE_DEFINITION as TRIG_INLINE_DEFINITION, TRIG_HELPERS, TRIG_NEEDS
from .constraints import Constraints
from .emit_common import (  # noqa: F401
    INLINE_MAX_CHARS,
    PREC_UNARY,
    CodegenError,
    ExprPrinter,
    Naming,
    Routine,
    check_inputs,
    describe,
    equation_routines,
    identifier,
    plan_routine,
    printable,
    read_counts,
    table_slopes,
)
from .equations import Equations
from .angle_free import angle_free_tape, gated_lookups
from .hooks import c_helpers as hook_helpers
from .jacobian import jacobian_or_none, parameter_jacobian_or_none
from .jacobian_loops import loop_jacobian_or_none, loop_jacobian_work_size
from .reactions import ACCELERATION_ARRAY, MULTIPLIER_ARRAY

GENERATOR = "mbs.compiler.ccode"
#: OUTPUTS_MARKER: the first line of a file's outputs part (generate_c_outputs), which runtime/translation_units.py
#: builds as a unit of its own, so that a scene asking for other outputs recompiles only that unit.
from mbs.runtime.translation_units import COLD_APART, COLD_FUNCTIONS, OUTPUTS_MARKER, PART_SUFFIX  # noqa: E402


class NotSeparable(CodegenError):
    """The outputs cannot be written apart from the equations (they call a user hook): generate the file whole."""
c_identifier = identifier  # the old name


class CPrinter(ExprPrinter):
    """C99 text of a sympy expression; symbols are looked up in `names`."""

    LANGUAGE = "C"
    AND, OR, TRUE, FALSE, NAN = "&&", "||", "1", "0", "NAN"
    #: sin and cos inline (compiler/ccode_trig.py: 0.4 to 0.75 of the C library's instructions a call).
    FUNCTIONS = {**ExprPrinter.FUNCTIONS, "sin": "mbs_sin", "cos": "mbs_cos"}

    def _conditional(self, cond, then, otherwise):
        return f"({cond} ? {then} : {otherwise})"

    def _not(self, text):
        return f"!({text})", PREC_UNARY


#: Static helpers, defined in the file only when the printed code calls them (an unused static function is a
#: warning).
HELPERS = {
    "mbs_pow3": ["/* x^3 as the product x*x*x is printed for a symbol (the C library's pow costs ~20 times more). */",
                 "static double mbs_pow3(double x)",
                 "{",
                 "    return x * x * x;",
                 "}"],
    "mbs_pow4": ["/* x^4 as two squarings. */",
                 "static double mbs_pow4(double x)",
                 "{",
                 "    const double x2 = x * x;",
                 "    return x2 * x2;",
                 "}"],
    "mbs_sign": ["/* sign(x): -1, 0 or 1 (0 for NaN, like the model language's sign). */",
                 "static double mbs_sign(double x)",
                 "{",
                 "    return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);",
                 "}"],
    "mbs_lookup": ["/* y(x) by binary search in the n increasing knots xs: linear when ms is NULL, else the cubic",
                   " * Hermite interpolant with the knot slopes ms; the end values beyond the ends, NaN for NaN.  The",
                   " * search starts from the three intervals around the one evenly spaced knots would put x in when",
                   " * they hold it (a road profile's thousands of knots: a halving or two instead of a dozen), else",
                   " * from all: either way it ends on the one interval xs[lo] <= x < xs[lo + 1].",
                   " * (-DMBS_MACHINERY_FORMER=1: from all knots always, the same-run baseline of",
                   " * bench/event_instructions.py --machinery.) */",
                   "static double mbs_lookup(double x, const double *xs, const double *ys, const double *ms, int n)",
                   "{",
                   "    int lo = 0, hi = n - 1;",
                   "    double h, s, s2, s3;",
                   "    if (x <= xs[0])",
                   "        return ys[0];",
                   "    if (x >= xs[n - 1])",
                   "        return ys[n - 1];",
                   "#ifndef MBS_MACHINERY_FORMER",
                   "    {",
                   "        const double even = (x - xs[0]) / (xs[n - 1] - xs[0]) * (n - 1);",
                   "        if (even >= 0.0 && even < n - 1) {",
                   "            const int k = (int)even;",
                   "            const int below = k > 0 ? k - 1 : 0, above = k + 2 < n - 1 ? k + 2 : n - 1;",
                   "            if (xs[below] <= x && x < xs[above]) {",
                   "                lo = below;",
                   "                hi = above;",
                   "            }",
                   "        }",
                   "    }",
                   "#endif",
                   "    while (hi - lo > 1) {",
                   "        const int mid = (lo + hi) / 2;",
                   "        if (xs[mid] <= x)",
                   "            lo = mid;",
                   "        else",
                   "            hi = mid;",
                   "    }",
                   "    h = xs[hi] - xs[lo];",
                   "    s = (x - xs[lo]) / h;",
                   "    if (ms == NULL)",
                   "        return ys[lo] + s * (ys[hi] - ys[lo]);",
                   "    s2 = s * s;",
                   "    s3 = s2 * s;",
                   "    return (2.0 * s3 - 3.0 * s2 + 1.0) * ys[lo] + (s3 - 2.0 * s2 + s) * h * ms[lo]",
                   "           + (-2.0 * s3 + 3.0 * s2) * ys[hi] + (s3 - s2) * h * ms[hi];",
                   "}"],
    **TRIG_HELPERS,
}
#: The helpers a helper calls (_in_order defines them before it).
HELPER_NEEDS = TRIG_NEEDS


def _with_needs(used) -> set[str]:
    """The helpers `used` names and those they call, in turn."""
    found, todo = set(), list(used)
    while todo:
        name = todo.pop()
        if name not in found:
            found.add(name)
            todo += HELPER_NEEDS.get(name, ())
    return found


def _depth(name: str) -> int:
    """0 for a helper that calls none, else one more than the deepest it calls."""
    return 1 + max(map(_depth, HELPER_NEEDS[name])) if name in HELPER_NEEDS else 0


def _in_order(names) -> list[str]:
    """The helpers `names`, each after those it calls, else by name."""
    return sorted(names, key=lambda name: (_depth(name), name))


class CEmitter:
    """Writes the C file of `equations`, with the run-time parameters in the order of `parameters`, the model
    outputs `outputs` ((name, expression) pairs) and the lookup tables `tables` (mbs.language.expr.Table, or a
    TableRegistry; table k is called as mbs_table_k)."""

    def __init__(self, equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
                 outputs=(), tables=(), origin: str = "", inline_max_chars: int = INLINE_MAX_CHARS,
                 constraints=None, run_time_inputs=(), jacobian: bool = False, parameter_jacobian: bool = False,
                 dynamics=None, events=(), actions=(), friction=None, separate_outputs: bool = False,
                 closed_form=None, cold_apart: bool = False):
        self.eqs, self.model_name, self.inline_max_chars = equations, model_name, inline_max_chars
        # a tree's functions that no integrator calls left out of the file (mbs/pipeline.py cold_apart): the
        # runtime builds them into a library of their own when one is first called
        self.cold_apart = cold_apart and not (constraints is not None and constraints.nc)
        self.jacobian = self.parameter_jacobian = None
        self.loop_jacobian = None
        # bearing friction in loops (compiler/friction_loops.py bearing_routines): (routines, inputs, definitions,
        # work); f then depends on the loop solve itself, which the loop Jacobian's residuals do not know
        self.friction = friction
        # the outputs in a part of their own (generate_c_outputs): the rest of the file must not depend on them
        self.separate_outputs = separate_outputs
        if jacobian and not (constraints is not None and constraints.nc):
            self.eqs, self.jacobian = jacobian_or_none(equations)
        elif jacobian and not equations.zdot and friction is None:  # extra states: differences of mbs_rhs
            self.eqs, self.loop_jacobian = loop_jacobian_or_none(equations, constraints)
        if parameter_jacobian and not (constraints is not None and constraints.nc):
            self.eqs, self.parameter_jacobian = parameter_jacobian_or_none(self.eqs, parameters)
        self.run_time_inputs = tuple(run_time_inputs)
        # the dynamics functions asked for (compiler/dynamics_functions.py): (routines, acceleration inputs)
        self.dynamics_routines, dynamics_inputs, *frames = dynamics if dynamics is not None else ([], ())
        self.frame_names = tuple(frames[0]) if frames else ()
        self.constraints = constraints if constraints is not None and constraints.nc else None
        self.constraint_matrix = None
        if self.constraints is not None and not (separate_outputs and outputs):  # (not needed by the outputs part)
            self.eqs, self.constraint_matrix = constraint_matrix_routine(self.eqs, self.constraints)
        # loops closed in closed form (compiler/closed_form_loops.py): tried first at run time, the loop solver
        # where they decline (not needed by the outputs part either)
        self.closed_form = self.closed_form_routine = None
        if self.constraints is not None and closed_form is not None and not (separate_outputs and outputs):
            self.closed_form = closed_form
            self.eqs, self.closed_form_routine = closed_form_routine(self.eqs, closed_form)
        self.parameters = tuple(parameters)
        self.outputs = tuple((str(name), sp.sympify(e)) for name, e in outputs)
        self.events = tuple((str(name), sp.sympify(e)) for name, e in events)
        self._indicators_printed = None  # (tape, results) of mbs_events: _printed
        self.actions = tuple((str(name), sp.sympify(e)) for name, e in actions)
        self.tables = tuple(getattr(tables, "tables", tables))
        self.origin = origin
        check_inputs(equations, self.parameters, self.outputs + self.events + self.actions, self.tables, self.constraints, self.run_time_inputs)
        loop_inputs = self.loop_jacobian.inputs if self.loop_jacobian else ()
        loop_inputs += tuple(friction[1]) if friction else ()
        self.naming = Naming(self.eqs, self.parameters, self.run_time_inputs + tuple(dynamics_inputs) + loop_inputs)
        self.names = self.naming.names

    # ---- the file ---------------------------------------------------------------------------------------------

    def source(self, head_ready: Callable[[str, int], object] | None = None) -> str:
        """The file's text; head_ready: called with its head (head(), the text before the first function) and the
        number of temporaries on the tape before the functions are printed (runtime/build.py prebuild_head compiles
        the glue unit from it meanwhile)."""
        if head_ready is not None:
            head_ready(self.head(), len(self.eqs.tape))
        printer = CPrinter(self.names, len(self.tables))
        functions = [self._function(plan_routine(tape, self.naming, printer, name, out, doc, shape, printed,
                                                 check_positive=positive, inline_max_chars=self.inline_max_chars))
                     for name, out, doc, shape, results, positive in self._routines()
                     for tape, printed in [self._printed(name, results)]]
        if self.events:  # right after mbs_events
            at = next(i for i, text in enumerate(functions) if "\nint mbs_events(" in "\n" + text)
            functions.insert(at + 1, self._event_indicator(printer))
        tree = self.eqs.tree
        functions += [name_table("mbs_state_name", "state i", [s.name for s in tree.x_symbols]),
                      name_table("mbs_parameter_name", "parameter i", [s.name for s in self.parameters])]
        if self.outputs:
            functions.append(name_table("mbs_output_name", "output i", [name for name, _ in self.outputs]))
        if self.frame_names:
            functions.append(name_table("mbs_frame_name", "frame i", list(self.frame_names)))
        if self.constraints is not None:
            functions.append(loop_functions(self.constraints))
        if self.closed_form is not None:
            functions.append(closed_form_functions())
        if self._loop_terms():
            functions.append(loop_terms_readers())
        return "\n".join([self._header(), *self._helpers(printer.used, printer.hook_calls), *functions])

    def _routines(self) -> list:
        """The contract's functions; with loops the constraint functions, and mbs_rhs is the loop solver's."""
        routines = equation_routines(self.eqs, self.outputs, self.events, self.actions) + list(self.dynamics_routines)
        if self.constraints is None:
            if self.cold_apart:
                routines = [r for r in routines if r[0] not in COLD_FUNCTIONS]
            return routines + [r for r in (self.jacobian, self.parameter_jacobian) if r]
        partials = self.loop_jacobian.routine if self.loop_jacobian else None
        loops = loop_routines(self.constraints) + ([partials] if partials else [])
        terms = loop_terms_routine(self.eqs, self.constraints, self.constraint_matrix)
        read_off = set(LOOP_TERMS_READ) if terms else set()  # read off the loop terms (loop_terms_readers)
        return ([r for r in routines + loops if r[0] != "mbs_rhs" and r[0] not in read_off]
                + [r for r in (self.constraint_matrix, state_rates_routine(self.eqs), self.closed_form_routine,
                               terms) if r]
                + (list(self.friction[0]) if self.friction else []))

    def _printed(self, routine: str, results: list) -> tuple:
        """(tape, results) a function is printed from: the indicators' without the sines and cosines of angles they
        do not depend on (compiler/angle_free.py angle_free_tape: a wheel's spin) and without the lookups a
        parameter at 0 scales away (gated_lookups: a road's random profile, off), every other function's the
        equations' tape and its own results."""
        if routine != "mbs_events":
            return self.eqs.tape, results
        if self._indicators_printed is None:  # (the fork is derived once: mbs_events and mbs_event_indicator)
            indicators = [e for _, e in self.events]
            tape, gated = gated_lookups(angle_free_tape(self.eqs.tape, indicators), indicators, self.parameters)
            self._indicators_printed = tape, list(enumerate(gated))
        tape, printed = self._indicators_printed
        return tape, [printed[k] for k, _ in results]

    def _event_indicator(self, printer) -> str:
        """mbs_event_indicator(k, ...): g[k] alone, each indicator's own slice of mbs_events' tape (a case of a switch
        on k; the rest of g is left as it is).  The root finding of c/ode.c evaluates the indicators that cross in a
        step alone at its trial points: on the Iltis a damper's rate limit about 150 instructions, a tyre's about
        550, where mbs_events costs 2,900.  An indicator whose slice would be printed in parts (a long one) is left
        to mbs_events."""
        nev = len(self.events)
        tape, printed = self._printed("mbs_events", [(k, None) for k in range(nev)])
        exprs = [e for _, e in printed]
        counts = read_counts(tape, tape.entries_for(exprs), exprs)  # mbs_events' own: its text, the same bits
        cases = []
        for k, e in printed:
            r = plan_routine(tape, self.naming, printer, "mbs_event_indicator", "g", "", (nev,), [(k, e)],
                             inline_max_chars=self.inline_max_chars, counts=counts)
            if plan_parts(r.steps, r.results) is not None:
                continue
            cases += [f"    case {k}: {{", *("    " + line for line in self._body(r, *self._run_time_prologue(r))),
                      f"        return mbs_all_finite(g + {k}, 1) ? 0 : 2;", "    }"]
        return "\n".join([
            "/* event indicator k alone: g[k] of mbs_events (the rest of g as it was), for the root finding */",
            "int mbs_event_indicator(int k, double t, const double *x, const double *p, double *g, double *work)",
            "{", "    switch (k) {", *cases, "    default:", "        break;", "    }",
            "    return mbs_events(t, x, p, g, work);", "}\n"])

    def _loop_terms(self) -> bool:
        """Whether the file has mbs_loop_terms, and mbs_mass_matrix, mbs_forces, mbs_constraint_acceleration
        read off it."""
        return self.constraints is not None and self.constraint_matrix is not None

    def write(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.source())
        return path

    def _header(self) -> str:
        """The file up to its first contract function: head() and the static helpers every file has."""
        lines = [self.head(),
                 "static int mbs_all_finite(const double *a, int n)",
                 "{",
                 "    /* 1 if every a[i] is finite: a[i] * 0 is 0 for a finite entry and NaN for an infinite or NaN one,",
                 "     * and a NaN stays in the sums (a test and branch per entry cost the Iltis's loop terms 410",
                 "     * instructions a call for their 58 entries, these two sums 260; the comment is inside the function:",
                 "     * the file's head, which runtime/translation_units.py compiles early, ends at its first line) */",
                 "    double s0 = 0.0, s1 = 0.0;",
                 "    int i;",
                 "    for (i = 0; i + 1 < n; i += 2) {",
                 "        s0 += a[i] * 0.0;",
                 "        s1 += a[i + 1] * 0.0;",
                 "    }",
                 "    if (i < n)",
                 "        s0 += a[i] * 0.0;",
                 "    return s0 + s1 == 0.0;",
                 "}",
                 ""]
        if not self.cold_apart:  # (the mass matrix's test alone calls it: unused, a warning)
            lines += POSITIVE_DEFINITE
        return "\n".join(lines)

    def head(self) -> str:
        """The file's text before its first function: the comment, the sizes, the constant tables and the
        declarations, everything known before a function is printed (runtime/translation_units.py glue_header)."""
        nq, nv = self.eqs.tree.nq, self.eqs.tree.nv
        text = describe(self.eqs, self.parameters, None if self.separate_outputs else self.outputs, self.tables,
                        self.model_name, self.origin, GENERATOR, self.inline_max_chars)
        # Names and expressions inside the comment must neither end it nor form trigraphs.
        comment = [_comment(" * " + line).rstrip() for line in text]
        comment[0] = "/*" + comment[0][2:]
        lines = [*comment, " */",
                 "#include <math.h>",
                 "#include <stddef.h>",
                 *(["#include <string.h>   /* memcpy: the functions read off the loop terms */"]
                   if self._loop_terms() else []),
                 *TRIG_INLINE_DEFINITION,
                 "",
                 f"#define MBS_NQ {nq}   /* free position coordinates */",
                 f"#define MBS_NV {nv}   /* free velocity coordinates */",
                 *([f"#define MBS_NZ {self.eqs.tree.nz}   /* extra differential states */",
                    "#define MBS_NX (MBS_NQ+MBS_NV+MBS_NZ)"] if self.eqs.tree.nz else ["#define MBS_NX (MBS_NQ+MBS_NV)"]),
                 f"#define MBS_NP {len(self.parameters)}   /* parameters */",
                 f"#define MBS_NWORK {self._work()}   /* doubles of work memory the caller provides */"]
        if self.outputs:
            lines.append(f"#define MBS_NY {len(self.outputs)}   /* outputs */")
        if self._output_scratch():
            lines.append(f"#define MBS_OUTPUTS_WORK {self._output_scratch()}   /* mbs_outputs solve in work from here */")
        if self.jacobian:
            lines.append("#define MBS_JACOBIAN 1   /* mbs_jacobian exists */")
        if self.cold_apart:
            lines.append(f"#define {COLD_APART} 1   /* mbs_mass_matrix, mbs_forces ... are not in this file: the "
                         "runtime builds them apart when first called */")
        if self.dynamics_routines:
            lines.append("#define MBS_NXA (MBS_NX+MBS_NV)   /* input [q; v; a] of mbs_inverse_dynamics */")
        if self.frame_names:
            lines.append(f"#define MBS_NF {len(self.frame_names)}   /* named frames (mbs_frame_name) */")
        if self.events:
            lines.append(f"#define MBS_NEV {len(self.events)}   /* event indicators (mbs_events) */")
            lines.append("#define MBS_EVENT_INDICATOR 1   /* mbs_event_indicator exists: one indicator alone */")
        if self.actions:
            lines.append(f"#define MBS_NACT {len(self.actions)}   /* values of event actions (mbs_event_actions) */")
        if self.parameter_jacobian:
            lines.append("#define MBS_PARAM_JACOBIAN 1   /* mbs_param_jacobian exists */")
        if self.constraints is not None:
            lines += [f"#define MBS_TREE_NWORK {self._tree_work()}   /* of the tree functions */",
                      loop_definitions(self.constraints, self.constraint_matrix is not None, self._friction_work(),
                                       len(self.parameters), self.eqs.mass_matrix)]
            if self.closed_form is not None:
                lines.append(closed_form_definitions(self.closed_form, nv, self.constraints.nc))
            if self.friction:
                lines.append(self.friction[2])
            if self.loop_jacobian:
                lines.append(self.loop_jacobian.definitions)
        lines += ["",
                  "/* Leave with status 1 (not positive) or 2 (not a number) unless the pivot d is positive. */",
                  "#define MBS_PIVOT(d) do { if (!((d) > 0.0)) return (d) <= 0.0 ? 1 : 2; } while (0)",
                  ""]
        return "\n".join(lines)

    def _helpers(self, used: set, hook_calls: dict | None = None) -> list[str]:
        """The static helpers the functions call, then one array group and one function per lookup table."""
        used = _with_needs(used)
        parts = ["\n".join(HELPERS[name]) + "\n" for name in _in_order(HELPERS) if name in used
                 or (name == "mbs_lookup" and self.tables)]
        parts += hook_helpers(hook_calls or {})
        return parts + [_table_text(k, table) for k, table in enumerate(self.tables)]

    def outputs_source(self, defined: set[str], first_table: int) -> str:
        """The outputs' part of a file whose other part (written with separate_outputs and no outputs) defines
        the static helpers named in `defined` and the lookup tables below `first_table`: MBS_NY, the helpers and
        tables only the outputs use, mbs_outputs and mbs_output_name. Raises NotSeparable for outputs that call
        a user hook (its helpers are one block per file)."""
        printer = CPrinter(self.names, len(self.tables))
        routines = [r for r in equation_routines(self.eqs, self.outputs) if r[0] == "mbs_outputs"]
        functions = [self._function(plan_routine(self.eqs.tape, self.naming, printer, name, out, doc, shape, results,
                                                 check_positive=positive, inline_max_chars=self.inline_max_chars))
                     for name, out, doc, shape, results, positive in routines]
        if printer.hook_calls:
            raise NotSeparable("the outputs call a user hook")
        new_tables = self.tables[first_table:]
        used = _with_needs(printer.used)
        helpers = ["\n".join(HELPERS[name]) + "\n" for name in _in_order(HELPERS) if name not in defined
                   and (name in used or (name == "mbs_lookup" and new_tables))]
        helpers += [_table_text(first_table + k, table) for k, table in enumerate(new_tables)]
        names = [_comment(f"  y[{k}]  {name}") for k, (name, _) in enumerate(self.outputs)]
        return "\n".join([OUTPUTS_MARKER, "/* Outputs y:", *[" *" + n[1:] for n in names], " */",
                          f"#define MBS_NY {len(self.outputs)}   /* outputs */", "", *helpers, *functions,
                          name_table("mbs_output_name", "output i", [name for name, _ in self.outputs])])

    def _work(self) -> int:
        return self._tree_work() + self._loop_work() + self._output_scratch()

    def _loop_work(self) -> int:
        """Doubles of work after the tree functions': the loop solver's (its bearing friction's at its end), then
        the loop Jacobian's."""
        tree = self.eqs.tree
        nc = self.constraints.nc if self.constraints is not None else 0
        loops = (loop_work_size(tree.nq, tree.nv, nc, tree.nz, len(self.parameters)) + self._friction_work()
                 if nc else 0)
        if self.loop_jacobian:
            loops += loop_jacobian_work_size(tree.nq, tree.nv, nc)
        return loops

    def _tree_work(self) -> int:
        """Doubles of work the generated functions use: the mass matrix's Cholesky test, or all the loop terms
        that mbs_mass_matrix, mbs_forces and mbs_constraint_acceleration are read off."""
        nv = self.eqs.tree.nv
        return max(nv * nv, loop_terms_size(nv, self.constraints.nc) if self._loop_terms() else 0)

    def _friction_work(self) -> int:
        """Doubles at the end of the loop solver's work for bearing friction in the loops (MBS_FRICTION_NWORK)."""
        return self.friction[3] if self.friction else 0

    def _output_scratch(self) -> int:
        """Doubles at the start of work in which the output function keeps x' and the multipliers (with the
        outputs in a part of their own always: MBS_NWORK must not depend on which outputs a scene asks for).

        With loops the outputs (and the events that read the multipliers) solve in work + this
        (MBS_OUTPUTS_WORK, mbs_loop_rates; the rows' projection too, c/mbs_glue.c): a loop solver's work of its
        own, which must not overlap the right-hand side's at work. The two keep a partition, its blocks' plan and
        a stamp from call to call; overlapping by a few doubles, each overwrote the other's plan (found as a
        crash in the blocks' null space of a plane contact beside a slider-crank once the stamp grew)."""
        if not self.run_time_inputs and not self.separate_outputs:
            return 0
        rates = self.eqs.tree.nx + (self.constraints.nc if self.constraints is not None else 0)
        if self.constraints is None:
            return rates
        return max(rates, self._tree_work() + self._loop_work())

    def _run_time_prologue(self, r: Routine) -> tuple[list[str], list[str]]:
        """Lines that evaluate the accelerations (and multipliers) the function reads, before it reads them: the
        pointers to them in work, and the call that fills work with its status test (both empty or neither)."""
        arrays = {array for _, _, array, _ in r.reads}
        if not arrays & {ACCELERATION_ARRAY, MULTIPLIER_ARRAY}:
            return [], []
        scratch = self._output_scratch()
        pointers = []
        if ACCELERATION_ARRAY in arrays:  # (a function that reads only multipliers, friction's events, has none)
            pointers.append(f"    const double *const {ACCELERATION_ARRAY} = work + MBS_NQ;")
        if self.constraints is None:
            call = [f"    const int mbs_status = mbs_rhs(t, x, p, work, work + {scratch});"]
        else:
            pointers.append(f"    const double *const {MULTIPLIER_ARRAY} = work + MBS_NX;")
            # the header's macro: the emitter of a separate outputs unit may count another tree work
            solver = "work + MBS_OUTPUTS_WORK" if scratch else "work"
            call = [f"    const int mbs_status = mbs_loop_rates(t, x, p, work, {solver});"]
        return pointers, [*call, "    if (mbs_status != 0)", "        return mbs_status;"]

    def _function(self, r: Routine) -> str:
        out = r.out
        if r.check_positive and self.constraints is not None:
            return unchecked_mass_matrix(self._function(replace(r, name=f"{r.name}_unchecked",
                                                               check_positive=False)), r.name, out)
        pointers, call = self._run_time_prologue(r)
        plan = plan_parts(r.steps, r.results) if r.name != CLOSED_FORM else None
        if plan is None:
            lines = [f"/* {_comment(r.doc)} */",
                     f"int {r.name}(double t, const double *x, const double *p, double *{out}, double *work)", "{",
                     *self._body(r, pointers, call)]
            text = "\n".join(lines + self._epilogue(r))
        else:
            text = self._parted_function(r, plan, pointers, call)
        if r.name == LOOP_TERMS:
            return loop_terms_checks(text)
        return unchecked_constraint_matrix(text, out) if r.name == CONSTRAINT_MATRIX else text

    def _body(self, r: Routine, pointers: list[str], call: list[str]) -> list[str]:
        """The lines of a function printed in one piece between its opening brace and its epilogue: the run-time
        prologue, the reads, the unused arguments voided, the temporaries and the outputs."""
        lines = [*([_PROLOGUE_COMMENT] if call else []), *pointers, *call]
        lines += [_read_line(read) for read in r.reads]
        reads = {a for *_, a, _ in r.reads}
        unused = [arg for arg, present in (("t", r.uses_t), ("x", "x" in reads), ("p", "p" in reads),
                                           ("work", r.check_positive)) if not (present or pointers)]
        if unused:
            lines.append("    " + " ".join(f"(void){arg};" for arg in unused))
        return lines + _statements(r.steps, r.results, r.out)

    def _epilogue(self, r: Routine) -> list[str]:
        """The end of a function once its outputs are written: the test for finite values, the status."""
        size = _SIZE_MACROS.get(r.out) or str(math.prod(r.shape))
        lines = []
        if r.name != CLOSED_FORM:  # (the closed form's callers test what they give: runtime/c/loops.c hooks)
            lines += [f"    if (!mbs_all_finite({r.out}, {size}))", "        return 2;"]
        if r.check_positive:
            lines.append(f"    return mbs_positive_definite({r.out}, MBS_NV, work) ? 0 : 1;")
        else:
            lines.append("    return 0;")
        return lines + ["}\n"]

    def _parted_function(self, r: Routine, plan, pointers: list[str], call: list[str]) -> str:
        """`r` as its parts (compiler/ccode_parts.py), each a function, and the function that calls them."""
        parts, slots, copies = plan
        out, n = r.out, len(parts)
        copies_in_part, copies = _copies_after_sources(parts, copies)
        texts = []
        for k, part in enumerate(parts, 1):
            used = set().union(*map(names_in, _part_texts(part)))
            reads = [read for read in r.reads if read[1] in used]
            arrays = {array for *_, array, _ in reads}
            mine = [line for line in pointers if line.split(" = ")[0].split()[-1] in arrays]
            lines = [f"/* {r.name}, part {k} of {n}: temporaries {part.steps[0].name} to {part.steps[-1].name} "
                     "(compiler/ccode_parts.py) */",
                     f"int {r.name}{PART_SUFFIX}{k}(double t, const double *x, const double *p, double *{out}, "
                     "double *work, double *carry)", "{", *mine]
            lines += [_read_line(read) for read in reads]
            unused = [arg for arg, present in (("t", "t" in used), ("x", "x" in arrays), ("p", "p" in arrays),
                                               (out, bool(part.results)), ("work", bool(mine)),
                                               ("carry", bool(part.imports or part.exports))) if not present]
            if unused:
                lines.append("    " + " ".join(f"(void){arg};" for arg in unused))
            lines += _part_statements(part_order(part, copies_in_part[k - 1]), slots, out)
            texts.append("\n".join(lines + ["    return 0;", "}\n"]))
        lines = [f"/* {_comment(r.doc)} (in {n} parts) */",
                 f"int {r.name}(double t, const double *x, const double *p, double *{out}, double *work)", "{",
                 *([_PROLOGUE_COMMENT] if call else []), *call,
                 f"    double carry[{max(len(slots), 1)}];   /* temporaries one part leaves to a later one */",
                 "    int status;"]
        for k in range(1, n + 1):
            lines += [f"    if ((status = {r.name}{PART_SUFFIX}{k}(t, x, p, {out}, work, carry)) != 0)",
                      "        return status;"]
        if copies:
            lines.append("    /* the entries equal to others */")
            lines += [f"    {out}[{k}] = {out}[{j}];" for k, j in copies]
        texts.append("\n".join(lines + self._epilogue(r)))
        return "\n".join(texts)


#: The Cholesky test of mbs_mass_matrix (in the header of every file that has one).
POSITIVE_DEFINITE = ["/* Cholesky factorisation of the n x n row-major matrix A into work (n*n doubles): 1 if A is",
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
_PROLOGUE_COMMENT = "    /* the accelerations at (t, x) first: x' at the start of work, then the loop multipliers */"


def _read_line(read) -> str:
    s, cname, array, index = read
    return f"    const double {cname} = {array}[{index}];   /* {_comment(s.name)} */"


def _statements(steps, results, out: str) -> list[str]:
    """The temporaries under their sections' comments (each after its pivot test), then the outputs."""
    lines, section = [], None
    for step in steps:
        if step.section != section:
            section = step.section
            lines.append(f"    /* {_comment(section)} */")
        if step.guard is not None:
            lines.append(f"    MBS_PIVOT({step.guard});")
        lines.append(f"    const double {step.name} = {step.text};")
    lines.append("    /* outputs */")
    for k, value in results:
        lines.append(f"    {out}[{k}] = {f'{out}[{value}]' if isinstance(value, int) else value};")
    return lines


def _part_statements(order, slots: dict[str, int], out: str) -> list[str]:
    """A part's statements in the order of ccode_parts.part_order, under their sections' comments: the reads of
    carried temporaries, the temporaries (each after its pivot test), their stores for later parts, the outputs."""
    lines, reads, section = [], [], None
    for kind, what in order:
        if kind == "read":  # (printed after the comment of the section whose statement reads it)
            reads.append(f"    const double {what} = carry[{slots[what]}];")
            continue
        if kind == "step" and what.section != section:
            section = what.section
            lines.append(f"    /* {_comment(section)} */")
        lines += reads
        reads.clear()
        if kind == "keep":
            lines.append(f"    carry[{slots[what]}] = {what};")
        elif kind == "write":
            k, value = what
            lines.append(f"    {out}[{k}] = {f'{out}[{value}]' if isinstance(value, int) else value};")
        else:
            if what.guard is not None:
                lines.append(f"    MBS_PIVOT({what.guard});")
            lines.append(f"    const double {what.name} = {what.text};")
    return lines


def _copies_after_sources(parts, copies) -> tuple[list[list], list]:
    """Each part's outputs with the entries copied from them (a symmetric mass matrix's lower triangle) right after
    their source, where the value is still in a register: one store each, where the parent's copy after all parts
    loads it back (1,100 of the Iltis's loop terms' instructions). The copies whose source no part writes stay
    with the parent."""
    home = {j: n for n, part in enumerate(parts) for j, _ in part.results}
    after: dict[int, list[int]] = {}
    left = []
    for k, j in copies:
        if j in home:
            after.setdefault(j, []).append(k)
        else:
            left.append((k, j))
    results = [[entry for j, value in part.results for entry in [(j, value), *((k, j) for k in after.get(j, ()))]]
               for part in parts]
    return results, left


def _part_texts(part) -> list[str]:
    return ([s.text for s in part.steps] + [s.guard for s in part.steps if s.guard]
            + [v for _, v in part.results])


#: The length of each contract function's output, as the file's size macros.
_SIZE_MACROS = {"xdot": "MBS_NX", "M": "MBS_NV*MBS_NV", "f": "MBS_NV", "qdot": "MBS_NQ", "y": "MBS_NY",
                "g": "MBS_NEV", "a": "MBS_NACT"}


def _comment(text: str) -> str:
    """Text safe inside a C comment: does not end it, opens none inside it (a warning), holds no trigraph."""
    return printable(text).replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")


def _table_text(k: int, table) -> str:
    """The arrays and the function mbs_table_<k> of lookup table k."""
    n, smooth = len(table.xs), table.method == "smooth"
    lines = [f"/* Lookup table {k}: {'monotone cubic' if smooth else 'linear'} interpolation in {n} points, "
             "constant beyond the ends. */",
             _array(f"mbs_table_{k}_x", table.xs), _array(f"mbs_table_{k}_y", table.ys)]
    if smooth:
        lines.append(_array(f"mbs_table_{k}_m", table_slopes(table.xs, table.ys)))
    slopes = f"mbs_table_{k}_m" if smooth else "NULL"
    lines += [f"static double mbs_table_{k}(double x)", "{",
              f"    return mbs_lookup(x, mbs_table_{k}_x, mbs_table_{k}_y, {slopes}, {n});", "}", ""]
    return "\n".join(lines)


def _array(name: str, values) -> str:
    return f"static const double {name}[{len(values)}] = {{{', '.join(repr(float(v)) for v in values)}}};"


def generate_c(equations: Equations, parameters: Sequence[sp.Symbol], model_name: str = "model", *,
               outputs=(), tables=(), origin: str = "", inline_max_chars: int = INLINE_MAX_CHARS,
               constraints=None, run_time_inputs=(), jacobian: bool = False, parameter_jacobian: bool = False,
               dynamics=None, events=(), actions=(), friction=None, separate_outputs: bool = False,
               closed_form=None, cold_apart: bool = False, head_ready=None) -> str:
    """The C source text of `equations` (see the module docstring for the contract).

    parameters: fixes the order of p; must hold every parameter the equations and the outputs use.
    outputs: (name, sympy expression on the equations' tape) pairs, e.g. `Lowered.outputs`; none: no MBS_NY.
    tables: the lookup tables the expressions call as mbs_table_k (`Lowered.tables` or its `.tables` list).
    origin: where the model came from (e.g. "pendulum.mbs, scene swing"), for the header comment.
    run_time_inputs: (symbol, array, index) of the accelerations and multipliers the outputs read
    (`Lowered.run_time_inputs`): mbs_outputs then evaluates the right-hand side first.
    jacobian: also emit mbs_jacobian (compiler/jacobian.py; trees only), for the stiff integrators.
    dynamics: (routines, inputs) of compiler/dynamics_functions.py when the dynamics functions are asked for.
    events, actions: (name, expression) pairs of mbs_events (MBS_NEV) and mbs_event_actions (MBS_NACT).
    parameter_jacobian: also emit mbs_param_jacobian (d xdot/d p; trees only), for sensitivities.
    separate_outputs: the file without outputs, to which generate_c_outputs appends them (then the text does
    not depend on the outputs: the header does not list them, MBS_NWORK always holds their scratch).
    cold_apart: a tree's file without the functions no integrator calls (runtime/translation_units.py
    COLD_FUNCTIONS), which the runtime builds from the whole file when first called; the rest of the text is the
    whole file's (MBS_NWORK too), the header says so (COLD_APART).
    head_ready: called with the file's head (CEmitter.head) and the tape's length before a function is printed."""
    return CEmitter(equations, parameters, model_name, outputs=outputs, tables=tables, origin=origin,
                    events=events, actions=actions,
                    inline_max_chars=inline_max_chars, constraints=constraints,
                    run_time_inputs=run_time_inputs, jacobian=jacobian, parameter_jacobian=parameter_jacobian,
                    dynamics=dynamics, friction=friction, separate_outputs=separate_outputs,
                    closed_form=closed_form, cold_apart=cold_apart).source(head_ready)


def generate_c_outputs(equations: Equations, parameters: Sequence[sp.Symbol], equations_source: str,
                       first_table: int, *, outputs, tables=(), constraints=None, run_time_inputs=(),
                       friction=None, inline_max_chars: int = INLINE_MAX_CHARS) -> str:
    """The outputs' part of a file whose rest is `equations_source` (generate_c with separate_outputs and the
    same equations, parameters and constraints, before the outputs were lowered onto the tape): appended to
    it, the whole file. `first_table`: how many lookup tables that rest defines (the outputs' own come after).
    Raises NotSeparable when the outputs cannot stand apart (then generate the file whole). No outputs: ''."""
    if not outputs:
        return ""
    defined = set(re.findall(r"^static (?:inline |MBS_TRIG_INLINE )?(?:int|double|void) (mbs_\w+)\(", equations_source,
                             re.MULTILINE))
    return CEmitter(equations, parameters, outputs=outputs, tables=tables, constraints=constraints,
                    run_time_inputs=run_time_inputs, friction=friction, inline_max_chars=inline_max_chars,
                    separate_outputs=True).outputs_source(defined, first_table)


def generate_loop_c(equations: Equations, constraints: Constraints, parameters: Sequence[sp.Symbol],
                    model_name: str = "model", *, outputs=(), tables=(), origin: str = "") -> str:
    """The whole C file of a model with loops, from `ccode.CEmitter`'s parts: its header with MBS_NWORK
    enlarged by MBS_LOOP_NWORK, the tree functions except the articulated-body mbs_rhs (which would solve the
    open tree), the constraint functions, and mbs_rhs as the constrained right-hand side.

    `equations` may lack vdot (derive with forward_dynamics=False: the articulated-body algorithm divides by
    zero for massless bodies, which loops allow). Everything on the tape must be derived before this call."""
    tree = equations.tree
    if equations.vdot is None:  # the emitter checks that vdot exists; it is not printed here
        equations = replace(equations, vdot=(sp.S.Zero,) * tree.nv)
    emitter = CEmitter(equations, parameters, model_name, outputs=outputs, tables=tables, origin=origin)
    missing = [s.name for s in constraints.parameters() if s not in set(emitter.parameters)]
    if missing:
        raise CodegenError(f"parameters missing from the parameter list: {', '.join(missing)}")
    printer = CPrinter(emitter.names, len(emitter.tables))
    routines = [r for r in equation_routines(equations, emitter.outputs) if r[0] != "mbs_rhs"]
    routines += loop_routines(constraints)
    functions = [emitter._function(plan_routine(equations.tape, emitter.naming, printer, name, out, doc, shape,
                                                results, check_positive=positive))
                 for name, out, doc, shape, results, positive in routines]
    header = emitter._header()
    tree_work = re.search(r"#define MBS_NWORK (\d+)", header)
    if tree_work is None:
        raise CodegenError("the emitter's header has no '#define MBS_NWORK <n>' line")
    total = int(tree_work.group(1)) + loop_work_size(tree.nq, tree.nv, constraints.nc, np=len(emitter.parameters))
    header = header.replace(tree_work.group(0), f"#define MBS_TREE_NWORK {tree_work.group(1)}   /* of the tree "
                                                f"functions */\n#define MBS_NWORK {total}")
    names = [name_table("mbs_state_name", "state i", [s.name for s in tree.q_symbols + tree.v_symbols]),
             name_table("mbs_parameter_name", "parameter i", [s.name for s in emitter.parameters])]
    if emitter.outputs:
        names.append(name_table("mbs_output_name", "output i", [name for name, _ in emitter.outputs]))
    helpers = emitter._helpers(printer.used, printer.hook_calls)
    definitions = loop_definitions(constraints, np=len(emitter.parameters), mass_matrix=equations.mass_matrix)
    return "\n".join([header, definitions, *helpers, *functions, *names,
                      loop_functions(constraints)])
