"""The two back ends behind :class:`~mbs.runtime.model.CompiledModel`: generated C compiled to an
extension module, and the generated pure Python/NumPy module for machines without a C compiler.

Both expose the same small interface (:class:`Backend`): sizes, the table of model functions, and
``function(name, p, work)`` returning a callable ``f(t, x) -> new ndarray`` bound to a workspace's
parameter and work arrays.  A model status other than 0 raises :class:`EvaluationError` in both.

**The NumPy module contract** (what the code generator emits, mirroring the C file exactly):
module constants ``MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK`` (and ``MBS_NY`` when there are outputs),
and functions ``mbs_<name>(t, x, p, out, work) -> int`` that write into ``out`` (shape from
:data:`FUNCTION_SHAPES`) and return the same status codes as C.
"""

from __future__ import annotations

import importlib.util
import os
import time
from pathlib import Path
from types import ModuleType
from typing import Callable, Protocol

import numpy as np

from .errors import EvaluationError, UsageError

#: Output shape of each model function, by size name.  The C glue has the same table (MBS_TABLE in
#: c/mbs_glue.c); adding a function is one row here and one there.  A function whose size is absent
#: (MBS_NY for outputs) is optional.
FUNCTION_SHAPES: dict[str, tuple[str, ...]] = {
    "rhs": ("NX",),
    "mass_matrix": ("NV", "NV"),
    "forces": ("NV",),
    "qdot": ("NQ",),
    "outputs": ("NY",),
    "jacobian": ("NX", "NX1"),  # [d xdot/d x | d xdot/d t], when generated (compiler/jacobian.py)
    # models with events (compiler/events.py): indicators and the values their actions assign
    "events": ("NEV",),
    "event_actions": ("NACT",),
    "param_jacobian": ("NX", "NP"),  # d xdot/d p, when generated for sensitivities (compiler/jacobian.py)
    # models with closed loops (NC constraint rows; runtime/c/loops.c)
    "constraints": ("NC",),
    "constraint_velocity": ("NC",),
    "constraint_acceleration": ("NC",),
    "constraint_jacobian": ("NC", "NV"),
    "project": ("NX",),
    "normalize": ("NX",),
    "multipliers": ("NC",),
    "loop_report": ("NREPORT",),
    "loop_rhs": ("NX",),  # x' without projection (what the C integrators call between projected steps)
    "loop_accept": ("NX2",),  # [loop_rhs; x projected with the factors of that evaluation]: a DOPRI5 step's end
    # dynamics functions, generated only when asked for (compiler/dynamics_functions.py)
    "inverse_dynamics": ("NV",),
    "bias_forces": ("NV",),
    "gravity_forces": ("NV",),
    "frame_positions": ("NF", "POSE"),
    "frame_velocities": ("NF", "TWIST"),
    "frame_jacobians": ("NF6", "NV"),
}
#: Functions whose input is longer than x = [q; v] (as the C table's nin column): [q; v; a].
FUNCTION_INPUTS: dict[str, str] = {"inverse_dynamics": "NXA"}

ModelFunction = Callable[[float, np.ndarray], np.ndarray]


class Backend(Protocol):
    kind: str                        #: "c" or "numpy"
    sizes: dict[str, int]            #: NQ, NV, NX, NP, NWORK and NY (0 without outputs)
    functions: dict[str, tuple]      #: name -> output shape
    native_methods: tuple[str, ...]  #: integrators that run inside the back end (empty for NumPy)

    def function(self, name: str, p: np.ndarray, work: np.ndarray) -> ModelFunction: ...
    def time_call(self, f: ModelFunction, x: np.ndarray, n: int, t: float) -> float: ...


class CBackend:
    """A model compiled to a CPython extension module (see build.py and c/mbs_glue.c)."""

    kind = "c"

    def __init__(self, module: ModuleType):
        self.module = module
        ny = module.NY if module.NY >= 0 else 0
        self.sizes = {"NQ": module.NQ, "NV": module.NV, "NX": module.NX, "NP": module.NP,
                      "NWORK": module.NWORK, "NY": ny}
        self.functions = {name: tuple(shape) for name, shape in module.FUNCTIONS}
        self.native_methods = tuple(module.METHODS)

    def function(self, name: str, p: np.ndarray, work: np.ndarray) -> ModelFunction:
        return self.module.Function(name, p, work)

    def time_call(self, f, x, n, t):
        return f.time(np.ascontiguousarray(x, dtype=float), int(n), float(t))


class NumpyBackend:
    """The generated pure Python/NumPy module (same functions, same statuses; much slower)."""

    kind = "numpy"
    native_methods: tuple[str, ...] = ()

    def __init__(self, module: ModuleType):
        self.module = module
        try:
            self.sizes = {k: int(getattr(module, "MBS_" + k)) for k in ("NQ", "NV", "NX", "NP", "NWORK")}
        except AttributeError as exc:
            raise UsageError(f"{module.__name__} is not a generated model module: {exc}") from None
        self.sizes["NY"] = int(getattr(module, "MBS_NY", 0))
        self.sizes["NX1"] = self.sizes["NX"] + 1
        if hasattr(module, "MBS_NXA"):
            self.sizes["NXA"] = int(module.MBS_NXA)
        if hasattr(module, "MBS_NF"):  # named frames: pose (position, rotation) and twist (velocity, angular)
            self.sizes.update(NF=int(module.MBS_NF), NF6=6 * int(module.MBS_NF), POSE=12, TWIST=6)
        self.sizes.update(NEV=int(getattr(module, "MBS_NEV", 0)), NACT=int(getattr(module, "MBS_NACT", 0)))
        self.functions = {}
        for name, dims in FUNCTION_SHAPES.items():
            fn = getattr(module, "mbs_" + name, None)
            if fn is not None and all(d in self.sizes for d in dims) and (name != "outputs" or self.sizes["NY"]) \
                    and self.sizes.get(FUNCTION_INPUTS.get(name, "NX"), 0):
                self.functions[name] = tuple(self.sizes[d] for d in dims)

    def function(self, name: str, p: np.ndarray, work: np.ndarray) -> ModelFunction:
        if name not in self.functions:
            raise KeyError(f"the model has no function '{name}'")
        fn, shape = getattr(self.module, "mbs_" + name), self.functions[name]
        nx = self.sizes[FUNCTION_INPUTS.get(name, "NX")]

        def call(t, x):
            x = np.asarray(x, dtype=float)
            if x.shape != (nx,):
                raise ValueError(f"x must have {nx} elements, got shape {x.shape}")
            out = np.empty(shape)
            status = fn(float(t), x, p, out, work)
            if status:
                error = EvaluationError(name, status, t)
                error.values = out  # what the function wrote before it failed, as the C glue keeps it
                raise error
            return out

        call.__name__ = name
        return call

    def time_call(self, f, x, n, t):
        x = np.asarray(x, dtype=float)
        start = time.perf_counter()
        for _ in range(int(n)):
            f(t, x)
        return (time.perf_counter() - start) / int(n)


def load_numpy_module(path: str | os.PathLike, name: str | None = None) -> ModuleType:
    """Import a generated NumPy model file by path (not registered in sys.modules)."""
    path = Path(path)
    spec = importlib.util.spec_from_file_location(name or f"mbs_numpy_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise UsageError(f"cannot import {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
