"""RODASP in C (c/rodasp.c): L-stable Rosenbrock 4(3) (Steinebach), finite-difference Jacobian, dense LU.

For stiff models (stiff tyre contact, bushings): the step size follows accuracy, not stability.
The Jacobian costs nx + 1 right-hand-side calls per step and the LU (nx^3)/3 flops, so it suits models
up to a few hundred states.
"""

from __future__ import annotations

import numpy as np

from .base import DenseOutput
from .native import NativeSolver
from .registry import register


class HermiteDense(DenseOutput):
    """Cubic Hermite interpolation through (y0, h f0) and (y1, h f1), as ro_dense in C."""

    def __init__(self, t_old, t, cont, n):
        super().__init__(t_old, t)
        self.c = np.asarray(cont[:4 * n]).reshape(4, n)
        self.h = float(cont[4 * n])

    def _call_impl(self, t):
        s = (t - self.t_old) / self.h
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        y0, y1, hf0, hf1 = (ci[:, None] if t.ndim else ci for ci in self.c)
        return h00 * y0 + h01 * y1 + h10 * hf0 + h11 * hf1


@register
class Rodasp(NativeSolver):
    name = "rodasp"
    description = "stiff Rosenbrock 4(3) in C with finite-difference Jacobian and dense output"
    native_method = "rodasp"
    dense_class = HermiteDense
