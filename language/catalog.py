"""What each joint, force and sensor kind accepts and provides: data the validator checks against.

Adding a kind starts here (its arguments, their dimensions, its coordinates); the compiler's lowering then
gives it meaning. Argument kinds: 'scalar' (an expression of the given dimension), 'vector' (3 components),
'axis' (a direction: x, y, z, -x, ... or a vector; normalised), 'frame' (a frame reference), 'word' (one of
a fixed set of names), 'law' (an expression that may use the kind's local variables), 'flag' (true/false).
"""

from __future__ import annotations

from dataclasses import dataclass

from . import units as U


@dataclass(frozen=True)
class Arg:
    name: str
    kind: str                       # scalar | vector | axis | frame | word | law | flag | table
    dimension: U.Dimension | None = None
    default: object = None          # None: required unless optional
    optional: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""


@dataclass(frozen=True)
class JointKind:
    name: str
    args: tuple[Arg, ...]
    # coordinate local names and dimensions; for 'spherical'/'free' they depend on the rotation argument
    coordinates: tuple[tuple[str, U.Dimension], ...]
    doc: str


@dataclass(frozen=True)
class ElementKind:
    name: str
    args: tuple[Arg, ...]
    locals: tuple[tuple[str, U.Dimension], ...] = ()  # variables a law may use
    components: tuple[str, ...] = ("",)               # sensor outputs ("" = scalar)
    doc: str = ""
    extra_args: bool = False                          # joint forces: one argument per coordinate


_CUT = Arg("cut", "flag", optional=True, doc="make this joint the cut joint of its loop")
_ROTATION = Arg("rotation", "word", default="quaternion", choices=("quaternion", "cardan"),
                doc="quaternion: singularity-free; cardan: angles x-y-z, for motions far from gimbal lock")

ANGLE, LENGTH = U.ANGLE, U.LENGTH
_CARDAN = (("alpha", ANGLE), ("beta", ANGLE), ("gamma", ANGLE))
_QUATERNION = (("qw", U.DIMENSIONLESS), ("qx", U.DIMENSIONLESS), ("qy", U.DIMENSIONLESS), ("qz", U.DIMENSIONLESS))
QUATERNION_SPEEDS = (("wx", U.ANGULAR_VELOCITY), ("wy", U.ANGULAR_VELOCITY), ("wz", U.ANGULAR_VELOCITY))

JOINTS: dict[str, JointKind] = {j.name: j for j in (
    JointKind("fixed", (_CUT,), (), "no relative motion"),
    JointKind("revolute", (Arg("axis", "axis", default="z"), _CUT), (("phi", ANGLE),),
              "rotation phi about axis (in frame a)"),
    JointKind("prismatic", (Arg("axis", "axis", default="z"), _CUT), (("s", LENGTH),),
              "translation s along axis"),
    JointKind("cylindrical", (Arg("axis", "axis", default="z"), _CUT), (("s", LENGTH), ("phi", ANGLE)),
              "translation s along and rotation phi about one axis"),
    JointKind("universal", (Arg("axis1", "axis", default="x"), Arg("axis2", "axis", default="y"), _CUT),
              (("phi1", ANGLE), ("phi2", ANGLE)), "Cardan joint: phi1 about axis1, then phi2 about axis2"),
    JointKind("spherical", (_ROTATION, _CUT), _QUATERNION, "ball joint"),
    JointKind("planar", (Arg("normal", "axis", default="z"), Arg("direction", "axis", default="x"), _CUT),
              (("x", LENGTH), ("y", LENGTH), ("phi", ANGLE)),
              "translation x along direction, y along normal x direction, rotation phi about normal"),
    JointKind("free", (_ROTATION, _CUT), (("x", LENGTH), ("y", LENGTH), ("z", LENGTH)) + _QUATERNION,
              "six degrees of freedom: translation in frame a, then rotation"),
)}


def joint_coordinates(kind: str, rotation: str) -> tuple[tuple[str, U.Dimension], ...]:
    """Coordinates of a joint; spherical and free joints depend on the rotation parametrisation."""
    coords = JOINTS[kind].coordinates
    if rotation == "cardan":
        coords = tuple(c for c in coords if c[0] not in ("qw", "qx", "qy", "qz")) + _CARDAN
    return coords


def speed_names(kind: str, rotation: str) -> tuple[str, ...]:
    """Names of the velocity coordinates (quaternion joints have angular velocities, not der(q))."""
    names = []
    for local, _ in joint_coordinates(kind, rotation):
        if local == "qw":
            continue
        names.append({"qx": "wx", "qy": "wy", "qz": "wz"}.get(local, local))
    return tuple(names)


