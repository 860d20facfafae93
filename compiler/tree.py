"""Tree-structured rigid multibody systems in minimal relative joint coordinates.

This is the intermediate form between the lowering layer (which turns a validated model into bodies, joints and
coordinates) and the symbolic equations of motion (`mbs.compiler.kinematics`, `.dynamics`, `.equations`).
It is pure data: frozen dataclasses holding sympy expressions, validated on construction.

Conventions (units SI throughout: m, kg, kg*m^2, rad, s):

* The bodies are listed in topological order; `parent` is an index into that list, -1 is the inertial (ground)
  body, whose reference frame is the world frame.
* Every joint connects a frame a, fixed in the parent body, to a frame b, fixed in the child body. With all joint
  coordinates zero the two frames coincide.
* A pose `(R, r)` places a frame in a body's reference frame: `R` (3x3) rotates the frame's components into the
  body's components, `r` (3) is the frame's origin in body components.
* Coordinates that are prescribed functions of time (rheonomic constraints: wheel spin, steering input) are not
  states; their velocities and accelerations are exact symbolic time derivatives.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property

import sympy as sp

#: The time symbol [s]. Prescribed coordinates are expressions of exactly this symbol (no assumptions, so that a
#: `sympy.Symbol("t")` made elsewhere is the same symbol).
t = sp.Symbol("t")

#: Number of axis vectors each joint kind takes (in the joint's frame a).
AXES_PER_KIND = {
    "fixed": 0, "revolute": 1, "prismatic": 1, "cylindrical": 1, "universal": 2,
    "spherical": 0, "planar": 2, "free": 0,
}

#: Coordinate names of the kinds whose rotation parametrisation does not matter.
_COORDINATES = {
    "fixed": (), "revolute": ("phi",), "prismatic": ("s",), "cylindrical": ("s", "phi"),
    "universal": ("phi1", "phi2"), "planar": ("x", "y", "phi"),
}
_ROTATION_COORDINATES = {"quaternion": ("qw", "qx", "qy", "qz"), "cardan": ("alpha", "beta", "gamma")}
_QUATERNION_VELOCITIES = ("wx", "wy", "wz")

#: Tolerance for the unit length of numeric axis vectors (they are typed-in decimals, not results of arithmetic).
AXIS_UNIT_TOLERANCE = 1e-9


class TreeError(ValueError):
    """A tree description that cannot be turned into equations of motion (a bug in the layer that built it)."""


@dataclass(frozen=True)
class JointSpec:
    """The kind of a joint and its constant geometry.

    kind: one of `AXES_PER_KIND`.
    axes: tuple of 3-tuples of sympy expressions, unit vectors in the joint's frame a:
        revolute, prismatic, cylindrical: (axis,); universal: (axis1, axis2), rotation about axis1, then about
        axis2 in the once-rotated frame; planar: (normal, in-plane direction u), the coordinates (x, y) are along
        u and normal x u, phi about the normal; spherical, free, fixed: ().
    rotation: parametrisation of spherical and free rotations: "quaternion" (coordinates qw, qx, qy, qz and
        velocities wx, wy, wz = angular velocity of frame b relative to frame a in frame-b components, as in
        MuJoCo and Pinocchio) or "cardan" (angles alpha, beta, gamma of the sequence x-y-z about the successively
        rotated axes; velocities are their time derivatives).
    A free joint is the translation (x, y, z) of frame b's origin in frame-a components (velocities are their time
    derivatives, also in frame a), followed by the rotation.
    """

    kind: str
    axes: tuple = ()
    rotation: str = "quaternion"

    def __post_init__(self):
        if self.kind not in AXES_PER_KIND:
            raise TreeError(f"unknown joint kind {self.kind!r}; expected one of {', '.join(AXES_PER_KIND)}")
        if self.rotation not in _ROTATION_COORDINATES:
            raise TreeError(f"unknown rotation parametrisation {self.rotation!r}; expected quaternion or cardan")
        axes = tuple(_vector(a, f"axis of {self.kind} joint") for a in self.axes)
        if len(axes) != AXES_PER_KIND[self.kind]:
            raise TreeError(f"a {self.kind} joint takes {AXES_PER_KIND[self.kind]} axes, got {len(axes)}")
        for a in axes:
            _check_unit(a, self.kind)
        object.__setattr__(self, "axes", axes)

    @property
    def nq(self) -> int:
        """Number of position coordinates."""
        return len(coordinate_names(self))

    @property
    def nv(self) -> int:
        """Number of velocity coordinates."""
        return len(velocity_names(self))

    @property
    def uses_quaternion(self) -> bool:
        return self.kind in ("spherical", "free") and self.rotation == "quaternion"


def coordinate_names(joint: JointSpec) -> tuple[str, ...]:
    """Names of the joint's position coordinates (the language calls them `<interaction>.<name>`)."""
    if joint.kind == "spherical":
        return _ROTATION_COORDINATES[joint.rotation]
    if joint.kind == "free":
        return ("x", "y", "z") + _ROTATION_COORDINATES[joint.rotation]
    return _COORDINATES[joint.kind]


