"""The recursive O(n) algorithms of rigid-body dynamics, executed symbolically on the tape of a `Kinematics`.

* `inverse_dynamics` (RNEA): tau = M vdot + k - q, used with vdot = 0 for the force vector f = q - k.
* `mass_matrix` (CRBA): M = J^T Mbar J of Leister/Schiehlen eq. (5), from composite rigid-body inertias.
* `forward_dynamics` (ABA): vdot solving M vdot = f directly, in O(n) without forming M.

Notation follows Featherstone, "Rigid Body Dynamics Algorithms" (2008), tables 5.1, 6.2 and 7.1; all 6-vectors in
body frames. Gravity enters as a fictitious acceleration -g of the ground. Multi-degree-of-freedom joints are
handled with a symbolic LDL^T factorisation of their (small) articulated-inertia block D = S^T IA S, so that every
division is by a scalar pivot d_j > 0, which the generated code checks at run time.
"""

from __future__ import annotations

from .kinematics import Kinematics
from .spatial import ZERO, ZERO3, ZERO6, add, dot, force_to_parent, motion_to_child, mul, sadd
from .tape import Tape


def _ground_acceleration(kin: Kinematics, gravity: bool) -> tuple:
    return ZERO3 + tuple(-g for g in kin.tree.gravity) if gravity else ZERO6


def inverse_dynamics(kin: Kinematics, vdot=None, *, inertial: bool = True, gravity: bool = True,
                     loads: bool = True, name: str = "tau") -> tuple:
    """Joint forces tau (one per free velocity) [N or N*m] that produce the accelerations `vdot` (free velocities,
    state order; None = 0): tau = M vdot + k - q.

    inertial: include the velocity products and prescribed accelerations (the vector k);
    gravity, loads: include the weights and the applied loads (the vector q).
    """
    return _rnea(kin, vdot, inertial=inertial, gravity=gravity, loads=loads, name=name)[0]


def transmitted_loads(kin: Kinematics, vdot, extra_wrenches=None) -> tuple:
    """Per body i, the load (n; f) [N*m, N] its joint transmits from the parent onto body i (body frame, at the
    body origin), given the actual accelerations `vdot` (state order) and further loads per body (a dict body ->
    6-vector in the body frame, e.g. the constraint forces of loop-closing joints).

    Newton-Euler for body i reads f_i = I a_i + v x* I v - f_ext_i + sum over its children of f_child: the
    inward pass of the RNEA with the true accelerations, which is why the reaction of every tree joint costs
    one pass over the tree. The load includes what the joint transmits along its own free directions (the
    generalized forces of `force ... = joint(...)` elements and the drive of prescribed coordinates)."""
    return _rnea(kin, vdot, inertial=True, gravity=True, loads=True, extra=extra_wrenches, name="rx")[1]


def body_accelerations(kin: Kinematics, vdot, *, gravity: bool = False, inertial: bool = True,
                        tag: str = "acc") -> tuple:
    """Spatial accelerations (omega'; v') of every body, body frame at its origin, for the state accelerations
    `vdot` (state order, None = 0). With `gravity` the ground accelerates upwards by -g (the RNEA's way of
    adding the weights); without it these are the true accelerations. Without `inertial` the velocity products
    and prescribed accelerations are left out (the RNEA's split of M vdot + k)."""
    tree, tape = kin.tree, kin.tape
    acc = [None] * len(tree.bodies)
    a0 = _ground_acceleration(kin, gravity)
    for i, (body, bk) in enumerate(zip(tree.bodies, kin.bodies)):
        n = i + 1
        tape.section(f"body {n} ({body.name}): acceleration")
        a_p = a0 if body.parent < 0 else acc[body.parent]
        a = ZERO6 if all(x is ZERO for x in a_p) else motion_to_child(tape, bk.X, a_p, f"{tag}p{n}")
        terms = [a, bk.bias] if inertial else [a]
        if vdot is not None:
            terms += [tuple(mul(x, vdot[tree.v_slots[i][k]]) for x in bk.S[k]) for k in bk.free]
        acc[i] = tape.vector([add(*(term[j] for term in terms)) for j in range(6)], f"{tag}{n}")
    return tuple(acc)


