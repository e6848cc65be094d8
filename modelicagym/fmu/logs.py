"""FMU log messages into Python `logging`, instead of stdout.

An FMU reports through a logger callback. FMI 2.0's callback is variadic, which ctypes cannot
receive, so fmpy's native proxy formats the message first; that proxy keeps one process-wide
target, so a single callback per FMI version serves every instance here and routes each message
by the environment pointer the instance was created with. FMI 1.0's callback has the same
signature but passes the instance (component) pointer where FMI 2.0 passes the environment: an
FMI 1.0 instance is routed by its component once instantiated (`FMULog.route_component`), and
while it is being instantiated by `FMULog.instantiating`. Each instance keeps its last messages
so that an FMI error can be reported with the FMU's own explanation.

A misbehaving FMU must not drown its user: each instance passes at most `LOG_LIMITS.per_interval`
messages to ``logging`` per `LOG_LIMITS.interval` seconds and counts the rest, saying how many it
held back ("... 9,412 more messages from <instance> in the last 10 s") with the next message after
the interval, or when the instance is freed (`RateLimitedLog`, which the env uses too for its own
messages about truncated episodes). Error-level messages are also counted on the
instance's clock (`FMULog.count_errors_in`): more than `LOG_LIMITS.errors_per_step` within one step
is an error loop, and the step fails although the FMU returned OK (`modelicagym.fmu.instance`, and
``csrc/step.c`` on the native path).
"""

from __future__ import annotations

import itertools
import logging
import math
import time
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from ctypes import c_void_p
from dataclasses import dataclass
from typing import Any

from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from fmpy.fmi3 import fmi3LogMessageCallback

from modelicagym.fmu.errors import ERROR, FATAL, WARNING, status_name

_LEVELS = (logging.DEBUG, logging.WARNING, logging.WARNING, logging.ERROR, logging.CRITICAL, logging.INFO)


@dataclass
class LogLimits:
    """How much of an FMU's log reaches ``logging``, and how many errors a step may log.

    ``per_interval`` messages of an instance are logged per ``interval`` seconds, the rest counted
    (messages below the logger's level count for neither); more than ``errors_per_step``
    error-level messages between the end of one step (or reset) and the end of the next end the
    episode (read when an instance is made).
    """

    per_interval: int = 20
    interval: float = 10.0
    errors_per_step: int = 100


#: the limits in force; change its fields to change them (``errors_per_step`` for instances made afterwards)
LOG_LIMITS = LogLimits()



class RateLimitedLog:
    """A logger that passes at most `LOG_LIMITS.per_interval` messages per `LOG_LIMITS.interval`
    seconds and counts the rest: "... 9,412 more messages from <source> in the last 10 s" comes
    with the first message after the interval, or from `flush`."""

    def __init__(self, logger: logging.Logger, source: str) -> None:
        self.logger = logger
        self.source = source
        self._window_start = -math.inf
        self._logged = 0
        self._held_back = 0
        self._held_back_level = logging.DEBUG

    def log(self, level: int, message: str, *args: Any) -> None:
        """``logger.log(level, message, *args)``, within the limits; a message below the logger's
        level takes no place."""
        if self.logger.isEnabledFor(level) and self._admit(level):
            self.logger.log(level, message, *args)

    def _admit(self, level: int) -> bool:
        now = time.monotonic()
        if now - self._window_start >= LOG_LIMITS.interval:
            self.flush(now)
            self._window_start, self._logged = now, 0
        if self._logged < LOG_LIMITS.per_interval:
            self._logged += 1
            return True
        self._held_back += 1
        self._held_back_level = max(self._held_back_level, level)
        return False

    def flush(self, now: float | None = None) -> None:
        """Say how many messages were held back since the last time, if any."""
        if not self._held_back:
            return
        seconds = (time.monotonic() if now is None else now) - self._window_start
        count = f"{self._held_back:,} more message" + ("s" if self._held_back > 1 else "")
        self.logger.log(self._held_back_level, "... %s from %s in the last %.0f s", count, self.source,
                        max(seconds, 1.0))
        self._held_back, self._held_back_level = 0, logging.DEBUG


