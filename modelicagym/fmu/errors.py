"""Exceptions raised by the FMI runtime.

Every error names the FMU (and, where it applies, the variable or FMI function) so that a user
who wraps an unknown FMU can tell from the message alone what went wrong and where.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from modelicagym.errors import ModelicaGymError

__all__ = [
    "ErrorLoopError",
    "FMUCallError",
    "FMUError",
    "FMUNotFoundError",
    "FMUValidationError",
    "InvalidFMUError",
    "LoadTrialError",
    "PlatformNotSupportedError",
    "StateMismatchError",
    "UnsupportedFeatureError",
    "VariableError",
]

#: FMI status codes (FMI 1.0's ``fmiStatus``, ``fmi2Status`` and ``fmi3Status`` share their values)
OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
STATUS_NAMES = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")


def status_name(status: int) -> str:
    """The FMI name of a status code (the status types of FMI 1.0, 2.0 and 3.0 share their values)."""
    return STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else f"illegal status {status}"


class FMUError(ModelicaGymError):
    """Base class of every error the FMI runtime raises."""


class FMUNotFoundError(FMUError, FileNotFoundError):
    """The FMU path does not exist."""


class InvalidFMUError(FMUError, ValueError):
    """The file exists but is not a usable FMU (not a zip, no modelDescription.xml, ...)."""


class FMUValidationError(InvalidFMUError):
    """The model description breaks rules of the FMI standard (its schema or fmpy's checks).

    ``summary`` says which rules and variables, ``problems`` are the rules broken, ``variables``
    the variables they concern, and ``skippable`` whether ``validate=False`` loads the FMU anyway
    (it does not when fmpy cannot read the description even without validating it); the message
    is the summary and what to do.
    """

    def __init__(self, summary: str, problems: list[str], variables: list[str], skippable: bool):
        hint = ("pass validate=False to load it anyway" if skippable
                else "fmpy cannot read it without validation either, so validate=False does not help")
        super().__init__(f"{summary} ({hint})")
        self.summary = summary
        self.problems = problems
        self.variables = variables
        self.skippable = skippable


class PlatformNotSupportedError(FMUError):
    """The FMU has no binary for this platform."""


class UnsupportedFeatureError(FMUError):
    """The FMU lacks a capability that was asked for (an interface type, state snapshots, ...)."""


class StateMismatchError(FMUError, ValueError):
    """A saved state given to another FMU (a changed one, another interface type) than the one it came from."""


class LoadTrialError(FMUError):
    """The FMU's binary crashed, ended its process or hung while tried in a child process before
    its first load (`modelicagym.fmu.trial`); it is not loaded, so that it cannot take the caller's
    process down. ``function`` is the FMI call it died in, ``messages`` its last log lines."""

    def __init__(self, message: str, function: str = "", messages: list[str] | tuple[str, ...] = ()):
        super().__init__(message)
        self.function = function
        self.messages = list(messages)

    def __reduce__(self) -> tuple:  # a pool's worker sends it to the parent
        return type(self), (str(self), self.function, self.messages)


class VariableError(FMUError, KeyError):
    """A variable name is unknown, or the variable cannot be used the way it was asked to."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


def unknown_variable(name: str, known: Iterable[str], fmu: str, role: str = "variable") -> VariableError:
    """A `VariableError` for ``name``, suggesting close matches among ``known``."""
    known = list(known)
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
    if not close:
        lowered = {k.lower(): k for k in known}
        close = [lowered[k] for k in difflib.get_close_matches(name.lower(), lowered, n=3, cutoff=0.6)]
    hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return VariableError(f"{fmu}: no {role} named {name!r}.{hint}")


class FMUCallError(FMUError):
    """An FMI function returned Error or Fatal (or Discard where that is not allowed).

    ``messages`` holds what the FMU logged just before, which is usually the real reason.
    """

    def __init__(self, fmu: str, function: str, status: int, messages: list[str] | None = None):
        self.fmu = fmu
        self.function = function
        self.status = status
        self.messages = list(messages or [])
        detail = f": {' | '.join(self.messages)}" if self.messages else ""
        super().__init__(f"{fmu}: {function} returned {status_name(status)}{detail}")


class ErrorLoopError(FMUError):
    """The FMU logged more error messages within one step than it may (`LOG_LIMITS.errors_per_step`,
    ``modelicagym.fmu.logs``) while its calls returned OK: a solver caught in an error loop.

    ``messages`` holds the last of them.
    """

    def __init__(self, fmu: str, count: int, limit: int, messages: list[str] | None = None):
        self.fmu = fmu
        self.count = count
        self.messages = list(messages or [])
        last = f"; the last: {' | '.join(self.messages[-3:])}" if self.messages else ""
        super().__init__(f"{fmu}: logged {count:,} error messages in one step (more than {limit}) "
                         f"while returning OK, an error loop{last}")
