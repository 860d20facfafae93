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
results and G's entries).  The four functions stay: the contract's, and callers that need one of them.  The
function exists when G is printed from the tape (ccode_loops.constraint_matrix_routine), whose fork it uses.
"""

from __future__ import annotations

#: The generated function's name; runtime/c/loops.c calls it when the file defines MBS_LOOP_TERMS.
LOOP_TERMS = "mbs_loop_terms"


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
