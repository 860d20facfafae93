"""Compile a generated model to a CPython extension module, cache it, and load it.

A small model is compiled as one translation unit: the generated C source, then the glue template ``c/mbs_glue.c``
(the model's function table and init function, and with loops the loop solver ``c/loops.c``).  A large one
(runtime/translation_units.py) is split into the glue unit and a few units of the model's functions, compiled at once
(as many jobs as cores, the biggest first) and linked; only the module's init function is exported
(-fvisibility=hidden).  Either is linked with the runtime object: the Python bindings and the integrators
(``c/mbs_python.c``, which use no model macro), compiled once per compiler, flags, Python and NumPy and kept in the
cache like the objects below (RUNTIME_UNIT): of a small model's compile it was nine tenths, of the Iltis's glue
unit half.

The result is cached under a hash of everything that can change the binary: the model source, the
run-time C files, the splitter and this module, the flags, the compiler's version, the Python and NumPy
versions.  A fresh build is made in a temporary directory inside the cache and moved into place with
``os.replace``, so processes compiling the same model at once each end up with a complete file (the last rename
wins; both are identical).

The objects of a split build are cached too, each under a hash of its unit's text, the header it includes (the
run-time C files for the glue unit), its flags and the compiler: a model whose text changed in one unit only (a
scene asking for other outputs changes outputs.c alone, runtime/translation_units.py) recompiles that unit and
links. The module's name is compiled into a tiny init unit only (PyInit_<name> calls the glue's
mbs_module_init), so the glue's object serves every module. Objects are recorded and verified like modules
(runtime/cache.py) and written the same way (a temporary file, then ``os.replace``).
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
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from mbs.base.cachedir import cache_folder
from mbs.base.cachedir import default_cache_dir as _default_cache_dir
from . import cache as _cache
from . import translation_units as _units
from .errors import BuildError, EvaluationError

#: Bump when the layout of the build unit changes in a way the hashed inputs do not show.
BUILD_FORMAT = 3
C_DIR = Path(__file__).resolve().parent / "c"
#: The run-time C files compiled into every model (all hashed).
RUNTIME_SOURCES = ("mbs_runtime.h", "ode.c", "dense_lu.c", "dopri5.c", "rosenbrock.c", "rodasp.c", "rodas5p.c",
                   "adams.c", "loops.c", "loop_jacobian.c", "mbs_python.h", "mbs_python.c", "mbs_glue.c", "mbs_cold_glue.c",
                   "huge_text.c")
#: The run-time object's unit (the same for every model) and the C files it is made of (its cache key hashes them).
RUNTIME_UNIT = "runtime.c"
RUNTIME_UNIT_SOURCES = ("mbs_python.c", "mbs_python.h", "mbs_runtime.h", "ode.c", "dense_lu.c", "dopri5.c",
                        "rosenbrock.c", "rodasp.c", "rodas5p.c", "adams.c", "huge_text.c")
#: Compiler flags; -fno-math-errno lets sqrt/sin compile to instructions (no errno is ever read).
FLAGS = ("-O2", "-fPIC", "-shared", "-std=c99", "-Wall", "-fno-math-errno")
#: Appended to the flags of the model's units in a split build (runtime/translation_units.py) when the compiler is GCC, from
#: what bench/optlevels.py measures. GCC's RTL global CSE/PRE and its alias walks (value numbering, dead stores)
#: grow faster than the code on long straight-line functions whose every store may alias every load: of the
#: 14 s of CPU the 40-four-bar chain's units took at -O2, 12 s went to its mass matrix. With these 6.4 s, and the
#: right-hand side as fast (0.96 of -O2 for the chain, 0.94 for the Iltis, interleaved in one process). -O1
#: would cost the chain's right-hand side 12 %. The glue unit (integrators, loop solver) keeps FLAGS.
#: Then -fno-schedule-insns2 and a cselib of 50 memory locations (GCC's default 500): of what was left of the
#: Iltis's model units (-ftime-report), the post-reload CSE over the spill slots took 18 % (cselib's memory
#: list, walked for every store, 5 % with 50) and the second scheduling 9 %. Both together: the five units'
#: compiles 32.4 -> 27.4 billion instructions (0.84, cachegrind on the compiler: load-independent), their compiler
#: CPU 0.71 and 0.90 in two runs (medians of 3 interleaved, GCC 12; each flag alone 0.85 and 0.90, which is why one
#: at a time looked like noise). bench/unit_flags.py: rhs and outputs the same to the bit, `loop_rhs` 52,842 ->
#: 52,859 instructions a call and the outputs 89,817 -> 89,836 (callgrind, bump_5 equilibrium; the out-of-order
#: core does the scheduling: the times per call agree within the machine's noise). On top of the two, model_2.c's
#: compile went 0.96 with -fno-expensive-optimizations and 0.93 with -fno-tree-slp-vectorize, which costs
#: `loop_rhs` 0.4 % more instructions (scalar for paired SSE2 arithmetic) and looked slower per call: left out;
#: alone, -fira-region=one/all, -fira-algorithm=priority, -fno-tree-pre/-vrp/-pta, -fno-reorder-blocks, -fno-dse
#: and --param=max-cse-path-length=1 moved three units by less than the noise (1.13 the last). Not the glue unit:
#: its loops' speed is what the integrators see, and instruction counts do not see scheduling.
GCC_MODEL_UNIT_FLAGS = ("-fno-gcse", "--param=sccvn-max-alias-queries-per-access=100",
                        "--param=dse-max-alias-queries-per-store=32", "-fno-schedule-insns2",
                        "--param=max-cselib-memory-locations=50")
#: Appended to those of the outputs' unit (outputs.c, after the model units' flags). The outputs are evaluated once
#: per sample, not per stage of a step; the Iltis's (135 kB of C) took 2.9 to 3.4 s of CPU at the model units' level
#: and 2.1 s at -Og (GCC 12, compiled alone), and a bump scene's simulate is as fast within the noise of a shared
#: machine (its mbs_outputs first solves the loops for the accelerations, in the model units).  Measured again with
#: `python bench/output_rows.py --flags` (GCC 12): the unit 0.31 s of CPU at -Og, 0.39 s at -O1, 0.55 s at the model
#: units' level; a bump row 98,200 instructions at -Og, 95,300 at both others (0.97: the outputs' own expressions are
#: 17 % of a row, the projection and the loop solve the rest), its CPU time the same within the noise (1.00 and 1.01
#: of -Og, medians of 9 interleaved rounds), one output in 20,000 one ulp apart: -Og stays.
OUTPUTS_UNIT_FLAGS: tuple[str, ...] = ("-Og",)
#: Appended to those of the units of the functions no integrator calls (runtime/translation_units.py
#: COLD_FUNCTIONS: an open tree's mass matrix and forces), from what bench/compile_time.py --units measures: the
#: 40-link pendulum's mass matrix (276 kB of C) took 13.8 s of CPU at the model units' level, 9.0 s at -O1 and
#: 6.9 s at -Og, which keeps the values in registers (a straight-line function at -O0 runs several times slower).
#: The results are the same to the bit at every level (no level reassociates without -ffast-math, and -std=c99
#: does not contract a*b+c).
COLD_UNIT_FLAGS: tuple[str, ...] = ("-Og",)
#: Extension modules on macOS resolve Python's symbols when loaded, not when linked.
PLATFORM_FLAGS = ("-undefined", "dynamic_lookup") if sys.platform == "darwin" else ()
#: Instruction-set flags for the CPU that builds and runs the model, on top of FLAGS: on x86-64 with AVX2, VEX-encoded
#: three-operand arithmetic (-mavx2) and, with GCC, the CPU's own instruction scheduling (-mtune=native). The same
#: bits as without: no fused multiply-add (not enabled, and -std=c99 contracts nothing), no reassociation, vector
#: code only where it was already allowed (every generated function of the Iltis the same to the bit at 200 states,
#: a bump run's steps and events unchanged); -march=native enables FMA among others and moved a tyre force by an
#: ulp. `python bench/cpu_flags.py` measures a whole simulate of the Iltis bump scenes with and without them in the
#: same run. A library built so runs only where AVX2 does: the flags are part of every cache key, and a study's
#: package names them in its platform (mbs/studies/package.py) so that a worker without them compiles its own.
#: $MBS_CPU_FLAGS replaces them (empty: none, a portable build; FMUs never get them: mbs/fmu.py).
CPU_FLAGS_ENV = "MBS_CPU_FLAGS"
AVX2_FLAGS = ("-mavx2",)
GCC_TUNE_FLAGS = ("-mtune=native",)
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
    compiled: tuple[str, ...] = ()  #: the units a fresh build compiled ('unit.c' for a one-unit build)
    reused: tuple[str, ...] = ()    #: the units whose objects a fresh split build took from the cache


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


def cpu_flags(cc: tuple[str, ...]) -> tuple[str, ...]:
    """The instruction-set flags of this CPU and compiler (CPU_FLAGS): $MBS_CPU_FLAGS when set, else AVX2's when
    the CPU has it and the compiler is GCC or Clang (with GCC's tuning), else none."""
    chosen = os.environ.get(CPU_FLAGS_ENV)
    if chosen is not None:
        return tuple(shlex.split(chosen))
    return _detected_cpu_flags(cc)


@functools.lru_cache(maxsize=8)
def _detected_cpu_flags(cc: tuple[str, ...]) -> tuple[str, ...]:
    if platform.machine().lower() not in ("x86_64", "amd64") or "avx2" not in _cpu_features():
        return ()
    version = compiler_version(cc)
    if "clang" in version:
        return AVX2_FLAGS
    return AVX2_FLAGS + GCC_TUNE_FLAGS if "Free Software Foundation" in version else ()


def _cpu_features() -> frozenset[str]:
    """The CPU's feature names as Linux lists them (/proc/cpuinfo); none elsewhere (no flags are added there)."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as info:
            for line in info:
                if line.startswith("flags"):
                    return frozenset(line.partition(":")[2].split())
    except OSError:
        pass
    return frozenset()


def base_flags(cc: tuple[str, ...]) -> tuple[str, ...]:
    """Every unit's flags before a caller's extras: FLAGS, the platform's, this CPU's (cpu_flags)."""
    return FLAGS + PLATFORM_FLAGS + cpu_flags(cc)


def have_c_compiler() -> bool:
    """True when a C compiler can be run (the C back end is then available)."""
    try:
        compiler_version(tuple(compiler_command()))
    except BuildError:
        return False
    return True


#: What the one unit of a small model starts with: the feature macros and C headers <Python.h> gave it when the glue
#: included it first (a user's hook file, runtime/hooks.py, may rely on them; M_PI needs the feature macros).
UNIT_PRELUDE = ("#define _GNU_SOURCE 1\n#include <errno.h>\n#include <limits.h>\n#include <math.h>\n"
                "#include <stdio.h>\n#include <stdlib.h>\n#include <string.h>\n")


def _unit_source(model_source: str, filename: str) -> str:
    # '#line' makes the compiler name the user's file in its messages
    return ("/* build unit written by mbs.runtime.build: do not edit */\n" + UNIT_PRELUDE +
            f"#line 1 \"{_units.line_name(filename)}\"\n{model_source}\n"
            "#line 1 \"mbs_glue.c\"\n#include \"mbs_glue.c\"\n")


def _runtime_unit() -> str:
    """The runtime object's unit: the Python bindings and the integrators (c/mbs_python.c)."""
    return "/* runtime unit written by mbs.runtime.build: do not edit */\n#include \"mbs_python.c\"\n"


class _Digest:
    """A SHA-256 of labelled parts (each with its length, so no two sequences of parts give the same stream)."""

    def __init__(self):
        self.h = hashlib.sha256()

    def add(self, label: str, data: str | bytes) -> "_Digest":
        data = data.encode() if isinstance(data, str) else data
        self.h.update(f"{label}:{len(data)}:".encode())
        self.h.update(data)
        return self

    def hexdigest(self) -> str:
        return self.h.hexdigest()


def _environment(digest: _Digest, cc: tuple[str, ...]) -> _Digest:
    """The compiler, its version, Python and NumPy: what every object and module depends on besides its text."""
    digest.add("format", str(BUILD_FORMAT)).add("cc", "\0".join(cc)).add("cc-version", compiler_version(cc))
    digest.add("python", f"{sys.version}\0{sysconfig.get_config_var('EXT_SUFFIX')}\0{platform.machine()}")
    return digest.add("numpy", np.__version__)


def _hash(code: str, filename: str, flags: tuple[str, ...], model_flags: tuple[str, ...], cc: tuple[str, ...],
          outputs_flags: tuple[str, ...] = (), library: str = "model") -> str:
    """The module's key: the generated text and everything that turns it into the module (the split into units
    is a function of the text, the splitter's and this module's source); `library`: "model", or "cold" for the
    library of its cold functions (build_cold)."""
    digest = _environment(_Digest(), cc).add("library", library).add("code", code).add("filename", filename)
    for name in RUNTIME_SOURCES:
        digest.add(name, (C_DIR / name).read_bytes())
    for module in (_units.__file__, __file__):
        digest.add(Path(module).name, Path(module).read_bytes())
    digest.add("split", f"{_units.SPLIT_MIN_CHARS} {_units.LOOP_SPLIT_FRACTION} {_units.UNIT_CHARS} "
                        f"{_units.MAX_MODEL_UNITS}")
    digest.add("flags", "\0".join(flags)).add("model units", "\0".join(model_flags))
    digest.add("cold units", "\0".join(COLD_UNIT_FLAGS))
    return digest.add("outputs unit", "\0".join(outputs_flags)).hexdigest()


def _object_key(name: str, files: dict[str, str], command: tuple[str, ...], cc: tuple[str, ...]) -> str:
    """An object's key: its unit's text, the header it includes, the run-time C files (the glue unit; the runtime
    unit: those it is made of, and no model's header) and its compile command (flags and include folders)."""
    digest = _environment(_Digest(), cc).add("unit", files[name])
    if name == RUNTIME_UNIT:
        sources = RUNTIME_UNIT_SOURCES
    else:
        header = _header_of(name, files)
        digest.add(header, files.get(header, ""))
        sources = RUNTIME_SOURCES if name in (_units.GLUE_UNIT, _units.COLD_GLUE_UNIT) else ()
    for source in sources:
        digest.add(source, (C_DIR / source).read_bytes())
    return digest.add("command", "\0".join(command)).hexdigest()


def _header_of(name: str, files: dict[str, str]) -> str:
    """The generated header unit `name` includes: the glue unit's own (translation_units.GLUE_HEADER) when the
    split has one, else model.h."""
    return _units.GLUE_HEADER if name == _units.GLUE_UNIT and _units.GLUE_HEADER in files else "model.h"


def _glue_unit(header: str, outputs: bool) -> str:
    """The glue unit's text: it includes `header` (model.h or translation_units.GLUE_HEADER), the outputs'
    declarations when the file has an outputs' part, and c/mbs_glue.c."""
    return ("/* glue unit written by mbs.runtime.build: do not edit */\n"
            f"#define MBS_SEPARATE_INIT 1\n#include \"{header}\"\n"
            + (_units.OUTPUTS_DECLARATIONS if outputs else "") + "#line 1 \"mbs_glue.c\"\n#include \"mbs_glue.c\"\n")


def _build_files(code: str, filename: str) -> dict[str, str]:
    """{file name: text} to compile: one unit, or the split model (runtime/translation_units.py) and the glue unit;
    and the runtime unit (RUNTIME_UNIT), whose object the cache has after the first build."""
    split = _units.split_sources(code, filename)
    if split is None:
        return {"unit.c": _unit_source(code, filename), RUNTIME_UNIT: _runtime_unit()}
    glue = _glue_unit(_header_of(_units.GLUE_UNIT, split), _units.OUTPUTS_UNIT in split)
    return {**split, _units.GLUE_UNIT: glue, RUNTIME_UNIT: _runtime_unit()}


def _cold_files(code: str, filename: str) -> dict[str, str]:
    """{file name: text} of the library of the cold functions of the whole generated file `code`
    (runtime/translation_units.py cold_sources), its glue unit (c/mbs_cold_glue.c) and the runtime unit. Raises
    BuildError when the file has none."""
    split = _units.cold_sources(code, filename)
    if split is None:
        raise BuildError(f"{filename} has no functions to build apart (a tree's mass matrix and forces)")
    glue = ("/* cold glue unit written by mbs.runtime.build: do not edit */\n#include \"model.h\"\n"
            "#line 1 \"mbs_cold_glue.c\"\n#include \"mbs_cold_glue.c\"\n")
    return {**split, _units.COLD_GLUE_UNIT: glue, RUNTIME_UNIT: _runtime_unit()}


def _init_unit(module_name: str) -> str:
    """The unit that names the module: PyInit_<name> (exported) returns the glue's module under that name."""
    return ("/* init unit written by mbs.runtime.build: do not edit */\n"
            "#if defined(_WIN32)\n#define MBS_EXPORT __declspec(dllexport)\n"
            "#else\n#define MBS_EXPORT __attribute__((visibility(\"default\")))\n#endif\n"
            "void *mbs_module_init(const char *name);\n"
            f"MBS_EXPORT void *PyInit_{module_name}(void);\n"
            f"MBS_EXPORT void *PyInit_{module_name}(void)\n{{\n    return mbs_module_init(\"{module_name}\");\n}}\n")


def _joined(files: dict[str, str]) -> str:
    """All files as one text (the cache key's input and the inspection copy beside the module)."""
    if "model.h" not in files:
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
             module_name: str, tmp: Path, filename: str, cache: Path,
             outputs_flags: tuple[str, ...] = ()) -> tuple[str, tuple[str, ...], tuple[str, ...]]:
    """Compile the files in `tmp` into tmp/module.so: (the compiler's messages, the units compiled, the units whose
    objects came from the cache). Raises BuildError."""
    one_unit = "model.h" not in files
    objects, todo, pending = {}, [], []
    jobs = _unit_jobs(files, flags, model_flags, cc, cache, outputs_flags)
    for name, command, cached in jobs:
        if cached in _PREBUILDS and not _cancelled(cached):  # being compiled by prebuild: taken when done
            pending.append((name, command, cached))
        elif cached.exists() and _cache.problem(cached) is None:
            objects[name] = cached
        else:
            todo.append((name, command, cached))
    sources = [name for name, _, _ in jobs]
    if one_unit:
        (tmp / "unit.c").write_text(files["unit.c"], encoding="utf-8")
        unit = (f"-DMBS_MODULE_NAME={module_name}", *_includes())
        if not todo and not pending:  # the runtime object is in the cache: one compiler call compiles and links
            command = (*cc, *flags, *unit, "unit.c", *(str(objects[n]) for n in sources), "-o", "module.so", "-lm")
            return _run(command, tmp, filename), ("unit.c",), tuple(sources)
        first = (*cc, *_link_free(flags), *unit, "-c", "unit.c", "-o", "unit.o")
        head: tuple[str, ...] = ("unit.o",)
    else:
        _write_headers(files, tmp)
        (tmp / "init.c").write_text(_init_unit(module_name), encoding="utf-8")
        first = (*cc, *_compile_flags(flags), "-c", "init.c", "-o", "init.o")
        head = ("-fvisibility=hidden", "init.o")
    with ThreadPoolExecutor(max_workers=build_jobs()) as pool:
        outputs = list(pool.map(lambda job: _run(job[1], tmp, filename),
                                [(None, first)] + [_written(job, files, tmp) for job in todo]))
    prebuilt = []
    for name, command, cached in pending:
        with _PREBUILD_LOCK:
            job = _PREBUILDS.pop(cached, None)
        if job is not None:
            job.exception()  # wait for it (a failed one is compiled here, with its messages)
        if cached.exists() and _cache.problem(cached) is None:
            objects[name] = cached
            prebuilt.append(name)
        else:
            outputs.append(_run(_written((name, command, cached), files, tmp)[1], tmp, filename))
            todo.append((name, command, cached))
    for name, _, cached in todo:  # kept by content for the next build that has the same unit
        objects[name] = tmp / (name[:-2] + ".o")
        try:
            _cache.store_object(objects[name], cached, _object_label(name, files))
            objects[name] = cached
        except OSError:  # a cache that cannot keep it still links this build
            pass
    link = (*cc, *flags, *head, *(str(objects[n]) for n in sources), "-o", "module.so", "-lm")
    compiled = ("unit.c",) * one_unit + tuple(name for name, _, _ in todo) + tuple(prebuilt)
    _forget_finished_prebuilds()
    return "".join(outputs) + _run(link, tmp, filename), compiled, tuple(n for n in sources if n not in compiled)