def velocity_names(joint: JointSpec) -> tuple[str, ...]:
    """Names of the joint's velocity coordinates: `der(name)` of each coordinate, except the angular velocity
    (wx, wy, wz) that replaces the derivative of a quaternion."""
    names = coordinate_names(joint)
    if joint.uses_quaternion:
        return tuple(f"der({n})" for n in names[:-4]) + _QUATERNION_VELOCITIES
    return tuple(f"der({n})" for n in names)


def velocity_of_coordinate(joint: JointSpec, k: int) -> int | None:
    """Index of the velocity that is the time derivative of coordinate k, or None for a quaternion component."""
    n_plain = joint.nq - 4 if joint.uses_quaternion else joint.nq
    return k if k < n_plain else None


@dataclass(frozen=True)
class TreeBody:
    """One rigid body and the joint connecting it to its parent.

    name: identifier, unique in the tree; it qualifies the coordinate symbols (`<name>.<coordinate>`).
    parent: index of the parent body in `Tree.bodies`, -1 for the ground; smaller than this body's own index.
    joint: the joint from the parent to this body.
    X_parent_joint: (R 3x3, r 3) pose of the joint's frame a in the parent body's frame [-, m].
    X_child_joint: (R 3x3, r 3) pose of the joint's frame b in this body's frame [-, m].
    mass: [kg], may be 0 (massless connector body).
    com: 3-vector, centre of mass in this body's frame [m].
    inertia: 3x3 symmetric, about the centre of mass in this body's frame components [kg*m^2].
    prescribed: one entry per coordinate: None (a free coordinate, part of the state) or a sympy expression of the
        time `t` and parameters [m or rad]. Quaternion coordinates cannot be prescribed. () means all free.
    """

    name: str
    parent: int
    joint: JointSpec
    X_parent_joint: tuple
    X_child_joint: tuple
    mass: sp.Expr
    com: sp.ImmutableMatrix
    inertia: sp.ImmutableMatrix
    prescribed: tuple = ()

    def __post_init__(self):
        where = f"body {self.name!r}"
        set_ = lambda field, value: object.__setattr__(self, field, value)  # noqa: E731 (frozen dataclass)
        set_("X_parent_joint", _pose(self.X_parent_joint, f"X_parent_joint of {where}"))
        set_("X_child_joint", _pose(self.X_child_joint, f"X_child_joint of {where}"))
        set_("mass", _number(sp.sympify(self.mass)))
        set_("com", sp.ImmutableMatrix(_vector(self.com, f"com of {where}")))
        inertia = _matrix(self.inertia, f"inertia of {where}")
        if any(sp.simplify(inertia[i, j] - inertia[j, i]) != 0 for i in range(3) for j in range(i)):
            raise TreeError(f"inertia of {where} is not symmetric")
        set_("inertia", inertia)
        prescribed = tuple(self.prescribed) or (None,) * self.joint.nq
        if len(prescribed) != self.joint.nq:
            raise TreeError(f"{where}: {len(prescribed)} prescribed entries for {self.joint.nq} coordinates")
        prescribed = tuple(None if e is None else _number(sp.sympify(e)) for e in prescribed)
        for k, e in enumerate(prescribed):
            if e is not None and velocity_of_coordinate(self.joint, k) is None:
                raise TreeError(f"{where}: quaternion coordinate {coordinate_names(self.joint)[k]} cannot be "
                                "prescribed; use the cardan rotation")
        set_("prescribed", prescribed)

    @property
    def free_coordinates(self) -> tuple[int, ...]:
        """Local indices of the coordinates that are states."""
        return tuple(k for k, e in enumerate(self.prescribed) if e is None)

    @property
    def free_velocities(self) -> tuple[int, ...]:
        """Local indices of the velocities that are states (quaternion velocities are always free)."""
        prescribed_v = {velocity_of_coordinate(self.joint, k) for k, e in enumerate(self.prescribed)
                        if e is not None}
        return tuple(k for k in range(self.joint.nv) if k not in prescribed_v)


