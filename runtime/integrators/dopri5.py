"""DOPRI5 in C (c/dopri5.c): Dormand-Prince 5(4), Hairer's step control, 4th-order dense output.

The default integrator of the C back end: non-stiff vehicle models at moderate tolerances.
"""

from __future__ import annotations

from .native import CoefficientDense, NativeSolver
from .registry import register


class Dopri5Dense(CoefficientDense):
    """y(t) = c0 + s (c1 + (1-s) (c2 + s (c3 + (1-s) c4))), s = (t - t_old)/h, as dp_dense in C."""

    rows = 5

    def _call_impl(self, t):
        s, (c0, c1, c2, c3, c4) = self.coefficients(t)
        s1 = 1.0 - s
        return c0 + s * (c1 + s1 * (c2 + s * (c3 + s1 * c4)))


@register
class Dopri5(NativeSolver):
    name = "dopri5"
    description = "explicit Runge-Kutta 5(4) in C, dense output, no Python per step"
    native_method = "dopri5"
    dense_class = Dopri5Dense
