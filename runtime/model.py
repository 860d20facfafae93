"""The immutable compiled model (MuJoCo's mjModel, Pinocchio's Model) and the functions that make one.

A :class:`CompiledModel` holds what never changes during a run: sizes, names, default parameters and
initial state, and the loaded back end.  Everything that does change lives in a
:class:`~mbs.runtime.workspace.Workspace`; one model serves any number of workspaces (one per parallel run).
"""

from __future__ import annotations

import functools
import logging
import os
import time
from dataclasses import dataclass, field
from types import MappingProxyType, ModuleType
from typing import Callable, Mapping, Sequence

import numpy as np

from . import build as _build
from .backends import Backend, CBackend, NumpyBackend, load_numpy_module
from .errors import UsageError
from .events import EventSpec

_log = logging.getLogger(__name__)


def _frozen(values, size: int, what: str) -> np.ndarray:
    a = np.array(values, dtype=float).reshape(-1)
    if a.shape != (size,):
        raise UsageError(f"{what} needs {size} values, got {a.size}")
    a.flags.writeable = False
    return a


def _names(names: Sequence[str] | None, size: int, prefix: str, what: str) -> tuple[str, ...]:
    if names is None:
        return tuple(f"{prefix}{i}" for i in range(size))
    names = tuple(str(n) for n in names)
    if len(names) != size:
        raise UsageError(f"{what} needs {size} names, got {len(names)}")
    return names


@dataclass(frozen=True, eq=False)
class CompiledModel:
    """A model ready to run.  Arrays are read-only; names follow the generated code's order.

    Sizes (properties): ``nq`` position coordinates, ``nv`` velocity coordinates (``nv != nq`` with
    quaternions), ``nz`` extra differential states, ``nx = nq + nv + nz`` states ``x = [q; v; z]``, ``np`` parameters, ``ny`` outputs, ``nwork``
    doubles of work memory per workspace.
    """

    name: str                       #: model name, as in the .mbs file
    backend: Backend                #: the loaded C library or NumPy module
    q_names: tuple[str, ...]        #: (nq,) position coordinate names, e.g. "hinge.phi" [unit in units]
    v_names: tuple[str, ...]        #: (nv,) velocity coordinate names, e.g. "der(hinge.phi)"
    p_names: tuple[str, ...]        #: (np,) parameter names
    y_names: tuple[str, ...]        #: (ny,) output names
    p_default: np.ndarray           #: (np,) default parameter values, SI units
    x0: np.ndarray                  #: (nx,) default initial state [q0; v0], SI units
    units: Mapping[str, str] = field(default_factory=dict)  #: name -> unit text ("rad", "m/s")
    events: tuple = ()              #: per indicator of mbs_events: EventSpec (runtime/events.py)
    z_names: tuple[str, ...] = ()   #: (nz,) extra differential states after q and v (language/states.py)

    @classmethod
    def from_backend(cls, backend: Backend, *, name: str = "model", q_names=None, v_names=None, p_names=None,
                     y_names=None, p_default=None, x0=None, units: Mapping[str, str] | None = None,
                     events=(), z_names=None) -> "CompiledModel":
        """Wrap a back end with the metadata the compiler knows (names, defaults, units); missing names
        default to q0.., v0.., p0.., y0.. and missing values to zeros."""
        s = backend.sizes
        return cls(
            name=name, backend=backend,
            q_names=_names(q_names, s["NQ"], "q", "q_names"),
            v_names=_names(v_names, s["NV"], "v", "v_names"),
            p_names=_names(p_names, s["NP"], "p", "p_names"),
            y_names=_names(y_names, s["NY"], "y", "y_names"),
            p_default=_frozen(np.zeros(s["NP"]) if p_default is None else p_default, s["NP"], "p_default"),
            x0=_frozen(np.zeros(s["NX"]) if x0 is None else x0, s["NX"], "x0"),
            units=MappingProxyType(dict(units or {})),
            events=tuple(EventSpec.of(e) for e in events),
            z_names=_names(z_names, s["NX"] - s["NQ"] - s["NV"], "z", "z_names"),
        )

    nq = property(lambda self: self.backend.sizes["NQ"], doc="number of position coordinates")
    nv = property(lambda self: self.backend.sizes["NV"], doc="number of velocity coordinates")
    nx = property(lambda self: self.backend.sizes["NX"], doc="number of states, nq + nv + nz")
    nz = property(lambda self: len(self.z_names), doc="number of extra differential states")
    np = property(lambda self: self.backend.sizes["NP"], doc="number of parameters")
    ny = property(lambda self: self.backend.sizes["NY"], doc="number of outputs (0 if none)")
    nwork = property(lambda self: self.backend.sizes["NWORK"], doc="doubles of work memory")

    @property
    def x_names(self) -> tuple[str, ...]:
        """(nx,) state names, q names, v names, then the extra states."""
        return self.q_names + self.v_names + self.z_names

    @property
    def functions(self) -> tuple[str, ...]:
        """Names of the model functions the back end provides ("rhs", "mass_matrix", ...)."""
        return tuple(self.backend.functions)

    def parameter_index(self, name: str) -> int:
        try:
            return self.p_names.index(name)
        except ValueError:
            raise UsageError(f"model {self.name} has no parameter '{name}' (parameters: "
                             f"{', '.join(self.p_names) or 'none'})") from None

    def __repr__(self) -> str:
        return (f"CompiledModel({self.name!r}, backend={self.backend.kind}, nq={self.nq}, nv={self.nv}, "
                f"np={self.np}, ny={self.ny})")


