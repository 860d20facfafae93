"""Coordinates whose motion no mass or inertia determines, found when the model is checked.

A joint whose far side (everything it carries, away from the inertial part) holds no rigid body moves only
massless parts: its row of the mass matrix is zero, and the equations of motion cannot give its acceleration.
Left alone, the derivation fails with a structurally singular pivot long after `mbs check` said "ok". Such a
joint is fine when its coordinates are prescribed (the motion is given, not computed) or when it lies on a
closed loop (the loop closure determines it together with the rest of the loop). Which joints carry a part
does not depend on the spanning tree the compiler picks: a joint that is on no loop is a bridge of the joint
graph, and its far side is the part of the graph that removing it cuts off from the inertial part.
"""

from __future__ import annotations

from . import model as M
from .diagnostics import Diagnostics
from .rules import joint_graph


def check_inertia(model: M.Model, diags: Diagnostics) -> None:
    """A located error per joint that moves only massless parts with free (not prescribed) coordinates."""
    # a free joint transmits no load: it neither carries the parts beyond it nor closes a loop
    graph = {part: [(other, inter) for other, inter in edges if inter.joint.kind != "free"]
             for part, edges in joint_graph(model).items()}
    massive = {p.name for p in model.parts if p.body is not None}
    for inter in model.interactions:
        joint = inter.joint
        if joint is None:
            continue
        free = [c.name for c in joint.coordinates if c.prescribed is None]
        if not free:
            continue
        far = _far_side(graph if joint.kind != "free" else _with(graph, inter), inter)
        if far is None or far & massive:
            continue
        parts = ", ".join(f"'{p}'" for p in sorted(far))
        diags.error(f"no mass or inertia determines the motion of {', '.join(free)}: joint '{inter.name}' moves "
                    f"only the massless part{'s' if len(far) > 1 else ''} {parts}; give {'one of them' if len(far) > 1 else 'it'} a body "
                    "(rigid ... { body { ... } }), prescribe the coordinate, or close a loop through it "
                    "(forces on a massless part do not determine its motion)", joint.span)


def _far_side(graph, inter: M.Interaction) -> set[str] | None:
    """The parts joined to the inertial part only through `inter` (None: `inter` lies on a loop, or neither
    side reaches the inertial part)."""
    reach_a = _reachable(graph, inter.a.part, inter)
    if inter.b.part in reach_a:
        return None  # another path joins a and b: a closed loop holds this joint
    if M.INERTIAL in reach_a:
        return _reachable(graph, inter.b.part, inter)
    reach_b = _reachable(graph, inter.b.part, inter)
    return reach_a if M.INERTIAL in reach_b else None


def _with(graph, inter: M.Interaction):
    """The graph with `inter` (a free joint) put back: what it carries itself."""
    out = {part: list(edges) for part, edges in graph.items()}
    out.setdefault(inter.a.part, []).append((inter.b.part, inter))
    out.setdefault(inter.b.part, []).append((inter.a.part, inter))
    return out


def _reachable(graph, start: str, without: M.Interaction) -> set[str]:
    seen, stack = {start}, [start]
    while stack:
        node = stack.pop()
        for other, inter in graph.get(node, ()):
            if inter is not without and other not in seen:
                seen.add(other)
                stack.append(other)
    return seen