def _write_headers(files: dict[str, str], tmp: Path) -> None:
    """Write the generated headers (model.h, translation_units.GLUE_HEADER) of `files` into `tmp`."""
    for name, text in files.items():
        if name.endswith(".h"):
            (tmp / name).write_text(text, encoding="utf-8")


def _includes() -> tuple[str, ...]:
    """The include folders of every unit: the run-time C files, Python's and NumPy's headers."""
    return f"-I{C_DIR}", f"-I{sysconfig.get_paths()['include']}", f"-I{np.get_include()}"


def _link_free(flags: tuple[str, ...]) -> tuple[str, ...]:
    """The flags without those of the link (-shared, the platform's)."""
    return tuple(f for f in flags if f not in ("-shared", *PLATFORM_FLAGS))


def _object_label(name: str, files: dict[str, str]) -> str:
    """What the cache's record says an object is."""
    if name == RUNTIME_UNIT:
        return f"{RUNTIME_UNIT}: the Python bindings and the integrators of every model"
    return f"{name} of {_cache.model_label(files[_header_of(name, files)])}"


def _compile_flags(flags: tuple[str, ...]) -> tuple[str, ...]:
    """The flags of a split build's compile steps (-c) and of the runtime unit's: the link's without -shared, hidden
    visibility."""
    return _link_free(flags) + ("-fvisibility=hidden",)


