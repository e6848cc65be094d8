"""The machine watch: an isolated pool's workers poll only once the CPU pressure stayed low."""

from __future__ import annotations

import time
from pathlib import Path

from cpu_pressure import Machine

from modelicagym.vector.layout.machine_load import QUIET_FOR, READ_EVERY, STALL_SHARE, MachineWatch, machine_stall_us

PSI = Path("/proc/pressure/cpu")


def watch_until(watch: MachineWatch, machine: Machine, seconds: float, stall_share: float) -> list[bool]:
    """What ``watch.quiet()`` says after each reading interval of ``seconds``."""
    said = []
    for _ in range(round(seconds / READ_EVERY)):
        machine.run(READ_EVERY, stall_share)
        said.append(watch.quiet())
    return said


def test_the_machine_is_quiet_once_the_pressure_stayed_low_for_a_while() -> None:
    machine = Machine()
    watch = MachineWatch(machine.stall, clock=lambda: machine.now)
    assert not watch.quiet()  # nothing measured yet
    said = watch_until(watch, machine, QUIET_FOR + 2 * READ_EVERY, stall_share=0.0)
    assert not said[0] and said[-1]  # quiet only after QUIET_FOR seconds of low pressure


def test_one_crowded_reading_ends_the_quiet_and_it_takes_a_while_to_come_back() -> None:
    machine = Machine()
    watch = MachineWatch(machine.stall, clock=lambda: machine.now)
    assert watch_until(watch, machine, QUIET_FOR + 2 * READ_EVERY, stall_share=0.0)[-1]
    assert watch_until(watch, machine, READ_EVERY, stall_share=10 * STALL_SHARE) == [False]  # a busy process
    assert not any(watch_until(watch, machine, QUIET_FOR - 2 * READ_EVERY, stall_share=0.0))
    assert watch_until(watch, machine, 3 * READ_EVERY, stall_share=0.0)[-1]


def test_a_pressure_just_under_the_share_still_counts_as_quiet() -> None:
    machine = Machine()
    watch = MachineWatch(machine.stall, clock=lambda: machine.now)
    assert watch_until(watch, machine, QUIET_FOR + 2 * READ_EVERY, stall_share=STALL_SHARE / 2)[-1]


def test_where_the_pressure_cannot_be_read_the_machine_is_never_quiet() -> None:
    machine = Machine()
    watch = MachineWatch(lambda: None, clock=lambda: machine.now)
    assert not any(watch_until(watch, machine, 2 * QUIET_FOR, stall_share=0.0))


def test_readings_are_rate_limited() -> None:
    """Called after every step, the watch reads the file at most every READ_EVERY seconds: a
    crowded stretch shorter than that, between two calls, shows only at the next reading."""
    machine = Machine()
    watch = MachineWatch(machine.stall, clock=lambda: machine.now)
    assert watch_until(watch, machine, QUIET_FOR + 2 * READ_EVERY, stall_share=0.0)[-1]
    machine.run(READ_EVERY / 4, stall_share=1.0)
    assert watch.quiet()  # not read yet
    machine.run(READ_EVERY, stall_share=0.0)
    assert not watch.quiet()  # 0.05 s of stall in 0.25 s: crowded


def test_the_watch_reads_the_machines_one_probe() -> None:
    """`machine_stall_us` is the C probe's reading (the one the waits' crowding check takes): the
    kernel's "some" total where the pressure file can be read, growing, else ``None``."""
    readable = PSI.exists() and PSI.read_text().startswith("some")
    first = machine_stall_us()
    time.sleep(0.01)
    second = machine_stall_us()
    if not readable:
        assert first is None and second is None
        return
    kernel = int(PSI.read_text().splitlines()[0].rsplit("total=", 1)[1])
    assert first is not None and second is not None and first <= second <= kernel
