"""RigidInertia.to_parent (compiler/spatial.py), the composite-rigid-body algorithm's move of an inertia to its
parent's frame, against the textbook X* I X^-1 of 6 x 6 matrices (Featherstone's spatial algebra, written out
here in numpy) at random placements and inertias: the formulas with the new first moment are the same inertia to
round-off, and so is the mass matrix of a floating body with an arm and a link (test_relative_line_forces.py's) at
random states against the former formulas (kept here as they were)."""

import numpy as np
import sympy as sp

from mbs.compiler import spatial
from mbs.compiler.spatial import ZERO, RigidInertia, add, dot, mul
from mbs.compiler.tape import Tape


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def matrix(inertia: RigidInertia, values: dict) -> np.ndarray:
    """The 6 x 6 matrix [[Ibar, hx], [hx^T, m 1]] of an inertia on a tape, its temporaries expanded."""
    m = float(sp.sympify(inertia.m).xreplace(values))
    h = np.array([float(sp.sympify(x).xreplace(values)) for x in inertia.h])
    Ibar = np.array([[float(sp.sympify(x).xreplace(values)) for x in row] for row in inertia.Ibar])
    return np.block([[Ibar, skew(h)], [skew(h).T, m * np.eye(3)]])


def rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.linalg.det(q)   # a rotation, not a reflection (whose cross products change sign)


def test_an_inertia_moved_to_the_parent_is_the_textbook_congruence():
    rng = np.random.default_rng(5)
    for _ in range(20):
        tape = Tape()
        m, com = rng.uniform(0.5, 5.0), rng.normal(0.0, 0.4, 3)
        A = rng.normal(size=(3, 3))
        Ic = A @ A.T + np.eye(3)
        R, r = rotation(rng), rng.normal(0.0, 1.0, 3)
        symbols = sp.symbols("m c0:3 I0:6 R0:9 r0:3")
        values = dict(zip(symbols, [m, *com, Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2],
                                    *R.ravel(), *r]))
        ms, cs, Is, Rs, rs = symbols[0], symbols[1:4], symbols[4:10], symbols[10:19], symbols[19:22]
        Icsym = ((Is[0], Is[1], Is[2]), (Is[1], Is[3], Is[4]), (Is[2], Is[4], Is[5]))
        body = RigidInertia.of_body(tape, ms, cs, Icsym, "I")
        moved = body.to_parent(tape, (tuple(tuple(Rs[3 * i:3 * i + 3]) for i in range(3)), tuple(rs)), "Ip")
        expanded = dict(zip([e.symbol for e in tape.entries], tape.expand([e.symbol for e in tape.entries])))
        subs = {k: v.xreplace(values) for k, v in expanded.items()}
        subs.update(values)
        # X* I X^-1 with the motion transform X^-1 from the child to the parent: [[R, 0], [rx R, R]]
        motion = np.block([[R, np.zeros((3, 3))], [skew(r) @ R, R]])   # child motion -> parent motion
        force = np.linalg.inv(motion).T                                 # child force -> parent force
        expected = force @ matrix(body, subs) @ np.linalg.inv(motion)
        got = matrix(moved, subs)
        assert np.allclose(got, expected, rtol=0.0, atol=1e-12 * np.max(np.abs(expected))), got - expected


def former_to_parent(self, tape, X, name):
    """RigidInertia.to_parent as it was before the new first moment entered it (the oracle of the test below):
    Ibar' = Ibar - (h r^T + r h^T) - m r r^T + (2 r.h + m |r|^2) 1."""
    R, r = X
    h = spatial.matvec(tape, R, self.h, name + "hr")
    Ibar = spatial.congruence(tape, R, self.Ibar, name + "R", symmetric=True)
    if spatial.is_zero(r):
        return RigidInertia(self.m, h, Ibar)
    diag = add(mul(2, dot(r, h)), mul(self.m, dot(r, r)))
    out = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            e = add(Ibar[i][j], -mul(h[i], r[j]), -mul(r[i], h[j]), -mul(self.m, mul(r[i], r[j])),
                    diag if i == j else ZERO)
            out[i][j] = out[j][i] = tape.temp(e, f"{name}_{i}{j}")
    h_p = tape.vector([add(x, mul(self.m, y)) for x, y in zip(h, r)], name + "h")
    return RigidInertia(self.m, h_p, tuple(tuple(row) for row in out))


def mass_matrices(states):
    """M at each state of test_relative_line_forces.py's floating car with two arms and a link (evaluated from the
    tape in Python, treekit.numeric_function)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent))
    from test_relative_line_forces import MODEL
    from treekit import numeric_function

    from mbs.compiler.equations import derive_equations
    from mbs.compiler.lower import lower
    from mbs.compiler.tree import t
    from mbs.language.frontend import load_text
    lowered = lower(load_text(MODEL))
    eqs = derive_equations(lowered.kinematics, forward_dynamics=False)
    outputs = [e for row in eqs.mass_matrix for e in row]
    tree = lowered.tree
    symbols = sorted(eqs.tape.free_symbols(outputs) - set(tree.q_symbols) - set(tree.v_symbols) - {t}, key=str)
    defaults = {sp.Symbol(p.name): p.value for p in lowered.model.parameters}
    f = numeric_function(eqs, symbols, outputs)
    values = [float(defaults[s]) for s in symbols]
    return [np.array(f(0.0, list(map(float, x)), values)).reshape(tree.nv, tree.nv) for x in states], tree


def test_the_mass_matrix_is_the_former_one_to_round_off(monkeypatch):
    """The composite-rigid-body mass matrix with the cheaper move against the former formulas, at random states of
    a floating body with three children (two of them with offsets and rotations): the same to round-off."""
    rng = np.random.default_rng(3)
    _, tree = mass_matrices([])
    states = []
    for _ in range(4):
        q = rng.normal(0.0, 0.6, tree.nq)
        q[3:7] /= np.linalg.norm(q[3:7])   # the free joint's quaternion
        states.append(np.concatenate([q, rng.normal(0.0, 2.0, tree.nv)]))
    ours, _ = mass_matrices(states)
    monkeypatch.setattr(RigidInertia, "to_parent", former_to_parent)
    former, _ = mass_matrices(states)
    for a, b in zip(ours, former):
        assert np.max(np.abs(b)) > 1.0
        assert np.max(np.abs(a - b)) < 1e-14 * np.max(np.abs(b)), np.max(np.abs(a - b)) / np.max(np.abs(b))