def _unit_jobs(files: dict[str, str], flags, model_flags, cc, cache: Path,
               outputs_flags: tuple[str, ...] = ()) -> list[tuple[str, tuple, Path]]:
    """(unit, compile command, where its object is kept) of the units whose objects the cache keeps (a split build's,
    and the runtime unit; not the one unit of a small model), the longest compile first."""
    jobs = []
    units = (n for n in files if n.endswith(".c") and n != "unit.c")
    for name in sorted(units, key=lambda n: -_weight(n, files, unit_flags(n, model_flags, outputs_flags))):
        command = (*cc, *_compile_flags(flags), *unit_flags(name, model_flags, outputs_flags), *_includes(), "-c",
                   name)
        jobs.append((name, command, _cache.object_path(cache, _object_key(name, files, command, cc))))
    return jobs


def unit_flags(name: str, model_flags: tuple[str, ...], outputs_flags: tuple[str, ...]) -> tuple[str, ...]:
    """The flags unit `name` of a split build gets beyond FLAGS: none for the glue unit and the runtime unit,
    model_flags for the model's units, and outputs_flags (COLD_UNIT_FLAGS) after them for the outputs' unit (the cold
    functions' units)."""
    if name in (_units.GLUE_UNIT, _units.COLD_GLUE_UNIT, RUNTIME_UNIT):
        return ()
    if name.startswith(_units.COLD_PREFIX):
        return (*model_flags, *COLD_UNIT_FLAGS)
    return (*model_flags, *outputs_flags) if name == _units.OUTPUTS_UNIT else model_flags


