"""Metrics of a run: the reductions on signals whose values are known, and the guard against code in metrics."""

from __future__ import annotations

import numpy as np
import pytest

from mbs import MbsError
from mbs.studies.metrics import default_metrics, parse

T = np.linspace(0.0, 10.0, 10001)
SIGNALS = {"time": T, "a.x": 2.0 + 3.0 * np.sin(2 * np.pi * T / 2.5), "der(a.x)": np.cos(T), "b": -T}


def value(text: str) -> float:
    return parse(text, SIGNALS)(T, SIGNALS.__getitem__)


def test_reductions_of_known_signals():
    assert value("peak(a.x)") == pytest.approx(5.0, abs=1e-4)
    assert value("min(a.x)") == pytest.approx(-1.0, abs=1e-4)
    assert value("range(a.x)") == pytest.approx(6.0, abs=2e-4)
    assert value("final(b)") == -10.0
    assert value("rms(b)") == pytest.approx(np.sqrt(np.mean(T ** 2)))
    assert value("mean(der(a.x))") == pytest.approx(np.sin(10.0) / 10.0, abs=1e-3)
    # the period from interpolated crossings of the mid-range, not from the sampling grid
    assert value("period(a.x)") == pytest.approx(2.5, rel=1e-6)


def test_expressions_of_metrics_and_of_signals():
    assert value("peak(a.x) - min(a.x)") == pytest.approx(value("range(a.x)"))
    assert value("peak(abs(b))") == 10.0
    assert value("2 * final(b) ** 2 / 4") == 50.0
    assert value("rms(a.x - 2)") == pytest.approx(3.0 / np.sqrt(2.0), rel=1e-3)


def test_default_metrics_are_peak_and_final_of_each_output():
    assert default_metrics(["heave", "fl.load"]) == ["peak(heave)", "final(heave)", "peak(fl.load)",
                                                     "final(fl.load)"]


@pytest.mark.parametrize("text, message", [
    ("__import__('os').system('true')", "is not allowed"),
    ("exec('1')", "unknown function 'exec'"),
    ("peak(a.x).real", "is not allowed"),
    ("[1, 2]", "is not allowed"),
    ("peak(a.y)", "no output or coordinate 'a.y'; did you mean 'a.x'?"),
    ("peak(a.x, b)", "takes one argument"),
    ("peak(", "not an expression"),
])
def test_bad_metrics_are_located_errors(text, message):
    with pytest.raises(MbsError, match=message.replace("(", r"\(").replace(")", r"\)").replace("?", r"\?")):
        parse(text, SIGNALS)


def test_a_signal_is_not_a_metric():
    with pytest.raises(MbsError, match="is a signal, not a number"):
        value("abs(b)")
