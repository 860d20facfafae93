"""A compiled model packed for other processes: what a Dask worker needs to run variants without deriving or
compiling anything.

User hooks travel with it: a C hook is in the built binary (and its text in the source, for a rebuild); Python
hooks are in the package's binding, pickled: a `module.py:function` as the file's path, text and function name
(each worker imports the file itself, once), any other callable by value as Dask pickles a task (cloudpickle:
lambdas and closures too). A callable that cannot be pickled is a usage error naming the hook, before any run.

The client derives and compiles once; the package carries the built extension module's bytes (plus the C
source, for a worker on another platform, which then compiles it once), the names, defaults and units of the
CompiledModel, and what starting a run needs (the loop rows and the states the user fixed). Parameters are
run-time values, so one package serves every variant of a study. A worker loads a package once per process.
"""

from __future__ import annotations

import platform
import sys
import sysconfig
import types
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mbs.base.atomic import write_bytes_atomic
from mbs.runtime import build as _build
from mbs.runtime.model import CompiledModel, load_c, load_numpy


def _platform_tag() -> str:
    return f"{sys.implementation.cache_tag}|{sysconfig.get_config_var('EXT_SUFFIX')}|{platform.machine()}|" \
           f"{sys.platform}|numpy {np.__version__}"


def _cpu_needs() -> tuple[str, ...]:
    """The CPU features a binary built here now needs (the instruction-set flags of runtime/build.py cpu_flags)."""
    try:
        flags = _build.cpu_flags(tuple(_build.compiler_command()))
    except _build.BuildError:
        return ()
    return ("avx2",) if "-mavx2" in flags else ()


@dataclass(frozen=True)
class ModelPackage:
    """A picklable compiled model (C extension bytes, or the NumPy source) and how to start its runs."""

    key: str                       #: identifies the build (a worker keeps one loaded model per key)
    kind: str                      #: "c" or "numpy"
    module_name: str               #: import name of the C extension ("" for NumPy)
    binary: bytes                  #: the extension module file (empty for NumPy)
    platform: str                  #: where the binary runs
    source: str                    #: generated C (to rebuild elsewhere) or NumPy source
    info: dict                     #: CompiledModel.from_backend keywords: names, defaults, units
    loops: bool = False            #: closed loops: every start is assembled
    fixed: tuple[str, ...] = ()    #: states the user gave initial values (assembly keeps them)
    rows: tuple[str, ...] = ()     #: names of the loop-closure rows (for assembly messages)
    hooks: object = None           #: runtime.hooks.HookBinding of the model's user hooks, or None
    #: the whole generated C when `source` was written without the cold functions (mbs.pipeline.Generated
    #: cold_apart): a worker builds them from it when one is first called ("": none apart)
    whole: str = ""
    #: CPU features the binary needs (runtime/build.py cpu_flags: "avx2" when built with -mavx2): a worker whose CPU
    #: lacks one builds its own from the source, as on another platform
    cpu: tuple[str, ...] = ()

    @classmethod
    def of(cls, system, scene: str | None, hooks=None) -> "ModelPackage":
        """Pack the compiled model of a System's scene (compiled here if it was not yet); hooks: the
        implementations of the model's user hooks, as for System.simulate."""
        from mbs import pipeline
        from mbs.runtime.hooks import bind
        binding = bind(system.model.hooks, hooks, system.model.name)
        _check_picklable(binding)
        compiled = system.compile(scene, hooks=binding)
        gen = system.generate(scene)
        info = dict(name=compiled.name, q_names=compiled.q_names, v_names=compiled.v_names, z_names=compiled.z_names,
                    p_names=compiled.p_names, y_names=compiled.y_names, p_default=np.array(compiled.p_default),
                    x0=np.array(compiled.x0), units=dict(compiled.units),
                    events=compiled.events)  # the events and switches: without them a variant ran as written
        rows = gen.layout.constraint_rows
        loops = dict(loops=rows is not None, fixed=tuple(pipeline.fixed_state_names(gen)) if rows is not None else (),
                     rows=tuple(rows or ()), hooks=binding)
        if compiled.backend.kind == "c":
            module = compiled.backend.module
            return cls(key=module.__name__, kind="c", module_name=module.__name__,
                       binary=Path(module.__file__).read_bytes(), platform=_platform_tag(), cpu=_cpu_needs(),
                       source=gen.c_source + (binding.c_source() if binding is not None else ""), info=info,
                       whole=gen.whole_source if gen.cold_apart else "", **loops)
        import hashlib
        key = "numpy_" + hashlib.sha256(gen.numpy_source.encode()).hexdigest()[:24]
        return cls(key=key, kind="numpy", module_name="", binary=b"", platform="", source=gen.numpy_source,
                   info=info, **loops)

    def load(self) -> CompiledModel:
        """The CompiledModel in this process: the shipped binary when it runs here, else built from source."""
        if self.kind == "numpy":
            module = types.ModuleType(f"mbs_numpy_{self.info['name']}")
            exec(compile(self.source, f"<generated numpy code of {self.info['name']}>", "exec"), module.__dict__)
            return load_numpy(module, **self.info)
        cold = (lambda: self.whole) if self.whole else None
        if self.platform != _platform_tag() or not set(self.cpu) <= _build._cpu_features():
            return load_c(code=self.source, cold=cold, **self.info)
        path = _build.default_cache_dir() / (self.module_name + sysconfig.get_config_var("EXT_SUFFIX"))
        if not path.exists():
            write_bytes_atomic(path, self.binary)
        module = _build.load(_build.BuildResult(path, self.module_name, self.key, True, ""))
        from mbs.runtime.backends import CBackend
        from mbs.runtime.model import cold_library
        return CompiledModel.from_backend(CBackend(module, cold=cold_library(cold, self.info["name"])), **self.info)


def _check_picklable(binding) -> None:
    """Every Python hook can go to another process (a PythonFileHook always can), or a usage error naming it."""
    if binding is None:
        return
    import cloudpickle

    from mbs.runtime.errors import UsageError
    from mbs.runtime.hook_implementations import PythonFileHook
    for name, fn in binding.python.items():
        if isinstance(fn, PythonFileHook):
            continue
        try:
            cloudpickle.dumps(fn)
        except Exception as exc:  # noqa: BLE001 - whatever pickling raises, the message says which hook
            raise UsageError(f"hook '{name}': the Python callable cannot be sent to the Dask workers "
                             f"({type(exc).__name__}: {exc}); put it in a file and give 'module.py:function' "
                             "(each worker imports the file), or give the hook as a C file") from None


_LOADED: dict[str, CompiledModel] = {}


def compiled_model(package: ModelPackage) -> CompiledModel:
    """The package's model, loaded once per process."""
    model = _LOADED.get(package.key)
    if model is None:
        model = _LOADED[package.key] = package.load()
    return model
