"""C code of the loop-closure constraints: the generated part of a model with closed kinematic loops.

The model's constraint rows (`mbs.compiler.constraints`) become four functions of the one fixed signature,
printed by the same planner and printer as the equations of motion (`ccode.CEmitter`):

    int mbs_constraints(double t, const double *x, const double *p, double *out, double *work);           g, nc
    int mbs_constraint_velocity(double t, const double *x, const double *p, double *out, double *work);   G v + g_t
    int mbs_constraints_with_velocity(double t, const double *x, const double *p, double *out, double *work);
                                                                                       [g; G v + g_t], 2 nc
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
the rest of the text; `ccode.generate_loop_c` assembles a whole file from them and `ccode.CEmitter`'s parts
(this module imports nothing of ccode: the emitter uses it, not the other way round).
"""

from __future__ import annotations

import copy
import dataclasses

from .c_text import name_table
from .constraints import Constraints
from .differentiate import NotDifferentiable, forward_derivatives
from .equations import Equations
from .jacobian_colours import constraint_colours

#: The generated constraint Jacobian's function (`constraint_matrix_routine`).
CONSTRAINT_MATRIX = "mbs_constraint_matrix"
#: The residuals and their rate in one function (`loop_routines`): the projection of an accepted step and of a row
#: of the results evaluate both at the same positions, sharing the kinematics (runtime/c/loops.c).
CONSTRAINTS_WITH_VELOCITY = "mbs_constraints_with_velocity"

#: Doubles of scalar scratch in the loop solver's work area (runtime/c/loops.c, MBS_LOOP_NWORK_NEEDED).
LOOP_SCALARS = 16


def loop_work_size(nq: int, nv: int, nc: int, nz: int = 0, np: int = 0) -> int:
    """Doubles of work memory the loop solver needs beyond the tree functions' (the formula of
    MBS_LOOP_NWORK_NEEDED in runtime/c/loops.c, which checks it at compile time); nz extra states ride along
    in its two state copies, np parameters in its stamp."""
    nx = nq + nv + nz
    stamp = nq + np + 4  # the state and parameters whose factors the solver keeps for an accepted step's projection
    plan = 1 + (4 + nv + nc) + 3 + 6 * nc + 2 * nv + nc * nv  # the blocks of the kept partition (MBS_LOOP_PLAN_SIZE)
    return 4 * nv * nv + 3 * nc * nv + 7 * nc + 2 * nx + 10 * nv + nq + 4 + LOOP_SCALARS + stamp + plan


def loop_routines(constraints: Constraints) -> list:
    """(name, out, doc, shape, results, check_positive) of the generated constraint functions, the format of
    `emit_common.equation_routines`. The output array is called `out` (a reserved name)."""
    nc = constraints.nc
    return [
        ("mbs_constraints", "out", "loop-closure residuals g(q, t), one per constraint row [m or -]", (nc,),
         list(enumerate(constraints.position)), False),
        ("mbs_constraint_velocity", "out", "gdot = G(q) v + g_t(q, t), affine in v [m/s or 1/s]", (nc,),
         list(enumerate(constraints.velocity)), False),
        (CONSTRAINTS_WITH_VELOCITY, "out", "[g; gdot]: mbs_constraints and mbs_constraint_velocity from one pass "
         "(the sines and cosines of the loops' angles once), 2 nc", (2 * nc,),
         list(enumerate(constraints.position)) + [(nc + i, e) for i, e in enumerate(constraints.velocity)], False),
        ("mbs_constraint_acceleration", "out", "gddot with vdot = 0: G vdot + this = 0 on the constraint "
         "manifold [m/s^2 or 1/s^2]", (nc,), list(enumerate(constraints.acceleration)), False),
    ]


def state_rates_routine(equations: Equations) -> tuple | None:
    """The routine `mbs_state_rates` writing z' of the extra states (tree.states), or None without states.
    With loops mbs_rhs is the loop solver's, which takes qdot and vdot from the loop solve and z' from this
    function at the same (projected) state: the rates are functions of (t, q, v, z), never of accelerations
    (the language refuses acceleration and reaction sensors in them), so no loop solve is needed for them."""
    if not equations.zdot:
        return None
    return ("mbs_state_rates", "out", "z' of the extra states, at the state the loop solver evaluates "
            "(runtime/c/loops.c)", (len(equations.zdot),), list(enumerate(equations.zdot)), False)


