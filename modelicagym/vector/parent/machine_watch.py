"""Whether the machine has been quiet: no thread kept waiting for a core, by the kernel's account.

An isolated pool's stand-in worker polls for its next command only on a quiet machine
(`modelicagym.vector.parent.dispatch.Dispatcher.watch_machine`). The C waits' own crowding check
(``native/csrc/signal.h``) looks at a millisecond at a time; between its holds a poller got through
often enough beside a busy process to cost the calling process a scheduler slice each time (on 2
cores, 8 light envs fell from 2.2x to 0.9x one env). This watch decides over seconds instead: the
machine is quiet once the CPU pressure (``/proc/pressure/cpu``, the time some runnable thread waited
for a core) stayed under `STALL_SHARE` of the time for `QUIET_FOR` seconds; one reading above it ends
that at once. Without PSI the machine is never called quiet (the workers sleep between batches).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

__all__ = ["MachineWatch", "QUIET_FOR", "READ_EVERY", "STALL_SHARE"]

#: seconds between two readings of the CPU pressure, at least
READ_EVERY = 0.2
#: seconds the pressure must have stayed low before the machine counts as quiet
QUIET_FOR = 1.0
#: share of the time some thread may wait for a core on a quiet machine
STALL_SHARE = 0.02

PSI_CPU = Path("/proc/pressure/cpu")


class MachineWatch:
    """Reads the CPU pressure at most every `READ_EVERY` seconds; :meth:`quiet` says whether it
    stayed under ``stall_share`` of the time (`STALL_SHARE` unless told) for the last ``quiet_for``
    seconds."""

    def __init__(self, path: Path = PSI_CPU, clock: Callable[[], float] = time.monotonic,
                 quiet_for: float = QUIET_FOR, stall_share: float = STALL_SHARE) -> None:
        self._path = path
        self._quiet_for = quiet_for
        self._stall_share = stall_share
        self._clock = clock
        self._read_at = clock()
        self._stall_us = self._read_stall_us()
        #: since when the pressure has stayed low (``None``: it has not, or cannot be read)
        self._low_since: float | None = None

    def quiet(self) -> bool:
        """Whether the machine has been quiet for ``quiet_for`` seconds (`QUIET_FOR` unless told;
        reads the pressure if due)."""
        now = self._clock()
        if now - self._read_at >= READ_EVERY:
            stall_us = self._read_stall_us()
            if stall_us is None or self._stall_us is None:
                self._low_since = None
            elif (stall_us - self._stall_us) * 1e-6 > self._stall_share * (now - self._read_at):
                self._low_since = None
            elif self._low_since is None:
                self._low_since = self._read_at
            self._read_at, self._stall_us = now, stall_us
        return self._low_since is not None and now - self._low_since >= self._quiet_for

    def _read_stall_us(self) -> int | None:
        """The total microseconds some thread waited for a core ("some ... total="), or ``None``."""
        try:
            line = self._path.read_text().splitlines()[0]
            return int(line.rsplit("total=", 1)[1])
        except (OSError, IndexError, ValueError):
            return None