def load_c(path: str | os.PathLike | None = None, *, code: str | None = None,
           cache_dir: str | os.PathLike | None = None, extra_flags: tuple[str, ...] = (),
           cold: Callable[[], str] | None = None, **info) -> CompiledModel:
    """Compile (or fetch from the cache) a generated C file, or C source text given as ``code``, and
    wrap it; ``info`` as in :meth:`CompiledModel.from_backend`.  Raises BuildError when the compiler fails.
    cold: for a tree's file written without its cold functions (compiler/ccode.py cold_apart), what gives the
    whole file, whose cold functions are built into a library of their own when one is first called
    (runtime/backends.py ColdLibrary, runtime/build.py build_cold)."""
    if (path is None) == (code is None):
        raise UsageError("give either the path of a generated C file or its source as code= (exactly one)")
    options = dict(cache_dir=cache_dir, extra_flags=extra_flags)
    started = time.perf_counter()
    result = _build.build_file(path, **options) if code is None else _build.build(code, **options)
    took = time.perf_counter() - started
    _log.log(25 if took > 1.0 else logging.INFO, "C build of %s: cache %s, %.2f s", info.get("name", "model"),
             "hit" if result.cached else "miss", took)  # 25: mbs.pipeline.NOTE, a slow step shown by default
    _log.debug("C build product: %s", getattr(result, "path", "?"))
    library = cold_library(cold, info.get("name", "model"), **options)
    return CompiledModel.from_backend(CBackend(_build.load(result), cold=library), **info)


def cold_library(whole: Callable[[], str] | None, name: str, **options) -> Callable[[], ModuleType] | None:
    """What loads the library of the cold functions of the whole file `whole()` gives (None: no such file);
    options: of build_cold (cache_dir, extra_flags)."""
    return functools.partial(_load_cold, whole, name, options) if whole is not None else None


def _load_cold(whole: Callable[[], str], name: str, options: dict) -> ModuleType:
    """The loaded library of the cold functions of the whole file `whole()` gives (built, or from the cache)."""
    started = time.perf_counter()
    result = _build.build_cold(whole(), **options)
    took = time.perf_counter() - started
    _log.log(25 if took > 1.0 else logging.INFO, "the cold functions of %s (mass matrix, forces): derived and built "
             "on first call, cache %s, %.2f s", name, "hit" if result.cached else "miss", took)
    return _build.load(result)


def load_numpy(module: ModuleType | str | os.PathLike, **info) -> CompiledModel:
    """Wrap a generated NumPy module (or the path of one)."""
    if not isinstance(module, ModuleType):
        module = load_numpy_module(module)
    return CompiledModel.from_backend(NumpyBackend(module), **info)


def load_model(c_path: str | os.PathLike | None = None, numpy_module: ModuleType | str | os.PathLike | None = None,
               *, backend: str = "auto", cache_dir: str | os.PathLike | None = None, **info) -> CompiledModel:
    """Load a model with the C back end when possible (``backend="auto"``: a C file is given and a
    compiler runs), else with the NumPy back end (a module or the path of one).  ``backend`` may force
    "c" or "numpy"."""
    if backend not in ("auto", "c", "numpy"):
        raise UsageError(f"unknown back end '{backend}' (use 'auto', 'c' or 'numpy')")
    use_c = backend == "c" or (backend == "auto" and c_path is not None
                               and (numpy_module is None or _build.have_c_compiler()))
    if use_c:
        if c_path is None:
            raise UsageError("the C back end needs the generated C file")
        return load_c(c_path, cache_dir=cache_dir, **info)
    if numpy_module is None:
        raise UsageError("no C compiler is available and no NumPy module was given")
    return load_numpy(numpy_module, **info)
