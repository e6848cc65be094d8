"""Where modelicagym keeps what it builds and extracts: one folder, shared by every process."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

try:
    import fcntl
except ImportError:  # no fcntl (Windows): atomic renames alone keep results valid
    fcntl = None


def cache_dir() -> Path:
    """The cache folder: ``$MODELICAGYM_CACHE`` if set, else ``~/.cache/modelicagym``."""
    env = os.environ.get("MODELICAGYM_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "modelicagym"


@contextmanager
def locked(lock_path: Path) -> Iterator[None]:
    """Hold an exclusive inter-process lock on ``lock_path`` (no-op without fcntl)."""
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    with open(lock_path, "a+b") as handle:
        if fcntl is not None:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fcntl is not None:
                fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
