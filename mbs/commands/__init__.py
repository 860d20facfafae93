"""One small class per ``mbs`` subcommand: its arguments and what it runs (the work lives in the stages).

A command is a class with ``help``, ``arguments(parser)`` and ``run(args) -> exit status``; adding one is a
module in this package and a line in COMMANDS.
"""

from .accuracy import Accuracy
from .analysis import Equilibrium, Info, Linearize
from .compile import Compile
from .eom import Eom
from .model_files import Check, Export, Fmt
from .numerics import Numerics
from .sensitivity import Sensitivity
from .simulate import Simulate

COMMANDS = {"check": Check, "fmt": Fmt, "export": Export, "simulate": Simulate, "compile": Compile, "eom": Eom,
            "info": Info, "equilibrium": Equilibrium, "linearize": Linearize, "accuracy": Accuracy,
            "numerics": Numerics, "sensitivity": Sensitivity}
