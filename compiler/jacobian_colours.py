"""Which velocities each constraint row's rate depends on, and a colouring of the Jacobian's columns.

The loop solver needs G = d(gdot)/dv at every evaluation. gdot = G v + g_t is affine in v, so column j of G is
gdot(e_j) - gdot(0); evaluated column by column that costs nv + 1 evaluations of the whole constraint rate. But
a cut joint's rows depend only on the velocities along its loop (the Iltis corners share only the chassis), so
columns that never meet in a row can be set together: one evaluation with v = sum of e_j over a colour gives
every column of that colour (Curtis, Powell and Reid's compression of sparse Jacobians). Columns no row
depends on are structurally zero and never evaluated.

The pattern comes from the tape: each temporary's set of velocity symbols, propagated in tape order (bit masks).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class ColumnColours:
    """rows[i]: the velocity indices row i's rate depends on; colour[j]: the colour of column j (-1: no row
    depends on v_j); ncolours: the number of evaluations (beyond gdot(0)) that give all of G."""

    rows: tuple[tuple[int, ...], ...]
    colour: tuple[int, ...]
    ncolours: int

    def column_of(self, row: int, colour: int) -> int:
        """The column of `colour` that row `row` depends on, or -1 (at most one: that is the colouring)."""
        for j in self.rows[row]:
            if self.colour[j] == colour:
                return j
        return -1


def velocity_dependence(tape, outputs, v_symbols) -> list[tuple[int, ...]]:
    """For each output expression, the sorted indices of the symbols in `v_symbols` it depends on through the
    tape's temporaries."""
    bit = {s: 1 << k for k, s in enumerate(v_symbols)}
    masks: dict = {}
    outputs = [sp.sympify(e) for e in outputs]
    for entry in tape.entries_for(outputs):
        mask = 0
        for s in entry.expr.free_symbols:
            mask |= bit.get(s, 0) | masks.get(s, 0)
        masks[entry.symbol] = mask
    result = []
    for e in outputs:
        mask = 0
        for s in e.free_symbols:
            mask |= bit.get(s, 0) | masks.get(s, 0)
        result.append(tuple(k for k in range(len(v_symbols)) if mask >> k & 1))
    return result


def colour_columns(rows, nv: int) -> ColumnColours:
    """Greedy colouring of the column intersection graph, columns with the most rows first."""
    rows = tuple(tuple(r) for r in rows)
    rows_of = [[i for i, r in enumerate(rows) if j in r] for j in range(nv)]
    colour = [-1] * nv
    ncolours = 0
    for j in sorted(range(nv), key=lambda j: (-len(rows_of[j]), j)):
        if not rows_of[j]:
            continue
        taken = {colour[k] for i in rows_of[j] for k in rows[i] if colour[k] >= 0}
        c = next(c for c in range(nv) if c not in taken)
        colour[j] = c
        ncolours = max(ncolours, c + 1)
    return ColumnColours(rows, tuple(colour), ncolours)


def constraint_colours(constraints) -> ColumnColours:
    """The colouring of the constraint Jacobian of `constraints` (mbs.compiler.constraints.Constraints)."""
    tree = constraints.tree
    rows = velocity_dependence(constraints.tape, constraints.velocity, tree.v_symbols)
    return colour_columns(rows, tree.nv)


__all__ = ["ColumnColours", "colour_columns", "constraint_colours", "velocity_dependence"]
