"""Seeded random spatial trees, written as .mbs text and, alongside, as a list of physkit.Link (the same
mechanism described in numpy terms) for the oracles to build from.

The text exercises what a user writes: frames placed and rotated every way the language offers
(axis_angle about a named axis or a vector, cardan, euler, angles, dcm), inertia tensors in the part frame or
in a frame's axes, joints of every kind with named or oblique (non-unit) axes, revolute/prismatic/cylindrical
joints written from child to parent, parts and interactions declared in shuffled order, and a gravity vector
that is sometimes not the default.
"""

from __future__ import annotations

import numpy as np

from physkit import AXIS, EYE, Link, cardan, euler, rot

KINDS = ("revolute", "prismatic", "cylindrical", "universal", "planar", "spherical", "cardan", "free",
         "free_cardan", "fixed")
FLIPPABLE = ("revolute", "prismatic", "cylindrical", "fixed")  # may be written child -> parent
LANGUAGE_KIND = {"cardan": "spherical", "free_cardan": "free"}


def num(x: float) -> str:
    """Shortest text that reads back as the same double."""
    return repr(float(x))


def vec(v) -> str:
    return "(" + ", ".join(num(x) for x in v) + ")"


def mat(M) -> str:
    return "[" + ", ".join("[" + ", ".join(num(x) for x in row) + "]" for row in M) + "]"


def random_axis(rng) -> tuple[str, np.ndarray]:
    """(text, unit vector): a named axis (maybe negative) or an oblique vector of random length."""
    if rng.random() < 0.4:
        name = "xyz"[rng.integers(3)]
        sign = rng.choice([1, -1])
        return ("-" if sign < 0 else "") + name, sign * AXIS[name]
    a = rng.normal(size=3) * rng.uniform(0.5, 2.0)
    return vec(a), a / np.linalg.norm(a)


def random_rotation(rng) -> tuple[str, np.ndarray]:
    """(text after 'rotate', or '' for none; the rotation matrix: frame axes in part components)."""
    kind = rng.integers(7)
    angles = rng.uniform(-180, 180, size=3)
    deg = [f"{num(a)} deg" for a in angles]
    rad = np.radians(angles)
    if kind == 0:
        return "", EYE
    if kind == 1:
        text, u = random_axis(rng)
        return f"axis_angle({text}, {deg[0]})", rot(u, rad[0])
    if kind == 2:
        return f"cardan({', '.join(deg)})", cardan(*rad)
    if kind == 3:
        return f"euler({', '.join(deg)})", euler(*rad)
    if kind == 4:
        seq = ["zyx", "xzy", "yxz", "zxz", "xyx"][rng.integers(5)]
        R = rot(AXIS[seq[0]], rad[0]) @ rot(AXIS[seq[1]], rad[1]) @ rot(AXIS[seq[2]], rad[2])
        return f"angles({seq}, {', '.join(deg)})", R
    # A direction-cosine matrix, rows as written; orthonormal to the last bit.
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return f"dcm({mat(R)})", R


def random_inertia(rng) -> np.ndarray:
    """A physical inertia tensor about the centre of mass: principal moments from second moments a, b, c > 0
    (so the triangle inequalities hold), turned to random principal axes."""
    a, b, c = rng.uniform(0.01, 0.2, size=3)
    D = np.diag([b + c, a + c, a + b])
    _, R = random_rotation(rng)
    return symmetric(R @ D @ R.T)


def symmetric(M) -> np.ndarray:
    """Exactly symmetric in floating point (a + b == b + a), as an inertia tensor written by hand is."""
    return (M + M.T) / 2


def _joint_text(rng, kind: str) -> tuple[str, tuple]:
    """(joint declaration, axes as unit vectors)."""
    if kind in ("revolute", "prismatic", "cylindrical"):
        text, u = random_axis(rng)
        return f"{kind}(axis = {text})", (u,)
    if kind == "universal":
        (t1, a1), (t2, a2) = random_axis(rng), random_axis(rng)
        while abs(a1 @ a2) > 0.9:
            t2, a2 = random_axis(rng)
        return f"universal(axis1 = {t1}, axis2 = {t2})", (a1, a2)
    if kind == "planar":
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        u = np.cross(n, rng.normal(size=3))
        u /= np.linalg.norm(u)
        return f"planar(normal = {vec(n)}, direction = {vec(u)})", (n, u)
    if kind in ("cardan", "free_cardan"):
        return f"{LANGUAGE_KIND[kind]}(rotation = cardan)", ()
    return kind, ()


