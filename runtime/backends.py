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
import threading
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

#: The functions of a tree's file written without its cold functions (compiler/ccode.py cold_apart), which
#: ColdLibrary builds apart when one is first called.
COLD_APART_FUNCTIONS = ("mass_matrix", "forces")


class Backend(Protocol):
    kind: str                        #: "c" or "numpy"
    sizes: dict[str, int]            #: NQ, NV, NX, NP, NWORK and NY (0 without outputs)
    functions: dict[str, tuple]      #: name -> output shape
    native_methods: tuple[str, ...]  #: integrators that run inside the back end (empty for NumPy)

    def function(self, name: str, p: np.ndarray, work: np.ndarray) -> ModelFunction: ...
    def time_call(self, f: ModelFunction, x: np.ndarray, n: int, t: float) -> float: ...


class CBackend:
    """A model compiled to a CPython extension module (see build.py and c/mbs_glue.c).

    cold: for a tree whose file was written without its cold functions (COLD_APART_FUNCTIONS), what loads their
    library (a callable returning its module, built the first time: ColdLibrary); they are in `functions` all the
    same, and a workspace's binding of one builds the library at its first call."""

    kind = "c"

    def __init__(self, module: ModuleType, cold: Callable[[], ModuleType] | None = None):
        self.module = module
        ny = module.NY if module.NY >= 0 else 0
        self.sizes = {"NQ": module.NQ, "NV": module.NV, "NX": module.NX, "NP": module.NP,
                      "NWORK": module.NWORK, "NY": ny}
        self.functions = {name: tuple(shape) for name, shape in module.FUNCTIONS}
        self.native_methods = tuple(module.METHODS)
        self.cold = ColdLibrary(cold, self.sizes) if cold is not None else None
        if self.cold is not None:
            self.functions.update({name: tuple(self.sizes[d] for d in FUNCTION_SHAPES[name])
                                   for name in COLD_APART_FUNCTIONS})

    def function(self, name: str, p: np.ndarray, work: np.ndarray) -> ModelFunction:
        if self.cold is not None and name in COLD_APART_FUNCTIONS:
            return ColdFunction(self.cold, name, p, work)
        return self.module.Function(name, p, work)

    def time_call(self, f, x, n, t):
        return f.time(np.ascontiguousarray(x, dtype=float), int(n), float(t))


class ColdLibrary:
    """The library of a model's cold functions (runtime/build.py build_cold), loaded the first time one is called.

    Why a slot filled late in an immutable model: a fresh compile of a long open chain spent a third of its C
    compiler (and much of its printing) on the mass matrix and the forces, which no integrator of a tree calls;
    they are built when linearisation, the equilibrium, the dynamics API or a user first asks. The slot holds
    nothing the user sees change: the same functions, the same values (the whole file's text, compiled as the eager
    build compiles it), only later. A lock makes the first fill happen once when threads ask at the same time."""

    def __init__(self, load: Callable[[], ModuleType], sizes: dict[str, int]):
        self._load, self._sizes = load, sizes
        self._module: ModuleType | None = None
        self._lock = threading.Lock()

    @property
    def loaded(self) -> bool:
        """Whether the library is built and loaded (no call of a cold function before: False)."""
        return self._module is not None

    def module(self) -> ModuleType:
        """The library's module (built, or taken from the build cache, and loaded at the first call)."""
        if self._module is None:
            with self._lock:
                if self._module is None:
                    module = self._load()
                    theirs = {k: getattr(module, k) for k in ("NQ", "NV", "NX", "NP", "NWORK")}
                    if any(theirs[k] != self._sizes[k] for k in theirs):
                        raise UsageError(f"the library of the cold functions does not fit the model: sizes {theirs}, "
                                         f"the model's {self._sizes}")
                    self._module = module
        return self._module


class ColdFunction:
    """A cold function bound to a workspace's p and work: the library's own Function, made at the first call
    (which builds the library if needed); its methods (time, rows) and attributes are that Function's."""

    __slots__ = ("_library", "_name", "_p", "_work", "_bound")

    def __init__(self, library: ColdLibrary, name: str, p: np.ndarray, work: np.ndarray):
        self._library, self._name, self._p, self._work = library, name, p, work
        self._bound = None

    def _function(self):
        if self._bound is None:
            self._bound = self._library.module().Function(self._name, self._p, self._work)
        return self._bound

    def __call__(self, t, x):
        return self._function()(t, x)

    def __getattr__(self, attribute: str):
        if attribute.startswith("__"):  # (what copy, pickle and functools look for: not a reason to build)
            raise AttributeError(attribute)
        return getattr(self._function(), attribute)

    def __repr__(self) -> str:
        return f"<cold function {self._name}{'' if self._library.loaded else ' (not built yet)'}>"


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
