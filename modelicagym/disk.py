"""Writing files onto a disk that may fill up: one clear error, nothing half-written.

A full file system (``ENOSPC``) or a used-up quota (``EDQUOT``) surfaces deep inside whatever was
writing (numpy's zip writer, matplotlib, a compiler), often twice: from the write, and again from
the close that flushes what is left. Wherever modelicagym writes a file, that becomes one
`DiskFullError` naming the file and what to do, and what was written under a temporary name is
removed, so the user reads one line and finds no partial files. The command line prints it as
that line (`modelicagym.console`).

Like `modelicagym.cache`, nothing here imports the rest of the package.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from modelicagym.errors import DiskFullError

__all__ = [
    "DISK_FULL_ERRNOS",
    "ROOM_TO_BUILD",
    "atomic_write",
    "build_ran_out_of_room",
    "disk_full",
    "is_disk_full",
]

#: the errors of a write that found no room: a full file system, a used-up quota
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})
#: how tools that write files (the compiler, the linker) say the same in their output
_DISK_FULL_WORDS = tuple(os.strerror(code) for code in sorted(DISK_FULL_ERRNOS))
#: a build that fails with less room than this on its file system ran out of room: CMake does
#: not always say that a write failed (its test compile fails "with no rule to make target")
ROOM_TO_BUILD = 4 << 20
_ANYWHERE_ELSE = "write it to another folder"


def is_disk_full(error: BaseException) -> bool:
    """Whether ``error`` is a write that found no room on its file system."""
    return isinstance(error, OSError) and error.errno in DISK_FULL_ERRNOS


def disk_full(path: str | os.PathLike[str], elsewhere: str = _ANYWHERE_ELSE, code: int = errno.ENOSPC) -> DiskFullError:
    """The `DiskFullError` for ``path``: one line naming it and what to do (free space, or
    ``elsewhere``: e.g. "choose another results folder (reproduce --out)")."""
    message = f"cannot write {path}: {os.strerror(code).lower()}; free space on its file system, or {elsewhere}"
    return DiskFullError(code, message, str(path))


@contextlib.contextmanager
def _reporting_disk_full(path: str | os.PathLike[str], elsewhere: str = _ANYWHERE_ELSE) -> Iterator[None]:
    """Raise a full disk met inside the block as a `DiskFullError` naming ``path`` (one raised by
    a nested block, which names its own file, passes unchanged)."""
    try:
        yield
    except DiskFullError:
        raise
    except OSError as error:
        if error.errno not in DISK_FULL_ERRNOS:
            raise
        raise disk_full(path, elsewhere, error.errno) from error


def build_ran_out_of_room(output: str, folder: str | os.PathLike[str]) -> bool:
    """Whether a build that failed, with this ``output``, in ``folder``, failed for lack of room:
    the tool says so, or the file system has less than `ROOM_TO_BUILD` free."""
    if any(words in output for words in _DISK_FULL_WORDS):
        return True
    try:
        return shutil.disk_usage(folder).free < ROOM_TO_BUILD
    except OSError:
        return False


@contextlib.contextmanager
def atomic_write(
    path: str | os.PathLike[str], mode: str = "w", *, elsewhere: str = _ANYWHERE_ELSE
) -> Iterator[IO[Any]]:
    """Open a temporary file next to ``path``; on success sync it and rename it to ``path``, else
    delete it, so ``path`` is the old file or the whole new one, never part of one.

    A full disk is a `DiskFullError` naming ``path`` and ``elsewhere`` (what to do besides
    freeing space). Text mode writes UTF-8 with no newline translation.
    """
    path = Path(path)
    with _reporting_disk_full(path, elsewhere):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(fd, mode, **({"newline": "", "encoding": "utf-8"} if "b" not in mode else {})) as f:
                yield f
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            raise
