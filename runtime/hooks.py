"""The implementations of a model's user hooks for one run (language/hooks.py declares them, compiler/hooks.py
calls them): a Python callable for prototyping, or a C source file compiled into the model for speed.

    res = system.simulate(hooks={"friction_law": my_law})            # Python: my_law(w, n, mu_s, mu_k) -> f
    res = system.simulate(hooks={"friction_law": "friction_law.c"})  # C: int friction_law(const double *arg,
                                                                     #                     double *res)

Why this shape. The model file only declares a hook, so reading a model never runs code; an implementation
is named by the caller of a run. A C file is appended to the generated model's build unit (its text is part
of the cache key; compiler messages name the file and line through ``#line``). A Python callable reaches
the C back end through a ctypes callback stored in a pointer the binding exports (one per loaded library:
fine for prototyping, slow, and not for parallel runs of one model with different callables); the NumPy
back end calls it directly. Values cross in the units the hook declares. What is given (a callable,
'file.c', 'module.py:function') is resolved by hook_implementations.py, the same for every command.

Derivatives (for the generated Jacobians, compiler/hooks.py): a C file may define NAME_derivative, a Python
callable may carry `.derivative`; the binding adds a trampoline for the latter. The NumPy back end gets the
same central differences as the C helpers when there is none.

A failing hook (a Python exception, a C status other than 0, a non-finite result) ends the run: the
generated helper returns NaN, the model function reports a non-finite value, the integrator stops with the
samples so far, and :meth:`HookBinding.failure` names the hook, the time and its arguments for the message.
"""

from __future__ import annotations

import ctypes
import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.language.hooks import DIFFERENCE_STEP, derivative_name

from .errors import UsageError
from .hook_implementations import derivative_of, implementation, loaded, read_source

#: How a run supplies a hook, for messages.
HOW_TO_SUPPLY = ("give its implementation with the run: `--hook {name}=file.c` (or `--hook {name}=module.py:function`) "
                 "on the command line, or `hooks={{'{name}': function, 'file.c' or 'module.py:function'}}` in Python")
_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double))


@dataclass(frozen=True)
class HookFailure:
    """The first hook failure of a run."""

    name: str
    t: float
    args: tuple[float, ...]
    reason: str


@dataclass
class _Record:
    """What a Python hook left when it failed (the C side records the time and the arguments)."""

    failure: HookFailure | None = None


