"""Rodas5P in C (c/rodas5p.c on the engine c/rosenbrock.c): L-stable Rosenbrock 5(4) (Steinebach 2023) with
a dense output of order 4.

Eight right-hand sides, one Jacobian and one LU per step against RODASP's six; in return order 5 with its error
control on an order-4 solution, so at tight tolerances far fewer steps than RODASP, and on closed-loop
mechanisms about as few as dopri5 (python bench/rodasp_order.py).
"""

from __future__ import annotations

import numpy as np

from .base import DenseOutput
from .native import NativeSolver
from .registry import register


class Rodas5pDense(DenseOutput):
    """y(t) = s1 y0 + s (y1 + s1 (w1 + s (w2 + s w3))), s = (t - t_old)/h, s1 = 1 - s, as rodas5p_dense in C."""

    def __init__(self, t_old, t, cont, n):
        super().__init__(t_old, t)
        self.c = np.asarray(cont[:5 * n]).reshape(5, n)
        self.h = float(cont[5 * n])

    def _call_impl(self, t):
        s = (t - self.t_old) / self.h
        s1 = 1.0 - s
        y0, y1, w1, w2, w3 = (ci[:, None] if t.ndim else ci for ci in self.c)
        return s1 * y0 + s * (y1 + s1 * (w1 + s * (w2 + s * w3)))


@register
class Rodas5p(NativeSolver):
    name = "rodas5p"
    description = "stiff Rosenbrock 5(4) in C (Steinebach's Rodas5P), generated Jacobian, dense output of order 4"
    native_method = "rodas5p"
    dense_class = Rodas5pDense