def constraint_matrix_routine(equations: Equations, constraints: Constraints) -> tuple[Equations, tuple | None]:
    """(equations on a tape that also holds G = d gdot / d v, the routine `mbs_constraint_matrix` writing G,
    nc rows of nv, row-major), or (equations, None) when a row has no printable derivative: the loop solver then
    takes G from evaluations of gdot (one per colour of compiler/jacobian_colours.py). gdot is affine in v, so
    its derivative is G itself, a function of q and t: one call instead of 1 + MBS_NCOLOUR (Iltis: 13) calls of
    mbs_constraint_velocity per evaluation of the right-hand side."""
    tree = constraints.tree
    if equations.tape is not constraints.tape:
        return equations, None
    try:
        fork, rows = forward_derivatives(equations.tape, constraints.velocity, tree.v_symbols,
                                         labels=[s.name for s in tree.v_symbols])
    except NotDifferentiable:
        return equations, None
    nv = tree.nv
    results = [(i * nv + k, d) for i, row in enumerate(rows) for k, d in enumerate(row)]
    kinematics = copy.copy(equations.kinematics)
    kinematics.tape = fork
    routine = (CONSTRAINT_MATRIX, "out", "G = d gdot / d v, the constraint Jacobian (nc rows, nv columns, "
               "row-major) by forward differentiation of the tape", (constraints.nc, nv), results, False)
    return dataclasses.replace(equations, kinematics=kinematics), routine


def mass_pattern(mass_matrix) -> str:
    """The structural nonzeros of the mass matrix as runs of columns by rows (MBS_MASS_PATTERN): the entries the
    generated functions print as anything but the literal 0, from its upper triangle (M is symmetric; row i holds
    column j when M[min(i,j)][max(i,j)] is not the constant 0).  The loop solver forms M T and M c0 from these
    entries only (runtime/c/loops.c): the Iltis's corners couple through the car body alone, so a corner velocity's
    row holds 7-10 nonzeros of 34, in two or three runs (the body's six columns, then the corner's own).  Written
    once by the generator, they hold at every state."""
    nv = len(mass_matrix)
    rows, begin, end = [0], [], []
    for i in range(nv):
        for j in range(nv):
            if mass_matrix[min(i, j)][max(i, j)] == 0:
                continue
            if len(begin) > rows[-1] and end[-1] == j:
                end[-1] = j + 1
            else:
                begin.append(j)
                end.append(j + 1)
        rows.append(len(begin))
    return "\n".join([
        "#define MBS_MASS_PATTERN 1   /* the structural nonzeros of M by rows (runtime/c/loops.c) */",
        "/* Row i of M is nonzero at most in the column runs k = mbs_mass_row[i] .. mbs_mass_row[i + 1] - 1, each the",
        " * columns mbs_mass_begin[k] .. mbs_mass_end[k] - 1. */",
        f"static const int mbs_mass_row[{nv + 1}] = {{{', '.join(map(str, rows))}}};",
        f"static const int mbs_mass_begin[{max(len(begin), 1)}] = {{{', '.join(map(str, begin)) or '0'}}};",
        f"static const int mbs_mass_end[{max(len(end), 1)}] = {{{', '.join(map(str, end)) or '0'}}};"])


