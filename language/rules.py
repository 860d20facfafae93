"""Checks on a finished data model that need the whole model: mass geometry, connectivity, loops.

Run after elaboration, evaluating expressions with parameter defaults. Each rule reports through the
shared Diagnostics so that ``mbs check`` lists every problem of a model in one run.
"""

from __future__ import annotations

import math

import numpy as np

from . import expr as X
from . import model as M
from .diagnostics import Diagnostics
from .quaternions import check_start_quaternions

INERTIA_REL_TOL = 1e-9  # relative slack for the triangle inequalities and symmetry (round-off in data)


def check_model(model: M.Model, diags: Diagnostics, component: bool = False, assumed_links=()) -> None:
    """``component``: a component checked on its own may leave parts for its user to connect."""
    values = {p.name: p.value for p in model.parameters}
    for part in model.parts:
        if part.body is not None:
            check_body(part, values, diags)
    check_start_quaternions(diags, model)
    check_topology(model, diags, require_connected=not component, assumed_links=assumed_links)


def _num(e: X.E, values) -> float | None:
    try:
        return X.evaluate(e, values)
    except X.EvaluationError:
        return None


def check_body(part: M.Part, values, diags: Diagnostics) -> None:
    for _, message in body_problems(part, values):
        diags.error(message, part.body.span)


def body_problems(part: M.Part, values, massless_ok: bool = False) -> list[tuple[str, str]]:
    """(quantity: "mass" or "inertia", message) for each reason why the mass geometry of a part is not a
    physical body's with these parameter values (empty: it is).
    A point mass (zero inertia) and a thin rod (one zero moment) are positive semi-definite and allowed;
    values that cannot be evaluated are left alone. `massless_ok`: a mass of zero is accepted (a parameter study
    taking a part's mass to its massless limit, as long as the mass matrix stays regular); negative never is."""
    body = part.body
    problems = []
    mass = _num(body.mass, values)
    if mass is not None and massless_ok and not mass >= 0:
        problems.append(("mass", f"the mass of '{part.name}' must not be negative, but it is {mass:g} kg"))
    elif mass is not None and not massless_ok and not mass > 0:
        problems.append(("mass", f"the mass of '{part.name}' must be positive, but it is {mass:g} kg "
                        "(a massless part is declared with 'part', not 'rigid')"))
    inertia = [[_num(c, values) for c in row] for row in body.inertia]
    if any(v is None for row in inertia for v in row):
        return problems
    tensor = np.array(inertia, dtype=float)
    scale = max(1e-300, np.abs(tensor).max())
    what = f"the inertia tensor of '{part.name}'"
    if body.about:
        what += f" about its centre of mass (shifted from frame '{body.about}')"
    if not np.all(np.isfinite(tensor)):
        return problems + [("inertia", f"the inertia of '{part.name}' is not finite")]
    if np.abs(tensor - tensor.T).max() > INERTIA_REL_TOL * scale:
        return problems + [("inertia", f"the inertia tensor of '{part.name}' must be symmetric")]
    principal = np.linalg.eigvalsh(tensor)
    # Zero moments are allowed: point masses and thin rods are standard idealisations (as in Pinocchio).
    if principal.min() < -INERTIA_REL_TOL * scale:
        return problems + [("inertia", f"{what} must be positive semi-definite (principal moments "
                                       f"{', '.join('%.6g' % v for v in principal)} kg*m^2)")]
    a, b, c = principal
    if a + b < c * (1 - INERTIA_REL_TOL) or a + c < b * (1 - INERTIA_REL_TOL) or b + c < a * (1 - INERTIA_REL_TOL):
        problems.append(("inertia", f"the principal moments of '{part.name}' ({a:.6g}, {b:.6g}, {c:.6g} kg*m^2) "
                                    "violate the triangle inequality: no physical body has them"))
    return problems