@dataclass
class HookBinding:
    """Every declared hook's implementation: {name: Python callable or C source file}."""

    specs: tuple        #: language.hooks.HookSpec of the model, in declaration order
    python: dict        #: name -> callable
    c_files: dict       #: name -> (path as given, source text)
    _record: _Record = field(default_factory=_Record)

    @property
    def key(self) -> tuple:
        """What decides the compiled library: which hooks are Python (with a derivative or not) and each C file's
        name and text."""
        return tuple(sorted([(n, "python", derivative_of(fn) is not None) for n, fn in self.python.items()]
                            + [(n, "c", p, hashlib.sha256(text.encode()).hexdigest()) for n, (p, text)
                               in self.c_files.items()]))

    def c_paths(self) -> list[str]:
        """The C files, each once (one file may implement several hooks)."""
        return list({os.path.realpath(path): path for path, _ in self.c_files.values()}.values())

    def c_file_names(self) -> dict[str, tuple[str, str]]:
        """{file name: (path, text)} of the C files under names unique among them (an FMU's sources/)."""
        out: dict[str, tuple[str, str]] = {}
        for path in self.c_paths():
            stem, name, k = Path(path).stem, Path(path).name, 2
            while name in out:
                name, k = f"{stem}_{k}.c", k + 1
            out[name] = (path, next(text for p, text in self.c_files.values() if p == path))
        return out

    def c_source(self, include: bool = False) -> str:
        """The text appended to the generated C: the C files, then one trampoline per Python hook. include:
        `#include "NAME.c"` of each file under its name in c_file_names (to build beside copies of them), else
        the files' text itself (compiler messages name the files through #line)."""
        parts = []
        for name, (path, text) in self.c_file_names().items():
            if include:
                parts.append(f'#include "{name}"')
            else:
                shown = path.replace("\\", "\\\\").replace('"', '\\"')
                parts.append(f'#line 1 "{shown}"\n{text}\n')
        if self.python:
            parts.append("#line 1 \"<python hooks: runtime/hooks.py>\"\n"
                         "/* Python hooks: a ctypes callback per hook, set by runtime/hooks.py before a run */")
            for name, fn in self.python.items():
                functions = [name] + ([f"{name}_derivative"] if derivative_of(fn) is not None else [])
                for function in functions:
                    parts.append(f"int (*mbs_hook_python_{function})(const double *, double *) = NULL;\n"
                                 f"int {function}(const double *arg, double *res)\n{{\n"
                                 f"    return mbs_hook_python_{function} != NULL ? "
                                 f"mbs_hook_python_{function}(arg, res) : -1;\n}}\n")
        return "\n".join(parts)

    # -- before a run ---------------------------------------------------------------------------------
    def attach(self, compiled) -> None:
        """Connect the implementations to a compiled model and clear the last failure."""
        self._record.failure = None
        backend = compiled.backend
        if backend.kind == "numpy":
            for spec in self.specs:
                n = len(spec.results)
                for k in range(n):
                    setattr(backend.module, f"mbs_hook__{spec.name}__{k}__{n}", self._numpy_helper(spec, k))
                    for j in range(len(spec.args)):
                        setattr(backend.module, derivative_name(spec.name, k, n, j), self._numpy_partial(spec, k, j))
            return
        lib = _library(backend.module)
        for spec in self.specs:
            if spec.name in self.python:
                fn = loaded(self.python[spec.name])
                self._point(lib, backend.module.__file__, spec.name, self._c_callback(spec, fn, len(spec.results)))
                derivative = derivative_of(fn)
                if derivative is not None:
                    self._point(lib, backend.module.__file__, f"{spec.name}_derivative",
                                self._c_callback(spec, derivative, len(spec.results) * len(spec.args), jacobian=True))
        lib.mbs_hook_reset()

    @staticmethod
    def _point(lib, path: str, function: str, python) -> None:
        """Set the library's pointer mbs_hook_python_<function> to a ctypes callback of `python`."""
        callback = _CALLBACK(python)
        # kept alive while the library points to it (until the next attach replaces it): the binding
        # itself may be gone long before the last call of a model function
        _CALLBACKS[(path, function)] = callback
        pointer = ctypes.c_void_p.in_dll(lib, f"mbs_hook_python_{function}")
        pointer.value = ctypes.cast(callback, ctypes.c_void_p).value

    def _c_callback(self, spec, fn, nres: int, jacobian: bool = False) -> Callable:
        """The Python side of a ctypes callback: fn's results (or, jacobian, its derivative's row-major
        matrix) into res; a failure kept for the message and reported to C as status -1."""
        nargs, record = len(spec.args), self._record
        call = _call_derivative if jacobian else _call

        def callback(arg, res) -> int:
            values = [arg[i] for i in range(nargs)]
            try:
                results = call(spec, fn, values)
            except BaseException as exc:  # noqa: BLE001 - nothing may cross the C boundary; reported after the run
                if record.failure is None:
                    what = "its derivative: " if jacobian else ""
                    record.failure = HookFailure(spec.name, math.nan, tuple(values), what + _describe(exc))
                return -1
            for i in range(nres):
                res[i] = results[i]
            return 0
        return callback

    def _numpy_helper(self, spec, k: int) -> Callable:
        fn, record = loaded(self.python.get(spec.name)), self._record

        def helper(t, *args):
            values = tuple(float(a) for a in args)
            try:
                results = _call(spec, fn, values)
                if not all(math.isfinite(r) for r in results):
                    raise ArithmeticError(f"returned a non-finite result {results}")
            except BaseException as exc:  # noqa: BLE001 - reported after the run, as on the C back end
                if record.failure is None:
                    record.failure = HookFailure(spec.name, float(t), values, _describe(exc))
                return math.nan
            return results[k]
        return helper

    def _numpy_partial(self, spec, k: int, j: int) -> Callable:
        """d(result k)/d(argument j) for the NumPy back end: the hook's derivative, else the central difference
        the C helpers take (compiler/hooks.py)."""
        value = self._numpy_helper(spec, k)
        derivative, record, nargs = derivative_of(self.python.get(spec.name)), self._record, len(spec.args)

        def partial(t, *args):
            if derivative is not None:
                values = tuple(float(a) for a in args)
                try:
                    d = _call_derivative(spec, derivative, values)[k * nargs + j]
                    if not math.isfinite(d):
                        raise ArithmeticError(f"returned a non-finite derivative {d}")
                    return d
                except BaseException as exc:  # noqa: BLE001 - reported after the run
                    if record.failure is None:
                        record.failure = HookFailure(spec.name, float(t), values, "its derivative: " + _describe(exc))
                    return math.nan
            a = float(args[j])
            h = DIFFERENCE_STEP * max(abs(a), 1.0)
            h = (a + h) - a
            up, down = list(args), list(args)
            up[j], down[j] = a + h, a - h
            return (value(t, *up) - value(t, *down)) / (2.0 * h)
        return partial

    def value(self, name: str, result: int, args) -> float:
        """Result `result` of the Python hook `name` at `args` (a failure raises, naming the hook)."""
        spec = next(s for s in self.specs if s.name == name)
        try:
            return _call(spec, loaded(self.python[name]), list(args))[result]
        except Exception as exc:  # noqa: BLE001 - the user's code: a message naming the hook
            raise UsageError(self.message(HookFailure(name, math.nan, tuple(args), _describe(exc)))) from None

    # -- after a run ----------------------------------------------------------------------------------
    def failure(self, compiled) -> HookFailure | None:
        """The first hook failure since `attach`, or None."""
        python = self._record.failure
        if compiled.backend.kind == "numpy":
            return python
        lib = _library(compiled.backend.module)
        t, status, narg = ctypes.c_double(), ctypes.c_int(), ctypes.c_int()
        most = max([len(s.args) for s in self.specs] + [1])
        args = (ctypes.c_double * most)()
        name = lib.mbs_hook_failure(ctypes.byref(t), ctypes.byref(status), args, ctypes.byref(narg))
        if name is None:
            return python
        name = name.decode()
        values = tuple(args[i] for i in range(narg.value))
        derivative = name not in {s.name for s in self.specs}  # NAME_derivative (compiler/hooks.py)
        name = name.removesuffix("_derivative") if derivative else name
        if python is not None and python.name == name:
            reason = python.reason
        elif status.value == -2:
            reason = "returned a non-finite result"
        else:
            reason = f"returned status {status.value}"
        return HookFailure(name, t.value, values, ("its derivative " if derivative and python is None else "") + reason)

    def message(self, failure: HookFailure) -> str:
        """``hook 'friction_law' failed at t = 0.5 s (w = 0.2 m/s, n = 9.81 N): ValueError: ...``"""
        spec = next(s for s in self.specs if s.name == failure.name)
        shown = ", ".join(f"{slot.name} = {value:.6g}" + (f" {slot.unit}" if slot.unit != "1" else "")
                          for slot, value in zip(spec.args, failure.args))
        when = f" at t = {failure.t:.6g} s" if math.isfinite(failure.t) else ""
        return f"hook '{failure.name}' failed{when} ({shown}): {failure.reason}"


