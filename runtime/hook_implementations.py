"""What a run is given for a user hook, resolved once for every command and API entry (runtime/hooks.py binds it
to the model's declarations): a Python callable as it is; ``"module.py:function"`` as a PythonFileHook; a C
file's path, checked to exist. `mbs ... --hook NAME=IMPL` (mbs/commands/hook_args.py) and ``hooks={...}`` of
the Python API both come here, so they accept the same things and say the same when something is wrong.

A Python file is imported only because the caller names it (a model file never can), under a private module
name, once per process; a PythonFileHook pickles as the file's path, text and function name, so that a Dask
worker, here or on another machine, imports it itself.
"""

from __future__ import annotations

import hashlib
import os
import types
from pathlib import Path
from typing import Callable

from .errors import UsageError


def implementation(name: str, given):
    """What a run is given for hook `name`, resolved once for every command and API entry: a Python callable as
    it is; 'module.py:function' as a PythonFileHook (imported now, so a broken file is an error before any
    build); 'file.c' (or a path) as the path of a C file, checked to exist."""
    if callable(given):
        return given
    if isinstance(given, (str, os.PathLike)):
        text = os.fspath(given)
        if text.endswith(".c"):
            if not Path(text).is_file():
                raise UsageError(f"hook '{name}': no C file {text}")
            return given
        path, sep, function = text.rpartition(":")
        if sep and path.endswith(".py"):
            if not function.isidentifier():
                raise UsageError(f"hook '{name}': '{function}' in {text} is not a Python function name")
            hook = PythonFileHook(path, function, read_source(name, path, "Python file"))
            hook.load(name)
            return hook
    raise UsageError(f"hook '{name}': expected a Python callable, the path of a C source file (file.c) or "
                     f"module.py:function, got {given!r}")


def read_source(name: str, path, what: str) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise UsageError(f"hook '{name}': no {what} {os.fspath(path)}") from None
        raise UsageError(f"hook '{name}': cannot read the {what} {os.fspath(path)} "
                         f"({getattr(exc, 'strerror', None) or exc})") from None


class PythonFileHook:
    """A Python hook named as ``module.py:function``: called like the function; pickled as the file's path, its
    text and the function's name, so that every process that runs the model (a Dask worker, here or on another
    machine) imports the file itself, once. The module gets a private name: it cannot shadow an installed
    package. A file is imported only because the caller named it (a model file never can)."""

    def __init__(self, path: str, function: str, source: str):
        self.path, self.function, self.source = os.fspath(path), function, source
        self._fn = None

    def load(self, name: str = "") -> Callable:
        """The function (the module imported on the first call in this process)."""
        if self._fn is None:
            key = (os.path.abspath(self.path), hashlib.sha256(self.source.encode()).hexdigest(), self.function)
            fn = _FILE_FUNCTIONS.get(key)
            if fn is None:
                fn = _FILE_FUNCTIONS[key] = _import(self, name or self.function)
            self._fn = fn
        return self._fn

    def __call__(self, *args):
        return self.load()(*args)

    @property
    def derivative(self):
        return derivative_of(self.load())

    def __reduce__(self):
        return PythonFileHook, (self.path, self.function, self.source)

    def __repr__(self) -> str:
        return f"{self.path}:{self.function}"


_FILE_FUNCTIONS: dict[tuple, Callable] = {}


def loaded(fn):
    """The function itself (a PythonFileHook imported), for the calls of a run."""
    return fn.load() if isinstance(fn, PythonFileHook) else fn


def _import(hook: PythonFileHook, name: str) -> Callable:
    module = types.ModuleType(f"mbs_user_hook_{name}")
    module.__file__ = hook.path
    try:
        exec(compile(hook.source, hook.path, "exec"), module.__dict__)
    except Exception as exc:  # noqa: BLE001 - the user's module: its failure is a message, not our traceback
        raise UsageError(f"hook '{name}': importing {hook.path} failed: {type(exc).__name__}: {exc}") from None
    fn = getattr(module, hook.function, None)
    if not callable(fn):
        raise UsageError(f"hook '{name}': {hook.path} has no function '{hook.function}'")
    return fn


def derivative_of(fn) -> Callable | None:
    """A Python hook's own derivative: the callable's attribute ``derivative`` (None: central differences)."""
    fn = loaded(fn)
    derivative = getattr(fn, "derivative", None)
    return derivative if callable(derivative) else None
