"""What the benchmarks report of the machine's wake-ups: the measured round trip and the KVM guest's
halt polling setting. Only what holds on any machine is asserted, never a duration's size."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from modelicagym.bench.machine import halt_poll_ns, wake_conditions, wake_round_trip_us

two_cores = pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="the round trip runs on two cores")


def _children() -> set[int]:
    path = Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children")
    return set(map(int, path.read_text().split())) if path.exists() else set()


@two_cores
def test_the_round_trip_is_measured_and_leaves_the_process_as_it_was() -> None:
    affinity, children = os.sched_getaffinity(0), _children()
    round_trip = wake_round_trip_us()
    assert round_trip is not None and round_trip > 0
    assert os.sched_getaffinity(0) == affinity  # it held this process on one core only meanwhile
    assert _children() == children  # its child was reaped


def test_the_halt_polling_setting_is_read_where_there_is_one(tmp_path: Path) -> None:
    setting = tmp_path / "guest_halt_poll_ns"
    setting.write_text("0\n")
    assert halt_poll_ns(setting) == 0
    setting.write_text("200000\n")
    assert halt_poll_ns(setting) == 200000
    assert halt_poll_ns(tmp_path / "absent") is None
    setting.write_text("garbage")
    assert halt_poll_ns(setting) is None


@two_cores
def test_the_conditions_say_both_in_a_line_and_in_json() -> None:
    line, data = wake_conditions()
    assert line.startswith("wake-up round trip between two sleeping processes: ")
    assert f"{data['wake_round_trip_us']:.1f} µs" in line
    if data["guest_halt_poll_ns"] is not None:
        assert f"guest_halt_poll_ns={data['guest_halt_poll_ns']}" in line
