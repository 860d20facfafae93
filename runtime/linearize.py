"""Linearisation of a compiled model about a state: Jacobians, eigenvalues, natural frequencies, mode shapes.

    lin = linearize(model, data, t, x)           # x typically the static equilibrium
    lin.frequencies, lin.damping_ratios, lin.modes[0].dominant(3), lin.undamped_frequencies

Why reduced coordinates. The state x = [q; v] is the spanning tree's; with closed loops the right-hand side
first projects x onto the constraints, so d(xdot)/dx has one spurious zero eigenvalue per constraint row and
coordinate (the directions that the projection throws away), and with quaternions q has one coordinate more
per quaternion than there are rotations. Neither is a physical mode. So the modes are computed in local
coordinates of the constraint manifold: with E(q) the nq x nv matrix of qdot(q, v) = E(q) v and N an
orthonormal basis of the null space of the constraint Jacobian G(q) (nc x nv; N = I without loops),

    x(a, b) = [ normalize(q0 + E0 N a) ;  v0 + N b ]           a, b in R^dof,

and the reduced rates are a' = N^T E0^+ q',  b' = N^T v'. The chart is the identity to first order in
the tangent space (the projection inside the rhs and the renormalisation of quaternions only move x by second
order terms, which cancel in central differences), so A_red = d(a', b')/d(a, b) at 0 has exactly 2 dof
eigenvalues, the mechanism's. Its eigenvalues do not depend on the (metric) choice of N.

Steps (central differences): h = STEP = 1e-6 in the units of each state (m, rad, m/s, rad/s), scaled by
max(1, |x_i|) for the full-state Jacobian. It balances the two errors. Noise: not eps (which would suggest
eps^(1/3) ~ 6e-6) but the loop projection's Newton tolerance (MBS_LOOP_TOL = 1e-12 m or rad) inside every rhs
call, an error ~ 1e-12 m / h = 1e-6 relative to a stiffness entry. Truncation ~ (h / L)^2 with L the length
scale of the nonlinearities near an equilibrium (tyre deflection, spring end stops, damper polynomials:
millimetres), (1e-6 / 1e-3)^2 = 1e-6 relative. Kinks (a unilateral tyre exactly at lift-off, an end stop exactly at its
break) have no derivative; there the result is the mean of the two one-sided slopes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import UsageError
from .mode_energy import energy_shares, mode_name
from .model import CompiledModel
from .workspace import Workspace, check_workspace

#: Finite-difference step in state units (see the module docstring for why).
STEP = 1e-6
#: Singular values of G below this fraction of the largest count as zero: redundant constraint rows
#: (the assembly's RCOND; the C loop solver uses 1e-9 on pivots).
RCOND = 1e-10
#: A rigid-body motion (zero stiffness, zero damping: a vehicle's travel, side shift and yaw) comes out of the
#: finite differences as omega^2 ~ 1e-8 of the largest omega^2 at worst (the noise of the module docstring,
#: ~1e-6 of a stiffness entry, seen at ~1e-12 on the Iltis vehicle), hence |lambda| ~ 1e-4 of the largest:
#: below these fractions an eigenvalue or omega^2 counts as zero (0 Hz). A genuine mode four decades below
#: the stiffest one would be reported as rigid.
RIGID_STIFFNESS = 1e-8
ZERO_EIGENVALUE = RIGID_STIFFNESS ** 0.5


@dataclass(frozen=True)
class Mode:
    """One eigenvalue and its shape, by coordinate.

    eigenvalue [1/s]; frequency: undamped natural frequency |lambda| / (2 pi) [Hz]; damping_ratio:
    -Re(lambda) / |lambda| (1 for a real decaying eigenvalue, negative when unstable, 0 for a rigid-body
    motion); oscillatory: a complex pair (reported once, Im > 0; rigid-body motions, |lambda| at the noise
    level, are listed one by one and never oscillatory); shape: {coordinate: complex amplitude} of
    the position part in velocity coordinates (for a coordinate 'j.phi' the name 'j.phi', for a quaternion
    the rotation components 'j.wx'...), scaled so the largest has modulus 1."""

    eigenvalue: complex
    frequency: float
    damping_ratio: float
    oscillatory: bool
    shape: dict
    kinetic: dict = field(default_factory=dict)    # {group (part, corner): share of the kinetic energy}
    potential: dict = field(default_factory=dict)  # {group: share of the potential energy}; see mode_energy
    name: str = ""                                 # 'car bounce', 'fl arm_bearing.phi': from the energy

    def dominant(self, n: int = 3, threshold: float = 0.1) -> list[tuple[str, float]]:
        """The n coordinates with the largest amplitudes (at least `threshold` of the largest)."""
        ranked = sorted(((name, abs(a)) for name, a in self.shape.items()), key=lambda p: -p[1])
        return [(name, amp) for name, amp in ranked[:n] if amp >= threshold]


@dataclass(frozen=True)
class Linearization:
    """The linear model about (t, x).

    A: (nx, nx) d(xdot)/dx of the right-hand side as it is (with the spurious directions of loops and
    quaternions); A_reduced: (2 dof + nz, 2 dof + nz) in the manifold coordinates (a, b) of the module docstring
    and the extra differential states z (language/states.py) as they are;
    basis: (nv, dof) N; E: (nq, nv) qdot(q, v) = E v at x; modes: physical modes, oscillatory pairs once,
    sorted by frequency; eigenvalues: all 2 dof + nz eigenvalues of A_reduced; undamped_frequencies [Hz]: from
    the stiffness part alone, sqrt(eig(-A_ab A_ba)) / (2 pi), ascending (NaN where negative: unstable)."""

    t: float
    x: np.ndarray
    A: np.ndarray
    A_reduced: np.ndarray
    basis: np.ndarray
    E: np.ndarray
    eigenvalues: np.ndarray
    modes: tuple
    undamped_frequencies: np.ndarray
    coordinate_names: tuple
    dof: int
    state_space: object = None  # runtime.statespace.StateSpace: B, C, D for the inputs and outputs

    @property
    def B(self) -> np.ndarray:
        return self._ss().B

    @property
    def C(self) -> np.ndarray:
        return self._ss().C

    @property
    def D(self) -> np.ndarray:
        return self._ss().D

    def to_scipy(self):
        """scipy.signal.StateSpace of x' = A x + B u, y = C x + D u."""
        return self._ss().to_scipy()

    def to_control(self):
        """control.StateSpace with signal names (python-control, when installed)."""
        return self._ss().to_control()

    def _ss(self):
        if self.state_space is None:
            raise UsageError("this linearisation has no input/output model (made by runtime.linearize alone; "
                             "System.linearize adds B, C, D)")
        return self.state_space

    @property
    def frequencies(self) -> np.ndarray:
        return np.array([m.frequency for m in self.modes])

    @property
    def damping_ratios(self) -> np.ndarray:
        return np.array([m.damping_ratio for m in self.modes])

    def table(self) -> str:
        """The modes as a text table: frequency, damping ratio, eigenvalue, dominant coordinates."""
        energies = any(m.kinetic for m in self.modes)
        last = "name: energy share kinetic/potential by part" if energies else "dominant coordinates"
        lines = [f"{'mode':>4}  {'f [Hz]':>10}  {'damping [1]':>11}  {'eigenvalue [1/s]':>24}  {last}"]
        for i, m in enumerate(self.modes, 1):
            lam = m.eigenvalue
            ev = f"{lam.real:.5g} {'+' if lam.imag >= 0 else '-'} {abs(lam.imag):.5g}j" if m.oscillatory \
                else f"{lam.real:.5g}"
            if m.kinetic:
                groups = list(dict.fromkeys([*list(m.kinetic)[:2], *list(m.potential)[:1]]))
                shares = ", ".join(f"{g} {100 * m.kinetic.get(g, 0):.0f}/{100 * m.potential.get(g, 0):.0f} %"
                                   for g in groups)
                dom = f"{m.name}: {shares}"
            else:
                dom = ", ".join(f"{name} {amp:.2f}" for name, amp in m.dominant())
            lines.append(f"{i:>4}  {m.frequency:>10.5g}  {m.damping_ratio:>11.4g}  {ev:>24}  {dom}")
        return "\n".join(lines)


