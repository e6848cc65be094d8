"""Where modelicagym keeps what it builds and extracts: one folder, shared by every process."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """The cache folder: ``$MODELICAGYM_CACHE`` if set, else ``~/.cache/modelicagym``."""
    env = os.environ.get("MODELICAGYM_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "modelicagym"
