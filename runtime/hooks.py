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
back end calls it directly. Values cross in the units the hook declares.

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

from .errors import UsageError

#: How a run supplies a hook, for messages.
HOW_TO_SUPPLY = ("give its implementation when running: `mbs simulate ... --hook {name}=file.c` (or "
                 "`--hook {name}=module.py:function`), or `System.simulate(..., hooks={{'{name}': function or "
                 "'file.c'}})`")
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
        """What decides the compiled library: which hooks are Python and each C file's name and text."""
        return tuple(sorted([(n, "python") for n in self.python]
                            + [(n, "c", p, hashlib.sha256(text.encode()).hexdigest()) for n, (p, text)
                               in self.c_files.items()]))

    def c_source(self) -> str:
        """The text appended to the generated C: the C files, then one trampoline per Python hook."""
        parts, seen = [], set()
        for name, (path, text) in self.c_files.items():
            if os.path.realpath(path) in seen:  # one file may implement several hooks
                continue
            seen.add(os.path.realpath(path))
            shown = path.replace("\\", "\\\\").replace('"', '\\"')
            parts.append(f'#line 1 "{shown}"\n{text}\n')
        if self.python:
            parts.append("#line 1 \"<python hooks: runtime/hooks.py>\"\n"
                         "/* Python hooks: a ctypes callback per hook, set by runtime/hooks.py before a run */")
            for name in self.python:
                parts.append(f"int (*mbs_hook_python_{name})(const double *, double *) = NULL;\n"
                             f"int {name}(const double *arg, double *res)\n{{\n"
                             f"    return mbs_hook_python_{name} != NULL ? mbs_hook_python_{name}(arg, res) : -1;\n}}\n")
        return "\n".join(parts)

    # -- before a run ---------------------------------------------------------------------------------
    def attach(self, compiled) -> None:
        """Connect the implementations to a compiled model and clear the last failure."""
        self._record.failure = None
        backend = compiled.backend
        if backend.kind == "numpy":
            for spec in self.specs:
                for k in range(len(spec.results)):
                    setattr(backend.module, f"mbs_hook__{spec.name}__{k}__{len(spec.results)}",
                            self._numpy_helper(spec, k))
            return
        lib = _library(backend.module)
        for spec in self.specs:
            if spec.name in self.python:
                callback = _CALLBACK(self._c_callback(spec))
                # kept alive while the library points to it (until the next attach replaces it): the binding
                # itself may be gone long before the last call of a model function
                _CALLBACKS[(backend.module.__file__, spec.name)] = callback
                pointer = ctypes.c_void_p.in_dll(lib, f"mbs_hook_python_{spec.name}")
                pointer.value = ctypes.cast(callback, ctypes.c_void_p).value
        lib.mbs_hook_reset()

    def _c_callback(self, spec) -> Callable:
        fn, nargs, nres, record = self.python[spec.name], len(spec.args), len(spec.results), self._record

        def callback(arg, res) -> int:
            values = [arg[i] for i in range(nargs)]
            try:
                results = _call(spec, fn, values)
            except BaseException as exc:  # noqa: BLE001 - nothing may cross the C boundary; reported after the run
                if record.failure is None:
                    record.failure = HookFailure(spec.name, math.nan, tuple(values), _describe(exc))
                return -1
            for i in range(nres):
                res[i] = results[i]
            return 0
        return callback

    def _numpy_helper(self, spec, k: int) -> Callable:
        fn, record = self.python.get(spec.name), self._record

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
        if python is not None and python.name == name:
            reason = python.reason
        elif status.value == -2:
            reason = "returned a non-finite result"
        else:
            reason = f"returned status {status.value}"
        return HookFailure(name, t.value, values, reason)

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
    hook without an implementation is an error located at its declaration (before anything is compiled)."""
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
        if callable(given):
            python[name] = given
        elif isinstance(given, (str, os.PathLike)) and os.fspath(given).endswith(".c"):
            path = Path(given)
            try:
                c_files[name] = (os.fspath(given), path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError) as exc:
                raise UsageError(f"hook '{name}': cannot read the C file {os.fspath(given)} "
                                 f"({getattr(exc, 'strerror', None) or exc})") from None
        else:
            raise UsageError(f"hook '{name}': expected a Python callable or the path of a C source file (.c), got "
                             f"{given!r}")
    return HookBinding(tuple(specs), python, c_files)


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
