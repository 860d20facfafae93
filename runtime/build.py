"""Compile a generated model to a CPython extension module, cache it, and load it.

A small model is compiled as one translation unit: ``<Python.h>``, the generated C source, then the glue
template ``c/mbs_glue.c`` (which includes the integrators in ``c/``).  A large one (runtime/translation_units.py) is split
into the glue unit and a few units of the model's functions, compiled at once (as many jobs as cores, the
biggest first) and linked; only the module's init function is exported (-fvisibility=hidden).

The result is cached under a hash of everything that can change the binary: the model source, the
run-time C files, the flags, the compiler's version, the Python and NumPy versions.  A fresh build is
made in a temporary directory inside the cache and moved into place with ``os.replace``, so processes
compiling the same model at once each end up with a complete file (the last rename wins; both are
identical).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import logging
import os
import platform
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from mbs.base.cachedir import default_cache_dir as _default_cache_dir
from . import cache as _cache
from . import translation_units as _units
from .errors import BuildError, EvaluationError

#: Bump when the layout of the build unit changes in a way the hashed inputs do not show.
BUILD_FORMAT = 2
C_DIR = Path(__file__).resolve().parent / "c"
#: The run-time C files compiled into every model (all hashed).
RUNTIME_SOURCES = ("mbs_runtime.h", "ode.c", "dense_lu.c", "dopri5.c", "rosenbrock.c", "rodasp.c", "rodas5p.c",
                   "loops.c", "loop_jacobian.c", "mbs_glue.c")
#: Compiler flags; -fno-math-errno lets sqrt/sin compile to instructions (no errno is ever read).
FLAGS = ("-O2", "-fPIC", "-shared", "-std=c99", "-Wall", "-fno-math-errno")
#: Appended to the flags of the model's units in a split build (runtime/translation_units.py) when the compiler is GCC, from
#: what bench/optlevels.py measures. GCC's RTL global CSE/PRE and its alias walks (value numbering, dead stores)
#: grow faster than the code on long straight-line functions whose every store may alias every load: of the
#: 14 s of CPU the 40-four-bar chain's units took at -O2, 12 s went to its mass matrix. With these 6.4 s, and the
#: right-hand side as fast (0.96 of -O2 for the chain, 0.94 for the Iltis, interleaved in one process). -O1
#: would cost the chain's right-hand side 12 %. The glue unit (integrators, loop solver) keeps FLAGS.
GCC_MODEL_UNIT_FLAGS = ("-fno-gcse", "--param=sccvn-max-alias-queries-per-access=100",
                        "--param=dse-max-alias-queries-per-store=32")
#: Extension modules on macOS resolve Python's symbols when loaded, not when linked.
PLATFORM_FLAGS = ("-undefined", "dynamic_lookup") if sys.platform == "darwin" else ()
CACHE_ENV = "MBS_CACHE_DIR"
#: How many compiler processes a split build runs at once (default: the cores this process may use).
JOBS_ENV = "MBS_BUILD_JOBS"

_LOADED: dict[str, ModuleType] = {}


@dataclass(frozen=True)
class BuildResult:
    """A compiled model on disk."""

    path: Path          #: the extension module file
    module_name: str    #: its import name (unique per hash)
    key: str            #: hex SHA-256 of all inputs
    cached: bool        #: True when the file was already in the cache (no compiler run)
    warnings: str       #: compiler messages of a fresh build ('' when cached or clean)


def default_cache_dir() -> Path:
    """``$MBS_CACHE_DIR``, else ``$XDG_CACHE_HOME/baukasten``, else ``~/.cache/baukasten`` (mbs.base.cachedir)."""
    return _default_cache_dir()


def compiler_command() -> list[str]:
    """The C compiler as a command prefix: ``$CC`` if set, else the one Python was built with."""
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    return shlex.split(cc)


@functools.lru_cache(maxsize=8)
def compiler_version(cc: tuple[str, ...]) -> str:
    """The compiler's ``--version`` text; raises BuildError when it cannot be run."""
    try:
        proc = subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as exc:
        raise BuildError(f"no usable C compiler ({shlex.join(cc)}: {exc}); install one (e.g. gcc) "
                         "or use the NumPy back end") from None
    if proc.returncode != 0:
        raise BuildError(f"the C compiler {shlex.join(cc)} does not run", proc.stderr, tuple(cc))
    return proc.stdout.strip()


