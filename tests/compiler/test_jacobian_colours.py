"""The colouring of the constraint Jacobian's columns (compiler/jacobian_colours.py): columns of one colour share
no row, and the pattern read from the tape is what the expressions depend on."""

from __future__ import annotations

import itertools

import sympy as sp

from mbs.compiler.jacobian_colours import colour_columns, velocity_dependence
from mbs.compiler.tape import Tape


def test_columns_of_one_colour_share_no_row_and_every_used_column_has_one():
    rows = [(0, 1, 2), (0, 3), (0, 4, 5), (6,), (), (1, 3, 5)]
    colours = colour_columns(rows, 8)
    for row in rows:
        assert len({colours.colour[j] for j in row}) == len(row)  # no two columns of a row share a colour
    assert colours.colour[7] == -1 and all(colours.colour[j] >= 0 for j in range(7))
    assert colours.ncolours == 4  # columns 0, 1, 3, 5 meet pairwise (a clique of four): no fewer colours
    for i, c in itertools.product(range(len(rows)), range(colours.ncolours)):
        j = colours.column_of(i, c)
        assert j == -1 or (j in rows[i] and colours.colour[j] == c)


def test_the_pattern_follows_the_tape_temporaries():
    v = sp.symbols("v0:4")
    q = sp.Symbol("q")
    tape = Tape()
    w = tape.temp(sp.cos(q) * v[0] + v[1], "w")
    u = tape.temp(w * sp.sin(q), "u")
    rows = velocity_dependence(tape, [u + v[3], sp.cos(q) * 2, v[2]], v)
    assert rows == [(0, 1, 3), (), (2,)]
