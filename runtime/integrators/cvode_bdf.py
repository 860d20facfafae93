"""SUNDIALS CVODE with backward differentiation formulas (orders 1-5), Newton iteration, dense LU: stiff models.

The generated Jacobian is used when the model has one; otherwise CVODE differences the right-hand side."""

from __future__ import annotations

from .registry import register
from .sundials_common import SundialsSolver


@register
class CvodeBdf(SundialsSolver):
    name = "cvode_bdf"
    description = "SUNDIALS CVODE, BDF orders 1-5 (stiff), generated Jacobian when present"
    method = "BDF"

    def _make(self, settings):
        from sksundae import cvode
        if self.jac is not None:
            settings["jacfn"] = lambda t, y, yp, J: J.__setitem__(slice(None), self.jac(t, y))
        solver = cvode.CVODE(lambda t, y, yp: self._f(t, y, yp), method=self.method, **settings)
        solver.init_step(self.t, self.y)
        return solver
