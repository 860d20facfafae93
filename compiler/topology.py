"""Topology: which joints form the spanning tree, which close loops, and in which order the bodies come.

The first stage of the compiler proper (validated model -> topology). The tree grows from the inertial
part through joints; joints the user marked ``cut = true`` are taken last, so they close the loops; of the
others, breadth-first order keeps chains short. Each tree joint is oriented parent -> child: when the model
connects them the other way round (frame a on the child), the joint is flipped if its kind allows.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError

# Joint kinds whose motion of a relative to b is the same kind with the axis reversed.
FLIPPABLE = ("fixed", "revolute", "prismatic", "cylindrical")


@dataclass(frozen=True)
class TreeJoint:
    """One edge of the spanning tree: ``interaction`` moves ``child`` relative to ``parent``.

    ``flipped``: the model connects child -> parent; the tree uses the inverse joint (axis reversed)."""

    interaction: M.Interaction
    parent: str
    child: str
    flipped: bool


@dataclass(frozen=True)
class Topology:
    bodies: tuple[str, ...]            # parts in tree order (parents first); 'inertial' excluded
    joints: tuple[TreeJoint, ...]      # joints[i] moves bodies[i]
    parent_index: tuple[int, ...]      # index into bodies of each body's parent, -1 for the ground
    cuts: tuple[M.Interaction, ...]    # joints outside the tree: each closes one loop

    @property
    def has_loops(self) -> bool:
        return bool(self.cuts)


def build_topology(model: M.Model) -> Topology:
    """Spanning tree of the joint graph; raises MbsError for parts the joints do not reach."""
    adjacency: dict[str, list[tuple[str, M.Interaction]]] = {p.name: [] for p in model.parts}
    for inter in model.interactions:
        if inter.joint is not None:
            adjacency[inter.a.part].append((inter.b.part, inter))
            adjacency[inter.b.part].append((inter.a.part, inter))
    order: list[str] = []
    joints: list[TreeJoint] = []
    in_tree: set[str] = set()
    seen = {M.INERTIAL}
    for allow_cut in (False, True):
        queue = deque([M.INERTIAL] + order)
        while queue:
            node = queue.popleft()
            for other, inter in adjacency[node]:
                if other in seen or (inter.joint.cut and not allow_cut):
                    continue
                seen.add(other)
                in_tree.add(inter.name)
                order.append(other)
                joints.append(TreeJoint(inter, node, other, flipped=inter.a.part != node))
                queue.append(other)
    missing = [p for p in model.parts if p.name not in seen]
    if missing:
        raise MbsError([Diagnostic("error", f"part '{p.name}' is not connected to the inertial part by joints",
                                   p.span) for p in missing])
    problems = [Diagnostic("error", f"joint '{j.interaction.name}' ({j.interaction.joint.kind}) is written from "
                                    f"child to parent; write 'connect {j.interaction.b} -> {j.interaction.a}' "
                                    "so that frame a is on the part nearer the ground", j.interaction.span)
                for j in joints if j.flipped and j.interaction.joint.kind not in FLIPPABLE]
    if problems:
        raise MbsError(problems)
    index = {name: i for i, name in enumerate(order)}
    parents = tuple(-1 if j.parent == M.INERTIAL else index[j.parent] for j in joints)
    cuts = tuple(i for i in model.interactions if i.joint is not None and i.name not in in_tree)
    return Topology(tuple(order), tuple(joints), parents, cuts)
