"""C code of the loop-closure constraints: the generated part of a model with closed kinematic loops.

The model's constraint rows (`mbs.compiler.constraints`) become three functions of the one fixed signature,
printed by the same planner and printer as the equations of motion (`ccode.CEmitter`):

    int mbs_constraints(double t, const double *x, const double *p, double *out, double *work);           g, nc
    int mbs_constraint_velocity(double t, const double *x, const double *p, double *out, double *work);   G v + g_t
    int mbs_constraint_acceleration(double t, const double *x, const double *p, double *out, double *work);
                                                                                       gddot with vdot = 0, nc
    const char *mbs_constraint_name(int i);      "<cut joint>.<label>", NULL when out of range

and the definitions the run-time loop solver (runtime/c/loops.c) reads:

    #define MBS_NC ..            constraint rows (> 0 marks a model with loops)
    #define MBS_NQUAT ..         quaternions in q; static const int mbs_quaternion_slots[]: index of each qw
    #define MBS_LOOP_NWORK ..    doubles of work the loop solver needs beyond the tree's MBS_TREE_NWORK

With loops, `mbs_rhs` is the constrained right-hand side: a wrapper of `mbs_loop_rhs` (runtime/c/loops.c,
compiled after the model), so every consumer of mbs_rhs gets the dynamics of the closed mechanism.

`loop_routines` gives the functions in the emitter's routine format, `loop_definitions` and `loop_functions`
the rest of the text; `generate_loop_c` assembles a whole file from `ccode.CEmitter`'s parts.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import replace

import sympy as sp

from .constraints import Constraints
from .emit_common import CodegenError, equation_routines, plan_routine
from .equations import Equations
from .jacobian_colours import constraint_colours

#: Doubles of scalar scratch in the loop solver's work area (runtime/c/loops.c, MBS_LOOP_NWORK_NEEDED).
LOOP_SCALARS = 16


def loop_work_size(nq: int, nv: int, nc: int) -> int:
    """Doubles of work memory the loop solver needs beyond the tree functions' (the formula of
    MBS_LOOP_NWORK_NEEDED in runtime/c/loops.c, which checks it at compile time)."""
    nx = nq + nv
    return 3 * nv * nv + 3 * nc * nv + 7 * nc + 2 * nx + 10 * nv + nq + 4 + LOOP_SCALARS


def loop_routines(constraints: Constraints) -> list:
    """(name, out, doc, shape, results, check_positive) of the generated constraint functions, the format of
    `emit_common.equation_routines`. The output array is called `out` (a reserved name)."""
    nc = constraints.nc
    return [
        ("mbs_constraints", "out", "loop-closure residuals g(q, t), one per constraint row [m or -]", (nc,),
         list(enumerate(constraints.position)), False),
        ("mbs_constraint_velocity", "out", "gdot = G(q) v + g_t(q, t), affine in v [m/s or 1/s]", (nc,),
         list(enumerate(constraints.velocity)), False),
        ("mbs_constraint_acceleration", "out", "gddot with vdot = 0: G vdot + this = 0 on the constraint "
         "manifold [m/s^2 or 1/s^2]", (nc,), list(enumerate(constraints.acceleration)), False),
    ]


def loop_definitions(constraints: Constraints) -> str:
    """Sizes, quaternion slots and the declaration of the loop solver's right-hand side (after the header)."""
    tree = constraints.tree
    slots = constraints.quaternion_slots
    work = loop_work_size(tree.nq, tree.nv, constraints.nc)
    colours = constraint_colours(constraints)
    ncol = max(colours.ncolours, 1)
    table = [colours.column_of(i, c) for i in range(constraints.nc) for c in range(ncol)]
    return "\n".join([
        f"#define MBS_NC {constraints.nc}   /* loop-closure constraint rows */",
        f"#define MBS_NQUAT {len(slots)}   /* quaternions in q */",
        f"#define MBS_LOOP_NWORK {work}   /* doubles of work for the loop solver (runtime/c/loops.c) */",
        "/* Index in x of the first component (qw) of each quaternion (the list holds -1 when there is none). */",
        f"static const int mbs_quaternion_slots[{max(len(slots), 1)}] = "
        f"{{{', '.join(str(s) for s in slots) or '-1'}}};",
        "/* Columns of the constraint Jacobian G that share no row get one colour: one evaluation of",
        " * mbs_constraint_velocity with all of them set to 1 gives them all (runtime/c/loops.c). */",
        f"#define MBS_NCOLOUR {colours.ncolours}   /* evaluations for G beyond gdot(v = 0) */",
        "/* Colour of each velocity column, -1 when no row depends on it. */",
        f"static const int mbs_column_colour[{tree.nv}] = {{{', '.join(map(str, colours.colour))}}};",
        "/* Row i, colour c: the column of that colour row i depends on, -1 when none. */",
        f"static const int mbs_colour_column[{len(table)}] = {{{', '.join(map(str, table))}}};",
        "",
        "/* The constrained right-hand side and the multipliers, defined by the run-time loop solver compiled",
        " * after this file. */",
        "int mbs_loop_rhs(double t, const double *x, const double *p, double *xdot, double *work);",
        "int mbs_loop_rhs_direct(double t, const double *x, const double *p, double *xdot, double *work);",
        "int mbs_loop_multipliers(double t, const double *x, const double *p, double *lambda, double *work);",
        ""])


