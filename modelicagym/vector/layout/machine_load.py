"""The machine's load: whether its cores are crowded or idle, read by one probe, judged in one place.

The pool adapts to the cores actually free, and reads them from the kernel's own accounts:

- *the CPU pressure* (``/proc/pressure/cpu``, the time some runnable thread waited for a core),
  read by one probe a process, in C (``native/csrc/signal.c``; at most once a millisecond): the C
  waits ask it whether the machine is crowded now (:func:`machine_crowded`), and every `MachineWatch`
  reads its readings (:func:`machine_stall_us`) to say whether the pressure stayed low for a while;
- *the idle cores* (``/proc/stat``): `IdleCores`, averaged since the last look;
- *the foreign load* (``/proc/stat`` less the pool's own processes' ``/proc/PID/stat``): `ForeignLoad`,
  the cores of the pool's CPUs that other processes keep busy.

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
`FOREIGN_CORES_TO_SHARE` = 0.5 (`ForeignLoad`, read every `READ_EVERY` seconds at most)
    a layout policy counts the machine as shared: it tries every env in the calling process, and
    keeps heavy batches' parties apart (`modelicagym.vector.layout.policy`). Measured: two pools of
    64 light envs on 2 cores kept a core of each other's busy while the CPU pressure stayed near 5%;
    a quiet machine reads 0.0-0.1.

Without PSI, or without the native library (no C compiler), the machine is never called quiet (the
workers sleep between batches), and the C check counts the runnable threads of ``/proc/loadavg``
instead.

**One probe, three verdicts, and why they are not one.** Every verdict reads the same probe: the
kernel's "some" total, read by the C library once a millisecond at most. What differs is the span
a verdict judges and what a wrong verdict costs, so each has its own share:

- *crowded now* (C, per wait) must answer within a millisecond, without the GIL, since a poll on
  a crowded machine holds a core somebody needs for a scheduler slice. Over a single millisecond
  a few wake-ups' runnable time already shows, so its share is above the sustained ones; a wrong
  "crowded" costs one wait's wake-up and a 2 ms hold.
- *quiet for a second* (`STALL_SHARE`) lets the stand-in's workers poll until it changes, every
  batch; a wrong "quiet" costs a scheduler slice each batch, so it takes the lowest share over the
  longest span. Before this verdict existed, the crowding check alone let pollers through in the
  gaps between its millisecond readings (the 0.9x above).
- *timings to trust* (`TRUST_STALL_SHARE`) asks whether a party's wall time is its own stepping.
  The layouts it compares make pressure of their own (~3% with two workers of 1 ms envs): at 2%
  the policy would never trust them and would try a consolidation that cost such a pool 4-6 s at
  half speed; a neighbour makes 30% and more.

A single share for all three would have to be below 2% and above 3% at once. The 2% of the polling
verdict was measured against the crowding check alone, not against 5% over 0.2 s: that comparison
is still owed.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from modelicagym.vector.wire.sync import pool_native_library

__all__ = [
    "FOREIGN_CORES_TO_SHARE",
    "IDLE_CORES_TO_PROBE",
    "QUIET_FOR",
    "READ_EVERY",
    "STALL_SHARE",
    "TRUST_QUIET_FOR",
    "TRUST_STALL_SHARE",
    "ForeignLoad",
    "IdleCores",
    "MachineWatch",
    "machine_crowded",
    "machine_stall_us",
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
#: cores of the pool's CPUs that other processes keep busy, for the pool to count them as shared
FOREIGN_CORES_TO_SHARE = 0.5


class MachineWatch:
    """Takes the probe's CPU pressure (``stall_us``: microseconds some thread waited for a core, in
    all, or ``None``; `machine_stall_us` unless told) at most every `READ_EVERY` seconds;
    :meth:`quiet` says whether it stayed under ``stall_share`` of the time (`STALL_SHARE` unless
    told) for the last ``quiet_for`` seconds."""

    def __init__(self, stall_us: Callable[[], int | None] | None = None, clock: Callable[[], float] = time.monotonic,
                 quiet_for: float = QUIET_FOR, stall_share: float = STALL_SHARE) -> None:
        self._read_stall_us = machine_stall_us if stall_us is None else stall_us
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


class ForeignLoad:
    """Cores of ``cpus`` (the calling thread's affinity mask unless told) that processes other than
    ``pids()`` (the pool's own: the calling process and its workers) kept busy, averaged since the
    last reading; readings at most every `READ_EVERY` seconds (between them, the last one).

    The CPU pressure cannot see a neighbour that never makes a thread wait: two pools on two cores
    take turns on them, the machine's cores are all busy and the pressure stays near 5%. What each
    pool can see is that half the time spent on its CPUs is not its own. Busy time is read from
    ``/proc/stat``'s lines of those CPUs, the pool's own from ``/proc/PID/stat`` (both in clock
    ticks); time stolen by the hypervisor counts as foreign. ``None`` where either cannot be read."""

    def __init__(self, pids: Callable[[], list[int]], cpus: set[int] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._pids = pids
        self._cpus = {f"cpu{cpu}".encode() for cpu in (os.sched_getaffinity(0) if cpus is None else cpus)}
        self._clock = clock
        self._read_at = clock()
        self._last = self._read()
        self._cores: float | None = None

    def __call__(self) -> float | None:
        now = self._clock()
        if now - self._read_at < READ_EVERY:
            return self._cores
        reading = self._read()
        last, self._last, self._read_at = self._last, reading, now
        if reading is None or last is None or reading[1] <= last[1]:
            self._cores = None
        else:
            busy, total, own = (new - old for new, old in zip(reading, last))
            self._cores = max(0.0, (busy - own) * len(self._cpus) / total)
        return self._cores

    def _read(self) -> tuple[int, int, int] | None:
        """(busy, total) clock ticks of the CPUs, and the pool's processes' CPU time in ticks."""
        busy = total = own = 0
        try:
            with open("/proc/stat", "rb") as handle:
                for line in handle:
                    fields = line.split()
                    if fields and fields[0] in self._cpus:
                        values = [int(f) for f in fields[1:9]]
                        total += sum(values)
                        busy += sum(values) - values[3] - values[4]
            for pid in self._pids():
                with open(f"/proc/{pid}/stat", "rb") as handle:
                    fields = handle.read().rsplit(b")", 1)[1].split()
                own += int(fields[11]) + int(fields[12])
        except (OSError, ValueError, IndexError):
            return None
        return busy, total, own


def machine_crowded() -> bool:
    """Whether this process's waits now sleep at once because runnable threads outnumber the
    cores (``mg_machine_crowded``; ``False`` without the native library)."""
    library = pool_native_library()
    return library is not None and bool(library.mg_machine_crowded())


def machine_stall_us() -> int | None:
    """The CPU pressure as the process's one probe last read it (``mg_machine_stall_us``; read now if
    a reading is due): microseconds some thread waited for a core, in all; ``None`` where it cannot
    be read, or without the native library."""
    library = pool_native_library()
    stall_us = -1 if library is None else library.mg_machine_stall_us()
    return None if stall_us < 0 else stall_us
