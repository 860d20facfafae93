"""Where Baukasten keeps what it can rebuild (compiled models, the parser's tables): one place, importable
without numpy, so the parser can use it on a cheap start."""

from __future__ import annotations

import os
from pathlib import Path

CACHE_ENV = "MBS_CACHE_DIR"


def default_cache_dir() -> Path:
    """``$MBS_CACHE_DIR``, else ``$XDG_CACHE_HOME/baukasten``, else ``~/.cache/baukasten``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base).expanduser() / "baukasten"


def cache_folder(cache_dir: str | os.PathLike | None = None) -> Path:
    """The cache folder a call names (`cache_dir`, ~ expanded), else default_cache_dir()."""
    return Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
