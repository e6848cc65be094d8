"""Systems of FMUs as one model: several FMUs (and time tables) connected, stepped by a master
algorithm, in the shape of one FMU so that `FMUEnv`, the pool and the tools take either.

``ssp`` reads SSP archives and folders; ``components`` opens each component; ``graph`` checks the
connections (types, units) and orders them; ``loops`` finds the loops of direct feedthrough,
where each is read from the previous step, and guards them; ``units`` converts along them;
``table`` reads and interpolates time tables; ``description`` is the system as declared
(`SystemDescription`); ``master`` steps it (`SystemInstance`); ``saved_state`` is its state as a
value. This layer builds on `modelicagym.fmu` and knows nothing of reinforcement learning.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping, Sequence
from typing import Any

from modelicagym.errors import ConfigError
from modelicagym.fmu.description import FMUDescription, open_fmu
from modelicagym.system.description import MASTERS, SystemDescription, open_system
from modelicagym.system.master import SystemInstance, new_instance
from modelicagym.system.saved_state import SystemState
from modelicagym.system.ssp import is_ssp

__all__ = ["MASTERS", "SystemDescription", "SystemInstance", "SystemState", "is_system", "new_instance",
           "open_model", "open_system"]


def is_system(fmu: Any = None, fmus: Mapping[str, Any] | None = None) -> bool:
    """Whether a config's ``fmu`` / ``fmus`` describe a system (components to connect, or an SSP
    archive or folder) rather than one FMU."""
    if fmus is not None or isinstance(fmu, SystemDescription):
        return True
    return isinstance(fmu, (str, os.PathLike)) and is_ssp(fmu)


def open_model(fmu: Any = None, *, fmus: Mapping[str, Any] | None = None, connections: Sequence[Any] = (),
               loop_breaks: Sequence[Any] = (), validate: bool = True,
               used: Collection[str] | None = None) -> FMUDescription | SystemDescription:
    """What a config names, opened: a system (`open_system`) or one FMU (`open_fmu`, which takes no
    ``loop_breaks``)."""
    if isinstance(fmu, SystemDescription):
        return fmu
    if is_system(fmu, fmus) or connections:
        return open_system(fmu, fmus=fmus, connections=connections, loop_breaks=loop_breaks, validate=validate)
    if loop_breaks:
        raise ConfigError("'loop_breaks' is a system's option (give 'fmus' and 'connections', or an SSP system), "
                          "not one FMU's")
    return open_fmu(fmu, validate=validate, used=used)
