"""`--hook NAME=file.c` and `--hook NAME=module.py:function`: the implementations of a model's user hooks.

A Python file is imported only because the command names it (a model file never can); its module gets a
private name, so it cannot shadow an installed package.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from .common import ArgumentError

HELP = ("implementation of a user hook the model declares: NAME=file.c (compiled into the model) or "
        "NAME=module.py:function (Python, for prototyping); repeat for several hooks")


def hook_arg(p) -> None:
    p.add_argument("--hook", action="append", default=[], metavar="NAME=IMPL", help=HELP)


def hooks_from_args(args) -> dict:
    """{name: 'file.c' or callable} from the --hook options (ArgumentError: exit status 2)."""
    hooks: dict = {}
    for text in getattr(args, "hook", None) or []:
        name, sep, impl = text.partition("=")
        name, impl = name.strip(), impl.strip()
        if not sep or not name or not impl:
            raise ArgumentError(f"--hook {text}: expected NAME=file.c or NAME=module.py:function")
        if name in hooks:
            raise ArgumentError(f"--hook {name} is given twice")
        if impl.endswith(".c"):
            if not Path(impl).is_file():
                raise ArgumentError(f"--hook {name}: no C file {impl}")
            hooks[name] = impl
        else:
            hooks[name] = _python_function(name, impl)
    return hooks


def _python_function(name: str, impl: str):
    path, sep, function = impl.rpartition(":")
    if not sep or not path.endswith(".py") or not function.isidentifier():
        raise ArgumentError(f"--hook {name}={impl}: expected a C file (.c) or module.py:function")
    if not Path(path).is_file():
        raise ArgumentError(f"--hook {name}: no Python file {path}")
    spec = importlib.util.spec_from_file_location(f"mbs_user_hook_{name}", path)
    if spec is None or spec.loader is None:
        raise ArgumentError(f"--hook {name}: cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # noqa: BLE001 - the user's module: its failure is a message, not our traceback
        raise ArgumentError(f"--hook {name}: importing {path} failed: {type(exc).__name__}: {exc}") from None
    fn = getattr(module, function, None)
    if not callable(fn):
        raise ArgumentError(f"--hook {name}: {path} has no function '{function}'")
    return fn
