"""Integrators: one base class (base.py), one file per method, and a registry of names.

Built in: ``dopri5``, ``adams``, ``rodasp`` and ``rodas5p`` (in C, the fast path) and scipy's ``RK45``, ``DOP853``, ``Radau``,
``BDF``, ``LSODA`` (driven from Python), ``auto`` (dopri5, rodas5p once it finds stiffness), and SUNDIALS'
``cvode_adams``, ``cvode_bdf``, ``ida`` (scikit-sundae, imported when first used).  Add a method by subclassing OdeSolver and calling ``register``.
"""

from .base import FAILED, FINISHED, RUNNING, DenseOutput, OdeSolver
from .dopri5 import Dopri5  # first: registration order is the order available() lists, the default leading
from .adams import Adams  # noqa: I001
from .native import NativeSolver
from .registry import available, get_integrator, register
from .rodasp import Rodasp
from .rodas5p import Rodas5p
from .scipy_methods import BDF, DOP853, LSODA, RK45, Radau, ScipyMethod
from .auto import Auto  # noqa: E402  (after the methods it combines)
from .cvode_adams import CvodeAdams
from .cvode_bdf import CvodeBdf
from .ida import Ida

__all__ = ["OdeSolver", "DenseOutput", "NativeSolver", "ScipyMethod", "Dopri5", "Adams", "Rodasp", "Rodas5p", "RK45",
           "DOP853", "Radau", "BDF", "LSODA", "Auto", "CvodeAdams", "CvodeBdf", "Ida", "register", "get_integrator",
           "available", "RUNNING", "FINISHED", "FAILED"]
