"""Shared fixtures: paths of the repository's model files."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ROOT / "library"
SHIPPED_MODELS = sorted(LIBRARY.rglob("*.mbs"))


@pytest.fixture(autouse=True)
def _run_from_repository_root(monkeypatch):
    """Diagnostics show paths relative to the working directory; golden texts assume the repo root."""
    monkeypatch.chdir(ROOT)
