"""The loop solver's terms at one state in one generated function: M, f, G and gddot0 from one pass over the
tree's kinematics.

With closed loops every right-hand side needs, at one state, the mass matrix M, the generalized forces f, the
constraint Jacobian G and the constraint acceleration with vdot = 0 (runtime/c/loops.c).  Written as four functions,
each computes the kinematics of the tree again (the rotations, positions and velocities of the bodies): the Iltis's
four print 3301 temporaries with 156 sines and cosines, the one function of this module 2656 with 49.

    int mbs_loop_terms(double t, const double *x, const double *p, double *out, double *work);
        out = [M (nv x nv, row-major); f (nv); G (nc x nv, row-major); gddot0 (nc)]

f and gddot0 are tested for finite values (as mbs_forces and mbs_constraint_acceleration test theirs), M and G are
not (as mbs_mass_matrix_unchecked and mbs_constraint_matrix, compiler/ccode_loops.py: the loop solver tests its
results and G's entries).  The function exists when G is printed from the tape
(ccode_loops.constraint_matrix_routine), whose fork it uses.

The contract's mbs_mass_matrix and mbs_forces, and mbs_constraint_acceleration, are then read off this function
(loop_terms_readers) instead of being printed again: no right-hand side calls them (the loop Jacobian of the
implicit integrators, the equilibrium, linearisation and the user do), and printed on their own they were a
quarter of the Iltis's C (350 kB of 1.3 MB) and of its compile.  Each evaluates the terms into the tree functions'
work (MBS_TREE_NWORK, at least MBS_LOOP_TERMS_SIZE doubles then) and copies its part.  A status of the terms
is theirs: the mass matrix of a state whose forces are not finite says 2, not only the forces.
"""

from __future__ import annotations

#: The generated function's name; runtime/c/loops.c calls it when the file defines MBS_LOOP_TERMS.
LOOP_TERMS = "mbs_loop_terms"
#: The functions read off it (loop_terms_readers) instead of printed on their own.
LOOP_TERMS_READ = ("mbs_mass_matrix", "mbs_forces", "mbs_constraint_acceleration")


def loop_terms_routine(equations, constraints, constraint_matrix) -> tuple | None:
    """(name, out, doc, shape, results, check_positive) of mbs_loop_terms in the emitter's routine format, or None
    without the generated G (`constraint_matrix` None): equations on the tape that holds G."""
    if constraint_matrix is None:
        return None
    nv, nc = equations.tree.nv, constraints.nc
    mass = [(i * nv + j, equations.mass_matrix[i][j] if j >= i else j * nv + i)
            for i in range(nv) for j in range(nv)]
    forces = [(nv * nv + k, e) for k, e in enumerate(equations.forces)]
    at_g = nv * nv + nv
    jacobian = [(at_g + k, at_g + e if isinstance(e, int) else e) for k, e in constraint_matrix[4]]
    at_h = at_g + nc * nv
    acceleration = [(at_h + k, e) for k, e in enumerate(constraints.acceleration)]
    doc = ("out = [M (nv x nv); f (nv); G (nc x nv); gddot0 (nc)]: the loop solver's terms at one state from one "
           "pass over the kinematics (compiler/ccode_loop_terms.py)")
    return LOOP_TERMS, "out", doc, (at_h + nc,), mass + forces + jacobian + acceleration, False


def loop_terms_checks(body: str) -> str:
    """The text of mbs_loop_terms with its test for finite values narrowed to f and gddot0."""
    start = body.find("    if (!mbs_all_finite(out, ")
    end = body.find("        return 2;\n", start)
    if start < 0 or end < 0:
        raise ValueError("the loop terms' function has no finiteness check to narrow")
    narrowed = ("    if (!mbs_all_finite(out + MBS_NV*MBS_NV, MBS_NV)\n"
                "        || !mbs_all_finite(out + MBS_NV*MBS_NV + MBS_NV + MBS_NC*MBS_NV, MBS_NC))\n")
    return body[:start] + narrowed + body[body.find("\n", start) + 1:]


def loop_terms_size(nv: int, nc: int) -> int:
    """Doubles mbs_loop_terms writes: M, f, G, gddot0."""
    return nv * nv + nv + nc * nv + nc


def loop_terms_readers() -> str:
    """mbs_mass_matrix, mbs_forces and mbs_constraint_acceleration as parts of mbs_loop_terms' results."""
    call = ("    const int status = mbs_loop_terms(t, x, p, work, NULL);   /* (the terms use no work of their own) */\n"
            "    if (status != 0)\n        return status;")
    return "\n".join([
        "/* M (nv x nv, row-major) from the loop terms (compiler/ccode_loop_terms.py), evaluated into work: status 1",
        " * unless M is positive definite, 2 if a term is not finite. */",
        "int mbs_mass_matrix(double t, const double *x, const double *p, double *M, double *work)", "{", call,
        "    memcpy(M, work, MBS_NV*MBS_NV * sizeof(double));",
        "    if (!mbs_all_finite(M, MBS_NV*MBS_NV))", "        return 2;",
        "    return mbs_positive_definite(M, MBS_NV, work) ? 0 : 1;", "}", "",
        "/* f = q - k (nv) from the loop terms, evaluated into work. */",
        "int mbs_forces(double t, const double *x, const double *p, double *f, double *work)", "{", call,
        "    memcpy(f, work + MBS_NV*MBS_NV, MBS_NV * sizeof(double));", "    return 0;", "}", "",
        "/* gddot with vdot = 0 (nc) from the loop terms, evaluated into work. */",
        "int mbs_constraint_acceleration(double t, const double *x, const double *p, double *out, double *work)",
        "{", call,
        "    memcpy(out, work + MBS_NV*MBS_NV + MBS_NV + MBS_NC*MBS_NV, MBS_NC * sizeof(double));",
        "    return 0;", "}", ""])
