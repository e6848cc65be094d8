"""A CPU pressure file (as ``/proc/pressure/cpu``) and a clock, both moved by a test."""

from __future__ import annotations

from pathlib import Path


class Machine:
    """A CPU pressure file and a clock, both moved by the test."""

    def __init__(self, tmp_path: Path) -> None:
        self.path = tmp_path / "cpu"
        self.now = 100.0
        self.stall_us = 5_000_000
        self._write()

    def _write(self) -> None:
        self.path.write_text(f"some avg10=0.00 avg60=0.00 avg300=0.00 total={self.stall_us}\n"
                             "full avg10=0.00 avg60=0.00 avg300=0.00 total=0\n")

    def run(self, seconds: float, stall_share: float) -> None:
        """Let ``seconds`` pass in which some thread waited for a core ``stall_share`` of the time."""
        self.now += seconds
        self.stall_us += round(seconds * stall_share * 1e6)
        self._write()