def random_model(rng, n_bodies: int, kinds=KINDS, name: str = "tree", inertia_in_frame: float = 0.0,
                 flip_probability: float = 0.3) -> tuple[str, list[Link], np.ndarray]:
    """(model text, links in depth-first order, gravity [m/s^2]). With probability `inertia_in_frame` a body's
    inertia is given in the axes of a rotated frame of its part; with `flip_probability` a joint that allows it
    is written child -> parent."""
    links: list[Link] = []
    frames: dict[int, list[str]] = {-1: []}     # part index -> frame declarations
    interactions, bodies = [], []
    for i in range(n_bodies):
        # Depth-first order (each subtree contiguous), as Pinocchio's crba wants: the parent is the previous
        # body or one of its ancestors, or the ground.
        path, j = [-1], i - 1
        while j >= 0:
            path.append(j)
            j = links[j].parent
        parent = int(path[rng.integers(len(path))])
        kind = kinds[rng.integers(len(kinds))]
        joint, axes = _joint_text(rng, kind)
        frames[i] = []
        # frame a on the parent
        rot_text, Ra = random_rotation(rng)
        ra = rng.normal(size=3) * 0.4
        fa = f"a{i}"
        frames[parent].append(f"frame {fa} at {vec(ra)} m" + (f" rotate {rot_text}" if rot_text else ""))
        pname = "inertial" if parent < 0 else f"p{parent}"
        # frame b on the child: half of the time its origin (the usual modelling choice)
        if rng.random() < 0.5:
            Rb, rb, fb = EYE, np.zeros(3), f"p{i}"
        else:
            rot_text, Rb = random_rotation(rng)
            rb = rng.normal(size=3) * 0.4
            frames[i].append(f"frame b{i} at {vec(rb)} m" + (f" rotate {rot_text}" if rot_text else ""))
            fb = f"p{i}.b{i}"
        side_a = f"{pname}.{fa}"
        if kind in FLIPPABLE and rng.random() < flip_probability:
            # Written child -> parent: the parent's frame moves relative to the child's, so seen from the
            # parent the child turns (slides) about the reversed axis by the same coordinate.
            connect = f"connect {fb} -> {side_a}"
            axes = tuple(-a for a in axes)
        else:
            connect = f"connect {side_a} -> {fb}"
        interactions.append(f"    interact j{i} {{\n        {connect}\n        joint {joint}\n    }}\n")
        inertia = random_inertia(rng)
        com = rng.normal(size=3) * 0.3
        mass = rng.uniform(0.5, 3.0)
        if rng.random() < inertia_in_frame:
            # components in the axes of a frame of the part: I_part = R I_frame R^T
            rot_text, RI = random_rotation(rng)
            frames[i].append("frame inertia_axes at (0, 0, 0) m" + (f" rotate {rot_text}" if rot_text else ""))
            inertia_text = f"{mat(symmetric(RI.T @ inertia @ RI))} kg*m^2 in inertia_axes"
        else:
            inertia_text = f"{mat(inertia)} kg*m^2"
        links.append(Link(f"j{i}", parent, kind, mass, com, inertia, axes, Ra, ra, Rb, rb))
        bodies.append(f"        body {{\n            mass = {num(mass)} kg\n            com = {vec(com)} m\n"
                               f"            inertia = {inertia_text}\n        }}\n")
    gravity = np.array([0, 0, -9.81])
    lines = [f"model {name} {{\n"]
    if rng.random() < 0.5:
        gravity = rng.normal(size=3) * 3 + gravity
        lines.append(f"    gravity = {vec(gravity)} m/s^2\n")
    if frames[-1]:
        lines.append("    part inertial {\n" + "".join(f"        {f}\n" for f in frames[-1]) + "    }\n")
    parts = [f"    rigid p{i} {{\n" + bodies[i] + "".join(f"        {f}\n" for f in frames[i]) + "    }\n"
             for i in range(n_bodies)]
    for block in (parts, interactions):
        order = rng.permutation(len(block))
        lines += [block[k] for k in order]
    lines.append("}\n")
    return "".join(lines), links, gravity


def random_values(rng, links) -> dict:
    """Random coordinates (unit quaternions) and speeds, by name."""
    values = {}
    for link in links:
        qn, vn = link.coordinates()
        q = rng.uniform(-1.5, 1.5, size=len(qn))
        if link.kind in ("spherical", "free"):
            quat = rng.normal(size=4)
            q[-4:] = quat / np.linalg.norm(quat)
        values.update(zip(qn, q))
        values.update(zip(vn, rng.normal(size=len(vn))))
    return values
