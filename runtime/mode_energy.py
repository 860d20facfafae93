"""Which part of the machine a mode moves: its kinetic and potential energy shared out over groups of
coordinates (a part, a suspension corner), and a name from the group that holds most of it.

Why energy and not the raw mode shape. A shape mixes metres and radians and counts a light link that turns
a lot as much as the heavy body that moves a little, so the quarter car's body bounce and wheel hop both
listed the same suspension angles. Energy is one unit for every coordinate and weighs each by its mass and
stiffness. With phi the shape in velocity coordinates, M the mass matrix and K = -d(forces)/dq (applied
generalized forces, along the shape), coordinate i holds the shares

    kinetic_i = Re(conj(phi_i) (M phi)_i) / (phi^H M phi),   potential_i = Re(conj(phi_i) (K phi)_i) / (phi^H K phi)

(modal energy fractions; they sum to 1 and can be slightly negative where coordinates are coupled), and a
group holds the sum of its coordinates' shares. With closed loops phi lies in the constraints' null space, so
the constraint forces do no work along it and drop out of both sums.
"""

from __future__ import annotations

import numpy as np

#: Words for the coordinates of a free or spherical joint (the body's own motions).
MOTION_WORDS = {"x": "surge", "y": "sway", "z": "bounce", "wx": "roll", "wy": "pitch", "wz": "yaw",
                "alpha": "roll", "beta": "pitch", "gamma": "yaw"}

#: Groups holding at least this fraction of the leading group's energy share the mode's name.
SHARED = 0.8


def part_groups(model) -> dict[str, str]:
    """{coordinate name (position form, 'j.phi', 'j.wx'): group}: the part the joint moves, a component
    instance's parts as one group (the corner 'fl'), so a mode is named after what carries its energy."""
    groups = {}
    for inter in model.interactions:
        if inter.joint is None:
            continue
        moved = inter.b.part if inter.b.part != "inertial" else inter.a.part
        group = moved.split(".", 1)[0]
        for c in inter.joint.coordinates:
            groups[c.name] = group
            if c.local in ("qx", "qy", "qz"):
                groups[f"{inter.name}.w{c.local[1]}"] = group
    return groups


def energy_shares(data, t: float, x: np.ndarray, E: np.ndarray, shape: np.ndarray, names, groups,
                  step: float) -> tuple[dict, dict]:
    """({group: kinetic share}, {group: potential share}) of a mode shape (velocity coordinates) about x."""
    nq, nv = E.shape
    M = np.asarray(data.mass_matrix(t, x)).reshape(nv, nv)

    def forces_along(direction: np.ndarray) -> np.ndarray:
        xp, xm = x.copy(), x.copy()
        xp[:nq] += step * (E @ direction)
        xm[:nq] -= step * (E @ direction)
        return -(np.asarray(data.forces(t, xp)) - np.asarray(data.forces(t, xm))) / (2 * step)

    K_phi = forces_along(shape.real) + 1j * forces_along(shape.imag)
    return _shares(shape, M @ shape, names, groups), _shares(shape, K_phi, names, groups)


def _shares(shape: np.ndarray, weighted: np.ndarray, names, groups) -> dict:
    per_coordinate = np.real(np.conj(shape) * weighted)
    total = per_coordinate.sum()
    out: dict[str, float] = {}
    if not abs(total) > 0:
        return out
    for name, value in zip(names, per_coordinate / total):
        group = groups.get(name, name.rsplit(".", 1)[0])
        out[group] = out.get(group, 0.0) + float(value)
    return dict(sorted(out.items(), key=lambda item: -item[1]))


def mode_name(kinetic: dict, potential: dict, shape: dict, groups) -> str:
    """'car bounce', 'car pitch', 'fl+fr arm_bearing.phi': the group with most of the mode's energy (kinetic and
    potential averaged; groups with nearly as much joined by '+', an axle's two corners) and, within it, the
    coordinate that moves most (a body's own motion by its word)."""
    energy = {g: 0.5 * (kinetic.get(g, 0.0) + potential.get(g, 0.0)) for g in {*kinetic, *potential}}
    if not energy:
        return ""
    group = max(energy, key=energy.get)
    alike = [g for g in energy if g != group and energy[g] >= SHARED * energy[group]]
    members = [(n, abs(a)) for n, a in shape.items() if groups.get(n, n.rsplit(".", 1)[0]) == group]
    if not members:
        return group
    coordinate = max(members, key=lambda m: m[1])[0]
    local = coordinate.rsplit(".", 1)[1]
    word = MOTION_WORDS.get(local)
    if word is None:
        word = coordinate if not coordinate.startswith(group + ".") else coordinate[len(group) + 1:]
    return f"{'+'.join(sorted([group, *alike]))} {word}"
