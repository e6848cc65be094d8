"""The machine's load: whether its cores are crowded or idle, read in one place.

The pool adapts to the cores actually free, and reads them from the kernel's own accounts:

- *the CPU pressure* (``/proc/pressure/cpu``, the time some runnable thread waited for a core):
  `MachineWatch` says whether it stayed low for a while; the C waits read the same file, a
  millisecond at a time (:func:`machine_crowded`);
- *the idle cores* (``/proc/stat``): `IdleCores`, averaged since the last look.

Every threshold of these readings, what it decides, and where it was measured (docs/design.md,
"Waiting" and "The adaptive layout", has the figures in context):

``CROWDED_STALL_SHARE`` = 5% of at least a millisecond (C: ``native/csrc/signal.c``)
    a wait sleeps at once, without polling. Measured: 2 light cart-poles beside one busy Python
    process ran at 0.23x one env before the check.
`STALL_SHARE` = 2% for `QUIET_FOR` = 1 s, read every `READ_EVERY` = 0.2 s at most
    a stand-in's workers poll for their next command only on a quiet machine
    (`modelicagym.vector.dispatch.dispatcher.Dispatcher.watch_machine`). Measured: 8 Feedthrough
    FMI 2.0 envs on 2 cores beside a busy process, 2.2x one env with the workers asleep and 0.9x
    polling, as the C check alone let them (its millisecond readings let a poller through).
`TRUST_STALL_SHARE` = 10% for `TRUST_QUIET_FOR` = 0.3 s
    a consolidation policy trusts its parties' stepping times (`modelicagym.vector.layout.policy`).
    Measured: the pool's own hand-overs make ~3% (8 envs of ~1 ms in two workers), a busy process
    beside 30% and more.
`IDLE_CORES_TO_PROBE` = 0.5
    a calling process that steps every env probes its workers again. A rule, not a measurement:
    half a core idle since the last look.

Without PSI the machine is never called quiet (the workers sleep between batches), and the C check
counts the runnable threads of ``/proc/loadavg`` instead.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

from modelicagym.vector.wire.sync import pool_native_library

__all__ = [
    "IDLE_CORES_TO_PROBE",
    "PSI_CPU",
    "QUIET_FOR",
    "READ_EVERY",
    "STALL_SHARE",
    "TRUST_QUIET_FOR",
    "TRUST_STALL_SHARE",
    "IdleCores",
    "MachineWatch",
    "machine_crowded",
]

#: seconds between two readings of the CPU pressure, at least
READ_EVERY = 0.2
#: seconds the pressure must have stayed low before the machine counts as quiet
QUIET_FOR = 1.0
#: share of the time some thread may wait for a core on a quiet machine
STALL_SHARE = 0.02
#: seconds of a quiet machine after which a consolidation policy trusts its parties' stepping times
#: (their wall times: on a crowded machine two workers may share a core and each seem to take twice
#: its time), and the share of the time some thread may wait for a core on such a machine
TRUST_QUIET_FOR = 0.3
TRUST_STALL_SHARE = 0.1
#: idle cores (averaged since the last look) that make a probe of the workers worth it
IDLE_CORES_TO_PROBE = 0.5

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


class IdleCores:
    """Idle cores of the machine since the last call, averaged (``/proc/stat``; all of them where it
    cannot be read, so that the policy still probes, as its back-off allows)."""

    def __init__(self, cores: int) -> None:
        self._cores = cores
        self._machine_cores = os.cpu_count() or cores
        self._last = self._read()

    def __call__(self) -> float:
        now = self._read()
        last, self._last = self._last, now
        if now is None or last is None or now[1] <= last[1]:
            return float(self._cores)
        return self._machine_cores * (now[0] - last[0]) / (now[1] - last[1])

    def _read(self) -> tuple[int, int] | None:
        """(idle, total) jiffies of all CPUs."""
        try:
            with open("/proc/stat", "rb") as handle:
                fields = handle.readline().split()[1:]
        except OSError:
            return None
        values = [int(f) for f in fields]
        return values[3] + values[4], sum(values[:8])


def machine_crowded() -> bool:
    """Whether this process's waits now sleep at once because runnable threads outnumber the
    cores (``mg_machine_crowded``; ``False`` without the native library)."""
    library = pool_native_library()
    return library is not None and bool(library.mg_machine_crowded())
