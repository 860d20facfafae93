"""Metrics of a run: one number per variant of a study, from the sampled outputs.

A metric is a small expression over result columns: a reduction of a signal (``peak(heave)``, ``rms(tyre.load -
3700)``, ``period(hinge.phi)``) or arithmetic of such numbers (``peak(heave) - min(heave)``). Column names are
the results' own spellings (``hinge.phi``, ``der(hinge.phi)``, ``fl.tyre.load``). The text is parsed with
Python's ``ast`` and only numbers, column names, + - * / ** and the functions below are accepted, so a metric
given on the command line can never run code.

Reductions (signal -> number): ``peak`` (largest value), ``min``, ``rms``, ``mean``, ``final`` (last sample),
``range`` (peak minus min), ``period`` (mean time between upward crossings of the mid-range). Element-wise:
``abs``, ``sqrt``.

This module is the one grammar of metrics: `mbs sweep` and `mbs optimize` evaluate a parsed Metric on sampled
signals; `mbs sensitivity` (mbs/sensitivity.py) walks the same checked tree to differentiate it.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from mbs.language.diagnostics import Diagnostic, MbsError


def upward_crossings(x: np.ndarray, level: float) -> np.ndarray:
    """Indices i where the samples cross `level` upwards between i and i + 1 (the crossings `period` counts)."""
    s = x - level
    return np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]


def _period(t: np.ndarray, x: np.ndarray) -> float:
    """Mean interval between upward crossings of (max + min) / 2, crossing times interpolated linearly."""
    level = 0.5 * (float(np.max(x)) + float(np.min(x)))
    s = x - level
    rising = upward_crossings(x, level)
    if rising.size < 2:
        return float("nan")
    crossings = t[rising] - s[rising] * (t[rising + 1] - t[rising]) / (s[rising + 1] - s[rising])
    return float((crossings[-1] - crossings[0]) / (crossings.size - 1))


REDUCTIONS = {
    "peak": lambda t, x: float(np.max(x)),
    "min": lambda t, x: float(np.min(x)),
    "rms": lambda t, x: float(np.sqrt(np.mean(np.square(x)))),
    "mean": lambda t, x: float(np.mean(x)),
    "final": lambda t, x: float(x[-1]),
    "range": lambda t, x: float(np.max(x) - np.min(x)),
    "period": _period,
}
ELEMENTWISE = {"abs": np.abs, "sqrt": np.sqrt}
_OPERATORS = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide, ast.Pow: np.power}


def metric_error(text: str, message: str) -> MbsError:
    """The one wording of a bad metric: "metric 'TEXT': message"."""
    return MbsError([Diagnostic("error", f"metric '{text}': {message}", None)])


def column_name(node: ast.AST) -> str | None:
    """`a.b.c` -> "a.b.c"; `der(a.b)` -> "der(a.b)"; anything else None."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        head = column_name(node.value)
        return None if head is None or head.startswith("der(") else f"{head}.{node.attr}"
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "der"
            and len(node.args) == 1 and not node.keywords):
        inner = column_name(node.args[0])
        return None if inner is None else f"der({inner})"
    return None


@dataclass(frozen=True)
class Metric:
    """A parsed metric: its text (the column name in the study's table) and the columns it reads."""

    text: str
    tree: ast.Expression
    columns: tuple[str, ...]

    def __call__(self, t: np.ndarray, column) -> float:
        """The metric of one run; `column(name)` returns a signal."""
        value = self._eval(self.tree.body, t, column)
        if np.ndim(value) != 0:
            raise metric_error(self.text, "is a signal, not a number: reduce it with peak, min, rms, mean, final, "
                                    "range or period")
        return float(value)

    def _eval(self, node, t, column):
        name = column_name(node)
        if name is not None:
            return np.asarray(column(name), dtype=float)
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.UnaryOp):
            value = self._eval(node.operand, t, column)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp):
            return _OPERATORS[type(node.op)](self._eval(node.left, t, column), self._eval(node.right, t, column))
        # a call, checked by parse()
        argument = self._eval(node.args[0], t, column)
        if node.func.id in ELEMENTWISE:
            return ELEMENTWISE[node.func.id](argument)
        if np.ndim(argument) == 0:
            raise metric_error(self.text, f"{node.func.id}() needs a signal, got a number")
        if argument.size == 0:
            return float("nan")
        return REDUCTIONS[node.func.id](t, argument)


def parse(text: str, columns: Iterable[str] | None = None) -> Metric:
    """A Metric from its text, checked: only the allowed syntax, and (when `columns` is given) known names."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise metric_error(text, f"not an expression ({exc.msg})") from None
    used: list[str] = []

    def check(node) -> None:
        name = column_name(node)
        if name is not None:
            used.append(name)
            return
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(
                node.value, bool):
            return
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return check(node.operand)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            check(node.left)
            return check(node.right)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            known = {**REDUCTIONS, **ELEMENTWISE}
            if node.func.id not in known:
                raise metric_error(text, f"unknown function '{node.func.id}' (known: {', '.join(known)})")
            if len(node.args) != 1 or node.keywords:
                raise metric_error(text, f"{node.func.id}() takes one argument")
            return check(node.args[0])
        raise metric_error(text, f"'{ast.unparse(node)}' is not allowed here (use output names, numbers, + - * / ** "
                           "and the functions peak, min, rms, mean, final, range, period, abs, sqrt)")

    check(tree.body)
    if columns is not None:
        known = list(columns)
        missing = [name for name in used if name not in known]
        if missing:
            from mbs.language.scope import did_you_mean
            raise metric_error(text, f"no output or coordinate '{missing[0]}'{did_you_mean(missing[0], known)}")
    return Metric(text.strip(), tree, tuple(dict.fromkeys(used)))


def default_metrics(outputs: Sequence[str]) -> list[str]:
    """Without --metric: the peak and final value of each of the scene's outputs."""
    return [f"{kind}({name})" for name in outputs for kind in ("peak", "final")]


def evaluate(metrics: Sequence[Metric], results) -> dict[str, float]:
    """Every metric of one run's Results (NaN for a metric of an empty run)."""
    t = results.t
    return {m.text: m(t, results.__getitem__) for m in metrics}