def _call(spec, fn, values) -> list[float]:
    """The results of a Python hook as floats, checked against the declaration."""
    out = fn(*values)
    n = len(spec.results)
    if isinstance(out, Mapping):
        missing = [r.name for r in spec.results if r.name not in out]
        if missing:
            raise ValueError(f"the returned mapping lacks the result(s) {', '.join(missing)}")
        return [float(out[r.name]) for r in spec.results]
    if n == 1 and not isinstance(out, (tuple, list)) and getattr(out, "ndim", 0) == 0:
        return [float(out)]
    values = [float(v) for v in out]
    if len(values) != n:
        raise ValueError(f"returned {len(values)} values; the hook declares {n} result(s) "
                         f"({', '.join(r.name for r in spec.results)})")
    return values


def _call_derivative(spec, fn, values) -> list[float]:
    """A Python derivative's matrix d res[i]/d arg[j] as floats, row-major (one result: a flat row is fine)."""
    rows = fn(*values)
    nres, nargs = len(spec.results), len(spec.args)
    flat = [float(v) for v in _flatten(rows)]
    if len(flat) != nres * nargs:
        raise ValueError(f"the derivative returned {len(flat)} values; {nres} result(s) x {nargs} argument(s) = "
                         f"{nres * nargs} expected")
    return flat


