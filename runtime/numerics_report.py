"""A numerics report from the linearisation at the start: how stiff the model is and what to integrate it with.

    report = numerics_report(model, data, t_end, owners)      # data: parameters and start state
    print(report.text())

From the eigenvalues of d xdot / d x at the start (the generated Jacobian when the model has one, else central
differences; with closed loops the reduced eigenvalues of mbs.runtime.linearize, free of the loops' spurious
zeros): the spread |lambda|max / |lambda|min over the non-zero ones, the fastest and the slowest motion and the
coordinate that participates most in each (participation factors), the largest step DOPRI5 can take without
amplifying any mode faster than the exact solution grows (its stability function on h lambda), and from these
a recommended integrator and tolerance.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from math import factorial

import numpy as np

from .model import CompiledModel
from .workspace import Workspace

#: DOPRI5's stability polynomial: the Taylor terms to order 5 and the 6th-order coefficient of the method
#: (Hairer, Norsett, Wanner I, II.5: R(z) = sum_{k<=5} z^k/k! + z^6/600).
DOPRI5_STABILITY = [1.0 / factorial(k) for k in range(6)] + [1.0 / 600.0]
#: A model needing more explicit steps than this for stability alone over the run is called stiff.
STIFF_STEPS = 20_000
#: Eigenvalues below this fraction of the largest are rigid-body motions (zero up to round-off).
ZERO = 1e-9


@dataclass(frozen=True)
class Motion:
    eigenvalue: complex
    coordinate: str
    owner: str

    def describe(self) -> str:
        lam = self.eigenvalue
        kind = (f"{abs(lam.imag) / (2 * np.pi):.4g} Hz, damping ratio {-lam.real / abs(lam) + 0.0:.3g}"
                if abs(lam.imag) > 1e-9 * abs(lam) else f"time constant {1 / abs(lam):.3g} s")
        value = f"{lam.real:.4g}" + (f" +/- {abs(lam.imag):.4g}j" if abs(lam.imag) > 1e-9 * abs(lam) else "")
        return f"eigenvalue {value} 1/s ({kind}), mostly {self.coordinate}" + (f" ({self.owner})" if self.owner
                                                                               else "")


@dataclass(frozen=True)
class NumericsReport:
    eigenvalues: np.ndarray
    spread: float
    fastest: Motion | None
    slowest: Motion | None
    explicit_step: float      # largest stable DOPRI5 step [s] (inf when nothing limits it)
    explicit_steps: float     # steps DOPRI5 needs over the run for stability alone
    integrator: str
    rtol: float
    reason: str

    def text(self) -> str:
        lines = [f"eigenvalues: {self.eigenvalues.size} non-zero, spread |lambda|max/|lambda|min = {self.spread:.3g}"]
        if self.fastest:
            lines.append(f"fastest motion: {self.fastest.describe()}")
        if self.slowest:
            lines.append(f"slowest motion: {self.slowest.describe()}")
        lines.append(f"largest stable explicit (dopri5) step: {self.explicit_step:.3g} s "
                     f"(at least {self.explicit_steps:.3g} steps for the run by stability alone)")
        lines.append(f"recommended: integrator = {self.integrator}, rtol = {self.rtol:g} ({self.reason}); "
                     "check with `mbs accuracy`")
        return "\n".join(lines)


def numerics_report(model: CompiledModel, data: Workspace, t_end: float,
                    owners: Mapping[str, str] | None = None) -> NumericsReport:
    t, x = float(data.t), data.x.copy()
    A, names = _state_matrix(model, data, t, x)
    values, right = np.linalg.eig(A)
    left = np.linalg.inv(right)
    scale = np.max(np.abs(values), initial=0.0)
    keep = np.abs(values) > ZERO * scale
    motions = [Motion(complex(values[k]), *_culprit(names, right[:, k] * left[k], owners))
               for k in np.flatnonzero(keep)]
    motions.sort(key=lambda m: abs(m.eigenvalue))
    nonzero = values[keep]
    spread = float(np.max(np.abs(nonzero)) / np.min(np.abs(nonzero))) if nonzero.size else 1.0
    h = largest_stable_step(nonzero)
    steps = (t_end - t) / h if np.isfinite(h) and h > 0 else 0.0
    fastest = motions[-1] if motions else None
    stiff = steps > STIFF_STEPS and fastest is not None and -fastest.eigenvalue.real > 0.5 * abs(fastest.eigenvalue)
    if stiff:
        integrator = "rodas5p" if model.nx <= 200 else "cvode_bdf"
        reason = (f"stiff: the fastest motion is strongly damped and would hold an explicit method to "
                  f"{steps:.3g} steps")
    else:
        integrator, reason = "dopri5", "not stiff: an explicit method's steps follow accuracy"
    return NumericsReport(nonzero, spread, fastest, motions[0] if motions else None, h, steps, integrator, 1e-6,
                          reason)


def largest_stable_step(eigenvalues) -> float:
    """Largest h for which |R(h lambda)| <= max(1, |exp(h lambda)|) for every eigenvalue (DOPRI5's R): the step
    beyond which the method amplifies some mode faster than the mode itself grows."""
    lams = np.asarray(eigenvalues, dtype=complex)
    lams = lams[np.abs(lams) > 0]
    if lams.size == 0:
        return float("inf")
    coefficients = DOPRI5_STABILITY[::-1]

    def stable(h: float) -> bool:
        z = h * lams
        return bool(np.all(np.abs(np.polyval(coefficients, z)) <= np.maximum(1.0, np.abs(np.exp(z))) * (1 + 1e-12)))

    hi = 10.0 / np.max(np.abs(lams))  # |R| ~ |z|^6/600 > 1 beyond |z| ~ 3 in every direction
    lo = 0.0
    for h in np.geomspace(hi * 1e-6, hi, 200):  # the first unstable step on a fine grid, then bisection
        if not stable(h):
            hi = h
            break
        lo = h
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def _state_matrix(model, data, t, x) -> tuple[np.ndarray, list[str]]:
    """(d xdot/d x, the coordinate each row belongs to); with closed loops the reduced matrix, its coordinates
    named by the tree coordinate each basis vector of the constraints' null space moves most."""
    from .linearize import jacobian, linearize, position_names
    names = list(model.q_names) + list(position_names(model.v_names))
    if "jacobian" in model.functions:
        return data.jacobian(t, x)[:, :-1], names
    if "project" in model.functions:  # closed loops: the reduced matrix has no spurious zero eigenvalues
        lin = linearize(model, data, t, x)
        speeds = position_names(model.v_names)
        reduced = [speeds[int(np.argmax(np.abs(lin.basis[:, k])))] for k in range(lin.dof)]
        return lin.A_reduced, reduced + reduced
    return jacobian(data, t, x), names


def _culprit(names, participation, owners) -> tuple[str, str]:
    strength: dict = {}
    for name, amount in zip(names, np.abs(participation)):
        strength[name] = strength.get(name, 0.0) + float(amount)
    name = max(strength, key=strength.get)
    return name, (owners or {}).get(name, "")
