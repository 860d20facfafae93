"""RODASP in C (c/rodasp.c on the engine c/rosenbrock.c): L-stable Rosenbrock 4(3) (Steinebach), dense LU.

For stiff models (stiff tyre contact, bushings): the step size follows accuracy, not stability.
The Jacobian is the generated one (finite differences, nx + 1 right-hand-side calls, where there is none) and
the LU costs (nx^3)/3 flops per step, so it suits models up to a few hundred states.
"""

from __future__ import annotations

from .native import CoefficientDense, NativeSolver
from .registry import register


class HermiteDense(CoefficientDense):
    """Cubic Hermite interpolation through (y0, h f0) and (y1, h f1), as rodasp_dense in C."""

    rows = 4

    def _call_impl(self, t):
        s, (y0, y1, hf0, hf1) = self.coefficients(t)
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        return h00 * y0 + h01 * y1 + h10 * hf0 + h11 * hf1


@register
class Rodasp(NativeSolver):
    name = "rodasp"
    description = "stiff Rosenbrock 4(3) in C with finite-difference Jacobian and dense output"
    native_method = "rodasp"
    dense_class = HermiteDense
