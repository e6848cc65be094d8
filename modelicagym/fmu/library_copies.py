"""Private copies of an FMU's binary, so that an FMU allowed one instance per process gets many.

An FMU with ``canBeInstantiatedOnlyOncePerProcess="true"`` (JModelica, some Dymola and Simulink
exports) keeps its model state in global variables: two instances from one loaded library would
share them. A second ``dlopen`` of a *different file* with the same content gives that copy its own
globals, so each further instance alive at once in a process loads its own copy of the FMU's
``binaries/<platform>`` folder (the whole folder, so that libraries found ``$ORIGIN``-relative
resolve beside the copy; ``resources`` is linked beside it for the same reason).

Per process and library, slot 0 is the FMU's own binary and slot ``k > 0`` a copy. A binding leases
the first free slot for its life (`lease_library`) and gives it back when it closes
(`LibraryLease.release`): resets, re-instantiation and envs made again reuse loaded copies, so a
process holds as many copies as it had instances alive at once. A binding told to keep the FMU's
rule (``instances_per_process="one"``) shares slot 0 with any others so told, and a private lease
then takes a copy. Libraries are never unloaded, so a
copy's files stay while its process lives, under ``<cache>/library-copies/<pid>-<random>/``,
locked by the process; they are removed when the process ends (by `multiprocessing`'s exit
finalizers, which the main process and every multiprocessing child run, even those that leave by
``os._exit``), and a folder whose process died without that (killed, crashed) is removed by the
next process that makes a copy (its lock is free). A dependency loaded by name (no path) that is
already loaded is shared by every copy (the dynamic linker matches it by its soname): only the
FMU's own library is private.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass, field
from multiprocessing.util import Finalize
from pathlib import Path
from typing import IO

try:
    import fcntl
except ImportError:  # no fcntl (Windows): no lock, so no sweeping of dead processes' copies
    fcntl = None

from modelicagym.cache import ELSEWHERE, cache_dir
from modelicagym.disk import disk_full, is_disk_full
from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import FMUError

__all__ = ["INSTANCES_PER_PROCESS", "LibraryLease", "check_instances_per_process", "copies_root", "lease_library"]

logger = logging.getLogger(__name__)

#: values of the ``instances_per_process`` setting: private copies of the binary for further
#: instances, or one instance per process (a pool then keeps one env per worker)
INSTANCES_PER_PROCESS = ("copies", "one")

_LOCK_NAME = ".lock"
#: a folder younger than this without its lock file is being made, not left behind
_MAKING_GRACE_S = 60.0


def check_instances_per_process(value: object) -> str:
    """``value`` if it is one of `INSTANCES_PER_PROCESS`; a one-line `ConfigError` otherwise."""
    if value not in INSTANCES_PER_PROCESS:
        raise ConfigError(f"instances_per_process must be one of {INSTANCES_PER_PROCESS}, got {value!r}")
    return value  # type: ignore[return-value]


def copies_root() -> Path:
    """The folder under which each process keeps its copies (one sub-folder per process)."""
    return cache_dir() / "library-copies"


@dataclass
class _Slots:
    """The libraries of one FMU binary loaded in this process: slot 0 the binary, then copies; and
    how many bindings hold each."""

    paths: list[Path]
    holders: list[int] = field(default_factory=list)


@dataclass
class LibraryLease:
    """A slot leased by one binding: the library to load, and the slot to give back."""

    path: Path
    slot: int
    _slots: _Slots | None

    def release(self) -> None:
        """Give the slot back (its library stays loaded for the next instance). Safe to call twice."""
        with _lock:
            if self._slots is not None:
                self._slots.holders[self.slot] -= 1
                self._slots = None


_lock = threading.Lock()
_slots: dict[Path, _Slots] = {}
_folder: tuple[int, Path, IO[bytes] | None] | None = None  # (pid, folder, its locked lock file)


def lease_library(library: Path, fmu_name: str, resources: Path | None = None, private: bool = True) -> LibraryLease:
    """A slot of ``library`` in this process, leased. ``private``: the first free one, i.e. the
    binary itself while no other binding holds it, else a private copy (made now if every copy is
    held); otherwise the binary itself, shared (``instances_per_process="one"``)."""
    key = library.resolve()
    with _lock:
        slots = _slots.setdefault(key, _Slots([library], [0]))
        free = [k for k, holders in enumerate(slots.holders) if holders == 0] if private else [0]
        if free:
            slot = free[0]
        else:
            slot = len(slots.paths)
            slots.paths.append(_copy(key, slot, fmu_name, resources))
            slots.holders.append(0)
        slots.holders[slot] += 1
        return LibraryLease(slots.paths[slot], slot, slots)


def _copy(library: Path, slot: int, fmu_name: str, resources: Path | None) -> Path:
    """Copy ``library``'s folder into this process's folder as copy ``slot``; the copy's library."""
    digest = hashlib.sha256(str(library).encode()).hexdigest()[:12]
    target = None
    try:
        target = _process_folder() / f"{digest}-{slot}"
        platform = target / "binaries" / library.parent.name
        shutil.copytree(library.parent, platform, symlinks=True)
        if resources is not None and resources.is_dir():
            (target / "resources").symlink_to(resources, target_is_directory=True)
    except OSError as error:
        if target is not None:
            shutil.rmtree(target, ignore_errors=True)
        where = target or copies_root()
        if is_disk_full(error):
            raise disk_full(where, ELSEWHERE) from error
        raise FMUError(f"{fmu_name}: cannot copy its binary folder {library.parent} to {where} (a private copy for "
                       "a further instance in this process; set MODELICAGYM_CACHE to a writable folder, or "
                       f"instances_per_process='one' to keep one instance per process): {error}") from error
    log = logger.info if slot == 1 else logger.debug
    log("%s may be instantiated only once per process (canBeInstantiatedOnlyOncePerProcess) and %d instance(s) "
        "are alive in this one: loading a private copy of its binary, %s (instances_per_process='one' "
        "keeps one instance per process instead)", fmu_name, slot, platform)
    return platform / library.name


