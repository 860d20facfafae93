"""3-vector, 3x3 and spatial (6-vector) algebra executed on a `Tape`.

Vectors are tuples of sympy expressions, matrices tuples of rows. Spatial vectors follow Featherstone's order:
motion (omega; v) and force (n; f), each in some body's frame at that frame's origin.

A placement `X = (R, r)` of a child frame in a parent frame (R rotates child components into parent components, r
is the child origin in parent components) acts on motion from parent to child and on force from child to parent:
    motion: omega_c = R^T omega_p,  v_c = R^T (v_p + omega_p x r)
    force:  f_p = R f_c,            n_p = R n_c + r x f_p

Every function takes the tape and a name for the temporaries it creates; products with literal 0 and 1 are
skipped here already (cheaper than letting sympy fold them).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from . import fast_arith
from .tape import ONE, ZERO, Tape

IDENTITY = ((ONE, ZERO, ZERO), (ZERO, ONE, ZERO), (ZERO, ZERO, ONE))
ZERO3 = (ZERO, ZERO, ZERO)
ZERO6 = ZERO3 + ZERO3


# ---- expression level (no temporaries) -------------------------------------------------------------------------

def mul(a, b):
    if a is ZERO or b is ZERO:
        return ZERO
    if a is ONE:
        return b
    if b is ONE:
        return a
    return fast_arith.product(a, b)


def add(*terms):
    terms = [x for x in terms if x is not ZERO]
    if not terms:
        return ZERO
    return terms[0] if len(terms) == 1 else fast_arith.total(terms)


def dot(a, b):
    return add(*(mul(x, y) for x, y in zip(a, b)))


def cross(a, b):
    return (add(mul(a[1], b[2]), fast_arith.negative(mul(a[2], b[1]))),
            add(mul(a[2], b[0]), fast_arith.negative(mul(a[0], b[2]))),
            add(mul(a[0], b[1]), fast_arith.negative(mul(a[1], b[0]))))


def transpose(M):
    return tuple(zip(*M))


def column(M, j):
    return tuple(row[j] for row in M)


def is_identity(M) -> bool:
    return all(M[i][j] is (ONE if i == j else ZERO) for i in range(3) for j in range(3))


def is_zero(v) -> bool:
    return all(x is ZERO for x in v)


# ---- taped 3-vector and 3x3 operations -------------------------------------------------------------------------

def vadd(tape: Tape, a, b, name: str) -> tuple:
    return tape.vector([add(x, y) for x, y in zip(a, b)], name)


def vsub(tape: Tape, a, b, name: str) -> tuple:
    return tape.vector([add(x, -y) for x, y in zip(a, b)], name)


def vscale(tape: Tape, s, a, name: str) -> tuple:
    return tape.vector([mul(s, x) for x in a], name)


def vcross(tape: Tape, a, b, name: str) -> tuple:
    return tape.vector(cross(a, b), name)


def matvec(tape: Tape, M, x, name: str) -> tuple:
    return tape.vector([dot(row, x) for row in M], name)


def matTvec(tape: Tape, M, x, name: str) -> tuple:
    """M^T x."""
    return tape.vector([dot(column(M, j), x) for j in range(3)], name)


def matmul(tape: Tape, A, B, name: str) -> tuple:
    Bt = transpose(B)
    return tuple(tuple(tape.temp(dot(A[i], Bt[j]), f"{name}_{i}{j}") for j in range(3)) for i in range(3))


def congruence(tape: Tape, R, A, name: str, symmetric: bool) -> tuple:
    """R A R^T; for symmetric A only the upper triangle is computed."""
    if is_identity(R):
        return A
    RA = matmul(tape, R, A, name + "r")
    out = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i if symmetric else 0, 3):
            out[i][j] = tape.temp(dot(RA[i], R[j]), f"{name}_{i}{j}")
            if symmetric:
                out[j][i] = out[i][j]
    return tuple(tuple(row) for row in out)


# ---- spatial vectors --------------------------------------------------------------------------------------------

def motion_to_child(tape: Tape, X, m, name: str) -> tuple:
    """Motion vector m in the parent frame -> child frame of placement X."""
    R, r = X
    w, v = m[:3], m[3:]
    v_at = v if is_zero(r) else vadd(tape, v, cross(w, r), name + "p")
    return matTvec(tape, R, w, name)[:3] + tape.vector([dot(column(R, j), v_at) for j in range(3)], name + "v")


def force_to_parent(tape: Tape, X, f, name: str) -> tuple:
    """Force vector f in the child frame -> parent frame of placement X."""
    R, r = X
    n, fl = f[:3], f[3:]
    f_p = matvec(tape, R, fl, name + "f")
    n_p = tape.vector([add(dot(R[i], n), c) for i, c in enumerate(cross(r, f_p))], name + "n")
    return n_p + f_p


def motion_from_frame(tape: Tape, X, m, name: str) -> tuple:
    """Motion vector m given in a frame placed by X in a body -> the body frame (at its origin):
    omega_b = R omega, v_b = R v + r x omega_b."""
    R, r = X
    w = matvec(tape, R, m[:3], name + "w")
    Rv = [dot(row, m[3:]) for row in R]
    return w + tape.vector([add(x, y) for x, y in zip(Rv, cross(r, w))], name + "v")


def motion_cross(tape: Tape, a, b, name: str) -> tuple:
    """a x b for motion vectors (Featherstone's crm)."""
    w, v = a[:3], a[3:]
    bw, bv = b[:3], b[3:]
    return tape.vector(cross(w, bw) + tuple(add(x, y) for x, y in zip(cross(w, bv), cross(v, bw))), name)


def force_cross(tape: Tape, a, f, name: str) -> tuple:
    """a x* f for a motion vector a and a force vector f (Featherstone's crf)."""
    w, v = a[:3], a[3:]
    n, fl = f[:3], f[3:]
    return tape.vector(tuple(add(x, y) for x, y in zip(cross(w, n), cross(v, fl))) + cross(w, fl), name)


def sadd(tape: Tape, a, b, name: str) -> tuple:
    return tape.vector([add(x, y) for x, y in zip(a, b)], name)


# ---- spatial inertias -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RigidInertia:
    """Spatial inertia of a rigid body (or a rigid composite) about a frame's origin:
    mass m [kg], first moment h = m*c [kg*m] and rotational inertia Ibar [kg*m^2] about the origin (symmetric
    3x3), all in that frame's components. As a 6x6 matrix [[Ibar, hx], [hx^T, m*1]]."""

    m: sp.Expr
    h: tuple
    Ibar: tuple

    @staticmethod
    def of_body(tape: Tape, m, com, Ic, name: str) -> "RigidInertia":
        """From mass, centre of mass and inertia about the centre of mass: Ibar = Ic + m (|c|^2 1 - c c^T)."""
        # Combined as plain expressions before taping, so that e.g. m l^2 - m l l folds to 0.
        m = tape.temp(m, name + "m")
        h_expr = [mul(m, c) for c in com]
        cc = dot(com, com)
        Ibar = [[None] * 3 for _ in range(3)]
        for i in range(3):
            for j in range(i, 3):
                shift = add(mul(m, cc) if i == j else ZERO, -mul(h_expr[i], com[j]))
                Ibar[i][j] = Ibar[j][i] = tape.temp(add(Ic[i][j], shift), f"{name}_{i}{j}")
        return RigidInertia(m, tape.vector(h_expr, name + "h"), tuple(tuple(row) for row in Ibar))

    def apply(self, tape: Tape, a, name: str) -> tuple:
        """I a for a motion vector a: (Ibar w + h x v; m v - h x w)."""
        w, v = a[:3], a[3:]
        hv, hw = cross(self.h, v), cross(self.h, w)
        n = [add(dot(row, w), c) for row, c in zip(self.Ibar, hv)]
        f = [add(mul(self.m, x), -c) for x, c in zip(v, hw)]
        return tape.vector(n + f, name)

    def to_parent(self, tape: Tape, X, name: str) -> "RigidInertia":
        """X^T I X: the same inertia about the parent frame's origin, in parent components."""
        R, r = X
        h = matvec(tape, R, self.h, name + "hr")
        Ibar = congruence(tape, R, self.Ibar, name + "R", symmetric=True)
        if is_zero(r):
            return RigidInertia(self.m, h, Ibar)
        # Ibar' = Ibar - (h r^T + r h^T) - m r r^T + (2 r.h + m |r|^2) 1, with h the rotated first moment. With the
        # new first moment h' = h + m r that is Ibar - h r^T - r h'^T off the diagonal and, on it,
        # Ibar_ii + sum over k != i of r_k (h_k + h'_k): 12 multiplications instead of about 40, and no terms
        # that cancel on the diagonal (2 h_i r_i + m r_i^2, added in 2 r.h + m |r|^2 and taken off again).
        h_p = tape.vector([add(x, mul(self.m, y)) for x, y in zip(h, r)], name + "h")
        both = [tape.temp(mul(y, add(x, z)), f"{name}s_{k}") for k, (x, y, z) in enumerate(zip(h, r, h_p))]
        out = [[None] * 3 for _ in range(3)]
        for i in range(3):
            for j in range(i, 3):
                if i == j:
                    e = add(Ibar[i][i], *(both[k] for k in range(3) if k != i))
                else:
                    e = add(Ibar[i][j], -mul(h[i], r[j]), -mul(r[i], h_p[j]))
                out[i][j] = out[j][i] = tape.temp(e, f"{name}_{i}{j}")
        return RigidInertia(self.m, h_p, tuple(tuple(row) for row in out))

    def plus(self, tape: Tape, other: "RigidInertia", name: str) -> "RigidInertia":
        Ibar = tuple(tuple(tape.temp(add(a, b), f"{name}_{i}{j}") for j, (a, b) in enumerate(zip(ra, rb)))
                     for i, (ra, rb) in enumerate(zip(self.Ibar, other.Ibar)))
        return RigidInertia(tape.temp(add(self.m, other.m), name + "m"), vadd(tape, self.h, other.h, name + "h"),
                            Ibar)

    def general(self) -> "ArticulatedInertia":
        hx = ((ZERO, -self.h[2], self.h[1]), (self.h[2], ZERO, -self.h[0]), (-self.h[1], self.h[0], ZERO))
        mI = tuple(tuple(self.m if i == j else ZERO for j in range(3)) for i in range(3))
        return ArticulatedInertia(self.Ibar, hx, mI)


@dataclass(frozen=True)
class ArticulatedInertia:
    """A general symmetric spatial inertia [[A, B], [B^T, C]] (A, C symmetric 3x3), as produced by the
    articulated-body algorithm."""

    A: tuple
    B: tuple
    C: tuple

    def apply(self, tape: Tape, a, name: str) -> tuple:
        w, v = a[:3], a[3:]
        n = [add(dot(ra, w), dot(rb, v)) for ra, rb in zip(self.A, self.B)]
        f = [add(dot(column(self.B, i), w), dot(self.C[i], v)) for i in range(3)]
        return tape.vector(n + f, name)

    def minus_outer(self, tape: Tape, U, W, name: str, null=()) -> "ArticulatedInertia":
        """I - U W^T for 6-vectors U, W with U W^T symmetric (W = U/d). Rows and columns whose 6-index is in
        `null` are known to vanish in the result (the caller proves it) and are set to exact zeros."""
        def block(M, a, b, tag, symmetric, di, dj):
            out = [[None] * 3 for _ in range(3)]
            for i in range(3):
                for j in range(i if symmetric else 0, 3):
                    if i + di in null or j + dj in null:
                        out[i][j] = ZERO
                    else:
                        out[i][j] = tape.temp(add(M[i][j], -mul(a[i], b[j])), f"{name}{tag}_{i}{j}")
                    if symmetric:
                        out[j][i] = out[i][j]
            return tuple(tuple(row) for row in out)
        return ArticulatedInertia(block(self.A, U[:3], W[:3], "a", True, 0, 0),
                                  block(self.B, U[:3], W[3:], "b", False, 0, 3),
                                  block(self.C, U[3:], W[3:], "c", True, 3, 3))

    def to_parent(self, tape: Tape, X, name: str) -> "ArticulatedInertia":
        """X^T I X: A' = A + rx B^T - B rx - rx C rx, B' = B + rx C, C' = C (after rotating each block)."""
        R, r = X
        A = congruence(tape, R, self.A, name + "a", symmetric=True)
        B = congruence(tape, R, self.B, name + "b", symmetric=False)
        C = congruence(tape, R, self.C, name + "c", symmetric=True)
        if is_zero(r):
            return ArticulatedInertia(A, B, C)
        rx = ((ZERO, -r[2], r[1]), (r[2], ZERO, -r[0]), (-r[1], r[0], ZERO))
        rxC = [[dot(rx[i], column(C, j)) for j in range(3)] for i in range(3)]
        B2 = tuple(tuple(tape.temp(add(B[i][j], rxC[i][j]), f"{name}B_{i}{j}") for j in range(3))
                   for i in range(3))
        # With B' = B + rx C:  A' = A + rx B^T - B rx - rx C rx = A + rx B'^T - B rx  (as (rx C)^T = -C rx).
        out = [[None] * 3 for _ in range(3)]
        for i in range(3):
            for j in range(i, 3):
                e = add(A[i][j], dot(rx[i], B2[j]), -dot(B[i], column(rx, j)))
                out[i][j] = out[j][i] = tape.temp(e, f"{name}A_{i}{j}")
        return ArticulatedInertia(tuple(tuple(row) for row in out), B2, C)

    def plus(self, tape: Tape, other: "ArticulatedInertia", name: str) -> "ArticulatedInertia":
        def block(P, Q, tag):
            return tuple(tuple(tape.temp(add(P[i][j], Q[i][j]), f"{name}{tag}_{i}{j}") for j in range(3))
                         for i in range(3))
        return ArticulatedInertia(block(self.A, other.A, "a"), block(self.B, other.B, "b"),
                                  block(self.C, other.C, "c"))
