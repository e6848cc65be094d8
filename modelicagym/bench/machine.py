"""What the machine charges for a wake-up, reported with every benchmark's conditions.

A pool whose parties sleep between batches pays two wake-ups a batch, and their price is the
machine's: on a KVM guest whose idle cores halt, a wake-up goes through the hypervisor. Measured on
this project's 2-core VM: a round trip between two sleeping processes on two cores took 15-35 µs
with the guest's halt polling off (``guest_halt_poll_ns=0``, as it came), 5 µs with it on
(``200000``); two processes on one core, 4 µs. The default pool avoids sleeping where it can (its
workers poll when they fit the cores, light envs are consolidated), so its figures hardly moved
with halt polling on; a layout whose workers sleep every batch did: 8 light envs in two workers
(``adapt_layout=False``) ran at 0.74x one env with it off, 1.04x with it on. Only the machine's
administrator can change it (as root: ``echo 200000 > /sys/module/haltpoll/parameters/
guest_halt_poll_ns``), so the benchmarks say both, and a figure is read against them.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

__all__ = ["HALT_POLL_NS", "halt_poll_ns", "wake_conditions", "wake_round_trip_us"]

logger = logging.getLogger(__name__)

#: the KVM guest's halt polling limit (nanoseconds an idle core polls before it halts; 0: off)
HALT_POLL_NS = Path("/sys/module/haltpoll/parameters/guest_halt_poll_ns")
#: round trips measured; their median is reported (~5-40 ms in all)
ROUNDS = 1000


def halt_poll_ns(path: Path = HALT_POLL_NS) -> int | None:
    """The KVM guest halt polling limit in nanoseconds (0: off), or ``None`` where the machine has
    none (bare metal, other hypervisors, no ``cpuidle-haltpoll``)."""
    try:
        return int(path.read_text())
    except (OSError, ValueError):
        return None


def wake_round_trip_us() -> float | None:
    """Median microseconds of a round trip between two processes on two cores that sleep between
    posts (``mg_wake_round_trip_ns``, `modelicagym.bench.native`); ``None`` without the library or
    with one usable core."""
    from modelicagym.bench.native import bench_library
    from modelicagym.errors import NativeBuildError

    try:
        nanoseconds = bench_library().mg_wake_round_trip_ns(ROUNDS)
    except NativeBuildError as error:
        logger.info("no wake-up measurement: %s", error)
        return None
    return None if nanoseconds < 0 else nanoseconds / 1e3


def wake_conditions() -> tuple[str, dict[str, Any]]:
    """The wake-up part of a benchmark's conditions: a line, and the same for its JSON."""
    round_trip, halt_poll = wake_round_trip_us(), halt_poll_ns()
    line = "wake-up round trip between two sleeping processes: " + (
        "not measured" if round_trip is None else f"{round_trip:.1f} µs")
    if halt_poll is not None:
        line += f"; KVM guest halt polling {'off' if halt_poll == 0 else 'on'} (guest_halt_poll_ns={halt_poll})"
    return line, {"wake_round_trip_us": round_trip, "guest_halt_poll_ns": halt_poll}