def _rnea(kin: Kinematics, vdot, *, inertial: bool, gravity: bool, loads: bool, extra=None, name: str) -> tuple:
    """(tau, transmitted): the joint forces and the per-body loads of the recursive Newton-Euler algorithm."""
    tree, tape = kin.tree, kin.tape
    nb = len(tree.bodies)
    acc = body_accelerations(kin, vdot, gravity=gravity, inertial=inertial, tag="a")
    force = [None] * nb
    for i in range(nb):
        n = i + 1
        tape.section(f"body {n} ({tree.bodies[i].name}): inverse dynamics, outward")
        inertia = kin.inertia(i)
        parts = [inertia.apply(tape, acc[i], f"Ia{n}")]
        if inertial:
            parts.append(kin.gyroscopic(i))
        if loads:
            parts.append(tuple(-x for x in kin.external_wrench(i)))
        if extra and i in extra:
            parts.append(tuple(-x for x in extra[i]))
        force[i] = tape.vector([add(*(p[j] for p in parts)) for j in range(6)], f"f{n}")
    tau = [None] * tree.nv
    transmitted = [None] * nb
    generalized = kin.generalized_forces() if loads else (ZERO,) * tree.nv
    for i in reversed(range(nb)):
        body, bk = tree.bodies[i], kin.bodies[i]
        tape.section(f"body {i + 1} ({body.name}): inverse dynamics, inward")
        transmitted[i] = force[i]  # every child (a higher index) has been added
        for k in bk.free:
            slot = tree.v_slots[i][k]
            tau[slot] = tape.temp(add(dot(bk.S[k], force[i]), -generalized[slot]), f"{name}{slot}")
        if body.parent >= 0:
            fp = force_to_parent(tape, bk.X, force[i], f"fp{i + 1}")
            force[body.parent] = sadd(tape, force[body.parent], fp, f"f{body.parent + 1}")
    return tuple(tau), tuple(transmitted)


def mass_matrix(kin: Kinematics) -> tuple:
    """The symmetric nv x nv mass matrix (tuple of rows) by the composite-rigid-body algorithm [kg, kg*m, kg*m^2]."""
    tree, tape = kin.tree, kin.tape
    nb = len(tree.bodies)
    composite = [kin.inertia(i) for i in range(nb)]
    for i in reversed(range(nb)):
        body = tree.bodies[i]
        if body.parent >= 0:
            tape.section(f"body {i + 1} ({body.name}): composite inertia")
            moved = composite[i].to_parent(tape, kin.bodies[i].X, f"Ic{i + 1}p")
            composite[body.parent] = composite[body.parent].plus(tape, moved, f"Ic{body.parent + 1}")
    M = [[ZERO] * tree.nv for _ in range(tree.nv)]  # zero between different branches
    for i in range(nb):
        bk = kin.bodies[i]
        if bk.free:
            tape.section(f"body {i + 1} ({tree.bodies[i].name}): mass matrix columns")
        for k in bk.free:
            col = tree.v_slots[i][k]
            F = composite[i].apply(tape, bk.S[k], f"F{col}_{i + 1}")
            j = i
            while True:
                bj = kin.bodies[j]
                for kk in bj.free:
                    row = tree.v_slots[j][kk]
                    if row <= col:
                        M[row][col] = M[col][row] = tape.temp(dot(bj.S[kk], F), f"M{row}_{col}")
                parent = tree.bodies[j].parent
                if parent < 0:
                    break
                F = force_to_parent(tape, bj.X, F, f"F{col}_{parent + 1}")
                j = parent
    return tuple(tuple(row) for row in M)