def model_unit_flags(cc: tuple[str, ...]) -> tuple[str, ...]:
    """The flags the model's units of a split build get beyond FLAGS (GCC_MODEL_UNIT_FLAGS for GCC, else none)."""
    version = compiler_version(cc)
    return GCC_MODEL_UNIT_FLAGS if "Free Software Foundation" in version and "clang" not in version else ()


def have_c_compiler() -> bool:
    """True when a C compiler can be run (the C back end is then available)."""
    try:
        compiler_version(tuple(compiler_command()))
    except BuildError:
        return False
    return True


def _unit_source(model_source: str, filename: str) -> str:
    # '#line' makes the compiler name the user's file in its messages; Python.h must come first.
    return ("/* build unit written by mbs.runtime.build: do not edit */\n"
            "#define PY_SSIZE_T_CLEAN\n#include <Python.h>\n"
            f"#line 1 \"{_units.line_name(filename)}\"\n{model_source}\n"
            "#line 1 \"mbs_glue.c\"\n#include \"mbs_glue.c\"\n")


def _hash(unit: str, flags: tuple[str, ...], cc: tuple[str, ...]) -> str:
    h = hashlib.sha256()

    def add(label: str, data: str | bytes) -> None:
        data = data.encode() if isinstance(data, str) else data
        h.update(f"{label}:{len(data)}:".encode())
        h.update(data)

    add("format", str(BUILD_FORMAT))
    add("unit", unit)
    for name in RUNTIME_SOURCES:
        add(name, (C_DIR / name).read_bytes())
    add("flags", "\0".join(flags))
    add("cc", "\0".join(cc))
    add("cc-version", compiler_version(cc))
    add("python", f"{sys.version}\0{sysconfig.get_config_var('EXT_SUFFIX')}\0{platform.machine()}")
    add("numpy", np.__version__)
    return h.hexdigest()


def _build_files(code: str, filename: str) -> dict[str, str]:
    """{file name: text} to compile: one unit, or the split model (runtime/translation_units.py) and the glue unit."""
    split = _units.split_sources(code, filename)
    if split is None:
        return {"unit.c": _unit_source(code, filename)}
    glue = ("/* glue unit written by mbs.runtime.build: do not edit */\n"
            "#define PY_SSIZE_T_CLEAN\n#include <Python.h>\n#include \"model.h\"\n"
            "#line 1 \"mbs_glue.c\"\n#include \"mbs_glue.c\"\n")
    return {**split, _units.GLUE_UNIT: glue}


def _joined(files: dict[str, str]) -> str:
    """All files as one text (the cache key's input and the inspection copy beside the module)."""
    if list(files) == ["unit.c"]:
        return files["unit.c"]
    return "\n".join(f"/* ==== {name} ==== */\n{text}" for name, text in files.items())


def build_jobs() -> int:
    """Compiler processes at once: $MBS_BUILD_JOBS, else the cores this process may run on."""
    try:
        return max(1, int(os.environ[JOBS_ENV]))
    except (KeyError, ValueError):
        pass
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _compile(files: dict[str, str], flags: tuple[str, ...], model_flags: tuple[str, ...], cc: tuple[str, ...],
             module_name: str, tmp: Path, filename: str) -> str:
    """Compile the files in `tmp` into tmp/module.so; the compiler's messages. Raises BuildError."""
    for name, text in files.items():
        (tmp / name).write_text(text, encoding="utf-8")
    includes = (f"-DMBS_MODULE_NAME={module_name}", f"-I{C_DIR}", f"-I{sysconfig.get_paths()['include']}",
                f"-I{np.get_include()}")
    if list(files) == ["unit.c"]:
        command = (*cc, *flags, *includes, "unit.c", "-o", "module.so", "-lm")
        return _run(command, tmp, filename)
    compile_flags = tuple(f for f in flags if f not in ("-shared", *PLATFORM_FLAGS)) + ("-fvisibility=hidden",)
    sources = sorted((n for n in files if n.endswith(".c")), key=lambda n: -len(files[n]))  # biggest first
    commands = [(*cc, *compile_flags, *(() if name == _units.GLUE_UNIT else model_flags), *includes, "-c", name,
                 "-o", name[:-2] + ".o") for name in sources]
    with ThreadPoolExecutor(max_workers=build_jobs()) as pool:
        outputs = list(pool.map(lambda command: _run(command, tmp, filename), commands))
    objects = [name[:-2] + ".o" for name in sources]
    link = (*cc, *flags, "-fvisibility=hidden", *objects, "-o", "module.so", "-lm")
    return "".join(outputs) + _run(link, tmp, filename)