def position_names(v_names) -> tuple[str, ...]:
    """Names of position increments in velocity coordinates: 'der(j.phi)' -> 'j.phi', 'j.wx' stays."""
    return tuple(n[4:-1] if n.startswith("der(") and n.endswith(")") else n for n in v_names)


def jacobian(data: Workspace, t: float, x, step: float = STEP) -> np.ndarray:
    """d(rhs)/dx at (t, x) by central differences, step h_i = step * max(1, |x_i|)."""
    x = np.array(x, dtype=float)
    n = x.size
    A = np.empty((n, n))
    for i in range(n):
        h = step * max(1.0, abs(x[i]))
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        A[:, i] = (data.rhs(t, xp) - data.rhs(t, xm)) / (2 * h)
    return A


def _qdot_matrix(data: Workspace, t: float, x: np.ndarray, nq: int, nv: int) -> np.ndarray:
    """E with qdot = E(q) v (qdot is linear in v): column k is qdot(q, e_k)."""
    E = np.empty((nq, nv))
    probe = x.copy()
    for k in range(nv):
        probe[nq:] = 0.0
        probe[nq + k] = 1.0
        E[:, k] = data.qdot(t, probe)
    return E


def _null_space(data: Workspace, t: float, x: np.ndarray, nv: int) -> np.ndarray:
    if "constraint_jacobian" not in data.model.functions:
        return np.eye(nv)
    G = data.constraint_jacobian(t, x)
    if G.size == 0:
        return np.eye(nv)
    _, s, vt = np.linalg.svd(G)
    rank = int(np.sum(s > RCOND * s[0])) if s.size and s[0] > 0 else 0
    return vt[rank:].T.copy()