def loop_definitions(constraints: Constraints, constraint_matrix: bool = False, extra_work: int = 0,
                     np: int = 0, mass_matrix=None) -> str:
    """Sizes, quaternion slots and the declaration of the loop solver's right-hand side (after the header);
    constraint_matrix: the file defines mbs_constraint_matrix (`constraint_matrix_routine`) and mbs_loop_terms
    (compiler/ccode_loop_terms.py); extra_work: doubles
    the loop solver's work holds beyond its own (bearing friction in the loops: MBS_FRICTION_NWORK, at its end); np:
    the model's parameters (MBS_NP); mass_matrix: the symbolic M (nv x nv, its upper triangle read), whose
    structural zeros the solver skips (`mass_pattern`; without it every entry counts)."""
    tree = constraints.tree
    slots = constraints.quaternion_slots
    work = loop_work_size(tree.nq, tree.nv, constraints.nc, tree.nz, np) + extra_work
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
        f"#define MBS_CONSTRAINTS_WITH_VELOCITY 1   /* {CONSTRAINTS_WITH_VELOCITY} gives [g; gdot] */",
        f"int {CONSTRAINTS_WITH_VELOCITY}(double t, const double *x, const double *p, double *out, double *work);",
        "/* Colour of each velocity column, -1 when no row depends on it. */",
        f"static const int mbs_column_colour[{tree.nv}] = {{{', '.join(map(str, colours.colour))}}};",
        "/* Row i, colour c: the column of that colour row i depends on, -1 when none. */",
        f"static const int mbs_colour_column[{len(table)}] = {{{', '.join(map(str, table))}}};",
        *(["/* z' of the extra states: the loop solver's right-hand sides append it (runtime/c/loops.c) */",
           "int mbs_state_rates(double t, const double *x, const double *p, double *out, double *work);"]
          if tree.nz else []),
        *(["#define MBS_CONSTRAINT_MATRIX 1   /* mbs_constraint_matrix gives G (the colours are not used) */",
           "int mbs_constraint_matrix(double t, const double *x, const double *p, double *out, double *work);",
           "#define MBS_LOOP_TERMS 1   /* mbs_loop_terms gives [M; f; G; gddot0] (compiler/ccode_loop_terms.py) */",
           "int mbs_loop_terms(double t, const double *x, const double *p, double *out, double *work);"]
          if constraint_matrix else []),
        *([mass_pattern(mass_matrix)] if mass_matrix is not None else []),
        "",
        "/* The constrained right-hand side and the multipliers, defined by the run-time loop solver compiled",
        " * after this file. */",
        "int mbs_loop_rhs(double t, const double *x, const double *p, double *xdot, double *work);",
        "int mbs_loop_rhs_direct(double t, const double *x, const double *p, double *xdot, double *work);",
        "int mbs_loop_multipliers(double t, const double *x, const double *p, double *lambda, double *work);",
        "int mbs_loop_rates(double t, const double *x, const double *p, double *out, double *work);",
        ""])


def loop_functions(constraints: Constraints) -> str:
    """The name table of the rows and `mbs_rhs`, the constrained right-hand side."""
    return "\n".join([
        name_table("mbs_constraint_name", "constraint row i (\"<cut joint>.<label>\")", constraints.names),
        "/* x' = [qdot; vdot] of the closed mechanism: the state projected onto the constraints, vdot by the",
        " * null-space method (runtime/c/loops.c). */",
        "int mbs_rhs(double t, const double *x, const double *p, double *xdot, double *work)", "{",
        "    return mbs_loop_rhs(t, x, p, xdot, work);", "}", ""])


def unchecked_mass_matrix(body: str, name: str, out: str) -> str:
    """The text of the mass matrix function `body` (called `<name>_unchecked`, no check that M is positive
    definite) followed by `name`, the contract's function with that check. The loop solver calls the unchecked
    one at every evaluation: it needs T^T M T definite, not M (massless parts are allowed), and the Cholesky
    check of the full nv x nv matrix cost more than the matrix itself (Iltis: 3.1 of 5.4 us). Nor does the
    unchecked one test every entry for NaN: the loop solver's results are checked, and a NaN in M reaches them."""
    finite = f"    if (!mbs_all_finite({out}, MBS_NV*MBS_NV))\n        return 2;\n"
    if finite not in body:
        raise ValueError("the mass matrix function has no finiteness check to leave out")
    return "\n".join([
        body.replace(finite, "").rstrip("\n"), "",
        "#define MBS_MASS_MATRIX_UNCHECKED 1   /* runtime/c/loops.c calls it */", "",
        f"/* {out} as {name}_unchecked, status 1 unless it is positive definite (the contract's mass matrix). */",
        f"int {name}(double t, const double *x, const double *p, double *{out}, double *work)", "{",
        f"    const int status = {name}_unchecked(t, x, p, {out}, work);",
        f"    return status != 0 ? status : mbs_positive_definite({out}, MBS_NV, work) ? 0 : 1;", "}", ""])


def unchecked_constraint_matrix(body: str, out: str) -> str:
    """The text of the constraint Jacobian's function `body` without its test of every entry for NaN: the loop
    solver tests G's entries as it scans them for their largest (mbs_loop_gmax, status 2 when one is not finite),
    and the exported mbs_loop_jacobian tests its copy; the test of all nc x nv entries, most of them exact zeros
    (independent loops), cost a third of the function (Iltis: 816 entries, about 100 nonzero)."""
    start = body.find(f"    if (!mbs_all_finite({out}, ")
    end = body.find("        return 2;\n", start)
    if start < 0 or end < 0:
        raise ValueError("the constraint matrix function has no finiteness check to leave out")
    return body[:start] + body[end + len("        return 2;\n"):]
