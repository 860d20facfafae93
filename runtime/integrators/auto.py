"""``auto``: DOPRI5 while the model is not stiff, Rodas5P from the moment DOPRI5 finds that it is.

The switch follows Hairer's stiffness test inside DOPRI5 (c/dopri5.c): when the step has been held at the
stability boundary (h |lambda| > 3.25) for 15 accepted steps, the explicit method stops there and the
L-stable Rosenbrock method (with the generated Jacobian when the model has one) continues from the same
state, as LSODA or DifferentialEquations.jl's AutoTsit5(Rosenbrock23) do. A model that is stiff at all is
usually stiff for good (a stiff bushing, a tyre), so the switch is one way: Rodas5P stays to the end. Rodas5P
rather than RODASP: on the stiff mount at rtol 1e-8 it takes 404 steps and 3,234 right-hand sides against
RODASP's 1,316 and 7,898, and ends 18 times closer to the reference (python bench/integrators.py --models
stiff_mount).
Both run in C; the samples of the two phases join seamlessly.
"""

from __future__ import annotations

from .base import FAILED, RUNNING, OdeSolver
from .dopri5 import Dopri5
from .native import STIFF
from .registry import register
from .rodas5p import Rodas5p


@register
class Auto(OdeSolver):
    name = "auto"
    description = "dopri5, switching to rodas5p when dopri5's stiffness test fires (both in C)"

    def __init__(self, fun, t0, y0, t_bound, **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        self._options = options
        self.active = Dopri5(fun, t0, y0, t_bound, **options)
        self.active.stop_on_stiffness()
        self.switched_at: float | None = None
        self._done = {"nfev": 0, "njev": 0, "nlu": 0, "nsteps": 0, "nreject": 0}
        self._sync()

    @property
    def stiffness(self):
        """The stiffness DOPRI5 found ({"t", "h", "h_lambda"}), or None."""
        return self._stiffness

    def _switch(self) -> None:
        """Rodas5P from DOPRI5's last accepted state on."""
        first = self.active
        self._stiffness = first.stiffness
        self.switched_at = first.t
        for key, value in first.stats.items():
            self._done[key] += value
        options = dict(self._options, max_steps=max(1, self.max_steps - first.nsteps))
        self.active = Rodas5p(self.fun, first.t, first.y, self.t_bound, **options)

    def _sync(self) -> None:
        a = self.active
        if not hasattr(self, "_stiffness"):
            self._stiffness = None
        if a.status == STIFF:
            self._switch()
            a = self.active
        self.t, self.y, self.t_old = a.t, a.y, a.t_old
        for key in self._done:
            setattr(self, key, self._done[key] + getattr(a, key))
        self.status, self.message = (RUNNING, "") if a.status == STIFF else (a.status, a.message)

    def _step_impl(self):
        self.active.step()
        self._sync()
        return self.status != FAILED, self.message

    def sample(self, t_eval, out, start=0):
        index = start
        while True:
            index = self.active.sample(t_eval, out, index)
            switching = self.active.status == STIFF
            self._sync()
            if not switching or index >= len(t_eval):
                return index

    def _dense_output_impl(self):
        return self.active.dense_output()
