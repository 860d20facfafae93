"""Rotations, axes and mirror images as model expressions (constant-folded where the numbers are known).

Frames may be rotated by an axis and angle, by three angles in a stated sequence, or by a direction-cosine
matrix; joint axes are unit vectors; a mirrored component instance reflects its geometry in a coordinate
plane. All of this is built from expr.py nodes so that geometry given by parameters stays symbolic.
"""

from __future__ import annotations

import math

from . import expr as X
from .expr import E

Vec3 = tuple[E, E, E]
Mat3 = tuple[Vec3, Vec3, Vec3]

IDENTITY: Mat3 = ((X.ONE, X.ZERO, X.ZERO), (X.ZERO, X.ONE, X.ZERO), (X.ZERO, X.ZERO, X.ONE))
ZERO_VEC: Vec3 = (X.ZERO, X.ZERO, X.ZERO)
UNIT_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
MIRROR_PLANES = {"xz": (1, -1, 1), "xy": (1, 1, -1), "yz": (-1, 1, 1)}


def const_vec(values) -> Vec3:
    return tuple(X.const(v) for v in values)  # type: ignore[return-value]


def _f(fn: str, a: E) -> E:
    if isinstance(a, X.Const):
        return X.const(getattr(math, fn)(a.value))
    return X.Op(fn, (a,))


def sub(a: E, b: E) -> E:
    return X.add(a, X.neg(b))


def matmul(a: Mat3, b: Mat3) -> Mat3:
    return tuple(tuple(_dot3(a[i], tuple(b[k][j] for k in range(3))) for j in range(3))  # type: ignore
                 for i in range(3))


def matvec(a: Mat3, v: Vec3) -> Vec3:
    return tuple(_dot3(a[i], v) for i in range(3))  # type: ignore[return-value]


def transpose(a: Mat3) -> Mat3:
    return tuple(tuple(a[j][i] for j in range(3)) for i in range(3))  # type: ignore[return-value]


def vadd(a: Vec3, b: Vec3) -> Vec3:
    return tuple(X.add(x, y) for x, y in zip(a, b))  # type: ignore[return-value]


def _dot3(a, b) -> E:
    out: E = X.ZERO
    for x, y in zip(a, b):
        out = X.add(out, X.mul(x, y))
    return out


def axis_rotation(axis: Vec3, angle: E) -> Mat3:
    """Rodrigues: R = cos I + sin [a]x + (1 - cos) a a^T, for a unit axis a."""
    c, s = _f("cos", angle), _f("sin", angle)
    one_c = sub(X.ONE, c)
    ax, ay, az = axis
    cross = ((X.ZERO, X.neg(az), ay), (az, X.ZERO, X.neg(ax)), (X.neg(ay), ax, X.ZERO))
    rows = []
    for i in range(3):
        row = []
        for j in range(3):
            term = X.mul(one_c, X.mul(axis[i], axis[j]))
            term = X.add(term, X.mul(s, cross[i][j]))
            if i == j:
                term = X.add(term, c)
            row.append(term)
        rows.append(tuple(row))
    return tuple(rows)  # type: ignore[return-value]


def sequence_rotation(sequence: str, angles: tuple[E, E, E]) -> Mat3:
    """Successive rotations about body-fixed axes, e.g. 'xyz' (Cardan) or 'zxz' (Euler): R = R1 R2 R3."""
    result = IDENTITY
    for letter, angle in zip(sequence, angles):
        result = matmul(result, axis_rotation(const_vec(UNIT_AXES[letter]), angle))
    return result


def normalise_constant(values: tuple[float, float, float]) -> tuple[float, float, float] | None:
    norm = math.sqrt(sum(v * v for v in values))
    if norm == 0.0 or not math.isfinite(norm):
        return None
    return tuple(v / norm for v in values)  # type: ignore[return-value]


def normalise(v: Vec3) -> Vec3:
    """Symbolic normalisation for axes given by parameters."""
    norm = _f("sqrt", _dot3(v, v))
    return tuple(X.Op("/", (c, norm)) if c != X.ZERO else c for c in v)  # type: ignore[return-value]


# ------------------------------------------------------------------------------------------ mirroring
def mirror_vec(signs: tuple[int, int, int], v: Vec3) -> Vec3:
    """Polar vectors (positions, forces, translation axes): v -> S v."""
    return tuple(c if s > 0 else X.neg(c) for s, c in zip(signs, v))  # type: ignore[return-value]


def mirror_axial(signs: tuple[int, int, int], v: Vec3) -> Vec3:
    """Axial vectors (rotation axes, torques): v -> det(S) S v, so mirrored motion keeps the same sign of
    the joint angle on both sides of a vehicle."""
    det = signs[0] * signs[1] * signs[2]
    return mirror_vec(tuple(det * s for s in signs), v)  # type: ignore[arg-type]


def mirror_mat(signs: tuple[int, int, int], m: Mat3) -> Mat3:
    """Rotation matrices and inertia tensors: M -> S M S (a proper rotation stays proper)."""
    return tuple(tuple(m[i][j] if signs[i] * signs[j] > 0 else X.neg(m[i][j]) for j in range(3))  # type: ignore
                 for i in range(3))


def compose_signs(a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[int, int, int]:
    return (a[0] * b[0], a[1] * b[1], a[2] * b[2])