def _run(command: tuple[str, ...], cwd: Path, filename: str) -> str:
    try:
        proc = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    except OSError as exc:
        raise BuildError(f"cannot run the C compiler {shlex.join(command[:1])}: {exc}", "", command) from None
    output = proc.stderr + proc.stdout
    if proc.returncode != 0:
        raise BuildError(f"compiling {filename} failed", output, command)
    return output


def build_file(path: str | os.PathLike, **options) -> BuildResult:
    """:func:`build` the generated C file at ``path``.  Compiler messages name the file by its base name,
    which keeps the cache key independent of where the file lies."""
    options.setdefault("filename", os.path.basename(os.fspath(path)))
    return build(Path(path).read_text(encoding="utf-8"), **options)


def build(code: str, *, filename: str = "model.c", cache_dir: str | os.PathLike | None = None,
          extra_flags: tuple[str, ...] = (), model_flags: tuple[str, ...] | None = None) -> BuildResult:
    """Compile generated C source text into a cached extension module.

    ``filename`` is the name compiler messages use for the model.  extra_flags: appended to every compiler
    call; model_flags: appended to those of the model's units of a split build (default model_unit_flags).
    Raises BuildError with the compiler's messages when compilation fails.
    """
    cc = tuple(compiler_command())
    flags = FLAGS + PLATFORM_FLAGS + tuple(extra_flags)
    model_flags = model_unit_flags(cc) if model_flags is None else tuple(model_flags)
    files = _build_files(code, filename)
    unit = _joined(files)
    key = _hash(unit, flags + (("model units:", *model_flags) if len(files) > 1 else ()), cc)
    module_name = f"mbs_model_{key[:24]}"
    cache = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    target = cache / (module_name + sysconfig.get_config_var("EXT_SUFFIX"))
    if target.exists():
        damage = _cache.problem(target)
        if damage is None:
            return BuildResult(target, module_name, key, True, "")
        logging.getLogger("mbs.cache").warning(f"note: the cached build {target.name} is not loaded ({damage}); "
                                               "rebuilding it")
    try:
        cache.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".build-", dir=cache))
    except OSError as exc:
        why = "a file, not a folder" if cache.exists() and not cache.is_dir() else (exc.strerror or str(exc))
        raise BuildError(f"the build cache {cache} cannot be used ({why}): set {CACHE_ENV} to a writable "
                         "folder") from None
    try:
        output = _compile(files, flags, model_flags, cc, module_name, tmp, filename)
        # keep the sources beside the module for inspection (one file); both appear atomically
        (tmp / "unit.c").write_text(unit, encoding="utf-8")
        os.replace(tmp / "unit.c", cache / (module_name + ".c"))
        os.replace(tmp / "module.so", target)
        _cache.record(target, key, unit)
    except OSError as exc:
        raise BuildError(f"the build cache {cache} cannot be written ({exc.strerror or exc}): set {CACHE_ENV} "
                         "to a writable folder") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return BuildResult(target, module_name, key, False, output.strip())


def load(result: BuildResult) -> ModuleType:
    """Import a built model (once per process; later calls return the same module)."""
    module = _LOADED.get(result.module_name)
    if module is None:
        spec = importlib.util.spec_from_file_location(result.module_name, result.path)
        if spec is None or spec.loader is None:
            raise BuildError(f"cannot load {result.path}: not an extension module for this Python")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        module._init(EvaluationError)
        # registered so that the native integrators can find the module of a model function
        sys.modules[result.module_name] = module
        _LOADED[result.module_name] = module
    return module