def _written(job, files: dict[str, str], tmp: Path) -> tuple[str, tuple]:
    """(unit, its full compile command) with the unit's text written into `tmp`."""
    name, command, _ = job
    (tmp / name).write_text(files[name], encoding="utf-8")
    return name, (*command, "-o", name[:-2] + ".o")


# ------------------------------------------------------------------------------------------ prebuild
#: Objects being compiled by prebuild in this process (their cache path -> the job), which build waits for.
_PREBUILDS: dict[Path, Future] = {}
_PREBUILD_LOCK = threading.Lock()
_PREBUILD_POOL: list[ThreadPoolExecutor] = []


def _forget_prebuilds() -> None:
    """In a forked child: the parent's compiler threads are not there, so neither are its jobs (build compiles
    what it does not find in the cache) nor its pool (a new one is made on first use)."""
    global _PREBUILD_LOCK
    _PREBUILD_LOCK = threading.Lock()
    _PREBUILDS.clear()
    _PREBUILD_POOL.clear()


def _cancelled(key: Path) -> bool:
    """Whether prebuild's job for the object `key` had not started and is now withdrawn (build compiles it in its
    own pool, beside the others: prebuild's one compiler process would otherwise compile its queue one unit after
    another while build waits and a core idles)."""
    with _PREBUILD_LOCK:
        job = _PREBUILDS.get(key)
        if job is None or not job.cancel():
            return False
        del _PREBUILDS[key]
        return True


