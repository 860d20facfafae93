"""Adams in C (c/adams.c): variable-step, variable-order Adams-Bashforth-Moulton, orders 1 to 12, PECE or PEC.

Two right-hand sides per step against DOPRI5's six (one where the step is small against the problem's time scale,
h L <= 0.05 at orders up to 6: PEC, the predicted state's f taken as the history's newest value), and high orders
where the solution is smooth: at tight tolerances on non-stiff models it reaches an accuracy with fewer right-hand
sides (python bench/adams.py).  At a
switch (an event without a jump of the state) it keeps its history and lets the order control step over the kink
(c/adams.c).
"""

from __future__ import annotations

import numpy as np

from .base import DenseOutput
from .native import NativeSolver
from .registry import register

#: ADAMS_KMAX of c/adams.c: the layout of its dense-output coefficients depends on it
KMAX = 12


class AdamsDense(DenseOutput):
    """y(t) = y_n + sum_i E_i h^(i+1) integral_0^s prod_{j<i} (u - r_j) du, s = (t - t_n)/h, as am_dense in C."""

    def __init__(self, t_old, t, cont, n):
        super().__init__(t_old, t)
        cont = np.asarray(cont)
        self.k = int(cont[0])
        self.t_n, self.h = float(cont[1]), float(cont[2])
        self.r = cont[3:3 + self.k].copy()
        base = 3 + KMAX + 2
        self.y0 = cont[base:base + n].copy()
        self.e = cont[base + n:base + (self.k + 2) * n].reshape(self.k + 1, n).copy()

    def _call_impl(self, t):
        s = (np.asarray(t, dtype=float) - self.t_n) / self.h
        coefficients = np.zeros((self.k + 2,) + s.shape)  # of the basis product, lowest power first
        coefficients[0] = 1.0
        weights = []
        for i in range(self.k + 1):
            powers = s[None] ** np.arange(1, i + 2).reshape((-1,) + (1,) * s.ndim)
            integral = np.sum(coefficients[:i + 1] * powers / np.arange(1, i + 2).reshape((-1,) + (1,) * s.ndim),
                              axis=0)
            weights.append(integral * self.h ** (i + 1))
            if i < self.k:
                shifted = np.zeros_like(coefficients)
                shifted[1:] = coefficients[:-1]
                coefficients = shifted - self.r[i] * coefficients
        weights = np.array(weights)  # [k + 1, ...]
        if s.ndim:
            return self.y0[:, None] + self.e.T @ weights
        return self.y0 + self.e.T @ weights


@register
class Adams(NativeSolver):
    name = "adams"
    description = "variable-order Adams-Bashforth-Moulton PECE/PEC in C (orders 1-12), dense output, history kept at events"
    native_method = "adams"
    dense_class = AdamsDense
