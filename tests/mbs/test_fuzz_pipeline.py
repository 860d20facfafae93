"""Fuzzing the layers behind the front end (issue 17): random valid models (trees and loops, every joint kind,
massless parts, springs, prescribed motion, extreme masses, inertias and gravity) through check, derivation, code
generation and a short simulation, and mutated models through check. Every outcome must be a result or a located
error: never an internal error, a crash or a hang. The count and the outcome table are printed.

The quick tier runs in the default test run (NumPy back end, a couple of C compiles); the slow tier runs at least
10,000 models (MBS_FUZZ_MODELS to change it, MBS_FUZZ_SEED for another campaign).
"""

import os

import pytest

from tests.mbs import fuzzkit


def _report(capsys, outcomes, failures):
    with capsys.disabled():
        print("\n" + fuzzkit.table(outcomes))
    assert not failures, "\n\n".join(f"{why}\n{text}" for text, why in failures[:3])


def test_quick_fuzz_of_the_whole_pipeline(capsys):
    outcomes, failures = fuzzkit.campaign(seed=17, valid=6, mutated=100, c_every=0, loops=False)
    _report(capsys, outcomes, failures)
    assert sum(outcomes.values()) == 106


def test_quick_fuzz_of_closed_loops_in_c(capsys):
    """Two models with a loop closed between random parts, on the C back end (the loop solver is C only)."""
    outcomes, failures = fuzzkit.campaign(seed=3, valid=2, mutated=0, loops=True, force_loops=True)
    _report(capsys, outcomes, failures)


@pytest.mark.slow
def test_slow_fuzz_of_ten_thousand_models(capsys):
    total = int(os.environ.get("MBS_FUZZ_MODELS", "10000"))
    seed = int(os.environ.get("MBS_FUZZ_SEED", "2026"))
    valid = max(1, total // 5)  # a fifth through every stage, the rest mutated through check
    outcomes, failures = fuzzkit.campaign(seed=seed, valid=valid, mutated=total - valid, c_every=50, loops=True)
    _report(capsys, outcomes, failures)
    assert sum(outcomes.values()) >= total
