"""Where modelicagym keeps what it builds and extracts: one folder, shared by every process.

Every entry (our native library, a built FMU, an extracted FMU folder) is published the same way:
made under a temporary name, its manifest written beside or inside it (the size and SHA-256 of
each file), then renamed into place. `damage` checks an entry against its manifest before anyone
loads it, so a file cut short by a full disk or a crash is found before ``dlopen`` maps it (a
truncated shared library kills the process with SIGBUS on first use) and the caller rebuilds or
re-extracts it. A verified entry is remembered for the life of the process, keyed by its
manifest's size and mtime, so the check costs one read per process and entry. A read-only cache
keeps working for entries that are already there: checking writes nothing.

Nothing here imports the rest of the package: it is the leaf every builder stands on.
"""

from __future__ import annotations

import errno
import hashlib
import json
import logging
import os
import shutil
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # no fcntl (Windows): atomic renames alone keep results valid
    fcntl = None

from modelicagym.disk import atomic_write, disk_full, is_disk_full
from modelicagym.errors import CacheError

__all__ = [
    "ELSEWHERE",
    "FOLDER_MANIFEST",
    "cache_dir",
    "damage",
    "ensure",
    "file_digest",
    "file_record",
    "locked",
    "mismatch",
    "write_manifest",
]

logger = logging.getLogger(__name__)

#: the manifest of a folder entry, inside it; a file entry's manifest is ``<file>.manifest.json``
FOLDER_MANIFEST = ".modelicagym-manifest.json"

#: what to do, besides freeing space, when the cache finds its disk full
ELSEWHERE = "set MODELICAGYM_CACHE to a folder on a file system with room"

_CHUNK = 1 << 20
_verified: set[tuple[str, int, int]] = set()


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


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes, as hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def file_record(path: Path) -> dict[str, Any]:
    """What a manifest records of a file: its size and SHA-256."""
    return {"bytes": path.stat().st_size, "sha256": file_digest(path)}


def mismatch(base: Path, recorded: Mapping[str, Mapping[str, Any]]) -> str | None:
    """The first file under ``base`` that differs from its `file_record` in ``recorded`` (by
    relative name), said in words; ``None`` when all match. Extra keys of a record are ignored."""
    for name, expected in recorded.items():
        path = base / name
        try:
            size = path.stat().st_size
        except OSError:
            return f"{path} is missing"
        if size != expected.get("bytes"):
            return f"{path} has {size:,} bytes where {expected.get('bytes'):,} were written"
        if file_digest(path) != expected.get("sha256"):
            return f"{path} does not hold the bytes that were written (SHA-256 differs)"
    return None


def _manifest_path(entry: Path, published_as: Path | None = None) -> Path:
    final = published_as or entry
    return entry / FOLDER_MANIFEST if entry.is_dir() else final.with_name(final.name + ".manifest.json")


def _files(entry: Path) -> dict[str, Path]:
    if not entry.is_dir():
        return {entry.name: entry}
    return {p.relative_to(entry).as_posix(): p for p in sorted(entry.rglob("*"))
            if p.is_file() and p.name != FOLDER_MANIFEST}


def write_manifest(entry: Path, published_as: Path | None = None) -> None:
    """Record the size and SHA-256 of every file of ``entry`` (a file, or a folder's files).

    ``entry`` is still under its temporary name; ``published_as`` is the name it will be renamed to
    (a file entry's manifest is written beside that name, a folder's inside the folder). Call it
    before the rename that publishes the entry, so a published entry always has its manifest.
    """
    files = {name: file_record(path) for name, path in _files(entry).items()}
    if not entry.is_dir() and published_as is not None:
        files = {published_as.name: files.pop(entry.name)}
    with atomic_write(_manifest_path(entry, published_as)) as f:
        json.dump({"files": files}, f, indent=1, sort_keys=True)


def damage(entry: Path) -> str | None:
    """What is wrong with the published cache ``entry``, or ``None`` if every file matches its
    manifest (a missing entry, manifest or file is damage too)."""
    manifest = _manifest_path(entry)
    try:
        stat = manifest.stat()
        key = (str(manifest), stat.st_size, stat.st_mtime_ns)
        if key in _verified:
            return None
        recorded = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        return f"its manifest {manifest} is missing or unreadable ({type(error).__name__})"
    problem = mismatch(entry if entry.is_dir() else entry.parent, recorded)
    if problem is None:
        _verified.add(key)
    return problem


def ensure(entry: Path, make: Callable[[], None], what: str) -> Path:
    """``entry``, checked against its manifest; made by ``make`` when missing or damaged.

    ``make`` publishes the entry (with `write_manifest` before its rename) and runs under an
    inter-process lock, so concurrent first users make it once. A damaged entry is removed first,
    with a warning naming what was wrong; one that cannot be made again (a read-only cache) is a
    `CacheError` that says which entry and how to clear it.
    """
    if damage(entry) is None:
        return entry
    try:
        with locked(entry.with_name(entry.name + ".lock")):
            problem = damage(entry)
            if problem is None:
                return entry
            if entry.exists():
                logger.warning("%s in the cache is damaged (%s): making it again", what, problem)
                _remove(entry)
            make()
    except OSError as error:
        if is_disk_full(error):
            raise disk_full(entry, ELSEWHERE, error.errno) from error
        if error.errno not in (errno.EACCES, errno.EPERM, errno.EROFS):
            raise
        raise CacheError(
            f"{what} in the cache at {entry} is missing or damaged and cannot be made again there ({error}); "
            f"remove {entry} with write access, or set MODELICAGYM_CACHE to a writable folder") from error
    problem = damage(entry)
    if problem is not None:
        raise CacheError(f"{what} was made at {entry} but does not check out ({problem}); remove {entry} and retry")
    return entry


def _remove(entry: Path) -> None:
    if entry.is_dir():
        shutil.rmtree(entry)
    else:
        entry.unlink()