def linearize(model: CompiledModel, data: Workspace, t: float, x, step: float = STEP,
              groups: dict | None = None) -> Linearization:
    """The linear model of `model` with the parameters in `data` about (t, x); prescribed motions are taken
    at time t and held (their rates enter through the rhs at t). groups: {coordinate: part or corner} for
    the modes' energy shares and names (mode_energy.part_groups; default: by joint)."""
    check_workspace(model, data)
    x = np.array(x, dtype=float)
    if x.shape != (model.nx,):
        raise UsageError(f"x needs shape ({model.nx},), got {x.shape}")
    nq, nv, nz = model.nq, model.nv, model.nz
    if "normalize" in model.functions:
        x = data.normalize(t, x)
    if "project" in model.functions:
        x = data.project(t, x)
    E = _qdot_matrix(data, t, x, nq, nv)
    E_pinv = np.linalg.pinv(E)
    N = _null_space(data, t, x, nv)
    dof = N.shape[1]

    def chart(z: np.ndarray) -> np.ndarray:
        out = x.copy()
        out[:nq] += E @ (N @ z[:dof])
        out[nq:nq + nv] += N @ z[dof:2 * dof]
        out[nq + nv:] += z[2 * dof:]  # the extra differential states as they are
        return data.normalize(t, out) if "normalize" in model.functions else out

    def reduced_rate(z: np.ndarray) -> np.ndarray:
        xdot = data.rhs(t, chart(z))
        return np.concatenate([N.T @ (E_pinv @ xdot[:nq]), N.T @ xdot[nq:nq + nv], xdot[nq + nv:]])

    size = 2 * dof + nz
    A_red = np.empty((size, size))
    for i in range(size):
        z = np.zeros(size)
        z[i] = step
        A_red[:, i] = (reduced_rate(z) - reduced_rate(-z)) / (2 * step)
    A = jacobian(data, t, x, step)

    eigenvalues, vectors = np.linalg.eig(A_red) if size else (np.zeros(0, complex), np.zeros((0, 0)))
    names = position_names(model.v_names)
    modes = []
    largest = np.max(np.abs(eigenvalues), initial=0.0)
    for lam, vec in zip(eigenvalues, vectors.T):
        magnitude = abs(lam)
        rigid = magnitude <= ZERO_EIGENVALUE * largest  # every one listed: their pairing is noise
        if lam.imag < 0 and not rigid:
            continue  # the conjugate of a pair is reported once
        shape = N @ vec[:dof]
        if np.max(np.abs(shape), initial=0.0) == 0.0:
            shape = N @ vec[dof:2 * dof]
        mechanical = np.max(np.abs(shape), initial=0.0) > 0.0
        shape = np.concatenate([shape, vec[2 * dof:]])  # with the extra states' amplitudes
        shape = shape / shape[np.argmax(np.abs(shape))]
        shape_map = {n: complex(a) for n, a in zip(names + model.z_names, shape)}
        kinetic, potential, name = {}, {}, ""
        if not mechanical:  # a mode of the extra states alone (an actuator lag's, an integrator's)
            name = "state " + max(model.z_names, key=lambda n: abs(shape_map[n]))
        elif "mass_matrix" in model.functions and "forces" in model.functions:
            kinetic, potential = energy_shares(data, t, x, E, shape[:len(names)], names, groups or {}, step)
            name = "rigid-body motion" if rigid else mode_name(kinetic, potential, shape_map, groups or {})
        modes.append(Mode(complex(lam), 0.0 if rigid else magnitude / (2 * np.pi),
                          0.0 if rigid else -lam.real / magnitude + 0.0, bool(lam.imag > 0 and not rigid),
                          shape_map, kinetic, potential, name))
    modes.sort(key=lambda m: (m.frequency, -m.damping_ratio))

    # stiffness part only: a' = A_ab b (+ A_aa a, zero at rest), b' = A_ba a + A_bb b; drop A_bb (damping)
    # and A_aa: a'' = A_ab A_ba a, so omega^2 are the eigenvalues of -A_ab A_ba
    A_ab, A_ba = A_red[:dof, dof:], A_red[dof:, :dof]
    w2 = np.sort(np.linalg.eigvals(-A_ab @ A_ba).real) if dof else np.zeros(0)
    floor = RIGID_STIFFNESS * np.max(np.abs(w2), initial=0.0)  # rigid-body motions: zero up to the noise
    w2 = np.where(np.abs(w2) <= floor, 0.0, w2)
    undamped = np.where(w2 >= 0.0, np.sqrt(np.abs(w2)), np.nan) / (2 * np.pi)
    return Linearization(float(t), x, A, A_red, N, E, eigenvalues, tuple(modes), undamped, names, dof)