@dataclass(frozen=True)
class Tree:
    """A tree of rigid bodies under gravity.

    bodies: in topological order (parent index below own index).
    gravity: 3-vector, acceleration of gravity in world components [m/s^2], e.g. (0, 0, -g).
    The state is x = [q; v]: the free coordinates (nq) then the free velocities (nv), each in body order and
    within a body in joint order.
    states: symbols of the model's extra differential states (language/states.py), appended: x = [q; v; z].
    """

    bodies: tuple
    gravity: sp.ImmutableMatrix
    states: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "bodies", tuple(self.bodies))
        object.__setattr__(self, "gravity", sp.ImmutableMatrix(_vector(self.gravity, "gravity")))
        names = set()
        for i, body in enumerate(self.bodies):
            if not isinstance(body, TreeBody):
                raise TreeError(f"bodies[{i}] is a {type(body).__name__}, not a TreeBody")
            if not -1 <= body.parent < i:
                raise TreeError(f"body {body.name!r} (index {i}) has parent {body.parent}; parents must come "
                                "first (topological order) and -1 is the ground")
            if body.name in names:
                raise TreeError(f"duplicate body name {body.name!r}")
            names.add(body.name)

    def body_index(self, body: int | str) -> int:
        """Index of a body given by index or name; -1 (or "ground") is the ground."""
        if isinstance(body, str):
            if body == "ground":
                return -1
            for i, b in enumerate(self.bodies):
                if b.name == body:
                    return i
            raise KeyError(f"no body named {body!r}")
        if not -1 <= body < len(self.bodies):
            raise IndexError(f"body index {body} out of range")
        return body

    @cached_property
    def q_symbols(self) -> tuple[sp.Symbol, ...]:
        """Symbols of the free coordinates in state order, named `<body>.<coordinate>` (length nq)."""
        return tuple(sp.Symbol(f"{b.name}.{coordinate_names(b.joint)[k]}")
                     for b in self.bodies for k in b.free_coordinates)

    @cached_property
    def v_symbols(self) -> tuple[sp.Symbol, ...]:
        """Symbols of the free velocities in state order, named `<body>.<velocity>` (length nv)."""
        return tuple(sp.Symbol(f"{b.name}.{velocity_names(b.joint)[k]}")
                     for b in self.bodies for k in b.free_velocities)

    @cached_property
    def q_slots(self) -> tuple[tuple[int | None, ...], ...]:
        """Per body, per coordinate: index into q, or None when prescribed."""
        return _slots(self.bodies, lambda b: b.joint.nq, lambda b: b.free_coordinates)

    @cached_property
    def v_slots(self) -> tuple[tuple[int | None, ...], ...]:
        """Per body, per velocity: index into v, or None when prescribed."""
        return _slots(self.bodies, lambda b: b.joint.nv, lambda b: b.free_velocities)

    @property
    def nq(self) -> int:
        return len(self.q_symbols)

    @property
    def nv(self) -> int:
        return len(self.v_symbols)

    @property
    def nz(self) -> int:
        return len(self.states)

    @property
    def nx(self) -> int:
        return self.nq + self.nv + self.nz

    @property
    def x_symbols(self) -> tuple[sp.Symbol, ...]:
        """The state in order: coordinates, velocities, extra states."""
        return self.q_symbols + self.v_symbols + tuple(self.states)

    @cached_property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """All symbols of the description other than `t` in `natural_key` order (masses, lengths, amplitudes)."""
        found = set(self.gravity.free_symbols)
        for b in self.bodies:
            found |= b.mass.free_symbols | b.com.free_symbols | b.inertia.free_symbols
            for R, r in (b.X_parent_joint, b.X_child_joint):
                found |= R.free_symbols | r.free_symbols
            for axis in b.joint.axes:
                found |= set().union(*(sp.sympify(c).free_symbols for c in axis))
            for e in b.prescribed:
                if e is not None:
                    found |= e.free_symbols
        found.discard(t)
        return tuple(sorted(found, key=natural_key))


