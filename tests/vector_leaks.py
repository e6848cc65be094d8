"""What the pool's tests count to prove nothing leaks: processes, /dev/shm entries, open fds.

psutil is not available, so processes are found through ``/proc``: every descendant of this
process (workers started with ``forkserver`` are children of the fork server, not of the test).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

#: /dev/shm names multiprocessing or the pool could create (named semaphores, SharedMemory)
_SHM_PREFIXES = ("sem.mp-", "psm_", "modelicagym", "pym-")


def _stat_fields(pid: int) -> list[str] | None:
    """The fields of ``/proc/<pid>/stat`` after the command name (state first, then the parent), or
    None when there is no such process."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            stat = f.read()
    except OSError:
        return None
    return stat[stat.rindex(")") + 2 :].split()


def process_state(pid: int) -> str | None:
    """The state letter of process ``pid`` ("R", "S", "Z", ...), or None when it is gone."""
    fields = _stat_fields(pid)
    return None if fields is None else fields[0]


def _parents() -> dict[int, int]:
    """The parent of every live (non-zombie) process."""
    parents = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        fields = _stat_fields(int(entry))
        if fields is not None and fields[0] != "Z":
            parents[int(entry)] = int(fields[1])
    return parents


def descendants(pid: int | None = None) -> set[int]:
    """Live (non-zombie) descendant processes of ``pid`` (default: this process)."""
    root = os.getpid() if pid is None else pid
    parents = _parents()
    children: dict[int, list[int]] = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    found, stack = set(), [root]
    while stack:
        for child in children.get(stack.pop(), []):
            if child not in found:
                found.add(child)
                stack.append(child)
    return found


def shm_entries() -> set[str]:
    """Entries of /dev/shm that multiprocessing or the pool could have created."""
    return {name for name in os.listdir("/dev/shm") if name.startswith(_SHM_PREFIXES)}


def open_fds() -> dict[int, str]:
    """The file descriptors this process has open, and what each refers to."""
    fds = {}
    for entry in os.listdir("/proc/self/fd"):
        try:
            fds[int(entry)] = os.readlink(f"/proc/self/fd/{entry}")
        except OSError:  # the listing's own descriptor, closed by now
            continue
    return fds


@dataclass
class Snapshot:
    """Processes, /dev/shm entries and open fds at one moment."""

    processes: set[int]
    shm: set[str]
    fds: dict[int, str]

    @classmethod
    def take(cls) -> Snapshot:
        return cls(descendants(), shm_entries(), open_fds())

    def assert_restored(self, timeout: float = 5.0) -> None:
        """Assert that, within ``timeout``, no process, /dev/shm entry or fd was added since."""
        deadline = time.monotonic() + timeout
        while True:
            now = Snapshot.take()
            extra_processes = now.processes - self.processes
            extra_shm = now.shm - self.shm
            extra_fds = len(now.fds) - len(self.fds)
            if not extra_processes and not extra_shm and extra_fds <= 0:
                return
            if time.monotonic() > deadline:
                new = {fd: target for fd, target in now.fds.items() if self.fds.get(fd) != target}
                raise AssertionError(f"leaked: processes {sorted(extra_processes)}, /dev/shm {sorted(extra_shm)}, "
                                     f"fds {extra_fds} (new since: {new})")
            time.sleep(0.05)
