"""Baukasten: a multibody compiler for vehicle dynamics.

    import mbs
    sys = mbs.load("library/examples/pendulum.mbs")   # parse and validate (located errors: mbs.MbsError)
    res = sys.simulate("swing")                        # derive, generate C, compile (cached), integrate
    res["hinge.phi"]

Stages, each usable on its own: mbs.language (text -> validated model), mbs.compiler (model -> equations
-> C), mbs.runtime (compiled model, workspace, integrators, results).
"""

from mbs.language.diagnostics import MbsError

from .system import System, load, loads

__all__ = ["MbsError", "System", "load", "loads"]
__version__ = "0.1.0"
