"""The run-time layer's error vocabulary (STYLE.md point 4).

Every error a user can cause here is an :class:`~mbs.language.diagnostics.MbsError`, so the command line
shows it as ``error: message`` without a traceback.  Numerical failure during integration is *not* an
exception: integrators turn it into a status and a message (see ``integrators/base.py``).
"""

from __future__ import annotations

from mbs.language.diagnostics import Diagnostic, MbsError

#: Meaning of the status a generated model function returns (0 is success).
MODEL_STATUS = {0: "ok", 1: "singular mass matrix", 2: "non-finite value",
                3: "closed loops cannot be closed (constraint projection failed)"}


def status_text(status: int) -> str:
    """``"status 2 (non-finite value)"``: a model status in words."""
    return f"status {status} ({MODEL_STATUS.get(status, 'unknown status')})"


class MbsRuntimeError(MbsError):
    """Base of the run-time layer's errors: one diagnostic without a source location."""

    def __init__(self, message: str):
        self.message = message
        super().__init__([Diagnostic("error", message, None)])


class BuildError(MbsRuntimeError):
    """The C compiler failed (or is missing).  ``compiler_output`` holds its messages, ``command`` the
    command line that was run (empty when no compiler was found)."""

    def __init__(self, message: str, compiler_output: str = "", command: tuple[str, ...] = ()):
        self.compiler_output = compiler_output
        self.command = command
        super().__init__(message + (f"\n{compiler_output.rstrip()}" if compiler_output.strip() else ""))


class EvaluationError(MbsRuntimeError, ArithmeticError):
    """A model function returned a status other than 0 when called from Python.

    Raised by the C glue (``mbs_glue.c``) and by the NumPy back end with the same arguments.
    """

    def __init__(self, function: str, status: int, t: float):
        self.function, self.status, self.t = function, int(status), float(t)
        self.values = None  # the back end sets what the function wrote before it failed
        super().__init__(f"model function '{function}' returned {status_text(self.status)} at t = {self.t:.6g} s")

    def __reduce__(self):  # picklable across processes (the default would pass the rendered message)
        return (type(self), (self.function, self.status, self.t))


class UsageError(MbsRuntimeError, ValueError):
    """A run-time function was called with arguments that cannot work (wrong sizes, unknown integrator,
    a workspace of another model, ...)."""


class SimulationError(MbsRuntimeError):
    """Raised by :meth:`Results.check` when a run did not finish; the results stay available."""