def forward_dynamics(kin: Kinematics) -> tuple:
    """vdot (free velocities, state order) [m/s^2 or rad/s^2] by the articulated-body algorithm."""
    tree, tape = kin.tree, kin.tape
    nb = len(tree.bodies)
    tau = kin.generalized_forces()
    IA, pA = [None] * nb, [None] * nb
    for i in range(nb):
        n = i + 1
        tape.section(f"body {n} ({tree.bodies[i].name}): articulated body, outward")
        IA[i] = kin.inertia(i).general()
        pA[i] = tape.vector([add(x, -y) for x, y in zip(kin.gyroscopic(i), kin.external_wrench(i))], f"pA{n}")
    factors = [None] * nb
    for i in reversed(range(nb)):
        body, bk, n = tree.bodies[i], kin.bodies[i], i + 1
        tape.section(f"body {n} ({body.name}): articulated body, inward")
        u = [add(tau[tree.v_slots[i][k]], -dot(bk.S[k], pA[i])) for k in bk.free]
        factors[i] = f = _Pivots(tape, IA[i], [bk.S[k] for k in bk.free], u, f"{n}")
        if body.parent < 0:
            continue
        # Ia S = 0 and S^T pa = tau hold identically; where S is a unit coordinate vector e_r, that makes row and
        # column r of Ia and entry r of pa exact (sympy cannot see it through the temporaries).
        axes = {r: tau[tree.v_slots[i][k]] for k in bk.free for r in [_unit_index(bk.S[k])] if r is not None}
        Ia = IA[i]
        for j, (W, inv) in enumerate(zip(f.W, f.inv)):
            last = j == len(f.W) - 1
            Ia = Ia.minus_outer(tape, W, [mul(x, inv) for x in W], f"Ia{n}{j}", null=axes if last else ())
        Ia_c = Ia.apply(tape, bk.bias, f"Iac{n}")
        pa = tape.vector([axes[r] if r in axes else
                          add(pA[i][r], Ia_c[r], *(mul(W[r], zi) for W, zi in zip(f.W, f.z_scaled)))
                          for r in range(6)], f"pa{n}")
        p = body.parent
        IA[p] = IA[p].plus(tape, Ia.to_parent(tape, bk.X, f"IA{n}p"), f"IA{p + 1}")
        pA[p] = sadd(tape, pA[p], force_to_parent(tape, bk.X, pa, f"pa{n}p"), f"pA{p + 1}")
    vdot = [None] * tree.nv
    acc = [None] * nb
    a0 = _ground_acceleration(kin, True)
    for i in range(nb):
        body, bk, n = tree.bodies[i], kin.bodies[i], i + 1
        tape.section(f"body {n} ({body.name}): articulated body, accelerations")
        a_p = a0 if body.parent < 0 else acc[body.parent]
        a = ZERO6 if all(x is ZERO for x in a_p) else motion_to_child(tape, bk.X, a_p, f"aq{n}")
        a = tape.vector([add(x, y) for x, y in zip(a, bk.bias)], f"ab{n}")
        qdd = factors[i].solve(a)
        for k, value in zip(bk.free, qdd):
            vdot[tree.v_slots[i][k]] = value
        acc[i] = tape.vector([add(a[r], *(mul(bk.S[k][r], x) for k, x in zip(bk.free, qdd))) for r in range(6)],
                             f"aa{n}")
    return tuple(vdot)


def _unit_index(s) -> int | None:
    """r if the 6-vector s is exactly the unit vector e_r, else None."""
    nonzero = [r for r, x in enumerate(s) if x is not ZERO]
    return nonzero[0] if len(nonzero) == 1 and s[nonzero[0]] == 1 else None


class _Pivots:
    """LDL^T of one joint's D = S^T IA S, done with W = U L^-T (U = IA S): d_j = S_j.W_j, L_ij = S_i.W_j / d_j,
    W_j = U_j - sum_k<j L_jk W_k; then U D^-1 U^T = sum_j W_j W_j^T / d_j and D^-1 = L^-T diag(1/d) L^-1."""

    def __init__(self, tape: Tape, IA, S, u, tag: str):
        self.tape, self.tag = tape, tag
        n = len(S)
        self.W, self.inv, self.L = [], [], [[ZERO] * n for _ in range(n)]
        for j in range(n):
            U = IA.apply(tape, S[j], f"U{tag}{j}")
            W = tape.vector([add(U[r], *(-mul(self.L[j][k], self.W[k][r]) for k in range(j))) for r in range(6)],
                            f"W{tag}{j}") if j else U
            self.W.append(W)
            self.inv.append(tape.inverse(dot(S[j], W), f"iD{tag}{j}" if n > 1 else f"iD{tag}"))
            for i in range(j + 1, n):
                self.L[i][j] = tape.temp(mul(dot(S[i], W), self.inv[j]), f"L{tag}{i}{j}")
        # z = L^-1 u, then scaled by 1/d.
        self.z = []
        for j in range(n):
            self.z.append(tape.temp(add(u[j], *(-mul(self.L[j][k], self.z[k]) for k in range(j))), f"z{tag}{j}"))
        self.z_scaled = [tape.temp(mul(z, inv), f"zs{tag}{j}") for j, (z, inv) in enumerate(zip(self.z, self.inv))]

    def solve(self, a) -> list:
        """D^-1 (u - U^T a) = L^-T diag(1/d) (z - W^T a): the joint accelerations given the parent-side a."""
        n, tape, tag = len(self.W), self.tape, self.tag
        y = [tape.temp(mul(add(z, -dot(W, a)), inv), f"y{tag}{j}")
             for j, (z, W, inv) in enumerate(zip(self.z, self.W, self.inv))]
        x = [None] * n
        for j in reversed(range(n)):
            x[j] = tape.temp(add(y[j], *(-mul(self.L[i][j], x[i]) for i in range(j + 1, n))), f"qdd{tag}{j}")
        return x
