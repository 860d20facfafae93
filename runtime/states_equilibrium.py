"""The static equilibrium of a model with extra differential states (language/states.py).

At rest the speeds vanish and neither the accelerations nor the extra states' rates may: an integrator state
settles where its input is zero, a lag where it has caught up with its command. The unknowns are the
coordinates and the extra states, (q, z), and the conditions vdot(q, 0, z) = 0 and zdot(q, 0, z) = 0: square
for joints without quaternions, solved by MINPACK's hybrid Powell method (least squares otherwise, and with
closed loops, where the right-hand side projects the coordinates so that the dependent ones have no effect:
the solution is then projected onto the constraints). The relaxation
of runtime/equilibrium.py (stop the parts at the kinetic energy's peak, start again) has no meaning for a state
that is not a motion, so it is not used here.
"""

from __future__ import annotations

import numpy as np

from mbs.language.diagnostics import Diagnostic, MbsError

from .model import CompiledModel
from .workspace import Workspace

#: Residual (accelerations in m/s^2 or rad/s^2, state rates in their units per second) accepted as rest.
TOLERANCE = 1e-8
#: Weight [1/s^2] of the rows PIN * (u - u0) the least-squares solve adds to the conditions. Those can leave
#: unknowns free (a car on a flat road stands anywhere, facing any way), and least squares drifted along them by
#: whatever the round-off of its steps made of them: the Iltis's steering scene with tyre relaxation started
#: 4 mm ahead or 52 mm back, yawed by 0.003 or 0.45 degrees, after a change of its right-hand side in the last
#: bits, or stopped at a point whose loops could not be closed (and the tests of
#: tests/library/test_iltis_relaxation.py passed or failed on which). With the rows it starts at the guess's x, y
#: and yaw. Along the other directions (stiffnesses of 1 to 1e4 m/s^2 per m or rad) they shift the solution by
#: about PIN^2 / stiffness times its distance from the guess, far below TOLERANCE. 1e-6 was too weak to steer
#: the steps: that scene's solve stopped with a residual of 335 m/s^2.
PIN = 1e-4


def equilibrium_with_states(model: CompiledModel, data: Workspace, x0, t: float = 0.0) -> np.ndarray:
    """x = [q; 0; z] at rest with every acceleration and state rate zero, from the guess x0 (the coordinates
    and the extra states as they are there); MbsError when there is none."""
    nq, nv = model.nq, model.nv
    x = np.array(x0, dtype=float)
    x[nq:nq + nv] = 0.0

    def state(u: np.ndarray) -> np.ndarray:
        out = x.copy()
        out[:nq], out[nq + nv:] = u[:nq], u[nq:]
        return data.normalize(t, out) if "normalize" in model.functions else out

    def residual(u: np.ndarray) -> np.ndarray:
        return data.rhs(t, state(u))[nq:]

    from scipy.optimize import least_squares, root  # only a model with extra states needs them: not at start-up

    u0 = np.concatenate([x[:nq], x[nq + nv:]])
    loops = "project" in model.functions  # closed loops: rhs projects q, so the dependent ones do not count
    if nq == nv and not loops:
        sol = root(residual, u0, method="hybr", options={"xtol": 1e-13})
        u = sol.x
    else:
        u = least_squares(lambda u: np.concatenate([residual(u), PIN * (u - u0)]), u0, xtol=1e-14, ftol=1e-14).x
    worst = float(np.max(np.abs(residual(u)), initial=0.0))
    if not worst <= TOLERANCE:
        names = model.v_names + model.z_names
        k = int(np.argmax(np.abs(residual(u))))
        raise MbsError([Diagnostic("error", f"no static equilibrium with the extra states at rest: the rate of "
                                            f"'{names[k]}' stays at {worst:.3g} (a state that integrates "
                                            "without bound, or a part with nothing to hold it)", None)])
    return data.function("project")(t, state(u)) if loops else state(u)


def rest_residual(model: CompiledModel, data: Workspace, x: np.ndarray, t: float = 0.0) -> tuple[float, str]:
    """(largest |acceleration or state rate|, its name) at x: what is left of the equilibrium."""
    r = np.abs(data.rhs(t, x)[model.nq:])
    k = int(np.argmax(r)) if r.size else 0
    return (float(r[k]), (model.v_names + model.z_names)[k]) if r.size else (0.0, "")
