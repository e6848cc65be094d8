"""Creating a party's envs, refusing early when they would not fit in memory.

A pool of a million envs used to build for minutes, then swap or be killed, with no word. Each
party (a worker, or the calling process) creates its envs here instead: from the `FIRST_MEASURE`-th
env on, at doubling counts and then every `MEASURE_EVERY` envs, it measures what an env took (the
growth of the process's resident memory per env created) and projects what the envs still to come
need. If
that is more than the party's share of the memory the machine has available, it stops at once with
`PoolMemoryError`, naming the counts and sizes, instead of driving the machine into swap.

The measure is Linux's (``/proc``); elsewhere envs are created unchecked.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Sequence

import gymnasium as gym

from modelicagym.vector.errors import PoolMemoryError

__all__ = [
    "FIRST_MEASURE", "MEASURE_EVERY", "EnvCreator", "available_memory", "close_envs", "create_envs", "resident_memory",
]

logger = logging.getLogger(__name__)

#: envs created before the measure starts (the first ones also load libraries: they would count high)
FIRST_MEASURE = 4
#: the most envs created between two projections
MEASURE_EVERY = 256
#: seconds between two progress lines while a party creates many envs
PROGRESS_EVERY = 10.0


def resident_memory() -> int | None:
    """This process's resident memory in bytes, or ``None`` where ``/proc`` cannot tell."""
    try:
        with open("/proc/self/statm", "rb") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def available_memory() -> int | None:
    """The memory the machine can give without swapping (``MemAvailable``) in bytes, or ``None``."""
    try:
        with open("/proc/meminfo", "rb") as meminfo:
            for line in meminfo:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def close_envs(envs: Sequence[gym.Env]) -> None:
    """Close every env, logging (not raising) what a close raises."""
    for env in envs:
        try:
            env.close()
        except Exception:
            logger.exception("error while closing an env")


def create_envs(
    env_fns: Sequence[Callable[[], gym.Env]], first: int, where: str, share: float = 1.0
) -> list[gym.Env]:
    """Call every fn of ``env_fns`` (envs ``first``, ``first + 1``, ... of the pool) in this process:
    ``EnvCreator(first, where, share).create(env_fns)``."""
    return EnvCreator(first, where, share).create(env_fns)


class EnvCreator:
    """Creates a party's envs, measuring their memory as it goes (see the module docstring).

    Args:
        first: the pool's index of the first env, for messages.
        where: who creates them, for messages ("worker 2", "the calling process").
        share: the fraction of the machine's available memory these envs may take (parties that
            create envs at the same time share it in proportion to their envs).
    """

    def __init__(self, first: int, where: str, share: float = 1.0) -> None:
        self.first, self.where, self.share = first, where, share
        #: envs created so far: after a failure, the offset of the env whose fn failed
        self.created = 0

    def create(self, env_fns: Sequence[Callable[[], gym.Env]]) -> list[gym.Env]:
        """One env per fn; on any failure the envs created are closed and the error raised.

        Raises:
            PoolMemoryError: the envs still to create would not fit in this party's share.
        """
        envs: list[gym.Env] = []
        watch = _MemoryWatch(len(env_fns), self.first, self.where, self.share)
        try:
            for fn in env_fns:
                envs.append(fn())
                self.created = len(envs)
                watch.created(len(envs))
        except BaseException:
            close_envs(envs)
            raise
        return envs


class _MemoryWatch:
    """Projects, as envs are created, whether the rest will fit (see the module docstring)."""

    def __init__(self, total: int, first: int, where: str, share: float) -> None:
        self.total, self.first, self.where, self.share = total, first, where, share
        self._next = FIRST_MEASURE
        self._baseline: tuple[int, int] | None = None
        self._started = self._reported = time.monotonic()
        self._enabled = total > FIRST_MEASURE and resident_memory() is not None

    def created(self, count: int) -> None:
        """Account the ``count``-th env created; raise `PoolMemoryError` if the rest will not fit."""
        if not self._enabled or count < self._next:
            return
        self._next = min(2 * count, count + MEASURE_EVERY)
        resident = resident_memory()
        if self._baseline is None:  # the first envs paid for loading libraries: measure from here
            self._baseline = (count, resident)
            return
        per_env = max(resident - self._baseline[1], 0) / (count - self._baseline[0])
        needed = per_env * (self.total - count)
        available = available_memory()
        if available is not None and needed > self.share * available:
            raise PoolMemoryError(
                f"{self.where} created {count} of its {self.total} envs (from env {self.first} on): each took "
                f"~{per_env / 1024:.0f} KiB, so the other {self.total - count} need ~{_size(needed)}, more than its "
                f"share ({self.share:.0%}) of the {_size(available)} the machine has available; make a pool of "
                f"fewer envs (or give the machine more memory)"
            )
        now = time.monotonic()
        if now - self._reported >= PROGRESS_EVERY:
            self._reported = now
            logger.info("%s: created %d of %d envs in %.0f s (~%.0f KiB each)", self.where, count, self.total,
                        now - self._started, per_env / 1024)


def _size(nbytes: float) -> str:
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"
