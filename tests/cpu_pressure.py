"""The CPU pressure as the machine's probe gives it (``/proc/pressure/cpu``'s "some" total) and a
clock, both moved by a test."""

from __future__ import annotations


class Machine:
    """A CPU pressure and a clock, both moved by the test."""

    def __init__(self) -> None:
        self.now = 100.0
        self.stall_us = 5_000_000

    def stall(self) -> int:
        """Microseconds some thread waited for a core, in all (as `machine_stall_us` says it)."""
        return self.stall_us

    def run(self, seconds: float, stall_share: float) -> None:
        """Let ``seconds`` pass in which some thread waited for a core ``stall_share`` of the time."""
        self.now += seconds
        self.stall_us += round(seconds * stall_share * 1e6)
