"""An instance's time bookkeeping, in a C struct: the Python and the native step path share it.

Simulation time is ``origin + steps * dt`` from an integer step count, so it does not drift. The
struct is ``mg_clock`` of ``modelicagym/native/csrc/step.h`` (`modelicagym.native.abi` mirrors it);
`FMUInstance` reads and writes its fields as ordinary attributes (:class:`OnClock`), and the native
step library writes the same memory, so either path can take any step.
"""

from __future__ import annotations

from typing import Any

from modelicagym.native.abi import StepClock

__all__ = ["OnClock", "StepClock"]


class OnClock:
    """An attribute kept in the owner's ``clock`` (a :class:`StepClock`) under the same name
    without leading underscores; flags read as ``bool``."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.field = name.lstrip("_")
        self.flag = self.field in ("terminated", "broken")

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        value = getattr(instance.clock, self.field)
        return bool(value) if self.flag else value

    def __set__(self, instance: Any, value: Any) -> None:
        setattr(instance.clock, self.field, value)