def _forget_finished_prebuilds() -> None:
    """Drop the finished jobs that no build took (a derivation that failed after its prebuild, or whose file was
    then written whole): their objects are in the cache, and the table would otherwise grow for as long as the
    process lives."""
    with _PREBUILD_LOCK:
        for key in [key for key, job in _PREBUILDS.items() if job.done()]:
            del _PREBUILDS[key]


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_prebuilds)


def prebuild(equations_code: str, *, filename: str = "model.c", cache_dir: str | os.PathLike | None = None,
             extra_flags: tuple[str, ...] = (), model_flags: tuple[str, ...] | None = None,
             outputs: bool = True) -> int:
    """Start compiling, in the background, the units of a file whose equations' part is known and whose outputs'
    part is not yet (pipeline.generate writes the equations' C, then lowers the outputs): the model units and
    the glue unit of a split build do not depend on the outputs, so their objects can be made while the outputs
    are derived; build() (with the same options) then takes them from the cache, or waits for them. So is the
    runtime unit's object, when the cache has none yet. One compiler process less than build() runs, so the
    derivation keeps a core. Returns how many units were started (0 without a compiler, or with every object
    cached; at most 1, the runtime unit, for a model built as one unit). Never raises for the model's sake: a unit
    that fails is compiled again by build(), which reports it. outputs: whether the file will have an outputs'
    part (the glue unit then declares them; a scene without outputs has none)."""
    try:
        cc = tuple(compiler_command())
        model_flags = model_unit_flags(cc) if model_flags is None else tuple(model_flags)
    except BuildError:
        return 0
    flags = base_flags(cc) + tuple(extra_flags)
    files = _build_files(equations_code + ("\n" + _units.OUTPUTS_MARKER + "\n" if outputs else ""), filename)
    files.pop(_units.OUTPUTS_UNIT, None)
    cache = cache_folder(cache_dir)
    return _submit(_unit_jobs(files, flags, model_flags, cc, cache), files, cache, filename)


