"""Baukasten: a multibody compiler for vehicle dynamics.

    import mbs
    sys = mbs.load("library/examples/pendulum.mbs")   # parse and validate (located errors: mbs.MbsError)
    res = sys.simulate("swing")                        # derive, generate C, compile (cached), integrate
    res["hinge.phi"]

Stages, each usable on its own: mbs.language (text -> validated model), mbs.compiler (model -> equations
-> C), mbs.runtime (compiled model, workspace, integrators, results).

The names below are imported on first use (PEP 562), so `import mbs` and the `mbs` command start without
loading sympy, scipy or the code generator.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

__all__ = ["MbsError", "Results", "System", "load", "loads"]
__version__ = "0.1.0"

_LAZY = {"MbsError": "mbs.language.diagnostics", "Results": "mbs.runtime.results", "System": "mbs.system",
         "load": "mbs.system", "loads": "mbs.system"}

if TYPE_CHECKING:  # what IDEs and type checkers see
    from mbs.language.diagnostics import MbsError
    from mbs.runtime.results import Results
    from mbs.system import System, load, loads


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mbs' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
