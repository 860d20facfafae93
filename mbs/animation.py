"""What an animation shows: every part's pose over a run, its solid, and the road under the tyres.

Poses come from the model's own forward kinematics (compiler/kinematics.py) on a fresh tape, evaluated with
NumPy over all samples at once: the body frame (= the part frame) of each tree body in world coordinates.
A part is drawn as its equivalent inertia box (a homogeneous box with the part's mass and principal moments,
at the centre of mass; small or massless parts get a minimum size), thin links from the centre of mass to
each of its frames, and wheels (parts a tyre of library/tyres acts on) as discs of the tyre's radius.
The road is the profile each such tyre reads, evaluated along its track from its `deflection` output
(road(x) = deflection at a wheel centre of height 0, less the unloaded radius).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp


#: frames at most in a page (longer runs are strided)
MAX_FRAMES = 1200
MIN_BOX = 0.04  # m


@dataclass
class Animation:
    """Times, per-body poses (n, 7: x y z qx qy qz qw) and the static geometry, ready for the page."""

    title: str
    t: np.ndarray
    bodies: list[dict]
    roads: list[dict]

    def to_json(self) -> dict:
        def rounded(a, digits=5):
            return np.round(np.asarray(a, dtype=float), digits).tolist()
        return {"title": self.title, "t": rounded(self.t, 6),
                "bodies": [{**{k: v for k, v in b.items() if k != "poses"}, "poses": rounded(b["poses"])}
                           for b in self.bodies],
                "roads": [{**r, "x": rounded(r["x"], 4), "z": rounded(r["z"], 5)} for r in self.roads]}


def world_poses(system, scene, t: np.ndarray, states: np.ndarray, params: dict) -> list[np.ndarray]:
    """(n, 7) pose of every tree body's part: the origin of its coordinates and the rotation quaternion (x, y, z, w)
    in the world."""
    from mbs.compiler.kinematics import Kinematics
    from mbs.compiler.symbolic import parameter_symbol
    from mbs.compiler.tree import t as t_symbol
    gen = system.generate(scene)
    tree = gen.lowered.tree
    kin = Kinematics(tree)
    outputs = []
    for i, origin in enumerate(gen.lowered.body_origins):
        R, r = kin.world_pose(i)   # (the body frame's origin is not the part's: compiler/lower.py, Lowered)
        r = [x - sum(R[a][b] * origin[b] for b in range(3)) for a, x in enumerate(r)]
        outputs.append([*r, *(R[a][b] for a in range(3) for b in range(3))])
    env = {s: states[:, k] for k, s in enumerate(tree.q_symbols)}
    env[t_symbol] = t
    for p in system.model.parameters:
        env[parameter_symbol(p.name)] = np.full(t.shape, params[p.name])
    for entry in kin.tape.entries_for([e for row in outputs for e in row]):
        env[entry.symbol] = _evaluate(entry.expr, env, t.shape)
    poses = []
    for row in outputs:
        values = [_evaluate(sp.sympify(e), env, t.shape) for e in row]
        R = np.stack(values[3:], axis=-1).reshape(-1, 3, 3)
        poses.append(np.column_stack([*values[:3], quaternions(R)]))
    return poses


def _evaluate(expr, env, shape):
    symbols = sorted(expr.free_symbols, key=lambda s: s.name)
    fn = sp.lambdify(symbols, expr, "numpy")
    return np.broadcast_to(np.asarray(fn(*(env[s] for s in symbols)), dtype=float), shape).copy()


def quaternions(R: np.ndarray) -> np.ndarray:
    """(n, 4) unit quaternions (x, y, z, w) of rotation matrices (n, 3, 3), by Shepperd's method."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_quat()


