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


@pytest.fixture(autouse=True)
def _run_from_repository_root(monkeypatch):
    """Diagnostics show paths relative to the working directory; golden texts assume the repo root."""
    monkeypatch.chdir(ROOT)