_ALONG = Arg("along", "axis", optional=True,
             doc="act along this axis of frame a (deflection = projection) instead of along the line a-b")
_LINE_LOCALS = (("l", LENGTH), ("v", U.VELOCITY))
# What a tyre's laws may read (each law only those computed before it: road < fz < fx < fy < mz).
TYRE_LOCALS = (("x", LENGTH), ("y", LENGTH), ("rho", LENGTH), ("rho_dot", U.VELOCITY), ("gamma", ANGLE),
               ("vx", U.VELOCITY), ("fz", U.FORCE), ("alpha", ANGLE), ("kappa", U.DIMENSIONLESS),
               ("vsx", U.VELOCITY), ("vsy", U.VELOCITY), ("omega", U.ANGULAR_VELOCITY), ("fx", U.FORCE),
               ("fy", U.FORCE))
# The tyre sensor's components and their dimensions.
# The slip velocities and the spin rate come last (added later: the components before them keep their places);
# with a relaxation length alpha and kappa are the relaxed slips, and vsx, vsy, vx give the kinematic ones.
TYRE_OUTPUTS = {"fx": U.FORCE, "fy": U.FORCE, "fz": U.FORCE, "mz": U.TORQUE, "alpha": ANGLE,
                "kappa": U.DIMENSIONLESS, "gamma": ANGLE, "rho": LENGTH, "vx": U.VELOCITY,
                "vsx": U.VELOCITY, "vsy": U.VELOCITY, "omega": U.ANGULAR_VELOCITY}

# Dry friction (language/friction.py, compiler/friction.py). 'normal' may read the local 'reaction': the
# magnitude of the force the joint carries (bearing friction that grows with the load).
FRICTION_ARGS = (
    Arg("mu_k", "scalar", U.DIMENSIONLESS, doc="kinetic (sliding) friction coefficient"),
    Arg("mu_s", "scalar", U.DIMENSIONLESS, optional=True, doc="static coefficient (default: mu_k)"),
    Arg("normal", "law", U.FORCE, doc="normal force pressing the surfaces together; 'reaction': the joint's load"),
    Arg("radius", "scalar", LENGTH, optional=True, doc="friction radius of a revolute joint (torque = force * radius)"),
    Arg("stribeck_speed", "scalar", U.VELOCITY, optional=True,
        doc="mu falls from mu_s to mu_k as exp(-(w / stribeck_speed)^2) with the slip speed w"),
    Arg("smoothing", "scalar", U.VELOCITY, optional=True,
        doc="no stick/slip switch: the smoothed law mu N tanh(w / smoothing) (for comparison)"),
    Arg("tangent", "axis", optional=True,
        doc="a point contact instead of a joint: sliding along this axis of frame a, at frame b's origin"),
    Arg("surface_normal", "axis", optional=True,
        doc="a point contact sliding in the plane normal to this axis of frame a (isotropic friction, two "
            "tangential directions), at frame b's origin"),
)