def _process_folder() -> Path:
    """This process's folder of copies, made (and locked, and its removal at exit arranged) on
    first use; a forked child makes its own. Called with ``_lock`` held."""
    global _folder
    if _folder is not None and _folder[0] == os.getpid():
        return _folder[1]
    root = copies_root()
    root.mkdir(parents=True, exist_ok=True)
    _sweep(root)
    folder = Path(tempfile.mkdtemp(prefix=f"{os.getpid()}-", dir=root))
    handle = None
    if fcntl is not None:
        handle = open(folder / _LOCK_NAME, "wb")  # noqa: SIM115 (held for the life of the process)
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
    _folder = (os.getpid(), folder, handle)
    Finalize(None, _remove, args=(folder, handle), exitpriority=0)  # runs in this process only
    return folder


def _remove(folder: Path, handle: IO[bytes] | None) -> None:
    """Remove a process's folder of copies at its exit (a loaded library's file may go: it stays mapped)."""
    shutil.rmtree(folder, ignore_errors=True)
    if handle is not None:
        handle.close()


def _sweep(root: Path) -> None:
    """Remove the folders of processes that died without removing theirs: their lock is free."""
    if fcntl is None:
        return
    for folder in root.iterdir():
        lock = folder / _LOCK_NAME
        try:
            if not lock.exists():
                if time.time() - folder.stat().st_mtime > _MAKING_GRACE_S:
                    shutil.rmtree(folder, ignore_errors=True)
                continue
            with open(lock, "rb") as handle:
                fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                shutil.rmtree(folder, ignore_errors=True)
        except OSError:  # locked (its process lives), or gone meanwhile
            continue
        logger.debug("removed %s: the copies of a process that ended without removing them", folder)
