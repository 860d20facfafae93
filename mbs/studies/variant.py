"""One variant of a study, as a task a Dask worker runs: parameters and start in, metrics (or a message) out.

The client prepares everything that needs the symbolic model (every parameter's value, the initial state from
the joints' and scene's init expressions); the worker only needs the ModelPackage. A variant that fails is a
row with its message, never an exception that loses the study.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mbs.language.diagnostics import MbsError

from .metrics import evaluate, parse
from .package import ModelPackage, compiled_model


@dataclass(frozen=True)
class Variant:
    """What one run needs besides the model: parameters (model order), initial state, scene settings."""

    index: int
    values: dict                 #: the swept parameters' values (for the table)
    p: np.ndarray                #: every parameter, in the compiled model's order
    x0: np.ndarray               #: initial state before assembly / equilibrium
    settings: dict               #: t_end, sample, integrator, rtol, atol
    start: str = "initial"       #: "initial" or "equilibrium"


@dataclass
class Outcome:
    """A row of the study: the variant's parameters, metrics (NaN when failed), status and message."""

    index: int
    values: dict
    metrics: dict = field(default_factory=dict)
    status: str = "finished"
    message: str = ""


def run_variant(package: ModelPackage, variant: Variant, metrics: tuple[str, ...]) -> Outcome:
    """Run one variant and measure it (a worker task; every failure becomes the row's message)."""
    nan = {text: float("nan") for text in metrics}
    try:
        results = simulate_variant(package, variant)
        parsed = [parse(text) for text in metrics]
        values = evaluate(parsed, results) if len(results) else nan
        return Outcome(variant.index, variant.values, values, results.metadata.get("status", "finished"),
                       results.message)
    except MbsError as exc:
        return Outcome(variant.index, variant.values, nan, "failed", "; ".join(d.message for d in exc.diagnostics))
    except Exception as exc:  # a bug must not lose the study: the row names it
        return Outcome(variant.index, variant.values, nan, "failed",
                       f"internal error (please report): {type(exc).__name__}: {exc}")


def simulate_variant(package: ModelPackage, variant: Variant):
    """The Results of one variant: start assembled (loops) and settled (scene start = equilibrium), then run."""
    from mbs.runtime.assembly import assemble
    from mbs.runtime.equilibrium import static_equilibrium
    from mbs.runtime.simulate import simulate
    from mbs.runtime.workspace import Workspace
    from mbs.runtime.hooks import report
    model = compiled_model(package)
    if package.hooks is not None:
        package.hooks.attach(model)
    data = Workspace(model)
    data.p = variant.p
    data.x = variant.x0
    if package.loops:
        data.x = assemble(model, data, fixed=package.fixed, row_names=package.rows).x
    if variant.start == "equilibrium":
        data.x = static_equilibrium(model, data, data.x).x
    settings = dict(variant.settings)
    results = simulate(model, data, settings.pop("t_end"), **settings)
    if package.hooks is not None:
        report(package.hooks, model, results)  # a hook that failed: its name, time and arguments in the row
    return results