_routes: dict[int, FMULog] = {}
_keys = itertools.count(1)
_instantiating: list[FMULog] = []


class FMULog:
    """The log of one FMU instance: forwards to ``logging`` within the limits and remembers recent
    messages."""

    def __init__(self, fmu_name: str, instance_name: str, keep: int = 20):
        self.logger = logging.getLogger(f"modelicagym.fmu.{fmu_name}")
        self.instance_name = instance_name
        self.recent: deque[str] = deque(maxlen=keep)
        self.key = next(_keys)
        self._components: list[int] = []
        self._error_counter: Any = None
        self._limited = RateLimitedLog(self.logger, instance_name)
        _routes[self.key] = self

    @property
    def environment(self) -> c_void_p:
        """The pointer handed to the FMU at instantiation; it comes back with every message."""
        return c_void_p(self.key)

    def count_errors_in(self, counter: Any) -> None:
        """Add one to ``counter.log_errors`` for every error-level message (an instance's clock)."""
        self._error_counter = counter

    def emit(self, status: int, category: str, message: str) -> None:
        level = _LEVELS[status] if 0 <= status < len(_LEVELS) else logging.ERROR
        if status >= WARNING:
            self.recent.append(f"[{status_name(status)}] {message}")
            if status in (ERROR, FATAL) and self._error_counter is not None:
                self._error_counter.log_errors += 1
        self._limited.log(level, "%s [%s] %s", self.instance_name, category, message)

    def flush(self) -> None:
        """Say how many messages were held back, if any."""
        self._limited.flush()

    def take_recent(self) -> list[str]:
        """The messages logged with a non-OK status since the last call, oldest first."""
        messages = list(self.recent)
        self.recent.clear()
        return messages

    def route_component(self, component: int | None) -> None:
        """Route messages whose first argument is ``component`` here (FMI 1.0 loggers get the
        instance pointer); `unroute_components` before the instance is freed."""
        if component:
            _routes[component] = self
            self._components.append(component)

    def unroute_components(self) -> None:
        for component in self._components:
            if _routes.get(component) is self:
                del _routes[component]
        self._components.clear()

    @contextmanager
    def instantiating(self) -> Iterator[None]:
        """Messages of instances not yet routed go here meanwhile (FMI 1.0 instantiation)."""
        _instantiating.append(self)
        try:
            yield
        finally:
            _instantiating.remove(self)

    def close(self) -> None:
        self.flush()
        self.unroute_components()
        _routes.pop(self.key, None)


def _decode(text: bytes | None) -> str:
    return text.decode("utf-8", errors="replace") if text else ""


def _route(environment: int | None, status: int, category: bytes | None, message: bytes | None) -> None:
    log = _routes.get(environment or 0)
    if log is None and _instantiating:
        log = _instantiating[-1]
    if log is None:
        logging.getLogger("modelicagym.fmu").log(
            _LEVELS[status] if 0 <= status < len(_LEVELS) else logging.ERROR, "%s", _decode(message)
        )
    else:
        log.emit(status, _decode(category), _decode(message))


def _fmi2_logger(environment: int | None, instance_name: bytes, status: int, category: bytes, message: bytes) -> None:
    """FMI 2.0's logger (environment first) and FMI 1.0's (component first): same C signature."""
    _route(environment, status, category, message)


def _fmi3_logger(environment: int | None, status: int, category: bytes, message: bytes) -> None:
    _route(environment, status, category, message)


FMI2_LOGGER = fmi2CallbackLoggerTYPE(_fmi2_logger)
#: FMI 1.0's logger type is FMI 2.0's (ctypes caches function types by signature).
FMI1_LOGGER = FMI2_LOGGER
FMI3_LOGGER = fmi3LogMessageCallback(_fmi3_logger)

