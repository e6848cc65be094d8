"""A system's state as a value: every component's (an FMU's `FMUState`, a table's clock), so a
system saved in one process goes on bit for bit in another loading it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from modelicagym.fmu.errors import StateMismatchError


@dataclass(frozen=True)
class SystemState:
    """The state of system ``system``: ``components[name]`` is that component's saved state."""

    system: str
    components: dict[str, Any]
    time: float
    steps: int
    origin: float
    dt: float

    def check_fits(self, system: str, components: list[str]) -> None:
        """Refuse (`StateMismatchError`) a state of another system or of other components."""
        if self.system != system or list(self.components) != components:
            raise StateMismatchError(f"{system}: a saved state of {self.system} (components "
                                     f"{', '.join(self.components)}) does not fit this system (components "
                                     f"{', '.join(components)})")