def joint_graph(model: M.Model) -> dict[str, list[tuple[str, M.Interaction]]]:
    graph: dict[str, list] = {p.name: [] for p in model.parts}
    for inter in model.interactions:
        if inter.joint is not None:
            graph[inter.a.part].append((inter.b.part, inter))
            graph[inter.b.part].append((inter.a.part, inter))
    return graph


def check_topology(model: M.Model, diags: Diagnostics, require_connected: bool = True, assumed_links=()) -> None:
    """Every part must hang on the inertial part through joints; closed loops are reported by name.

    ``assumed_links`` are part pairs whose joint had errors of its own: they count as joined."""
    graph = joint_graph(model)
    for a, b in assumed_links:
        if a in graph and b in graph:
            graph[a].append((b, _ASSUMED))
            graph[b].append((a, _ASSUMED))
    seen = {M.INERTIAL}
    tree_edges = set()
    # Spanning tree: joints the user marked as cut joints enter last, so they close the loops.
    for allow_cut in (False, True):
        stack = list(seen)
        while stack:
            node = stack.pop()
            for other, inter in graph[node]:
                if other not in seen and (allow_cut or not inter.joint.cut):
                    seen.add(other)
                    tree_edges.add(inter.name)
                    stack.append(other)
    for part in model.parts:
        if part.name not in seen and require_connected:
            diags.error(f"part '{part.name}' is not connected to the inertial part by joints "
                        "(add an interaction with a joint, e.g. 'joint free' for a floating body)", part.span)
    for loop in find_loops(model, graph, tree_edges):
        names = " -> ".join(loop.parts)
        diags.note(f"closed kinematic loop {names} (joints: {', '.join(loop.joints)}); joint "
                   f"'{loop.cut}' closes it", model.interaction_map[loop.cut].span)


class _Assumed:
    name = "<invalid joint>"

    class joint:
        cut = False


_ASSUMED = _Assumed()


class Loop:
    def __init__(self, parts, joints, cut):
        self.parts, self.joints, self.cut = parts, joints, cut


def find_loops(model: M.Model, graph, tree_edges) -> list[Loop]:
    """One fundamental loop per joint outside the spanning tree (BFS tree from the inertial part)."""
    parent: dict[str, tuple[str, str] | None] = {M.INERTIAL: None}
    order = [M.INERTIAL]
    for node in order:
        for other, inter in graph[node]:
            if other not in parent and inter.name in tree_edges:
                parent[other] = (node, inter.name)
                order.append(other)
    loops = []
    for inter in model.interactions:
        if inter.joint is None or inter.name in tree_edges or inter.name not in model.interaction_map:
            continue
        if inter.a.part not in parent or inter.b.part not in parent:
            continue
        path_a, path_b = _path_to_root(parent, inter.a.part), _path_to_root(parent, inter.b.part)
        common = set(p for p, _ in path_a) & set(p for p, _ in path_b)
        up = [(p, j) for p, j in path_a if p not in common or p == _first_common(path_a, common)]
        down = [(p, j) for p, j in path_b if p not in common]
        parts = [p for p, _ in up] + [p for p, _ in reversed(down)]
        joints = [j for _, j in up[:-1] if j] + [j for _, j in reversed(down) if j] + [inter.name]
        loops.append(Loop(parts, joints, inter.name))
    return loops


def _path_to_root(parent, node):
    path = []
    while node is not None:
        link = parent[node]
        path.append((node, link[1] if link else None))
        node = link[0] if link else None
    return path


def _first_common(path, common):
    for p, _ in path:
        if p in common:
            return p
    return None


def degrees_of_freedom_estimate(model: M.Model) -> int:
    """Sum of free joint velocities (the exact count with loops comes from the constraint Jacobian's rank)."""
    count = 0
    for inter in model.interactions:
        if inter.joint is None:
            continue
        for c in inter.joint.coordinates:
            if c.prescribed is None and c.local != "qw":
                count += 1
    return count


__all__ = ["check_model", "body_problems", "check_topology", "find_loops", "joint_graph",
           "degrees_of_freedom_estimate", "math"]
