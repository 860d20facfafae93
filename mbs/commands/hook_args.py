"""`--hook NAME=file.c` and `--hook NAME=module.py:function`: the implementations of a model's user hooks, one
option for every command that runs or builds a model (runtime/hooks.py resolves what is given, as it does for
`hooks={...}` of the Python API).
"""

from __future__ import annotations

from .common import ArgumentError

HELP = ("implementation of a user hook the model declares: NAME=file.c (compiled into the model) or "
        "NAME=module.py:function (Python, for prototyping); repeat for several hooks")


def hook_arg(p) -> None:
    p.add_argument("--hook", action="append", default=[], metavar="NAME=IMPL", help=HELP)


def hooks_from_args(args) -> dict:
    """{name: 'file.c' or the Python function} from the --hook options, each file read and each Python file
    imported once, here (bad usage: exit status 2)."""
    from mbs.runtime.hook_implementations import implementation
    hooks: dict = {}
    for text in getattr(args, "hook", None) or []:
        name, sep, impl = text.partition("=")
        name, impl = name.strip(), impl.strip()
        if not sep or not name or not impl:
            raise ArgumentError(f"--hook {text}: expected NAME=file.c or NAME=module.py:function")
        if name in hooks:
            raise ArgumentError(f"--hook {name} is given twice")
        if not impl.endswith(".c") and not impl.rpartition(":")[0].endswith(".py"):
            raise ArgumentError(f"--hook {name}={impl}: expected a C file (.c) or module.py:function")
        hooks[name] = implementation(name, impl)
    return hooks
