"""Sensitivities of a run's metrics to the model's parameters: d(metric)/d(p) from the forward sensitivity
equations, one run for all parameters, no finite differences of runs.

    sys = mbs.load("pendulum.mbs")
    table = sensitivities(sys, "swing", params=["l"], metrics=["period(hinge.phi)", "peak(der(hinge.phi))"])
    table.derivative("period(hinge.phi)", "l"), table.normalised("period(hinge.phi)", "l")

A metric is a reduction of one column (a state such as `hinge.phi` or `der(hinge.phi)`, or a scene output), with
the reductions of the sweep's metrics: final, peak, min, range, mean, rms, period, or arithmetic of such
(`peak(heave) - min(heave)`, `rms(load) / 3700`; + - * /, ** a number, abs, sqrt), differentiated by the chain
rule. The metric is parsed by the sweep's one grammar (mbs.studies.metrics); this module holds only the derivatives.
Each reduction has its derivative:

- final, mean, rms: from dy/dp at the samples (mean over the samples, like the metric itself);
- peak, min: the extremum is located on the integrator's interpolant (a root of dy/dt between samples) and, since
  dy/dt = 0 there, d(peak)/dp = dy/dp at that time (at the first or last sample when the extremum is there);
- period: the mean interval between upward crossings of the mid-range level, the crossing times located on the
  interpolant; a crossing y(t_c, p) = level moves by dt_c/dp = -(dy/dp - dlevel/dp) / (dy/dt) at t_c.

States carry their exact sensitivities S = dx/dp; an output y(t, x, p) gets dy/dp = (dy/dx) S + dy/dp by a
central difference along the direction (S_k, e_k) (two output evaluations per parameter and sample, about 1e-9
relative; outputs are not differentiated symbolically because some read the accelerations of the loop solver).

How the start depends on a parameter (S(0) = dx0/dp: `init phi = theta0`, an equilibrium start) and how the other
parameters follow it (defaults that are expressions of it) is taken by central differences of the start itself,
which is algebraic: step 1e-6 * max(|p|, 1), error about 1e-10 relative for smooth defaults.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.runtime.sensitivity import SensitivityRun, integrate_sensitivities
from mbs.runtime.simulate import output_times
from mbs.studies.metrics import REDUCTIONS, Metric, column_name, default_metrics, metric_error, parse, \
    upward_crossings

#: Relative step of the central differences of the start and of the outputs.
STEP = 1e-6


def _error(message: str) -> MbsError:
    return MbsError([Diagnostic("error", message, None)])


@dataclass(frozen=True)
class Sensitivity:
    """One metric's derivative with respect to one parameter, and its normalised form (p / metric) d metric/dp:
    the relative change of the metric per relative change of the parameter."""

    metric: str
    parameter: str
    value: float       # the metric
    p: float           # the parameter's value [SI]
    derivative: float  # d metric / d p [metric unit / parameter unit]

    @property
    def normalised(self) -> float:
        return self.derivative * self.p / self.value if self.value else float("nan")


@dataclass(frozen=True)
class SensitivityTable:
    """Every (metric, parameter) pair of one sensitivity run."""

    rows: tuple[Sensitivity, ...]
    run: SensitivityRun = field(repr=False)

    def row(self, metric: str, parameter: str) -> Sensitivity:
        for r in self.rows:
            if r.metric == metric and r.parameter == parameter:
                return r
        raise KeyError(f"no sensitivity of '{metric}' to '{parameter}'")

    def derivative(self, metric: str, parameter: str) -> float:
        return self.row(metric, parameter).derivative

    def normalised(self, metric: str, parameter: str) -> float:
        return self.row(metric, parameter).normalised

    def text(self) -> str:
        """The table as the command line prints it."""
        head = ("metric", "parameter", "value", "p", "d metric/dp", "(p/metric) d/dp")
        body = [(r.metric, r.parameter, f"{r.value:.10g}", f"{r.p:.6g}", f"{r.derivative:.8g}",
                 f"{r.normalised:.6g}") for r in self.rows]
        widths = [max(len(row[i]) for row in [head, *body]) for i in range(len(head))]
        return "\n".join("  ".join(c.ljust(w) if i < 2 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
                         .rstrip() for row in [head, *body])

    def csv(self) -> str:
        lines = ["metric,parameter,value,p,derivative,normalised"]
        lines += [f'"{r.metric}",{r.parameter},{r.value!r},{r.p!r},{r.derivative!r},{r.normalised!r}' for r in self.rows]
        return "\n".join(lines) + "\n"


def parse_metric(text: str, columns: Sequence[str]) -> Metric:
    """A metric parsed by the sweep's one grammar (mbs.studies.metrics.parse: whitelist, known columns), then held
    to the form that has a derivative here: each reduction of one column as it is (`rms(load)`, not
    `rms(load - 3700)`), no signal outside a reduction, and ** with a number as exponent."""
    metric = parse(text, columns)

    def check(node) -> None:
        if isinstance(node, ast.Constant):
            return
        if isinstance(node, ast.UnaryOp):
            return check(node.operand)
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.Pow) and not isinstance(node.right, ast.Constant):
                raise metric_error(metric.text, "the exponent of ** must be a number for a sensitivity")
            check(node.left)
            return check(node.right)
        if isinstance(node, ast.Call) and node.func.id in REDUCTIONS:
            if column_name(node.args[0]) is None:
                raise metric_error(metric.text, f"a sensitivity needs {node.func.id}() of one column as it is, "
                                                f"e.g. {node.func.id}(hinge.phi), not of "
                                                f"'{ast.unparse(node.args[0])}'")
            return None
        if isinstance(node, ast.Call):  # abs, sqrt
            return check(node.args[0])
        raise metric_error(metric.text, f"'{ast.unparse(node)}' is a signal, not a number: reduce it with "
                                        f"{', '.join(REDUCTIONS)}")

    check(metric.tree.body)
    return metric


def evaluate_metric(metric: Metric, reduce) -> tuple[float, np.ndarray]:
    """(value, gradient) of a parsed metric by the chain rule; reduce(reduction, column) -> (value, gradient)."""

    def walk(node):
        if isinstance(node, ast.Constant):
            return float(node.value), 0.0
        if isinstance(node, ast.UnaryOp):
            a, da = walk(node.operand)
            return (-a, -da) if isinstance(node.op, ast.USub) else (a, da)
        if isinstance(node, ast.Call):
            if node.func.id in REDUCTIONS:
                return reduce(node.func.id, column_name(node.args[0]))
            a, da = walk(node.args[0])
            if node.func.id == "abs":
                return abs(a), np.sign(a) * da
            return np.sqrt(a), da / (2 * np.sqrt(a))
        (a, da), (b, db) = walk(node.left), walk(node.right)
        if isinstance(node.op, ast.Add):
            return a + b, da + db
        if isinstance(node.op, ast.Sub):
            return a - b, da - db
        if isinstance(node.op, ast.Mult):
            return a * b, da * b + a * db
        if isinstance(node.op, ast.Div):
            return a / b, (da * b - a * db) / (b * b)
        return a ** b, b * a ** (b - 1) * da  # b a number (checked)

    return walk(metric.tree.body)


class _Column:
    """One column of the run as a function of t with its rate and its sensitivities (samples and interpolant)."""

    def __init__(self, name: str, data, run: SensitivityRun, P: np.ndarray, steps: np.ndarray):
        model = data.model
        self.data, self.run, self.P, self.steps = data, run, P, steps
        self.state = model.x_names.index(name) if name in model.x_names else None
        self.output = None if self.state is not None else model.y_names.index(name)
        self.p0 = data.p.copy()

    def at(self, t: float, x=None, S=None) -> tuple[float, float, np.ndarray]:
        """(y, dy/dt, dy/dp) at time t (state and sensitivities from the interpolant unless given)."""
        if x is None:
            x, S = self.run.state_at(t)
        f = self.data.rhs(t, x)
        if self.state is not None:
            return float(x[self.state]), float(f[self.state]), S[self.state].copy()
        y = self._output(t, x, self.p0)
        h = STEP * max(1.0, abs(t))
        rate = (self._output(t + h, x + h * f, self.p0) - self._output(t - h, x - h * f, self.p0)) / (2 * h)
        dp = np.empty(S.shape[1])
        for k, hk in enumerate(self.steps):
            up = self._output(t, x + hk * S[:, k], self.p0 + hk * self.P[:, k])
            down = self._output(t, x - hk * S[:, k], self.p0 - hk * self.P[:, k])
            dp[k] = (up - down) / (2 * hk)
        return y, rate, dp

    def _output(self, t, x, p) -> float:
        self.data.p = p
        try:
            return float(self.data.outputs(t, x)[self.output])
        finally:
            self.data.p = self.p0

    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """(y (n,), dy/dp (n, k)) at the samples."""
        run = self.run
        if self.state is not None:
            return run.x[:, self.state], run.S[:, self.state, :]
        values = [self.at(t, x, S) for t, x, S in zip(run.t, run.x, run.S)]
        return np.array([v[0] for v in values]), np.array([v[2] for v in values])


def _extremum(column: _Column, y: np.ndarray, sign: float) -> tuple[float, np.ndarray]:
    """(peak, d peak/dp) for sign = 1, (min, d min/dp) for sign = -1, the extremum refined between samples."""
    t = column.run.t
    i = int(np.argmax(sign * y))
    if 0 < i < len(t) - 1:
        rate = lambda s: column.at(s)[1]
        lo, hi = (t[i - 1], t[i]) if rate(t[i]) * sign < 0 else (t[i], t[i + 1])
        if rate(lo) * rate(hi) < 0:
            value, _, dp = column.at(brentq(rate, lo, hi, xtol=1e-14, rtol=1e-14))
            return value, dp
    value, _, dp = column.at(t[i], column.run.x[i], column.run.S[i])
    return value, dp


def _period(column: _Column, y: np.ndarray) -> tuple[float, np.ndarray]:
    """(period, dT/dp): the sweep's period (the same upward crossings of the mid-range), each crossing located
    on the interpolant and moved by dt_c/dp = -(dy/dp - dlevel/dp) / (dy/dt)."""
    top, dtop = _extremum(column, y, 1.0)
    bottom, dbottom = _extremum(column, y, -1.0)
    level, dlevel = 0.5 * (top + bottom), 0.5 * (dtop + dbottom)
    t = column.run.t
    rising = upward_crossings(y, level)
    if rising.size < 2:
        k = len(dlevel)
        return float("nan"), np.full(k, np.nan)
    times, shifts = [], []
    for i in rising:
        tc = brentq(lambda u: column.at(u)[0] - level, t[i], t[i + 1], xtol=1e-14, rtol=1e-14)
        _, rate, dp = column.at(tc)
        times.append(tc)
        shifts.append(-(dp - dlevel) / rate)
    n = len(times) - 1
    return (times[-1] - times[0]) / n, (shifts[-1] - shifts[0]) / n


def metric_sensitivity(reduction: str, column: _Column) -> tuple[float, np.ndarray]:
    """(metric value, d metric / d p (k,)) of one reduction of one column."""
    y, dy = column.samples()
    if reduction == "final":
        return float(y[-1]), dy[-1]
    if reduction == "mean":
        return float(np.mean(y)), dy.mean(axis=0)
    if reduction == "rms":
        rms = float(np.sqrt(np.mean(y ** 2)))
        return rms, (y[:, None] * dy).mean(axis=0) / rms
    if reduction in ("peak", "min"):
        return _extremum(column, y, 1.0 if reduction == "peak" else -1.0)
    if reduction == "range":
        (top, dtop), (bottom, dbottom) = _extremum(column, y, 1.0), _extremum(column, y, -1.0)
        return top - bottom, dtop - dbottom
    return _period(column, y)


def sensitivities(system, scene: str | None = None, *, params: Sequence[str], values: Mapping[str, float] | None = None,
                  metrics: Sequence[str] | None = None, t_end: float | None = None, method: str = "DOP853",
                  rtol: float | None = None, atol: float | None = None, hooks=None) -> SensitivityTable:
    """d(metric)/d(p) of a scene's run for each metric and each parameter named in `params`, at the scene's
    parameter values overridden by `values` (as --param name=value of a run). hooks: the implementations of the
    model's user hooks, as for System.simulate; their derivatives are the implementations' own (a C
    NAME_derivative, a Python callable's .derivative) or central differences of the hooks (compiler/hooks.py)."""
    from mbs.runtime.hooks import bind
    binding = bind(system.model.hooks, hooks, system.model.name)  # checked before anything compiles
    names = [params] if isinstance(params, str) else list(params)
    at = dict(values or {})
    unknown = [n for n in names if n not in system.model.parameter_map]
    if unknown:
        known = ", ".join(p.name for p in system.model.parameters) or "none"
        raise _error(f"model '{system.model.name}' has no parameter '{unknown[0]}' (parameters: {known})")
    if not names:
        raise _error("name at least one parameter to differentiate with respect to")
    data, settings = system.start(scene, params=at, jacobian=True, parameter_jacobian=True, t_end=t_end, rtol=rtol,
                                  atol=atol, hooks=binding)
    model = data.model
    if "project" in model.functions:
        raise _error(f"model '{system.model.name}' has closed kinematic loops: sensitivities are for trees so far")
    values = [float(data.p[model.parameter_index(n)]) for n in names]
    steps = np.array([STEP * max(abs(v), 1.0) for v in values])
    P = np.empty((model.np, len(names)))
    S0 = np.empty((model.nx, len(names)))
    for k, (name, value, h) in enumerate(zip(names, values, steps)):
        up, _ = system.start(scene, params={**at, name: value + h}, jacobian=True, parameter_jacobian=True,
                             hooks=binding)
        down, _ = system.start(scene, params={**at, name: value - h}, jacobian=True, parameter_jacobian=True,
                               hooks=binding)
        P[:, k] = (up.p - down.p) / (2 * h)
        S0[:, k] = (up.x - down.x) / (2 * h)
    times = output_times(data.t, settings["t_end"], sample=settings.get("sample"))
    run = integrate_sensitivities(model, data, settings["t_end"], P, S0, t_eval=times, method=method,
                                  rtol=settings["rtol"], atol=settings["atol"],
                                  scales=[max(abs(v), 1.0) for v in values])
    columns = list(model.x_names) + list(model.y_names)
    metrics = list(metrics) if metrics else default_metrics(list(model.y_names) or list(model.q_names))
    parsed = [parse_metric(m, columns) for m in metrics]
    cache: dict = {}

    def reduce(reduction: str, name: str):
        if (reduction, name) not in cache:
            cache[reduction, name] = metric_sensitivity(reduction, _Column(name, data, run, P, steps))
        return cache[reduction, name]

    rows = []
    for metric in parsed:
        value, derivative = evaluate_metric(metric, reduce)
        derivative = np.broadcast_to(np.asarray(derivative, dtype=float), (len(names),))
        rows += [Sensitivity(metric.text, n, float(value), v, float(d)) for n, v, d in zip(names, values, derivative)]
    return SensitivityTable(tuple(rows), run)