def prebuild_runtime(*, cache_dir: str | os.PathLike | None = None, extra_flags: tuple[str, ...] = ()) -> int:
    """Start compiling, in the background, the runtime unit's object (the Python bindings and the integrators,
    which depend on no model) when the cache has none yet: a model's derivation calls this as it starts
    (mbs/system.py), so that the first compile into an empty cache makes it on the core the derivation leaves
    idle, not after the equations' C is written. Returns 1 when started, else 0 (no compiler, already in the cache
    or being compiled). Never raises: build() compiles what is not there and reports it."""
    try:
        cc = tuple(compiler_command())
        compiler_version(cc)
    except BuildError:
        return 0
    flags = base_flags(cc) + tuple(extra_flags)
    cache = cache_folder(cache_dir)
    files = {RUNTIME_UNIT: _runtime_unit()}
    return _submit(_unit_jobs(files, flags, (), cc, cache), files, cache, RUNTIME_UNIT)


#: How many temporaries a model's tape holds at least for prebuild_head to start its glue unit before its functions
#: are printed: about the size from which a file with loops is split (translation_units.split_min_chars, 48 kB; the
#: Iltis's 3,896 temporaries printed 900 kB, the pendulum's 13 three kB). A smaller file is built as one unit, which
#: has no glue unit of its own: compiled early, it would be compiled for nothing.
HEAD_MIN_ENTRIES = 200


