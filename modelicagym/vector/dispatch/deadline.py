"""A timeout turned into a point in time, once: the pool's deadline arithmetic in one place.

Runs in the calling process only (the pool's waits for its parties, ``close``)."""

from __future__ import annotations

import time
from typing import NamedTuple

__all__ = ["Deadline"]


class Deadline(NamedTuple):
    """``timeout`` seconds from when it was made (``time.monotonic()``); ``None``: no deadline."""

    timeout: float | None
    at: float | None

    @classmethod
    def after(cls, timeout: float | None) -> Deadline:
        """The deadline ``timeout`` seconds from now (``None``: never)."""
        return NEVER if timeout is None else cls(timeout, time.monotonic() + timeout)

    def remaining(self) -> float | None:
        """Seconds left (never negative), ``None`` if there is no deadline."""
        return None if self.at is None else max(self.at - time.monotonic(), 0.0)

    def passed(self) -> bool:
        """Whether the deadline has passed (never, without one)."""
        return self.at is not None and time.monotonic() > self.at


#: no deadline (a ``timeout`` of ``None``), made once: the hot path of a step makes none
NEVER = Deadline(None, None)