FORCES: dict[str, ElementKind] = {k.name: k for k in (
    ElementKind("spring", (Arg("k", "scalar", U.STIFFNESS), Arg("l0", "scalar", LENGTH, default=0.0), _ALONG),
                doc="linear spring, tension k (l - l0)"),
    ElementKind("damper", (Arg("d", "scalar", U.DAMPING), _ALONG), doc="linear damper, tension d v"),
    ElementKind("spring_damper", (Arg("k", "scalar", U.STIFFNESS), Arg("d", "scalar", U.DAMPING),
                                  Arg("l0", "scalar", LENGTH, default=0.0), _ALONG),
                doc="tension k (l - l0) + d v"),
    ElementKind("line", (Arg("f", "law", U.FORCE), _ALONG), _LINE_LOCALS,
                doc="nonlinear tension f(l, v) along the line a-b (or along an axis); positive pulls together"),
    ElementKind("point", (Arg("force", "vector", U.FORCE, optional=True),
                          Arg("torque", "vector", U.TORQUE, optional=True),
                          Arg("in", "frame", optional=True)),
                doc="force and torque on frame b (components in frame 'in', default frame a); reaction on a"),
    ElementKind("joint", (), (), extra_args=True,
                doc="generalized forces on the interaction's joint coordinates: joint(phi = -d * der(phi))"),
    ElementKind("tyre", (Arg("radius", "scalar", LENGTH, doc="unloaded radius"),
                         Arg("road", "law", LENGTH, optional=True, doc="road height z(x, y) in frame a (default 0)"),
                         Arg("fz", "law", U.FORCE, doc="normal load from the deflection rho and its rate rho_dot"),
                         Arg("fx", "law", U.FORCE, optional=True, doc="longitudinal force (tyre x forward)"),
                         Arg("fy", "law", U.FORCE, optional=True, doc="lateral force (tyre y to the left)"),
                         Arg("mz", "law", U.TORQUE, optional=True, doc="aligning torque about the road normal"),
                         Arg("v_low", "scalar", U.VELOCITY, default=0.5,
                             doc="speed added (in quadrature) to |vx| in the slip denominators: finite at standstill"),
                         Arg("relax_y", "scalar", LENGTH, optional=True,
                             doc="lateral relaxation length: the laws see the slip angle lagging by this rolled "
                                 "distance (a tyre state, compiler/tyre_relaxation.py); default off"),
                         Arg("relax_x", "scalar", LENGTH, optional=True,
                             doc="longitudinal relaxation length, the same for the longitudinal slip"),
                         Arg("vertical", "flag", optional=True,
                             doc="the normal along frame a's z instead of the road's normal (a point contact that "
                                 "sees only the height, as the Iltis benchmark's tyre)")),
                TYRE_LOCALS,
                doc="wheel (frame b, spin axis y) on a road (frame a, height along z): contact kinematics and "
                    "force laws of the slip quantities (compiler/tyre.py)"),
    ElementKind("coulomb", FRICTION_ARGS, (("reaction", U.FORCE),),
                doc="dry friction in the interaction's prismatic or revolute joint: an exact stick/slip switch "
                    "(compiler/friction.py), or tanh-smoothed with 'smoothing'"),
)}

SENSORS: dict[str, ElementKind] = {k.name: k for k in (
    ElementKind("position", (Arg("in", "frame", optional=True),), components=("x", "y", "z"),
                doc="position of frame b relative to frame a, components in frame 'in' (default a)"),
    ElementKind("velocity", (Arg("in", "frame", optional=True),), components=("x", "y", "z"),
                doc="velocity of frame b relative to frame a (time derivative seen from the inertial frame)"),
    ElementKind("acceleration", (Arg("in", "frame", optional=True),), components=("x", "y", "z"),
                doc="acceleration of frame b relative to frame a"),
    ElementKind("angles", (Arg("sequence", "word", default="xyz", choices=("xyz", "zyx", "zxz")),),
                components=("a", "b", "c"), doc="orientation of frame b relative to frame a as three angles"),
    ElementKind("distance", (), doc="distance between the origins of frames a and b"),
    ElementKind("joint", (), components=(), doc="the joint's coordinates and speeds"),
    ElementKind("force", (Arg("element", "word", optional=True),),
                doc="the scalar force of a force element of this interaction"),
    ElementKind("tyre", (Arg("element", "word", optional=True),), components=tuple(TYRE_OUTPUTS),
                doc="forces, slip quantities and deflection of a tyre force element of this interaction"),
    ElementKind("reaction", (Arg("in", "frame", optional=True),),
                components=("fx", "fy", "fz", "mx", "my", "mz"),
                doc="constraint force and torque the joint transmits to frame b, components in frame 'in'"),
)}

# Settings allowed in blocks: name -> (dimension or kind, default)
BODY_SETTINGS = {"mass": U.MASS, "com": LENGTH, "inertia": U.INERTIA}
MODEL_SETTINGS = {"gravity": U.ACCELERATION}
SCENE_SETTINGS = {
    "model": "word", "t_end": U.TIME, "sample": U.TIME, "integrator": "word", "rtol": U.DIMENSIONLESS,
    "atol": U.DIMENSIONLESS, "start": "word",
}
#: dopri5, adams, rodasp, rodas5p, auto: in C; cvode_*, ida: SUNDIALS; the rest: scipy
INTEGRATORS = ("dopri5", "adams", "rodasp", "rodas5p", "auto", "cvode_adams", "cvode_bdf", "ida", "RK45", "DOP853",
               "Radau", "BDF", "LSODA")
#: the one default tolerance of every integration: scenes, mbs.System and mbs.runtime.simulate called directly
#: (tight, because multibody results are read as differences of nearby runs and as conservation checks)
DEFAULT_RTOL, DEFAULT_ATOL = 1e-8, 1e-10
SCENE_DEFAULTS = {"t_end": 1.0, "integrator": "dopri5", "rtol": DEFAULT_RTOL, "atol": DEFAULT_ATOL,
                  "start": "initial"}
