"""SUNDIALS IDA (variable-order BDF for implicit equations F(t, y, y') = 0). A tree is integrated in residual
form F = y' - f(t, y), with the generated Jacobian dF/dy + c dF/dy' = c I - J when the model has one. A closed
mechanism is integrated as the stabilised index-2 DAE of ggl.py (constraints as equations, multipliers among
the unknowns, no projection), which continues in the residual form of the projected state where its rows
lose rank (a singular position: from the last accepted state where they are still well conditioned, since the
states the DAE form accepts right before its Newton iteration fails there carry errors of 1e-3 in the
velocities); the results hold its state x = [q; v] as for every other integrator."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from .ggl import GGL
from .registry import register
from .sundials_common import SundialsSolver


@register
class Ida(SundialsSolver):
    name = "ida"
    description = "SUNDIALS IDA, BDF orders 1-5 on F = x' - f(t, x), closed loops as an index-2 DAE (stiff)"
    #: simulate passes the workspace: closed loops need the model's functions, not only its rhs
    uses_workspace: ClassVar[bool] = True

    def __init__(self, fun, t0, y0, t_bound, *, workspace=None, **options):
        self._ggl = None
        self.switched_to_ode = None  # the time from which the DAE form gave way to the ODE form (else None)
        self._ode_next = False  # the DAE form's rows are near losing rank: the next step in the ODE form
        if workspace is not None and "constraint_jacobian" in workspace.model.functions:
            self._ggl = GGL(workspace, t0, y0)
            y0 = self._ggl.y0[:self._ggl.nx]
            if options.get("events") is not None:  # the indicators read the state, not the multipliers
                g, *rest = options["events"]
                nx = self._ggl.nx
                options["events"] = (lambda t, y: g(t, y[:nx]), *rest)
        super().__init__(fun, t0, y0, t_bound, **options)

    def _make(self, settings):
        from sksundae import ida
        self._settings = dict(settings)  # before the DAE form adds its own: the ODE form may start later
        if self._ggl is not None:
            ggl = self._ggl
            settings.update(atol=ggl.atol(settings["atol"]), algebraic_idx=ggl.algebraic)
            solver = ida.IDA(ggl.residual, **settings)
            solver.init_step(self.t, ggl.y0, ggl.yp0)
            return solver
        n = self.n
        scratch = np.empty(n)

        def residual(t, y, yp, res):
            self._f(t, y, scratch)
            res[:] = yp - scratch

        if self.jac is not None:
            eye = np.eye(n)

            def jacobian(t, y, yp, res, cj, J):
                J[:, :] = cj * eye - self.jac(t, y)

            settings["jacfn"] = jacobian
        solver = ida.IDA(residual, **settings)
        yp0 = np.asarray(self.fun(self.t, self.y), dtype=float)
        solver.init_step(self.t, self.y, yp0)
        return solver

    def _step_impl(self):
        if self._ggl is not None and self._ode_next:  # after the samples inside the DAE form's last step
            self._continue_as_ode()
        ok, reason = super()._step_impl()
        if self._ggl is not None:
            full = self.y
            self.y = self.y[:self._ggl.nx]  # the multipliers stay inside
            if not ok and self._error is None:
                self._continue_as_ode()
                return super()._step_impl()
            self._ode_next = ok and self._ggl.near_singular(self.t, full)
        return ok, reason

    def _continue_as_ode(self):
        """The DAE form's rows are chosen once; at a singular position of the loops (a four-bar stretched flat)
        they lose rank and its Newton iteration fails.  From the last accepted state (the first one whose rows
        are near losing rank, or the last before a failure) the run goes on in the residual form of the
        projected tree state, F = x' - f(P(x)), which the loop solver carries through such positions (the limit
        of the motion, runtime/c/loops.c); counters restart with the new solver.  On the 40-four-bar chain at
        rtol 1e-8 the switch at the failure (t = 1.244 s) kept a velocity error of 1.1e-3 rad/s, and the crank
        ended 0.19 rad off after 20 s."""
        self._ggl = None
        self.switched_to_ode = self.t
        self._solver = self._make(dict(self._settings))

    def _interpolate(self, t: float) -> np.ndarray:
        y = super()._interpolate(t)
        return y[:self._ggl.nx] if self._ggl is not None else y