def prebuild_head(head: str, entries: int, *, filename: str = "model.c", cache_dir: str | os.PathLike | None = None,
                  extra_flags: tuple[str, ...] = (), outputs: bool = True) -> int:
    """Start compiling, in the background, the glue unit of a file of which only the head is written
    (compiler/ccode.py CEmitter.head: sizes, tables, declarations) and whose functions are being printed (`entries`
    temporaries on the tape): the glue unit of a split file with loops (the loop solver: as long a compile as a
    model unit) includes the head and the declarations of translation_units.GLUE_HEADER alone, so build() (with
    the same options) takes its object from the cache, or waits for it. Returns 1 when started, else 0 (no
    compiler, no loops, too small a tape for a split file, a head that glue_header refuses, or the object already
    there). outputs: as for prebuild. Never raises."""
    if entries < HEAD_MIN_ENTRIES or not _units.has_loops(head):
        return 0
    header = _units.glue_header(head, filename)
    try:
        cc = tuple(compiler_command())
        compiler_version(cc)
    except BuildError:
        return 0
    if header is None:
        return 0
    files = {_units.GLUE_HEADER: header, _units.GLUE_UNIT: _glue_unit(_units.GLUE_HEADER, outputs)}
    flags = base_flags(cc) + tuple(extra_flags)
    cache = cache_folder(cache_dir)
    return _submit(_unit_jobs(files, flags, (), cc, cache), files, cache, filename)


def _submit(jobs, files: dict[str, str], cache: Path, filename: str) -> int:
    """Queue the jobs whose objects are neither in the cache nor being compiled on prebuild's pool (one compiler
    process less than build() runs, so the derivation keeps a core); how many were queued."""
    started = 0
    with _PREBUILD_LOCK:
        if not _PREBUILD_POOL:
            _PREBUILD_POOL.append(ThreadPoolExecutor(max_workers=max(1, build_jobs() - 1)))
        for job in jobs:
            if job[2] in _PREBUILDS or job[2].exists():
                continue
            _PREBUILDS[job[2]] = _PREBUILD_POOL[0].submit(_prebuild_one, job, files, cache, filename)
            started += 1
    return started


@dataclass(frozen=True)
class Prebuilds:
    """What a compile hands the derivation (pipeline.generate's `equations_ready`), so that the C compiler starts
    on each unit as soon as what the unit is compiled from is known: called with the equations' C, prebuild; its
    `derivation_started` (called when a derivation begins, not when the generated code comes from the derivation
    cache) starts the runtime unit (prebuild_runtime), which depends on no model; its `head_written` (called with
    the file's head before its functions are printed) the glue unit (prebuild_head). outputs: whether the scene
    asks for outputs (the file then has an outputs' part, which the glue unit declares)."""

    cache_dir: str | os.PathLike | None = None
    outputs: bool = True

    def __call__(self, equations_code: str) -> int:
        return prebuild(equations_code, cache_dir=self.cache_dir, outputs=self.outputs)

    def derivation_started(self) -> int:
        return prebuild_runtime(cache_dir=self.cache_dir)

    def head_written(self, head: str, entries: int) -> int:
        return prebuild_head(head, entries, cache_dir=self.cache_dir, outputs=self.outputs)


def _prebuild_one(job, files: dict[str, str], cache: Path, filename: str) -> None:
    """Compile one unit in a folder of its own and keep its object in the cache."""
    try:
        cache.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".prebuild-", dir=cache))
    except OSError:  # build() reports an unusable cache
        return
    try:
        _write_headers(files, tmp)
        name, command = _written(job, files, tmp)
        _run(command, tmp, filename)
        _cache.store_object(tmp / (name[:-2] + ".o"), job[2], _object_label(name, files))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def runtime_object(*, cache_dir: str | os.PathLike | None = None, extra_flags: tuple[str, ...] = ()) -> Path:
    """The runtime unit's object (the Python bindings and the integrators, shared by every model) in the cache,
    compiled first when the cache has none or a damaged one: what the first build with these flags makes. Raises
    BuildError."""
    cc = tuple(compiler_command())
    flags = base_flags(cc) + tuple(extra_flags)
    cache = cache_folder(cache_dir)
    files = {RUNTIME_UNIT: _runtime_unit()}
    (job,) = _unit_jobs(files, flags, (), cc, cache)
    if not (job[2].exists() and _cache.problem(job[2]) is None):
        try:
            cache.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise BuildError(f"the build cache {cache} cannot be used ({exc.strerror or exc})") from None
        _prebuild_one(job, files, cache, RUNTIME_UNIT)
        if not job[2].exists():
            raise BuildError(f"the build cache {cache} cannot be written: set {CACHE_ENV} to a writable folder")
    return job[2]