def _flatten(rows):
    if hasattr(rows, "ravel"):
        return list(rows.ravel())
    out = []
    for row in (rows if isinstance(rows, (list, tuple)) else [rows]):
        out.extend(row if isinstance(row, (list, tuple)) else [row])
    return out


def _describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


_LIBRARIES: dict[str, ctypes.CDLL] = {}
#: (library file, hook) -> the ctypes callback its pointer holds now
_CALLBACKS: dict[tuple[str, str], object] = {}


def _library(module) -> ctypes.CDLL:
    """The loaded extension module as a ctypes library (dlopen of a loaded file returns the same copy)."""
    path = module.__file__
    lib = _LIBRARIES.get(path)
    if lib is None:
        lib = ctypes.CDLL(path)
        lib.mbs_hook_failure.restype = ctypes.c_char_p
        lib.mbs_hook_failure.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int),
                                         ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int)]
        lib.mbs_hook_reset.restype = None
        _LIBRARIES[path] = lib
    return lib


# ------------------------------------------------------------------------------------------ checking what is given
def bind(specs: tuple, supplied: Mapping[str, object] | None, model_name: str = "model") -> HookBinding | None:
    """The binding of the hooks a caller supplies, checked against the model's declarations; None when the
    model declares none and none are given. A hook the model does not declare is a usage error; a declared
    hook without an implementation is an error located at its declaration (before anything is compiled).
    A binding given again is returned as it is."""
    if isinstance(supplied, HookBinding):
        return supplied
    supplied = dict(supplied or {})
    declared = {s.name: s for s in specs}
    unknown = [name for name in supplied if name not in declared]
    if unknown:
        from mbs.language.scope import did_you_mean
        names = ", ".join(declared) or "none"
        raise UsageError(f"model '{model_name}' declares no hook '{unknown[0]}'{did_you_mean(unknown[0], declared)} "
                         f"(hooks: {names})")
    missing = [s for s in specs if s.name not in supplied]
    if missing:
        raise MbsError([Diagnostic("error", f"hook '{s.name}' is declared but no implementation was supplied: "
                                            + HOW_TO_SUPPLY.format(name=s.name), s.span) for s in missing])
    if not specs:
        return None
    python, c_files = {}, {}
    for name, given in supplied.items():
        given = implementation(name, given)
        if callable(given):
            python[name] = given
        else:
            c_files[name] = (os.fspath(given), read_source(name, given, "C file"))
    return HookBinding(tuple(specs), python, c_files)


def require_python(binding: HookBinding | None, why: str) -> None:
    """Refuse C hooks where nothing is compiled (the equations evaluated by sympy)."""
    if binding is not None and binding.c_files:
        names = ", ".join(binding.c_files)
        raise UsageError(f"hook(s) {names}: a C file cannot be used there, {why}; give the hook as a Python "
                         f"function (--hook {next(iter(binding.c_files))}=module.py:function)")


def require_c(binding: HookBinding | None, why: str) -> None:
    """Refuse Python hooks where the model runs without Python (an FMU, a standalone library)."""
    if binding is not None and binding.python:
        names = ", ".join(binding.python)
        raise UsageError(f"hook(s) {names}: a Python implementation cannot go there, {why}; give the hook as a C "
                         f"file (--hook {next(iter(binding.python))}=file.c)")


def check_numpy(binding: HookBinding | None) -> None:
    """A C hook needs the C back end (the NumPy back end calls Python hooks only)."""
    if binding is not None and binding.c_files:
        names = ", ".join(binding.c_files)
        raise UsageError(f"the C hook(s) {names} need the C back end (no C compiler found, or backend='numpy'); "
                         "supply a Python callable instead")


def report(binding: HookBinding, compiled, results) -> None:
    """Make a run a hook ended say so: the hook, the time, its arguments, and the state the samples end at."""
    failure = binding.failure(compiled)
    if failure is None:
        return
    message = binding.message(failure)
    if len(results):
        row = results.columns(compiled.x_names)[-1]
        shown = ", ".join(f"{n} = {v:.6g}" for n, v in list(zip(compiled.x_names, row))[:8])
        more = ", ..." if len(compiled.x_names) > 8 else ""
        message += f"; results kept up to t = {results.t[-1]:.6g} s, state there: {shown}{more}"
    results.metadata["status"] = "failed"
    results.metadata["message"] = message
