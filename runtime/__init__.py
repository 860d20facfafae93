"""Run-time stage: compiled model (immutable), workspace (mutable), integrators, simulation, results.

See runtime/README.md for the contract with the generated code.
"""

from .model import CompiledModel, load_c, load_model, load_numpy
from .results import Results
from .simulate import simulate
from .workspace import Workspace

__all__ = ["CompiledModel", "Results", "Workspace", "load_c", "load_model", "load_numpy", "simulate"]
