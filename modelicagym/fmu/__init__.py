"""The FMI runtime: everything that touches an FMU, nothing about reinforcement learning.

``open_fmu`` reads what an FMU declares (`FMUDescription`); `FMUInstance` runs one instance of it.
"""

from modelicagym.fmu.description import FMUDescription, open_fmu
from modelicagym.fmu.errors import (
    ErrorLoopError,
    FMUCallError,
    FMUError,
    FMUNotFoundError,
    FMUValidationError,
    InvalidFMUError,
    LoadTrialError,
    PlatformNotSupportedError,
    StateMismatchError,
    UnsupportedFeatureError,
    VariableError,
)
from modelicagym.fmu.instance import FMUInstance
from modelicagym.fmu.variables import Variable

__all__ = [
    "ErrorLoopError",
    "FMUCallError",
    "FMUDescription",
    "FMUError",
    "FMUInstance",
    "FMUNotFoundError",
    "FMUValidationError",
    "InvalidFMUError",
    "LoadTrialError",
    "PlatformNotSupportedError",
    "StateMismatchError",
    "UnsupportedFeatureError",
    "Variable",
    "VariableError",
    "open_fmu",
]