#: The expected compile time of the units whose text is short but what they include is not, in characters of model
#: code: the glue unit of a model with loops (the loop solver: 1.9 s of CPU for the Iltis, whose 120-kB units take
#: 2 to 4 s) and the runtime unit (1.8 s). Started in their place among the model units, the two cores finish
#: together. The glue unit of a model without loops is the function table alone.
GLUE_WEIGHT = 80_000
RUNTIME_WEIGHT = 80_000
#: What a character of a unit compiled at -Og (the outputs' unit, the cold units) weighs against one at the model
#: units' level: the Iltis's outputs.c, 191,000 characters of code, took 1.04 s of CPU at -Og and its model units,
#: 126,000 to 134,000 each, 1.4 to 2.2 s (bench/compile_time.py --units). Weighed by its characters alone it was
#: started first, and a model unit ended the build alone on one core.
OG_WEIGHT = 0.5


def _weight(name: str, files: dict[str, str], extra_flags: tuple[str, ...] = ()) -> int:
    """A unit's expected compile time, in characters of model code (extra_flags: those it gets beyond FLAGS)."""
    if name == RUNTIME_UNIT:
        return RUNTIME_WEIGHT
    if name == _units.GLUE_UNIT:
        return GLUE_WEIGHT if _units.has_loops(files.get(_header_of(name, files), "")) else 0
    chars = _units.code_chars(files[name])
    return int(chars * OG_WEIGHT) if "-Og" in extra_flags else chars


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
          extra_flags: tuple[str, ...] = (), model_flags: tuple[str, ...] | None = None,
          outputs_flags: tuple[str, ...] | None = None) -> BuildResult:
    """Compile generated C source text into a cached extension module.

    ``filename`` is the name compiler messages use for the model.  extra_flags: appended to every compiler
    call; model_flags: appended to those of the model's units of a split build (default model_unit_flags);
    outputs_flags: appended after them to those of its outputs' unit (default OUTPUTS_UNIT_FLAGS).
    Raises BuildError with the compiler's messages when compilation fails.
    """
    return _cached_build(code, filename, cache_dir, extra_flags, model_flags, outputs_flags, "model")


def build_cold(code: str, *, filename: str = "model.c", cache_dir: str | os.PathLike | None = None,
               extra_flags: tuple[str, ...] = (), model_flags: tuple[str, ...] | None = None) -> BuildResult:
    """The library of the cold functions (runtime/translation_units.py COLD_FUNCTIONS) of the whole generated file
    `code` of a tree: an extension module of its own with their function table alone (c/mbs_cold_glue.c), built
    the first time one of them is called of a model whose file was written without them (compiler/ccode.py
    cold_apart; runtime/backends.py ColdLibrary), and cached by content like a model (a second call finds it).
    Its units get the cold units' flags (COLD_UNIT_FLAGS). Raises BuildError."""
    return _cached_build(code, filename, cache_dir, extra_flags, model_flags, None, "cold")


def _cached_build(code: str, filename: str, cache_dir, extra_flags, model_flags, outputs_flags,
                  library: str) -> BuildResult:
    """build (library "model") or build_cold (library "cold")."""
    cc = tuple(compiler_command())
    flags = base_flags(cc) + tuple(extra_flags)
    model_flags = model_unit_flags(cc) if model_flags is None else tuple(model_flags)
    outputs_flags = OUTPUTS_UNIT_FLAGS if outputs_flags is None else tuple(outputs_flags)
    key = _hash(code, filename, flags, model_flags, cc, outputs_flags, library)
    # (both under the cache's module prefix, so that `mbs cache` lists and cleans the cold libraries too)
    module_name = f"mbs_model_{key[:24]}" if library == "model" else f"mbs_model_{library}_{key[:24]}"
    cache = cache_folder(cache_dir)
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
    files = _cold_files(code, filename) if library == "cold" else _build_files(code, filename)
    unit = _joined(files)
    try:
        output, compiled, reused = _compile(files, flags, model_flags, cc, module_name, tmp, filename, cache,
                                            outputs_flags)
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
    if reused:
        logging.getLogger("mbs.cache").info("C build of %s: compiled %s; objects of %s from the cache",
                                            _cache.model_label(unit), ", ".join(compiled) or "nothing",
                                            ", ".join(reused))
    return BuildResult(target, module_name, key, False, output.strip(), compiled, reused)


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
