"""SUNDIALS IDA (variable-order BDF for implicit equations F(t, y, y') = 0) on the model in residual form
F = y' - f(t, y), with the generated Jacobian dF/dy + c dF/dy' = c I - J when the model has one.

The closed loops enter through the model's right-hand side (projected state), not yet as a stabilised
index-2 DAE with multipliers among the unknowns."""

from __future__ import annotations

import numpy as np

from .registry import register
from .sundials_common import SundialsSolver


@register
class Ida(SundialsSolver):
    name = "ida"
    description = "SUNDIALS IDA, BDF orders 1-5 on F = x' - f(t, x) (stiff)"

    def _make(self, settings):
        from sksundae import ida
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
