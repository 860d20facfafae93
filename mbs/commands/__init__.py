"""One small class per ``mbs`` subcommand: its arguments and what it runs (the work lives in the stages).

A command is a class with ``help``, ``arguments(parser)`` and ``run(args) -> exit status``; adding one is a
module in this package and a line in COMMANDS.
"""

from .accuracy import Accuracy
from .analysis import Equilibrium, Info, Linearize
from .animate import Animate
from .cache import Cache
from .comfort import Comfort
from .compile import Compile
from .eom import Eom
from .fmu import Fmu
from .model_files import Check, Export, Fmt
from .modes import Modes
from .numerics import Numerics
from .optimize import Optimize
from .sensitivity import Sensitivity
from .simulate import Simulate
from .sweep import Sweep
from .tir import Tir

COMMANDS = {"check": Check, "fmt": Fmt, "export": Export, "simulate": Simulate, "compile": Compile, "eom": Eom,
            "info": Info, "equilibrium": Equilibrium, "linearize": Linearize, "accuracy": Accuracy,
            "animate": Animate, "cache": Cache, "comfort": Comfort, "fmu": Fmu, "modes": Modes,
            "numerics": Numerics, "optimize": Optimize, "sensitivity": Sensitivity, "sweep": Sweep, "tir": Tir}
