"""Several load-dependent friction elements (``normal = reaction``) in one model, with any others.

Each loaded element l slips with F_l = sigma_l c_l rho_l, rho_l = |R_l| the load its joint carries, and R_l =
R0_l + B_l F is affine in all the friction forces (compiler/friction.py). With the loads rho as unknowns the rest is
linear: the rows of the sticking elements (a0 + W F = 0) and of the slipping ones (their kinetic forces) give
F = F0 + H rho, so R_l = P_l + Q_l rho, and the loads solve the m equations |P_l + Q_l rho| = rho_l. One element
alone is a quadratic equation, solved exactly by compiler/friction.py's _bearing; several are coupled through
the off-diagonal columns of Q (one pin's friction torque changes the accelerations and so the other pin's load).

They are solved by Newton's method on the tape, a fixed number of steps (the generated code has no loops) from a
start that is exact when the coupling is absent: each element's own quadratic with the others' loads at zero.
The coupling is of the order of mu r |dR/dT|, itself below 1 wherever the law has a solution at all (Painleve),
and Newton's error squares per step, so NEWTON_STEPS steps reach round-off for any practical bearing; the tests
check |F_l| = mu r |R_l| against the reaction sensors (an independent inverse dynamics) to 1e-10.
"""

from __future__ import annotations

import sympy as sp

from .spatial import add, dot, mul

#: Newton steps on the loads (quadratic convergence from an error of the order of the coupling).
NEWTON_STEPS = 3


def solve_loaded(tape, elements, a0, W, R0, B, linear_solve, sticks, affine_split):
    """(forces, loads of the loaded elements at the solution) for `elements` (compiler/friction.py's _Element),
    R0[l], B[l] the load vector of the l-th loaded element and its slope in the forces (3 x n)."""
    loaded = [i for i, e in enumerate(elements) if e.load is not None]
    rho = [sp.Symbol(f"friction.load{l}") for l in range(len(loaded))]
    n = len(elements)
    kinetic = []
    for i, e in enumerate(elements):
        if e.load is not None:
            kinetic.append(-e.mode * e.mu * e.load * e.lever * rho[loaded.index(i)])
        else:
            kinetic.append(-e.mode * e.mu * e.normal * (e.lever if e.direction is None else e.direction))
    A = [[add(mul(sticks(e), W[i][j]), (1 - sticks(e)) if i == j else 0) for j in range(n)]
         for i, e in enumerate(elements)]
    b = [add(-sticks(e) * a0[i], (1 - sticks(e)) * kinetic[i]) for i, e in enumerate(elements)]
    tape.section("friction: the forces for given bearing loads, and the loads they make")
    forces = linear_solve(tape, A, b)
    vectors = [[add(R0[l][c], *(mul(B[l][c][j], forces[j]) for j in range(n))) for c in range(3)]
               for l in range(len(loaded))]
    targets = [c for v in vectors for c in v] + list(forces)
    zero, slope = affine_split(tape, targets, rho)
    m = len(loaded)
    P = [zero[3 * l:3 * l + 3] for l in range(m)]
    Q = [[[slope[3 * l + c][k] for k in range(m)] for c in range(3)] for l in range(m)]
    F0, H = zero[3 * m:], slope[3 * m:]
    loads = loads_by_newton(tape, P, Q, linear_solve)
    tape.section("friction: the forces at the bearing loads")
    solved = [tape.temp(add(F0[i], *(mul(H[i][k], loads[k]) for k in range(m))), f"friction_force{i}")
              for i in range(n)]
    return solved, loaded


def loads_by_newton(tape, P, Q, linear_solve) -> list:
    """The loads rho (m of them) with |P_l + sum_k Q_lk rho_k| = rho_l, P[l] a load vector (3 components), Q[l][c][k]
    its slope in rho_k: each element's own quadratic, then NEWTON_STEPS Newton steps when they are coupled."""
    m = len(P)
    tape.section("friction: the bearing loads by Newton's method from each element's own quadratic")
    loads = []
    for l in range(m):
        q = [Q[l][c][l] for c in range(3)]
        pq, pp, qq = (tape.temp(dot(x, y), f"friction_start{l}") for x, y in ((P[l], q), (P[l], P[l]), (q, q)))
        # 1 - q.q > 0 unless the law has no unique solution (Painleve): NaN then, as for one element
        root = tape.temp(sp.sqrt(1 - qq), f"friction_root_alpha{l}")
        alpha = tape.temp(root * root, f"friction_alpha{l}")
        loads.append(tape.temp((pq + sp.sqrt(pq ** 2 + alpha * pp)) / alpha, f"friction_load{l}"))
    for step in range(NEWTON_STEPS if m > 1 else 0):
        V = [[tape.temp(add(P[l][c], *(mul(Q[l][c][k], loads[k]) for k in range(m))), f"friction_R{l}")
              for c in range(3)] for l in range(m)]
        size = [tape.temp(sp.sqrt(dot(v, v)), f"friction_R{l}") for l, v in enumerate(V)]
        inverse = [tape.temp(1 / s, f"friction_iR{l}") for l, s in enumerate(size)]
        # (I - V_l.Q_lk / |V_l|) d = |V| - rho: diagonal near 1, so no pivoting
        J = [[tape.temp(add(1 if l == k else 0, -mul(dot(V[l], [Q[l][c][k] for c in range(3)]), inverse[l])),
                        f"friction_J{l}{k}") for k in range(m)] for l in range(m)]
        d = linear_solve(tape, J, [tape.temp(size[l] - loads[l], f"friction_f{l}") for l in range(m)])
        loads = [tape.temp(loads[l] + d[l], f"friction_load{l}") for l in range(m)]
    return loads


__all__ = ["NEWTON_STEPS", "loads_by_newton", "solve_loaded"]
