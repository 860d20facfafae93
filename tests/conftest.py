"""Shared fixtures: paths of the repository's model files."""

import os
from pathlib import Path

# One BLAS thread for the tests (before numpy loads OpenBLAS; a setting of the caller's wins): the matrices here are
# small, and on a machine whose cores are all busy OpenBLAS's threads wait for each other, so that one LU of a
# 162 x 162 matrix (scipy's Radau and BDF on the 40-four-bar chain) took 294 ms instead of 2.4 ms.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ROOT / "library"
SHIPPED_MODELS = sorted(LIBRARY.rglob("*.mbs"))


#: The seed of sympy's own random generator before each test (see pytest_runtest_setup).
SYMPY_SEED = 0


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """Seed sympy's random generator before each test's fixtures are set up.

    sympy's factor (Wang's algorithm, reached through trigsimp when a loop is closed in closed form,
    compiler/closed_form_loops.py) draws its evaluation points from sympy.core.random, which is seeded from the
    operating system at import. The same four-bar's closed form (tests/compiler/models/four_bar.mbs) took 3.5 s
    or more than 2 minutes by the draw, to the same C text, so the run's time was a lottery. Seeded before every
    test, a test's derivations take the same time whatever ran before it; what they derive does not depend on
    the draw."""
    import sympy.core.random
    sympy.core.random.seed(SYMPY_SEED)


@pytest.fixture(autouse=True)
def _run_from_repository_root(monkeypatch):
    """Diagnostics show paths relative to the working directory; golden texts assume the repo root."""
    monkeypatch.chdir(ROOT)
