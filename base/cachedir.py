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