def natural_key(symbol: sp.Symbol) -> tuple:
    """Sort key of a symbol's name with embedded numbers compared as numbers (m_2 before m_10)."""
    return tuple((0, int(part), "") if part.isdigit() else (1, 0, part)
                 for part in re.split(r"(\d+)", symbol.name) if part)


# ---- normalisation helpers -------------------------------------------------------------------------------------

def _number(e: sp.Expr) -> sp.Expr:
    """Exact numbers for double-precision floats: the decimal Rational of the float's shortest repr, which is the
    same double. Typed-in geometry is decimal, so this folds exactly (0.6**2 + 0.8**2 == 1, 1.0*x == x, 0.0
    vanishes), and sympy's rational arithmetic is several times faster than its Float arithmetic. Floats inside
    expressions are converted too; higher-precision Floats are kept."""
    if isinstance(e, sp.Float):
        return sp.Rational(repr(float(e))) if e._prec <= 53 else e
    if isinstance(e, sp.Basic) and e.has(sp.Float):
        return e.xreplace({f: _number(f) for f in e.atoms(sp.Float)})
    return e


def _vector(v, what: str) -> tuple:
    try:
        entries = tuple(_number(sp.sympify(c)) for c in (list(v) if not isinstance(v, sp.MatrixBase) else v))
    except (TypeError, sp.SympifyError) as exc:
        raise TreeError(f"{what}: expected a 3-vector ({exc})") from None
    if len(entries) != 3:
        raise TreeError(f"{what}: expected a 3-vector, got {len(entries)} entries")
    return entries


def _matrix(m, what: str) -> sp.ImmutableMatrix:
    try:
        mat = sp.ImmutableMatrix(m)
    except (TypeError, ValueError, sp.SympifyError) as exc:
        raise TreeError(f"{what}: expected a 3x3 matrix ({exc})") from None
    if mat.shape != (3, 3):
        raise TreeError(f"{what}: expected a 3x3 matrix, got shape {mat.shape}")
    return mat.applyfunc(_number)


def _pose(pose, what: str) -> tuple:
    try:
        R, r = pose
    except (TypeError, ValueError):
        raise TreeError(f"{what}: expected a pair (R, r)") from None
    return _matrix(R, what), sp.ImmutableMatrix(_vector(r, what))


def _check_unit(axis: tuple, kind: str) -> None:
    if all(c.is_number for c in axis):
        norm = float(sp.sqrt(sum(c**2 for c in axis)))
        if abs(norm - 1.0) > AXIS_UNIT_TOLERANCE:
            raise TreeError(f"axis {axis} of {kind} joint is not a unit vector (length {norm:.12g})")


def _slots(bodies, count, free) -> tuple:
    slots, n = [], 0
    for b in bodies:
        row = [None] * count(b)
        for k in free(b):
            row[k] = n
            n += 1
        slots.append(tuple(row))
    return tuple(slots)