def _box(part, params) -> list[float]:
    """Edge lengths of the homogeneous box with the part's mass and (diagonal) moments of inertia."""
    if part.body is None:
        return [MIN_BOX] * 3
    mass = _number(part.body.mass, params)
    I = [_number(part.body.inertia[k][k], params) for k in range(3)]
    if not mass > 0:
        return [MIN_BOX] * 3
    squares = [6.0 * (I[1] + I[2] - I[0]) / mass, 6.0 * (I[0] + I[2] - I[1]) / mass,
               6.0 * (I[0] + I[1] - I[2]) / mass]
    return [max(MIN_BOX, math.sqrt(max(s, 0.0))) for s in squares]


def _number(value, params) -> float:
    from mbs.language import expr as X
    return float(value) if isinstance(value, (int, float)) else X.evaluate(value, params)


def tyres(system) -> list[tuple[str, str, str]]:
    """(tyre instance, wheel part, wheel frame) of every tyre that has a deflection output and a radial contact."""
    outputs = {o.name for o in system.model.outputs}
    found = []
    for inter in system.model.interactions:
        if inter.name.endswith(".radial"):
            prefix = inter.name[: -len(".radial")]
            if f"{prefix}.deflection" in outputs and f"{prefix}.r0" in system.model.parameter_map:
                found.append((prefix, inter.b.part, inter.b.frame))
    return found


def animation(system, scene, res, params: dict) -> Animation:
    """The Animation of a run (Results with the state columns) of a scene with parameter values `params`."""
    gen = system.generate(scene)  # the names only: no build (a model with hooks needs none)
    stride = max(1, math.ceil(len(res) / MAX_FRAMES))
    t = np.asarray(res.t[::stride])
    q = res.columns(gen.q_names)[::stride]
    poses = world_poses(system, scene, t, q, params)
    parts = {p.name: p for p in system.model.parts}
    wheels = {part: prefix for prefix, part, _ in tyres(system)}
    bodies = []
    for i, name in enumerate(gen.lowered.topology.bodies):
        part = parts[name]
        com = [_number(c, params) for c in part.body.com] if part.body is not None else [0.0, 0.0, 0.0]
        frames = [[_number(c, params) for c in f.position] for f in part.frames]
        body = {"name": name, "com": com, "box": _box(part, params), "frames": frames, "poses": poses[i],
                "mass": _number(part.body.mass, params) if part.body is not None else 0.0}
        if name in wheels:
            body["wheel_radius"] = params[f"{wheels[name]}.r0"]
        bodies.append(body)
    return Animation(f"{system.model.name}" + (f", scene {scene}" if scene else ""), t, bodies,
                     roads(system, t, {b["name"]: b for b in bodies}, params))


def roads(system, t: np.ndarray, bodies: dict, params: dict) -> list[dict]:
    """Profile of each tyre's road along its track: static (one profile) or, when it moves (a road that passes
    under a car standing still), one profile per frame."""
    from mbs.language import expr as X
    deflection = {o.name: o.value for o in system.model.outputs}
    found = []
    for prefix, part, frame in tyres(system):
        body = bodies.get(part)
        if body is None:
            continue
        centre = np.asarray(body["poses"])[:, :3]
        lo, hi = float(centre[:, 0].min()) - 3.0, float(centre[:, 0].max()) + 3.0
        expr = deflection[f"{prefix}.deflection"]

        def profile(time: float, points: int = 300) -> np.ndarray:
            xs = np.linspace(lo, hi, points)
            env = dict(params, t=time)
            env[f"{prefix}.radial.centre.z"] = 0.0
            out = np.empty(xs.size)
            for k, x in enumerate(xs):
                env[f"{prefix}.radial.centre.x"] = x
                out[k] = X.evaluate(expr, env) - params[f"{prefix}.r0"]
            return out

        first, last = profile(float(t[0])), profile(float(t[-1]))
        moving = not np.allclose(first, last)
        points = 80 if moving else 300  # a moving road: one profile per frame, coarser
        z = np.array([profile(float(time), points) for time in t]) if moving else first
        found.append({"tyre": prefix, "y": float(np.median(centre[:, 1])), "x": np.linspace(lo, hi, points),
                      "z": z, "moving": moving})
    return found
