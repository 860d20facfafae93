"""The integrator a run can use: a C integrator asked for by a model built with the NumPy back end (no C
compiler on this machine) becomes its nearest scipy method, with a one-line note, so that a scene written
for the compiled back end still runs wherever Python does (more slowly).
"""

from __future__ import annotations

from .integrators import NativeSolver, OdeSolver, get_integrator
from .model import CompiledModel

#: C method -> the scipy method closest to it: the same Dormand-Prince 5(4) pair; a stiff, L-stable implicit
#: method for the Rosenbrock one; LSODA (Adams while the problem is not stiff) for Adams. Methods not listed fall
#: back to Radau (safe on stiff and non-stiff models).
NEAREST_SCIPY = {"dopri5": "RK45", "rodasp": "Radau", "rodas5p": "Radau", "adams": "LSODA"}


def runnable_integrator(model: CompiledModel, name) -> tuple[type[OdeSolver], str]:
    """(integrator class, note): the class asked for, or its nearest scipy method and why ("" when none)."""
    cls = get_integrator(name)
    if not (isinstance(cls, type) and issubclass(cls, NativeSolver)):
        return cls, ""
    if cls.native_method in model.backend.native_methods:
        return cls, ""
    nearest = NEAREST_SCIPY.get(cls.name.lower(), "Radau")
    return get_integrator(nearest), (f"note: integrator '{cls.name}' runs in C, but this model was built with the "
                                     f"{model.backend.kind} back end (no C compiler); using scipy's '{nearest}'")
