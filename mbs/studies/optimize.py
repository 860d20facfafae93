"""Design optimisation: minimise a metric of a scene over chosen parameters, with bounds and with constraints on
other metrics, by differential evolution (scipy.optimize, a derivative-free global method) whose population is
evaluated on Dask, one run per member, each generation in parallel.

    opt = optimize(system, "bump", "rms(body_acc)", {"d_susp": (500, 5000)},
                   constraints=["rms(wheel_load - final(wheel_load)) <= 800"])
    opt.x, opt.value, opt.log; opt.scene_text  # the optimum as a scene the user can run

Constraints use scipy's handling (Lampinen's feasibility rules): a feasible member beats an infeasible one,
two infeasible ones compare by their violation. No gradients: forward sensitivities would need the generated
Jacobian, which the equations do not provide yet, and the final gradient polish is off because its
finite-difference steps would run one simulation at a time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

from mbs import pipeline
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.language.units import unit_text

from .metrics import parse
from .package import ModelPackage
from .sweep import dask_client, run_on_dask
from .variant import Outcome, Variant

_CONSTRAINT = re.compile(r"^(.*?)(<=|>=)\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*$")


def _error(message: str) -> MbsError:
    return MbsError([Diagnostic("error", message, None)])


@dataclass(frozen=True)
class Constraint:
    """metric <= bound or metric >= bound."""

    metric: str
    sense: str
    bound: float

    @classmethod
    def parse(cls, text: str) -> "Constraint":
        match = _CONSTRAINT.match(text.strip())
        if match is None:
            raise _error(f"constraint '{text}': expected 'METRIC <= NUMBER' or 'METRIC >= NUMBER'")
        return cls(match.group(1).strip(), match.group(2), float(match.group(3)))

    def violation(self, value: float) -> float:
        """How far a value lies outside the allowed side (0 when it satisfies the constraint; inf for NaN)."""
        if not np.isfinite(value):
            return np.inf
        return max(0.0, value - self.bound) if self.sense == "<=" else max(0.0, self.bound - value)


@dataclass
class Optimum:
    """The best design found, the metrics there, how the search went and the optimum as a scene."""

    x: dict[str, float]
    objective: str   #: the minimised metric as parsed (its column in the table of runs)
    value: float
    constraints: dict[str, float]
    feasible: bool
    evaluations: int
    log: list[dict] = field(default_factory=list)      #: one entry per generation: best x, value, evaluations
    rows: list[Outcome] = field(default_factory=list)  #: every evaluated design
    message: str = ""
    scene_text: str = ""


class _Evaluator:
    """Runs batches of designs on Dask and remembers every result (objective and constraints read one cache)."""

    def __init__(self, system, scene, names, metrics, fixed, client, package):
        from mbs.system import _settings
        self.system, self.names, self.metrics, self.client = system, names, tuple(metrics), client
        self.sc = system.scene(scene)
        self.compiled, self.gen = system.compile(scene, hooks=package.hooks), system.generate(scene)
        self.package = client.scatter(package, broadcast=True, hash=False)  # shipped once
        self.settings = _settings(self.sc, None, None, None, None, None)
        self.fixed = dict(fixed or {})
        self.cache: dict[bytes, Outcome] = {}
        self.rows: list[Outcome] = []

    def variant(self, index: int, x: np.ndarray) -> Variant:
        values = dict(zip(self.names, map(float, x)))
        every = pipeline.parameter_values(self.system.model, {**pipeline.scene_overrides(self.sc), **self.fixed,
                                                              **values})
        return Variant(index, values, np.array(pipeline.parameter_vector(self.compiled.p_names, every)),
                       pipeline.initial_state(self.gen, every), self.settings,
                       self.sc.start if self.sc is not None else "initial")

    def batch(self, xs: np.ndarray) -> list[Outcome]:
        """Outcomes of the columns of xs (N, S), running only the designs not seen before."""
        columns = [np.ascontiguousarray(xs[:, j]) for j in range(xs.shape[1])]
        new = {c.tobytes(): c for c in columns if c.tobytes() not in self.cache}
        variants = [self.variant(len(self.rows) + i, x) for i, x in enumerate(new.values())]
        for outcome in run_on_dask(self.package, variants, self.metrics, client=self.client):
            key = np.array([outcome.values[n] for n in self.names]).tobytes()
            self.cache[key] = outcome
            self.rows.append(outcome)
        return [self.cache[c.tobytes()] for c in columns]


def optimize(system, scene: str | None, objective: str, bounds: Mapping[str, tuple[float, float]], *,
             constraints: Sequence[str] = (), fixed: Mapping | None = None, maxiter: int = 20, popsize: int = 6,
             seed: int = 0, tol: float = 1e-3, scheduler: str | None = None, client=None,
             log: Callable[[dict], None] | None = None, hooks=None) -> Optimum:
    """Minimise `objective` (a metric) over the parameters in `bounds` (SI), subject to `constraints`
    ("METRIC <= NUMBER"); returns the Optimum. Each generation's members run in parallel on Dask. hooks: the
    implementations of the model's user hooks, as for System.simulate (package.py: how they reach the workers)."""
    from scipy.optimize import NonlinearConstraint, differential_evolution

    from mbs.runtime.hooks import bind
    binding = bind(system.model.hooks, hooks, system.model.name)  # checked before anything compiles
    if not bounds:
        raise _error("optimize needs at least one parameter with bounds (--param NAME=LOW:HIGH)")
    for name, (low, high) in bounds.items():
        if not low < high:
            raise _error(f"parameter '{name}': the lower bound {low:g} must lie below the upper bound {high:g}")
    limits = [Constraint.parse(text) for text in constraints]
    package = ModelPackage.of(system, scene, binding)  # unpicklable hooks refused before the first run
    compiled = system.compile(scene, hooks=binding)
    columns = ("time",) + compiled.x_names + compiled.y_names
    metrics = [parse(objective, columns).text] + [parse(c.metric, columns).text for c in limits]
    with dask_client(scheduler, client) as client:
        names = list(bounds)
        ev = _Evaluator(system, scene, names, metrics, fixed, client, package)
        history: list[dict] = []

        def objective_of(xs):
            return np.array([o.metrics[metrics[0]] if np.isfinite(o.metrics[metrics[0]]) else np.inf
                             for o in ev.batch(np.atleast_2d(xs.T).T if xs.ndim == 1 else xs)])

        def constraint_of(xs):
            xs = xs.reshape(len(names), -1)
            return np.array([[o.metrics[c.metric] if np.isfinite(o.metrics[c.metric]) else 1e300 for o in
                              ev.batch(xs)] for c in limits])

        scipy_constraints = [NonlinearConstraint(constraint_of, [c.bound if c.sense == ">=" else -np.inf
                                                                 for c in limits],
                                                 [c.bound if c.sense == "<=" else np.inf for c in limits])
                             ] if limits else ()

        def callback(intermediate_result):  # scipy passes the OptimizeResult to a parameter of this name
            entry = {"iteration": len(history) + 1, "evaluations": len(ev.rows),
                     "value": float(intermediate_result.fun),
                     "x": dict(zip(names, map(float, intermediate_result.x)))}
            history.append(entry)
            if log is not None:
                log(entry)

        result = differential_evolution(objective_of, [bounds[n] for n in names], constraints=scipy_constraints,
                                        maxiter=maxiter, popsize=popsize, seed=seed, tol=tol, polish=False,
                                        vectorized=True, updating="deferred", callback=callback, init="sobol")
        best = ev.batch(np.asarray(result.x, dtype=float).reshape(-1, 1))[0]
    values = {c.metric: best.metrics[c.metric] for c in limits}
    feasible = best.status == "finished" and all(c.violation(values[c.metric]) == 0 for c in limits)
    optimum = Optimum(dict(best.values), metrics[0], best.metrics[metrics[0]], values, feasible, len(ev.rows), history,
                      ev.rows, result.message)
    optimum.scene_text = optimum_scene(system, scene, optimum.x, objective)
    return optimum


def optimum_scene(system, scene: str | None, values: Mapping[str, float], objective: str) -> str:
    """The scene the optimum came from, renamed NAME_optimum, with the optimised parameters set (in the
    parameters' units, 10 significant digits)."""
    units = {p.name: p.dimension for p in system.model.parameters}
    lines = []
    for name, value in values.items():
        dim = units.get(name)
        unit = "" if dim is None or dim.is_dimensionless else f" {unit_text(dim)}"
        lines.append(f"    param {name} = {value:.10g}{unit}")
    note = f'"optimum of {objective.replace(chr(34), chr(39))} found by mbs optimize"'
    sc = system.scene(scene)
    if sc is None:
        return "scene optimum " + note + " {\n" + "\n".join(lines) + "\n}\n"
    text = sc.span.source.text[sc.span.start:sc.span.end]
    body = text[text.index("{") + 1:]
    for name in values:  # the base scene's own setting of an optimised parameter is replaced
        body = re.sub(rf"(?m)^[ \t]*param[ \t]+{re.escape(name)}[ \t]*=.*\n", "", body)
    return f"scene {sc.name}_optimum {note} {{\n" + "\n".join(lines) + body + "\n"
