"""Independent oracles for the physics tests: rotations, forward kinematics and energy of a tree of rigid
parts written directly in numpy (nothing here imports the compiler), and the period of an oscillation from
its zero crossings.

Conventions follow docs/language.md: a joint moves frame b (on the child part) relative to frame a (on the
parent part); frames are placed in their part's frame by a rotation R (columns: the frame's axes in part
components) and a position r. Rotational joint speeds are in frame-b components.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicHermiteSpline

MODELS = Path(__file__).parent / "models"
EYE = np.eye(3)
AXIS = {"x": EYE[0], "y": EYE[1], "z": EYE[2]}


# ---- rotations -------------------------------------------------------------------------------------------------

def rot(axis, angle: float) -> np.ndarray:
    """Rotation by `angle` [rad] about `axis` (any length; normalised), Rodrigues' formula."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    ux = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.cos(angle) * EYE + np.sin(angle) * ux + (1 - np.cos(angle)) * np.outer(u, u)


def quat_matrix(q) -> np.ndarray:
    """Rotation matrix of the quaternion (w, x, y, z), normalised first."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def cardan(a, b, c) -> np.ndarray:
    """Body-fixed x, then y, then z."""
    return rot(AXIS["x"], a) @ rot(AXIS["y"], b) @ rot(AXIS["z"], c)


def euler(a, b, c) -> np.ndarray:
    """Body-fixed z, then x, then z."""
    return rot(AXIS["z"], a) @ rot(AXIS["x"], b) @ rot(AXIS["z"], c)


# ---- a tree of rigid parts -------------------------------------------------------------------------------------

@dataclass
class Link:
    """One part and the joint that carries it (interaction `name`, joint frame a on part `parent`).

    kind: "fixed", "revolute" (axes[0]), "prismatic" (axes[0]), "cylindrical" (axes[0]), "universal" (axes[0],
    axes[1]), "planar" (normal axes[0], direction axes[1]), "spherical" (quaternion), "cardan" (spherical with
    rotation = cardan), "free" (quaternion), "free_cardan". Geometry in SI units, in part frames; `inertia` is
    about the centre of mass in part-frame components.
    """

    name: str
    parent: int
    kind: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    axes: tuple = ()
    Ra: np.ndarray = field(default_factory=lambda: EYE)
    ra: np.ndarray = field(default_factory=lambda: np.zeros(3))
    Rb: np.ndarray = field(default_factory=lambda: EYE)
    rb: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def coordinates(self) -> tuple[list[str], list[str]]:
        """(position names, speed names) as the language names them."""
        n = self.name
        scalar = {"fixed": [], "revolute": ["phi"], "prismatic": ["s"], "cylindrical": ["s", "phi"],
                  "universal": ["phi1", "phi2"], "planar": ["x", "y", "phi"], "cardan": ["alpha", "beta", "gamma"],
                  "free_cardan": ["x", "y", "z", "alpha", "beta", "gamma"]}
        if self.kind in scalar:
            names = [f"{n}.{c}" for c in scalar[self.kind]]
            return names, [f"der({c})" for c in names]
        quat = [f"{n}.q{c}" for c in "wxyz"]
        omega = [f"{n}.w{c}" for c in "xyz"]
        if self.kind == "spherical":
            return quat, omega
        trans = [f"{n}.{c}" for c in "xyz"]
        return trans + quat, [f"der({c})" for c in trans] + omega


def joint_motion(link: Link, q, v):
    """(R_J, p_J, omega_J, pdot_J): rotation of b in a, position of b's origin and its rate in a components,
    angular velocity of b relative to a in a components."""
    zero = np.zeros(3)
    kind = link.kind
    axes = [np.asarray(a, float) / np.linalg.norm(a) for a in link.axes]
    if kind == "fixed":
        return EYE, zero, zero, zero
    if kind == "revolute":
        return rot(axes[0], q[0]), zero, axes[0] * v[0], zero
    if kind == "prismatic":
        return EYE, axes[0] * q[0], zero, axes[0] * v[0]
    if kind == "cylindrical":
        u = axes[0]
        return rot(u, q[1]), u * q[0], u * v[1], u * v[0]
    if kind == "universal":
        a1, a2 = axes
        R1 = rot(a1, q[0])
        # omega = a1 phi1' + (a2 turned by the first rotation) phi2'
        return R1 @ rot(a2, q[1]), zero, a1 * v[0] + R1 @ a2 * v[1], zero
    if kind == "planar":
        n, u = axes
        w = np.cross(n, u)
        return rot(n, q[2]), u * q[0] + w * q[1], n * v[2], u * v[0] + w * v[1]
    if kind in ("cardan", "free_cardan"):
        k = 3 if kind == "free_cardan" else 0
        a, b = q[k:k + 2]
        Rx, Ry = rot(AXIS["x"], a), rot(AXIS["y"], b)
        w = AXIS["x"] * v[k] + Rx @ AXIS["y"] * v[k + 1] + Rx @ Ry @ AXIS["z"] * v[k + 2]
        p, pd = (np.asarray(q[:3], float), np.asarray(v[:3], float)) if k else (zero, zero)
        return cardan(*q[k:]), p, w, pd
    if kind == "spherical":
        R = quat_matrix(q)
        return R, zero, R @ np.asarray(v, float), zero
    if kind == "free":
        R = quat_matrix(q[3:])
        return R, np.asarray(q[:3], float), R @ np.asarray(v[3:], float), np.asarray(v[:3], float)
    raise ValueError(kind)


@dataclass
class PartState:
    R: np.ndarray       # part frame -> world
    o: np.ndarray       # part origin, world [m]
    w: np.ndarray       # angular velocity, world [rad/s]
    vo: np.ndarray      # velocity of the part origin, world [m/s]

    def point(self, r):
        """(position, velocity) in the world of the point at r in part components."""
        d = self.R @ r
        return self.o + d, self.vo + np.cross(self.w, d)


def forward(links, values: dict) -> list[PartState]:
    """Pose and velocity of every part; `values` maps coordinate and speed names to floats."""
    ground = PartState(EYE, np.zeros(3), np.zeros(3), np.zeros(3))
    states = []
    for link in links:
        par = ground if link.parent < 0 else states[link.parent]
        qn, vn = link.coordinates()
        RJ, pJ, wJ, pdJ = joint_motion(link, [values[n] for n in qn], [values[n] for n in vn])
        A, vA = par.point(link.ra)
        Ra = par.R @ link.Ra
        B = A + Ra @ pJ
        vB = vA + np.cross(par.w, Ra @ pJ) + Ra @ pdJ
        Rc = Ra @ RJ @ link.Rb.T
        wc = par.w + Ra @ wJ
        d = Rc @ link.rb
        states.append(PartState(Rc, B - d, wc, vB - np.cross(wc, d)))
    return states


def energy(links, values: dict, gravity=(0, 0, -9.81)) -> tuple[float, float]:
    """(kinetic, potential) energy [J]; potential zero at the world origin."""
    kinetic = potential = 0.0
    for link, st in zip(links, forward(links, values)):
        r, v = st.point(link.com)
        inertia_world = st.R @ link.inertia @ st.R.T
        kinetic += 0.5 * link.mass * v @ v + 0.5 * st.w @ inertia_world @ st.w
        potential -= link.mass * np.dot(gravity, r)
    return kinetic, potential


def sample_values(res, i: int) -> dict:
    """Column name -> value at sample i of a Results table."""
    return {n: res.data[i, k] for k, n in enumerate(res.names)}


# ---- oscillations ----------------------------------------------------------------------------------------------

def crossings(t, y, dy) -> np.ndarray:
    """Times where y changes sign, located on the cubic Hermite interpolant of (y, dy): for samples h apart
    its error is O(h^4 y''''), below 1e-12 s for the sampling used in these tests.  A run with switches has two
    rows at each of its events (before and after, the same continuous state): one of them is kept."""
    once = np.concatenate([[True], np.diff(t) > 0])
    spline = CubicHermiteSpline(np.asarray(t)[once], np.asarray(y)[once], np.asarray(dy)[once])
    roots = np.unique(spline.roots(extrapolate=False))
    roots = roots[np.abs(spline(roots, 1)) > 0]
    if roots.size == 0:
        return roots
    # a crossing on a sample (an event's row: y is 0 to round-off there) is found by the pieces on both sides
    return roots[np.concatenate([[True], np.diff(roots) > 1e-12 * np.maximum(1.0, np.abs(roots[1:]))])]


def period(t, y, dy) -> float:
    """Mean period from the first to the last crossing in the same direction (whole periods only)."""
    roots = crossings(t, y, dy)
    whole = (len(roots) - 1) // 2
    if whole < 1:
        raise AssertionError(f"fewer than three zero crossings in {t[0]}..{t[-1]} s")
    return (roots[2 * whole] - roots[0]) / whole