def loop_functions(constraints: Constraints) -> str:
    """The name table of the rows and `mbs_rhs`, the constrained right-hand side."""
    return "\n".join([
        name_table("mbs_constraint_name", "constraint row i (\"<cut joint>.<label>\")", constraints.names),
        "/* x' = [qdot; vdot] of the closed mechanism: the state projected onto the constraints, vdot by the",
        " * null-space method (runtime/c/loops.c). */",
        "int mbs_rhs(double t, const double *x, const double *p, double *xdot, double *work)", "{",
        "    return mbs_loop_rhs(t, x, p, xdot, work);", "}", ""])


def name_table(function: str, what: str, names: Sequence[str]) -> str:
    """`const char *function(int i)`: names[i], NULL when out of range."""
    from .ccode import c_string  # ccode imports this module (the splice): import at call time
    lines = [f"/* Name of {what}, NULL when out of range. */", f"const char *{function}(int i)", "{"]
    if names:
        lines += ["    static const char *const names[] = {"]
        lines += [f"        {c_string(name)}," for name in names]
        lines += ["    };", f"    return (i >= 0 && i < {len(names)}) ? names[i] : NULL;"]
    else:
        lines += ["    (void)i;", "    return NULL;"]
    return "\n".join(lines + ["}", ""])


def generate_loop_c(equations: Equations, constraints: Constraints, parameters: Sequence[sp.Symbol],
                    model_name: str = "model", *, outputs=(), tables=(), origin: str = "") -> str:
    """The whole C file of a model with loops, from `ccode.CEmitter`'s parts: its header with MBS_NWORK
    enlarged by MBS_LOOP_NWORK, the tree functions except the articulated-body mbs_rhs (which would solve the
    open tree), the constraint functions, and mbs_rhs as the constrained right-hand side.

    `equations` may lack vdot (derive with forward_dynamics=False: the articulated-body algorithm divides by
    zero for massless bodies, which loops allow). Everything on the tape must be derived before this call."""
    from .ccode import CEmitter, CPrinter
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
    total = int(tree_work.group(1)) + loop_work_size(tree.nq, tree.nv, constraints.nc)
    header = header.replace(tree_work.group(0), f"#define MBS_TREE_NWORK {tree_work.group(1)}   /* of the tree "
                                                f"functions */\n#define MBS_NWORK {total}")
    names = [name_table("mbs_state_name", "state i", [s.name for s in tree.q_symbols + tree.v_symbols]),
             name_table("mbs_parameter_name", "parameter i", [s.name for s in emitter.parameters])]
    if emitter.outputs:
        names.append(name_table("mbs_output_name", "output i", [name for name, _ in emitter.outputs]))
    return "\n".join([header, loop_definitions(constraints), *emitter._helpers(printer.used), *functions, *names,
                      loop_functions(constraints)])
