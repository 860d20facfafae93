"""Rodas5P in C (c/rodas5p.c on the engine c/rosenbrock.c): L-stable Rosenbrock 5(4) (Steinebach 2023) with
a dense output of order 4.

Eight right-hand sides, one Jacobian and one LU per step against RODASP's six; in return order 5 with its error
control on an order-4 solution, so at tight tolerances far fewer steps than RODASP, and on closed-loop
mechanisms about as few as dopri5 (python bench/rodasp_order.py).
"""

from __future__ import annotations

from .native import CoefficientDense, NativeSolver
from .registry import register


class Rodas5pDense(CoefficientDense):
    """y(t) = s1 y0 + s (y1 + s1 (w1 + s (w2 + s w3))), s = (t - t_old)/h, s1 = 1 - s, as rodas5p_dense in C."""

    rows = 5

    def _call_impl(self, t):
        s, (y0, y1, w1, w2, w3) = self.coefficients(t)
        s1 = 1.0 - s
        return s1 * y0 + s * (y1 + s1 * (w1 + s * (w2 + s * w3)))


@register
class Rodas5p(NativeSolver):
    name = "rodas5p"
    description = "stiff Rosenbrock 5(4) in C (Steinebach's Rodas5P), generated Jacobian, dense output of order 4"
    native_method = "rodas5p"
    dense_class = Rodas5pDense
